"""One run: validate, nondimensionalise, call the kernels, return an xarray Dataset."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.kernels import layout as L
from tumblemc.kernels.geometry import Geometry
from tumblemc.kernels.residual import n_unknowns
from tumblemc.kernels.stepper import Buffers, Clock, Model, Start, empty_record, make_buffers, n_records, run
from tumblemc.model.cost import DEFAULT_MAX_WALL_S, check_cost
from tumblemc.model.energy import ENERGY_GAIN_TOL, energy_summary, ledger_variables
from tumblemc.model.fields import (
    SEG_FREQ,
    Field,
    Rotating,
    Sequence,
    Static,
    compile_program,
    describe,
    field_at,
    peak_mT,
    revolutions,
    scale_program,
    segment_mT,
)
from tumblemc.model.frames import plane_frame, rot_to_quat
from tumblemc.model.outcome import run_status
from tumblemc.model.params import RANGES, Params, check_choice, check_number, get_preset
from tumblemc.model.plausible import check_motion, check_resolved, check_solver
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.shapes.types import Shape
from tumblemc.model.solver_options import DEFAULT_ROTATION, ROTATION_OPTIONS, TORQUE_END_WEIGHT, TORQUE_OPTIONS, SolverOptions
from tumblemc.model.step_size import CEILING_S, default_step
from tumblemc.model.units import LENGTH_M, Units
from tumblemc.schema import RUN_STATUS_MEANINGS, annotate
from tumblemc.version import __version__

#: the ceiling of the default time step, s: the largest dt of the convergence study
#: (docs/validation) whose verdicts match the finest dt (1.25e-5 s) in every case and whose
#: progress ratios are within 2% of it in every climbing case, with the torque at the start
#: of the step (aluminum 20 deg binds: 0.895 at 1e-4 against 0.876). A run's default is this
#: or a whole divisor of it, from what the run must resolve (model/step_size.py).
DEFAULT_DT = CEILING_S


MAX_RECORD_BYTES = 2 * 2**30  # memory of one run's record
DEFAULT_DURATION_S = 2.0


@dataclass(frozen=True)
class RunInputs:
    """The inputs of one run, validated (SI; built only by :func:`run_inputs`).

    Every later layer (:func:`prepare`, :func:`tumblemc.model.rows.simulate_rows`, the
    study engine) trusts these values: they were checked once, against the one range
    table :data:`tumblemc.model.params.RANGES`.
    """

    shape: Shape
    params: Params
    incline_deg: float
    field_mT: float
    freq_hz: float
    duration_s: float
    dt: float
    n_steps: int
    torque: str
    rotation: str
    record_every: int
    solver: SolverOptions
    lift_m: float
    v0: tuple[float, float, float]
    omega0: tuple[float, float, float]
    field: Field | None
    program: np.ndarray | None  # compile_program(field), SI; None: the paper's field
    dt_rule: str  # what set dt: "given" (the caller's) or the default's rule (model/step_size.py)


@dataclass(frozen=True)
class RunSpec(RunInputs):
    """A run's validated inputs plus the kernel's scaled data: units, ``prm`` and ``state0``."""

    units: Units
    prm: np.ndarray
    state0: np.ndarray

    @property
    def h(self) -> float:
        """Time step in scaled units."""
        return self.dt / self.units.time

    @cached_property
    def geo(self) -> Geometry:
        """The shape's kernel geometry, built on first use.

        The batch path builds it once per shape, not per run.
        """
        return self.shape.geometry()


def run_inputs(  # noqa: C901
    shape: str | Shape = "cuboid",
    preset: str | Params = "paper",
    incline_deg: float = 0.0,
    field_mT: float | None = None,
    freq_hz: float | None = None,
    duration_s: float | None = None,
    dt: float | None = None,
    *,
    field: Field | None = None,
    periods: float | None = None,
    torque: str = "start",
    rotation: str = DEFAULT_ROTATION,
    record_every: int = 1,
    solver: SolverOptions | None = None,
    lift_m: float = 0.0,
    v0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    omega0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    max_record_bytes: float = MAX_RECORD_BYTES,
    **overrides: Any,
) -> RunInputs:
    """Validate the inputs of one run: the one place where run inputs are checked.

    ``max_record_bytes`` bounds the record of ``record_every`` (the batch kernel of a study
    records only the rows it measures, bounded by the study's budget instead).

    Parameters are those of :func:`simulate`. The duration is either ``duration_s``
    (default 2 s, or a :class:`~tumblemc.model.fields.Sequence`'s total) or ``periods`` field
    periods (``periods / freq_hz``, which needs ``freq_hz > 0``), not both. ``field`` (a
    field program) and ``field_mT``/``freq_hz`` (the paper's field, default 20 mT, 1 Hz)
    exclude each other; for a program, ``field_mT`` and ``freq_hz`` of the result are its
    peak magnitude and its mean rotation rate (revolutions / duration).

    Returns
    -------
    RunInputs

    Raises
    ------
    ValueError
        For the first bad value, naming the argument, the value and the allowed range.
    """
    if not isinstance(shape, (str, Shape)):
        raise ValueError(f"shape={shape!r} is not allowed (allowed: a shape name or a tumblemc.shapes.Shape)")
    if not isinstance(preset, (str, Params)):
        raise ValueError(f"preset={preset!r} is not allowed (allowed: a preset name or a tumblemc.model.params.Params)")
    shp = get_shape(shape)
    params = get_preset(preset).replace(**overrides) if overrides else get_preset(preset)
    incline_deg = RANGES["incline_deg"].check("incline_deg", incline_deg)
    program = None
    if field is not None:
        if not isinstance(field, (Static, Rotating, Sequence)):
            raise ValueError(f"field={field!r} is not allowed (allowed: tumblemc.model.fields.Static, Rotating or Sequence)")
        if field_mT is not None or freq_hz is not None:
            raise ValueError(
                f"field={describe(field)!r} and field_mT={field_mT!r}, freq_hz={freq_hz!r} are both given "
                "(allowed: a field program or the paper's field_mT/freq_hz shorthand)"
            )
        if periods is not None and not isinstance(field, Rotating):
            raise ValueError(f"periods={periods!r} is not allowed with a {type(field).__name__} program (allowed: duration_s)")
        if duration_s is None and isinstance(field, Sequence):
            duration_s = field.duration_s
        if isinstance(field, Rotating) and field == Rotating(field.mT, field.hz):
            field_mT, freq_hz = field.mT, field.hz  # the paper's field: the kernel's own code, identical records
        else:
            program = compile_program(field, incline_deg)
            field_mT = peak_mT(program)
            if isinstance(field, Rotating):  # for periods; the mean rate below is the same
                freq_hz = field.hz
    field_mT = RANGES["field_mT"].check("field_mT", 20.0 if field_mT is None else field_mT)
    freq_hz = RANGES["freq_hz"].check("freq_hz", 1.0 if freq_hz is None else freq_hz)
    if periods is not None:
        if duration_s is not None:
            raise ValueError(f"duration_s={duration_s!r} and periods={periods!r} are both given (allowed: one of them)")
        periods = RANGES["periods"].check("periods", periods)
        if not freq_hz > 0:
            raise ValueError(f"freq_hz={freq_hz!r} is out of range (allowed: > 0 for a duration in field periods)")
        duration_s = periods / freq_hz
    duration_s = RANGES["duration_s"].check("duration_s", DEFAULT_DURATION_S if duration_s is None else duration_s)
    omega0 = check_motion("omega0", omega0)
    dt_rule = "given"
    if dt is None:  # the default: what the run must resolve (model/step_size.py)
        freqs, seg = ([freq_hz], None) if program is None else (np.abs(program[:, SEG_FREQ]).tolist(), segment_mT(program).tolist())
        choice = default_step(shp.inertia(params.mass), params.V_m * params.magnetization, field_mT, freqs, omega0, seg)
        dt, dt_rule = check_resolved(choice)
    else:
        dt = RANGES["dt"].check("dt", dt)
    torque = check_choice("torque", torque, TORQUE_OPTIONS)
    rotation = check_choice("rotation", rotation, ROTATION_OPTIONS)
    if isinstance(record_every, bool) or not float(check_number("record_every", record_every, "", 1, 1e9)).is_integer():
        raise ValueError(f"record_every={record_every!r} is not allowed (allowed: an integer >= 1)")
    record_every = int(record_every)
    n_steps = round(duration_s / dt)
    if n_steps < 1:
        raise ValueError(f"duration_s={duration_s!r} is shorter than one step dt={dt!r} (allowed: duration_s >= dt)")
    rows = n_records(n_steps, record_every)
    if rows * L.N_REC * 8 > max_record_bytes:
        raise ValueError(
            f"duration_s={duration_s!r} with dt={dt!r} and record_every={record_every} records {rows} rows "
            f"({rows * L.N_REC * 8 / 2**30:.1f} GiB; allowed: up to {max_record_bytes / 2**30:.0f} GiB): raise record_every or dt"
        )
    lift_m = RANGES["lift_m"].check("lift_m", lift_m)
    if program is not None:
        freq_hz = revolutions(program, duration_s) / duration_s
    return RunInputs(
        shape=shp,
        params=params,
        incline_deg=incline_deg,
        field_mT=field_mT,
        freq_hz=freq_hz,
        duration_s=duration_s,
        dt=dt,
        n_steps=n_steps,
        torque=torque,
        rotation=rotation,
        record_every=record_every,
        solver=check_solver(solver),
        lift_m=lift_m,
        v0=check_motion("v0", v0),
        omega0=omega0,
        field=field,
        program=program,
        dt_rule=dt_rule,
    )


def torque_per_tesla(params: Params, u: Units) -> float:
    """``V_m |E|`` in kernel torque units per tesla: the magnetic torque is this times ``(R E_b) x B``."""
    return params.V_m * params.magnetization / u.torque


def prepare(inputs: RunInputs) -> RunSpec:
    """Nondimensionalise validated inputs into the kernel's arrays (MODEL.md, "Numerics")."""
    shp, params = inputs.shape, inputs.params
    u = Units(mass=params.mass, g=params.g)
    fr = plane_frame(inputs.incline_deg)
    nseg = 0 if inputs.program is None else len(inputs.program)
    prm = np.zeros(L.N_PRM + nseg * L.FSEG)
    prm[L.P_MASS] = 1.0
    prm[L.P_G] = 1.0
    prm[L.P_FELECT] = params.F_elect / u.force
    prm[L.P_MU] = params.mu
    prm[L.P_ET] = params.e_t
    prm[L.P_EO] = params.e_o
    prm[L.P_ER] = params.e_r / u.length
    prm[L.P_LINEFRAC] = params.line_contact_fraction
    prm[L.P_ADHC] = params.adhesion_C * u.area / u.force
    prm[L.P_TORQ] = params.V_m * params.magnetization * inputs.field_mT * 1e-3 / u.torque  # this order: records as before programs
    prm[L.P_FREQ] = inputs.freq_hz * u.time
    prm[L.P_ELECT_FLIGHT] = 1.0 if params.electrostatic_in_flight else 0.0
    prm[L.P_TORQUE_END] = TORQUE_END_WEIGHT[inputs.torque]
    prm[L.P_POSE_W0] = 0.5 if inputs.rotation == "midpoint" else 0.0
    prm[L.P_N : L.P_N + 3] = fr["n"]
    prm[L.P_T : L.P_T + 3] = fr["t"]
    prm[L.P_O : L.P_O + 3] = fr["o"]
    prm[L.P_U : L.P_U + 3] = fr["u"]
    prm[L.P_EB : L.P_EB + 3] = params.magnetisation_dir()
    prm[L.P_IB : L.P_IB + 9] = (shp.inertia(params.mass) / u.inertia).ravel()
    prm[L.P_FIELD_ON] = 1.0 if prm[L.P_TORQ] > 0.0 else 0.0
    prm[L.P_ROT_PAPER] = 1.0 if inputs.rotation == "paper" else 0.0
    prm[L.P_LINE_STRIP] = 1.0 if params.line_adhesion == "strip" else 0.0
    prm[L.P_LINEW] = params.line_contact_width / u.length
    prm[L.P_PEEL] = 1.0 if params.adhesion_release == "peel" else 0.0
    prm[L.P_PEEL_LEN] = params.peel_length / u.length
    if inputs.program is not None:
        prm[L.P_FPROG] = nseg
        prm[L.N_PRM :] = scale_program(inputs.program, u.time, torque_per_tesla(params, u)).ravel()

    # initial state (MODEL.md): at rest, flat, body +y along u, body +z along -n
    R0 = np.column_stack([np.cross(fr["u"], -fr["n"]), fr["u"], -fr["n"]])
    state0 = np.zeros(13)
    state0[0:3] = (shp.rest_height() + inputs.lift_m) / LENGTH_M * fr["n"]
    state0[3:7] = rot_to_quat(R0)
    state0[7:10] = np.asarray(inputs.v0, dtype=float) / u.velocity
    state0[10:13] = np.asarray(inputs.omega0, dtype=float) * u.time
    fields = {f.name: getattr(inputs, f.name) for f in dataclasses.fields(RunInputs)}
    return RunSpec(**fields, units=u, prm=prm, state0=state0)


def initial_contact(spec: RunSpec) -> tuple[float, bool]:
    """Adhering area (scaled) and contact at ``t = 0``.

    The robot starts lying on a face (MODEL.md), unless lifted, so that face adheres from
    the first step.
    """
    resting = spec.lift_m == 0.0
    p = spec.params
    area = spec.shape.rest_face_area(p.line_contact_fraction, p.line_adhesion, p.line_contact_width) if resting else 0.0
    return area / spec.units.area, resting


def run_spec(spec: RunSpec, buffers: Buffers | None = None, n_steps: int | None = None) -> tuple[np.ndarray, int, int]:
    """Run the kernel for ``spec``; returns ``(rec, status, failed_steps)`` (scaled).

    ``buffers`` (:func:`~tumblemc.kernels.stepper.make_buffers`) may be reused across runs
    of one shape; the unknowns are zeroed first, so a run never depends on the previous one.
    ``n_steps`` runs only the first steps (the cost probe, :mod:`tumblemc.model.cost`).
    """
    n_steps = spec.n_steps if n_steps is None else n_steps
    geo = spec.geo
    buf = buffers or make_buffers(n_unknowns(geo.pstart))
    for arr in (buf.z, buf.z6, buf.zsave):
        arr[:] = 0.0
    rec = empty_record(n_steps, spec.record_every)
    area0, resting = initial_contact(spec)
    start = Start(state=spec.state0.copy(), t0=0.0, area0=area0, touch0=resting)
    clock = Clock(h=spec.h, n_steps=n_steps, record_every=spec.record_every)
    status, failed, _ = run(Model(prm=spec.prm, geo=geo), spec.solver.as_array(), start, clock, rec, buf)
    return rec, int(status), int(failed)


def to_dataset(spec: RunSpec, rec: np.ndarray, status: int, failed: int) -> xr.Dataset:
    """Convert a kernel record to an annotated SI Dataset."""
    u = spec.units
    rows = rec
    if status != L.ST_OK:  # keep the rows that were written
        last = int(np.max(np.nonzero(rows[:, L.R_T])[0], initial=0))
        rows = rows[: last + 1]
    t = rows[:, L.R_T] * u.time
    pos = rows[:, L.R_X : L.R_X + 3] * u.length
    uphill = plane_frame(spec.incline_deg)["u"]
    progress = (pos - pos[0]) @ uphill
    fr = plane_frame(spec.incline_deg)
    if spec.program is None:
        ang = 2 * np.pi * spec.freq_hz * t
        c, s = np.cos(ang), np.sin(ang)
        ub = fr["u"]
        field = spec.field_mT * 1e-3 * np.stack([np.full_like(t, ub[0]), c * ub[1] - s * ub[2], s * ub[1] + c * ub[2]], -1)
    else:
        field = field_at(spec.program, t)
    xyz = ("time", "xyz")
    ds = xr.Dataset(
        {
            "progress": ("time", progress),
            "position": (xyz, pos),
            "quaternion": (("time", "quat"), rows[:, L.R_Q : L.R_Q + 4]),
            "velocity": (xyz, rows[:, L.R_V : L.R_V + 3] * u.velocity),
            "omega": (xyz, rows[:, L.R_W : L.R_W + 3] / u.time),
            "normal_force": ("time", rows[:, L.R_LN] * u.force),
            "adhesion_force": ("time", rows[:, L.R_ADH] * u.force),
            "contact_area": ("time", rows[:, L.R_AREA] * u.area),
            "contact_mode": ("time", rows[:, L.R_MODE].astype(np.int8)),
            "slip_speed": ("time", rows[:, L.R_SLIP] * u.velocity),
            "ecp": (xyz, rows[:, L.R_ECP : L.R_ECP + 3] * u.length),
            "newton_iterations": ("time", rows[:, L.R_NIT].astype(np.int32)),
            "residual": ("time", rows[:, L.R_RES]),
            "fallbacks": ("time", rows[:, L.R_FALLBACK].astype(np.int32)),
            "substeps": ("time", rows[:, L.R_SUB].astype(np.int32)),
            "penetration": ("time", rows[:, L.R_PEN] * u.length),
            "failed": ("time", rows[:, L.R_FAIL].astype(np.int32)),
            "loose": ("time", rows[:, L.R_LOOSE].astype(np.int32)),
            "impulse_kept": ("time", rows[:, L.R_IMPULSE].astype(np.int32)),
            "field": (xyz, field),
            **ledger_variables(spec.prm, u, rows, field, torque_per_tesla(spec.params, u)),
        },
        coords={"time": t, "xyz": ["x", "y", "z"], "quat": ["w", "x", "y", "z"]},
    )
    annotate(ds)
    energy = energy_summary(spec.prm, u, rows)
    ds.attrs.update(
        {
            "title": f"tumblemc run: {spec.shape.name} robot",
            "Conventions": "CF-1.10",
            "source": f"tumblemc {__version__}",
            "tumblemc_version": __version__,
            "shape": spec.shape.name,
            "incline_deg": spec.incline_deg,
            "field_mT": spec.field_mT,
            "freq_hz": spec.freq_hz,
            "field_program": "paper" if spec.field is None else describe(spec.field),
            "duration_s": spec.duration_s,
            "dt": spec.dt,
            "dt_rule": spec.dt_rule,
            "torque": spec.torque,
            "rotation": spec.rotation,
            "record_every": spec.record_every,
            "hull_perimeter": spec.shape.hull_perimeter,
            "ideal_speed": spec.shape.hull_perimeter * spec.freq_hz,
            # outcome status (schema.STATUS_FLAGS): a run with a failed step is not "ok"
            "status": run_status(int(status), int(failed), energy_gain_ratio=energy["energy_gain_ratio"]),
            "status_meanings": RUN_STATUS_MEANINGS,
            **energy,
            "energy_gain_tolerance": ENERGY_GAIN_TOL,
            "kernel_status": int(status),
            "failed_steps": int(failed),
            "n_steps": spec.n_steps,
            **{f"solver_{k}": v for k, v in vars(spec.solver).items()},
            **spec.params.as_attrs(),
        }
    )
    return ds


def simulate(
    shape: str | Shape = "cuboid",
    preset: str | Params = "paper",
    incline_deg: float = 0.0,
    field_mT: float | None = None,
    freq_hz: float | None = None,
    duration_s: float | None = None,
    dt: float | None = None,
    *,
    field: Field | None = None,
    periods: float | None = None,
    torque: str = "start",
    rotation: str = DEFAULT_ROTATION,
    record_every: int = 1,
    solver: SolverOptions | None = None,
    lift_m: float = 0.0,
    v0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    omega0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    max_wall_s: float | None = DEFAULT_MAX_WALL_S,
    **overrides: Any,
) -> xr.Dataset:
    """Simulate one tumbling robot and return its time series.

    Parameters
    ----------
    shape : str or Shape
        ``"cuboid"`` (more in :mod:`tumblemc.shapes`).
    preset : str or Params
        ``"paper"`` (Table 1) or ``"aluminum"`` (Table 3).
    incline_deg : float
        Incline of the substrate, degrees (rotation about world x).
    field_mT, freq_hz : float, optional
        The paper's field: magnitude (mT, default 20) and frequency (Hz, default 1),
        rotating about world x from the uphill direction; 0 mT switches the field off.
    field : tumblemc.model.fields.Static, Rotating or Sequence, optional
        A field program instead (MODEL.md, "Field programs"): static, rotating about any
        axis, with a cone or bias, or a sequence of segments. ``Rotating(mT, hz)`` is the
        paper's field (same physics; the shorthand runs the kernel's original code).
    duration_s : float, optional
        Simulated time, s (default 2 s).
    periods : float, optional
        Simulated time in field periods instead of ``duration_s`` (``periods / freq_hz``).
    dt : float, optional
        Time step, s; ``None`` takes the default of :mod:`tumblemc.model.step_size`:
        :data:`DEFAULT_DT` (set by the convergence study) or a whole divisor of it that
        resolves the field's period, the magnet's natural frequency and the initial spin
        (the run's ``dt_rule`` attribute says which).
    rotation : {"momentum", "paper", "midpoint"}
        The rotational row of the discrete model: ``"momentum"`` (default), which keeps a
        free body's angular momentum and never makes energy (MODEL.md, "The discrete
        model"); ``"paper"``, the paper's explicit gyroscopic form, which gains energy in
        a spin off a principal axis (the energy ledger flags such runs); ``"midpoint"``
        (with ``torque="mid"``), the pose turned by the mean velocity, far less damping of
        fast spins (docs/notes/step_size.md). Planar motion is the same in the first two.
    torque : {"start", "end", "mid"}
        Where in the step the magnetic torque is evaluated: ``"start"`` (default, accurate),
        ``"end"`` (the paper's choice; numerically damped, see MODEL.md "Numerics") or
        ``"mid"`` (their mean).
    record_every : int
        Record every k-th step (iteration counts are summed, penetration is maxed).
    solver : SolverOptions, optional
    lift_m, v0, omega0 : optional
        Initial height above the resting pose (m), velocity (m/s) and angular velocity
        (rad/s, world frame); by default the robot starts at rest, lying flat (MODEL.md).
    max_wall_s : float or None
        Wall-time budget, s (default 600; None: no limit): a long run is first probed on its
        first steps and refused if its projected time exceeds this (:mod:`tumblemc.model.cost`).
    **overrides
        Any :class:`~tumblemc.params.Params` field by name (``mu=0.4``, ``mass=...``).

    Returns
    -------
    xarray.Dataset
        Dimension ``time``; variables and units in :mod:`tumblemc.results`; attrs hold
        every parameter in SI, the options and the package version.
    """
    spec = prepare(
        run_inputs(
            shape,
            preset,
            incline_deg,
            field_mT,
            freq_hz,
            duration_s,
            dt,
            field=field,
            periods=periods,
            torque=torque,
            rotation=rotation,
            record_every=record_every,
            solver=solver,
            lift_m=lift_m,
            v0=v0,
            omega0=omega0,
            **overrides,
        )
    )
    check_cost(spec.n_steps, spec.dt, lambda n: run_spec(spec, n_steps=n), max_wall_s)
    rec, status, failed = run_spec(spec)
    return to_dataset(spec, rec, status, failed)
