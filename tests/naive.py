"""A slow, plain-numpy twin of the one-step residual ``Phi(z)``.

Written from the equations (MODEL.md, "The discrete model", and the docstring of
:mod:`tumblemc.kernels.residual`), not from the kernel's code, so that the tests can
check the kernel against an independent reading of the model:

- quaternions are scalar first and multiplied with the Hamilton product; a world-frame
  angular velocity ``w`` gives ``dQ/dt = 1/2 (0, w) (x) Q``;
- ``Q+ = normalise(Q + h/2 (0, w+) (x) Q)``, ``R+`` rotates ``v`` as ``Q+ (0, v) Q+*``;
- ``x+ = x + h v+``, ``I+ = R+ Ib R+^T``, ``r = a1 - x+``, ``y = R+^T r``,
  ``N_i = R+ grad f_i(y)``, plane ``g(x) = n.x``;
- rows: Newton-Euler (0:6), then per piece: ``a1 - a2 - l_s n`` at the ``a1`` slots,
  ``sum_i l_i N_i + n`` at the ``a2`` slots, maximum dissipation (divided by ``e``) at the
  ``lam_t, lam_o, lam_r`` slots, and each Fischer-Burmeister row at the index of its
  complementarity variable: ``FB(sigma, mu^2 lam_n^2 - sum (lam/e)^2)``,
  ``FB(l_i, -f_i)``, ``FB(l_s, -g(a2))``, ``FB(lam_n, g(a1))``.

Only numpy and the standard library are used (the layout constants are plain integers).
"""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np

from tumblemc.kernels import layout as L

# ---- Fischer-Burmeister -------------------------------------------------------------


def fb_plain(a: float, b: float) -> float:
    """The textbook formula in float64 (loses all digits when a, b > 0 differ a lot)."""
    return a + b - np.sqrt(a * a + b * b)


def _exact_ctx(*xs: Decimal):  # type: ignore[no-untyped-def]
    """A decimal context that holds sums of the xs and of their squares exactly."""
    nz = [x for x in xs if x != 0]
    digits = sum(len(x.as_tuple().digits) for x in nz)
    spread = max(x.adjusted() for x in nz) - min(x.adjusted() for x in nz) if nz else 0
    return localcontext(prec=60 + 2 * (digits + spread), Emin=-999999, Emax=999999)


def fb_exact(a: float, b: float) -> float:
    """``a + b - sqrt(a^2 + b^2)`` in decimal arithmetic, rounded once to float.

    Floats convert to Decimal exactly. The precision holds ``a + b`` and ``a^2 + b^2``
    exactly, with 60 spare digits, so even the cancellation when a, b > 0 differ by hundreds
    of orders of magnitude leaves far more than 17 correct digits.
    """
    da, db = Decimal(float(a)), Decimal(float(b))
    with _exact_ctx(da, db):
        return float(da + db - (da * da + db * db).sqrt())


def fb_smooth_exact(a: float, b: float, mu: float) -> float:
    """Smoothed FB ``a + b - sqrt(a^2 + b^2 + 2 mu^2)`` (Kanzow 1996), as :func:`fb_exact`."""
    da, db, dm = Decimal(float(a)), Decimal(float(b)), Decimal(float(mu))
    with _exact_ctx(da, db, dm):
        return float(da + db - (da * da + db * db + 2 * dm * dm).sqrt())


# ---- quaternions and rotations --------------------------------------------------------


def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p (x) q`` (scalar first)."""
    p0, pv = p[0], np.asarray(p[1:], dtype=float)
    q0, qv = q[0], np.asarray(q[1:], dtype=float)
    return np.concatenate(([p0 * q0 - pv @ qv], p0 * qv + q0 * pv + np.cross(pv, qv)))


def quat_conj(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]], dtype=float)


def rotmat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion: column j is ``q (0, e_j) q*``."""
    R = np.empty((3, 3))
    for j in range(3):
        e = np.zeros(4)
        e[1 + j] = 1.0
        R[:, j] = quat_mul(quat_mul(q, e), quat_conj(q))[1:]
    return R


def quat_update(q: np.ndarray, w: np.ndarray, h: float) -> np.ndarray:
    """``normalise(Q + h dQ/dt)`` with ``dQ/dt = 1/2 (0, w) (x) Q`` (world-frame ``w``)."""
    dq = 0.5 * quat_mul(np.concatenate(([0.0], w)), q)
    qt = np.asarray(q, dtype=float) + h * dq
    return qt / np.linalg.norm(qt)


# ---- convex constraints (body frame) ----------------------------------------------------


