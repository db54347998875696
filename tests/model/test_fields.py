"""Field programs (MODEL.md, "Field programs").

The kernel against its NumPy twin, the shorthand, validation and the work bound.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumblemc
from tumblemc import SolverOptions
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_dir, field_work_bound, program_field
from tumblemc.model.fields import Rotating, Sequence, Static, compile_program, field_at, peak_mT, revolutions, scale_program
from tumblemc.model.frames import plane_frame
from tumblemc.model.run import prepare, run_inputs

PROGRAMS = [
    Static(12.0, (0.3, -0.2, -1.0)),
    Rotating(20.0, 3.0, axis=(0.0, 1.0, 1.0), cone_deg=20.0, bias_mT=(1.0, 2.0, -3.0)),
    Sequence((0.3, Rotating(20.0, 1.0)), (0.25, Static(5.0, (0, 0, 1))), (0.4, Rotating(15.0, 2.0, axis=(0, 1, 0)))),
]


def _kernel_prm(program: np.ndarray) -> np.ndarray:
    prm = np.zeros(L.N_PRM + program.size)
    prm[L.P_FPROG] = len(program)
    prm[L.P_FIELD_ON] = 1.0
    prm[L.N_PRM :] = program.ravel()
    return prm


@pytest.mark.parametrize("field", PROGRAMS, ids=["static", "rotating", "sequence"])
def test_kernel_field_matches_numpy_twin(field) -> None:
    prog = compile_program(field, 30.0)
    prm = _kernel_prm(prog)
    t = np.linspace(0.0, 1.5, 301)
    want = field_at(prog, t)
    got = np.zeros((len(t), 3))
    for i, ti in enumerate(t):
        program_field(prm, ti, got[i])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


def test_rotating_formula_by_hand() -> None:
    # B(t) = |B| (cos psi s + sin psi (a x s)) + bias with the start projected off the axis
    a = np.array([0.0, 1.0, 1.0]) / math.sqrt(2)
    f = Rotating(10.0, 2.0, axis=tuple(a), start=(1.0, 0.0, 0.0), bias_mT=(0.0, 0.0, 1.0))
    t = 0.1
    psi = 2 * math.pi * 2.0 * t
    s = np.array([1.0, 0.0, 0.0])
    want = 1e-2 * (math.cos(psi) * s + math.sin(psi) * np.cross(a, s)) + np.array([0, 0, 1e-3])
    np.testing.assert_allclose(field_at(compile_program(f, 0.0), np.array([t]))[0], want, atol=1e-17)
    # the cone keeps the magnitude and leans toward +axis
    c = field_at(compile_program(Rotating(10.0, 1.0, axis=(0, 0, 1), cone_deg=30.0), 0.0), np.linspace(0, 1, 7))
    np.testing.assert_allclose(np.linalg.norm(c, axis=1), 1e-2, rtol=1e-14)
    np.testing.assert_allclose(c[:, 2], 1e-2 * math.sin(math.radians(30.0)), rtol=1e-14)


def test_paper_field_is_the_default_rotating_program() -> None:
    # Rotating(mT, hz) with the defaults is the paper's field R_x(2 pi f t) u
    for inc in (0.0, 37.0):
        prog = compile_program(Rotating(20.0, 1.5), inc)
        prm = np.zeros(L.N_PRM)
        prm[L.P_FREQ] = 1.5
        prm[L.P_U : L.P_U + 3] = plane_frame(inc)["u"]
        t = np.linspace(0, 2, 50)
        paper = np.zeros((len(t), 3))
        for i, ti in enumerate(t):
            field_dir(prm, ti, paper[i])
        np.testing.assert_allclose(field_at(prog, t), 0.02 * paper, atol=1e-17)


def test_sequence_continues_the_field_and_counts_revolutions() -> None:
    seq = Sequence((0.3, Rotating(20.0, 1.0)), (1.0, Rotating(20.0, 2.0, axis=(0.0, 0.6, 0.8))))
    prog = compile_program(seq, 0.0)
    before, after = field_at(prog, np.array([0.3 - 1e-12, 0.3]))
    axis = np.array([0.0, 0.6, 0.8])
    # the second segment starts at the first one's end direction projected off its axis
    proj = before - (before @ axis) * axis
    np.testing.assert_allclose(after / np.linalg.norm(after), proj / np.linalg.norm(proj), atol=1e-9)
    assert revolutions(prog, 1.3) == pytest.approx(0.3 + 2.0)
    assert revolutions(prog, 0.2) == pytest.approx(0.2)
    assert peak_mT(prog) == pytest.approx(20.0)
    # the run lasts the sequence by default; freq_hz is the mean rotation rate
    inp = run_inputs(field=seq)
    assert inp.duration_s == pytest.approx(1.3)
    assert inp.freq_hz == pytest.approx(2.3 / 1.3)


def test_periods_of_a_rotating_program() -> None:
    inp = run_inputs(field=Rotating(20.0, 4.0, axis=(0, 1, 0)), periods=3)
    assert inp.duration_s == pytest.approx(0.75) and inp.freq_hz == pytest.approx(4.0)


def test_work_bound_of_a_program() -> None:
    seq = Sequence((0.5, Rotating(20.0, 1.0)), (1.0, Static(10.0, (0, 0, -1))))
    spec = prepare(run_inputs(field=seq))
    k = spec.params.V_m * spec.params.magnetization / spec.units.torque  # torque per tesla
    T = 1.5 / spec.units.time
    want = k * 0.02 * (2 + 2 * math.pi * 1.0 * 0.5) + k * 0.01 * 2
    assert field_work_bound(spec.prm, T) == pytest.approx(want, rel=1e-12)
    # the paper's field: |m||B| (2 + 2 pi f T) as before programs
    p = prepare(run_inputs(field_mT=20.0, freq_hz=1.0)).prm
    assert field_work_bound(p, 3.0) == p[L.P_TORQ] * (2.0 + 2.0 * math.pi * p[L.P_FREQ] * 3.0)
    # scaling: times and frequencies in kernel units, fields as torques
    sp = scale_program(compile_program(seq, 0.0), 2.0, 3.0)
    assert sp[1, L.FS_T0] == 0.25 and sp[0, L.FS_FREQ] == 2.0 and sp[0, L.FS_AMP] == pytest.approx(0.06)


def test_shorthand_and_program_give_the_same_run() -> None:
    # the default Rotating is the shorthand itself (identical records); an explicit start
    # takes the program path, equal to rounding with a fresh Newton matrix at every
    # iteration and the quadratic warm start, and to the solver's tolerance with the chord
    # start and the cubic warm start (SolverOptions.chord_iter, warm_order: a rounding
    # difference can change how many chord iterations a step takes, or which extrapolation
    # the next step starts from)
    for chord, rel in ((0, 1e-9), (SolverOptions().chord_iter, 1e-6)):
        so = SolverOptions(chord_iter=chord, warm_order=2 if chord == 0 else SolverOptions().warm_order)
        a = tumblemc.simulate("cuboid", "paper", 45.0, 20.0, 1.0, duration_s=0.3, solver=so)
        b = tumblemc.simulate("cuboid", "paper", 45.0, duration_s=0.3, field=Rotating(20.0, 1.0), solver=so)
        c = tumblemc.simulate(
            "cuboid", "paper", 45.0, duration_s=0.3, field=Rotating(20.0, 1.0, start=tuple(plane_frame(45.0)["u"])), solver=so
        )
        for v in ("position", "quaternion", "omega", "normal_force", "field"):
            np.testing.assert_array_equal(a[v].values, b[v].values)
            np.testing.assert_allclose(a[v].values, c[v].values, rtol=0, atol=rel * float(np.abs(a[v]).max() + 1e-30))
        assert c.attrs["field_program"].startswith("rotating 20 mT")
        assert a.attrs["field_program"] == "paper"
        np.testing.assert_allclose(c["magnetic_energy"].values, a["magnetic_energy"].values, rtol=0, atol=1e-20 if chord == 0 else 1e-17)


def test_static_field_holds_still_and_ledger_balances() -> None:
    # the paper robot under a weak static field along its magnetisation stays put
    ds = tumblemc.simulate("cuboid", "paper", 0.0, duration_s=0.2, field=Static(5.0, (0.0, -1.0, 0.0)))
    assert ds.attrs["status"] == 0
    assert float(np.abs(ds["position"] - ds["position"][0]).max()) < 1e-9
    np.testing.assert_allclose(ds["field"].values, np.tile([0.0, -5e-3, 0.0], (ds.sizes["time"], 1)))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"field": Static(5.0), "field_mT": 5.0}, "both given"),
        ({"field": "static"}, "field='static' is not allowed"),
        ({"field": Static(5.0), "periods": 2}, "periods=2 is not allowed with a Static program"),
    ],
)
def test_bad_field_inputs(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        run_inputs(**kwargs)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Static(5.0, (0, 0, 0)), r"Static.direction=\(0, 0, 0\)"),
        (lambda: Static(-1.0), "Static.mT=-1.0"),
        (lambda: Rotating(5.0, -1.0), "Rotating.hz=-1.0"),
        (lambda: Rotating(5.0, 1.0, start=(2, 0, 0)), "parallel to axis"),
        (lambda: Rotating(5.0, 1.0, cone_deg=90), "Rotating.cone_deg=90"),
        (lambda: Sequence(), "no segments"),
        (lambda: Sequence((0.0, Static(1.0))), "duration_s=0.0"),
        (lambda: Sequence((1.0, 3.0)), "Sequence segment 0"),
    ],
)
def test_bad_programs_name_the_field(make, match) -> None:
    with pytest.raises(ValueError, match=match):
        make()
