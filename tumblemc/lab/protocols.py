"""Bench tests in simulation: static tilt, critical field, step-out, steering.

Each protocol returns an xarray Dataset with units (and a ``protocol`` attribute) that
:mod:`tumblemc.viz.lab` plots; ``tumblemc lab ...`` runs them from the command line.

- :func:`static_tilt`: the equilibrium tilt under a static field for each field strength.
  The model has no damping besides friction and backward Euler's numerical dissipation,
  so a robot that lifts rocks about its equilibrium (it snaps off its face and swings past
  it). The equilibrium is detected where the tilt's second time derivative changes sign
  during a smooth pivot (contact mode "line" on both sides, no impact): there the net
  torque about the pivot vanishes, which is the definition of the equilibrium. The mean
  and spread of those tilts are reported, with the rocking range and the time mean.
  :func:`cuboid_tilt_balance` is the closed form for a cuboid pivoting about an edge
  (``docs/lab.md`` derives it).
- :func:`critical_field`: the smallest field magnitude at which the robot tumbles (or,
  on an incline, climbs: progress ratio at least the threshold), by bisection.
- :func:`step_out`: speed, progress ratio, phase lag and the share of the field's turns
  the magnet follows against frequency, and the step-out frequency (where the magnet
  stops following: it makes less than half the field's turns), refined by bisection;
  :func:`step_out_bisect` finds it by bisection alone.
- :func:`steering`: roll about one world axis, then another; the heading turn is the angle
  between the centre of mass's displacements over the two legs.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence as Seq
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.analysis.bench import (
    LIFT_DEG,
    TILT_SKIP_S,
    cuboid_tilt_balance,
    equilibrium_tilts,
    following_share,
    phase_lag_deg,
    tilt_deg,
)
from tumblemc.model.fields import Rotating, Sequence, Static, compile_program, field_at
from tumblemc.model.frames import plane_frame
from tumblemc.model.outcome import summarize
from tumblemc.model.params import check_number
from tumblemc.model.run import simulate
from tumblemc.version import __version__

#: static_tilt's defaults: dt 1.25e-5 s keeps the rocking robot's energy ledger well inside
#: its tolerance (docs/lab.md: at 5e-5 s the pivot's O(h) chord error makes the normal
#: impulse do positive work, 1-2% of the field's work bound in 0.6 s); 0.6 s holds 30 to 60
#: detected equilibria from 6.5 to 15 mT
TILT_DT = 1.25e-5
TILT_DURATION_S = 0.6
STEP_OUT_SHARE = 0.5  # a robot whose magnet makes less than this share of the field's turns stepped out


def _vec3(v: Seq[float]) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _grid(name: str, values: float | Seq[float], lo: float, hi: float) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    for v in arr:
        check_number(name, v, "", lo, hi)
    if arr.size == 0:
        raise ValueError(f"{name}=[] is empty (allowed: one or more values)")
    return arr


def static_tilt(
    field_mT: float | Seq[float],
    direction: Seq[float] = (0.0, 0.0, -1.0),
    shape: str = "cuboid",
    preset: str = "paper",
    incline_deg: float = 0.0,
    duration_s: float = TILT_DURATION_S,
    dt: float = TILT_DT,
    progress: bool = False,
    workers: int | None = None,
    **overrides: Any,
) -> xr.Dataset:
    """Equilibrium tilt under a static field of each magnitude in ``field_mT`` (world ``direction``).

    Returns
    -------
    xarray.Dataset
        Dimension ``field_mT``: ``tilt_deg`` (mean of the detected equilibria; 0 for a robot
        that stayed flat), ``tilt_spread_deg`` (their standard deviation), ``n_equilibria``,
        ``tilt_time_mean_deg``, ``tilt_min_deg``, ``tilt_max_deg`` (after the first
        ``0.1 s``), ``status`` (the run's outcome status) and, for the paper's cuboid under
        a field along ``-n``, ``tilt_closed_form_deg``. ``workers`` threads (default: the
        CPU count) simulate the fields side by side.
    """
    fields = _grid("field_mT", field_mT, 0.0, 10_000.0)
    keys = ("tilt_deg", "tilt_spread_deg", "n_equilibria", "tilt_time_mean_deg", "tilt_min_deg", "tilt_max_deg", "status")
    down = np.allclose(np.asarray(direction, float) / np.linalg.norm(direction), -plane_frame(incline_deg)["n"])

    def one(mT: float) -> dict[str, float]:
        ds = simulate(shape, preset, incline_deg, duration_s=duration_s, dt=dt, field=Static(float(mT), _vec3(direction)), **overrides)
        th = tilt_deg(ds)
        late = th[ds["time"].values > TILT_SKIP_S]
        eq = equilibrium_tilts(ds)
        flat = late.max(initial=0.0) < LIFT_DEG
        if progress:
            print(f"static tilt: {mT:g} mT done", flush=True)
        return {
            "tilt_deg": 0.0 if flat else (float(eq.mean()) if eq.size else math.nan),
            "tilt_spread_deg": 0.0 if flat else (float(eq.std()) if eq.size else math.nan),
            "n_equilibria": eq.size,
            "tilt_time_mean_deg": float(late.mean()),
            "tilt_min_deg": float(late.min()),
            "tilt_max_deg": float(late.max()),
            "status": int(ds.attrs["status"]),
        }

    # the kernels release the GIL: threads run the fields side by side (results do not depend on it)
    n_threads = max(1, min(len(fields), workers if workers is not None else (os.cpu_count() or 1)))
    with ThreadPoolExecutor(n_threads) as pool:
        rows = list(pool.map(one, [float(b) for b in fields]))
    out = {k: [r[k] for r in rows] for k in keys}
    closed = [cuboid_tilt_balance(float(mT), preset, **overrides) if shape == "cuboid" and down else math.nan for mT in fields]
    units = {"n_equilibria": "1", "status": "1"}
    data = {k: ("field_mT", np.asarray(v), {"units": units.get(k, "degree")}) for k, v in out.items()}
    data["tilt_closed_form_deg"] = ("field_mT", np.asarray(closed), {"units": "degree", "long_name": "closed-form edge balance"})
    res = xr.Dataset(data, coords={"field_mT": ("field_mT", fields, {"units": "mT", "long_name": "static field magnitude"})})
    res["tilt_deg"].attrs["long_name"] = "equilibrium tilt (mean of the detected equilibria)"
    if np.isfinite(closed).any():  # the closed form on a fine grid, for the figure (it jumps at lift-off)
        fine = np.linspace(fields.min(), fields.max(), 400)
        curve = [cuboid_tilt_balance(float(b), preset, **overrides) for b in fine]
        res["tilt_closed_form_curve_deg"] = ("field_fine_mT", np.asarray(curve), {"units": "degree"})
        res = res.assign_coords(field_fine_mT=("field_fine_mT", fine, {"units": "mT"}))
    res.attrs.update(_attrs("static_tilt", shape, preset, incline_deg, dt, duration_s, overrides))
    res.attrs["direction"] = list(map(float, direction))
    return res


def _attrs(protocol: str, shape: str, preset: str, incline_deg: float, dt: float | None, duration_s: float, overrides: dict) -> dict:
    return {
        "protocol": protocol,
        "shape": shape,
        "preset": preset,
        "incline_deg": float(incline_deg),
        "dt": float(dt) if dt else math.nan,
        "duration_s": float(duration_s),
        "overrides": repr(overrides),
        "source": f"tumblemc {__version__}",
        "Conventions": "CF-1.10",
    }


def _climbs(mT: float, freq_hz: float, incline_deg: float, shape: str, preset: str, periods: float, threshold: float, kw: dict) -> bool:
    ds = simulate(shape, preset, incline_deg, mT, freq_hz, periods=periods, **kw)
    return bool(summarize(ds, threshold=threshold)["climbed"])


def critical_field(
    freq_hz: float = 1.0,
    incline_deg: float = 0.0,
    shape: str = "cuboid",
    preset: str = "paper",
    lo_mT: float = 0.5,
    hi_mT: float = 40.0,
    tol_mT: float = 0.1,
    periods: float = 3.0,
    threshold: float = 0.5,
    **overrides: Any,
) -> xr.Dataset:
    """Smallest field (mT) at which the robot tumbles (ratio >= ``threshold``), by bisection in ``[lo, hi]``.

    Assumes one crossing in the bracket (checked at both ends): ``critical_mT`` is NaN
    when the robot already tumbles at ``lo_mT`` or still fails at ``hi_mT`` (the flags say
    which).
    """
    check_number("tol_mT", tol_mT, "", 1e-6, 1e3)
    lo, hi = check_number("lo_mT", lo_mT, "", 0.0, 10_000.0), check_number("hi_mT", hi_mT, "", 0.0, 10_000.0)
    if not hi > lo:
        raise ValueError(f"hi_mT={hi_mT!r} is not above lo_mT={lo_mT!r} (allowed: lo_mT < hi_mT)")
    args = (freq_hz, incline_deg, shape, preset, periods, threshold, overrides)
    tested: list[tuple[float, bool]] = []

    def climbs(mT: float) -> bool:
        ok = _climbs(mT, *args)
        tested.append((mT, ok))
        return ok

    at_lo, at_hi = climbs(lo), climbs(hi)
    crit = math.nan
    if not at_lo and at_hi:
        while hi - lo > tol_mT:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if climbs(mid) else (mid, hi)
        crit = hi
    n = len(tested)
    res = xr.Dataset(
        {
            "critical_mT": ((), crit, {"units": "mT", "long_name": "smallest field that tumbles (upper end of the last bracket)"}),
            "bracket_mT": (("end",), np.array([lo, hi]), {"units": "mT"}),
            "tumbles_at_lo": ((), at_lo),
            "tumbles_at_hi": ((), at_hi),
            "n_runs": ((), n),
            "tested_mT": ("trial", np.array([t for t, _ in tested]), {"units": "mT", "long_name": "fields tried, in order"}),
            "tumbled": ("trial", np.array([ok for _, ok in tested]), {"long_name": "the run at that field tumbled"}),
        },
        coords={"end": ["lo", "hi"], "trial": np.arange(n)},
    )
    res.attrs.update(_attrs("critical_field", shape, preset, incline_deg, overrides.get("dt"), periods / freq_hz, overrides))
    res.attrs.update({"freq_hz": float(freq_hz), "threshold": threshold, "tol_mT": tol_mT})
    return res


def posterior_samples(path: str, n: int, shape: str | None = None, preset: str | None = None) -> list[dict[str, float]]:
    """The first ``n`` draws of a calibration posterior file as Params overrides (one dict per draw).

    ``shape``/``preset``: refuse a file calibrated for another robot (its attributes).
    """
    from tumblemc.model.params import NUMERIC_FIELDS

    with xr.open_dataset(path) as ds:
        for key, want in (("shape", shape), ("preset", preset)):
            have = ds.attrs.get(key)
            if want is not None and have is not None and have != want:
                raise ValueError(f"{path} was calibrated for {key} {have!r}, not {want!r} (allowed: a posterior of the same robot)")
        names = [v for v in ds.data_vars if ds[v].dims == ("sample",) and v in NUMERIC_FIELDS]
        if not names:
            raise ValueError(f"{path}: no posterior draws (allowed: a file written by tumblemc calibrate)")
        k = min(int(n), ds.sizes["sample"])
        return [{v: float(ds[v].values[i]) for v in names} for i in range(k)]


def critical_field_samples(samples: Seq[dict[str, Any]], freq_hz: float = 1.0, incline_deg: float = 0.0, **kwargs: Any) -> xr.Dataset:
    """:func:`critical_field` once per parameter sample (Params overrides, e.g. :func:`posterior_samples`).

    Returns the per-sample critical fields along ``sample`` (with the sampled values) and
    their median and 5-95% range.
    """
    if not samples:
        raise ValueError("samples=[] is empty (allowed: one or more dicts of Params overrides)")
    runs = [critical_field(freq_hz, incline_deg, **kwargs, **smp) for smp in samples]
    crit = np.array([float(r["critical_mT"]) for r in runs])
    res = xr.Dataset(
        {
            "critical_mT": ("sample", crit, {"units": "mT", "long_name": "smallest field that tumbles, per sample"}),
            "n_runs": ("sample", np.array([int(r["n_runs"]) for r in runs])),
            "critical_mT_median": ((), float(np.nanmedian(crit)) if np.isfinite(crit).any() else math.nan, {"units": "mT"}),
            "critical_mT_5_95": (
                ("q",),
                np.nanpercentile(crit, [5, 95]) if np.isfinite(crit).any() else np.full(2, np.nan),
                {"units": "mT"},
            ),
        },
        coords={"sample": np.arange(len(samples)), "q": [5, 95]},
    )
    for name in samples[0]:
        res[name] = ("sample", np.array([smp[name] for smp in samples]))
    res.attrs.update(runs[0].attrs)
    res.attrs["protocol"] = "critical_field_samples"
    return res


def _follows(f: float, field_mT: float, incline_deg: float, shape: str, preset: str, periods: float, kw: dict) -> tuple[bool, xr.Dataset]:
    ds = simulate(shape, preset, incline_deg, field_mT, float(f), periods=periods, **kw)
    return following_share(ds, 1.0 / f) >= STEP_OUT_SHARE, ds


def step_out_bisect(
    lo_hz: float,
    hi_hz: float,
    field_mT: float = 20.0,
    incline_deg: float = 0.0,
    shape: str = "cuboid",
    preset: str = "paper",
    periods: float = 8.0,
    rel_tol: float = 0.005,
    **overrides: Any,
) -> float:
    """Step-out frequency by bisection between ``lo_hz`` (the robot follows) and ``hi_hz`` (it does not).

    NaN when the bracket does not hold a crossing. With several crossings in the bracket
    (the dynamics near step-out can be chaotic) it finds one of them.
    """
    args = (field_mT, incline_deg, shape, preset, periods, overrides)
    if not (_follows(lo_hz, *args)[0] and not _follows(hi_hz, *args)[0]):
        return math.nan
    while hi_hz - lo_hz > rel_tol * hi_hz:
        mid = 0.5 * (lo_hz + hi_hz)
        lo_hz, hi_hz = (mid, hi_hz) if _follows(mid, *args)[0] else (lo_hz, mid)
    return hi_hz


def step_out(
    freq_hz: Seq[float],
    field_mT: float = 20.0,
    incline_deg: float = 0.0,
    shape: str = "cuboid",
    preset: str = "paper",
    periods: float = 8.0,
    threshold: float = 0.5,
    refine: bool = True,
    progress: bool = False,
    **overrides: Any,
) -> xr.Dataset:
    """Speed, progress ratio, phase lag and following share against frequency; the step-out frequency.

    The robot *follows* at a frequency when its magnetisation makes at least
    :data:`STEP_OUT_SHARE` of the field's turns after the first period
    (:func:`following_share`). ``step_out_hz`` is the first swept frequency where it does
    not, after one where it does, refined (``refine``) by bisection between the two to
    0.5%; NaN if the sweep holds no such pair. Near step-out the robot can follow and lose
    turns alternately over a band of frequencies (docs/lab.md: 76-95 Hz for the paper
    robot at 8 mT); ``last_following_hz``, the highest swept frequency it still follows,
    shows that band's upper end.
    """
    freqs = _grid("freq_hz", freq_hz, 0.0, 10_000.0)
    speed, ratio, lag, status, share = [], [], [], [], []
    for k, f in enumerate(freqs):
        if progress:
            print(f"step-out {k + 1}/{len(freqs)}: {f:g} Hz", flush=True)
        ds = simulate(shape, preset, incline_deg, field_mT, float(f), periods=periods, **overrides)
        s = summarize(ds, threshold=threshold)
        speed.append(s["mean_speed"] * 1e3)
        ratio.append(s["progress_ratio"])
        status.append(s["status"])
        lag.append(phase_lag_deg(ds, 1.0 / f))
        share.append(following_share(ds, 1.0 / f))
    follows = np.asarray(share) >= STEP_OUT_SHARE
    first = np.nonzero(~follows[1:] & follows[:-1])[0]
    so = math.nan
    last = float(freqs[np.nonzero(follows)[0][-1]]) if follows.any() else math.nan  # above step_out_hz: an intermittent band
    if first.size:
        lo, hi = float(freqs[first[0]]), float(freqs[first[0] + 1])
        so = step_out_bisect(lo, hi, field_mT, incline_deg, shape, preset, periods, **overrides) if refine else hi
    res = xr.Dataset(
        {
            "speed": ("freq_hz", np.asarray(speed), {"units": "mm s-1", "long_name": "mean uphill speed after one period"}),
            "progress_ratio": ("freq_hz", np.asarray(ratio), {"units": "1"}),
            "phase_lag_deg": ("freq_hz", np.asarray(lag), {"units": "degree", "long_name": "field minus magnetisation angle"}),
            "following_share": ("freq_hz", np.asarray(share), {"units": "1", "long_name": "share of the field's turns the magnet made"}),
            "status": ("freq_hz", np.asarray(status), {"units": "1"}),
            "step_out_hz": ((), so, {"units": "Hz", "long_name": "first frequency the robot stops following (refined)"}),
            "last_following_hz": ((), last, {"units": "Hz", "long_name": "highest swept frequency the robot still follows"}),
        },
        coords={"freq_hz": ("freq_hz", freqs, {"units": "Hz"})},
    )
    res.attrs.update(_attrs("step_out", shape, preset, incline_deg, overrides.get("dt"), periods, overrides))
    res.attrs.update({"field_mT": float(field_mT), "threshold": threshold, "step_out_share": STEP_OUT_SHARE})
    return res


def steering(
    preset: str = "paper",
    shape: str = "cuboid",
    field_mT: float = 20.0,
    freq_hz: float = 1.75,
    leg_s: float = 1.0,
    axes: tuple[Seq[float], Seq[float]] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    **overrides: Any,
) -> xr.Dataset:
    """Roll about ``axes[0]`` for ``leg_s``, then about ``axes[1]``; the heading turn between the legs.

    The first leg is the paper's field (it starts along the uphill direction, along the
    magnetisation of the resting robot); the second continues the field from where the
    first left it, projected onto its rotation plane (:class:`~tumblemc.model.fields.Sequence`).
    With ``freq_hz x leg_s`` a whole number plus 3/4 (the default 1.75 Hz x 1 s), the field
    then points up at the switch, normal to both axes, and turns without a jump; otherwise
    it jumps by ``field_jump_deg`` (a robot on adhering aluminum can snap metres per second
    off such a jump). The heading of a leg is the direction of the centre of mass's
    displacement over it in the world x-y plane (flat ground).
    """
    seq = Sequence(
        (leg_s, Rotating(field_mT, freq_hz, axis=_vec3(axes[0]))),
        (leg_s, Rotating(field_mT, freq_hz, axis=_vec3(axes[1]))),
    )
    ds = simulate(shape, preset, 0.0, field=seq, **overrides)
    t, p = ds["time"].values, ds["position"].values
    i = int(np.searchsorted(t, leg_s - 1e-12))
    prog = compile_program(seq, 0.0)
    b0, b1 = field_at(prog, np.array([leg_s * (1 - 1e-12), leg_s]))
    jump = math.degrees(math.acos(float(np.clip(b0 @ b1 / (np.linalg.norm(b0) * np.linalg.norm(b1)), -1.0, 1.0))))
    d1, d2 = p[i] - p[0], p[-1] - p[i]
    h1, h2 = math.degrees(math.atan2(d1[1], d1[0])), math.degrees(math.atan2(d2[1], d2[0]))
    turn = (h2 - h1 + 180.0) % 360.0 - 180.0
    res = xr.Dataset(
        {
            "heading_deg": ("leg", np.array([h1, h2]), {"units": "degree", "long_name": "direction of the displacement from world x"}),
            "distance": ("leg", np.array([np.hypot(*d1[:2]), np.hypot(*d2[:2])]), {"units": "m"}),
            "turn_deg": ((), turn, {"units": "degree"}),
            "field_jump_deg": ((), jump, {"units": "degree", "long_name": "field direction change at the switch"}),
            "failed_steps": ((), int(ds.attrs["failed_steps"])),
            "status": ((), int(ds.attrs["status"])),
            "max_height": ((), float(p[:, 2].max()), {"units": "m", "long_name": "highest centre of mass"}),
        },
        coords={"leg": [1, 2]},
    )
    res.attrs.update(_attrs("steering", shape, preset, 0.0, overrides.get("dt"), 2 * leg_s, overrides))
    res.attrs["field_program"] = ds.attrs["field_program"]
    res["position"] = (("time", "xyz"), p, {"units": "m"})
    res = res.assign_coords(time=("time", t, {"units": "s"}), xyz=["x", "y", "z"])
    return res


__all__ = [
    "critical_field",
    "critical_field_samples",
    "posterior_samples",
    "cuboid_tilt_balance",
    "following_share",
    "step_out_bisect",
    "equilibrium_tilts",
    "phase_lag_deg",
    "static_tilt",
    "steering",
    "step_out",
    "tilt_deg",
]
