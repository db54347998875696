"""Helpers of the tests: a script loaded as a module, one kernel step from a saved start."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT / "tools"
#: where scripts live: the maintained tools, the generators of the saved test data, the archived experiments
SCRIPT_DIRS = (TOOLS, ROOT / "tests" / "data", ROOT / "experiments")


def load_tool(name: str) -> ModuleType:
    """``<name>.py`` of :data:`SCRIPT_DIRS` imported as module ``name`` (registered in ``sys.modules``: dataclasses look it up)."""
    path = next((d / f"{name}.py" for d in SCRIPT_DIRS if (d / f"{name}.py").is_file()), None)
    assert path is not None, f"no script {name}.py in {[str(d) for d in SCRIPT_DIRS]}"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def one_step(saved: Mapping[str, Any], spec: Any, prefix: str = "", h: float | None = None) -> tuple[Any, Any, Any, Any]:
    """One kernel step from a saved start (``tests/data/fast_landings.before_step``'s keys, each with ``prefix``).

    ``spec`` is a prepared run (``tumblemc.model.run.prepare``), whose solver options the step
    uses; ``h`` the step (default ``spec.h``).
    Returns ``((status, failed, t_decided), record row, Start after the step, buffers)``.
    """
    from tumblemc.kernels.stepper import Clock, Model, Start, empty_record, make_buffers, run

    z = saved[f"{prefix}z"]
    buf = make_buffers(z.shape[0])
    buf.z[:] = z
    area, mode = float(saved[f"{prefix}area"]), float(saved[f"{prefix}mode"])
    start = Start(saved[f"{prefix}state"].copy(), float(saved[f"{prefix}t"]), area, mode > 0)
    rec = empty_record(1, 1)
    out = run(Model(spec.prm, spec.geo), spec.solver.as_array(), start, Clock(spec.h if h is None else h, 1, 1), rec, buf)
    return out, rec[1], start, buf
