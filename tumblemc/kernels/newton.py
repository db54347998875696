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
from .layout import (
    O_ARMIJO,
    O_CHORD,
    O_MAXIT,
    O_MINSTEP,
    O_PIVROW,
    O_STALL,
    O_TOL,
    S_H,
    ST_LINESEARCH,
    ST_MAXIT,
    ST_NAN,
    ST_OK,
)
from .lu import copy_amax, lu_factor, lu_solve
from .residual import N_RS, residual
from .rounding import momentum_floor, rounding_scales, within_rounding

#: a chord iteration is kept while it divides the residual's max-norm by at least 2
CHORD_RATE = 0.5
#: a chord solve that took this many iterations marks its factors stale: the next step
#: factors afresh (measured on 7 runs: 3 against never and 2, docs/chord.md)
CHORD_STALE = 3

Workspace = namedtuple(
    "Workspace",
    [
        "F",
        "J",
        "A",
        "d",
        "zt",
        "Ft",
        "g",
        "fbb",
        "isfb",
        "piv",
        "rs",
        "Ft_isfb",
        "unz",
        "ucnt",
        "lnz",
        "lcnt",
        "y",
        "lu_h",
        "rsc",
    ],
)


def make_workspace(n: int) -> Workspace:
    """Allocate the solver's arrays for ``n`` unknowns (done once per run), by field name."""
    return Workspace(
        F=np.zeros(n),
        J=np.zeros((n, n)),
        A=np.zeros((n, n)),
        d=np.zeros(n),
        zt=np.zeros(n),
        Ft=np.zeros(n),
        g=np.zeros(n),
        fbb=np.zeros(n),
        isfb=np.zeros(n, np.int64),
        piv=np.zeros(n, np.int64),
        rs=np.zeros(N_RS),
        Ft_isfb=np.zeros(n, np.int64),
        unz=np.zeros((n, n), np.int64),
        ucnt=np.zeros(n, np.int64),
        lnz=np.zeros((n, n), np.int64),
        lcnt=np.zeros(n, np.int64),
        y=np.zeros(n),
        lu_h=np.zeros(1),
        rsc=np.zeros(n),  # the rows' rounding scales (rounding.rounding_scales)
    )


@jit
def _rounded(z, F, prob, ws):  # type: ignore[no-untyped-def]
    """Whether every row of ``F = Phi(z)`` lies within its rounding (:mod:`.rounding`)."""
    rounding_scales(z, prob, ws.rsc)
    return within_rounding(F, ws.rsc)


@jit
def jtj_shift(J, n, nu, A, cols):  # type: ignore[no-untyped-def]  # noqa: C901
    """``A[:n, :n] = J^T J + nu I`` for :func:`_lm_direction`; ``cols``: int64[n] scratch.

    Summed row by row of J over its nonzeros only (J is sparse: the dense triple loop took
    7% of the curved robot's hard runs). Each entry receives the same products in the same
    order as the dense sum ``sum_k J[k, i] J[k, j]`` started at +0.0; the products left out
    are +-0, which leave such a sum unchanged, so A is the dense loop's bit for bit. A J
    with inf or NaN takes the dense loop, where ``0 x inf`` gives its NaN.
    """
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
    finite = True
    for k in range(n):
        m = 0
        for j in range(n):
            v = J[k, j]
            if v != 0.0:
                if not v - v == 0.0:  # inf or NaN
                    finite = False
                cols[m] = j
                m += 1
        if not finite:
            break
        for a in range(m):
            ca = cols[a]
            ja = J[k, ca]
            for b in range(a, m):
                cb = cols[b]
                A[ca, cb] += ja * J[k, cb]
    if finite:
        for i in range(n):
            for j in range(i + 1, n):
                A[j, i] = A[i, j]
            A[i, i] += nu
        return
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += J[k, i] * J[k, j]
            A[i, j] = acc
            A[j, i] = acc
        A[i, i] += nu


