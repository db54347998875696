"""Many runs through the batch kernel: rows of parameters in, rows of outcomes out.

:func:`simulate_rows` is the engine's unit of work (one dask task) and the bare kernel the
engine benchmark compares against. Each run is validated and scaled by the same
:func:`tumblemc.model.run.run_inputs` and :func:`~tumblemc.model.run.prepare` as :func:`tumblemc.simulate`, so a row's outcome equals
``summarize(simulate(...))`` of the same inputs; a row whose inputs are invalid gets
``status = 3`` (error) and the message, it never raises.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np

from tumblemc.kernels import batch as KB
from tumblemc.kernels.residual import n_unknowns
from tumblemc.kernels.stepper import empty_record, make_buffers
from tumblemc.model.energy import field_work_bound
from tumblemc.model.fields import Rotating
from tumblemc.model.outcome import climbed
from tumblemc.model.run import RunSpec, initial_contact, prepare, run_inputs
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.shapes.types import Shape
from tumblemc.model.solver_options import SolverOptions
from tumblemc.schema import OUTCOMES


class RunRow(TypedDict, total=False):
    """The inputs of one run that vary within a batch (a row of :func:`simulate_rows`).

    :func:`tumblemc.model.run.run_inputs` keywords, checked there. Absent keys take
    ``run_inputs``' defaults and the preset's values.
    """

    preset: str
    incline_deg: float
    field_mT: float
    freq_hz: float
    mass: float
    F_elect: float
    mu: float
    offset_deg: float
    offset_axis: tuple[float, float, float]
    V_m: float
    magnetization: float
    adhesion_C: float
    line_contact_fraction: float
    e_t: float
    e_o: float
    e_r: float
    electrostatic_in_flight: bool
    g: float
    line_contact_width: float
    line_adhesion: str
    peel_length: float
    adhesion_release: str
    field: Rotating
    dt: float  # s; the grid's ``dt`` when absent


@dataclass(frozen=True)
class TimeGrid:
    """The time grid every run of a batch shares.

    periods : duration in field periods; transient_periods : periods skipped before the
    speed is measured (as :func:`tumblemc.summarize`); dt : s (None: the default);
    refine : every run's step (its row's ``dt``, else ``dt``) divided by this whole number (a
    study's numerical check; a step is needed then); torque : ``"start"`` or ``"end"``; success_ratio : progress-ratio threshold of
    ``climbed``; max_failed_steps : stop a run after that many failed steps (0: never);
    its outcome is then NaN with status ``failed_steps``; early_decision : stop a run once
    its verdict can only be failure (:mod:`tumblemc.kernels.decide`): ``decided_early`` is
    then 1, ``climbed`` 0 and the progress ratio is the one up to the decision (censored).
    Every run reports ``decided_time``, when the bound decided it (NaN: never).
    """

    periods: float = 2.0
    transient_periods: float = 1.0
    dt: float | None = None
    refine: int = 1
    torque: str = "start"
    rotation: str = "momentum"
    success_ratio: float = 0.5
    max_failed_steps: int = 0  # 0: never stop a run early (as simulate); studies use 1
    early_decision: bool = False  # stop a run once the energy bound decides failure (kernels/decide.py)


def record_stride(n_steps: int, i0: int) -> tuple[int, int]:
    """A recording stride that puts a row at step ``i0`` (and the last step), and that row."""
    k = math.gcd(n_steps, i0) if i0 > 0 else n_steps
    return k, (i0 // k if i0 > 0 else 0)


def simulate_rows(shape: str | Shape, rows: Sequence[RunRow], grid: TimeGrid, full: Sequence[bool] | None = None) -> dict[str, np.ndarray]:
    """Simulate one run per row of ``rows`` through the batch kernel.

    Parameters
    ----------
    shape : str or Shape
        Shared by every row.
    rows : sequence of RunRow
        Keyword arguments of :func:`tumblemc.simulate` per run: ``preset``,
        ``incline_deg``, ``field_mT``, ``freq_hz``, any parameter overrides and ``dt``. Rows
        with the same number of steps share a batch; rows are grouped by it internally.
    grid : TimeGrid
    full : sequence of bool, optional
        Rows simulated to the end even with ``grid.early_decision`` (the audited ones: a
        study's dt-check runs); their ``decided_time`` says when the bound would have
        stopped them.

    Returns
    -------
    dict of numpy arrays
        One entry per :data:`OUTCOMES` column (length ``len(rows)``) plus ``error``
        (object array of messages, ``""`` where the run was valid).
    """
    shp = get_shape(shape)
    nrow = len(rows)
    res: dict[str, np.ndarray] = {k: np.zeros(nrow, dt) for k, dt in OUTCOMES.items()}
    for k in (
        "progress_ratio",
        "mean_speed",
        "progress",
        "newton_iterations",
        "max_penetration",
        "energy_gain",
        "energy_gain_ratio",
        "field_work_bound",
        "lateral_drift",
        "heading_change_deg",
        "decided_time",
    ):
        res[k][:] = np.nan
    res["status"][:] = KB.BATCH_ERROR
    errors = np.full(nrow, "", dtype=object)
    specs: dict[int, RunSpec] = {}
    solver = SolverOptions(max_failed_steps=grid.max_failed_steps)
    for i, row in enumerate(rows):
        try:  # the run's inputs are validated here, once (run_inputs), and trusted after
            kw: dict[str, Any] = dict(row)
            dt = kw.pop("dt", grid.dt)
            if grid.refine != 1:
                if dt is None:
                    raise ValueError(f"TimeGrid.refine={grid.refine!r} needs a step (allowed: a dt in the grid or the row)")
                dt = dt / grid.refine
            spec = prepare(
                run_inputs(
                    shp,
                    periods=grid.periods,
                    dt=dt,
                    torque=grid.torque,
                    rotation=grid.rotation,
                    solver=solver,
                    max_record_bytes=math.inf,  # the kernel records the measured rows only (the study budget bounds them)
                    **kw,
                )
            )
        except (ValueError, TypeError) as exc:
            errors[i] = str(exc)
            continue
        specs[i] = spec
    # runs on the same time grid go through the kernel together
    groups: dict[tuple[int, int, int, int], list[int]] = {}
    for i, spec in specs.items():
        i0 = round(grid.transient_periods / spec.freq_hz / spec.dt)
        stride, i0_row = record_stride(spec.n_steps, i0)
        groups.setdefault((spec.n_steps, stride, i0_row, spec.prm.size), []).append(i)
    geo = shp.geometry()
    buf = make_buffers(n_unknowns(geo.pstart))
    for (n_steps, stride, i0_row, _), idx in sorted(groups.items()):
        ss = [specs[i] for i in idx]
        prms = np.ascontiguousarray(np.stack([s.prm for s in ss]))
        states = np.ascontiguousarray(np.stack([s.state0 for s in ss]))
        hs = np.array([s.h for s in ss])
        contact = [initial_contact(s) for s in ss]
        area0 = np.array([a for a, _ in contact])
        touch0 = np.array([t for _, t in contact])
        out = np.zeros((len(ss), KB.N_OUT))
        rec = empty_record(n_steps, stride)
        i0 = i0_row * stride
        # the uphill progress over the window that success needs (scaled length)
        need = np.array(
            [grid.success_ratio * s.shape.hull_perimeter * s.freq_hz * (n_steps - i0) * s.h * s.units.time / s.units.length for s in ss]
        )
        stop = [grid.early_decision and not (full is not None and full[i]) for i in idx]
        decide = np.array([2 if st else 1 for st in stop], dtype=np.int64)
        batch = KB.Batch(prms=prms, states0=states, hs=hs, area0=area0, touch0=touch0, need=need, decide=decide)
        KB.run_batch(geo, batch, (n_steps, stride, i0_row), solver.as_array(), buf, rec, out)
        for j, (i, s) in enumerate(zip(idx, ss, strict=True)):
            o = out[j]
            status = int(o[KB.OUT_STATUS])
            window = o[KB.OUT_WINDOW] * s.units.time
            progress = o[KB.OUT_PROGRESS] * s.units.length
            speed = progress / window if window > 0 else math.nan
            ideal = s.shape.hull_perimeter * s.freq_hz
            ratio = speed / ideal
            if status == KB.BATCH_NONFINITE:
                speed = ratio = progress = math.nan
            res["status"][i] = status
            res["progress"][i] = progress
            res["mean_speed"][i] = speed
            res["progress_ratio"][i] = ratio
            early = o[KB.OUT_STOPPED] > 0.5
            res["climbed"][i] = 0 if early else int(climbed(ratio, status, grid.success_ratio))
            res["decided_early"][i] = int(early)
            res["decided_time"][i] = o[KB.OUT_DECIDED] * s.units.time
            res["newton_iterations"][i] = o[KB.OUT_NIT] / o[KB.OUT_STEPS]
            res["substeps"][i] = int(o[KB.OUT_SUB])
            res["fallbacks"][i] = int(o[KB.OUT_FALLBACK])
            res["failed_steps"][i] = int(o[KB.OUT_FAILED])
            res["max_penetration"][i] = o[KB.OUT_PEN] * s.units.length
            res["loose_steps"][i] = int(o[KB.OUT_LOOSE])
            res["impulse_steps"][i] = int(o[KB.OUT_IMPULSE])
            res["energy_gain"][i] = o[KB.OUT_EGAIN] * s.units.energy
            res["energy_gain_ratio"][i] = o[KB.OUT_EGAIN] / o[KB.OUT_EREF]
            res["lateral_drift"][i] = o[KB.OUT_LATERAL] * s.units.length
            res["heading_change_deg"][i] = o[KB.OUT_HEADING]
            res["field_work_bound"][i] = field_work_bound(s.prm, s.n_steps * s.h) * s.units.energy
    res["error"] = errors
    return res
