"""The import-direction check (tools/check_imports.py) passes on tumblemc and can fail."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

from tests.tooling import load_tool

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "tools" / "check_imports.py"


@pytest.fixture(scope="module")
def checker() -> ModuleType:
    return load_tool("check_imports")


def test_tumblemc_imports_point_down_the_layers(checker: ModuleType) -> None:
    violations = checker.check(ROOT / "tumblemc")
    assert violations == [], "\n".join(violations)


def test_every_module_has_a_layer(checker: ModuleType) -> None:
    names = checker.load(ROOT / "tumblemc")
    assert [n for n in names if checker.layer_of(n) is None] == []


def _package(root: Path, files: dict[str, str]) -> Path:
    pkg = root / "tumblemc"
    for rel, text in files.items():
        path = pkg / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    for d in [pkg, *(p for p in pkg.rglob("*") if p.is_dir())]:
        (d / "__init__.py").touch()
    return pkg


# what the layers allow: a private module within its own package, a dunder name, imports
# of the same or a lower layer at module and function level
GOOD = {
    "__init__.py": "__version__ = '0'\nfrom tumblemc.study.engine import run\n",
    "kernels/_jit.py": "jit = None\n",
    "kernels/stepper.py": "from ._jit import jit\nimport numpy as np\nx = 1\n",
    "schema.py": "from tumblemc.kernels import stepper as K\nN = K.x\n",
    "model/run.py": "from tumblemc.kernels.stepper import x\nimport xarray\n",
    "analysis/maps.py": "from tumblemc.schema import N\n",
    "study/engine.py": "def run():\n    from tumblemc.model.run import x\n    from tumblemc.analysis import maps\n",
    "viz/run.py": "import matplotlib\nfrom tumblemc.study.engine import run\n",
    "cli.py": "from tumblemc import __version__\nfrom tumblemc.viz.run import run\n",
}

# one violation of each kind, with the words the report must contain
BAD = {
    "kernels/stepper.py": ("import xarray as xr\n", "kernel tumblemc.kernels.stepper imports xarray"),
    "model/run.py": (
        "def f():\n    from tumblemc.study.engine import run\n",
        "tumblemc.model.run (model layer) imports tumblemc.study.engine (study layer)",
    ),
    "model/version.py": ("from tumblemc import __version__\n", "tumblemc.model.version (model layer) imports tumblemc (cli layer)"),
    "model/frames.py": ("from tumblemc.kernels.stepper import _snap\n", "imports the private name _snap of tumblemc.kernels.stepper"),
    "model/units.py": (
        "from tumblemc.kernels import stepper\ny = stepper._snap\n",
        "uses the private name _snap of tumblemc.kernels.stepper",
    ),
    "model/jit.py": ("from tumblemc.kernels import _jit\n", "imports the private module tumblemc.kernels._jit from outside its package"),
    "analysis/sens.py": ("from tumblemc.model.run import simulate\n", "analysis never runs a simulation"),
    "viz/big.py": ("x = 1\n" * 501, "tumblemc.viz.big has 501 lines"),
    "kernels/long.py": ("x = 1\n" * 501, "tumblemc.kernels.long has 501 lines"),
    "plugins.py": ("\n", "tumblemc.plugins has no layer"),
    "study/figure.py": (
        "def f():\n    import matplotlib.pyplot\n",
        "tumblemc.study.figure imports matplotlib: figures are drawn in tumblemc.viz only",
    ),
}


def test_a_clean_synthetic_package_passes(checker: ModuleType, tmp_path: Path) -> None:
    pkg = _package(tmp_path, GOOD)
    assert checker.check(pkg) == []


@pytest.mark.parametrize("rel", sorted(BAD))
def test_each_kind_of_violation_is_reported(checker: ModuleType, tmp_path: Path, rel: str) -> None:
    text, words = BAD[rel]
    pkg = _package(tmp_path, {**GOOD, rel: text})
    violations = checker.check(pkg)
    assert len(violations) == 1 and words in violations[0], violations
    assert violations[0].startswith(f"tumblemc/{rel}:")


def test_the_script_exits_1_with_one_line_per_violation(tmp_path: Path) -> None:
    pkg = _package(tmp_path, {**GOOD, **{rel: text for rel, (text, _) in BAD.items()}})
    res = subprocess.run([sys.executable, str(SCRIPT), str(pkg)], capture_output=True, text=True)
    assert res.returncode == 1
    assert len(res.stdout.splitlines()) == len(BAD)
    ok = subprocess.run([sys.executable, str(SCRIPT), str(_package(tmp_path / "good", GOOD))], capture_output=True, text=True)
    assert ok.returncode == 0 and ok.stdout == ""


def test_an_import_loop_is_reported_and_a_deferred_import_is_not(checker: ModuleType, tmp_path: Path) -> None:
    a = "from tumblemc.study.b import x\n"
    b_typing = "from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    from tumblemc.study.a import y\nx = 1\n"
    violations = checker.check(_package(tmp_path / "loop", {**GOOD, "study/a.py": a, "study/b.py": b_typing}))
    assert len(violations) == 1 and "import loop among tumblemc.study.a, tumblemc.study.b" in violations[0], violations
    b_deferred = "def f():\n    from tumblemc.study.a import y\n\n\nx = 1\n"
    assert checker.check(_package(tmp_path / "deferred", {**GOOD, "study/a.py": a, "study/b.py": b_deferred})) == []
