"""Calibration from bench data: fit :class:`~tumblemc.model.params.Params` fields, then a posterior.

Bench data are CSV files with a header naming the test:

- static tilt: ``field_mT,tilt_deg`` (a static field of fixed direction, :func:`tumblemc.lab.static_tilt`);
- speed against frequency: ``freq_hz,speed_mm_s`` (the paper's rotating field, :func:`tumblemc.lab.step_out`).

(``incline_deg,climbed``, the critical incline, is read but not fitted yet: a 0/1 response
needs a likelihood, not least squares.)

**Fit.** Bounded nonlinear least squares (:func:`scipy.optimize.least_squares`, trust
region reflective) on the free fields, each scaled by its bound width. The model can have
steps (the lift-off field moves with the adhesion, and a data point flips from flat to
lifted), which trap a local fit. Where the closed form applies (static tilt of the cuboid
under a field along -z) a global search on it (differential evolution) gives the start,
for either forward model; otherwise the costs of the preset's values and of a seeded Latin
hypercube of ``screen`` points (default 4 per free field) are screened and the fit runs
from the best ``starts`` (2), keeping the lowest cost. The forward model is the simulator itself (``model="simulate"``: any shape, every
physics option) or, for the paper's cuboid under a field along ``-n``, the closed-form
edge balance (``model="closed-form"``, :func:`tumblemc.lab.cuboid_tilt_balance`; it
agrees with the simulator to 0.002 deg, docs/lab.md), which is a thousand times cheaper.

**Posterior.** A Laplace approximation at the optimum: the parameters are normal with
precision ``J^T J / s^2 + P0`` (``J`` the Jacobian of the residuals at the optimum, ``s^2``
the residual variance ``SSR / (n - p)``, ``P0`` the bounds as a weak prior: the precision
of a uniform on them), drawn as a multivariate t with ``n - p`` degrees of freedom (the
noise variance is estimated, not known) and truncated to the bounds by rejection. Chosen by
cost and coverage: it needs one Jacobian beyond the fit (``p + 1`` forward runs), where a
residual bootstrap needs a fit per replicate and MCMC (emcee) thousands of forward runs,
tens of minutes each with the simulator; its coverage is measured by
``tools/calibration_coverage.py`` (docs/calibration.md) on synthetic data. It is only as
good as the linearisation: the Jacobian is taken at two steps (1e-3 and 1e-2 of the bound
width) and, per parameter, the flatter one is used; parameters where they differ by more
than 2x are flagged ``rough`` (the model has a kink or a jump there). The diagnostics also
report the condition number of ``J^T J`` (in bound-width units) and flag the parameters
whose spread the data do not halve (``undetermined``).

The result is an xarray Dataset, one variable per free :class:`Params` field along
``sample`` (the posterior draws, the file a study samples from with
``[uncertain] posterior = "calib.nc"``), plus the data, the fitted curve with a 95% band,
the estimate, its covariance and the diagnostics.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.lab import protocols as lab
from tumblemc.model.params import NUMERIC_FIELDS, RANGES, get_preset
from tumblemc.version import __version__

#: header -> (test, x column, y column, y units)
KINDS: dict[tuple[str, str], tuple[str, str, str, str]] = {
    ("field_mT", "tilt_deg"): ("static_tilt", "field_mT", "tilt_deg", "degree"),
    ("freq_hz", "speed_mm_s"): ("speed", "freq_hz", "speed_mm_s", "mm s-1"),
    ("incline_deg", "climbed"): ("critical_incline", "incline_deg", "climbed", "1"),
}
MODELS = ("auto", "simulate", "closed-form")
N_POSTERIOR = 2000
COARSE_STEP = 1e-2  # the second Jacobian's step, in bound widths (the fit's is 1e-3)
UNDETERMINED_SHARE = 0.5  # the data determine a parameter when they halve the spread of its bounds (sd width/sqrt(12))


@dataclass(frozen=True)
class BenchData:
    """One bench test's data: ``test`` (static_tilt or speed), ``x`` and ``y`` columns."""

    test: str
    x_name: str
    y_name: str
    y_units: str
    x: np.ndarray
    y: np.ndarray
    source: str


