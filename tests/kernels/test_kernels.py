"""The Numba residual kernel against an independent plain-numpy twin (tests/naive.py).

1. ``F`` of :func:`tumblemc.kernels.residual.residual` equals the naive residual on random
   states (three geometries, torque at the start and at the end of the step, random
   incline, inertia, step and complementarity variables, some of them exactly zero).
2. Its analytic Jacobian equals central finite differences of the kernel's and of the
   naive ``F`` away from Fischer-Burmeister kinks.
3. :func:`tumblemc.kernels.residual.fb` against an exact decimal reference, also where the
   textbook formula cancels, and its sign properties.
4. At exact FB kinks (``a = b = 0``) the Jacobian row is an element of the generalised
   Jacobian, ``(1 - alpha) grad a + (1 - beta) grad b`` with ``alpha^2 + beta^2 <= 1``,
   and it is the De Luca-Facchinei-Kanzow element the kernel documents.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from tests import naive
from tests.naive import block_index, fb_exact, fb_plain, fb_smooth_exact, naive_model, naive_residual
from tumblemc.kernels import layout as L
from tumblemc.kernels.newton import make_workspace
from tumblemc.kernels.residual import Problem, fb, fb_smooth, n_unknowns, residual

# ---- tolerances (named, in one place) --------------------------------------------------
F_RTOL = 1e-12  # kernel F vs naive F, relative to 1 + max|F|; seen: <= 2e-15
FD_STEP = 1e-6  # central-difference step on the (O(1), scaled) unknowns
FD_RTOL = 1e-6  # max_j |J_ij - Jfd_ij| <= FD_RTOL * (1 + max_j |J_ij| + 1e-16 |F_i| / FD_STEP); seen: <= 4e-9
KINK_MIN = 1e-2  # FD points keep every FB pair at least this far from (0, 0)
FB_RTOL = 4e-16  # fb vs the correctly rounded value: a few ulps
GJ_TOL = 1e-9  # generalised-Jacobian membership checks

SETTINGS = settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


# ---- geometries ---------------------------------------------------------------------------


def _planes(normals, ds):  # type: ignore[no-untyped-def]
    cd = np.zeros((len(ds), 4))
    for i, (nb, d) in enumerate(zip(normals, ds, strict=True)):
        nb = np.asarray(nb, dtype=float)
        cd[i, :3] = nb / np.linalg.norm(nb)
        cd[i, 3] = d
    return cd


def cuboid(hx=2.0, hy=4.0, hz=0.5, centre=(0.0, 0.0, 0.0)):  # type: ignore[no-untyped-def]
    """Six half-spaces of a box with half-dimensions hx, hy, hz about ``centre``."""
    c = np.asarray(centre, dtype=float)
    normals = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    halves = [hx, hx, hy, hy, hz, hz]
    ds = [hv + np.dot(nb, c) for nb, hv in zip(normals, halves, strict=True)]
    return _planes(normals, ds)


def geom_cuboid():  # type: ignore[no-untyped-def]
    cdata = cuboid()
    return np.zeros(6, np.int64), cdata, np.array([0, 6], np.int64)


def geom_curved():  # type: ignore[no-untyped-def]
    """The curved robot's hull: x faces, outer arc (C_CYL_X), two radial ends, inner chord."""
    zc, r_out, r_in, half = 11.8, 12.5, 11.0, math.radians(25.0)
    s, c = math.sin(half), math.cos(half)
    planes = _planes(
        [(1, 0, 0), (-1, 0, 0), (0, c, s), (0, -c, s), (0, 0, 1)],
        [2.0, 2.0, s * zc, s * zc, zc - r_in * c],
    )
    cdata = np.zeros((6, 4))
    cdata[:2] = planes[:2]
    cdata[2] = (0.0, zc, r_out, 0.0)
    cdata[3:] = planes[2:]
    ctype = np.array([0, 0, L.C_CYL_X, 0, 0, 0], np.int64)
    return ctype, cdata, np.array([0, 6], np.int64)


def geom_two_pieces():  # type: ignore[no-untyped-def]
    """A bar and a slanted block (non-axis normals): pstart = [0, 6, 12]."""
    bar = cuboid(1.5, 4.0, 0.75)
    spike = _planes(
        [(1, 0, 0), (-1, 0, 0), (0, 0.6, 0.8), (0, -0.6, 0.8), (0, 0.3, -1.0), (0.2, 1.0, 0.1)],
        [1.5, 1.5, 2.5, 2.5, 0.75, 3.0],
    )
    return np.zeros(12, np.int64), np.vstack([bar, spike]), np.array([0, 6, 12], np.int64)


GEOMETRIES = {"cuboid": geom_cuboid, "curved": geom_curved, "two_pieces": geom_two_pieces}


# ---- random problems ------------------------------------------------------------------------


def incline_frame(theta):  # type: ignore[no-untyped-def]
    s, c = math.sin(theta), math.cos(theta)
    return np.array([0.0, s, c]), np.array([1.0, 0.0, 0.0]), np.array([0.0, c, -s])


