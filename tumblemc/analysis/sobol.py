"""Variance-based sensitivity: Saltelli sampling and Sobol indices (analysis layer).

Sensitivity analysis is kept in three steps, as in SALib:

1. **Sampling** (no simulation): :func:`saltelli_design` draws the Saltelli matrices
   ``A``, ``B`` and ``AB_i`` on the unit hypercube from one scrambled Sobol sequence.
2. **Running**: elsewhere. :mod:`tumblemc.study.sobol` maps a design through a study
   config's distributions and runs it on the robot; an analytic function of
   :mod:`tumblemc.testing` evaluates it in microseconds.
3. **Analysis** (here): :func:`split_saltelli` takes the outputs of the stacked design
   apart and :func:`sobol_indices` estimates first-order and total indices with
   bootstrap intervals.

For an existing Monte Carlo study, whatever its sampler, :mod:`tumblemc.analysis.screening`
(rank correlation, logistic regression) and :mod:`tumblemc.analysis.prim` (PRIM boxes
where failures concentrate) answer the same question without a dedicated design.

Nothing here runs the simulator: inputs are arrays of outputs, results are an
:class:`xarray.Dataset` over ``parameter`` with ``units`` and ``long_name`` on every
variable.

References
----------
Archer, G. E. B., Saltelli, A. & Sobol', I. M. (1997). Sensitivity measures, ANOVA-like
techniques and the use of bootstrap. J. Statist. Comput. Simul. 58, 99-120.
Jansen, M. J. W. (1999). Analysis of variance designs for model output. Computer Physics
Communications 117, 35-43.
Saltelli, A. (2002). Making best use of model evaluations to compute sensitivity
indices. Computer Physics Communications 145, 280-297.
Saltelli, A., Annoni, P., Azzini, I., Campolongo, F., Ratto, M. & Tarantola, S. (2010).
Variance based sensitivity analysis of model output. Design and estimator for the total
sensitivity index. Computer Physics Communications 181, 259-270.

"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy.stats import qmc

from tumblemc.schema import SENSITIVITY_COORD_ATTRS

_BOOT_ELEMENTS = 1 << 22  # bootstrap chunk size (float64 elements per array), ~32 MB


class SaltelliDesign(NamedTuple):
    """Saltelli matrices on the unit hypercube.

    ``A``, ``B``: (n, d); ``AB``: (d, n, d), ``AB[i]`` is ``A`` with column ``i`` taken
    from ``B`` (Saltelli 2010, section 3).
    """

    A: np.ndarray
    B: np.ndarray
    AB: np.ndarray

    @property
    def n(self) -> int:
        """Base sample size (rows of ``A``)."""
        return int(self.A.shape[0])

    @property
    def d(self) -> int:
        """Number of inputs (columns of ``A``)."""
        return int(self.A.shape[1])

    def stack(self) -> np.ndarray:
        """All ``n (d + 2)`` points as one matrix in the SALib layout.

        Row block ``j`` (``d + 2`` rows) is ``A[j], AB[0][j], ..., AB[d-1][j], B[j]``;
        :func:`split_saltelli` takes the outputs of these rows apart again.
        """
        n, d = self.A.shape
        out = np.empty((n, d + 2, d))
        out[:, 0] = self.A
        out[:, 1 : d + 1] = np.swapaxes(self.AB, 0, 1)
        out[:, d + 1] = self.B
        return out.reshape(n * (d + 2), d)


def _pow2(n: int, what: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"{what} must be an integer >= 2, got {n!r}")
    m = int(n).bit_length() - 1
    if 1 << m != n:
        raise ValueError(f"{what} must be a power of 2 (Sobol points are balanced only then), got {n}; use {1 << m} or {1 << (m + 1)}")
    return m


def saltelli_design(n: int, d: int, seed: int) -> SaltelliDesign:
    """Saltelli design for first-order and total Sobol indices on the unit hypercube.

    Parameters
    ----------
    n : int
        Base sample size, a power of 2 (>= 2); the design has ``n (d + 2)`` points.
    d : int
        Number of inputs, >= 1.
    seed : int
        Seed of the scrambling (same seed, same design).

    Returns
    -------
    SaltelliDesign
        ``A`` and ``B`` (n, d) are the two halves of one ``2 d``-dimensional scrambled
        Sobol sequence; ``AB`` (d, n, d) the radial matrices. Values in [0, 1).

    Notes
    -----
    Saltelli (2002) and Saltelli et al. (2010, section 3): taking ``A`` and ``B`` from the
    first and last ``d`` coordinates of one quasi-random sequence of dimension ``2 d``
    keeps them independent of each other. ``n`` must be a power of two because only
    then does a scrambled Sobol sequence keep its balance (``random_base2``); no
    rounding is done silently. Second-order indices are not offered.
    """
    m = _pow2(n)
    if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1:
        raise ValueError(f"d must be an integer >= 1, got {d!r}")
    base = qmc.Sobol(2 * int(d), scramble=True, rng=np.random.default_rng(seed)).random_base2(m)
    A = np.ascontiguousarray(base[:, :d])
    B = np.ascontiguousarray(base[:, d:])
    AB = np.repeat(A[None, :, :], d, axis=0)
    for i in range(d):
        AB[i, :, i] = B[:, i]
    return SaltelliDesign(A, B, AB)


def split_saltelli(y: ArrayLike, d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Take the outputs at the rows of :meth:`SaltelliDesign.stack` apart.

    Parameters
    ----------
    y : (n (d + 2),) float array
        Outputs in the row order of the stacked matrix.
    d : int
        Number of inputs, >= 1.

    Returns
    -------
    yA, yB : (n,) float64 array
        Outputs at the rows of ``A`` and ``B``.
    yAB : (d, n) float64 array
        ``yAB[i]`` holds the outputs at ``AB[i]``.

    Raises
    ------
    ValueError
        If ``y`` does not hold a whole number of ``d + 2``-row blocks.
    """
    v = np.asarray(y, dtype=np.float64).ravel()
    if d < 1 or v.size % (d + 2):
        raise ValueError(f"y has {v.size} values, not a multiple of d + 2 = {d + 2}")
    blocks = v.reshape(-1, d + 2)
    return blocks[:, 0].copy(), blocks[:, d + 1].copy(), np.ascontiguousarray(blocks[:, 1 : d + 1].T)


