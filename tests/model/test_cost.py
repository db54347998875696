"""The wall-time guard of a single run (tumblemc.model.cost): the projection against a fake clock, the refusal against the kernel."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from tumblemc.model import cost
from tumblemc.model.cost import DEAREST_STEP_S, DEFAULT_MAX_WALL_S, MIN_PROBED_STEPS, check_cost, check_max_wall
from tumblemc.model.run import simulate


class FakeRun:
    """A run whose first ``n`` steps cost ``first + n * per_step`` s on a fake clock."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, per_step: float, first: float = 0.3) -> None:
        self.now, self.per_step, self.first, self.calls = 0.0, per_step, first, []
        monkeypatch.setattr(cost, "thread_time", lambda: self.now)

    def __call__(self, n: int) -> None:
        self.calls.append(n)
        self.now += self.first + n * self.per_step


def test_a_dear_run_is_refused_in_one_line_naming_the_projection_and_what_to_do(monkeypatch: pytest.MonkeyPatch) -> None:
    run = FakeRun(monkeypatch, per_step=5e-3)
    with pytest.raises(ValueError) as err:
        check_cost(100_000, 2e-5, run)
    msg = str(err.value)
    assert "\n" not in msg
    # the first call's cost cancels: 5 ms a step; the 128-step probe's 0.94 s plus 10 x 99,872 x 5 ms
    assert "max_wall_s=600: this run could take 4,995 s of wall time" in msg, msg
    assert "(100,000 steps of dt=2e-05 s: its first 128 steps cost 5 ms a step, and later steps up to 10 times more" in msg, msg
    for words in ("shorten duration_s", "coarser dt", "raise max_wall_s"):
        assert words in msg
    # 1024 steps, at twice the last cost of a step, would take the probe past 3 s
    assert run.calls == [2, 16, 128]


def test_a_cheap_run_is_probed_briefly_and_passes(monkeypatch: pytest.MonkeyPatch) -> None:
    run = FakeRun(monkeypatch, per_step=5e-6, first=0.0)
    p = check_cost(40_000, 5e-5, run)
    assert p is not None and run.calls == [2, 16]  # clear of the budget after the first two
    assert p.per_step == pytest.approx(5e-6) and p.seconds == pytest.approx(8e-5 + 10 * 5e-6 * 39_984)


def test_a_dear_first_step_bounds_the_cost_until_a_longer_probe_shows_it(monkeypatch: pytest.MonkeyPatch) -> None:
    # a first step from rest of 0.5 s hides 20 us a step: each short probe's difference is
    # below 5% of its time, so the bound holds until 1024 steps bring it near the truth
    run = FakeRun(monkeypatch, per_step=2e-5, first=0.5)
    p = check_cost(680_000, 2.94e-6, run)
    assert p is not None and run.calls == [2, 16, 128, 1024]
    assert 2e-5 <= p.per_step <= 3e-5 and p.seconds < 250.0  # 10 x 680,000 x 29 us


def test_a_projection_near_the_budget_is_probed_longer(monkeypatch: pytest.MonkeyPatch) -> None:
    run = FakeRun(monkeypatch, per_step=1e-4, first=0.0)
    p = check_cost(500_000, 4e-6, run)  # 10 x 50 s: within 600, not clear of it
    assert p is not None and run.calls == [2, 16, 128, 1024]
    assert p.seconds == pytest.approx(0.1024 + 10 * 1e-4 * (500_000 - 1024))


def test_short_runs_and_no_budget_are_not_probed(monkeypatch: pytest.MonkeyPatch) -> None:
    run = FakeRun(monkeypatch, per_step=1.0)
    assert check_cost(round(DEFAULT_MAX_WALL_S / DEAREST_STEP_S), 5e-5, run) is None
    assert check_cost(MIN_PROBED_STEPS, 5e-5, run, max_wall_s=1e-3) is None
    assert check_cost(10**9, 5e-5, run, max_wall_s=None) is None
    assert check_cost(10**9, 5e-5, run, max_wall_s=math.inf) is None
    assert run.calls == []


def test_the_probe_stays_shorter_than_the_run(monkeypatch: pytest.MonkeyPatch) -> None:
    run = FakeRun(monkeypatch, per_step=1e-6, first=0.0)
    check_cost(MIN_PROBED_STEPS + 1, 5e-5, run, max_wall_s=1e-2)
    assert run.calls == [2, 16, 128]


@pytest.mark.parametrize("bad", [0, -1.0, math.nan, "10", True, [600]])
def test_a_bad_budget_is_refused(bad: Any) -> None:
    with pytest.raises(ValueError, match=r"^max_wall_s=.* is not allowed \(allowed: a number of seconds > 0, inf or None for no limit\)$"):
        check_max_wall(bad)
    with pytest.raises(ValueError, match="max_wall_s="):
        simulate(duration_s=0.01, max_wall_s=bad)


def test_simulate_refuses_a_run_over_a_tiny_budget_at_once() -> None:
    with pytest.raises(ValueError) as err:
        simulate(duration_s=1.0, max_wall_s=1e-3)  # 20,000 steps of the paper's 5e-5 s
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("max_wall_s=0.001: this run could take"), msg
    assert "20,000 steps of dt=5e-05 s" in msg and "steps cost" in msg and "later steps up to 10 times more" in msg


def test_a_probed_run_is_the_same_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    probes: list[int] = []
    project = cost.project
    monkeypatch.setattr(cost, "project", lambda n, run_first, budget: project(n, lambda k: probes.append(k) or run_first(k), budget))
    probed = simulate(duration_s=1.0)  # 20,000 steps: more than the default budget's 12,000 unprobed
    assert probes[:2] == [2, 16]
    free = simulate(duration_s=1.0, max_wall_s=None)
    assert len(probes) <= 4
    for v in free.data_vars:
        assert np.array_equal(probed[v].values, free[v].values, equal_nan=True), v