def make_problem(geom, seed, torque_end, theta, h, p_zero):  # type: ignore[no-untyped-def]
    """A random step: returns (z, sc, prm, ctype, cdata, pstart)."""
    rng = np.random.default_rng(seed)
    ctype, cdata, pstart = GEOMETRIES[geom]()
    nrm, tt, oo = incline_frame(theta)

    prm = np.zeros(L.N_PRM)
    prm[L.P_MASS] = rng.uniform(0.5, 2.0)
    prm[L.P_G] = 1.0
    prm[L.P_MU] = rng.uniform(0.1, 1.0)
    prm[L.P_ET] = rng.uniform(0.5, 2.0)
    prm[L.P_EO] = rng.uniform(0.5, 2.0)
    prm[L.P_ER] = rng.choice([rng.uniform(0.05, 1.0), rng.uniform(1.0, 20.0)])  # both r-row scalings
    prm[L.P_TORQUE_END] = 1.0 if torque_end else 0.0
    prm[L.P_N : L.P_N + 3] = nrm
    prm[L.P_T : L.P_T + 3] = tt
    prm[L.P_O : L.P_O + 3] = oo
    prm[L.P_U : L.P_U + 3] = (0.0, -math.cos(theta), math.sin(theta))
    eb = rng.normal(size=3)
    prm[L.P_EB : L.P_EB + 3] = eb / np.linalg.norm(eb)
    A = rng.normal(size=(3, 3))
    Ib = A @ A.T + rng.uniform(0.2, 2.0) * np.eye(3)  # symmetric positive definite
    prm[L.P_IB : L.P_IB + 9] = Ib.ravel()
    prm[L.P_FIELD_ON] = 1.0
    # both rotation rows (momentum form, the paper's explicit form), from a separate stream
    # so that every other draw stays what it was
    prm[L.P_ROT_PAPER] = 1.0 if np.random.default_rng([seed, 1]).random() < 0.5 else 0.0
    # the pose update and the torque's end weight: the paper's (1) or the midpoint rule's
    # (0.5), from another stream
    prm[L.P_POSE_W0] = 0.5 if np.random.default_rng([seed, 2]).random() < 0.3 else 0.0
    if prm[L.P_POSE_W0] == 0.5 and np.random.default_rng([seed, 3]).random() < 0.5:
        prm[L.P_TORQUE_END] = 0.5

    sc = np.zeros(L.N_SC)
    sc[L.S_X : L.S_X + 3] = rng.normal(size=3) * 2.0
    q = rng.normal(size=4)
    sc[L.S_Q : L.S_Q + 4] = q / np.linalg.norm(q)
    sc[L.S_V : L.S_V + 3] = rng.normal(size=3)
    sc[L.S_W : L.S_W + 3] = rng.normal(size=3) * 2.0
    sc[L.S_H] = h
    sc[L.S_FEXT : L.S_FEXT + 3] = rng.normal(size=3)
    sc[L.S_TM : L.S_TM + 3] = rng.normal(size=3)
    sc[L.S_B1 : L.S_B1 + 3] = rng.normal(size=3)

    n = n_unknowns(pstart)
    z = np.zeros(n)
    z[0:3] = rng.normal(size=3)
    z[3:6] = rng.normal(size=3) * 2.0
    for blk in block_index(pstart):
        a1 = sc[L.S_X : L.S_X + 3] + rng.normal(size=3) * 3.0
        z[blk["a1"] : blk["a1"] + 3] = a1
        z[blk["a2"] : blk["a2"] + 3] = a1 + rng.normal(size=3)
        for key in ("lt", "lo", "lr"):
            z[blk[key]] = rng.normal()
        for row in [blk["sig"], *blk["l"], blk["ls"], blk["ln"]]:
            z[row] = 0.0 if rng.random() < p_zero else rng.uniform(0.0, 3.0)
    return z, sc, prm, ctype, cdata, pstart


def kernel(z, sc, prm, ctype, cdata, pstart, want_J=True, mu_s=None):  # type: ignore[no-untyped-def]
    """Run the kernel on fresh workspaces; returns (F, J, theta). ``mu_s=None``: default FB."""
    ws = make_workspace(z.size)
    a = (z, Problem(sc, prm, ctype, cdata, pstart), ws.F, ws.J, (ws.isfb, ws.fbb, ws.rs), want_J)
    theta = residual(*a) if mu_s is None else residual(*a, mu_s)
    return ws.F.copy(), ws.J.copy(), theta


def fd_jacobian(fun, z, step=FD_STEP):  # type: ignore[no-untyped-def]
    n = z.size
    Jfd = np.empty((n, n))
    for j in range(n):
        zp = z.copy()
        zm = z.copy()
        zp[j] += step
        zm[j] -= step
        Jfd[:, j] = (fun(zp) - fun(zm)) / (2.0 * step)
    return Jfd


def fb_rows(pstart):  # type: ignore[no-untyped-def]
    rows = []
    for blk in block_index(pstart):
        rows += [blk["sig"], *blk["l"], blk["ls"], blk["ln"]]
    return rows


problem_args = dict(
    seed=st.integers(0, 2**32 - 1),
    torque_end=st.booleans(),
    theta=st.floats(0.0, 1.3),
    h=st.floats(1e-3, 1.0),
)


# ---- 1. residual -------------------------------------------------------------------------


@pytest.mark.parametrize("geom", sorted(GEOMETRIES))
@SETTINGS
@given(p_zero=st.sampled_from([0.0, 0.3, 1.0]), **problem_args)
def test_residual_matches_naive(geom, seed, torque_end, theta, h, p_zero):  # type: ignore[no-untyped-def]
    args = make_problem(geom, seed, torque_end, theta, h, p_zero)
    Fk, _, theta_k = kernel(*args, want_J=True)
    Fk_nojac, _, theta_nojac = kernel(*args, want_J=False)
    Fn = naive_residual(*args)
    scale = 1.0 + np.abs(Fn).max()
    err = np.abs(Fk - Fn)
    assert err.max() <= F_RTOL * scale, f"rows {np.flatnonzero(err > F_RTOL * scale)}: kernel {Fk} naive {Fn}"
    np.testing.assert_array_equal(Fk, Fk_nojac)
    assert theta_k == theta_nojac
    assert math.isclose(theta_k, 0.5 * float(Fn @ Fn), rel_tol=1e-12, abs_tol=1e-300)


def test_residual_hand_checked_state():
    """Identity pose at the origin, at rest, all unknowns zero: Phi = (-F_ext, -T_m, 0, n, 0...)."""
    z, sc, prm, ctype, cdata, pstart = make_problem("cuboid", 0, False, 0.3, 0.1, 0.0)
    sc[L.S_X : L.S_X + 3] = 0.0
    sc[L.S_Q : L.S_Q + 4] = (1.0, 0.0, 0.0, 0.0)
    sc[L.S_V : L.S_V + 3] = 0.0
    sc[L.S_W : L.S_W + 3] = 0.0
    z[:] = 0.0
    Fk, _, _ = kernel(z, sc, prm, ctype, cdata, pstart)
    expect = np.zeros(24)
    expect[0:3] = -sc[L.S_FEXT : L.S_FEXT + 3]
    expect[3:6] = -sc[L.S_TM : L.S_TM + 3]
    expect[9:12] = prm[L.P_N : L.P_N + 3]  # sum l_i N_i + n at the a2 slots
    np.testing.assert_array_equal(Fk, expect)
    np.testing.assert_array_equal(naive_residual(z, sc, prm, ctype, cdata, pstart), expect)
    assert n_unknowns(pstart) == 24


