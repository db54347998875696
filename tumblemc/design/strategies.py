"""Where to look next: the proposal strategies of a design search, and the model's best design.

Every strategy works in the unit box (each design variable scaled to [0, 1]) on what the
search has measured: ``Y`` (designs x objectives, oriented so that larger is better) and
``V``, the known noise variance of each estimate (binomial for P(climb), s^2/n for a
mean speed, from the order-statistic interval for a quantile). A proposal is a
deterministic function of the measurements, the seed and the round, so a resumed search
proposes what the uninterrupted one would.

- ``"gp"`` (default): a Gaussian process (scikit-learn ``GaussianProcessRegressor``,
  Matern 5/2 with one length scale per variable) told each estimate's noise variance
  (``alpha``: the library's way of passing known, per-point noise), expected improvement
  over the best posterior mean, maximised over 2,048 Sobol candidates and local moves
  around the best designs; a batch by the kriging believer. Several objectives: a random
  augmented-Chebyshev scalarisation per proposal (ParEGO).
- ``"tpe"``: Optuna's multivariate tree-structured Parzen estimator (``constant_liar``
  for batches; several objectives: its multi-objective TPE). It has no noise model.
- ``"sobol"``: the next points of a scrambled Sobol sequence (no model: the baseline).

:func:`model_best` is the recommendation: the evaluated design with the highest GP
posterior mean on the (single) objective, so that a design that was merely lucky on its
robots is shrunk toward its neighbours, never the largest raw estimate.
docs/guide/libraries.md says how the default was chosen (measured).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from scipy import stats
from scipy.stats import qmc


def _sobol(d: int, seed: int, start: int, n: int) -> np.ndarray:
    """Points ``start .. start + n`` of one scrambled Sobol sequence (a power-of-two prefix drawn, then sliced)."""
    m = max(1, math.ceil(math.log2(start + n)))
    return qmc.Sobol(d, scramble=True, rng=np.random.default_rng(seed)).random_base2(m)[start : start + n]


def initial(d: int, n: int, seed: int) -> np.ndarray:
    """The first ``n`` designs: a scrambled Sobol set in the unit box (seeded)."""
    return _sobol(d, seed, 0, n)


def _need(module: str, strategy: str) -> None:
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise ValueError(f"the design search's {strategy} needs {module}, which is not installed: pip install 'tumblemc[design]'")


def require(strategy: str) -> None:
    """Refuse at once (ValueError naming the extra) when a library the search will need is missing."""
    _need("sklearn", "model (strategy gp and the recommendation)")
    if strategy == "tpe":
        _need("optuna", "strategy tpe")


def _fit(X: np.ndarray, y: np.ndarray, var: np.ndarray, seed: int, kernel: Any = None) -> Any:
    _need("sklearn", "model (strategy gp and the recommendation)")
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern

    mu, sd = float(np.mean(y)), float(np.std(y))
    sd = sd if sd > 1e-12 else 1.0
    alpha = np.maximum(var / sd**2, 1e-8)
    d = X.shape[1]
    k = kernel or ConstantKernel(1.0, (1e-3, 1e2)) * Matern(length_scale=np.full(d, 0.3), length_scale_bounds=(0.03, 10.0), nu=2.5)
    gp = GaussianProcessRegressor(k, alpha=alpha, normalize_y=False, n_restarts_optimizer=2 if kernel is None else 0, random_state=seed)
    if kernel is not None:
        gp.optimizer = None
    with warnings.catch_warnings():  # "close to the bound" of a length scale: harmless, not an error
        warnings.simplefilter("ignore")
        gp.fit(X, (y - mu) / sd)
    gp.tm_shift = (mu, sd)
    return gp


def _predict(gp: Any, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mu, sd = gp.tm_shift
    m, s = gp.predict(X, return_std=True)
    return m * sd + mu, s * sd


def model_best(X: np.ndarray, y: np.ndarray, var: np.ndarray, seed: int = 0, eligible: np.ndarray | None = None) -> tuple[int, np.ndarray]:
    """Index of the evaluated design with the highest posterior mean (among ``eligible``), and every design's posterior mean."""
    ok = np.isfinite(y) & np.isfinite(var)
    if ok.sum() < 2:
        means = np.where(ok, y, -np.inf)
    else:
        gp = _fit(X[ok], y[ok], var[ok], seed)
        means = _predict(gp, X)[0]
        means[~ok] = -np.inf
    if eligible is not None:
        means = np.where(eligible, means, -np.inf)
    return int(np.argmax(means)), means


