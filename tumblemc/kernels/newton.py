"""Dense semismooth Newton for ``Phi(z) = 0`` with the Fischer-Burmeister reformulation.

Globalised on the merit ``theta = 1/2 ||Phi||^2`` (continuously differentiable for FB):
Newton direction with an Armijo backtracking line search; where the Newton matrix is
singular (free flight, lift-off, several active faces at an edge) or its direction is not
a descent direction or fails the line search, a Levenberg-Marquardt step
``(J^T J + nu I) d = -J^T Phi`` with ``nu = ||Phi||`` (Yamashita & Fukushima 2001), and
as a last resort the steepest-descent step. No allocation: all arrays come in a
:class:`Workspace`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ._jit import jit
from .layout import O_ARMIJO, O_MAXIT, O_MINSTEP, O_TOL, ST_LINESEARCH, ST_MAXIT, ST_NAN, ST_OK
from .residual import residual

Workspace = namedtuple(
    "Workspace",
    ["F", "J", "A", "d", "zt", "Ft", "g", "fbb", "isfb", "piv", "v3", "m33", "q4", "e43", "Jt", "Ft_isfb", "nzc"],
)


def make_workspace(n: int) -> Workspace:
    """Allocate the solver's arrays for ``n`` unknowns (done once per run)."""
    f = np.zeros
    return Workspace(
        f(n), f((n, n)), f((n, n)), f(n), f(n), f(n), f(n), f(n),
        np.zeros(n, np.int64), np.zeros(n, np.int64),
        f((16, 3)), f((8, 3, 3)), f((2, 4)), f((2, 4, 3)), f((n, n)), np.zeros(n, np.int64), np.zeros(n, np.int64),
    )  # fmt: skip


@jit
def lu_factor(A, piv, n, nzc):  # type: ignore[no-untyped-def]
    """In-place LU with partial pivoting of ``A[:n, :n]``. False if numerically singular.

    The Jacobian is sparse (a third of it is nonzero), so each elimination step updates
    only the nonzero columns of the pivot row (``nzc``: int64[n] workspace); the result
    is the same as the dense algorithm's.
    """
    amax = 0.0
    for i in range(n):
        for j in range(n):
            v = abs(A[i, j])
            if v > amax:
                amax = v
    if not amax > 0.0:
        return False
    tiny = 1e-13 * amax
    for k in range(n):
        p = k
        best = abs(A[k, k])
        for i in range(k + 1, n):
            v = abs(A[i, k])
            if v > best:
                best = v
                p = i
        if not best > tiny:
            return False
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        nnz = 0
        for j in range(k + 1, n):
            if A[k, j] != 0.0:
                nzc[nnz] = j
                nnz += 1
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            if A[i, k] != 0.0:
                f = A[i, k] * inv
                A[i, k] = f
                for q in range(nnz):
                    j = nzc[q]
                    A[i, j] -= f * A[k, j]
    return True