# ---- 2. Jacobian against finite differences -------------------------------------------------


def _check_jacobian(J, Jfd, F, label):  # type: ignore[no-untyped-def]
    row_scale = 1.0 + np.abs(J).max(axis=1) + np.abs(F) * 1e-16 / FD_STEP
    err = np.abs(J - Jfd).max(axis=1)
    bad = err > FD_RTOL * row_scale
    assert not bad.any(), f"{label}: rows {np.flatnonzero(bad).tolist()} err {err[bad]} scale {row_scale[bad]}"


def _fd_point(geom, seed, torque_end, theta, h, p_zero):  # type: ignore[no-untyped-def]
    args = make_problem(geom, seed, torque_end, theta, h, p_zero)
    pairs = naive_model(*args)["pairs"]
    return args, min(math.hypot(a, b) for a, b in pairs.values()) > KINK_MIN


@pytest.mark.parametrize("geom", sorted(GEOMETRIES))
@SETTINGS
@given(p_zero=st.sampled_from([0.0, 0.3]), **problem_args)
def test_jacobian_matches_finite_differences(geom, seed, torque_end, theta, h, p_zero):  # type: ignore[no-untyped-def]
    args, away_from_kinks = _fd_point(geom, seed, torque_end, theta, max(h, 0.01), p_zero)
    assume(away_from_kinks)
    z, rest = args[0], args[1:]
    Fk, Jk, _ = kernel(*args)
    Jfd_kernel = fd_jacobian(lambda zz: kernel(zz, *rest, want_J=False)[0], z)
    _check_jacobian(Jk, Jfd_kernel, Fk, "kernel J vs FD of kernel F")
    Jfd_naive = fd_jacobian(lambda zz: naive_residual(zz, *rest), z)
    _check_jacobian(Jk, Jfd_naive, Fk, "kernel J vs FD of naive F")


@pytest.mark.parametrize("geom", ["curved", "two_pieces"])
@settings(max_examples=10, deadline=None, derandomize=True, database=None)
@given(mu_s=st.floats(0.01, 0.5), p_zero=st.sampled_from([0.0, 1.0]), **problem_args)
def test_smoothed_residual_and_jacobian(geom, seed, torque_end, theta, h, mu_s, p_zero):  # type: ignore[no-untyped-def]
    """``mu_s > 0`` (smoothing continuation): F vs naive, J vs FD; smooth everywhere, kinks too."""
    args = make_problem(geom, seed, torque_end, theta, max(h, 0.01), p_zero)
    z, rest = args[0], args[1:]
    Fk, Jk, _ = kernel(*args, mu_s=mu_s)
    Fn = naive_residual(*args, mu_s=mu_s)
    assert np.abs(Fk - Fn).max() <= F_RTOL * (1.0 + np.abs(Fn).max())
    Jfd = fd_jacobian(lambda zz: kernel(zz, *rest, want_J=False, mu_s=mu_s)[0], z)
    _check_jacobian(Jk, Jfd, Fk, "smoothed: kernel J vs FD of kernel F")


# ---- 3. the Fischer-Burmeister function -------------------------------------------------------

finite = st.one_of(
    st.just(0.0),
    st.floats(1e-150, 1e150),
    st.floats(-1e150, -1e-150),
)


@settings(max_examples=300, deadline=None, derandomize=True, database=None)
@given(a=finite, b=finite)
def test_fb_accuracy_and_sign(a, b):  # type: ignore[no-untyped-def]
    v = fb(a, b)
    ref = fb_exact(a, b)
    assert abs(v - ref) <= FB_RTOL * abs(ref) + 1e-300, (a, b, v, ref)
    assert fb(b, a) == v  # symmetric
    if a >= 0.0 and b >= 0.0 and a * b == 0.0:
        assert v == 0.0
    else:
        assert v != 0.0
    if a >= 0.0 and b >= 0.0:
        assert 0.0 <= v <= min(a, b)
    else:
        assert v < 0.0


@pytest.mark.parametrize(
    "a, b",
    [(1e8, 1e-8), (1.0, 1e-12), (3.0, 4e-20), (1e-30, 5.0), (1e150, 1e-150), (1e-100, 1e-120), (1.0, 1.0), (2.0, 0.0)],
)
def test_fb_cancellation_free(a, b):  # type: ignore[no-untyped-def]
    """a, b > 0 with one tiny: the textbook formula cancels, the kernel's must not."""
    ref = fb_exact(a, b)
    assert abs(fb(a, b) - ref) <= FB_RTOL * abs(ref)
    if 0.0 < min(a, b) < 1e-10 * max(a, b):
        assert ref > 0.0 and abs(fb_plain(a, b) - ref) > 1e-6 * ref  # why the form matters


@pytest.mark.parametrize("a, b", [(1e-200, 1e-200), (1e-160, 1e-170), (1e-150, 1e-160)])
def test_fb_tiny_positive_pairs(a, b):  # type: ignore[no-untyped-def]
    """A * b would underflow; the kernel divides first."""
    ref = fb_exact(a, b)
    assert ref > 0.0
    assert abs(fb(a, b) - ref) <= FB_RTOL * ref


@settings(max_examples=100, deadline=None, derandomize=True, database=None)
@given(a=st.floats(-1e6, 1e6), b=st.floats(-1e6, 1e6), mu=st.floats(1e-8, 1.0))
def test_fb_smooth_accuracy(a, b, mu):  # type: ignore[no-untyped-def]
    val, rho = fb_smooth(a, b, mu)
    ref = fb_smooth_exact(a, b, mu)
    assert abs(val - ref) <= 8e-16 * abs(ref) + 1e-300, (a, b, mu, val, ref)
    assert math.isclose(rho, math.sqrt(a * a + b * b + 2 * mu * mu), rel_tol=1e-15)
    assert (val == 0.0) == (ref == 0.0)