@jit
def _lm_direction(J, F, g, d, n, nu, ws):  # type: ignore[no-untyped-def]
    """d = -(J^T J + nu I)^-1 J^T F. False if even that fails."""
    A = ws.A
    ws.lu_h[0] = 0.0  # A no longer holds a Newton matrix's factors (solve's chord start)
    jtj_shift(J, n, nu, A, ws.piv)  # piv as scratch: lu_factor sets it itself
    if not lu_factor(A, ws.piv, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, -1.0, A, False):
        return False
    for i in range(n):
        d[i] = -g[i]
    lu_solve(A, ws.piv, d, n, ws.unz, ws.ucnt, ws.lnz, ws.lcnt, ws.y)
    return True


@jit
def _line_search(z, slope, theta, prob, ws, trial, opts, mode):  # type: ignore[no-untyped-def]
    """Armijo backtracking along ``ws.d``; on success ``ws.zt`` holds the new point.

    ``trial`` is the residual's work tuple for the trial points (``ws.Ft_isfb``,
    ``ws.fbb``, ``ws.rs``, built once per solve); ``mode = (project, mu_s)``. ``ws.J`` is
    only passed through: the trial residuals do not form the Jacobian, so the solver's J
    survives the line search. Arrays are taken out of the tuples once per call (each
    access costs Numba an atomic reference-count pair).

    With ``project``, trial points are projected onto ``z_i >= 0`` for the complementarity variables
    (``isfb[i] != 0``: sigma, l_i, l_s, lam_n), where every solution lies. Without it
    the iterates can stall at spurious stationary points of the merit with sigma < 0
    (friction along the slip, which the dissipation rows alone admit), e.g. on sliding
    landings. Sufficient decrease is measured along the projected displacement
    (projected Newton / Levenberg-Marquardt for box-constrained equations, Kanzow,
    Yamashita & Fukushima 2004). Projection slows convergence at sticking contacts
    (sigma = 0), so the stepper tries it only after the plain iteration failed.
    """
    project, mu_s = mode
    d = ws.d
    zt = ws.zt
    g = ws.g
    Ft = ws.Ft
    J = ws.J
    isfb = ws.isfb
    n = z.shape[0]
    t = 1.0
    c = opts[O_ARMIJO]
    while t >= opts[O_MINSTEP]:
        projected = False
        for i in range(n):
            v = z[i] + t * d[i]
            if project and isfb[i] != 0 and v < 0.0:
                v = 0.0
                projected = True
            zt[i] = v
        if projected:
            dec = 0.0
            for i in range(n):
                dec += g[i] * (zt[i] - z[i])
            target = theta + c * dec if dec < 0.0 else theta * (1.0 - c * t)
        else:
            target = theta + c * t * slope
        th = residual(zt, prob, Ft, J, trial, False, mu_s)
        if th <= target:
            return True, th
        t *= 0.5
    return False, theta


