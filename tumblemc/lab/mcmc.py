"""The calibration posterior where the forward model is cheap: emcee on the closed-form static tilt.

:func:`tilt_balance_batch` is :func:`tumblemc.lab.cuboid_tilt_balance` (the paper cuboid's
edge balance under a field along ``-n``) over arrays of parameter values and fields at
once (a safeguarded Newton iteration on the bracket ``(0, top)``, where the scalar version
calls brentq; they agree to 1e-9 deg, tests/lab/test_calibrate.py): a posterior draw of a
15-field data set costs about 10 microseconds instead of 2 milliseconds.

:func:`sample_posterior` draws the posterior of the free parameters with emcee's ensemble
sampler: a uniform prior on the bounds in the sampling scale (log10 for scale parameters),
Gaussian noise of unknown sd marginalised under the prior ``1/sigma``
(``p(data | theta) ~ SSR(theta)^(-n/2)``), walkers started half in a small ball around the
least-squares optimum and half spread over the prior (so that a cliff-shaped posterior,
which a lift-off threshold makes, is explored beyond the optimum's side of it).
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tumblemc.model.params import get_preset
from tumblemc.model.shapes.library import get_shape

BURN_STEPS = 750  # steps before the stragglers are moved, and again after
MIN_STEPS = 1500  # production steps, at least
MAX_STEPS = 20000  # production steps, at most (a chain 50 autocorrelation times long stops earlier)
TAU_FACTOR = 50  # emcee's own rule: trust tau once the chain is 50 tau long
STRAGGLER_LOGP = 10.0  # a walker whose log posterior sits this far (plus p) below the median after burn-in is moved
IS_POINTS = 40000  # points per round of the importance correction
IS_ROUNDS = 2  # rounds: the proposal refitted to the weighted points of the previous round
IS_DEFENSIVE = 0.1  # the prior's (the uniform box's) share of the proposal
IS_INFLATE = 4.0  # the proposal's covariance, times the weighted points'
IS_DF = 4  # the proposal's Student-t degrees of freedom
IS_MIN_ESS = 1.0  # the correction is kept when its effective sample size is at least this many times the draws asked


@functools.cache
def cuboid_lwh() -> tuple[float, float, float]:
    """Length, width, height (m) of the library's cuboid (x W, y L, z H), as the closed form uses them."""
    w, l_, h = np.ptp(get_shape("cuboid").pieces[0].support_points, axis=0)
    return float(l_), float(w), float(h)


def tilt_balance_batch(field_mT: Any, preset: str = "paper", fixed: Mapping[str, Any] | None = None, **free: Any) -> np.ndarray:
    """Closed-form equilibrium tilt (deg) for arrays of fields and parameter values, broadcast together.

    The same balance as :func:`tumblemc.lab.cuboid_tilt_balance` (flat until the face
    adhesion lets go, then the root of the edge balance, toppled beyond it); ``fixed`` are
    Params overrides for every element, ``free`` arrays of Params values broadcast against
    ``field_mT`` (e.g. shape ``(k, 1)`` against ``(m,)`` gives ``(k, m)``). Values are not
    range-checked: the caller's bounds keep them inside the physical ranges.
    """
    p = get_preset(preset).replace(**fixed) if fixed else get_preset(preset)
    v = {nm: np.asarray(free[nm], float) if nm in free else getattr(p, nm) for nm in p.__dataclass_fields__}
    L, W, H = cuboid_lwh()
    b = np.asarray(field_mT, float)
    phi = np.radians(v["offset_deg"])
    torque = v["V_m"] * v["magnetization"] * b * 1e-3
    load = v["mass"] * v["g"] + v["F_elect"]
    line = v["line_contact_width"] * W if p.line_adhesion == "strip" else v["line_contact_fraction"] * W * H
    lam = v["adhesion_C"] * line
    shape = np.broadcast_shapes(*(np.shape(a) for a in (torque, phi, load, lam)))
    torque, phi, lw, face = (np.broadcast_to(a, shape).ravel() for a in (torque, phi, load + lam, load + v["adhesion_C"] * L * W))
    lifted = torque * np.cos(phi) > face * L / 2
    top = np.minimum(np.pi / 2 - phi, math.atan2(L, H))
    out = np.where(lifted, top, 0.0)  # flat, or toppled: the tilt where the centre of mass is over the edge

    def net(th: np.ndarray, s: np.ndarray) -> np.ndarray:
        return torque[s] * np.cos(th + phi[s]) - lw[s] * (L / 2 * np.cos(th) - H / 2 * np.sin(th))

    s = np.flatnonzero(lifted)
    s = s[net(top[s], s) <= 0.0]  # a root in (0, top)
    lo, hi = np.zeros(s.size), top[s]
    th = 0.5 * hi
    for _ in range(100):  # safeguarded Newton: a step leaving the bracket is a bisection
        f = net(th, s)
        neg = f < 0.0
        hi = np.where(neg, th, hi)
        lo = np.where(neg, lo, th)
        d = -torque[s] * np.sin(th + phi[s]) + lw[s] * (L / 2 * np.sin(th) + H / 2 * np.cos(th))
        with np.errstate(divide="ignore", invalid="ignore"):
            nt = th - f / d
        new = np.where((nt >= lo) & (nt <= hi), nt, 0.5 * (lo + hi))
        done = np.all(np.abs(new - th) <= 1e-14)
        th = new
        if done:
            break
    out[s] = th
    return np.degrees(out).reshape(shape)


