"""What `tumblemc study run` says and leaves after each fault, on real media: docs/guide/faults.md.

    sudo python experiments/faults_on_real_media.py TREE WORKDIR [CASE ...]

TREE is a tumblemc checkout (this one, or ``git worktree add ../old 157fb29``); the study
runs there with ``PYTHONPATH=TREE`` (set ``NUMBA_CACHE_DIR`` per tree). WORKDIR gets one
folder per case. The cases (default: all): ``killed`` (a task that ends its worker process,
on a local cluster of one worker), ``sigterm`` (to a running `study run` with one worker
process), ``leftover`` (a shard folder beside a complete file), ``full_at_start``,
``free_space`` (a tmpfs just too small for the final file) and ``readonly`` (a complete
result, the tmpfs remounted read-only) and ``lost_meta`` (``study.json`` deleted, one shard
replaced by another seed's). The tmpfs cases need root (``mount``). Each case
prints the exit status, the end of stderr and what is left in its folder.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: the smoke study made tiny (tests/study/test_engine.py's ``tiny``): 6 runs of 0.2 s and 2 check runs
TINY = """name = "tiny"
shapes = ["cuboid"]
presets = ["aluminum"]
incline_deg = [0, 60]
field_mT = 20
freq_hz = 10
periods = 2
transient_periods = 1
torque = "start"
success_ratio = 0.5
samples = 3
sampler = "mc"
seed = 20190818
ci = "wilson"
ci_level = 0.95
[check]
fraction = 0.02
min_runs = 2
dt_factor = 2
[execution]
batch_size = 4
[uncertain.mu]
dist = "truncnormal"
rel_sd = 0.15
[uncertain.adhesion_C]
dist = "lognormal"
cv = 0.3
[uncertain.offset_deg]
dist = "normal"
sd = 5.0
[uncertain.magnetization]
dist = "normal"
rel_sd = 0.1
"""

#: a task that ends its worker process when it holds run 2 (the hook the killed case installs)
KILL_HOOK = """
import os, sys
try:
    from tumblemc.study.tasks import execute_task
except ImportError:  # 157fb29
    from tumblemc.study.engine import execute_task

def dies_on_run_2(task):
    if 2 in task.run:
        os._exit(1)
    return execute_task(task)

if __name__ == "__main__":
    import tumblemc.study.engine as engine
    from tumblemc.cli import main
    engine.execute_task = dies_on_run_2
    sys.exit(main(["study", "run", sys.argv[1], "--workers", "1", "--batch-size", "1", "--out", sys.argv[2], "--no-progress"]))
"""

#: a lost study.json and, in place of one of the study's shards, the same-numbered shard of another seed
LOST_META = """
import shutil, sys, tomllib
from pathlib import Path
import xarray as xr
import tumblemc.study.engine as engine
from tumblemc.io import open_result

work = Path(sys.argv[1])
def tiny(**ch):
    d = tomllib.loads((work.parent / "tiny.toml").read_text()); d.update(ch); return d

def interrupted(out, **ch):
    real, engine.write_result = engine.write_result, lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt)
    try:
        engine.run_study(tiny(**ch), out=out, progress=False, batch_size=1)
    except KeyboardInterrupt:
        pass
    engine.write_result = real
    return sorted(out.with_name(out.name + ".parts").glob("main-*.npz"))

engine.run_study(tiny(), out=work / "ref.nc", progress=False)
foreign = interrupted(work / "other" / "t.nc", seed=999)[2]
out = work / "t.nc"
interrupted(out)[2].unlink()
parts = out.with_name(out.name + ".parts")
(parts / "study.json").unlink()
shutil.copy(foreign, parts / foreign.name)
try:
    engine.run_study(tiny(), out=out, progress=False)
except ValueError as e:
    print("refused:", e)
    sys.exit(0)