def read_bench(path: str | os.PathLike[str]) -> BenchData:
    """Read a bench CSV; raise ValueError naming the file, the line and the problem."""
    with open(path, newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{path}: empty (allowed: a header such as field_mT,tilt_deg and data rows)")
    header = tuple(c.strip() for c in rows[0])
    if header not in KINDS:
        allowed = "; ".join(",".join(k) for k in KINDS)
        raise ValueError(f"{path}: header {','.join(header)!r} is not a bench test (allowed: {allowed})")
    test, xn, yn, yu = KINDS[header]
    vals = []
    for i, r in enumerate(rows[1:], start=2):
        try:
            x, y = (float(v) for v in r)
        except ValueError:
            raise ValueError(f"{path}, line {i}: {','.join(r)!r} is not two numbers") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"{path}, line {i}: {','.join(r)!r} is not finite")
        vals.append((x, y))
    if len(vals) < 2:
        raise ValueError(f"{path}: {len(vals)} data row(s) (allowed: at least 2)")
    arr = np.asarray(vals)
    return BenchData(test, xn, yn, yu, arr[:, 0], arr[:, 1], os.fspath(path))


def write_bench(path: str | os.PathLike[str], x_name: str, y_name: str, x: Sequence[float], y: Sequence[float]) -> None:
    """Write bench data in the format :func:`read_bench` reads."""
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow([x_name, y_name])
        for a, b in zip(x, y, strict=True):
            w.writerow([f"{a:.10g}", f"{b:.10g}"])


def forward_model(
    data: BenchData,
    shape: str = "cuboid",
    preset: str = "paper",
    direction: Sequence[float] = (0.0, 0.0, -1.0),
    model: str = "simulate",
    **fixed: Any,
) -> Callable[[dict[str, Any]], np.ndarray]:
    """The model's prediction of ``data.y`` at ``data.x`` for given free-parameter values."""
    if model not in MODELS:
        raise ValueError(f"model={model!r} is not allowed (allowed: {', '.join(MODELS)})")
    if model == "auto":
        model = "closed-form" if closed_form_applies(data, shape, direction) else "simulate"
    if data.test == "static_tilt":
        if model == "closed-form":
            if not closed_form_applies(data, shape, direction):
                raise ValueError("model='closed-form' is the paper cuboid's edge balance under a field along -z (allowed: shape cuboid)")
            return lambda p: np.array([lab.cuboid_tilt_balance(float(b), preset, **fixed, **p) for b in data.x])
        return lambda p: lab.static_tilt(data.x.tolist(), direction, shape, preset, **fixed, **p)["tilt_deg"].values
    if data.test == "speed":
        if model == "closed-form":
            raise ValueError("model='closed-form' exists only for the static tilt (allowed: simulate)")
        return lambda p: lab.step_out(data.x.tolist(), shape=shape, preset=preset, **fixed, **p)["speed"].values
    raise ValueError(f"{data.source}: the critical-incline test is read but not fitted yet (allowed: static tilt, speed)")


def closed_form_applies(data: BenchData, shape: str, direction: Sequence[float]) -> bool:
    """Whether the cuboid's closed-form edge balance models ``data`` (static tilt, cuboid, field along -z)."""
    d = np.asarray(direction, float)
    return data.test == "static_tilt" and shape == "cuboid" and bool(np.allclose(d / np.linalg.norm(d), (0.0, 0.0, -1.0)))


def _check_free(
    free: Sequence[str], bounds: dict[str, tuple[float, float]] | None, preset: str
) -> tuple[list[str], np.ndarray, np.ndarray]:
    if not free:
        raise ValueError("free=() names no parameter (allowed: Params fields such as F_elect,offset_deg)")
    nominal = get_preset(preset)
    lo, hi = [], []
    for name in free:
        if name not in NUMERIC_FIELDS:
            raise ValueError(f"free parameter {name!r} is not a numeric Params field (allowed: {', '.join(NUMERIC_FIELDS)})")
        if bounds and name in bounds:
            a, b = (float(v) for v in bounds[name])
        else:  # default: 0.25x to 4x the nominal (+-30 deg for angles)
            v = float(getattr(nominal, name))
            a, b = (v - 30.0, v + 30.0) if name == "offset_deg" else ((0.25 * v, 4.0 * v) if v > 0 else (0.0, 1.0))
        r = RANGES[name]
        if bounds and name in bounds and not (r.lo <= a and b <= r.hi):
            raise ValueError(f"bounds of {name} = ({a:g}, {b:g}) leave the physical range (allowed: {r.lo:g} to {r.hi:g} {r.units})")
        a, b = max(a, r.lo), min(b, r.hi)
        if not b > a:
            raise ValueError(f"bounds of {name} = ({a}, {b}) are empty (allowed: lower < upper inside {r.lo}..{r.hi} {r.units})")
        lo.append(a)
        hi.append(b)
    return list(free), np.asarray(lo), np.asarray(hi)