def _chebyshev(Y: np.ndarray, V: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = np.nanmin(Y, axis=0), np.nanmax(Y, axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    gap = (hi - Y) / span  # 0 at the best value of each objective
    j = np.argmax(w * gap, axis=1)
    s = (w * gap)[np.arange(len(Y)), j] + 0.05 * (w * gap).sum(axis=1)
    var = (w[j] ** 2) * V[np.arange(len(Y)), j] / span[j] ** 2
    return -s, var


def _ei(gp: Any, C: np.ndarray, best: float) -> np.ndarray:
    m, s = _predict(gp, C)
    s = np.maximum(s, 1e-12)
    z = (m - best) / s
    return (m - best) * stats.norm.cdf(z) + s * stats.norm.pdf(z)


def _gp(X: np.ndarray, Y: np.ndarray, V: np.ndarray, n_new: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    d = X.shape[1]
    out: list[np.ndarray] = []
    for _ in range(n_new):
        if Y.shape[1] > 1:
            w = rng.dirichlet(np.ones(Y.shape[1]))
            y, var = _chebyshev(Y, V, w)
        else:
            y, var = Y[:, 0], V[:, 0]
        ok = np.isfinite(y) & np.isfinite(var)
        Xo, yo, vo = X[ok], y[ok], var[ok]
        gp = _fit(Xo, yo, vo, seed)
        for p in out:  # the kriging believer: earlier proposals of this batch at their predicted mean
            Xo = np.vstack([Xo, p])
            yo = np.append(yo, _predict(gp, p[None])[0])
            vo = np.append(vo, 1e-6 * (float(np.var(yo)) + 1e-12))
        if out:
            gp = _fit(Xo, yo, vo, seed, kernel=gp.kernel_)
        best = float(np.max(_predict(gp, Xo)[0]))
        top = Xo[np.argsort(-_predict(gp, Xo)[0])[:5]]
        local = np.clip(np.repeat(top, 64, axis=0) + rng.normal(0, 0.05, (len(top) * 64, d)), 0, 1)
        cand = np.vstack([_sobol(d, int(rng.integers(2**31)), 0, 2048), local])
        out.append(cand[int(np.argmax(_ei(gp, cand, best)))])
    return np.array(out)


def _tpe(X: np.ndarray, Y: np.ndarray, n_new: int, seed: int) -> np.ndarray:
    _need("optuna", "strategy tpe")
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    d, m = X.shape[1], Y.shape[1]
    dists: dict[str, optuna.distributions.BaseDistribution] = {f"x{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(d)}
    with warnings.catch_warnings():  # multivariate and constant_liar are "experimental" in optuna's words
        warnings.simplefilter("ignore")
        sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, constant_liar=True, n_startup_trials=0)
        study = optuna.create_study(directions=["maximize"] * m, sampler=sampler)
        for x, y in zip(X, Y, strict=True):
            if np.all(np.isfinite(y)):
                vals = [float(v) for v in y]
                study.add_trial(
                    optuna.trial.create_trial(params={f"x{i}": float(x[i]) for i in range(d)}, distributions=dists, values=vals)
                )
        out = []
        for _ in range(n_new):
            t = study.ask(dists)
            out.append([t.params[f"x{i}"] for i in range(d)])
    return np.array(out)


def propose(strategy: str, X: np.ndarray, Y: np.ndarray, V: np.ndarray, n_new: int, seed: int, n_seen: int) -> np.ndarray:
    """``n_new`` designs (unit box) from ``strategy`` given designs ``X``, estimates ``Y`` (larger is better) and their noise ``V``.

    ``n_seen``: designs proposed so far (the Sobol baseline continues its sequence there).
    """
    if strategy == "sobol":
        return _sobol(X.shape[1], seed, n_seen, n_new)
    if strategy == "tpe":
        return _tpe(X, Y, n_new, seed)
    if strategy == "gp":
        return _gp(X, Y, V, n_new, seed)
    raise ValueError(f"strategy={strategy!r} is unknown (allowed: gp, tpe, sobol)")


__all__ = ["initial", "model_best", "propose", "require"]