same = all(
    a.drop_attrs().equals(b.drop_attrs()) for a, b in zip(open_result(work / "ref.nc"), open_result(out))
)
print("adopted; the file is", "identical to" if same else "DIFFERENT from", "the uninterrupted run's")
"""


def main() -> None:
    tree, work = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
    cases = sys.argv[3:] or list(CASES)
    work.mkdir(parents=True, exist_ok=True)
    tiny = work / "tiny.toml"
    tiny.write_text(TINY)
    slow = work / "slow.toml"  # 8 runs of 2 s: long enough to signal
    slow.write_text(TINY.replace("freq_hz = 10", "freq_hz = 1").replace("samples = 3", "samples = 4").replace("[0, 60]", "[0, 30]"))
    assert tomllib.loads(slow.read_text())["freq_hz"] == 1
    (work / "killhook.py").write_text(KILL_HOOK)
    (work / "lost_meta.py").write_text(LOST_META)
    env = dict(os.environ, PYTHONPATH=f"{tree}:{work}")
    for case in cases:
        d = work / case
        if d.exists():
            subprocess.run(["umount", str(d)], check=False, capture_output=True)
            shutil.rmtree(d)
        d.mkdir()
        print(f"=== {case}")
        CASES[case](d, tiny, slow, env)


def _cli(env: dict[str, str], *args: object, script: list[str] | None = None) -> subprocess.Popen[str]:
    cmd = script or ["-m", "tumblemc", "study", "run", *map(str, args)]
    return subprocess.Popen([sys.executable, *cmd], env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _show(name: str, proc: subprocess.Popen[str]) -> None:
    _, err = proc.communicate(timeout=900)
    tail = "\n    ".join(err.strip().splitlines()[-6:])
    print(f"--- {name}: exit {proc.returncode}\n    {tail}")


def _left(d: Path) -> None:
    print("    left:", sorted(p.name for p in d.iterdir() if p.name != "fill"))


def _mount(d: Path, size: str) -> None:
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(d)], check=True)


def killed(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    _show("workers die on run 2", _cli(env, script=[str(d.parent / "killhook.py"), str(tiny), str(d / "t.nc")]))
    _left(d)


def sigterm(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    out = d / "s.nc"
    p = _cli(env, slow, "--workers", "1", "--batch-size", "1", "--out", out, "--no-progress")
    deadline = time.time() + 300
    while time.time() < deadline and not list(d.glob("s.nc.parts/main-*.npz")):
        time.sleep(0.1)
    p.send_signal(signal.SIGTERM)
    _show("SIGTERM", p)
    _left(d)
    _show("rerun", _cli(env, slow, "--workers", "0", "--out", out, "--no-progress"))
    _left(d)


def leftover(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    _show("complete run", _cli(env, tiny, "--workers", "0", "--out", d / "t.nc", "--no-progress"))
    (d / "t.nc.parts").mkdir()  # what a kill between the final rename and the shards' removal leaves (its shards aside)
    _show("rerun", _cli(env, tiny, "--workers", "0", "--out", d / "t.nc"))
    _left(d)


def full_at_start(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    _mount(d, "64k")
    fd = os.open(d / "fill", os.O_WRONLY | os.O_CREAT)
    try:
        while True:
            os.write(fd, b"\0" * 4096)
    except OSError:
        pass
    os.close(fd)
    print(f"    free before: {shutil.disk_usage(d).free} B")
    _show("full disk", _cli(env, tiny, "--workers", "0", "--out", d / "t.nc", "--no-progress"))
    print("    left:", {p.name: p.stat().st_size for p in d.iterdir()})
    subprocess.run(["umount", str(d)], check=True)


def free_space(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    _mount(d, "160k")  # room for the shards, not for the final file
    _show("final write", _cli(env, tiny, "--workers", "0", "--out", d / "t.nc", "--no-progress"))
    print(f"    free once the process has ended: {shutil.disk_usage(d).free / 1024:.0f} KiB")
    _left(d)
    subprocess.run(["umount", str(d)], check=True)


def readonly(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    _mount(d, "4m")
    _show("complete run", _cli(env, tiny, "--workers", "0", "--out", d / "t.nc", "--no-progress"))
    subprocess.run(["mount", "-o", "remount,ro", str(d)], check=True)
    _show("rerun, read-only", _cli(env, tiny, "--workers", "0", "--out", d / "t.nc"))
    subprocess.run(["umount", str(d)], check=True)


def lost_meta(d: Path, tiny: Path, slow: Path, env: dict[str, str]) -> None:
    p = _cli(env, script=[str(d.parent / "lost_meta.py"), str(d)])
    out, err = p.communicate(timeout=900)
    print(f"--- lost study.json, a foreign shard: exit {p.returncode}\n    {out.strip()[:400]}{err.strip()[-400:]}")


CASES = {f.__name__: f for f in (killed, sigterm, leftover, full_at_start, free_space, readonly, lost_meta)}

if __name__ == "__main__":
    main()