@jit
def solve(z, prob, ws, opts, out, project, smooth0, chord=False):  # type: ignore[no-untyped-def]  # noqa: C901
    """Solve ``Phi(z) = 0`` in place from the warm start ``z``.

    Parameters
    ----------
    z : float64[n]
        Warm start in, solution (or best iterate) out.
    prob : Problem
        The step's system (:class:`tumblemc.kernels.residual.Problem`).
    ws : Workspace
    opts : float64[N_OPT]
        ``O_TOL`` (max-norm of Phi, scaled units; a plain iterate also passes within the
        momenta's rounding, :func:`~.rounding.momentum_floor`, once an iteration fails to
        halve it, and with every row within its rounding, :func:`~.rounding.within_rounding`,
        once no descent is left), ``O_MAXIT``, ``O_ARMIJO``, ``O_MINSTEP``,
        ``O_PIVROW`` (``lu_factor``'s row test) and ``O_STALL``: with ``smooth0 > 0``, stop
        (``ST_MAXIT``) after that many iterations in which neither ``||Phi||_inf`` halved nor
        the smoothing parameter fell (0: never).
    out : int64[3]
        Receives ``(iterations, fallbacks, 0)``; iterations count the chord ones too.
    project : bool
        Keep the complementarity variables >= 0 in the line search (see ``_line_search``).
    smooth0 : float
        If > 0, a smoothing continuation: Newton on the smoothed FB rows with
        ``mu = smooth0``, divided by 10 whenever ``||Phi_mu|| <= mu / 10``, down to the plain
        FB rows (Jacobian-smoothing idea of Chen, Qi & Sun 1998). The smoothed rows have
        no kinks and keep every complementarity pair strictly positive along the path,
        which frees the ECP to move across a face when the touching feature changes.
    chord : bool
        Start with up to ``opts[O_CHORD]`` chord iterations (simplified Newton: ``d = -A^-1
        Phi(z)`` with the factors still in ``ws.A``) if those are the factors of a plain
        Newton matrix of this step length ``prob.sc[S_H]`` (``ws.lu_h``). An iteration is
        kept while it divides ``||Phi||_inf`` by at least ``1 / CHORD_RATE``; the first that
        does not, or the last allowed, hands over to Newton from the last point kept. A
        chord solve that needs ``CHORD_STALE`` iterations or more leaves the factors marked
        stale, so the next step's Newton iteration factors afresh. The
        convergence test is Newton's (``||Phi||_inf <= tol``), so a chord solution is a
        solution to the same tolerance, not the same bits. Jacobian reuse as in stiff
        integrators (Hairer & Wanner, Solving ODEs II, IV.8): at 5e-5 s the Newton matrix
        of the last step is close to this one's, and a step then costs two or three
        residuals without a Jacobian and substitutions instead of a Jacobian, its LU and a
        residual.

    Returns
    -------
    status : int
        ``ST_OK``, ``ST_MAXIT``, ``ST_LINESEARCH`` or ``ST_NAN``.
    resid : float
        ``||Phi||_inf`` at the returned ``z``.
    """
    n = z.shape[0]
    # the workspace arrays taken out of the tuple once (see _line_search)
    F = ws.F
    J = ws.J
    g = ws.g
    d = ws.d
    A = ws.A
    piv = ws.piv
    unz = ws.unz
    ucnt = ws.ucnt
    lnz = ws.lnz
    lcnt = ws.lcnt
    y = ws.y
    work = (ws.isfb, ws.fbb, ws.rs)  # the residual's work arrays at z ...
    trial = (ws.Ft_isfb, ws.fbb, ws.rs)  # ... and at the line search's trial points
    zt = ws.zt
    Ft = ws.Ft
    tol = opts[O_TOL]
    floor = momentum_floor(prob)
    maxit = int(opts[O_MAXIT])
    mu_s = smooth0
    fallbacks = 0
    it = 0
    nchord = 0
    lu_h = ws.lu_h
    hstep = prob.sc[S_H]
    rowrel = opts[O_PIVROW] > 0.5
    if chord and lu_h[0] == hstep and mu_s == 0.0 and opts[O_CHORD] > 0.0:
        # chord start: the factors still in A are those of the last plain Newton matrix
        # of this step length (an earlier step's); each iteration costs a residual without
        # its Jacobian and a substitution. Kept while it contracts by CHORD_RATE; else
        # Newton goes on from the last point kept.
        residual(z, prob, F, J, work, False, 0.0)
        fnorm = 0.0
        for i in range(n):
            v = abs(F[i])
            if v > fnorm:
                fnorm = v
        while fnorm <= tol or (nchord < opts[O_CHORD] and fnorm < math.inf):
            if fnorm <= tol:
                if nchord >= CHORD_STALE:
                    lu_h[0] = 0.0
                out[0] = nchord
                out[1] = 0
                return ST_OK, fnorm
            nchord += 1
            for i in range(n):
                d[i] = -F[i]
            lu_solve(A, piv, d, n, unz, ucnt, lnz, lcnt, y)
            for i in range(n):
                zt[i] = z[i] + d[i]
            residual(zt, prob, Ft, J, trial, False, 0.0)
            fnew = 0.0
            for i in range(n):
                v = abs(Ft[i])
                if v > fnew:
                    fnew = v
            if not fnew <= CHORD_RATE * fnorm:
                break
            for i in range(n):
                z[i] = zt[i]
                F[i] = Ft[i]
            fnorm = fnew
    theta = residual(z, prob, F, J, work, True, mu_s)
    status = ST_MAXIT
    fnorm = 0.0
    stall = int(opts[O_STALL]) if smooth0 > 0.0 else 0  # the smoothing continuation's up-to-300 iterations only
    best = math.inf  # the max-norm when it last halved (or the smoothing parameter last fell) ...
    last = 0  # ... and the iteration count then
    fprev = math.inf  # the max-norm before the last plain iteration
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
            theta = residual(z, prob, F, J, work, True, mu_s)
            best = math.inf
            last = it
            continue
        if fnorm <= tol and mu_s == 0.0:
            status = ST_OK
            break
        if mu_s == 0.0 and fnorm <= floor and not fnorm <= CHORD_RATE * fprev:
            status = ST_OK  # stalled on the momenta's rounding: the last iteration did not halve it
            break
        fprev = fnorm if mu_s == 0.0 else math.inf
        if it >= maxit:
            status = ST_MAXIT
            break
        if stall > 0:
            if fnorm <= 0.5 * best:
                best = fnorm
                last = it
            elif it - last >= stall:
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
        amax = copy_amax(J, A, n)
        lu_h[0] = 0.0
        if lu_factor(A, piv, n, unz, ucnt, lnz, lcnt, amax, J, rowrel):
            if mu_s == 0.0:
                lu_h[0] = hstep
            for i in range(n):
                d[i] = -F[i]
            lu_solve(A, piv, d, n, unz, ucnt, lnz, lcnt, y)
            slope = 0.0
            dn = 0.0
            for i in range(n):
                slope += g[i] * d[i]
                dn += d[i] * d[i]
            if slope == slope and slope < -1e-12 * gnorm * math.sqrt(dn):
                accepted, th_new = _line_search(z, slope, theta, prob, ws, trial, opts, (project, mu_s))
        if not accepted and mu_s == 0.0 and (fnorm <= floor or _rounded(z, F, prob, ws)):
            status = ST_OK  # no descent left within the rows' rounding
            break
        # 2. Levenberg-Marquardt
        if not accepted:
            fallbacks += 1
            nu = math.sqrt(2.0 * theta)
            if _lm_direction(J, F, g, d, n, nu, ws):
                slope = 0.0
                for i in range(n):
                    slope += g[i] * d[i]
                if slope < 0.0:
                    accepted, th_new = _line_search(z, slope, theta, prob, ws, trial, opts, (project, mu_s))
        # 3. steepest descent
        if not accepted:
            for i in range(n):
                d[i] = -g[i] / max(gnorm, 1e-300)
            accepted, th_new = _line_search(z, -gnorm, theta, prob, ws, trial, opts, (project, mu_s))
        if not accepted:
            status = ST_LINESEARCH
            break
        fnew = 0.0
        for i in range(n):
            z[i] = zt[i]
            v = abs(Ft[i])
            if v > fnew:
                fnew = v
        if mu_s == 0.0 and fnew <= tol:
            # converged at the accepted point: its residual is known, skip the Jacobian
            for i in range(n):
                F[i] = Ft[i]
            fnorm = fnew
            status = ST_OK
            break
        theta = residual(z, prob, F, J, work, True, mu_s)
    out[0] = it + nchord
    out[1] = fallbacks
    return status, fnorm
