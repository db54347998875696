"""Bounds of a calibration's free parameters: defaults, sampling scales, and what a posterior says about them.

:func:`default_bounds` gives each free field bounds from its physical range and a sampling
scale (log10 for scale parameters such as ``adhesion_C`` and ``F_elect``, whose plausible
values span decades); :func:`check_free` checks given bounds against the physical range
(:data:`tumblemc.model.params.RANGES`). :func:`bound_messages` words two findings of a
posterior: a bound it presses on (with the ``--bounds`` flag that widens it) and a preset's
value the data rule out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from tumblemc.lab.mcmc import Scales
from tumblemc.model.params import NUMERIC_FIELDS, RANGES, Params, get_preset

#: default bounds (lo, hi, log scale) where the physical range of :data:`RANGES` is too wide
#: to sample: the magnetisation within 90 deg of the length axis, friction 0.01 to 1.5 (linear: a decade or two at most)
PHYSICAL_BOUNDS: dict[str, tuple[float, float, bool]] = {"offset_deg": (-90.0, 90.0, False), "mu": (0.01, 1.5, False)}
SCALE_DECADES = 3.0  # default bounds of a scale parameter: the preset's value x 10^-3 to x 10^3, log scale
PRESS_ZONE = 0.01  # within 1% of a bound in z (the sampling scale) ...
PRESS_SHARE = 0.05  # ... the optimum, or this share of the draws, presses on it


def default_bounds(name: str, preset: str = "paper") -> tuple[float, float, bool]:
    """Default bounds of a free field and whether it is sampled on a log scale: ``(lo, hi, log)``.

    :data:`PHYSICAL_BOUNDS` where it names the field; else a scale parameter (physical range
    from 0 up, spanning decades) gets the preset's value x 10^-3 to x 10^3 on a log scale,
    and a field with a finite physical range that range.
    """
    if name in PHYSICAL_BOUNDS:
        return PHYSICAL_BOUNDS[name]
    r, v = RANGES[name], float(getattr(get_preset(preset), name))
    lo, hi = max(r.lo, r.plausible_lo), min(r.hi, r.plausible_hi)  # plausible values only (RANGES)
    if r.lo == 0.0 and v > 0.0 and hi >= 100.0 * v:
        return max(v * 10.0**-SCALE_DECADES, lo), min(v * 10.0**SCALE_DECADES, hi), True
    if math.isfinite(r.lo) and math.isfinite(r.hi):  # a physically finite range (a plausible one is no scale)
        return lo, hi, False
    raise ValueError(f"{name} = {v:g} in preset {preset!r} sets no scale for default bounds (allowed: give them, --bounds {name}=LO:HI)")


#: posterior draws a calibration may ask for: fewer than 100 leave 2 draws beyond each end of
#: a 95% interval; more than 10^5 add nothing a study can use and cost memory (below)
MIN_DRAWS, MAX_DRAWS = 100, 100_000
#: memory a calibration's draws may take (model values at the data and the grid, a few copies)
MAX_DRAW_BYTES = 2 * 2**30


def check_request(free: Sequence[str], fixed: Mapping[str, Any], preset: str, n_posterior: Any, n_points: int) -> None:
    """Refuse a calibration that cannot run before it costs: bad fixed values, a field both free and fixed, a draw count out of range.

    ``fixed`` holds the ``--set`` values (Params fields are checked by :class:`Params`
    itself; the others go to the bench protocol), ``n_points`` the data and grid points
    each draw is evaluated at.
    """
    params = {k: v for k, v in fixed.items() if k in Params.field_names()}
    get_preset(preset).replace(**params)  # a ValueError naming the field, the value and the range
    both = [nm for nm in free if nm in fixed]
    if both:
        raise ValueError(f"{both[0]} is both free and fixed (--set {both[0]}=...) (allowed: each parameter free or fixed, not both)")
    if isinstance(n_posterior, bool) or not isinstance(n_posterior, (int, np.integer)) or not MIN_DRAWS <= n_posterior <= MAX_DRAWS:
        raise ValueError(f"samples={n_posterior!r} is not allowed (allowed: an integer in [{MIN_DRAWS}, {MAX_DRAWS:,}] posterior draws)")
    need = 4 * 8 * int(n_posterior) * n_points
    if need > MAX_DRAW_BYTES:
        raise ValueError(
            f"samples={n_posterior} draws at {n_points} points need about {need / 2**30:.2g} GiB "
            f"(allowed: at most {MAX_DRAW_BYTES / 2**30:.0f} GiB; fewer draws or data rows)"
        )


def check_free(free: Sequence[str], bounds: dict[str, tuple[float, float]] | None, preset: str) -> Scales:
    """The free fields' bounds (given ones checked against the physical range, defaults elsewhere) and sampling scales.

    A scale parameter given bounds from 0 is sampled on a linear scale (a log scale has no 0).
    """
    if not free:
        raise ValueError("free=() names no parameter (allowed: Params fields such as F_elect,offset_deg)")
    lo, hi, log = [], [], []
    for name in free:
        if name not in NUMERIC_FIELDS:
            raise ValueError(f"free parameter {name!r} is not a numeric Params field (allowed: {', '.join(NUMERIC_FIELDS)})")
        r = RANGES[name]
        if bounds and name in bounds:
            a, b = (float(v) for v in bounds[name])
            if not (math.isfinite(a) and math.isfinite(b)):
                raise ValueError(f"bounds of {name} = ({a:g}, {b:g}) are not finite (allowed: finite bounds in {r.describe_plausible()})")
            if not (r.lo <= a and b <= r.hi):
                raise ValueError(f"bounds of {name} = ({a:g}, {b:g}) leave the physical range (allowed: {r.lo:g} to {r.hi:g} {r.units})")
            if not r.plausible(np.array([a, b])).all():
                raise ValueError(
                    f"bounds of {name} = ({a:g}, {b:g}) leave the plausible range (allowed: {r.describe_plausible()}; {r.why})"
                )
            is_log = default_bounds(name, preset)[2] and a > 0.0  # a scale parameter whose bounds exclude 0
        else:
            a, b, is_log = default_bounds(name, preset)
        if not b > a:
            raise ValueError(f"bounds of {name} = ({a}, {b}) are empty (allowed: lower < upper inside {r.lo}..{r.hi} {r.units})")
        lo.append(a)
        hi.append(b)
        log.append(is_log)
    return Scales(tuple(free), np.asarray(lo), np.asarray(hi), np.asarray(log))


def widen_flag(sc: Scales, j: int, side: int) -> str:
    """The ``--bounds`` flag widening bound ``side`` (0 lower, 1 upper) of free field ``j``: a decade (log), half the width (linear)."""
    nm, r = sc.names[j], RANGES[sc.names[j]]
    lo, hi = float(sc.lo[j]), float(sc.hi[j])
    if sc.log[j]:
        lo, hi = (max(lo / 10.0, r.plausible_lo), hi) if side == 0 else (lo, min(hi * 10.0, r.plausible_hi))
    else:
        w = 0.5 * (hi - lo)
        lo, hi = (max(lo - w, r.lo, r.plausible_lo), hi) if side == 0 else (lo, min(hi + w, r.hi, r.plausible_hi))
    return f"--bounds {nm}={lo:.4g}:{hi:.4g}"


def bound_messages(sc: Scales, z_opt: np.ndarray, z: np.ndarray, values: np.ndarray, preset: str) -> tuple[list[str], list[str]]:
    """Bounds the posterior presses on, and presets' values the data rule out (outside the 99% interval), in words.

    A bound is pressed when, within :data:`PRESS_ZONE` of it in ``z`` (the sampling scale),
    lie the optimum, or :data:`PRESS_SHARE` of the draws, or draws at half the posterior's
    mean density over its central 98% or more (the posterior does not fall off before it).
    """
    press, ruled = [], []
    nominal = get_preset(preset)
    for j, nm in enumerate(sc.names):
        units = RANGES[nm].units
        q01, q99 = np.quantile(z[:, j], [0.01, 0.99]) if len(z) else (0.0, 1.0)
        flat = 0.5 * 0.98 * PRESS_ZONE / max(float(q99 - q01), PRESS_ZONE)  # the zone's share at half the mean density
        for side, near, opt in ((0, z[:, j] < PRESS_ZONE, z_opt[j] < PRESS_ZONE), (1, z[:, j] > 1 - PRESS_ZONE, z_opt[j] > 1 - PRESS_ZONE)):
            share = float(near.mean()) if len(near) else 0.0
            if opt or share >= min(PRESS_SHARE, flat):
                which, b = ("lower", sc.lo[j]) if side == 0 else ("upper", sc.hi[j])
                why = " and ".join(([] if not opt else ["the optimum"]) + ([f"{share:.1%} of the draws"] if share > 0 else []))
                scale = "log" if sc.log[j] else "linear"
                press.append(
                    f"{nm} presses on its {which} bound {b:.4g} {units} ({why} within {PRESS_ZONE:.0%} of it, {scale} scale): "
                    f"the posterior may end there only because the bound does; if the physics allows, widen it: {widen_flag(sc, j, side)}"
                )
        v0 = float(getattr(nominal, nm))
        a, b = np.quantile(values[:, j], [0.005, 0.995])
        if not a <= v0 <= b:
            ruled.append(f"the data rule out the preset's {nm} = {v0:.4g} {units}: the 99% interval is {a:.4g}..{b:.4g}")
    return press, ruled


__all__ = [
    "MAX_DRAWS",
    "MIN_DRAWS",
    "PHYSICAL_BOUNDS",
    "PRESS_SHARE",
    "PRESS_ZONE",
    "SCALE_DECADES",
    "bound_messages",
    "check_free",
    "check_request",
    "default_bounds",
    "widen_flag",
]
