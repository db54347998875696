"""Anytime-valid intervals for a success probability: a confidence sequence and its stopping rule.

A *confidence sequence* is a sequence of intervals ``CS_n`` with
``P(p in CS_n for every n) >= level``, so the interval at a data-dependent stopping time
(sample a cell until its interval is narrow enough) still covers ``p`` with probability at
least ``level``; a fixed-n interval (Wilson, Clopper-Pearson) does not.

The sequence here is Robbins' beta-binomial mixture (Robbins 1970, "Statistical methods
related to the law of the iterated logarithm", Ann. Math. Statist. 41; Howard, Ramdas,
McAuliffe and Sekhon 2021, "Time-uniform, nonparametric, nonasymptotic confidence
sequences", Ann. Statist. 49, section 3). With ``k`` successes in ``n`` independent
Bernoulli(p) trials and a uniform mixing prior,

    M_n(p) = B(k + 1, n - k + 1) / (p^k (1 - p)^(n - k))

is a nonnegative martingale with ``M_0 = 1`` under ``p``; Ville's inequality gives
``P(sup_n M_n(p) >= 1 / alpha) <= alpha``, so ``CS_n = {p : M_n(p) < 1 / alpha}``
(``alpha = 1 - level``) is a confidence sequence. ``log M_n`` is convex in ``p`` with its
minimum at ``k / n``, so ``CS_n`` is an interval; its ends are found by bisection. All
success (``k = n``) has the closed form ``lower = (alpha / (n + 1))^(1 / n)``.

:func:`stop_count` is the stopping rule of adaptive sampling (a study's ``precision``):
the first prefix of a cell's runs, in sample order, at which the half-width of ``CS_n``
over its valid runs is at most ``precision``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import betaln, xlog1py, xlogy

_BISECT = 80  # halvings of [0, 1]: below the spacing of doubles near every bound


def _log_m(p: np.ndarray, k: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``log M_n(p)`` of the uniform-prior beta-binomial mixture."""
    return betaln(k + 1.0, n - k + 1.0) - xlogy(k, p) - xlog1py(n - k, -p)


def cs_interval(k: ArrayLike, n: ArrayLike, level: float = 0.95) -> tuple[Any, Any]:
    """The beta-binomial mixture confidence sequence at ``(k, n)``, vectorised.

    Parameters
    ----------
    k, n : int array_like
        Successes and trials, ``0 <= k <= n``; broadcast together.
    level : float
        In (0, 1): ``P(p in interval for every n) >= level``.

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
    thr = -np.log1p(-float(level))  # log(1 / alpha)
    with np.errstate(invalid="ignore", divide="ignore"):
        phat = np.where(n_arr > 0, k_arr / np.maximum(n_arr, 1.0), 0.5)
    # lower end: in (0, phat] where log M crosses thr from above (only when k > 0)
    a, b = np.zeros(k_arr.shape), phat.copy()
    for _ in range(_BISECT):
        mid = 0.5 * (a + b)
        inside = _log_m(mid, k_arr, n_arr) < thr
        b = np.where(inside, mid, b)
        a = np.where(inside, a, mid)
    lo = np.where(k_arr > 0, b, 0.0)
    a, b = phat.copy(), np.ones(k_arr.shape)
    for _ in range(_BISECT):
        mid = 0.5 * (a + b)
        inside = _log_m(mid, k_arr, n_arr) < thr
        a = np.where(inside, mid, a)
        b = np.where(inside, b, mid)
    hi = np.where(k_arr < n_arr, a, 1.0)
    empty = n_arr == 0
    lo = np.where(empty, 0.0, lo)
    hi = np.where(empty, 1.0, hi)
    return lo[()], hi[()]


def half_width(k: ArrayLike, n: ArrayLike, level: float = 0.95) -> Any:
    """Half the width of :func:`cs_interval` (0.5 at ``n = 0``)."""
    lo, hi = cs_interval(k, n, level)
    return 0.5 * (np.asarray(hi) - np.asarray(lo))


def first_possible_stop(precision: float, level: float = 0.95, cap: int = 10**6) -> int:
    """Fewest runs after which any cell can stop: all of them valid and all one verdict.

    ``k = n`` (or ``k = 0``) gives the narrowest interval at each ``n``; the answer is the
    least ``n`` with ``(1 - (alpha / (n + 1))^(1 / n)) / 2 <= precision``, at most ``cap``.
    """
    n = np.arange(1, cap + 1, dtype=np.float64)
    alpha = 1.0 - float(level)
    ok = 0.5 * (1.0 - (alpha / (n + 1.0)) ** (1.0 / n)) <= float(precision)
    return int(n[np.argmax(ok)]) if ok.any() else cap


def stop_count(valid: ArrayLike, success: ArrayLike, precision: float, level: float = 0.95) -> int | None:
    """Runs a cell keeps under adaptive sampling, or None if it must go on.

    Parameters
    ----------
    valid, success : bool array_like
        The cell's runs ``0 .. m-1`` in sample order (``success`` implies ``valid``):
        only valid runs enter the interval (``p_success`` is conditional on a valid run).
    precision : float
        Target half-width of :func:`cs_interval`.

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
    ok = half_width(ks, nv, level) <= float(precision)
    return int(np.argmax(ok)) + 1 if ok.any() else None


__all__ = ["cs_interval", "first_possible_stop", "half_width", "stop_count"]