@dataclass(frozen=True)
class Scales:
    """The free parameters' bounds and sampling scales: ``z`` in [0, 1] is uniform on the bounds in that scale."""

    names: tuple[str, ...]
    lo: np.ndarray
    hi: np.ndarray
    log: np.ndarray  # bool per parameter: sampled as log10

    def _t(self, v: np.ndarray) -> np.ndarray:
        return np.where(self.log, np.log10(np.where(self.log, np.maximum(v, 1e-300), 1.0)), v)

    def to_z(self, values: Any) -> np.ndarray:
        """Parameter values -> z (0 at the lower bound, 1 at the upper, in the sampling scale)."""
        v = np.asarray(values, float)
        tlo, thi = self._t(self.lo), self._t(self.hi)
        return (self._t(v) - tlo) / (thi - tlo)

    def to_values(self, z: Any) -> np.ndarray:
        """Parameter values at ``z``."""
        z = np.asarray(z, float)
        tlo, thi = self._t(self.lo), self._t(self.hi)
        t = tlo + z * (thi - tlo)
        return np.where(self.log, 10.0 ** np.where(self.log, t, 0.0), t)


@dataclass(frozen=True)
class Chain:
    """What :func:`sample_posterior` returns: ``z`` draws (n x p), and the sampler's diagnostics."""

    z: np.ndarray
    n_walkers: int
    n_steps: int
    tau: np.ndarray  # integrated autocorrelation time per parameter (steps)
    acceptance: float
    n_moved: int  # stragglers moved after the first burn-in
    n_evaluations: int
    ess: float = math.nan  # effective sample size of the importance correction (NaN: not run)
    corrected: bool = False  # the draws are the importance correction's (else the chain's)


def importance_correct(
    log_post: Callable[[np.ndarray], np.ndarray], z: np.ndarray, n_draws: int, rng: np.random.Generator
) -> tuple[np.ndarray, float, int]:
    """Draws of the posterior by adaptive importance sampling, started from a chain's points ``z``.

    The proposal is a Student-t (:data:`IS_DF` degrees of freedom, the covariance of the
    points times :data:`IS_INFLATE`) mixed with the prior, the uniform box
    (:data:`IS_DEFENSIVE`): the prior's share bounds every weight by the likelihood over
    its mean, so the weights stay finite wherever the chain did not go. Each of
    :data:`IS_ROUNDS` rounds draws :data:`IS_POINTS` points and refits the t to the weighted
    points. Self-normalised weights make it exact as the points grow, whatever the chain
    missed (an ensemble sampler leaves the far end of a curved ridge pressing on a bound
    under-sampled: docs/notes/calibration_sampler.md). Returns ``n_draws`` draws
    resampled by weight, the effective sample size of the last round and the evaluations.
    """
    from scipy import stats

    p = z.shape[1]
    pts, w = z, np.full(len(z), 1.0 / len(z))
    ess, calls = math.nan, 0
    for _ in range(IS_ROUNDS):
        m = w @ pts
        d = pts - m
        cov = IS_INFLATE * (d.T * w) @ d + 1e-12 * np.eye(p)
        t = stats.multivariate_t(m, cov, df=IS_DF, seed=rng)
        n_t = int(round((1.0 - IS_DEFENSIVE) * IS_POINTS))
        pts = np.vstack([np.asarray(t.rvs(n_t)).reshape(n_t, p), rng.uniform(0.0, 1.0, (IS_POINTS - n_t, p))])
        inside = np.all((pts >= 0.0) & (pts <= 1.0), axis=1)
        log_q = np.logaddexp(math.log(1.0 - IS_DEFENSIVE) + t.logpdf(pts), np.where(inside, math.log(IS_DEFENSIVE), -np.inf))
        lp = np.full(len(pts), -np.inf)
        lp[inside] = log_post(pts[inside])
        calls += int(inside.sum())
        lw = lp - log_q
        if not np.isfinite(lw.max()):  # no point of positive posterior: the caller keeps the chain's draws
            return z[rng.choice(len(z), n_draws)], 0.0, calls
        w = np.exp(lw - lw.max())
        w /= w.sum()
        ess = float(1.0 / np.sum(w**2))
    return pts[rng.choice(len(pts), n_draws, p=w)], ess, calls