def test_fb_simple_values():
    assert fb(0.0, 0.0) == 0.0
    assert fb(0.0, 5.0) == 0.0 and fb(5.0, 0.0) == 0.0
    assert fb(-1.0, 0.0) == -2.0 and fb(0.0, -1.0) == -2.0
    assert fb(3.0, 4.0) == 2.0
    assert fb(-3.0, -4.0) == -12.0
    assert fb(3.0, -4.0) == fb_exact(3.0, -4.0) == -6.0


# ---- 4. generalised Jacobian at exact kinks -------------------------------------------------


def _kink_problem(kinds, seed, torque_end, theta):  # type: ignore[no-untyped-def]
    """A cuboid step with exact a = b = 0 in the FB pairs named in ``kinds``.

    ``ln``: lam_n = 0 and a1 = (alpha, 0, 0) so n.a1 = 0 exactly (n_x = 0).
    ``ls``: l_s = 0 and a2 = (beta, 0, 0).
    ``sig``: sigma = 0, e_t = 1, lam_o = lam_r = 0, lam_t = mu lam_n, so the cone is 0.
    ``l0``: l_1 = 0 on the +x face with an exact identity end pose (Q = 1, w = w+ = v+ = 0,
      x = 0) and a1_x = 2.
    """
    z, sc, prm, ctype, cdata, pstart = make_problem("cuboid", seed, torque_end, theta, 0.2, 0.0)
    blk = block_index(pstart)[0]
    rng = np.random.default_rng(seed + 1)
    if "l0" in kinds:
        sc[L.S_Q : L.S_Q + 4] = (1.0, 0.0, 0.0, 0.0)
        sc[L.S_X : L.S_X + 3] = 0.0
        sc[L.S_W : L.S_W + 3] = 0.0  # the midpoint rule's pose turns by the mean of w and w+
        z[0:6] = 0.0
        z[blk["l"][0]] = 0.0
        z[blk["a1"]] = 2.0
    if "ln" in kinds:
        z[blk["ln"]] = 0.0
        z[blk["a1"] : blk["a1"] + 3] = (z[blk["a1"]] if "l0" in kinds else rng.normal(), 0.0, 0.0)
    if "ls" in kinds:
        z[blk["ls"]] = 0.0
        z[blk["a2"] : blk["a2"] + 3] = (rng.normal(), 0.0, 0.0)
    if "sig" in kinds:
        z[blk["sig"]] = 0.0
        prm[L.P_ET] = 1.0
        z[blk["lo"]] = 0.0
        z[blk["lr"]] = 0.0
        z[blk["lt"]] = prm[L.P_MU] * z[blk["ln"]]
    return z, sc, prm, ctype, cdata, pstart


KINK_SETS = [("ln",), ("ls",), ("sig",), ("l0",), ("ln", "ls"), ("ln", "sig"), ("l0", "ln", "ls", "sig")]


@pytest.mark.parametrize("kinds", KINK_SETS, ids=["+".join(k) for k in KINK_SETS])
@settings(max_examples=8, deadline=None, derandomize=True, database=None)
@given(seed=st.integers(0, 2**31), torque_end=st.booleans(), theta=st.floats(0.0, 1.3))
def test_kink_row_in_generalised_jacobian(kinds, seed, torque_end, theta):  # type: ignore[no-untyped-def]
    args = _kink_problem(kinds, seed, torque_end, theta)
    z, rest = args[0], args[1:]
    pairs = naive_model(*args)["pairs"]
    blk = block_index(args[5])[0]
    kink_rows = [blk[k] if k != "l0" else blk["l"][0] for k in kinds]
    for row in kink_rows:
        a, b = pairs[row]
        assert a == 0.0 and b == 0.0, (row, a, b)  # the construction is exact
    degenerate = [r for r, (a, b) in pairs.items() if a == 0.0 and b == 0.0]
    assert sorted(degenerate) == sorted(kink_rows)

    F, J, _ = kernel(*args)
    assert np.all(F[kink_rows] == 0.0)
    zdir = np.zeros(z.size)
    zdir[degenerate] = 1.0
    for row in kink_rows:
        # grad a = e_row; grad b by central differences of the naive (smooth) b
        gb = fd_jacobian(lambda zz, row=row: np.array([naive_model(zz, *rest)["pairs"][row][1]]), z)[0]
        assert abs(gb[row]) <= GJ_TOL  # b does not depend on its own complementarity variable
        gb[row] = 0.0
        Jrow = J[row].copy()
        ca = Jrow[row]
        others = np.delete(Jrow, row)
        gbo = np.delete(gb, row)
        gscale = 1.0 + np.abs(gbo).max()
        if np.abs(gbo).max() > GJ_TOL:
            cb = float(others @ gbo) / float(gbo @ gbo)
        else:
            cb = 1.0  # any beta with alpha^2 + beta^2 <= 1 fits; the row must then be ca e_row
        assert np.abs(others - cb * gbo).max() <= GJ_TOL * gscale, (row, Jrow, gb)
        alpha, beta = 1.0 - ca, 1.0 - cb
        assert alpha * alpha + beta * beta <= 1.0 + GJ_TOL, (row, alpha, beta)
        # and it is the documented DFK element: z_j = 1 on the degenerate variables
        d = float(gb @ zdir)
        rho = math.hypot(1.0, d)
        assert abs(ca - (1.0 - 1.0 / rho)) <= GJ_TOL
        if np.abs(gbo).max() > GJ_TOL:
            assert abs(cb - (1.0 - d / rho)) <= GJ_TOL * gscale


