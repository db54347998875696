"""Critical inclines on aluminum and the static limit of line contact (``tumblemc validate``, rows C7c and S4).

The paper has the curved robot failing 30 deg of aluminum where the cuboid and the spiked
robots climb it; under the strip rule of line adhesion it is the best climber of the four,
its threshold on the static limit of line contact with the strip's adhesion, and the
verdict rests on ``line_contact_width`` (docs/notes/curved_strip_width.md). The functions
here measure that: a bisection on the incline and the closed-form static limit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from tumblemc.model.params import PRESETS, get_preset
from tumblemc.model.shapes.library import get_shape
from tumblemc.reports.convergence import timed_run

#: the strip widths (m) of the S4 rows: none, half the default, the default (5 um), twice it
S4_WIDTHS = (0.0, 2.5e-6, 5e-6, 10e-6)


def critical_incline(shape: str, lo: float = 20.0, hi: float = 40.0, tol: float = 0.1, **kw: Any) -> tuple[float, float]:
    """The critical incline of a C7 run (aluminum, 20 mT, 1 Hz, 2 periods) by bisection.

    Returns ``(last incline climbed, first incline failed)`` in degrees, ``hi - lo <= tol``
    apart; NaN for the first where even ``lo`` fails, for the second where even ``hi``
    climbs. It assumes that the verdict changes once in ``[lo, hi]`` (the 1-deg scans of
    ``experiments/curved_strip_width.py`` are monotone for all four shapes).
    """
    if not timed_run(shape=shape, preset="aluminum", incline_deg=lo, **kw)[1]["climbed"]:
        return math.nan, lo
    if timed_run(shape=shape, preset="aluminum", incline_deg=hi, **kw)[1]["climbed"]:
        return hi, math.nan
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if timed_run(shape=shape, preset="aluminum", incline_deg=mid, **kw)[1]["climbed"]:
            lo = mid
        else:
            hi = mid
    return lo, hi


def line_static_limit_deg(shape: str, preset: str = "aluminum", **overrides: Any) -> float:
    """Steepest incline (deg) on which friction holds ``shape`` resting in line contact (strip rule).

    Force balance along and across the plane, with the line's adhesion ``C w l`` (``l`` the
    shape's thickness along body x, the length of its contact line) pressing it on as the
    electrostatic force does: ``m g sin(theta) = mu (m g cos(theta) + F_elect + C w l)``
    (MODEL.md, "Forces"). With ``w = 0``, ``atan(mu)`` for F_elect = 0.
    """
    p = get_preset(preset).replace(**overrides) if overrides else get_preset(preset)
    length = float(np.ptp(get_shape(shape).pieces[0].support_points[:, 0]))
    weight = p.mass * p.g
    press = p.F_elect + p.adhesion_C * p.line_contact_width * length
    return math.degrees(math.atan(p.mu) + math.asin(p.mu * press / (weight * math.sqrt(1.0 + p.mu * p.mu))))


def _bracket(lo: float, hi: float) -> str:
    return f"{lo:.2f}-{hi:.2f} deg"


def climber_rows(shapes: Sequence[str], quick: bool = False) -> list[tuple[str, ...]]:
    """Claims-table rows of the critical inclines of ``shapes`` on aluminum and the curved robot's against the strip width.

    C7c: the shapes ordered by their critical incline (20 mT, 1 Hz), against the paper's
    verdicts at 30 deg (the curved robot the only one failing). S4: the curved robot's
    critical incline for each width in :data:`S4_WIDTHS`, with the static limit in line
    contact at that width (:func:`line_static_limit_deg`). Each row holds the fields of a
    ``tumblemc.reports.claims.Row`` in order.
    """
    rows: list[tuple[str, ...]] = []
    tol = 0.5 if quick else 0.1
    crit = {k: critical_incline(k, tol=tol) for k in shapes}
    order = sorted(shapes, key=lambda k: -crit[k][0])
    rows.append(
        (
            "C7c",
            "shapes, aluminum, 20 mT, 1 Hz, line_adhesion=strip",
            f"critical incline (last climbed - first failed, bisection to {tol:g} deg), best first",
            "; ".join(f"{k} {_bracket(*crit[k])}" for k in order),
            "curved lowest (fails 30 deg, the others climb it)",
            "pass" if order[-1] == "curved" else "FAIL",
            f"curved: its static limit in line contact with the strip's adhesion is {line_static_limit_deg('curved'):.2f} deg "
            f"({line_static_limit_deg('curved', line_contact_width=0.0):.2f} without); the verdict rests on line_contact_width (S4)",
        )
    )
    for width in (0.0, 5e-6) if quick else S4_WIDTHS:
        lo, hi = (
            crit["curved"]
            if width == PRESETS["aluminum"].line_contact_width
            else critical_incline("curved", tol=tol, line_contact_width=width)
        )
        rows.append(
            (
                "S4",
                f"curved, aluminum, 20 mT, 1 Hz, line_contact_width={width:g} m",
                "critical incline (last climbed - first failed); static limit in line contact",
                f"{_bracket(lo, hi)}; {line_static_limit_deg('curved', line_contact_width=width):.2f} deg",
                "(sensitivity)",
                "report",
            )
        )
    return rows
