"""Is one run's answer set by its step size, or by nothing? The single-run step check.

A study audits its step with a share of its runs (the dt check, docs/guide/study_results.md);
a single :func:`~tumblemc.model.run.simulate` has no such audit, and beyond the paper's
operating points (strong fields, high frequencies) its progress ratio can move with the step
while the run's status stays ok (docs/notes/step_size.md). :func:`check_step` runs the same
inputs

- at the run's own step ``dt`` (the default, or the caller's),
- at ``dt / factor`` (default 4, as a study's check), and
- ``twins`` times more at ``dt``, each with the magnetisation vector changed by ``twin_rel``
  (default 1e-6) of itself: twin ``i`` of ``n`` turns it by ``2 pi i / n`` on the circle
  of magnitude and offset angle, so the magnitude changes by ``twin_rel cos`` and the offset
  angle by ``twin_rel sin`` (radians). Two twins are the study's (the magnitude x (1 +-
  twin_rel)); the default four add the offset angle +- twin_rel;

and classes the run (:func:`classify`) with the study's tolerance (``ratio_abs_tol +
ratio_rel_tol x |fine ratio|``, 0.05 + 10%), the finer step's move ``|fine - ratio|`` and the
twins' largest move ``max |twin - ratio|``:

- ``sensitive``: a 1e-6 change of the magnetisation moves the ratio beyond the tolerance and
  at least as far as the finer step does (the twins move it as much as the step ladder
  does). The model does not determine this run's ratio to the tolerance and no step
  can; the distribution of its neighbours (an ensemble, a study) is the answer;
- ``limited by dt``: the finer step moves the ratio beyond the tolerance, farther than any
  twin does: the step, not the model, sets the answer; a finer ``dt`` gives a better one;
- ``within tolerance``: neither moves it beyond the tolerance (at this one finer step: a
  run whose ratio drifts slowly with the step can pass, docs/notes/step_size.md);
- ``not checked``: the run, or the run at the finer step, is not valid (its status says why).

The study's dt check classes a run outside the tolerance as sensitive when its two twins
move it beyond the tolerance. Here, where the finer step's move is known, the twins must also
move it as far as that: a run whose twins move it by 0.15 while the finer step moves it by
0.25 is limited by the step (docs/notes/step_size.md, "Single runs": the paper cuboid at
200 Hz).
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.model.outcome import summarize
from tumblemc.model.params import check_number
from tumblemc.model.run import run_inputs, simulate

#: the classes of a checked run (the attribute ``step_check_class``)
CLASSES = ("within tolerance", "limited by dt", "sensitive", "not checked")
#: the study's dt-check tolerance (``[check]`` ``ratio_abs_tol``, ``ratio_rel_tol``)
RATIO_ABS_TOL = 0.05
RATIO_REL_TOL = 0.1
#: the records per run kept for the check's figure (a longer run is strided down to it)
MAX_CURVE_POINTS = 20000
#: simulate's positional parameters, in order
POSITIONAL = ("shape", "preset", "incline_deg", "field_mT", "freq_hz", "duration_s", "dt")


def tolerance(fine_ratio: Any, abs_tol: float = RATIO_ABS_TOL, rel_tol: float = RATIO_REL_TOL) -> Any:
    """The tolerance of a ratio against its finer-step value: ``abs_tol + rel_tol x |fine|`` (a float or an array, as given).

    The one formula of a single run's check and a study's dt check (:func:`tumblemc.study.assemble.ratio_tol`).
    """
    return abs_tol + rel_tol * abs(fine_ratio)


def classify(ratio: float, fine_ratio: float, twin_ratios: np.ndarray, tol: float) -> tuple[str, float, float]:
    """The class of a checked run, the finer step's move and the twins' largest move.

    ``ratio`` and ``fine_ratio`` at ``dt`` and ``dt / factor``, ``twin_ratios`` the valid
    twins' (at ``dt``); every one finite (a run that is not valid is ``not checked`` before
    this). Returns ``(class, |fine - ratio|, max |twin - ratio|)`` (0 without twins).
    """
    move = abs(fine_ratio - ratio)
    twins = np.asarray(twin_ratios, dtype=float)
    spread = float(np.max(np.abs(twins - ratio))) if twins.size else 0.0
    if spread > tol and spread >= move:
        return "sensitive", move, spread
    return ("limited by dt" if move > tol else "within tolerance"), move, spread


@dataclass(frozen=True)
class StepCheck:
    """The outcome of :func:`check_step`; ``run`` is the run at its own step, as :func:`simulate` returns it."""

    run: xr.Dataset
    cls: str
    dt: float
    factor: int
    ratio: float
    status: int
    fine_ratio: float
    fine_status: int
    twin_ratios: np.ndarray
    twin_statuses: np.ndarray
    twin_rel: float
    tol: float
    move: float
    twin_spread: float
    threshold: float
    #: each run's progress along the plane (m) against time (s), at most MAX_CURVE_POINTS records:
    #: ``"the run"``, ``"dt / <factor>"``, ``"twin <i> of <n>"`` (:func:`tumblemc.viz.run.plot_step_check`)
    curves: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    def words(self) -> str:
        """One paragraph for a person: the class, the numbers behind it and what to do."""
        fine = f"at dt / {self.factor} ({self.dt / self.factor:.4g} s)"
        head = f"step check: {self.cls}. Progress ratio {_fmt(self.ratio)} at dt = {self.dt:.4g} s, {_fmt(self.fine_ratio)} {fine}"
        valid = self.twin_statuses == 0
        tw = ", ".join(
            _fmt(r) if ok else f"not valid (status {s})" for r, s, ok in zip(self.twin_ratios, self.twin_statuses, valid, strict=True)
        )
        twins = f"; {self.twin_ratios.size} twins (magnetisation changed by {self.twin_rel:g}): {tw}" if self.twin_ratios.size else ""
        body = f"{head}{twins}."
        if self.cls == "not checked":
            which = "the run" if self.status != 0 else f"the run {fine}"
            bad = self.status if self.status != 0 else self.fine_status
            return f"{body} {which[0].upper() + which[1:]} is not valid (status {bad}): no step comparison."
        said = f"The finer step moves the ratio by {self.move:.3g}, the twins by up to {self.twin_spread:.3g} (tolerance {self.tol:.3g})"
        flip = ""
        if (self.ratio >= self.threshold) != (self.fine_ratio >= self.threshold):
            flip = f" The verdict (ratio >= {self.threshold:g}) differs at the finer step."
        if self.cls == "within tolerance":
            return f"{body} {said}: at this step the answer is within the tolerance of the finer step's.{flip}"
        if self.cls == "limited by dt":
            return f"{body} {said}: the step sets this answer; run at a smaller dt (the answer {fine} is the better one).{flip}"
        return (
            f"{body} {said}: a change far below any measurement moves it as far as the step does, so no step "
            f"converges it; judge it by an ensemble of nearby robots (a study), not by this one run.{flip}"
        )

    def as_attrs(self) -> dict[str, Any]:
        """The check as netCDF attributes of the run (``step_check_*``)."""
        return {
            "step_check_class": self.cls,
            "step_check_factor": self.factor,
            "step_check_fine_dt": self.dt / self.factor,
            "step_check_fine_ratio": self.fine_ratio,
            "step_check_fine_status": self.fine_status,
            "step_check_twin_rel": self.twin_rel,
            "step_check_twin_ratios": [float(x) for x in self.twin_ratios],
            "step_check_twin_statuses": [int(x) for x in self.twin_statuses],
            "step_check_tolerance": self.tol,
            "step_check_move": self.move,
            "step_check_twin_spread": self.twin_spread,
            "step_check_threshold": self.threshold,
            "step_check_words": self.words(),
        }


def _whole(name: str, value: Any, lo: int, hi: int) -> int:
    x = check_number(name, value, f"(a whole number, {lo} to {hi})", lo, hi)
    if x != int(x):
        raise ValueError(f"{name}={value!r} is not a whole number (allowed: a whole number, {lo} to {hi})")
    return int(x)


def _fmt(x: float) -> str:
    return f"{x:.3f}" if math.isfinite(x) else "nan"


def _twin_overrides(magnetization: float, offset_deg: float, n: int, rel: float) -> list[dict[str, float]]:
    """Twin ``i`` of ``n``: the magnetisation vector turned by ``2 pi i / n`` on the circle of relative radius ``rel``."""
    out = []
    for i in range(n):
        a = 2.0 * math.pi * i / n
        c, s = round(math.cos(a), 12), round(math.sin(a), 12)  # exact 0 and +-1 at the quarter turns
        out.append({"magnetization": magnetization * (1.0 + rel * c), "offset_deg": offset_deg + math.degrees(rel * s)})
    return out


def check_step(
    *args: Any,
    factor: int = 4,
    twins: int = 4,
    twin_rel: float = 1e-6,
    ratio_abs_tol: float = RATIO_ABS_TOL,
    ratio_rel_tol: float = RATIO_REL_TOL,
    threshold: float = 0.5,
    workers: int | None = None,
    progress: bool | Callable[[str], None] = False,
    **kwargs: Any,
) -> StepCheck:
    """Run :func:`~tumblemc.model.run.simulate`'s inputs at their step, ``factor`` times finer and as ``twins`` twins; class the run.

    Parameters
    ----------
    *args, **kwargs
        What :func:`~tumblemc.model.run.simulate` takes (``max_wall_s`` applies to each run;
        the finer run records every ``factor``-th step of its own, so its records match).
    factor : int
        The finer step is ``dt / factor`` (2 to 64; default 4, as a study's dt check).
    twins : int
        How many twins at ``dt`` (0 to 64; default 4). 0: no twins, so a run outside the
        tolerance is ``limited by dt`` (no evidence of sensitivity was sought).
    twin_rel : float
        The relative change of the magnetisation vector of each twin (1e-12 to 1e-2;
        default 1e-6).
    ratio_abs_tol, ratio_rel_tol : float
        The tolerance of the ratio against the finer step's, ``ratio_abs_tol + ratio_rel_tol
        x |fine ratio|`` (default 0.05 + 10%, a study's ``[check]`` defaults; 0 to 10 each).
    threshold : float
        The climb threshold of the verdict (default 0.5): the words say when the finer step's
        verdict differs.
    workers : int, optional
        Threads running the runs side by side (the kernels release the GIL); default: the
        CPU count. The results do not depend on it.
    progress : bool or callable
        Say each run as it finishes (True: on stderr; a callable gets each line).

    Returns
    -------
    StepCheck
        The run at its own step (``.run``, with the check in its attributes ``step_check_*``),
        the class (``.cls``), the ratios and statuses, and ``.words()``.
    """
    factor = _whole("factor", factor, 2, 64)
    twins = _whole("twins", twins, 0, 64)
    twin_rel = check_number("twin_rel", twin_rel, "", 1e-12, 1e-2)
    ratio_abs_tol = check_number("ratio_abs_tol", ratio_abs_tol, "", 0.0, 10.0)
    ratio_rel_tol = check_number("ratio_rel_tol", ratio_rel_tol, "", 0.0, 10.0)
    threshold = check_number("threshold", threshold, "", -1e6, 1e6)
    if workers is not None:
        workers = _whole("workers", workers, 1, 1024)
    if len(args) > len(POSITIONAL):
        raise TypeError(f"check_step takes at most {len(POSITIONAL)} positional arguments ({', '.join(POSITIONAL)}), got {len(args)}")
    twice = sorted(set(POSITIONAL[: len(args)]) & set(kwargs))
    if twice:
        raise TypeError(f"check_step got multiple values for {', '.join(twice)}")
    kwargs = dict(zip(POSITIONAL, args, strict=False), **kwargs)
    inp = run_inputs(**{k: v for k, v in kwargs.items() if k != "max_wall_s"})
    if not inp.freq_hz > 0:
        raise ValueError(
            f"check_step compares progress ratios, which need a rotating field: freq_hz = {inp.freq_hz:g} "
            "(allowed: a rotating field, the paper's or Rotating)"
        )
    dt = inp.dt
    every = inp.record_every
    # the run as the caller asked (its dt_rule kept); the finer run and the twins at a given step
    fine_kw = dict(kwargs, dt=dt / factor, record_every=every * factor)
    jobs: list[tuple[str, dict[str, Any]]] = [("the run", kwargs), (f"dt / {factor}", fine_kw)]
    for i, over in enumerate(_twin_overrides(inp.params.magnetization, inp.params.offset_deg, twins, twin_rel)):
        jobs.append((f"twin {i + 1} of {twins}", dict(kwargs, dt=dt, **over)))  # the twin's own default step could differ
    say = progress if callable(progress) else (lambda s: print(s, file=sys.stderr, flush=True)) if progress else None
    t0 = time.perf_counter()
    curves: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def one(job: tuple[str, dict[str, Any]]) -> tuple[xr.Dataset | None, float, int]:
        name, kw = job
        ds = simulate(**kw)
        s = summarize(ds, threshold=threshold)
        if say is not None:
            say(f"step check: {name} done (ratio {_fmt(s['progress_ratio'])}, status {s['status']}, {time.perf_counter() - t0:.1f} s)")
        t, p = ds["time"].values, ds["progress"].values
        keep = np.unique(np.r_[np.arange(0, t.size, max(1, -(-t.size // MAX_CURVE_POINTS))), t.size - 1])
        curves[name] = (t[keep], p[keep])
        return (ds if kw is kwargs else None), float(s["progress_ratio"]), int(s["status"])  # only the run's records are kept

    n_threads = max(1, min(len(jobs), workers if workers is not None else (os.cpu_count() or 1)))
    with ThreadPoolExecutor(n_threads) as pool:
        out = list(pool.map(one, jobs))
    (ds, ratio, status), (_, fine_ratio, fine_status) = out[0], out[1]
    assert ds is not None
    t_ratio = np.array([r for _, r, _ in out[2:]], dtype=float)
    t_status = np.array([s for _, _, s in out[2:]], dtype=np.int64)
    tol = tolerance(fine_ratio, ratio_abs_tol, ratio_rel_tol) if math.isfinite(fine_ratio) else math.nan
    if status != 0 or fine_status != 0:
        cls, move, spread = "not checked", abs(fine_ratio - ratio), math.nan
    else:
        cls, move, spread = classify(ratio, fine_ratio, t_ratio[t_status == 0], tol)
    res = StepCheck(
        run=ds,
        cls=cls,
        dt=dt,
        factor=factor,
        ratio=ratio,
        status=status,
        fine_ratio=fine_ratio,
        fine_status=fine_status,
        twin_ratios=t_ratio,
        twin_statuses=t_status,
        twin_rel=twin_rel,
        tol=tol,
        move=move,
        twin_spread=spread,
        threshold=threshold,
        curves={name: curves[name] for name, _ in jobs},
    )
    ds.attrs.update(res.as_attrs())
    return res
