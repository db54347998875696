"""The archived step-size ladder of the snap hop (experiments/reproducer_ladder.py).

Moved out of the test tiers with the script: run with ``python -m pytest experiments/tests``.
"""

from __future__ import annotations

import pytest

from tests.tooling import load_tool


def test_reproducer_ladder_small_version() -> None:
    """The small version of experiments/reproducer_ladder.py (docs/notes/energy_ledger.md): two coarse steps."""
    text = load_tool("reproducer_ladder").main(["--dt", "1e-4", "--dt", "5e-5"])
    rows = [r.split("|") for r in text.splitlines()[2:]]
    assert [float(r[1]) for r in rows] == [1e-4, 5e-5]
    assert all(int(r[3]) == 0 for r in rows)  # no failed steps at the coarse steps
    assert all(float(r[2]) > 5.0 for r in rows)  # the snap hop: many times the no-slip gait
    with pytest.raises(SystemExit):
        load_tool("reproducer_ladder").main(["--dt", "3e-5"])  # does not divide 4 s
