"""Tests of the jit policy's memory rule (tumblemc/kernels/_jit.py).

The kernels run without Numba's reference counting, except the few that allocate. That is
safe while a kernel compiled without it neither allocates (Numba refuses to compile it) nor
returns an array, and while the allocating kernels free what they allocate.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core.runtime import _nrt_python, rtsys

import tumblemc
from tests.tooling import load_tool
from tumblemc.model.rows import TimeGrid, simulate_rows
from tumblemc.testing import REPRODUCERS

ROOT = Path(__file__).resolve().parents[2]

# a stress run with loose steps, sub-steps and landing guesses (stress run 122), and a 3-D run
# (the energy ledger's reproducer 2b): the paths that reach impact_guess and the fallbacks
HARD = {k: v for k, v in load_tool("fast_landings").RUN_122.items() if k not in ("shape", "duration_s")}
TILTED = {k: v for k, v in dict(REPRODUCERS)["R2b tilt about (1,0,1)"].items() if k != "duration_s"}


def _exercise() -> None:
    """Runs through ``simulate`` and the batch kernel, on the ordinary and the hard paths."""
    tumblemc.simulate(shape="cuboid", duration_s=0.5)
    tumblemc.simulate(shape="curved", preset="aluminum", incline_deg=35.0, duration_s=0.5)
    tumblemc.simulate(shape="cuboid", duration_s=1.0, **HARD)  # type: ignore[arg-type]
    tumblemc.simulate(shape="cuboid", duration_s=0.3, **TILTED)  # type: ignore[arg-type]
    grid = TimeGrid(periods=1.0, dt=5e-5, torque="start", rotation="momentum", transient_periods=0.5, success_ratio=0.5, max_failed_steps=1)
    simulate_rows("cuboid", [HARD, {"preset": "paper", "incline_deg": 45.0, "freq_hz": 2.0}], grid)  # type: ignore[list-item]


def test_kernels_free_every_array_they_allocate() -> None:
    """Every NRT allocation made during runs (simulate and the batch kernel) is freed."""
    _exercise()  # compiled or loaded before counting
    _nrt_python.memsys_enable_stats()
    try:
        before = rtsys.get_allocation_stats()
        _exercise()
        after = rtsys.get_allocation_stats()
    finally:
        _nrt_python.memsys_disable_stats()
    allocs = after.alloc - before.alloc
    assert allocs > 0  # the time loops allocate their scratch: the count sees them
    assert after.free - before.free == allocs
    assert after.mi_free - before.mi_free == after.mi_alloc - before.mi_alloc


CHECK = r"""
import importlib, json, sys
sys.path.insert(0, sys.argv[1])
from numba.core import types
from numba.core.registry import CPUDispatcher
from tests.kernels.test_runtime import _exercise
_exercise()

def has_array(t):
    if isinstance(t, types.Array):
        return True
    return any(has_array(x) for x in getattr(t, "types", ()))

out = {"compiled": [], "unused": [], "bad_return": [], "with_nrt": []}
for mod in ("batch", "contact", "field", "geometry", "guesses", "impacts", "ledger", "lu", "newton", "recording", "residual",
            "runtypes", "step", "stepper", "substep", "support"):
    m = importlib.import_module("tumblemc.kernels." + mod)
    for name, f in vars(m).items():
        if not isinstance(f, CPUDispatcher) or f.py_func.__module__ != m.__name__:
            continue
        key = mod + "." + name
        if f.targetoptions.get("_nrt", True):
            out["with_nrt"].append(key)
        if not f.overloads and f.targetoptions.get("inline") != "always":  # inlined stages compile into their callers
            out["unused"].append(key)
        for ov in f.overloads.values():
            out["compiled"].append(key)
            if not f.targetoptions.get("_nrt", True) and has_array(ov.signature.return_type):
                out["bad_return"].append(key + ": " + str(ov.signature.return_type))
print(json.dumps(out))
"""


@pytest.mark.slow
def test_no_kernel_without_reference_counting_returns_an_array(tmp_path: Path) -> None:
    """Compiled from scratch, no kernel compiled without NRT returns an array.

    A fresh ``NUMBA_CACHE_DIR`` makes every kernel compile in the child process, so each
    dispatcher holds the signatures the runs used. The kernels with NRT on are exactly the
    allocating ones, and the runs reach every kernel.
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.run([sys.executable, "-c", CHECK, str(ROOT)], capture_output=True, text=True, env=env, check=True, cwd=ROOT)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["bad_return"] == []
    assert sorted(out["with_nrt"]) == [
        "batch.run_batch",
        "impacts.impact_guess",
        "impacts.sticking_impact",
        "stepper.make_scratch",
        "stepper.run",
        "stepper.solver_options",
    ]
    assert out["unused"] == []  # a new kernel that the runs above do not reach: extend _exercise
    assert len(set(out["compiled"])) >= 40  # the loop above found the kernels (else the checks pass vacuously)


def test_cache_folder_follows_every_kernel_source(tmp_path: Path) -> None:
    """Numba keys a cached kernel by its own file only: the cache folder is keyed by all of them."""
    import numba

    from tumblemc.kernels import _jit

    src = tmp_path / "kernels"
    src.mkdir()
    (src / "a.py").write_text("x = 1\n")
    (src / "b.py").write_text("y = 2\n")
    d0 = _jit.kernels_digest(src)
    (src / "b.py").write_text("y = 3\n")  # an edit to another file than the caller's
    d1 = _jit.kernels_digest(src)
    (src / "b.py").write_text("y = 2\n")
    assert d1 != d0 and _jit.kernels_digest(src) == d0
    (src / "c.py").write_text("")
    assert _jit.kernels_digest(src) != d0  # a new file counts too
    once = _jit.kernels_cache_dir(str(tmp_path / "cache"), d0)
    assert Path(once).name == "kernels-" + d0
    assert _jit.kernels_cache_dir(once, d0) == once  # worker processes inherit the folder
    # this process (conftest sets NUMBA_CACHE_DIR): Numba writes under the current sources' folder
    here = "kernels-" + _jit.kernels_digest()
    assert Path(numba.config.CACHE_DIR).name == here and Path(os.environ["NUMBA_CACHE_DIR"]).name == here


def test_run_hashes_finds_every_difference() -> None:
    """tools/run_hashes.py's comparison: a changed array, a missing one, a missing case."""
    tool = load_tool("run_hashes")
    a = {"c1": {"x": "00", "y": "11"}, "c2": {"x": "22"}}
    assert tool.compare(a, {"c1": {"x": "00", "y": "11"}, "c2": {"x": "22"}}) == []
    assert tool.compare(a, {"c1": {"x": "00", "y": "12"}, "c2": {"x": "22"}}) == ["c1: y"]
    assert tool.compare(a, {"c1": {"x": "00"}, "c2": {"x": "22"}}) == ["c1: y"]
    assert tool.compare(a, {"c1": {"x": "00", "y": "11"}}) == ["c2: x"]


@pytest.mark.slow
def test_run_hashes_of_one_case_repeat(tmp_path: Path) -> None:
    """tools/run_hashes.py on one short case, twice: the same hashes (the runs are deterministic)."""
    tool = load_tool("run_hashes")
    for name in ("a.json", "b.json"):
        assert tool.main(["--cases", "cuboid_offset_3d", "--out", str(tmp_path / name)]) == 0
    assert tool.main(["--compare", str(tmp_path / "a.json"), str(tmp_path / "b.json")]) == 0
    assert len(json.loads((tmp_path / "a.json").read_text())["cuboid_offset_3d"]) > 20
