"""Anytime-valid intervals for a success probability: a confidence sequence and its stopping rule.

A *confidence sequence* is a sequence of intervals ``CS_n`` with
``P(p in CS_n for every n) >= level``, so the interval at a data-dependent stopping time
(sample a cell until its interval is narrow enough) still covers ``p`` with probability at
least ``level``; a fixed-n interval (Wilson, Clopper-Pearson) does not.

The sequence here is a beta-binomial mixture (Robbins 1970, "Statistical methods related
to the law of the iterated logarithm", Ann. Math. Statist. 41; Howard, Ramdas, McAuliffe
and Sekhon 2021, "Time-uniform, nonparametric, nonasymptotic confidence sequences", Ann.
Statist. 49, section 3). With ``k`` successes in ``n`` independent Bernoulli(p) trials and
a mixing prior ``pi`` on the success probability,

    M_n(p) = integral of q^k (1 - q)^(n - k) d pi(q)  /  (p^k (1 - p)^(n - k))

is a nonnegative martingale with ``M_0 = 1`` under ``p``, whatever ``pi`` is; Ville's
inequality gives ``P(sup_n M_n(p) >= 1 / alpha) <= alpha``, so ``CS_n = {p : M_n(p) < 1 /
alpha}`` (``alpha = 1 - level``) is a confidence sequence. For a mixture of beta priors
``sum_j w_j Beta(a_j, b_j)`` the integral is ``sum_j w_j B(k + a_j, n - k + b_j) / B(a_j,
b_j)``. ``log M_n`` is convex in ``p`` (the integral does not depend on ``p``) with its
minimum at ``k / n``, so ``CS_n`` is an interval; its ends are found by bisection.

The prior decides where the sequence is narrow (:data:`MIXTURES`):

- ``"ends"`` (``ci = "confidence-sequence-ends"``, adaptive sampling's default): half the
  prior is uniform, half is ``Beta(0.1, 0.1)`` (which by itself puts
  a quarter of its mass within 1e-3 of 0 and a quarter within 1e-3 of 1, so the mixture
  an eighth at each end). A robustness map has many cells where every
  run climbs or every run fails; this prior stops them after 21 runs at half-width 0.1
  (45 at 0.05) instead of 29 (69), at the price of a slightly wider interval in between
  (half-width 0.120 against 0.115 at ``k = 100, n = 200``). Chosen by the expected runs of
  a cell under a stated mix of cells (half at ``p = 0`` or ``1``, half spread over (0, 1);
  docs/adaptive.md), not fitted to one study's outcomes.
- ``"uniform"`` (``ci = "confidence-sequence"``, and the functions' default): Robbins'
  uniform prior, adaptive sampling's earlier rule (the method name kept its
  meaning, so earlier results and configs keep theirs); all success (``k = n``) then has
  the closed form ``lower = (alpha / (n + 1))^(1 / n)``.

:func:`stop_count` is the stopping rule of adaptive sampling (a study's ``precision``):
the first prefix of a cell's runs, in sample order, at which the half-width of ``CS_n``
over its valid runs is at most ``precision``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import betaln, logsumexp, xlog1py, xlogy

_BISECT = 80  # halvings of [0, 1]: below the spacing of doubles near every bound

#: Mixing priors: name -> components ``(weight, a, b)`` of ``sum_j w_j Beta(a_j, b_j)``.
MIXTURES: dict[str, tuple[tuple[float, float, float], ...]] = {
    "ends": ((0.5, 1.0, 1.0), (0.5, 0.1, 0.1)),
    "uniform": ((1.0, 1.0, 1.0),),
}
DEFAULT_MIXTURE = "uniform"  # of the functions below; a study's ``ci`` chooses its own
#: The interval methods (``ci`` of a study) that are confidence sequences, and their prior.
CS_METHODS: dict[str, str] = {"confidence-sequence": "uniform", "confidence-sequence-ends": "ends"}


def _components(mixture: str) -> tuple[tuple[float, float, float], ...]:
    try:
        return MIXTURES[mixture]
    except KeyError:
        raise ValueError(f"mixture must be one of {tuple(MIXTURES)}, got {mixture!r}") from None


def _log_marginal(k: np.ndarray, n: np.ndarray, mixture: str) -> np.ndarray:
    """``log`` of the prior's integral of ``q^k (1 - q)^(n - k)``."""
    comps = _components(mixture)
    if mixture == "uniform":  # the rule before the mixture was a choice, to the last bit
        return np.asarray(betaln(k + 1.0, n - k + 1.0))
    terms = [np.log(w) + betaln(k + a, n - k + b) - betaln(a, b) for w, a, b in comps]
    return np.asarray(logsumexp(np.stack(terms), axis=0))


def _log_m(p: np.ndarray, k: np.ndarray, n: np.ndarray, log_num: np.ndarray) -> np.ndarray:
    """``log M_n(p)``, given the prior's part ``log_num`` (:func:`_log_marginal`)."""
    return log_num - xlogy(k, p) - xlog1py(n - k, -p)