def sample_posterior(
    log_post: Callable[[np.ndarray], np.ndarray],
    z_opt: np.ndarray,
    n_draws: int,
    seed: int,
    n_walkers: int | None = None,
    correct: bool = True,
) -> Chain:
    """Draw ``n_draws`` points of a posterior on the unit box with emcee, deterministically for a ``seed``.

    ``log_post`` maps walkers' positions (k x p) to log posteriors (k,) (``-inf`` outside
    the box). Half the walkers start in a ball of radius 1e-3 around ``z_opt``, half
    uniform on the box; after :data:`BURN_STEPS` steps, walkers stuck far below the
    ensemble's median (a local mode or a plateau of the prior) restart beside a random
    other walker, and a second burn-in follows. The production run lasts until it is
    :data:`TAU_FACTOR` autocorrelation times long (at least :data:`MIN_STEPS`, at most
    :data:`MAX_STEPS`). With ``correct`` (the default) the draws are then those of
    :func:`importance_correct` started from the chain, when its effective sample size is at
    least :data:`IS_MIN_ESS` times ``n_draws``; otherwise (and without ``correct``) they are
    taken from the chain thinned by half the largest tau.
    """
    import emcee

    p = len(z_opt)
    k = n_walkers or max(32, 2 * ((8 * p + 1) // 2))
    rng = np.random.default_rng(seed)
    ball = np.clip(z_opt + 1e-3 * rng.standard_normal((k - k // 2, p)), 1e-6, 1 - 1e-6)
    start = np.vstack([ball, rng.uniform(0.0, 1.0, (k // 2, p))])
    calls = [0]

    def lp(z: np.ndarray) -> np.ndarray:
        calls[0] += len(z)
        return log_post(z)

    # the snooker move projects on the line between two walkers, which in one dimension is the
    # axis itself: its Metropolis factor divides zero by zero (NaN proposals); the stretch move there
    snooker = emcee.moves.DESnookerMove() if p > 1 else emcee.moves.StretchMove()
    moves = [(emcee.moves.DEMove(), 0.8), (snooker, 0.2)]
    sampler = emcee.EnsembleSampler(k, p, lp, vectorize=True, moves=moves)
    sampler.random_state = np.random.RandomState(seed).get_state()
    state = sampler.run_mcmc(start, BURN_STEPS)
    recent = sampler.get_log_prob()[-BURN_STEPS // 4 :].mean(axis=0)
    stuck = recent < np.median(recent) - STRAGGLER_LOGP - p
    pos = state.coords.copy()
    good = np.flatnonzero(~stuck)
    for w in np.flatnonzero(stuck):
        pos[w] = np.clip(pos[rng.choice(good)] + 1e-4 * rng.standard_normal(p), 0.0, 1.0)
    sampler.reset()
    state = sampler.run_mcmc(pos, BURN_STEPS)
    sampler.reset()
    steps = 0
    tau = np.full(p, np.nan)
    log = logging.getLogger("emcee")  # its "chain too short" warning: the loop below acts on it, the result records tau
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        while steps < MAX_STEPS:
            n = MIN_STEPS if steps == 0 else min(steps, MAX_STEPS - steps)
            state = sampler.run_mcmc(state, n)
            steps += n
            tau = np.asarray(sampler.get_autocorr_time(quiet=True), float)
            if np.all(np.isfinite(tau)) and TAU_FACTOR * float(tau.max()) <= steps:
                break
    finally:
        log.setLevel(level)
    thin = max(1, int(0.5 * float(np.nanmax(tau)))) if np.any(np.isfinite(tau)) else 1
    flat = sampler.get_chain(thin=thin, flat=True)
    if len(flat) < n_draws:
        flat = sampler.get_chain(flat=True)
    pick = rng.choice(len(flat), n_draws, replace=len(flat) < n_draws)
    draws, ess, corrected = flat[pick], math.nan, False
    if correct:
        is_draws, ess, n_is = importance_correct(log_post, sampler.get_chain(flat=True), n_draws, rng)
        calls[0] += n_is
        if ess >= IS_MIN_ESS * n_draws:
            draws, corrected = is_draws, True
    return Chain(draws, k, steps, tau, float(np.mean(sampler.acceptance_fraction)), int(stuck.sum()), calls[0], ess, corrected)


def noise_sd_draws(ssr: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """The noise sd given each draw's sum of squared residuals: ``sigma^2 | theta ~ SSR / chi^2_n`` (prior ``1/sigma``)."""
    return np.sqrt(ssr / rng.chisquare(n, size=len(ssr)))


def bands(pred: np.ndarray, sd: np.ndarray, rng: np.random.Generator, level: float = 0.95) -> dict[str, np.ndarray]:
    """Pointwise central ``level`` bands of the model (``pred``, draws x points) and of new data (plus noise of ``sd`` per draw)."""
    q = [(1 - level) / 2, (1 + level) / 2]
    new = pred + sd[:, None] * rng.standard_normal(pred.shape)
    (lo, hi), (plo, phi) = np.quantile(pred, q, axis=0), np.quantile(new, q, axis=0)
    return {"band_lo": lo, "band_hi": hi, "predictive_lo": plo, "predictive_hi": phi}


__all__ = ["Chain", "Scales", "bands", "cuboid_lwh", "importance_correct", "noise_sd_draws", "sample_posterior", "tilt_balance_batch"]