@pytest.mark.parametrize("tilt", [1e-5, 1e-3, 3e-2])
def test_snap_guess_lays_the_nearest_face_flat(tilt: float) -> None:
    """The snap guess lays the nearest face flat.

    ``guesses.snap_flat`` (``G_SNAP_FLAT``): from the cuboid's rest pose tilted by ``tilt``
    about a horizontal axis, the angular velocity it returns lays the bottom face flat at
    the end of the step up to the quaternion update's own error (angle 2 atan(h|w|/2)
    instead of h|w|: third order); a face tilted beyond SNAP_MAX_TILT is refused.
    """
    from tumblemc.kernels.geometry import N_QS, QS_Q, quat_step, quat_to_rot
    from tumblemc.kernels.guesses import SNAP_MAX_TILT, snap_flat
    from tumblemc.model.frames import quat_to_matrix, rot_to_quat
    from tumblemc.model.run import prepare, run_inputs

    spec = prepare(run_inputs(duration_s=0.01, incline_deg=20.0))
    n = spec.prm[L.P_N : L.P_N + 3]
    h = spec.h
    rng = np.random.default_rng(3)
    a = np.cross(n, rng.normal(size=3))
    a /= np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])

    def tilted(angle: float) -> np.ndarray:
        rot = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
        return rot @ quat_to_matrix(spec.state0[3:7])

    def bottom_tilt(R: np.ndarray) -> float:
        normals = (R @ spec.geo.cdata[:, :3].T).T
        nb = normals[np.argmax(-normals @ n)]
        return float(math.atan2(np.linalg.norm(np.cross(nb, -n)), -nb @ n))

    R0 = tilted(tilt)
    assert bottom_tilt(R0) == pytest.approx(tilt, rel=1e-6)
    w0 = np.zeros(3)
    w = np.zeros(3)
    assert snap_flat(R0.ravel(), spec.prm, spec.geo, h, w0, w)
    blk, R1 = np.zeros(N_QS), np.zeros(9)
    quat_step(rot_to_quat(R0), 0, w, 0, h, blk, 0, w, 0, 1.0)
    quat_to_rot(blk, QS_Q, R1, 0)
    assert bottom_tilt(R1.reshape(3, 3)) <= tilt**3 + 1e-14
    assert not snap_flat(tilted(1.5 * SNAP_MAX_TILT).ravel(), spec.prm, spec.geo, h, w0, w)


# ---- the sparse LU of the Newton solver -------------------------------------------------


@pytest.mark.parametrize("seed", range(40))
def test_lu_factor_and_solve_against_numpy(seed: int) -> None:
    """The LU factorisation and solve agree with numpy.

    ``lu_factor``/``lu_solve`` (rows left in place, nonzero lists) solve sparse systems
    like numpy, pivot ties included, and report exactly singular ones.
    """
    from tumblemc.kernels.lu import lu_factor, lu_solve

    rng = np.random.default_rng(seed)
    n = 6 + seed % 23
    A = np.where(rng.random((n, n)) < 0.3, rng.standard_normal((n, n)), 0.0)
    A[np.arange(n), rng.permutation(n)] += rng.choice([-2.0, -1.0, 1.0, 2.0], n)  # nonsingular, many ties
    if seed % 4 == 3:
        A[:, seed % n] = np.round(A[:, seed % n])  # tied pivot candidates
    ws = make_workspace(n)
    M = A.copy()
    b = rng.standard_normal(n)
    x = b.copy()
    cond = np.linalg.cond(A)
    assert cond < 1e10  # the construction keeps these systems well posed
    assert lu_factor(M, ws.piv, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, -1.0, A, True)
    assert sorted(ws.piv) == list(range(n))
    # a matrix that passes the matrix-wide test is factored the same with or without the row test
    ws0 = make_workspace(n)
    M0 = A.copy()
    assert lu_factor(M0, ws0.piv, n, ws0.unz, ws0.ucnt, ws0.lnz, ws0.lcnt, -1.0, A, False)
    assert np.array_equal(M0.view(np.int64), M.view(np.int64)) and np.array_equal(ws0.piv, ws.piv)
    lu_solve(M, ws.piv, x, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, ws.y)
    np.testing.assert_allclose(A @ x, b, rtol=0, atol=1e-13 * cond * (1 + np.abs(b).max()))
    S = A.copy()
    S[:, seed % n] = 0.0  # a zero column: singular
    assert not lu_factor(S.copy(), ws.piv, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, -1.0, S, True)


@pytest.mark.parametrize("seed", range(20))
def test_lu_factor_row_test_factors_rows_of_disparate_scale(seed: int) -> None:
    """A regular matrix with one row 1e14 times the others is factored with the row test.

    The test against the largest entry alone calls it singular (every pivot of a unit row is
    below 1e-13 of the big row's entries: the Newton matrix of an impact, whose torsional
    friction row is ``mu e_r lam_n``, docs/notes/solver_gaps.md section 7). With the row test the
    solution is numpy's, and a row that is another row to 1e-15 is still refused.
    """
    from tumblemc.kernels.lu import lu_factor, lu_solve

    rng = np.random.default_rng(100 + seed)
    n = 6 + seed % 19
    A = np.where(rng.random((n, n)) < 0.3, rng.standard_normal((n, n)), 0.0)
    A[np.arange(n), rng.permutation(n)] += rng.choice([-2.0, -1.0, 1.0, 2.0], n)
    assert np.linalg.cond(A) < 1e10
    big = seed % n
    A[big] *= 1e14
    ws = make_workspace(n)
    assert not lu_factor(A.copy(), ws.piv, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, -1.0, A, False)
    M = A.copy()
    assert lu_factor(M, ws.piv, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, -1.0, A, True)
    b = rng.standard_normal(n)
    x = b.copy()
    lu_solve(M, ws.piv, x, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, ws.y)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-8, atol=1e-8 * np.abs(x).max())
    D = A.copy()
    other = (big + 1) % n
    D[other] = D[(big + 2) % n] * (1.0 + 1e-15)  # dependent to rounding: still singular
    assert not lu_factor(D.copy(), ws.piv, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, -1.0, D, True)