@jit
def lu_solve(A, piv, b, n):  # type: ignore[no-untyped-def]
    """Solve in place with the factors of :func:`lu_factor`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    # forward substitution column by column: each b[i] receives the same subtractions in
    # the same order as the row-wise dot product, without its chain of dependent adds
    for j in range(n):
        bj = b[j]
        if bj != 0.0:
            for i in range(j + 1, n):
                b[i] -= A[i, j] * bj
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= A[i, j] * b[j]
        b[i] = acc / A[i, i]


@jit
def _lm_direction(J, F, g, A, piv, d, n, nu, nzc):  # type: ignore[no-untyped-def]
    """d = -(J^T J + nu I)^-1 J^T F. False if even that fails."""
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += J[k, i] * J[k, j]
            A[i, j] = acc
            A[j, i] = acc
        A[i, i] += nu
    if not lu_factor(A, piv, n, nzc):
        return False
    for i in range(n):
        d[i] = -g[i]
    lu_solve(A, piv, d, n)
    return True


@jit
def _line_search(z, d, slope, theta, sc, prm, ctype, cdata, pstart, ws, opts, n, project, mu_s):  # type: ignore[no-untyped-def]
    """Armijo backtracking along ``d``; on success ``ws.zt`` holds the new point.

    With ``project``, trial points are projected onto ``z_i >= 0`` for the complementarity variables
    (``ws.isfb[i] != 0``: sigma, l_i, l_s, lam_n), where every solution lies. Without it
    the iterates can stall at spurious stationary points of the merit with sigma < 0
    (friction along the slip, which the dissipation rows alone admit), e.g. on sliding
    landings. Sufficient decrease is measured along the projected displacement
    (projected Newton / Levenberg-Marquardt for box-constrained equations, Kanzow,
    Yamashita & Fukushima 2004). Projection slows convergence at sticking contacts
    (sigma = 0), so the stepper tries it only after the plain iteration failed.
    """
    t = 1.0
    c = opts[O_ARMIJO]
    while t >= opts[O_MINSTEP]:
        projected = False
        for i in range(n):
            v = z[i] + t * d[i]
            if project and ws.isfb[i] != 0 and v < 0.0:
                v = 0.0
                projected = True
            ws.zt[i] = v
        if projected:
            dec = 0.0
            for i in range(n):
                dec += ws.g[i] * (ws.zt[i] - z[i])
            target = theta + c * dec if dec < 0.0 else theta * (1.0 - c * t)
        else:
            target = theta + c * t * slope
        th = residual(ws.zt, sc, prm, ctype, cdata, pstart, ws.Ft, ws.Jt, False, ws.Ft_isfb, ws.fbb, ws.v3, ws.m33, ws.q4, ws.e43, mu_s)
        if th <= target:
            return True, th
        t *= 0.5
    return False, theta


@jit
def solve(z, sc, prm, ctype, cdata, pstart, ws, opts, out, project, smooth0):  # type: ignore[no-untyped-def]
    """Solve ``Phi(z) = 0`` in place from the warm start ``z``.

    Parameters
    ----------
    z : float64[n]
        Warm start in, solution (or best iterate) out.
    sc, prm, ctype, cdata, pstart
        See :func:`tumblemc.kernels.residual.residual`.
    ws : Workspace
    opts : float64[N_OPT]
        ``O_TOL`` (max-norm of Phi, scaled units), ``O_MAXIT``, ``O_ARMIJO``, ``O_MINSTEP``.
    out : int64[3]
        Receives ``(iterations, fallbacks, 0)``.
    project : bool
        Keep the complementarity variables >= 0 in the line search (see ``_line_search``).
    smooth0 : float
        If > 0, a smoothing continuation: Newton on the smoothed FB rows with
        ``mu = smooth0``, divided by 10 whenever ``||Phi_mu|| <= mu / 10``, down to the plain
        FB rows (Jacobian-smoothing idea of Chen, Qi & Sun 1998). The smoothed rows have
        no kinks and keep every complementarity pair strictly positive along the path,
        which frees the ECP to move across a face when the touching feature changes.

    Returns
    -------
    status : int
        ``ST_OK``, ``ST_MAXIT``, ``ST_LINESEARCH`` or ``ST_NAN``.
    resid : float
        ``||Phi||_inf`` at the returned ``z``.
    """
    n = z.shape[0]
    F = ws.F
    J = ws.J
    g = ws.g
    d = ws.d
    tol = opts[O_TOL]
    maxit = int(opts[O_MAXIT])
    mu_s = smooth0
    theta = residual(z, sc, prm, ctype, cdata, pstart, F, J, True, ws.isfb, ws.fbb, ws.v3, ws.m33, ws.q4, ws.e43, mu_s)
    fallbacks = 0
    it = 0
    status = ST_MAXIT
    fnorm = 0.0
    while True:
        fnorm = 0.0
        for i in range(n):
            v = abs(F[i])
            if v > fnorm:
                fnorm = v
        if not fnorm == fnorm or fnorm == math.inf:
            status = ST_NAN
            break
        if mu_s > 0.0 and fnorm <= max(tol, 0.1 * mu_s):
            mu_s = 0.1 * mu_s if 0.1 * mu_s > 1e-3 * tol else 0.0
            theta = residual(z, sc, prm, ctype, cdata, pstart, F, J, True, ws.isfb, ws.fbb, ws.v3, ws.m33, ws.q4, ws.e43, mu_s)
            continue
        if fnorm <= tol and mu_s == 0.0:
            status = ST_OK
            break
        if it >= maxit:
            status = ST_MAXIT
            break
        it += 1
        # g = J^T F row by row (the same sums, in the same order, as column dot products;
        # contiguous and free of dependent-add chains)
        for j in range(n):
            g[j] = 0.0
        for k in range(n):
            fk = F[k]
            for j in range(n):
                g[j] += J[k, j] * fk
        gnorm = 0.0
        for j in range(n):
            gnorm += g[j] * g[j]
        gnorm = math.sqrt(gnorm)
        accepted = False
        th_new = theta
        # 1. semismooth Newton
        for i in range(n):
            for j in range(n):
                ws.A[i, j] = J[i, j]
        if lu_factor(ws.A, ws.piv, n, ws.nzc):
            for i in range(n):
                d[i] = -F[i]
            lu_solve(ws.A, ws.piv, d, n)
            slope = 0.0
            dn = 0.0
            for i in range(n):
                slope += g[i] * d[i]
                dn += d[i] * d[i]
            if slope == slope and slope < -1e-12 * gnorm * math.sqrt(dn):
                accepted, th_new = _line_search(z, d, slope, theta, sc, prm, ctype, cdata, pstart, ws, opts, n, project, mu_s)
        # 2. Levenberg-Marquardt
        if not accepted:
            fallbacks += 1
            nu = math.sqrt(2.0 * theta)
            if _lm_direction(J, F, g, ws.A, ws.piv, d, n, nu, ws.nzc):
                slope = 0.0
                for i in range(n):
                    slope += g[i] * d[i]
                if slope < 0.0:
                    accepted, th_new = _line_search(z, d, slope, theta, sc, prm, ctype, cdata, pstart, ws, opts, n, project, mu_s)
        # 3. steepest descent
        if not accepted:
            for i in range(n):
                d[i] = -g[i] / max(gnorm, 1e-300)
            accepted, th_new = _line_search(z, d, -gnorm, theta, sc, prm, ctype, cdata, pstart, ws, opts, n, project, mu_s)
        if not accepted:
            status = ST_LINESEARCH
            break
        fnew = 0.0
        for i in range(n):
            z[i] = ws.zt[i]
            v = abs(ws.Ft[i])
            if v > fnew:
                fnew = v
        if mu_s == 0.0 and fnew <= tol:
            # converged at the accepted point: its residual is known, skip the Jacobian
            for i in range(n):
                F[i] = ws.Ft[i]
            fnorm = fnew
            status = ST_OK
            break
        theta = residual(z, sc, prm, ctype, cdata, pstart, F, J, True, ws.isfb, ws.fbb, ws.v3, ws.m33, ws.q4, ws.e43, mu_s)
    out[0] = it
    out[1] = fallbacks
    return status, fnorm