def calibrate(
    data: BenchData | str | os.PathLike[str],
    free: Sequence[str],
    bounds: dict[str, tuple[float, float]] | None = None,
    shape: str = "cuboid",
    preset: str = "paper",
    direction: Sequence[float] = (0.0, 0.0, -1.0),
    model: str = "auto",
    n_posterior: int = N_POSTERIOR,
    seed: int = 0,
    band_draws: int | None = None,
    screen: int | None = None,
    starts: int = 2,
    **fixed: Any,
) -> xr.Dataset:
    """Fit the ``free`` Params fields to bench ``data`` and draw a Laplace posterior.

    Returns
    -------
    xarray.Dataset
        One variable per free field along ``sample`` (the posterior), ``estimate_<name>``,
        ``covariance`` (param x param), ``x``/``y`` (the data), ``fit``, ``band_lo``,
        ``band_hi`` (the fitted curve and its pointwise 95% band: from ``band_draws``
        posterior draws, default 40 with the closed form; linearised, ``J cov J^T``, with the
        simulator, where each draw costs a forward run),
        and attributes: ``rms_residual``, ``condition_number``, ``n_evaluations``,
        ``undetermined`` (free fields the data do not determine), ``test``, ``model``.
    """
    from scipy.optimize import least_squares

    bench = data if isinstance(data, BenchData) else read_bench(data)
    names, lo, hi = _check_free(free, bounds, preset)
    if model not in MODELS:
        raise ValueError(f"model={model!r} is not allowed (allowed: {', '.join(MODELS)})")
    fit_model = ("closed-form" if closed_form_applies(bench, shape, direction) else "simulate") if model == "auto" else model
    f = forward_model(bench, shape, preset, direction, fit_model, **fixed)
    width = hi - lo
    nominal = get_preset(preset)
    z0 = np.clip((np.array([float(getattr(nominal, n)) for n in names]) - lo) / width, 1e-3, 1 - 1e-3)
    count = [0]  # forward-model evaluations of the fit
    search = [0]  # closed-form evaluations of the global search
    p = len(names)

    def resid(z: np.ndarray) -> np.ndarray:
        count[0] += 1
        return f(dict(zip(names, (lo + z * width).tolist(), strict=True))) - bench.y

    # a kink or a step in the model (the lift-off field moves with the parameters, and a data
    # point flips from flat to lifted) traps a local fit. Where the closed form applies, a
    # global search on it (differential evolution, milliseconds per evaluation) gives the
    # start; otherwise the costs of the preset's values and of a seeded Latin hypercube are
    # screened and the fit runs from the best few, keeping the lowest cost
    cands = [z0]
    if closed_form_applies(bench, shape, direction):
        from scipy.optimize import differential_evolution

        g = forward_model(bench, shape, preset, direction, "closed-form", **fixed)

        def cost_cf(z: np.ndarray) -> float:
            search[0] += 1
            return float(np.sum((g(dict(zip(names, (lo + z * width).tolist(), strict=True))) - bench.y) ** 2))

        de = differential_evolution(cost_cf, [(0.0, 1.0)] * p, seed=seed, tol=1e-6, polish=False, maxiter=300)
        cands = [np.clip(de.x, 1e-6, 1 - 1e-6)]
    else:
        from scipy.stats import qmc

        n_screen = screen if screen is not None else 4 * p
        if n_screen > 0:
            cands += list(qmc.LatinHypercube(p, rng=np.random.default_rng(seed)).random(n_screen) * 0.98 + 0.01)
    costs = [float(np.sum(resid(z) ** 2)) for z in cands] if len(cands) > 1 else [0.0]
    best = [cands[i] for i in np.argsort(costs)[: max(1, starts)]]
    fits = [least_squares(resid, z, bounds=(0.0, 1.0), diff_step=1e-3, x_scale=1.0) for z in best]
    sol = min(fits, key=lambda r: float(r.cost))
    n = len(bench.y)
    dof = max(n - p, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    # precision: the data's J^T J / s^2 (J in bound-width units) plus the bounds as a weak
    # prior (the variance of a uniform on them, 1/12 in these units), so that a direction
    # the data do not determine keeps the spread of its bounds instead of collapsing
    # the forward model can be rough (a slip or a lift-off moves with the parameters): a
    # second Jacobian at ten times the step; per parameter the flatter column is kept, so a
    # kink makes the posterior wider, not narrower, and the two are reported
    jac = np.array(sol.jac, dtype=float)
    coarse = np.empty_like(jac)
    for j in range(p):
        dz = COARSE_STEP if sol.x[j] + COARSE_STEP <= 1.0 else -COARSE_STEP
        z = sol.x.copy()
        z[j] += dz
        coarse[:, j] = (resid(z) - sol.fun) / dz
    norm_f, norm_c = np.linalg.norm(jac, axis=0), np.linalg.norm(coarse, axis=0)
    ratio = norm_f / np.where(norm_c > 0, norm_c, np.nan)
    rough = [nm for nm, r in zip(names, ratio, strict=True) if not 0.5 <= r <= 2.0]
    jac = np.where(norm_c < norm_f, coarse, jac)
    jtj = jac.T @ jac
    cond = float(np.linalg.cond(jtj))
    cov_z = np.linalg.inv(jtj / max(s2, 1e-300) + 12.0 * np.eye(p))
    cov = cov_z * np.outer(width, width)
    est = lo + sol.x * width
    rng = np.random.default_rng(seed)
    draws = np.empty((0, p))
    for _ in range(50):  # truncate to the bounds by rejection
        # multivariate t with n - p degrees of freedom: the posterior of a linear model whose
        # noise variance is estimated from the residuals (normal x inverse chi-square)
        scale = np.sqrt(dof / rng.chisquare(dof, size=4 * n_posterior))[:, None]
        d = est + scale * rng.multivariate_normal(np.zeros(p), cov, size=4 * n_posterior, method="eigh")
        draws = np.vstack([draws, d[np.all((d >= lo) & (d <= hi), axis=1)]])
        if len(draws) >= n_posterior:
            break
    draws = draws[:n_posterior]
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    prior_sd = width / math.sqrt(12.0)
    undetermined = [nm for nm, s, w in zip(names, sd, prior_sd, strict=True) if not s < UNDETERMINED_SHARE * w]
    fit = resid(sol.x) + bench.y
    sim_check = math.nan
    if model == "auto" and fit_model == "closed-form":  # the simulator at the estimate, as a check
        sim = forward_model(bench, shape, preset, direction, "simulate", **fixed)(dict(zip(names, est.tolist(), strict=True)))
        sim_check = float(np.sqrt(np.nanmean((sim - fit) ** 2)))
    if band_draws is None:  # the closed form is cheap enough for draws; the simulator is linearised
        band_draws = 40 if fit_model == "closed-form" else 0
    if band_draws > 0 and len(draws):
        band = np.array([f(dict(zip(names, d.tolist(), strict=True))) for d in draws[:band_draws]])
        band_lo, band_hi = np.percentile(band, 2.5, axis=0), np.percentile(band, 97.5, axis=0)
    else:  # J cov J^T with the t quantile
        from scipy.stats import t as student_t

        half = student_t.ppf(0.975, dof) * np.sqrt(np.einsum("ij,jk,ik->i", jac, cov_z, jac))
        band_lo, band_hi = fit - half, fit + half
    out = xr.Dataset(coords={"sample": np.arange(len(draws)), "param": names, "point": np.arange(n)})
    for j, nm in enumerate(names):
        r = RANGES[nm]
        out[nm] = ("sample", draws[:, j], {"units": r.units, "long_name": f"posterior draw of {r.long_name}"})
        out[f"estimate_{nm}"] = ((), est[j], {"units": r.units, "long_name": f"least-squares estimate of {r.long_name}"})
    out["covariance"] = (("param", "param_2"), cov, {"long_name": "Laplace covariance (parameter units)"})
    out["x"] = ("point", bench.x, {"long_name": bench.x_name})
    out["y"] = ("point", bench.y, {"long_name": bench.y_name, "units": bench.y_units})
    out["fit"] = ("point", fit, {"units": bench.y_units, "long_name": "model at the estimate"})
    out["band_lo"] = ("point", band_lo, {"units": bench.y_units})
    out["band_hi"] = ("point", band_hi, {"units": bench.y_units})
    out.attrs.update(
        {
            "title": f"tumblemc calibration: {bench.test} of the {shape} robot",
            "test": bench.test,
            "model": model,
            "fit_model": fit_model,
            "simulator_check_rms": sim_check,
            "shape": shape,
            "preset": preset,
            "direction": list(map(float, direction)),
            "free": ",".join(names),
            "bounds_lower": lo.tolist(),
            "bounds_upper": hi.tolist(),
            "fixed": repr(fixed),
            "data_file": bench.source,
            "rms_residual": math.sqrt(float(sol.fun @ sol.fun) / n),
            "residual_sd": math.sqrt(s2),
            "condition_number": cond,
            "n_evaluations": count[0],
            "n_search_evaluations": search[0],
            "optimizer_status": int(sol.status),
            "optimizer_message": str(sol.message),
            "undetermined": ",".join(undetermined),
            "rough": ",".join(rough),
            "jacobian_step_ratio": ratio.tolist(),
            "posterior": "Laplace at the least-squares optimum, truncated to the bounds",
            "source": f"tumblemc {__version__}",
            "Conventions": "CF-1.10",
        }
    )
    return out


def coverage(
    n_rep: int = 200,
    truth: dict[str, float] | None = None,
    fields_mT: Sequence[float] = tuple(np.arange(3.0, 15.5, 1.0)),
    noise_deg: float = 0.5,
    level: float = 0.95,
    seed: int = 1,
    progress: bool = False,
    clean: np.ndarray | None = None,
) -> xr.Dataset:
    """Coverage of the posterior's central ``level`` intervals on synthetic static-tilt data.

    ``n_rep`` data sets: the noise-free tilts ``clean`` at ``fields_mT`` (default: the
    closed-form edge balance at ``truth``; pass ``lab.static_tilt(...)["tilt_deg"]`` for
    simulated data) plus normal noise of ``noise_deg``, each calibrated with the closed-form
    model, free parameters the keys of ``truth`` (default: F_elect 2.5e-6 N, offset_deg
    22); returns, per parameter, the share of replicates whose interval holds the truth,
    and the interval widths.
    """
    truth = truth or {"F_elect": 2.5e-6, "offset_deg": 22.0}
    x = np.asarray(fields_mT, float)
    if clean is None:
        clean = np.array([lab.cuboid_tilt_balance(float(b), "paper", **truth) for b in x])
    rng = np.random.default_rng(seed)
    names = list(truth)
    hit = np.zeros((n_rep, len(names)), bool)
    width = np.zeros((n_rep, len(names)))
    undet = np.zeros((n_rep, len(names)), bool)
    q = (1 - level) / 2
    for i in range(n_rep):
        if progress and i % 20 == 0:
            print(f"coverage replicate {i + 1}/{n_rep}", flush=True)
        data = BenchData("static_tilt", "field_mT", "tilt_deg", "degree", x, clean + rng.normal(0.0, noise_deg, x.size), "synthetic")
        post = calibrate(data, names, model="closed-form", n_posterior=1000, seed=i)
        for j, nm in enumerate(names):
            a, b = np.quantile(post[nm].values, [q, 1 - q])
            hit[i, j] = a <= truth[nm] <= b
            width[i, j] = b - a
            undet[i, j] = nm in post.attrs["undetermined"].split(",")
    return xr.Dataset(
        {
            "coverage": ("param", hit.mean(0), {"units": "1", "long_name": f"share of {level:.0%} intervals holding the truth"}),
            "undetermined_share": ("param", undet.mean(0), {"units": "1", "long_name": "share of fits flagging it undetermined"}),
            "mean_width": ("param", width.mean(0), {"long_name": "mean interval width (parameter units)"}),
            "covered": (("replicate", "param"), hit),
        },
        coords={"param": names},
        attrs={"n_rep": n_rep, "noise_deg": noise_deg, "level": level, "truth": repr(truth), "fields_mT": x.tolist()},
    )


__all__ = ["KINDS", "MODELS", "BenchData", "calibrate", "closed_form_applies", "coverage", "forward_model", "read_bench", "write_bench"]
