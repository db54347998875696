"""Line coverage of the Numba kernels, measured with the JIT off.

    NUMBA_DISABLE_JIT=1 python tools/kernel_coverage.py [--duration S] [--json OUT]

Compiled code is invisible to Python's tracing, so the kernels' coverage is measured with
``NUMBA_DISABLE_JIT=1``: the same source runs in the interpreter (float64 throughout, the
same operations in the same order, but Python's own ``math.hypot`` and friends where the
compiled code calls the C library: :mod:`tests.kernels.test_nojit` compares the records). A set of short runs (:data:`CASES`: every shape,
paper and aluminum, flat and 10 Hz, a 3-D offset) are traced, and the
lines executed in each ``tumblemc/kernels/*.py`` are counted against the lines that carry
bytecode. Prints one row per module; ``--json`` writes them, ``--records`` the runs'
records (compared with the compiled runs' by the slow test).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ROOT / "tumblemc" / "kernels"

#: short runs (the duration comes from the command line)
CASES: dict[str, dict[str, Any]] = {
    "cuboid_paper_45": dict(shape="cuboid", preset="paper", incline_deg=45.0),
    "cuboid_aluminum_30": dict(shape="cuboid", preset="aluminum", incline_deg=30.0),
    "cuboid_flat_10Hz": dict(shape="cuboid", preset="paper", incline_deg=0.0, freq_hz=10.0),
    "spiked_aluminum_25": dict(shape="spiked", preset="aluminum", incline_deg=25.0),
    "spiked_ends_paper_45": dict(shape="spiked_ends", preset="paper", incline_deg=45.0),
    "curved_aluminum_35": dict(shape="curved", preset="aluminum", incline_deg=35.0),
    "cuboid_offset_3d": dict(shape="cuboid", preset="paper", incline_deg=15.0, offset_deg=20.0, offset_axis=(0.0, 1.0, 0.0)),
}


def code_lines(path: Path) -> set[int]:
    """Line numbers of ``path`` that carry bytecode (every nested function, class and comprehension)."""

    def walk(co: types.CodeType) -> Iterator[int]:
        for _, _, line in co.co_lines():
            if line is not None:
                yield line
        for c in co.co_consts:
            if isinstance(c, types.CodeType):
                yield from walk(c)

    top = compile(path.read_text(), str(path), "exec")
    # the module body itself (imports, constants) runs at import, before tracing starts
    body = {line for _, _, line in top.co_lines() if line is not None}
    return set(walk(top)) - body


def traced(fn: Any) -> dict[str, set[int]]:
    """Run ``fn()`` and return the lines executed in each kernel file."""
    hit: dict[str, set[int]] = {}
    prefix = str(KERNELS)

    def tracer(frame: types.FrameType, event: str, arg: object) -> Any:
        fname = frame.f_code.co_filename
        if not fname.startswith(prefix):
            return None
        lines = hit.setdefault(fname, set())

        def local(frame: types.FrameType, event: str, arg: object) -> Any:
            if event == "line":
                lines.add(frame.f_lineno)
            return local

        lines.add(frame.f_lineno)
        return local

    sys.settrace(tracer)
    try:
        fn()
    finally:
        sys.settrace(None)
    return hit


def records(duration_s: float) -> dict[str, Any]:
    """Run :data:`CASES` for ``duration_s``; each run's variables (data and coordinates), as ``case/variable``."""
    import tumblemc

    out: dict[str, Any] = {}
    for name, kw in CASES.items():
        ds = tumblemc.simulate(**kw, duration_s=duration_s, record_every=1)
        for v in ds.variables:
            out[f"{name}/{v}"] = ds[v].values
    return out


def coverage(duration_s: float) -> tuple[dict[str, dict[str, float]], dict[str, Any]]:
    """Per kernel module: executed and executable lines, and their ratio; and the runs' :func:`records`."""
    if os.environ.get("NUMBA_DISABLE_JIT") != "1":
        raise SystemExit("run with NUMBA_DISABLE_JIT=1: compiled code is invisible to tracing")
    recs: dict[str, Any] = {}
    hit = traced(lambda: recs.update(records(duration_s)))
    out: dict[str, dict[str, float]] = {}
    for path in sorted(KERNELS.glob("*.py")):
        lines = code_lines(path)
        done = hit.get(str(path), set()) & lines
        out[path.name] = {"executed": len(done), "lines": len(lines), "ratio": len(done) / len(lines) if lines else 1.0}
    return out, recs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=0.02, help="simulated seconds of each run (default 0.02)")
    ap.add_argument("--json", type=Path, help="write the table as JSON")
    ap.add_argument("--records", type=Path, help="write the runs' records (npz, keys case/variable)")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    cov, recs = coverage(a.duration)
    tot_e = sum(int(r["executed"]) for r in cov.values())
    tot_l = sum(int(r["lines"]) for r in cov.values())
    print(f"{'module':<20} {'lines':>6} {'run':>6} {'cover':>6}")
    for name, r in cov.items():
        print(f"{name:<20} {int(r['lines']):>6} {int(r['executed']):>6} {r['ratio']:>6.0%}")
    print(f"{'total':<20} {tot_l:>6} {tot_e:>6} {tot_e / tot_l:>6.0%}")
    if a.json:
        a.json.write_text(json.dumps(cov, indent=1))
    if a.records:
        import numpy as np

        np.savez(a.records, **recs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
