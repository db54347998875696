"""Tests of the notebooks in notebooks/.

They run from top to bottom on the shipped data (slow tier) and are committed executed,
from the current sources of tools/make_notebooks.py (fast tier).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.tooling import load_tool

nbformat = pytest.importorskip("nbformat")

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def test_there_are_notebooks() -> None:
    assert [p.name for p in NOTEBOOKS] == [
        "01_quickstart.ipynb",
        "02_explore_results.ipynb",
        "03_sensitivity.ipynb",
        "04_calibrate_and_study.ipynb",
        "05_design.ipynb",
    ]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_committed_executed_from_the_current_sources(path: Path) -> None:
    """The committed outputs (browsable on the repository page) come from tools/make_notebooks.py's sources."""
    mk = load_tool("make_notebooks")
    nb = nbformat.read(path, as_version=4)
    want = mk.build(mk.NOTEBOOKS[path.name])
    assert [c.source for c in nb.cells] == [c.source for c in want.cells], f"{path.name}: regenerate (python tools/make_notebooks.py)"
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1)), f"{path.name}: execute it (python tools/make_notebooks.py)"
    assert not [o for c in code for o in c.outputs if o.output_type == "error"]
    assert any(o.get("data", {}).get("image/png") for c in code for o in c.outputs), f"{path.name}: no figure in its outputs"


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_executes(path: Path) -> None:
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}})
    client.execute()  # raises CellExecutionError with the failing cell's traceback
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors


@pytest.mark.parametrize("name", ["example", "example_critical"])
def test_example_data_comes_from_its_config(name: str) -> None:
    """data/<name>.nc holds the study its config describes now (a config or schema change asks for it to be regenerated: data/README.md)."""
    from tumblemc.io import result_attrs
    from tumblemc.study.config import load_config
    from tumblemc.study.identity import config_hash

    stored = result_attrs(ROOT / "data" / f"{name}.nc")["config_hash"]
    assert stored == config_hash(load_config(ROOT / "studies" / f"{name}.toml")), f"regenerate data/{name}.nc (data/README.md)"
