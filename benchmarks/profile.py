"""Flat profile of the time loop by function name: ``python benchmarks/profile.py [options] [key=value ...]``.

Where does a step's time go? A worker process compiles, then calls ``tumblemc.simulate``
in a loop; ``perf record`` samples its instruction pointers, and gdb, attached to the same
still-running worker, names every sampled address (Numba registers its compiled functions
with gdb's JIT interface, not with perf, so ``perf report`` alone shows bare addresses).
The table gives each function's share of the samples; a function's inlined callees count
as the function.

Examples::

    python benchmarks/profile.py                                   # cuboid, paper, 45 deg
    python benchmarks/profile.py shape='"curved"' preset='"aluminum"' incline_deg=35 --seconds 30

``key=value`` pairs are keywords of ``tumblemc.simulate`` (values are Python literals;
``duration_s`` defaults to 2). Needs ``perf`` (with ``kernel.perf_event_paranoid`` <= 1, or
root) and ``gdb`` on the PATH. Reported in docs/notes/kernel_experiments.md ("Where the main
job's time goes").
"""

from __future__ import annotations

import argparse
import ast
import collections
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WORKER = r"""
import json, sys, time
import tumblemc
kw = json.loads(sys.argv[1])
seconds = float(sys.argv[2])
short = dict(kw, duration_s=min(0.05, kw.get("duration_s", 2.0)))
tumblemc.simulate(**short)  # compile (or load the cache) before sampling starts
print("ready", flush=True)
sys.stdin.readline()  # the parent starts perf, then says go
t0 = time.perf_counter()
n = 0
while time.perf_counter() - t0 < seconds:
    tumblemc.simulate(**kw)
    n += 1
print(json.dumps({"runs": n, "wall_s": time.perf_counter() - t0}), flush=True)
sys.stdin.readline()  # stay alive (and mapped) until gdb has named the addresses
"""

# a line of gdb's answer to "info symbol ADDR"
_SYM = re.compile(r"^(?P<name>.+?)(?: \+ \d+)? in section |^No symbol matches")


def _short_name(name: str) -> str:
    """The short name of a function: ``tumblemc::kernels::newton::lu_factor``.

    From a mangled or demangled Numba name; other names up to their first ``[`` or ``(``.
    """
    if name.startswith("_ZN"):
        parts = []
        s = name[3:]
        i = 0
        while i < len(s) and s[i].isdigit():
            j = i
            while j < len(s) and s[j].isdigit():
                j += 1
            n = int(s[i:j])
            parts.append(s[j : j + n])
            i = j + n
        return "::".join(parts) if parts else name
    return re.split(r"[\[(]", name, maxsplit=1)[0]


def _parse_kwargs(pairs: list[str]) -> dict[str, object]:
    kw: dict[str, object] = {"shape": "cuboid", "preset": "paper", "incline_deg": 45.0, "duration_s": 2.0}
    for p in pairs:
        if "=" not in p:
            raise SystemExit(f"profile.py: argument {p!r} is not key=value (a keyword of tumblemc.simulate)")
        k, v = p.split("=", 1)
        try:
            kw[k] = ast.literal_eval(v)
        except (ValueError, SyntaxError):
            kw[k] = v  # a bare word: a string
    return kw


def profile(kw: dict[str, object], seconds: float, freq: int, python: str) -> tuple[list[tuple[str, int]], int, dict[str, float]]:
    """Sample a worker running ``simulate(**kw)`` for ``seconds``.

    Returns ``(counts by function, total samples, the worker's runs and wall time)``.
    """
    for tool in ("perf", "gdb"):
        if shutil.which(tool) is None:
            raise SystemExit(f"profile.py needs {tool!r} on the PATH (not found)")
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "perf.data"
        proc = subprocess.Popen(
            [python, "-c", WORKER, json.dumps(kw), str(seconds)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert proc.stdin is not None and proc.stdout is not None
        try:
            if proc.stdout.readline().strip() != "ready":
                raise SystemExit("profile.py: the worker did not start (see its error above)")
            perf = subprocess.Popen(
                ["perf", "record", "-q", "-F", str(freq), "-p", str(proc.pid), "-o", str(data)],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
            )
            time.sleep(0.5)  # perf attached
            proc.stdin.write("go\n")
            proc.stdin.flush()
            stats = json.loads(proc.stdout.readline())
            perf.send_signal(2)  # SIGINT: perf writes its file and exits
            _, err = perf.communicate(timeout=60)
            if perf.returncode not in (0, -2, 130) or not data.exists():
                raise SystemExit(f"profile.py: perf record failed (kernel.perf_event_paranoid?):\n{err}")
            ips = subprocess.run(["perf", "script", "-i", str(data), "-F", "ip"], capture_output=True, text=True, check=True).stdout
            counts = collections.Counter(line.strip() for line in ips.splitlines() if line.strip())
            addrs = list(counts)
            cmds = Path(tmp) / "gdb.cmd"
            cmds.write_text("".join(f"info symbol 0x{a}\n" for a in addrs))
            out = subprocess.run(["gdb", "-p", str(proc.pid), "-batch", "-nx", "-x", str(cmds)], capture_output=True, text=True).stdout
        finally:
            proc.kill()
            proc.wait()
    answers = [m for m in (_SYM.match(line) for line in out.splitlines()) if m is not None]
    if len(answers) != len(addrs):
        raise SystemExit(f"profile.py: gdb named {len(answers)} of {len(addrs)} addresses; cannot pair them")
    by_name: collections.Counter[str] = collections.Counter()
    for a, m in zip(addrs, answers, strict=True):
        by_name["(unnamed: kernel, JIT stubs)" if m.group("name") is None else _short_name(m.group("name"))] += counts[a]
    total = sum(by_name.values())
    return by_name.most_common(), total, stats


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kwargs", nargs="*", help="keywords of tumblemc.simulate as key=value (Python literals)")
    ap.add_argument("--seconds", type=float, default=20.0, help="sampling time, s (default 20)")
    ap.add_argument("--freq", type=int, default=4000, help="samples per second (default 4000)")
    ap.add_argument("--top", type=int, default=20, help="rows of the table (default 20)")
    ap.add_argument("--python", default=sys.executable, help="interpreter of the worker (default: this one)")
    ap.add_argument("--json", type=Path, help="also write the whole table here")
    args = ap.parse_args(argv)
    kw = _parse_kwargs(args.kwargs)
    os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".numba_cache"))
    rows, total, stats = profile(kw, args.seconds, args.freq, args.python)
    if total == 0:
        raise SystemExit("profile.py: no samples")
    print(f"simulate({', '.join(f'{k}={v!r}' for k, v in kw.items())})")
    print(f"{stats['runs']} runs in {stats['wall_s']:.1f} s, {total} samples")
    print("| where | share of samples |\n|---|---|")
    for name, n in rows[: args.top]:
        print(f"| `{name}` | {100.0 * n / total:.1f}% |")
    if args.json:
        args.json.write_text(json.dumps({"kwargs": kw, "samples": total, **stats, "by_function": dict(rows)}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
