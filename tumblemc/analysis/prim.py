"""Scenario discovery with PRIM: where in parameter space the robot fails (analysis layer).

:func:`prim_box` peels a box of parameter space where a target outcome concentrates
(Friedman & Fisher 1999) from any array of inputs and outcomes; :func:`failure_region`
applies it to one cell of a study's runs, with the failures to climb as targets. The
result, :class:`PrimResult`, holds the chosen box and the whole peeling trajectory
(coverage against density), which :func:`tumblemc.viz.sensitivity.plot_prim` draws.

Nothing here runs the simulator. :func:`tumblemc.testing.box_failure` is a benchmark with
a known box.

References
----------
Friedman, J. H. & Fisher, N. I. (1999). Bump hunting in high-dimensional data.
Statistics and Computing 9, 123-143.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from tumblemc.analysis.screening import cell_mask, uncertain_parameters, valid_mask


@dataclass(frozen=True)
class PrimResult:
    """Outcome of :func:`prim_box`.

    ``box`` maps each parameter the chosen box restricts to ``(lo, hi)`` (``-inf``/``inf``
    on a side never peeled); a point is inside when ``lo < x < hi`` for every entry.
    ``coverage``: fraction of all target points inside; ``density``: fraction of the
    points inside that are targets; ``support``: fraction of all points inside;
    ``step``: the chosen step of ``trajectory`` (dims ``step``, ``parameter``).
    """

    box: dict[str, tuple[float, float]]
    coverage: float
    density: float
    support: float
    step: int
    names: tuple[str, ...]
    trajectory: xr.Dataset = field(repr=False)

    def contains(self, X: ArrayLike) -> np.ndarray:
        """Boolean mask of the rows of ``X`` (columns in ``names`` order) inside the box."""
        x = np.asarray(X, dtype=np.float64)
        inside = np.ones(x.shape[0], dtype=bool)
        for name, (lo, hi) in self.box.items():
            j = self.names.index(name)
            inside &= (x[:, j] > lo) & (x[:, j] < hi)
        return inside


def _choose(density: np.ndarray, n_box: np.ndarray, threshold: float | None) -> tuple[int, str]:
    if threshold is not None:
        hit = np.flatnonzero(density >= threshold)
        if hit.size:
            return int(hit[0]), f"first box with density >= {threshold:g}"
    k = int(np.argmax(density))
    d_max = float(density[k])
    tol = math.sqrt(d_max * (1.0 - d_max) / float(n_box[k]))
    first = int(np.flatnonzero(density >= d_max - tol - 1e-12)[0])
    rule = "first box within one binomial standard error of the peak density (1-SE rule)"
    if threshold is not None:
        rule = f"no box reaches density {threshold:g}; {rule}"
    return first, rule


def prim_box(
    X: ArrayLike,
    y: ArrayLike,
    names: Sequence[str],
    *,
    alpha: float = 0.05,
    min_support: float = 0.05,
    target: float = 1,
    threshold: float | None = None,
) -> PrimResult:
    """Peel a box of parameter space where ``y == target`` concentrates (PRIM).

    Parameters
    ----------
    X : (n, d) array_like of float
        Inputs, all finite, columns in ``names`` order.
    y : (n,) array_like
        Outcomes; the points with ``y == target`` are the targets (e.g. failures).
    names : sequence of d str
        Parameter names.
    alpha : float
        Fraction of the box's points peeled per step, in (0, 0.5).
    min_support : float
        Peeling stops before the box holds fewer than this fraction of all points, in
        (0, 1).
    target : float
        The outcome value sought.
    threshold : float, optional
        Choose the first (largest) box whose density reaches this. None (or when no box
        does): the first box whose density is within one binomial standard error of the
        peak density along the trajectory.

    Returns
    -------
    PrimResult
        The chosen box (only the parameters actually peeled), its coverage, density and
        support, and the whole ``trajectory`` Dataset (dim ``step``; ``coverage``,
        ``density``, ``support``, ``n_in_box``, ``peeled_parameter``, ``peeled_side``;
        ``lower``/``upper`` with dims ``(step, parameter)``; ``attrs["chosen_step"]``).

    Notes
    -----
    Friedman & Fisher (1999, section 4.1), top-down peeling without pasting: at each
    step every dimension is cut at its ``alpha`` (lower side) or ``1 - alpha`` (upper
    side) quantile among the points in the box, and the cut leaving the highest target
    density is kept (ties: the one removing fewer points, then the first dimension).
    Cuts that remove nothing (ties) or leave less than ``min_support`` are not allowed.
    Bounds lie midway between the last point removed and the first point kept, so the
    open box selects exactly the points kept.
    """
    x = np.asarray(X, dtype=np.float64)
    lab = [str(s) for s in names]
    if x.ndim != 2 or x.shape[1] != len(lab):
        raise ValueError(f"X must have shape (n, {len(lab)}) to match names, got {x.shape}")
    yv = np.asarray(y).ravel()
    if yv.size != x.shape[0]:
        raise ValueError(f"y has {yv.size} values for {x.shape[0]} rows of X")
    if not np.all(np.isfinite(x)):
        raise ValueError("X must be finite (drop invalid runs first)")
    if not (0.0 < alpha < 0.5):
        raise ValueError(f"alpha must be in (0, 0.5), got {alpha!r}")
    if not (0.0 < min_support < 1.0):
        raise ValueError(f"min_support must be in (0, 1), got {min_support!r}")
    t = yv == target
    n, d = x.shape
    n_t = int(np.count_nonzero(t))
    if n_t == 0:
        raise ValueError(f"no point has y == {target!r}: there is nothing to find")
    inbox = np.ones(n, dtype=bool)
    lo = np.full(d, -np.inf)
    hi = np.full(d, np.inf)
    steps: list[tuple[int, int, np.ndarray, np.ndarray, str, str]] = [(n, n_t, lo.copy(), hi.copy(), "", "")]
    n_min = math.ceil(min_support * n - 1e-9)
    while True:
        nb = int(np.count_nonzero(inbox))
        k = max(1, math.ceil(alpha * nb - 1e-9))
        xb, tb = x[inbox], t[inbox]
        # ((density, -removed, -j, -side), kept rows, bound) of the best peel so far
        best: tuple[tuple[float, int, int, int], np.ndarray, float] | None = None
        for j in range(d if k < nb else 0):
            s = np.sort(xb[:, j])
            for side in (0, 1):
                if side == 0:
                    cut = s[k]
                    keep = xb[:, j] >= cut
                else:
                    cut = s[nb - 1 - k]
                    keep = xb[:, j] <= cut
                kept = int(np.count_nonzero(keep))  # >= 1: the cut point itself stays
                if kept == nb or kept < n_min:  # nothing peeled (ties), or too small a box
                    continue
                # something was peeled: the bound lies midway to the nearest peeled point
                bound = 0.5 * (s[s < cut][-1] + cut) if side == 0 else 0.5 * (s[s > cut][0] + cut)
                key = (int(np.count_nonzero(tb[keep])) / kept, -(nb - kept), -j, -side)
                if best is None or key > best[0]:
                    best = (key, keep, float(bound))
        if best is None:
            break
        key, keep, bound = best
        j, side = -key[2], -key[3]
        where = np.flatnonzero(inbox)
        inbox[where[~keep]] = False
        if side == 0:
            lo[j] = bound
        else:
            hi[j] = bound
        steps.append(
            (int(np.count_nonzero(inbox)), int(np.count_nonzero(t & inbox)), lo.copy(), hi.copy(), lab[j], ("lower", "upper")[side])
        )

    n_box = np.array([s[0] for s in steps], dtype=np.int64)
    n_tb = np.array([s[1] for s in steps], dtype=np.int64)
    density = n_tb / n_box
    coverage = n_tb / n_t
    support = n_box / n
    chosen, rule = _choose(density, n_box, threshold)
    lower = np.array([s[2] for s in steps])
    upper = np.array([s[3] for s in steps])
    box = {
        lab[j]: (float(lower[chosen, j]), float(upper[chosen, j]))
        for j in range(d)
        if np.isfinite(lower[chosen, j]) or np.isfinite(upper[chosen, j])
    }
    step = ("step",)
    traj = xr.Dataset(
        {
            "coverage": (step, coverage, {"units": "1", "long_name": "fraction of all target points inside the box"}),
            "density": (step, density, {"units": "1", "long_name": "fraction of the points inside the box that are targets"}),
            "support": (step, support, {"units": "1", "long_name": "fraction of all points inside the box"}),
            "n_in_box": (step, n_box, {"units": "1", "long_name": "points inside the box"}),
            "n_target_in_box": (step, n_tb, {"units": "1", "long_name": "target points inside the box"}),
            "peeled_parameter": (step, np.asarray([s[4] for s in steps], dtype=str), {"long_name": "parameter cut at this step"}),
            "peeled_side": (step, np.asarray([s[5] for s in steps], dtype=str), {"long_name": "side of the cut (lower or upper)"}),
            "lower": (
                ("step", "parameter"),
                lower,
                {"units": "units of the parameter", "long_name": "lower bound of the box (-inf: open)"},
            ),
            "upper": (("step", "parameter"), upper, {"units": "units of the parameter", "long_name": "upper bound of the box (inf: open)"}),
        },
        coords={
            "step": ("step", np.arange(len(steps)), {"long_name": "peeling step"}),
            "parameter": ("parameter", np.asarray(lab, dtype=str)),
        },
        attrs={
            "title": "PRIM peeling trajectory (Friedman & Fisher 1999)",
            "chosen_step": int(chosen),
            "selection": rule,
            "alpha": float(alpha),
            "min_support": float(min_support),
            "target": f"y == {target!r}",
            "n_points": int(n),
            "n_target": n_t,
        },
    )
    return PrimResult(box, float(coverage[chosen]), float(density[chosen]), float(support[chosen]), int(chosen), tuple(lab), traj)


def failure_region(
    runs: xr.Dataset,
    shape: str,
    substrate: str,
    incline_deg: float,
    *,
    field_mT: float | None = None,
    freq_hz: float | None = None,
    parameters: Sequence[str] | None = None,
    alpha: float = 0.05,
    min_support: float = 0.05,
    threshold: float | None = None,
) -> PrimResult:
    """PRIM box of the parameter region where a study cell's valid runs fail to climb.

    Parameters
    ----------
    runs : Dataset
        Study runs (dim ``run``): ``status``, ``climbed``, the cell coordinates and the
        uncertain parameters.
    shape, substrate : str
        The cell's shape and substrate.
    incline_deg : float
        The cell's incline, degree.
    field_mT, freq_hz : float, optional
        The field setting (mT, Hz); needed when the study sweeps it.
    parameters : sequence of str, optional
        Parameter names (default ``runs.attrs["uncertain"]``).
    alpha, min_support, threshold : float
        See :func:`prim_box`.

    Returns
    -------
    PrimResult
        Targets are the valid runs (``status == 0``) with ``climbed == 0``; the box
        bounds are in the units of each parameter.
    """
    params = uncertain_parameters(runs, parameters)
    mask = cell_mask(runs, shape, substrate, incline_deg, field_mT=field_mT, freq_hz=freq_hz) & valid_mask(runs)
    X = np.column_stack([np.asarray(runs[v].values, dtype=np.float64)[mask] for _, v in params])
    failed = np.asarray(runs["climbed"].values)[mask] == 0
    ok = np.all(np.isfinite(X), axis=1)
    res = prim_box(X[ok], failed[ok], [p for p, _ in params], alpha=alpha, min_support=min_support, target=True, threshold=threshold)
    res.trajectory.attrs.update(
        {"target": "valid run that did not climb", "shape": shape, "substrate": substrate, "incline_deg": float(incline_deg)}
    )
    return res
