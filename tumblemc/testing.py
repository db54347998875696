"""Analytic benchmark problems shared by tests, docs and studies (model level).

Every function here has a known answer, so an estimator can be checked against it:

- :func:`ishigami` with :func:`ishigami_indices`: the standard non-additive benchmark of
  variance-based sensitivity analysis (Ishigami & Homma 1990), closed-form first-order
  and total Sobol indices.
- :func:`linear_additive` with :func:`linear_indices`: an additive model where first
  order and total indices are equal and known.
- :func:`box_failure` with :data:`BOX_FAILURE_BOX`: a binary outcome that is 1 exactly in
  a known axis-aligned box (the answer scenario discovery / PRIM should find), with its
  closed-form Sobol indices :func:`box_failure_indices` (a 0/1 benchmark).
- :data:`SNAP_HOP` and :data:`REPRODUCERS`: physics scenarios that broke the solver once
  (the snap hop: a flat aluminum cuboid thrown off by ten times the adhesion; two 3-D
  tilts), shared by the solver's tests, the validation and the stress campaign.
- :func:`synthetic_runs`: a study ``runs`` Dataset (the schema of
  :mod:`tumblemc.analysis`) whose outcome depends on ``mu`` only, with an all-success cell,
  a perfectly separated cell and invalid runs.

Nothing here runs the simulator, and nothing here imports above the model layer, so
every layer's tests can use it.

References
----------
Ishigami, T. & Homma, T. (1990). An importance quantification technique in uncertainty
analysis for computer models. ISUMA '90, 398-403.
Sobol', I. M. (2001). Global sensitivity indices for nonlinear mathematical models and
their Monte Carlo estimates. Math. Comput. Simul. 55, 271-280.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any, TypedDict

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy.special import expit

#: input domain of :func:`ishigami`: each of the three inputs is uniform on [-pi, pi]
ISHIGAMI_BOUNDS: tuple[tuple[float, float], ...] = ((-math.pi, math.pi),) * 3
#: the failure box of :func:`box_failure` on the unit cube: ``{column: (lo, hi)}``
BOX_FAILURE_BOX: dict[int, tuple[float, float]] = {0: (0.7, 1.0), 1: (0.0, 0.3)}


def _matrix(X: ArrayLike, d: int | None = None) -> np.ndarray:
    x = np.asarray(X, dtype=np.float64)
    if x.ndim != 2 or (d is not None and x.shape[1] != d):
        want = f"(n, {d})" if d is not None else "(n, d)"
        raise ValueError(f"X must be a 2-D array of shape {want}, got shape {x.shape}")
    return x


def ishigami(X: ArrayLike, a: float = 7.0, b: float = 0.1) -> np.ndarray:
    """Ishigami function ``sin x1 + a sin^2 x2 + b x3^4 sin x1``.

    Parameters
    ----------
    X : (n, 3) float array
        Inputs, each uniform on [-pi, pi] (:data:`ISHIGAMI_BOUNDS`).
    a, b : float
        Coefficients (the usual values 7 and 0.1).

    Returns
    -------
    (n,) float64 array
    """
    x = _matrix(X, 3)
    return np.sin(x[:, 0]) + a * np.sin(x[:, 1]) ** 2 + b * x[:, 2] ** 4 * np.sin(x[:, 0])


def ishigami_indices(a: float = 7.0, b: float = 0.1) -> dict[str, np.ndarray]:
    """Closed-form Sobol indices of :func:`ishigami` with inputs uniform on [-pi, pi]^3.

    Returns
    -------
    dict
        ``S1`` and ``ST``: (3,) float64 arrays of first-order and total indices, and ``V``
        (0-d array): the variance of the output.

    Notes
    -----
    With ``V1 = (1 + b pi^4 / 5)^2 / 2``, ``V2 = a^2 / 8``, ``V3 = 0`` and the only
    interaction ``V13 = 8 b^2 pi^8 / 225``, ``V = V1 + V2 + V13``; ``S1_i = V_i / V``,
    ``ST_1 = (V1 + V13) / V``, ``ST_2 = V2 / V``, ``ST_3 = V13 / V`` (Sobol' 2001).
    For ``a = 7, b = 0.1``: ``S1 = (0.3139, 0.4424, 0)``, ``ST = (0.5576, 0.4424, 0.2437)``.
    """
    pi4 = math.pi**4
    v1 = 0.5 * (1.0 + b * pi4 / 5.0) ** 2
    v2 = a * a / 8.0
    v13 = 8.0 * b * b * pi4 * pi4 / 225.0
    v = v1 + v2 + v13
    return {
        "S1": np.array([v1 / v, v2 / v, 0.0]),
        "ST": np.array([(v1 + v13) / v, v2 / v, v13 / v]),
        "V": np.asarray(v),
    }


def linear_additive(X: ArrayLike, coefficients: Sequence[float]) -> np.ndarray:
    """Additive model ``sum_i c_i x_i`` with inputs uniform on [0, 1].

    Parameters
    ----------
    X : (n, d) array_like of float
        Inputs on the unit cube.
    coefficients : sequence of d float
        The coefficients ``c_i``.

    Returns
    -------
    (n,) float64 array
    """
    c = np.asarray(coefficients, dtype=np.float64)
    x = _matrix(X, c.size)
    return x @ c


def linear_indices(coefficients: Sequence[float]) -> dict[str, np.ndarray]:
    """Sobol indices of :func:`linear_additive`: ``S1 = ST = c_i^2 / sum c^2``.

    Returns
    -------
    dict
        ``S1`` and ``ST`` (equal (d,) arrays; no interactions), ``V = sum c^2 / 12``.
    """
    c = np.asarray(coefficients, dtype=np.float64)
    c2 = c * c
    total = float(c2.sum())
    if total <= 0.0:
        raise ValueError("coefficients must not all be zero (the output would be constant)")
    s = c2 / total
    return {"S1": s, "ST": s.copy(), "V": np.asarray(total / 12.0)}


def box_failure(X: ArrayLike, box: Mapping[int, tuple[float, float]] | None = None) -> np.ndarray:
    """1 where the point lies in an axis-aligned box, else 0 (a known failure region).

    Parameters
    ----------
    X : (n, d) array_like of float
        Inputs on the unit cube.
    box : mapping of int to (float, float), optional
        ``{column: (lo, hi)}``; columns not named are unrestricted. Default
        :data:`BOX_FAILURE_BOX`: ``x1 > 0.7 and x2 < 0.3`` (columns 0 and 1), support 0.09
        for uniform inputs.

    Returns
    -------
    (n,) int8 array
    """
    x = _matrix(X)
    inside = np.ones(x.shape[0], dtype=bool)
    for j, (lo, hi) in (BOX_FAILURE_BOX if box is None else box).items():
        inside &= (x[:, j] > lo) & (x[:, j] < hi)
    return inside.astype(np.int8)


def box_failure_indices(d: int = 3, box: Mapping[int, tuple[float, float]] | None = None) -> dict[str, np.ndarray]:
    """Closed-form Sobol indices of :func:`box_failure` with inputs uniform on [0, 1]^d.

    Parameters
    ----------
    d : int
        Number of inputs (columns outside the box have indices 0).
    box : mapping of int to (float, float), optional
        As :func:`box_failure` (default :data:`BOX_FAILURE_BOX`).

    Returns
    -------
    dict
        ``S1``, ``ST``: (d,) float64 arrays; ``V`` (0-d array): the output variance.

    Notes
    -----
    With ``p_i = hi_i - lo_i`` and ``P = prod p_i``, the output is Bernoulli(``P``), so
    ``V = P (1 - P)``; ``E[y | x_i] = 1_i P / p_i`` gives ``S1_i = P (1 - p_i) / (p_i (1 - P))``
    and ``E[Var(y | x_~i)] = P (1 - p_i)`` gives ``ST_i = (1 - p_i) / (1 - P)``. A 0/1
    benchmark for the estimators on a success/failure verdict.
    """
    b = BOX_FAILURE_BOX if box is None else box
    p = {j: hi - lo for j, (lo, hi) in b.items()}
    P = math.prod(p.values())
    s1, st = np.zeros(d), np.zeros(d)
    for j, pj in p.items():
        s1[j] = P * (1.0 - pj) / (pj * (1.0 - P))
        st[j] = (1.0 - pj) / (1.0 - P)
    return {"S1": s1, "ST": st, "V": np.asarray(P * (1.0 - P))}


class Cell(TypedDict):
    """A study cell by its coordinates (``incline_deg`` in degree)."""

    shape: str
    substrate: str
    incline_deg: float


#: cells of :func:`synthetic_runs` with a special outcome
SYNTHETIC_ALL_SUCCESS: Cell = {"shape": "cuboid", "substrate": "paper", "incline_deg": 0.0}
SYNTHETIC_SEPARATED: Cell = {"shape": "cuboid", "substrate": "aluminum", "incline_deg": 30.0}


def synthetic_runs(
    seed: int = 0,
    per_cell: int = 400,
    *,
    slope: float = 3.0,
    shapes: Sequence[str] = ("cuboid", "curved"),
    substrates: Sequence[str] = ("paper", "aluminum"),
    inclines: Sequence[float] = (0.0, 30.0),
    invalid_fraction: float = 0.03,
) -> xr.Dataset:
    """A study ``runs`` Dataset whose outcome depends on ``mu`` only (monotone increasing).

    Parameters
    ----------
    seed : int
        Root seed of the draws.
    per_cell : int
        Runs per cell.
    slope : float
        Log-odds of climbing per standard deviation of ``mu`` (the true standardized
        logistic coefficient); the other parameters have coefficient 0.
    shapes, substrates : sequence of str
        Cell grid.
    inclines : sequence of float
        Cell grid, degree (every cell has ``field_mT = 20``, ``freq_hz = 1``).
    invalid_fraction : float
        Fraction of runs with ``status = 1`` (NaN progress ratio, not climbed), drawn
        independently of the parameters.

    Returns
    -------
    Dataset
        Dim ``run``; coordinates ``shape``, ``substrate``, ``incline_deg``, ``field_mT``,
        ``freq_hz``, ``sample``; uncertain parameters ``adhesion_C``, ``magnetization``,
        ``mu``, ``offset_deg`` (``attrs["uncertain"]``); outcomes ``progress_ratio``
        (increasing linearly in ``mu`` plus Gaussian noise), ``climbed`` ~
        Bernoulli(``expit(slope * z_mu)``) with ``z_mu`` the standardized ``mu`` (drawn
        apart from ``progress_ratio``: each outcome is its own benchmark), ``status``,
        ``mean_speed``. In the cell
        :data:`SYNTHETIC_ALL_SUCCESS` every valid run climbs; in
        :data:`SYNTHETIC_SEPARATED` a run climbs exactly when ``mu`` exceeds its nominal
        value (complete separation).
    """
    rng = np.random.default_rng(seed)
    rows = list(itertools.product(shapes, substrates, inclines, range(per_cell)))
    n = len(rows)
    shape = np.array([r[0] for r in rows])
    substrate = np.array([r[1] for r in rows])
    incline = np.array([r[2] for r in rows], dtype=np.float64)
    sample = np.array([r[3] for r in rows], dtype=np.int64)
    mu_nom, mu_sd = 0.3, 0.045
    z = rng.standard_normal((n, 4))
    mu = mu_nom + mu_sd * z[:, 0]
    adhesion = 3.7 * np.exp(0.3 * z[:, 1] - 0.045)
    magnetization = 15000.0 * (1.0 + 0.1 * z[:, 2])
    offset = 27.0 + 5.0 * z[:, 3]
    p = expit(slope * z[:, 0])
    climbed = (rng.uniform(size=n) < p).astype(np.int8)
    ratio = 0.5 + 0.25 * slope * z[:, 0] / (1.0 + abs(slope)) + rng.normal(0.0, 0.05, n)

    def in_cell(c: Cell) -> np.ndarray:
        return (shape == c["shape"]) & (substrate == c["substrate"]) & (incline == c["incline_deg"])

    easy = in_cell(SYNTHETIC_ALL_SUCCESS)
    climbed[easy] = 1
    ratio[easy] = 0.9 + 0.02 * z[easy, 0]
    sep = in_cell(SYNTHETIC_SEPARATED)
    climbed[sep] = (mu[sep] > mu_nom).astype(np.int8)
    status = (rng.uniform(size=n) < invalid_fraction).astype(np.int8)
    ratio[status != 0] = np.nan
    climbed[status != 0] = 0
    run = ("run",)
    return xr.Dataset(
        {
            "mu": (run, mu, {"units": "1", "long_name": "sampled friction coefficient"}),
            "adhesion_C": (run, adhesion, {"units": "N/m^2", "long_name": "sampled adhesion per contact area"}),
            "magnetization": (run, magnetization, {"units": "A/m", "long_name": "sampled magnetisation"}),
            "offset_deg": (run, offset, {"units": "degree", "long_name": "sampled magnetisation offset angle"}),
            "progress_ratio": (run, ratio, {"units": "1", "long_name": "progress ratio"}),
            "mean_speed": (run, ratio * 1e-4, {"units": "m s-1", "long_name": "mean uphill speed"}),
            "climbed": (run, climbed, {"long_name": "climbed (1) or not (0)"}),
            "status": (run, status, {"long_name": "run status (0 = valid)"}),
        },
        coords={
            "run": np.arange(n),
            "shape": (run, shape),
            "substrate": (run, substrate),
            "incline_deg": (run, incline, {"units": "degree"}),
            "field_mT": (run, np.full(n, 20.0), {"units": "mT"}),
            "freq_hz": (run, np.full(n, 1.0), {"units": "Hz"}),
            "sample": (run, sample),
        },
        attrs={"uncertain": "adhesion_C,magnetization,mu,offset_deg", "success_ratio": 0.5, "title": "synthetic mu-only study"},
    )


__all__ = [
    "BOX_FAILURE_BOX",
    "ISHIGAMI_BOUNDS",
    "SYNTHETIC_ALL_SUCCESS",
    "SYNTHETIC_SEPARATED",
    "Cell",
    "box_failure",
    "box_failure_indices",
    "ishigami",
    "ishigami_indices",
    "linear_additive",
    "linear_indices",
    "synthetic_runs",
]


#: the snap hop: the aluminum cuboid flat, ten times the adhesion, a strong slow field (its
#: face lets go and the adhesion throws it up: simulate keywords)
#: the step the snap hop was found at (5e-5 s; at 36.8 mT the default step is now 2.5e-5 s,
#: model/step_size.py): its reproducers run at it
SNAP_HOP_DT = 5e-5
SNAP_HOP = {
    "preset": "aluminum",
    "incline_deg": 0.0,
    "field_mT": 36.7659,
    "freq_hz": 0.5,
    "mu": 0.9557,
    "adhesion_C": 243.2243,
    "offset_deg": 27.4907,
}

#: the solver's reproducers: (name, simulate keywords), run by the stress campaign
REPRODUCERS: list[tuple[str, dict[str, Any]]] = [
    ("R1 snap hop", {"shape": "cuboid", "duration_s": 4.0, "dt": SNAP_HOP_DT, **SNAP_HOP}),
    ("R2a tilt about z", {"preset": "aluminum", "incline_deg": 0.0, "duration_s": 2.0, "offset_deg": 30.0, "offset_axis": (0.0, 0.0, 1.0)}),
    (
        "R2b tilt about (1,0,1)",
        {"preset": "aluminum", "incline_deg": 0.0, "duration_s": 2.0, "offset_deg": 27.0, "offset_axis": (0.7071, 0.0, 0.7071)},
    ),
]
