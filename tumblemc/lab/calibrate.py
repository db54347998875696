"""Calibration from bench data: fit :class:`~tumblemc.model.params.Params` fields, then a posterior.

Bench data are CSV files with a header naming the test:

- static tilt: ``field_mT,tilt_deg`` (a static field of fixed direction, :func:`tumblemc.lab.static_tilt`);
- speed against frequency: ``freq_hz,speed_mm_s`` (the paper's rotating field, :func:`tumblemc.lab.step_out`).

(``incline_deg,climbed``, the critical incline, is read but not fitted yet: a 0/1 response
needs a likelihood, not least squares.)

**Bounds.** Each free field has bounds (:func:`tumblemc.lab.bounds.default_bounds`: the physical range, a scale
parameter such as ``adhesion_C`` or ``F_elect`` the preset's value x 10^-3 to x 10^3) and a
sampling scale: log10 for scale parameters, linear otherwise. The fit and the posterior
work in ``z``, 0 at the lower bound and 1 at the upper in that scale; the prior is uniform
in ``z`` (log-uniform for scale parameters).

**Fit.** Bounded nonlinear least squares (:func:`scipy.optimize.least_squares`) in ``z``.
The static tilt has a step (a data point flips from flat to lifted when the lift-off field
crosses it), which traps a local fit: where the closed form applies (static tilt of the
cuboid under a field along -z) a global search on it (differential evolution) gives the
start; otherwise the costs of the preset's values and of a seeded Latin hypercube of
``screen`` points (default 4 per free field) are screened and the fit runs from the best
``starts`` (2). The forward model is the simulator itself (``model="simulate"``: any shape,
every physics option) or, for the paper's cuboid under a field along ``-n``, the closed-form
edge balance (``model="closed-form"``; it agrees with the simulator to 0.002 deg,
docs/guide/lab.md), about a thousand times cheaper.

**Posterior.** With the closed form (the default where it applies), MCMC
(:func:`tumblemc.lab.mcmc.sample_posterior`, emcee): the exact likelihood, Gaussian noise of
unknown sd marginalised (``SSR^(-n/2)``), so the lift-off threshold's cliff is sampled as it is;
the chain's draws are then importance-corrected (:func:`tumblemc.lab.mcmc.importance_correct`:
the ensemble sampler leaves the far end of a ridge under-sampled, and its intervals held the
truth less often than the exact posterior's, docs/notes/calibration_sampler.md). With the
simulator, whose runs cost seconds, a Laplace approximation at the optimum as a labelled
fallback: precision ``J^T J / s^2 + P0`` in ``z`` (``P0`` the bounds' uniform as a weak prior),
drawn as a multivariate t with ``n - p`` degrees of freedom and truncated to the bounds; the
Jacobian is taken at two steps (1e-3 and 1e-2) and, per parameter, the flatter one is used
(``rough`` flags a factor over 2 between them). Every result carries a posterior predictive
check (the share of the data inside their 95% predictive band), the bounds the posterior presses
on with the ``--bounds`` flag that widens them, and the presets' values the data rule out
(outside the 99% interval); :func:`report` words them.

The result is an xarray Dataset, one variable per free :class:`Params` field along
``sample`` (the posterior draws, the file a study samples from with
``[uncertain] posterior = "calib.nc"``), plus the data, the fitted curve with its 95% bands,
the estimate, the covariance and the diagnostics.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.lab import bounds as cb
from tumblemc.lab import mcmc as mc
from tumblemc.lab import protocols as lab
from tumblemc.lab.benchdata import KINDS, BenchData, read_bench, write_bench
from tumblemc.lab.diagnostics import diagnostic_lines, weakest_direction
from tumblemc.model.params import RANGES, check_vector, get_preset
from tumblemc.version import __version__

MODELS = ("auto", "simulate", "closed-form")
N_POSTERIOR = 2000
COARSE_STEP = 1e-2  # the second Jacobian's step, in bound widths (the fit's is 1e-3)
UNDETERMINED_SHARE = 0.5  # the data determine a parameter when they halve the spread of its bounds (sd width/sqrt(12))
POSTERIORS = ("auto", "mcmc", "laplace")
GRID_POINTS = 241  # the fine grid of the fitted curve and its bands (closed form)
BAND_NAMES = {
    "band_lo": "2.5% quantile of the model over the posterior",
    "band_hi": "97.5% quantile of the model over the posterior",
    "predictive_lo": "2.5% quantile of new data (posterior predictive)",
    "predictive_hi": "97.5% quantile of new data (posterior predictive)",
}


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
            return lambda p: mc.tilt_balance_batch(data.x, preset, fixed, **p)
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


def _laplace(
    resid: Callable[[np.ndarray], np.ndarray], sol: Any, n: int, n_posterior: int, seed: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Laplace at the optimum ``sol`` in z: draws (t, n - p dof, truncated to the box), cov_z, Jacobian, per-draw noise sd, step ratios."""
    p = len(sol.x)
    dof = max(n - p, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    # precision: the data's J^T J / s^2 plus the bounds as a weak prior (the variance of a
    # uniform on them, 1/12 in z), so a direction the data do not determine keeps the
    # spread of its bounds. The model can be rough (a slip or a lift-off moves with the
    # parameters): a second Jacobian at ten times the step; per parameter the flatter column
    # is kept, so a kink makes the posterior wider, not narrower
    jac = np.array(sol.jac, dtype=float)
    coarse = np.empty_like(jac)
    for j in range(p):
        dz = COARSE_STEP if sol.x[j] + COARSE_STEP <= 1.0 else -COARSE_STEP
        z = sol.x.copy()
        z[j] += dz
        coarse[:, j] = (resid(z) - sol.fun) / dz
    norm_f, norm_c = np.linalg.norm(jac, axis=0), np.linalg.norm(coarse, axis=0)
    ratio = norm_f / np.where(norm_c > 0, norm_c, np.nan)
    jac = np.where(norm_c < norm_f, coarse, jac)
    cov_z = np.linalg.inv(jac.T @ jac / max(s2, 1e-300) + 12.0 * np.eye(p))
    rng = np.random.default_rng(seed)
    draws, sd = np.empty((0, p)), np.empty(0)
    for _ in range(50):  # truncate to the bounds by rejection
        # multivariate t with n - p degrees of freedom: the posterior of a linear model whose
        # noise variance is estimated from the residuals (normal x inverse chi-square)
        scale = np.sqrt(dof / rng.chisquare(dof, size=4 * n_posterior))
        d = sol.x + scale[:, None] * rng.multivariate_normal(np.zeros(p), cov_z, size=4 * n_posterior, method="eigh")
        keep = np.all((d >= 0.0) & (d <= 1.0), axis=1)
        draws, sd = np.vstack([draws, d[keep]]), np.concatenate([sd, math.sqrt(s2) * scale[keep]])
        if len(draws) >= n_posterior:
            break
    return draws[:n_posterior], cov_z, jac, sd[:n_posterior], ratio


def calibrate(  # noqa: C901
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
    posterior: str = "auto",
    noise_sd: float | None = None,
    **fixed: Any,
) -> xr.Dataset:
    """Fit the ``free`` Params fields to bench ``data`` and draw their posterior.

    ``posterior``: ``auto`` (default: MCMC where the closed form is the forward model,
    Laplace with the simulator), ``mcmc`` (closed form only) or ``laplace``. ``noise_sd``:
    the data's noise sd when the instrument's is known (MCMC only); by default it is
    unknown and marginalised under the prior ``1/sigma`` (the likelihood ``SSR^(-n/2)``).

    Returns
    -------
    xarray.Dataset
        One variable per free field along ``sample`` (the posterior draws) and ``noise_sd``
        (the noise sd drawn with each), ``estimate_<name>``, ``covariance`` (param x param),
        ``x``/``y`` (the data), ``fit``, ``band_lo``/``band_hi`` (95% band of the model) and
        ``predictive_lo``/``predictive_hi`` (95% band of new data: model plus noise) at the
        data's x, and the same along ``x_grid`` (a fine grid with the closed form; the data's
        x with the simulator); attributes: the method (``posterior``), ``predictive_share``
        (the data inside their predictive band), ``liftoff_share``, ``bound_warnings``,
        ``ruled_out``, ``undetermined``, ``rms_residual``, ``condition_number``, the
        sampler's ``autocorr_steps`` and more (:func:`report` words them).
    """
    from scipy.optimize import least_squares

    t_start = time.perf_counter()
    bench = data if isinstance(data, BenchData) else read_bench(data)
    sc = cb.check_free(free, bounds, preset)
    cb.check_request(free, fixed, preset, n_posterior, len(bench.y) + GRID_POINTS)
    if not float(np.linalg.norm(check_vector("direction", direction))) > 0.0:
        raise ValueError(f"direction={tuple(direction)!r} is not allowed (allowed: a nonzero 3-vector, world frame)")
    names, p = list(sc.names), len(sc.names)
    if model not in MODELS:
        raise ValueError(f"model={model!r} is not allowed (allowed: {', '.join(MODELS)})")
    if posterior not in POSTERIORS:
        raise ValueError(f"posterior={posterior!r} is not allowed (allowed: {', '.join(POSTERIORS)})")
    cf = closed_form_applies(bench, shape, direction)
    fit_model = ("closed-form" if cf else "simulate") if model == "auto" else model
    f = forward_model(bench, shape, preset, direction, fit_model, **fixed)
    cheap = fit_model == "closed-form"
    method = ("mcmc" if cheap else "laplace") if posterior == "auto" else posterior
    is_sd = isinstance(noise_sd, (int, float)) and not isinstance(noise_sd, bool) and 0.0 < noise_sd < math.inf
    if noise_sd is not None and not (method == "mcmc" and is_sd):
        raise ValueError(f"noise_sd={noise_sd!r} is not allowed (allowed: a positive finite sd in the data's unit, with MCMC)")
    if method == "mcmc" and not cheap:
        raise ValueError("posterior='mcmc' needs the closed-form forward model (allowed with the simulator: laplace, or auto)")
    nominal = get_preset(preset)
    z0 = np.clip(sc.to_z([float(getattr(nominal, n)) for n in names]), 1e-3, 1 - 1e-3)
    count, search = [0], [0]  # forward-model evaluations of the fit; closed-form evaluations of the global search
    n = len(bench.y)

    def values(z: np.ndarray) -> dict[str, Any]:
        return dict(zip(names, sc.to_values(z).tolist(), strict=True))

    def resid(z: np.ndarray) -> np.ndarray:
        count[0] += 1
        return f(values(z)) - bench.y

    def batch(x: np.ndarray, v: np.ndarray) -> np.ndarray:  # the closed form at draws v (k x p): k x len(x)
        return mc.tilt_balance_batch(x, preset, fixed, **{nm: v[:, j, None] for j, nm in enumerate(names)})

    # a kink or a step in the model (the lift-off field moves with the parameters, and a data
    # point flips from flat to lifted) traps a local fit. Where the closed form applies, a
    # global search on it (differential evolution) gives the start; otherwise the costs of
    # the preset's values and of a seeded Latin hypercube are screened and the fit runs from
    # the best few, keeping the lowest cost
    cands = [z0]
    if cf:
        from scipy.optimize import differential_evolution

        def cost_cf(z: np.ndarray) -> np.ndarray:  # z: p x S (vectorized)
            search[0] += z.shape[1]
            return np.sum((batch(bench.x, sc.to_values(z.T)) - bench.y) ** 2, axis=1)

        de = differential_evolution(
            cost_cf, [(0.0, 1.0)] * p, seed=seed, tol=1e-6, polish=False, maxiter=300, vectorized=True, updating="deferred"
        )
        cands = [np.clip(de.x, 1e-6, 1 - 1e-6)]
    else:
        from scipy.stats import qmc

        n_screen = screen if screen is not None else 4 * p
        if n_screen > 0:
            cands += list(qmc.LatinHypercube(p, rng=np.random.default_rng(seed)).random(n_screen) * 0.98 + 0.01)
    costs = [float(np.sum(resid(z) ** 2)) for z in cands] if len(cands) > 1 else [0.0]
    best = [cands[i] for i in np.argsort(costs)[: max(1, starts)]]
    sol = min((least_squares(resid, z, bounds=(0.0, 1.0), diff_step=1e-3, x_scale=1.0) for z in best), key=lambda r: float(r.cost))
    dof = max(n - p, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    draws_z, cov_z, jac, sd_draws, ratio = _laplace(resid, sol, n, n_posterior, seed)
    cond = float(np.linalg.cond(jac.T @ jac))
    est = sc.to_values(sol.x)
    fit = resid(sol.x) + bench.y
    rng = np.random.default_rng(seed + 1)
    chain = None
    if method == "mcmc":

        def log_post(zz: np.ndarray) -> np.ndarray:
            out = np.full(len(zz), -np.inf)
            ok = np.all((zz >= 0.0) & (zz <= 1.0), axis=1)
            if ok.any():
                ssr = np.sum((batch(bench.x, sc.to_values(zz[ok])) - bench.y) ** 2, axis=1)
                if noise_sd is None:  # the sd unknown, marginalised under the prior 1/sigma
                    out[ok] = -0.5 * n * np.log(np.maximum(ssr, 1e-300))
                else:
                    out[ok] = -0.5 * ssr / noise_sd**2
            return out

        chain = mc.sample_posterior(log_post, sol.x, n_posterior, seed)
        draws_z = chain.z
    draws = sc.to_values(draws_z)
    x_grid = bench.x
    if cheap:  # every draw through the closed form, on the data and on a fine grid
        lo_x, hi_x = float(bench.x.min()), float(bench.x.max())
        x_grid = np.linspace(max(lo_x - 0.1 * (hi_x - lo_x), 0.0), hi_x + 0.05 * (hi_x - lo_x), GRID_POINTS)
        pred = batch(bench.x, draws)
        if method == "mcmc":  # sigma^2 | theta, data ~ SSR / chi^2_n under the prior 1/sigma
            ssr = np.sum((pred - bench.y) ** 2, axis=1)
            sd_draws = mc.noise_sd_draws(ssr, n, rng) if noise_sd is None else np.full(len(pred), float(noise_sd))
        at_data = mc.bands(pred, sd_draws, rng)
        on_grid = mc.bands(batch(x_grid, draws), sd_draws, rng)
        grid_fit = batch(x_grid, est[None, :])[0]
        clear = bench.y > 3.0 * math.sqrt(s2)
        lift = float(np.mean(np.all(pred[:, clear] > 0.0, axis=1))) if bench.test == "static_tilt" and clear.any() else math.nan
    else:  # each draw would cost a simulator run: linearised about the optimum, unless band_draws asks for runs
        if band_draws:
            pred = np.array([f(values(d)) for d in draws_z[:band_draws]])
            sd_b = sd_draws[:band_draws]
        else:
            pred, sd_b = fit + (draws_z - sol.x) @ jac.T, sd_draws
        at_data = on_grid = mc.bands(pred, sd_b, rng)
        grid_fit, lift = fit, math.nan
    inside = (bench.y >= at_data["predictive_lo"]) & (bench.y <= at_data["predictive_hi"])
    # the spread in z (the sampling scale) against the bounds' 1/sqrt(12)
    sd_z = np.sqrt(np.diag(cov_z)) if chain is None else draws_z.std(axis=0)
    undetermined = [nm for nm, s in zip(names, sd_z, strict=True) if not s < UNDETERMINED_SHARE / math.sqrt(12.0)]
    press, ruled = cb.bound_messages(sc, sol.x, draws_z, draws, preset)
    sim_check = math.nan
    if model == "auto" and fit_model == "closed-form":  # the simulator at the estimate, as a check
        sim = forward_model(bench, shape, preset, direction, "simulate", **fixed)(values(sol.x))
        sim_check = float(np.sqrt(np.nanmean((sim - fit) ** 2)))
    if chain is not None:
        label = (
            f"MCMC (emcee {_emcee_version()}, {chain.n_walkers} walkers x {chain.n_steps} steps after burn-in, closed-form forward model)"
        )
        cov = np.atleast_2d(np.cov(draws.T))
    else:
        why = "fallback: simulator forward model" if not cheap else "requested with the closed-form forward model"
        label = f"Laplace at the least-squares optimum, truncated to the bounds ({why})"
        decades = np.log10(np.where(sc.log, sc.hi / np.where(sc.log, sc.lo, 1.0), 1.0))
        dv = np.where(sc.log, est * math.log(10.0) * decades, sc.hi - sc.lo)  # d value / d z at the estimate
        cov = cov_z * np.outer(dv, dv)
    out = xr.Dataset(coords={"sample": np.arange(len(draws)), "param": names, "point": np.arange(n), "x_grid": x_grid})
    for j, nm in enumerate(names):
        r = RANGES[nm]
        out[nm] = ("sample", draws[:, j], {"units": r.units, "long_name": f"posterior draw of {r.long_name}"})
        out[f"estimate_{nm}"] = ((), est[j], {"units": r.units, "long_name": f"least-squares estimate of {r.long_name}"})
    u = {"units": bench.y_units}
    out["noise_sd"] = ("sample", sd_draws[: len(draws)], {**u, "long_name": "noise sd drawn with the parameters"})
    out["covariance"] = (("param", "param_2"), cov, {"long_name": f"posterior covariance (parameter units; {method})"})
    out["x"] = ("point", bench.x, {"long_name": bench.x_name})
    out["y"] = ("point", bench.y, {"long_name": bench.y_name, **u})
    out["fit"] = ("point", fit, {**u, "long_name": "model at the estimate"})
    for k, v in at_data.items():
        out[k] = ("point", v, {**u, "long_name": BAND_NAMES[k]})
    out["x_grid"].attrs["long_name"] = bench.x_name
    out["grid_fit"] = ("x_grid", grid_fit, {**u, "long_name": "model at the estimate"})
    for k, v in on_grid.items():
        out[f"grid_{k}"] = ("x_grid", v, {**u, "long_name": BAND_NAMES[k]})
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
            "bounds_lower": sc.lo.tolist(),
            "bounds_upper": sc.hi.tolist(),
            "sampling_scale": ",".join("log" if g else "linear" for g in sc.log),
            "fixed": repr(fixed),
            "data_file": bench.source,
            "rms_residual": math.sqrt(float(sol.fun @ sol.fun) / n),
            "residual_sd": math.sqrt(s2),
            "condition_number": cond,
            "weakest_direction": weakest_direction(jac, names),
            "n_evaluations": count[0],
            "n_search_evaluations": search[0],
            "optimizer_status": int(sol.status),
            "optimizer_message": str(sol.message),
            "undetermined": ",".join(undetermined),
            "rough": ",".join(nm for nm, r in zip(names, ratio, strict=True) if not 0.5 <= r <= 2.0),
            "jacobian_step_ratio": ratio.tolist(),
            "posterior": label,
            "posterior_method": method,
            "noise_model": "unknown sd, marginalised (prior 1/sigma)" if noise_sd is None else f"known sd {float(noise_sd):g}",
            "autocorr_steps": chain.tau.tolist() if chain else [],
            "mcmc_steps": chain.n_steps if chain else 0,
            "mcmc_long_enough": int(bool(chain and chain.n_steps >= mc.TAU_FACTOR * float(np.max(chain.tau)))),
            "mcmc_walkers": chain.n_walkers if chain else 0,
            "mcmc_acceptance": chain.acceptance if chain else math.nan,
            "mcmc_moved_walkers": chain.n_moved if chain else 0,
            "importance_ess": chain.ess if chain else math.nan,
            "importance_corrected": int(bool(chain and chain.corrected)),
            "n_posterior_evaluations": chain.n_evaluations if chain else 0,
            "predictive_share": float(inside.mean()),
            "liftoff_share": lift,
            "bound_warnings": "\n".join(press),
            "ruled_out": "\n".join(ruled),
            "fit_seconds": time.perf_counter() - t_start,
            "source": f"tumblemc {__version__}",
            "Conventions": "CF-1.10",
        }
    )
    return out


