"""The ``[check]`` table of a study: the numerical-error (dt) check and its sensitivity twins.

::

    [check]
    fraction = 0.02        # share of the runs re-simulated at dt / dt_factor (at least min_runs)
    min_runs = 20
    dt_factor = 4
    ratio_abs_tol = 0.05   # ratios agree when |fine - coarse| <= abs + rel x |fine|
    ratio_rel_tol = 0.1
    twin_rel = 1e-6        # the sensitivity twins (0: off); docs/studies.md, "The dt check"
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from tumblemc.model.step_check import RATIO_ABS_TOL, RATIO_REL_TOL
from tumblemc.study.checks import check_int, check_no_unknown, check_num, check_table, config_error


@dataclass(frozen=True)
class CheckConfig:
    """Numerical-error check: ``max(min_runs, ceil(fraction * runs))`` runs (at most all) are re-simulated at ``dt / dt_factor``.

    Their ratios agree when ``|fine - coarse| <= ratio_abs_tol + ratio_rel_tol |fine|``.
    Every check run outside that tolerance is simulated twice more at the study dt with the
    magnetisation x (1 +- ``twin_rel``): a run whose ratio they move beyond the tolerance is
    sensitive (no dt resolves its ratio to the tolerance); ``twin_rel = 0`` turns them off.
    """

    fraction: float = 0.02
    min_runs: int = 20
    dt_factor: int = 4
    ratio_abs_tol: float = RATIO_ABS_TOL  # the single-run step check's too (model/step_check.py)
    ratio_rel_tol: float = RATIO_REL_TOL
    twin_rel: float = 1e-6


def parse_check(table: Any) -> CheckConfig:
    """The validated ``[check]`` table (defaults for the keys it leaves out)."""
    ct = check_table("check", table)
    check_no_unknown(ct, ("fraction", "min_runs", "dt_factor", "ratio_abs_tol", "ratio_rel_tol", "twin_rel"), "check")
    twin_rel = check_num("check.twin_rel", ct.get("twin_rel", 1e-6), 0.0, 1e-2)
    if 0.0 < twin_rel < 1e-12:
        raise config_error(
            "check.twin_rel",
            twin_rel,
            "is below 1e-12, where a change of the magnetisation is lost to rounding",
            "0 (off) or a number in [1e-12, 0.01]",
        )
    return CheckConfig(
        fraction=check_num("check.fraction", ct.get("fraction", 0.02), 0.0, 1.0),
        min_runs=check_int("check.min_runs", ct.get("min_runs", 20), 0, 10**9),
        dt_factor=check_int("check.dt_factor", ct.get("dt_factor", 4), 2, 64),
        ratio_abs_tol=check_num("check.ratio_abs_tol", ct.get("ratio_abs_tol", 0.05), 0.0, 1e6),
        ratio_rel_tol=check_num("check.ratio_rel_tol", ct.get("ratio_rel_tol", 0.1), 0.0, 10.0),
        twin_rel=twin_rel,
    )
