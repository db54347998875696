"""Coverage of calibration posteriors on synthetic static-tilt data (tools/calibration_coverage.py, docs/notes/calibration_coverage.md).

:func:`coverage` calibrates ``n_rep`` synthetic data sets drawn at known parameters and
measures what the posterior promises: the share of its central intervals that hold the
truth, the share of its draws that reproduce the lift-off the data show, the share of
held-out points (new fields, new noise) inside its predictive band, and the fit time.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.lab.bounds import check_free
from tumblemc.lab.calibrate import BenchData, calibrate
from tumblemc.lab.mcmc import tilt_balance_batch
from tumblemc.model.params import Params


def coverage(
    n_rep: int = 200,
    truth: dict[str, float] | None = None,
    fields_mT: Sequence[float] = tuple(np.arange(3.0, 15.5, 1.0)),
    noise_deg: float = 0.5,
    level: float = 0.95,
    seed: int = 1,
    progress: bool = False,
    clean: np.ndarray | None = None,
    heldout_mT: Sequence[float] | None = None,
    heldout_clean: np.ndarray | None = None,
    n_posterior: int = 1000,
    shift_mT: float = 0.0,
    prior: dict[str, tuple[float, float]] | None = None,
    **options: Any,
) -> xr.Dataset:
    """Coverage of the posterior's central ``level`` intervals, and its predictions, on synthetic static-tilt data.

    ``n_rep`` data sets: the noise-free tilts ``clean`` at ``fields_mT`` (default: the
    closed-form edge balance at ``truth``; pass ``lab.static_tilt(...)["tilt_deg"]`` for
    simulated data) plus normal noise of ``noise_deg``, each calibrated with the closed-form
    model (``options`` go to :func:`~tumblemc.lab.calibrate.calibrate`, e.g. ``bounds`` or
    ``posterior="laplace"``), free parameters the keys of ``truth`` (default: F_elect
    2.5e-6 N, offset_deg 22). Held-out points: ``heldout_clean`` at ``heldout_mT`` (default:
    the closed form at the midpoints of ``fields_mT``) plus new noise. ``shift_mT`` > 0
    moves each replicate's fields (data and held-out) by a uniform offset in
    ``[0, shift_mT)``, the noise-free tilts then from the closed form: where the data fall
    relative to the lift-off field varies as it would between labs.

    ``prior`` (bounds per free parameter, the keys of ``truth``): each replicate's truth is
    drawn from the calibration's prior on these bounds (uniform in the sampling scale, log10
    for scale parameters), which are also the calibration's ``bounds``, and its noise-free
    tilts come from the closed form. This is simulation-based calibration: averaged over
    truths drawn from the prior, an exact posterior's central intervals hold the truth at
    their level, and the truth's rank among the draws is uniform, whatever the shape of the
    likelihood; at one fixed truth, no interval promises that where the likelihood is a
    cliff (a lift-off between two data fields).

    Returns
    -------
    xarray.Dataset
        Per parameter: ``coverage`` (share of intervals holding the truth), ``mean_width``,
        ``undetermined_share``, ``covered`` (replicate x param); per replicate:
        ``liftoff_share`` (share of draws tilting at every field whose datum exceeds 3 noise
        sd; NaN without such a field), ``heldout_share`` (held-out points inside the 95%
        predictive band), ``predictive_share`` (the data inside theirs), ``fit_s``,
        ``tau_max`` (largest autocorrelation time, steps; NaN for Laplace); ``rank``
        (replicate x param: the share of draws below the truth) and ``truth_value``.
    """
    truth = truth or {"F_elect": 2.5e-6, "offset_deg": 22.0}
    if shift_mT > 0.0 and (clean is not None or heldout_clean is not None):
        raise ValueError(f"shift_mT={shift_mT:g} recomputes the noise-free tilts (allowed: clean=None, heldout_clean=None, or shift_mT=0)")
    if prior is not None and (shift_mT > 0.0 or clean is not None or heldout_clean is not None or "bounds" in options):
        raise ValueError("prior= draws each truth and its tilts (allowed with it: shift_mT=0, clean=None, heldout_clean=None, no bounds)")
    x = np.asarray(fields_mT, float)
    if clean is None:
        clean = tilt_balance_batch(x, "paper", None, **truth)
    xh = np.asarray(heldout_mT, float) if heldout_mT is not None else 0.5 * (x[1:] + x[:-1])
    if heldout_clean is None:
        heldout_clean = tilt_balance_batch(xh, "paper", None, **truth)
    x0, xh0 = x.copy(), xh.copy()
    rng = np.random.default_rng(seed)
    names = list(truth)
    scales = None
    if prior is not None:
        scales, options = check_free(names, prior, "paper"), dict(options, bounds=prior)
    values = np.tile(np.array([truth[nm] for nm in names], float), (n_rep, 1))
    rank = np.zeros((n_rep, len(names)))
    hit = np.zeros((n_rep, len(names)), bool)
    width = np.zeros((n_rep, len(names)))
    undet = np.zeros((n_rep, len(names)), bool)
    per = {k: np.full(n_rep, np.nan) for k in ("liftoff_share", "heldout_share", "predictive_share", "fit_s", "tau_max")}
    q = (1 - level) / 2
    for i in range(n_rep):
        if progress and i % 10 == 0:
            print(f"coverage replicate {i + 1}/{n_rep}", flush=True)
        if shift_mT > 0.0:
            d = rng.uniform(0.0, shift_mT)
            x, xh = x0 + d, xh0 + d
            clean, heldout_clean = tilt_balance_batch(x, "paper", None, **truth), tilt_balance_batch(xh, "paper", None, **truth)
        if scales is not None:
            values[i] = scales.to_values(rng.uniform(0.0, 1.0, len(names)))
            truth = {nm: float(v) for nm, v in zip(names, values[i], strict=True)}
            clean, heldout_clean = tilt_balance_batch(x, "paper", None, **truth), tilt_balance_batch(xh, "paper", None, **truth)
        y = clean + rng.normal(0.0, noise_deg, x.size)
        yh = heldout_clean + rng.normal(0.0, noise_deg, xh.size)
        data = BenchData("static_tilt", "field_mT", "tilt_deg", "degree", x, y, "synthetic")
        t0 = time.perf_counter()
        post = calibrate(data, names, model="closed-form", n_posterior=n_posterior, seed=i, **options)
        per["fit_s"][i] = time.perf_counter() - t0
        for j, nm in enumerate(names):
            a, b = np.quantile(post[nm].values, [q, 1 - q])
            hit[i, j] = a <= truth[nm] <= b
            rank[i, j] = float(np.mean(post[nm].values < truth[nm]))
            width[i, j] = b - a
            undet[i, j] = nm in post.attrs["undetermined"].split(",")
        draws = {nm: post[nm].values[:, None] for nm in names}
        fixed = {k: v for k, v in options.items() if k in Params.field_names()}  # the Params overrides among calibrate's options
        clear = y > 3.0 * noise_deg
        if clear.any():
            pred = tilt_balance_batch(x[clear], "paper", fixed, **draws)
            per["liftoff_share"][i] = float(np.mean(np.all(pred > 0.0, axis=1)))
        new = tilt_balance_batch(xh, "paper", fixed, **draws)
        new = new + post["noise_sd"].values[:, None] * np.random.default_rng(seed + i).standard_normal(new.shape)
        lo, hi = np.quantile(new, [0.025, 0.975], axis=0)
        per["heldout_share"][i] = float(np.mean((yh >= lo) & (yh <= hi)))
        per["predictive_share"][i] = post.attrs["predictive_share"]
        tau = post.attrs["autocorr_steps"]
        per["tau_max"][i] = float(np.max(tau)) if len(tau) else np.nan
    return xr.Dataset(
        {
            "coverage": ("param", hit.mean(0), {"units": "1", "long_name": f"share of {level:.0%} intervals holding the truth"}),
            "undetermined_share": ("param", undet.mean(0), {"units": "1", "long_name": "share of fits flagging it undetermined"}),
            "mean_width": ("param", width.mean(0), {"long_name": "mean interval width (parameter units)"}),
            "covered": (("replicate", "param"), hit),
            "rank": (("replicate", "param"), rank, {"units": "1", "long_name": "share of posterior draws below the truth"}),
            "truth_value": (("replicate", "param"), values),
            **{k: ("replicate", v) for k, v in per.items()},
        },
        coords={"param": names},
        attrs={
            "n_rep": n_rep,
            "noise_deg": noise_deg,
            "level": level,
            "truth": repr(truth) if prior is None else "drawn from the prior",
            "fields_mT": x0.tolist(),
            "shift_mT": shift_mT,
            "prior": repr(prior),
        },
    )


__all__ = ["coverage"]