def _emcee_version() -> str:
    import emcee

    return str(emcee.__version__)


def report(ds: xr.Dataset) -> list[str]:
    """The calibration in words: estimates and intervals, the method, the predictive check, bounds pressed, presets ruled out."""
    a, lines = ds.attrs, []
    for nm in str(a["free"]).split(","):
        lo, hi = np.quantile(ds[nm].values, [0.025, 0.975])
        est = float(ds[f"estimate_{nm}"])
        lines.append(f"{nm:>14s} = {est:.6g} (95% {lo:.6g} .. {hi:.6g}, posterior sd {float(ds[nm].std()):.3g}) {ds[nm].attrs['units']}")
    lines.append(f"posterior: {a['posterior']}" + (f"; noise: {a['noise_model']}" if "noise_model" in a else ""))
    if a.get("posterior_method") == "mcmc":
        tau = ", ".join(f"{t:.0f}" for t in a["autocorr_steps"])
        ok = (
            ""
            if a.get("mcmc_long_enough", 1)
            else f" (warning: the chain is shorter than {mc.TAU_FACTOR} of them: read the draws with care)"
        )
        lines.append(f"  autocorrelation time {tau} steps; acceptance {a['mcmc_acceptance']:.2f}{ok}")
        ess = a.get("importance_ess", math.nan)
        if a.get("importance_corrected", 0):
            lines.append(f"  draws importance-corrected from the chain (effective sample size {ess:.0f})")
        elif np.isfinite(ess):
            lines.append(
                f"  the chain's own draws: the importance correction's effective sample size ({ess:.0f}) is below the "
                f"{ds.sizes['sample']} draws asked (its tails may be under-sampled)"
            )
    lines += diagnostic_lines(ds)
    inside = int(round(a["predictive_share"] * ds.sizes["point"]))
    lines.append(
        f"predictive check: {inside} of {ds.sizes['point']} data points ({a['predictive_share']:.0%}) inside their 95% posterior "
        "predictive band" + (" (linearised about the optimum)" if a["fit_model"] != "closed-form" else "")
    )
    if np.isfinite(a.get("liftoff_share", math.nan)):
        lines.append(f"lift-off: {a['liftoff_share']:.0%} of the draws tilt at every field where the data show a clear tilt (> 3 sd)")
    lines += [f"warning: {w}" for w in str(a.get("bound_warnings", "")).splitlines() if w]
    lines += [w for w in str(a.get("ruled_out", "")).splitlines() if w]
    if a["undetermined"]:
        lines.append(f"warning: the data do not determine {a['undetermined']} (its posterior keeps most of its bounds)")
    return lines


__all__ = [
    "KINDS",
    "MODELS",
    "POSTERIORS",
    "BenchData",
    "calibrate",
    "closed_form_applies",
    "forward_model",
    "read_bench",
    "report",
    "write_bench",
]