def constraint(ctype: int, cdata: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Value and gradient of one body constraint ``f(y) <= 0``."""
    if ctype == L.C_PLANE:
        nb = np.asarray(cdata[:3], dtype=float)
        return float(nb @ y - cdata[3]), nb.copy()
    if ctype == L.C_CYL_X:
        cy, cz, rad = cdata[0], cdata[1], cdata[2]
        d = np.array([0.0, y[1] - cy, y[2] - cz])
        rho = np.linalg.norm(d)
        return float(rho - rad), d / rho
    raise ValueError(f"unknown constraint type {ctype}")


# ---- the residual -------------------------------------------------------------------------


def block_index(pstart: np.ndarray) -> list[dict[str, int | list[int]]]:
    """Index of every unknown of every contact block (layout.py, module docstring)."""
    out = []
    off = 6
    for k in range(len(pstart) - 1):
        m = int(pstart[k + 1] - pstart[k])
        out.append(
            {
                "a1": off,
                "a2": off + 3,
                "lt": off + 6,
                "lo": off + 7,
                "lr": off + 8,
                "sig": off + 9,
                "l": list(range(off + 10, off + 10 + m)),
                "ls": off + 10 + m,
                "ln": off + 11 + m,
                "c0": int(pstart[k]),
            }
        )
        off += 12 + m
    return out


def naive_model(z, sc, prm, ctype, cdata, pstart, mu_s=0.0) -> dict:  # type: ignore[no-untyped-def]
    """Evaluate the model; returns ``F`` and the FB pairs ``{row: (a, b)}`` used.

    ``mu_s > 0`` replaces every FB row by the smoothed FB of the same pair.
    """
    z = np.asarray(z, dtype=float)
    sc = np.asarray(sc, dtype=float)
    prm = np.asarray(prm, dtype=float)
    n_unk = z.size
    F = np.zeros(n_unk)
    pairs: dict[int, tuple[float, float]] = {}

    # run constants
    mass = prm[L.P_MASS]
    mu, et, eo, er = prm[L.P_MU], prm[L.P_ET], prm[L.P_EO], prm[L.P_ER]
    nrm = prm[L.P_N : L.P_N + 3]
    tan_t = prm[L.P_T : L.P_T + 3]
    tan_o = prm[L.P_O : L.P_O + 3]
    e_b = prm[L.P_EB : L.P_EB + 3]
    Ib = prm[L.P_IB : L.P_IB + 9].reshape(3, 3)

    # step data
    x0 = sc[L.S_X : L.S_X + 3]
    q0 = sc[L.S_Q : L.S_Q + 4]
    v0 = sc[L.S_V : L.S_V + 3]
    w0 = sc[L.S_W : L.S_W + 3]
    h = sc[L.S_H]
    f_ext = sc[L.S_FEXT : L.S_FEXT + 3]

    v_new = z[0:3]
    w_new = z[3:6]

    # end-of-step pose and inertia
    x_new = x0 + h * v_new
    # the pose turned by w_theta = theta w+ + (1 - theta) w (theta 1: the paper's, 0.5: midpoint)
    theta = 1.0 - prm[L.P_POSE_W0]
    R = rotmat(quat_update(q0, theta * w_new + (1.0 - theta) * sc[L.S_W : L.S_W + 3], h))
    I_new = R @ Ib @ R.T

    # the magnetic torque: the end pose's weighted by P_TORQUE_END, the start's by the rest
    wend = prm[L.P_TORQUE_END]
    torque = wend * np.cross(R @ e_b, sc[L.S_B1 : L.S_B1 + 3]) + (1.0 - wend) * sc[L.S_TM : L.S_TM + 3]

    force_sum = np.zeros(3)
    moment_sum = np.zeros(3)

    for blk in block_index(pstart):
        a1 = z[blk["a1"] : blk["a1"] + 3]
        a2 = z[blk["a2"] : blk["a2"] + 3]
        lt, lo, lr = z[blk["lt"]], z[blk["lo"]], z[blk["lr"]]
        sig, ls, ln = z[blk["sig"]], z[blk["ls"]], z[blk["ln"]]

        r = a1 - x_new
        y = R.T @ r
        fc = ln * nrm + lt * tan_t + lo * tan_o
        force_sum += fc
        moment_sum += np.cross(r, fc) + lr * nrm

        # ECP / closest points
        F[blk["a1"] : blk["a1"] + 3] = a1 - a2 - ls * nrm
        cone = nrm.copy()
        for i, row in enumerate(blk["l"]):
            c = blk["c0"] + i
            fval, grad = constraint(int(ctype[c]), cdata[c], y)
            cone = cone + z[row] * (R @ grad)
            pairs[row] = (z[row], -fval)
        F[blk["a2"] : blk["a2"] + 3] = cone

        # maximum dissipation (paper's rows divided by e)
        v_ecp = v_new + np.cross(w_new, r)
        F[blk["lt"]] = mu * et * ln * (tan_t @ v_ecp) + lt / et * sig
        F[blk["lo"]] = mu * eo * ln * (tan_o @ v_ecp) + lo / eo * sig
        F[blk["lr"]] = mu * er * ln * (nrm @ w_new) + lr / er * sig

        # complementarity
        pairs[blk["sig"]] = (sig, (mu * ln) ** 2 - (lt / et) ** 2 - (lo / eo) ** 2 - (lr / er) ** 2)
        pairs[blk["ls"]] = (ls, -(nrm @ a2))
        pairs[blk["ln"]] = (ln, nrm @ a1)

    F[0:3] = mass * (v_new - v0) / h - force_sum - f_ext
    if prm[L.P_ROT_PAPER] == 1.0:  # the paper's explicit gyroscopic form
        F[3:6] = I_new @ (w_new - w0) / h + np.cross(w0, I_new @ w0) - moment_sum - torque
    else:  # momentum form: (I+ w+ - I w) / h with I at the start pose
        R0 = rotmat(q0)
        F[3:6] = (I_new @ w_new - R0 @ Ib @ R0.T @ w0) / h - moment_sum - torque
    for row, (a, b) in pairs.items():
        F[row] = fb_exact(a, b) if mu_s == 0.0 else fb_smooth_exact(a, b, mu_s)
    return {"F": F, "pairs": pairs}


def naive_residual(z, sc, prm, ctype, cdata, pstart, mu_s=0.0) -> np.ndarray:  # type: ignore[no-untyped-def]
    """``Phi(z)`` of one step (see the module docstring); ``mu_s``: FB smoothing."""
    return naive_model(z, sc, prm, ctype, cdata, pstart, mu_s)["F"]
