"""The design-search campaign (tools/design_campaign.py) in its small version: every stage runs and writes its table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.tooling import load_tool


@pytest.mark.slow
def test_campaign_quick(tmp_path: Path) -> None:
    dc = load_tool("design_campaign")
    common = ["--out", str(tmp_path), "--quick", "--workers", "2"]
    dc.main(["grid", *common])
    with np.load(tmp_path / "grid.npz") as z:
        assert z["values"].shape == (3, 3, 2, 8) and not np.isnan(z["values"]).any()
    dc.main(["crn", *common])
    dc.main(["emulate", *common, "--seeds", "1", "--strategies", "gp,sobol"])
    dc.main(["synthetic", *common, "--seeds", "1", "--strategies", "sobol"])
    dc.main(["search", *common, "--seeds", "1", "--strategies", "gp"])
    dc.main(["front", *common, "--seeds", "1", "--strategies", "gp"])
    dc.main(["front_emulate", *common, "--seeds", "1"])
    for name in ("crn.md", "emulate.md", "synthetic.md", "search_gp.md", "front_gp.md", "front_emulate.md"):
        text = (tmp_path / name).read_text()
        assert text.count("\n|") >= 2, name  # a header and at least one row
    # the grid resumes from its chunks: a second run simulates nothing and gives the same values
    before = np.load(tmp_path / "grid.npz")["values"]
    dc.main(["grid", *common])
    assert np.array_equal(before, np.load(tmp_path / "grid.npz")["values"], equal_nan=True)