def _sobol_point(yA: np.ndarray, yB: np.ndarray, yAB: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S1, ST over the last axis; leading axes broadcast (bootstrap replicates)."""
    pooled = np.concatenate([yA, yB], axis=-1)
    var = np.var(pooled, axis=-1)
    # centred on the pooled mean f0: the estimator is then shift-invariant, and its
    # variance no longer grows with f0^2 (docs/libraries.md measures the difference)
    f0 = np.mean(pooled, axis=-1, keepdims=True)
    first = np.mean((yB - f0)[..., None, :] * (yAB - yA[..., None, :]), axis=-1)
    total = 0.5 * np.mean((yA[..., None, :] - yAB) ** 2, axis=-1)
    ok = var > 0.0
    v = np.where(ok, var, 1.0)[..., None]
    s1 = np.where(ok[..., None], first / v, np.nan)
    st = np.where(ok[..., None], total / v, np.nan)
    return s1, st, var


def sobol_indices(
    yA: ArrayLike,
    yB: ArrayLike,
    yAB: ArrayLike,
    *,
    names: Sequence[str] | None = None,
    n_boot: int = 1000,
    level: float = 0.95,
    seed: int = 0,
) -> xr.Dataset:
    """First-order and total Sobol indices with bootstrap confidence intervals.

    Parameters
    ----------
    yA, yB : (n,) float arrays
        Model outputs at the rows of ``A`` and ``B`` (:func:`saltelli_design`).
    yAB : (d, n) float array
        Outputs at ``AB[i]`` (``A`` with column ``i`` from ``B``).
    names : sequence of d str, optional
        Parameter names (default ``x1 ... xd``).
    n_boot : int
        Bootstrap replicates (rows resampled with replacement), >= 0; 0 skips the
        intervals (they are NaN).
    level : float
        Confidence level of the percentile intervals, in (0, 1).
    seed : int
        Seed of the bootstrap resampling.

    Returns
    -------
    Dataset
        Dim ``parameter``: ``S1``, ``ST`` with ``*_lower``/``*_upper`` (percentile
        bootstrap interval) and ``*_se`` (bootstrap standard deviation). Attributes
        ``n_used`` (rows used), ``n_dropped`` (rows with a non-finite output, dropped),
        ``variance`` (output variance), ``n_boot``, ``confidence_level``.

    Notes
    -----
    With ``f0`` and ``V`` the mean and variance of the pooled ``yA`` and ``yB``:

    - first order (Saltelli et al. 2010, table 2 (b), on outputs centred by ``f0``, as
      SALib does): ``S1_i = mean((yB - f0) (yAB_i - yA)) / V``;
    - total (Jansen 1999; Saltelli et al. 2010, table 2 (f)):
      ``ST_i = mean((yA - yAB_i)^2) / (2 V)``.

    A row ``j`` (``yA[j]``, ``yB[j]`` and every ``yAB[i, j]``) is dropped when any of its
    outputs is NaN or infinite (a failed run), which keeps the estimators' pairing. The
    bootstrap resamples whole rows (Archer et al. 1997). Both estimators are unbiased
    but not bounded: small indices can come out slightly negative.
    """
    a = np.asarray(yA, dtype=np.float64).ravel()
    b = np.asarray(yB, dtype=np.float64).ravel()
    ab = np.asarray(yAB, dtype=np.float64)
    if ab.ndim == 1:
        ab = ab[None, :]
    if a.size != b.size or ab.ndim != 2 or ab.shape[1] != a.size:
        raise ValueError(f"need yA (n,), yB (n,) and yAB (d, n); got {a.shape}, {b.shape}, {ab.shape}")
    d = ab.shape[0]
    labels = [f"x{i + 1}" for i in range(d)] if names is None else [str(s) for s in names]
    if len(labels) != d:
        raise ValueError(f"names has {len(labels)} entries for d = {d} inputs")
    if not (0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 0:
        raise ValueError(f"n_boot must be an integer >= 0, got {n_boot!r}")
    keep = np.isfinite(a) & np.isfinite(b) & np.all(np.isfinite(ab), axis=0)
    n_dropped = int(a.size - np.count_nonzero(keep))
    a, b, ab = a[keep], b[keep], ab[:, keep]
    n = a.size
    if n < 2:
        raise ValueError(f"{n} complete rows after dropping {n_dropped} with non-finite outputs; need at least 2")
    s1, st, var = _sobol_point(a, b, ab)
    if not var > 0.0:
        raise ValueError("the output is constant over the design: Sobol indices are undefined")

    lo1 = hi1 = lot = hit = se1 = set_ = np.full(d, np.nan)
    n_bad = 0
    if n_boot:
        rng = np.random.default_rng(seed)
        chunk = max(1, _BOOT_ELEMENTS // (n * (d + 2)))
        boot1 = np.empty((n_boot, d))
        boott = np.empty((n_boot, d))
        for start in range(0, n_boot, chunk):
            stop = min(n_boot, start + chunk)
            idx = rng.integers(0, n, size=(stop - start, n))
            b1, bt, _ = _sobol_point(a[idx], b[idx], np.moveaxis(ab[:, idx], 0, 1))
            boot1[start:stop], boott[start:stop] = b1, bt
        good = np.all(np.isfinite(boot1), axis=1) & np.all(np.isfinite(boott), axis=1)
        n_bad = int(n_boot - np.count_nonzero(good))  # replicates with constant output
        if np.count_nonzero(good) >= 2:
            q = [0.5 * (1.0 - level), 0.5 * (1.0 + level)]
            lo1, hi1 = np.quantile(boot1[good], q, axis=0)
            lot, hit = np.quantile(boott[good], q, axis=0)
            se1 = np.std(boot1[good], axis=0, ddof=1)
            set_ = np.std(boott[good], axis=0, ddof=1)

    pct = f"{100 * float(level):g}%"
    dim = ("parameter",)

    def var_(x: np.ndarray, long: str) -> tuple[tuple[str], np.ndarray, dict[str, str]]:
        return (dim, np.asarray(x, dtype=np.float64), {"units": "1", "long_name": long})

    ds = xr.Dataset(
        {
            "S1": var_(s1, "first-order Sobol index (Saltelli et al. 2010 estimator, centred outputs)"),
            "S1_lower": var_(lo1, f"lower bound of the {pct} bootstrap percentile interval of S1"),
            "S1_upper": var_(hi1, f"upper bound of the {pct} bootstrap percentile interval of S1"),
            "S1_se": var_(se1, "bootstrap standard error of S1"),
            "ST": var_(st, "total Sobol index (Jansen 1999 estimator)"),
            "ST_lower": var_(lot, f"lower bound of the {pct} bootstrap percentile interval of ST"),
            "ST_upper": var_(hit, f"upper bound of the {pct} bootstrap percentile interval of ST"),
            "ST_se": var_(set_, "bootstrap standard error of ST"),
        },
        coords={"parameter": ("parameter", np.asarray(labels, dtype=str), SENSITIVITY_COORD_ATTRS["parameter"])},
        attrs={
            "title": "variance-based sensitivity indices",
            "n_used": int(n),
            "n_dropped": n_dropped,
            "variance": float(var),
            "n_boot": int(n_boot),
            "n_boot_degenerate": n_bad,
            "confidence_level": float(level),
            "bootstrap_seed": int(seed),
            "S1_estimator": "mean((yB - f0) * (yAB_i - yA)) / V, f0 = mean of yA and yB (Saltelli et al. 2010)",
            "ST_estimator": "mean((yA - yAB_i)**2) / (2 V) (Jansen 1999)",
        },
    )
    return ds
