"""The curved robot on aluminum: its static limit in line contact and its critical incline (issue 45).

The closed form is checked in the fast tier; the finding (the best climber under the strip
rule, its threshold just below that limit, sliding at 30 deg without the strip) in the slow
tier (docs/notes/curved_strip_width.md).
"""

from __future__ import annotations

import math

import pytest

import tumblemc
from tumblemc.reports.climbers import critical_incline, line_static_limit_deg


def test_static_limit_without_adhesion_is_the_friction_angle() -> None:
    assert line_static_limit_deg("curved", line_contact_width=0.0) == pytest.approx(math.degrees(math.atan(0.54)), abs=1e-12)


def test_static_limit_with_the_strip() -> None:
    p = tumblemc.PRESETS["aluminum"]
    th = math.radians(line_static_limit_deg("curved"))
    lam = p.adhesion_C * p.line_contact_width * 400e-6  # the curved robot is 400 um thick
    assert p.mass * p.g * math.sin(th) == pytest.approx(p.mu * (p.mass * p.g * math.cos(th) + lam), rel=1e-12)
    assert line_static_limit_deg("curved") == pytest.approx(30.463, abs=1e-3)
    assert line_static_limit_deg("spiked") < line_static_limit_deg("curved")  # a 300 um line


@pytest.mark.slow
def test_curved_threshold_sits_just_below_its_static_limit() -> None:
    for width in (0.0, 5e-6):
        lo, hi = critical_incline("curved", lo=25.0, hi=35.0, tol=0.1, line_contact_width=width)
        assert (
            line_static_limit_deg("curved", line_contact_width=width) - 0.3
            < lo
            < hi
            < line_static_limit_deg("curved", line_contact_width=width)
        )
