"""How small each row of ``Phi(z)`` can get in float64: the scale of its terms.

A row is a sum of terms; its computed value cannot resolve less than a few units in the
last place of the largest of them. :func:`rounding_scales` writes, per row of
:func:`~.residual.residual`, the sum of the magnitudes of its terms (the mirror of that
function's rows, bounded from the inputs rather than traced term by term), and
:func:`within_rounding` asks whether every row of a residual lies within ``ROUND_ULPS``
units in the last place of its scale: a componentwise backward-error test (Higham,
Accuracy and Stability of Numerical Algorithms, ch. 7). ``newton.solve`` accepts a plain
iterate inside it once no descent is left, and one inside :func:`momentum_floor` (a bound of
the Newton-Euler rows from the step's start) once an iteration fails to halve the residual
(docs/notes/step_size.md, "A residual floor at small steps"; docs/notes/solver_gaps.md,
section 11). The per-row test is kept to the no-descent case: applied at every iteration
that fails to halve, it stopped landings at 1.4e-9 that went on to reach ``tol``.

Two kinds of rows outgrow the solver's absolute ``tol`` at small steps:

- the Newton-Euler rows balance momenta and impulses divided by the step, ``m (v+ - v) /
  h`` and ``(I+ w+ - I w) / h``: one ulp of a fast spin moves them by ``eps |I w| / h``;
- the friction cone's row ``FB(sigma, (mu lam_n)^2 - (lam_t/e_t)^2 - ...)`` is quadratic
  in the forces, and a landing's forces are its impulse over the step: at 1.6e-8 s an edge
  landing carries ``lam_n`` = 5.7e5 weights, and one ulp of ``(mu lam_n)^2`` is 6e-6.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit
from .layout import (
    B_FIXED,
    B_L,
    B_LO,
    B_LR,
    B_LT,
    B_SIG,
    P_EO,
    P_ER,
    P_ET,
    P_IB,
    P_MASS,
    P_MU,
    P_ROT_PAPER,
    S_B1,
    S_FEXT,
    S_H,
    S_TM,
    S_V,
    S_W,
    S_X,
)

#: the rows' rounding allowance, in units in the last place of their scale
ROUND_ULPS = 8.0
EPS = float(np.finfo(np.float64).eps)  # float64's unit in the last place of 1


@jit
def _abs1(a, i0):  # type: ignore[no-untyped-def]
    return abs(a[i0]) + abs(a[i0 + 1]) + abs(a[i0 + 2])


@jit
def _norm2(a, i0):  # type: ignore[no-untyped-def]
    return math.sqrt(a[i0] * a[i0] + a[i0 + 1] * a[i0 + 1] + a[i0 + 2] * a[i0 + 2])


@jit
def rounding_scales(z, prob, out):  # type: ignore[no-untyped-def]  # noqa: C901
    """Write the magnitude of each row's terms at ``z`` into ``out`` (``n``, scaled units).

    Newton-Euler rows: the momenta of both ends of the step over ``h`` (``m (|v|_1 +
    |v+|_1)``; ``||Ib|| (|w| + |w+|)`` with ``||Ib||`` its largest row sum, and ``||Ib||
    |w|^2`` for the paper's rotation row), the applied force and torque, and each block's
    force and moment ``(1 + |a1|_1 + |x+|_1) (|lam_n| + |lam_t| + |lam_o|) + |lam_r|``: the
    lever ``r = a1 - x+`` carries the rounding of the positions it is the difference of.
    Per block: positions for the geometric rows, the multipliers for the normal cone, ``mu e
    lam_n |v_c|`` and ``lam sigma / e`` for the friction rows, and the squared forces of the
    cone's row.
    """
    sc, prm, ctype, cdata, pstart = prob
    h = sc[S_H]
    m = prm[P_MASS]
    mu = prm[P_MU]
    et = prm[P_ET]
    eo = prm[P_EO]
    er = prm[P_ER]
    ib = 0.0  # the largest row sum of |Ib|: a bound on its spectral norm, that of any R Ib R^T
    for i in range(3):
        ib = max(ib, abs(prm[P_IB + 3 * i]) + abs(prm[P_IB + 3 * i + 1]) + abs(prm[P_IB + 3 * i + 2]))
    w0 = _norm2(sc, S_W)
    w1 = _norm2(z, 3)
    w1_1 = _abs1(z, 3)  # |w+|_1, for the friction rows of every block
    v1_1 = _abs1(z, 0)
    xp = 0.0  # |x+|_1
    for i in range(3):
        xp += abs(sc[S_X + i] + h * z[i])
    lin = m * (_abs1(sc, S_V) + v1_1) / h + _abs1(sc, S_FEXT)
    ang = ib * (w0 + w1) / h + _abs1(sc, S_TM) + _abs1(sc, S_B1)
    if prm[P_ROT_PAPER] > 0.5:
        ang += ib * w0 * w0
    K = pstart.shape[0] - 1
    off = 6
    for kp in range(K):
        mk = pstart[kp + 1] - pstart[kp]
        ia1 = off
        ia2 = off + 3
        il0 = off + B_L
        ls = abs(z[il0 + mk])
        ln = abs(z[il0 + mk + 1])
        lt = abs(z[off + B_LT])
        lo = abs(z[off + B_LO])
        lr = abs(z[off + B_LR])
        sig = abs(z[off + B_SIG])
        a1 = _abs1(z, ia1)
        a2 = _abs1(z, ia2)
        arm = a1 + xp  # r = a1 - x+ is known to eps (|a1|_1 + |x+|_1), not to eps |r|
        lin += ln + lt + lo
        ang += arm * (ln + lt + lo) + lr
        for i in range(3):
            out[ia1 + i] = a1 + a2 + ls  # a1 - a2 - l_s n
        lsum = 1.0
        for ic in range(mk):
            c = pstart[kp] + ic
            lsum += abs(z[il0 + ic])
            cd = abs(cdata[c, 0]) + abs(cdata[c, 1]) + abs(cdata[c, 2]) + abs(cdata[c, 3])
            out[il0 + ic] = abs(z[il0 + ic]) + a1 + xp + cd  # FB(l_i, -f_i(a1))
        for i in range(3):
            out[ia2 + i] = lsum  # sum l_i N_i + n
        vc = v1_1 + w1_1 * arm  # |v+|_1 + |w+|_1 |r|_1, r's rounding included
        out[off + 6] = mu * et * ln * vc + lt * sig / et
        out[off + 7] = mu * eo * ln * vc + lo * sig / eo
        out[off + 8] = mu * er * ln * w1_1 + lr * sig / er
        out[off + B_SIG] = sig + (mu * ln) ** 2 + (lt / et) ** 2 + (lo / eo) ** 2 + (lr / er) ** 2
        out[il0 + mk] = ls + a2  # FB(l_s, -g(a2))
        out[il0 + mk + 1] = ln + a1  # FB(lam_n, g(a1))
        off += B_FIXED + mk
    for i in range(3):
        out[i] = lin
        out[3 + i] = ang


@jit
def momentum_floor(prob):  # type: ignore[no-untyped-def]
    """A residual max-norm the step's Newton-Euler rows cannot resolve below, from the step's start.

    The rows balance momenta divided by the step, ``m (v+ - v) / h`` and ``(I+ w+ - I w) /
    h``: one unit in the last place of ``v+`` or ``w+`` moves them by ``eps |p| / h``, and
    rounding in ``I+`` (built from the end pose) adds as much. The floor is ``ROUND_ULPS eps
    max(m |v|_1, ||Ib||_F |w|_1) / h`` at the start of the step (a bound on the momenta's
    components). For the paper cuboid at the paper's 5e-5 s it stays below the default
    ``tol`` (1e-9) up to spins of 3e5 rad/s; at 1.8e-8 s it passes 1e-9 at 120 rad/s, and
    from about 2000 rad/s the rows' rounding itself exceeds 1e-9. ``newton.solve`` accepts a
    plain iterate within it once an iteration fails to halve its residual (one number per
    solve, so it is checked at every iteration); :func:`within_rounding` is the finer,
    per-row test it applies where no descent is left.
    """
    sc = prob.sc
    prm = prob.prm
    pv = 0.0
    pw = 0.0
    for i in range(3):
        pv += abs(sc[S_V + i])
        pw += abs(sc[S_W + i])
    ib = 0.0
    for i in range(9):
        ib += prm[P_IB + i] * prm[P_IB + i]
    p = max(prm[P_MASS] * pv, math.sqrt(ib) * pw)
    return ROUND_ULPS * EPS * p / sc[S_H]


@jit
def within_rounding(F, scales):  # type: ignore[no-untyped-def]
    """Whether every row of ``F`` lies within ``ROUND_ULPS`` ulps of its ``scales``."""
    for i in range(F.shape[0]):
        if not abs(F[i]) <= ROUND_ULPS * EPS * scales[i]:
            return False
    return True