def cs_interval(k: ArrayLike, n: ArrayLike, level: float = 0.95, mixture: str = DEFAULT_MIXTURE) -> tuple[Any, Any]:
    """The beta-binomial mixture confidence sequence at ``(k, n)``, vectorised.

    Parameters
    ----------
    k, n : int array_like
        Successes and trials, ``0 <= k <= n``; broadcast together.
    level : float
        In (0, 1): ``P(p in interval for every n) >= level``.
    mixture : str
        The mixing prior, a key of :data:`MIXTURES` (``"ends"`` or ``"uniform"``).

    Returns
    -------
    (lo, hi) : float64 arrays (NumPy floats for scalar input)
        ``lo = 0`` at ``k = 0``, ``hi = 1`` at ``k = n``; ``(0, 1)`` at ``n = 0``.
    """
    if not 0.0 < float(level) < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    k_arr, n_arr = np.broadcast_arrays(np.asarray(k, dtype=np.float64), np.asarray(n, dtype=np.float64))
    if not (np.all(np.isfinite(k_arr)) and np.all(np.isfinite(n_arr))) or np.any(k_arr < 0) or np.any(k_arr > n_arr):
        raise ValueError("cs_interval needs finite 0 <= k <= n")
    log_num = _log_marginal(k_arr, n_arr, mixture)
    thr = -np.log1p(-float(level))  # log(1 / alpha)
    with np.errstate(invalid="ignore", divide="ignore"):
        phat = np.where(n_arr > 0, k_arr / np.maximum(n_arr, 1.0), 0.5)
    # lower end: in (0, phat] where log M crosses thr from above (only when k > 0)
    a, b = np.zeros(k_arr.shape), phat.copy()
    for _ in range(_BISECT):
        mid = 0.5 * (a + b)
        inside = _log_m(mid, k_arr, n_arr, log_num) < thr
        b = np.where(inside, mid, b)
        a = np.where(inside, a, mid)
    lo = np.where(k_arr > 0, b, 0.0)
    a, b = phat.copy(), np.ones(k_arr.shape)
    for _ in range(_BISECT):
        mid = 0.5 * (a + b)
        inside = _log_m(mid, k_arr, n_arr, log_num) < thr
        a = np.where(inside, mid, a)
        b = np.where(inside, b, mid)
    hi = np.where(k_arr < n_arr, a, 1.0)
    empty = n_arr == 0
    lo = np.where(empty, 0.0, lo)
    hi = np.where(empty, 1.0, hi)
    return lo[()], hi[()]


def half_width(k: ArrayLike, n: ArrayLike, level: float = 0.95, mixture: str = DEFAULT_MIXTURE) -> Any:
    """Half the width of :func:`cs_interval` (0.5 at ``n = 0``)."""
    lo, hi = cs_interval(k, n, level, mixture)
    return 0.5 * (np.asarray(hi) - np.asarray(lo))


def first_possible_stop(precision: float, level: float = 0.95, cap: int = 10**6, mixture: str = DEFAULT_MIXTURE) -> int:
    """Fewest runs after which any cell can stop: all of them valid and all one verdict.

    ``k = n`` (or ``k = 0``, the priors are symmetric) gives the narrowest interval at each
    ``n``, and its lower end has a closed form: ``M_n(p) = I_n / p^n`` with ``I_n`` the
    prior's integral of ``q^n``, so ``lower = (alpha I_n)^(1 / n)``. The answer is the least
    ``n`` with ``(1 - lower) / 2 <= precision``, at most ``cap`` (searched in blocks of
    growing size, so that a small answer costs little).
    """
    alpha = 1.0 - float(level)
    start, size = 1, 1024
    while start <= cap:
        n = np.arange(start, min(cap, start + size - 1) + 1, dtype=np.float64)
        if mixture == "uniform":
            lower = (alpha / (n + 1.0)) ** (1.0 / n)
        else:
            lower = np.exp((np.log(alpha) + _log_marginal(n, n, mixture)) / n)
        ok = 0.5 * (1.0 - lower) <= float(precision)
        if ok.any():
            return int(n[np.argmax(ok)])
        start += size
        size *= 8
    return cap


def stop_count(valid: ArrayLike, success: ArrayLike, precision: float, level: float = 0.95, mixture: str = DEFAULT_MIXTURE) -> int | None:
    """Runs a cell keeps under adaptive sampling, or None if it must go on.

    Parameters
    ----------
    valid, success : bool array_like
        The cell's runs ``0 .. m-1`` in sample order (``success`` implies ``valid``):
        only valid runs enter the interval (``p_success`` is conditional on a valid run).
    precision : float
        Target half-width of :func:`cs_interval`.
    level, mixture
        As in :func:`cs_interval`.

    Returns
    -------
    int or None
        The least ``j`` such that the interval over the valid runs among the first ``j``
        has half-width at most ``precision``; None if no prefix of the ``m`` runs reaches it.
        The answer depends only on the outcomes in sample order, never on how many runs
        beyond ``j`` were simulated.
    """
    v = np.asarray(valid, dtype=bool)
    s = np.asarray(success, dtype=bool) & v
    if v.size == 0:
        return None
    nv = np.cumsum(v)
    ks = np.cumsum(s)
    ok = half_width(ks, nv, level, mixture) <= float(precision)
    return int(np.argmax(ok)) + 1 if ok.any() else None


__all__ = ["CS_METHODS", "DEFAULT_MIXTURE", "MIXTURES", "cs_interval", "first_possible_stop", "half_width", "stop_count"]