@pytest.mark.parametrize("seed", range(10))
def test_geometry_kernels_against_naive_twins(seed: int) -> None:
    """The one geometry implementation (offset form, shared by residual and time loop).

    At random offsets it equals itself at offset 0 bit for bit (the addressing), the naive
    quaternion update, rotation and constraint of ``tests/naive.py`` to round-off, and its
    derivative blocks (d(theta)/d(w+), the Hessian) match central differences.
    """
    from tumblemc.kernels import geometry as G

    rng = np.random.default_rng(seed)
    q = rng.standard_normal(4)
    q /= np.linalg.norm(q)
    w = rng.standard_normal(3)
    h = 10.0 ** rng.uniform(-3, 0)
    k1, k2, k3 = (int(x) for x in rng.integers(1, 9, size=3))
    qa, wa = np.zeros(k1 + 4), np.zeros(k2 + 3)
    qa[k1:], wa[k2:] = q, w
    blk0, blk = np.zeros(G.N_QS), np.full(k3 + G.N_QS, np.nan)
    G.quat_step(q, 0, w, 0, h, blk0, 0, w, 0, 1.0)
    G.quat_step(qa, k1, wa, k2, h, blk, k3, wa, k2, 1.0)
    assert np.array_equal(blk[k3:], blk0)
    # the midpoint rule's pose: turned by the mean of w0 and w+, d(theta)/d(w+) halved
    w0 = rng.standard_normal(3)
    mid, at = np.zeros(G.N_QS), np.zeros(G.N_QS)
    G.quat_step(q, 0, w, 0, h, mid, 0, w0, 0, 0.5)
    G.quat_step(q, 0, 0.5 * w + 0.5 * w0, 0, h, at, 0, w0, 0, 1.0)
    assert np.allclose(mid[G.QS_Q : G.QS_Q + 4], at[G.QS_Q : G.QS_Q + 4], rtol=0, atol=1e-15)
    assert np.allclose(mid[G.QS_JTH : G.QS_JTH + 9], 0.5 * at[G.QS_JTH : G.QS_JTH + 9], rtol=0, atol=1e-15)
    qn = blk0[G.QS_Q : G.QS_Q + 4]
    assert np.allclose(qn, naive.quat_update(q, w, h), rtol=0, atol=1e-15)
    R0, R = np.zeros(9), np.full(k1 + 9, np.nan)
    G.quat_to_rot(qn, 0, R0, 0)
    G.quat_to_rot(blk, k3 + G.QS_Q, R, k1)
    assert np.array_equal(R[k1:], R0)
    assert np.allclose(R0.reshape(3, 3), naive.rotmat(qn), rtol=0, atol=1e-15)
    # d(theta)/d(w+): dR = [Jth dw]x R
    jth = blk0[G.QS_JTH : G.QS_JTH + 9].reshape(3, 3)
    eps = 1e-6
    for j in range(3):
        dw = np.zeros(3)
        dw[j] = eps
        Rp, Rm = naive.rotmat(naive.quat_update(q, w + dw, h)), naive.rotmat(naive.quat_update(q, w - dw, h))
        S = (Rp - Rm) @ R0.reshape(3, 3).T / (2 * eps)
        assert np.allclose([S[2, 1], S[0, 2], S[1, 0]], jth[:, j], rtol=0, atol=1e-6 * np.abs(jth).max())
    # cross and skew
    a, b = rng.standard_normal(3), rng.standard_normal(3)
    o = np.zeros(k1 + 3)
    G.cross(a, 0, b, 0, o, k1)
    assert np.array_equal(o[k1:], np.cross(a, b))
    m = np.zeros(k2 + 9)
    G.skew(a, 0, m, k2)
    assert np.allclose(m[k2:].reshape(3, 3) @ b, np.cross(a, b), rtol=0, atol=1e-15)
    # constraints: value, gradient against the twin, Hessian against differences
    ctype = np.array([L.C_PLANE, L.C_CYL_X], np.int64)
    nrm = rng.standard_normal(3)
    cdata = np.array([[*(nrm / np.linalg.norm(nrm)), rng.standard_normal()], [rng.standard_normal(), rng.standard_normal(), 2.0, 0.0]])
    for c in range(2):
        y = rng.standard_normal(3)
        ya = np.zeros(k3 + 3)
        ya[k3:] = y
        out = np.full(k2 + G.N_CG, np.nan)  # every entry must be written
        f = G.constraint_eval(ctype[c], cdata, c, ya, k3, out, k2)
        f_ref, g_ref = naive.constraint(int(ctype[c]), cdata[c], y)
        assert f == pytest.approx(f_ref, abs=1e-14)
        g = out[k2 + G.CG_G : k2 + G.CG_G + 3]
        H = out[k2 + G.CG_H : k2 + G.CG_H + 9].reshape(3, 3)
        assert np.allclose(g, g_ref, rtol=0, atol=1e-15)
        Hd = np.zeros((3, 3))
        for j in range(3):
            dy = np.zeros(3)
            dy[j] = 1e-6
            Hd[:, j] = (naive.constraint(int(ctype[c]), cdata[c], y + dy)[1] - naive.constraint(int(ctype[c]), cdata[c], y - dy)[1]) / 2e-6
        assert np.allclose(H, Hd, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("seed", range(12))
def test_copy_amax_is_the_copy_and_its_largest_magnitude(seed: int) -> None:
    """``copy_amax`` is a copy and its largest magnitude.

    ``copy_amax`` copies J bit for bit and returns max |J| (signed zeros, subnormals, inf
    included), or -1 with a NaN so that ``lu_factor`` scans (skipping NaN) itself; the LU
    with the given maximum is the LU with its own scan.
    """
    from tumblemc.kernels.lu import copy_amax, lu_factor

    rng = np.random.default_rng(seed)
    n = 5 + seed
    J = np.where(rng.random((n, n)) < 0.3, rng.standard_normal((n, n)) * 10.0 ** rng.integers(-310, 3, (n, n)), 0.0)
    J[0, 0] = -0.0
    J[np.arange(n), rng.permutation(n)] += 1.0
    if seed % 3 == 1:
        J[1, 2] = -np.inf
    A = np.full((n + 2, n + 2), 7.0)  # larger than n: only the leading block is copied
    J2 = np.full((n + 2, n + 2), 3.0)
    J2[:n, :n] = J
    amax = copy_amax(J2, A, n)
    assert np.array_equal(A[:n, :n].view(np.int64), J.view(np.int64))
    assert np.all(A[n:, :] == 7.0) and np.all(A[:, n:] == 7.0)
    assert amax == np.abs(J).max()
    if seed % 3 == 2:
        J2[2, 1] = np.nan
        assert copy_amax(J2, A, n) == -1.0
    else:
        ws1, ws2 = make_workspace(n + 2), make_workspace(n + 2)
        A1, A2 = J2.copy(), J2.copy()
        ok1 = lu_factor(A1, ws1.piv, n, ws1.unz, ws1.ucnt, ws1.lnz, ws1.lcnt, -1.0, J2, False)
        ok2 = lu_factor(A2, ws2.piv, n, ws2.unz, ws2.ucnt, ws2.lnz, ws2.lcnt, amax, J2, False)
        assert ok1 == ok2
        assert np.array_equal(A1, A2, equal_nan=True) and np.array_equal(ws1.piv, ws2.piv)


def _jtj_dense(J: np.ndarray, n: int, nu: float) -> np.ndarray:
    """The slow obvious twin: the dense triple loop in Python floats (IEEE, no FMA)."""
    A = np.zeros((n, n))
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += float(J[k, i]) * float(J[k, j])
            A[i, j] = acc
            A[j, i] = acc
        A[i, i] += nu
    return A


@pytest.mark.parametrize("seed", range(12))
def test_jtj_shift_is_the_dense_sum_bit_for_bit(seed: int) -> None:
    """``jtj_shift`` (the sparse J^T J + nu I of the Levenberg-Marquardt step) is the dense sum.

    Sparse J with signed zeros, subnormals and products that underflow to -0: A is the
    dense triple loop's bit for bit (only the leading n x n block written); with inf or NaN
    in J, the same NaNs and values as the dense loop.
    """
    from tumblemc.kernels.newton import jtj_shift

    rng = np.random.default_rng(seed)
    n = 6 + 2 * seed
    J = np.where(rng.random((n, n)) < 0.25, rng.standard_normal((n, n)) * 10.0 ** rng.integers(-170, 3, (n, n)), 0.0)
    J[0, 1] = -0.0
    J[1, :] = 0.0  # an empty row
    J[2, 0], J[2, 3] = 1e-200, -1e-200  # their product underflows to -0
    J[3, 0], J[3, 3] = 5e-324, 3.0  # a subnormal
    if seed % 4 == 3:
        J[n - 1, n - 2] = np.inf if seed % 8 == 3 else np.nan
    nu = float(rng.uniform(0.0, 2.0)) if seed % 2 else 0.0
    A = np.full((n + 2, n + 2), 7.0)
    cols = np.zeros(n + 2, np.int64)
    J2 = np.full((n + 2, n + 2), 5.0)
    J2[:n, :n] = J
    jtj_shift(J2, n, nu, A, cols)
    ref = _jtj_dense(J, n, nu)
    if seed % 4 == 3:
        assert np.isnan(A[:n, :n]).any()
        assert np.array_equal(np.isnan(A[:n, :n]), np.isnan(ref))
        assert np.array_equal(A[:n, :n], ref, equal_nan=True)
    else:
        assert A[:n, :n].tobytes() == ref.tobytes()
    assert np.all(A[n:, :] == 7.0) and np.all(A[:, n:] == 7.0)


@pytest.mark.parametrize("shape", ["cuboid", "curved"])
@pytest.mark.parametrize("seed", range(6))
def test_lowest_point_against_twin(shape: str, seed: int) -> None:
    """``lowest_point`` against a Python twin of the same sums.

    The lowest support height (minus the pad) and the centroid of the points within ``tol``
    of the lowest bit for bit. ``hts``: every height bit for bit for the
    cuboid's 8 points; for the curved robot's 226 (``_lowest_many``, which screens first),
    the height bit for bit of every point it kept, every point within ``tol`` of the lowest
    kept, ``inf`` for the others. Seeds 4 and 5: the body lies on its face (R = identity,
    support points tied in height), 100 length units from the origin.
    """
    from tumblemc.kernels.support import FAST_HEIGHT_POINTS, lowest_point
    from tumblemc.model.run import prepare, run_inputs

    spec = prepare(run_inputs(shape=shape, incline_deg=10.0 * (seed % 4), duration_s=0.001))
    geo, prm = spec.geo, spec.prm
    rng = np.random.default_rng(seed)
    q = rng.standard_normal(4)
    q /= np.linalg.norm(q)
    R = naive.rotmat(q).ravel() if seed < 4 else np.eye(3).ravel()
    x = rng.standard_normal(3) if seed < 4 else np.array([100.0, -3.0, 0.5])
    nrm = prm[L.P_N : L.P_N + 3]
    s0, s1 = int(geo.sup_start[0]), int(geo.sup_start[1])
    pts = geo.sup_pts[s0:s1]

    def height(p: np.ndarray) -> float:
        h = 0.0
        for i in range(3):
            wi = float(x[i])
            for j in range(3):
                wi += float(R[3 * i + j]) * float(p[j])
            h += float(nrm[i]) * wi
        return h

    heights = np.array([height(p) for p in pts])
    for tol in (0.0, 1e-3, 0.2, 1e3):
        hts = np.full(s1 - s0 + 3, np.nan)
        out = np.zeros(3)
        low = lowest_point(x, R, prm, geo, 0, out, tol, hts)
        assert low == heights.min() - geo.sup_pad[0]
        near = heights <= heights.min() + tol
        got = hts[: s1 - s0]
        if s1 - s0 > FAST_HEIGHT_POINTS:
            kept = np.isfinite(got)
            assert kept[near].all()
            if tol < 1.0:
                assert not kept.all()  # the screening left points out (_lowest_many ran)
            assert got[kept].tobytes() == heights[kept].tobytes()
            assert np.all(got[~kept] == np.inf)
        else:
            assert got.tobytes() == heights.tobytes()
        assert np.isnan(hts[s1 - s0 :]).all()  # nothing past the piece's points
        cen = [0.0, 0.0, 0.0]  # lowest_point's centroid loop, in its order
        for p in pts[near]:
            for i in range(3):
                wi = float(x[i])
                for j in range(3):
                    wi += float(R[3 * i + j]) * float(p[j])
                cen[i] += wi
        assert out.tobytes() == (np.array(cen) / int(near.sum())).tobytes()


def test_workspace_fields_by_name() -> None:
    """make_workspace builds every field by name with its shape and dtype (a swap shows)."""
    from tumblemc.kernels.residual import N_RS

    n = 7
    ws = make_workspace(n)
    f, i = np.float64, np.int64
    want = {
        "F": ((n,), f), "J": ((n, n), f), "A": ((n, n), f), "d": ((n,), f), "zt": ((n,), f), "Ft": ((n,), f),
        "g": ((n,), f), "fbb": ((n,), f), "isfb": ((n,), i), "piv": ((n,), i), "rs": ((N_RS,), f),
        "Ft_isfb": ((n,), i), "unz": ((n, n), i), "ucnt": ((n,), i), "lnz": ((n, n), i), "lcnt": ((n,), i), "y": ((n,), f),
        "lu_h": ((1,), f), "rsc": ((n,), f),
    }  # fmt: skip
    assert set(ws._fields) == set(want)
    for name, (shape, dtype) in want.items():
        arr = getattr(ws, name)
        assert arr.shape == shape and arr.dtype == dtype, name


@pytest.mark.parametrize("seed", range(4))
def test_recentre_moves_the_origin_along_the_plane_only(seed: int) -> None:
    """``recentre`` shifts x and every a1, a2 by the in-plane part of x, beyond RECENTRE_AT only.

    The residual is invariant under that translation: F at the shifted state and unknowns
    equals F at the original ones to the rounding of the original positions.
    """
    from tumblemc.kernels.recording import RECENTRE_AT, recentre

    z, sc, prm, ctype, cdata, pstart = make_problem("two_pieces", seed, False, 0.3 + 0.3 * seed, 1e-2, 0.3)
    rng = np.random.default_rng(seed)
    state = np.zeros(13)
    state[0:3] = sc[L.S_X : L.S_X + 3]
    z_near, state_near = z.copy(), state.copy()
    assert not recentre(state, z, np.zeros((0, z.size)), np.zeros(3), prm, pstart)
    assert np.array_equal(state, state_near) and np.array_equal(z, z_near)  # near the origin: untouched
    s = (rng.uniform(2, 5) * RECENTRE_AT) * (prm[L.P_T : L.P_T + 3] * rng.normal() + prm[L.P_O : L.P_O + 3] * rng.normal())
    state[0:3] += s
    for blk in block_index(pstart):
        for key in ("a1", "a2"):
            z[blk[key] : blk[key] + 3] += s
    far_z, far_x = z.copy(), state[0:3].copy()
    xoff = np.zeros(3)
    assert recentre(state, z, np.zeros((0, z.size)), xoff, prm, pstart)
    assert np.allclose(state[0:3] + xoff, far_x, rtol=0, atol=1e-12 * RECENTRE_AT)
    assert abs(state[0:3] @ prm[L.P_T : L.P_T + 3]) < 1e-12 * RECENTRE_AT  # the in-plane part is gone ...
    assert abs(state[0:3] @ prm[L.P_O : L.P_O + 3]) < 1e-12 * RECENTRE_AT
    height = far_x @ prm[L.P_N : L.P_N + 3]
    assert state[0:3] @ prm[L.P_N : L.P_N + 3] == pytest.approx(height, abs=1e-12 * RECENTRE_AT)  # ... not the height
    moved = np.zeros(z.size, bool)
    for blk in block_index(pstart):
        for key in ("a1", "a2"):
            moved[blk[key] : blk[key] + 3] = True
            assert np.allclose(z[blk[key] : blk[key] + 3] + xoff, far_z[blk[key] : blk[key] + 3], rtol=0, atol=1e-12 * RECENTRE_AT)
    assert np.array_equal(z[~moved], far_z[~moved])  # velocities and multipliers untouched
    sc_far, sc_near = sc.copy(), sc.copy()
    sc_far[L.S_X : L.S_X + 3] = far_x
    sc_near[L.S_X : L.S_X + 3] = state[0:3]
    F_far, _, _ = kernel(far_z, sc_far, prm, ctype, cdata, pstart)
    F_near, _, _ = kernel(z, sc_near, prm, ctype, cdata, pstart)
    assert np.allclose(F_near, F_far, rtol=1e-9, atol=1e-9)


def test_run_returns_positions_in_the_callers_frame_after_recentring() -> None:
    """After a run that recentres, its positions are in the caller's frame.

    The run slides 15 cm (1500 length units) and shifts its origin many times; the record,
    the final state and the last solution's a1 agree.
    """
    from tumblemc.kernels.recording import RECENTRE_AT
    from tumblemc.kernels.residual import n_unknowns as n_unk
    from tumblemc.kernels.stepper import Clock, Model, Start, empty_record, make_buffers, run
    from tumblemc.model.run import initial_contact, prepare, run_inputs
    from tumblemc.model.shapes.library import get_shape

    spec = prepare(
        run_inputs(get_shape("cuboid"), preset="paper", field_mT=0.0, F_elect=0.0, adhesion_C=0.0, incline_deg=60.0, mu=0.3, duration_s=0.2)
    )
    n = n_unk(spec.geo.pstart)
    buf = make_buffers(n)
    rec = empty_record(spec.n_steps, spec.n_steps)
    area0, resting = initial_contact(spec)
    start = Start(spec.state0.copy(), 0.0, area0, resting)
    status, failed, _ = run(Model(spec.prm, spec.geo), spec.solver.as_array(), start, Clock(spec.h, spec.n_steps, spec.n_steps), rec, buf)
    assert status == L.ST_OK and failed == 0
    x_end = rec[-1, L.R_X : L.R_X + 3]
    along = max(abs(x_end @ spec.prm[L.P_T : L.P_T + 3]), abs(x_end @ spec.prm[L.P_O : L.P_O + 3]))
    assert along > 10 * RECENTRE_AT  # far beyond the first shift
    assert np.array_equal(start.state[:3], x_end)
    assert np.array_equal(buf.z[6 + L.B_A1 : 6 + L.B_A1 + 3], rec[-1, L.R_ECP : L.R_ECP + 3])
    assert rec[-1, L.R_NIT] / spec.n_steps < 2.0
