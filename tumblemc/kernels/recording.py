"""Recording and recentring: a run's record rows, and the origin moved along the plane."""

from __future__ import annotations

import numpy as np

from ._jit import jit, jit_inline
from .layout import (
    B_A1,
    B_A2,
    B_FIXED,
    N_LED,
    N_REC,
    P_ADHC,
    P_O,
    P_T,
    R_ADH,
    R_AREA,
    R_ECP,
    R_FAIL,
    R_FALLBACK,
    R_IMPULSE,
    R_LED,
    R_LN,
    R_LOOSE,
    R_MODE,
    R_NIT,
    R_PEN,
    R_Q,
    R_RES,
    R_SLIP,
    R_SUB,
    R_T,
    R_V,
    R_W,
    R_X,
    SV_AREA,
    SV_ECP,
    SV_FAIL,
    SV_FB,
    SV_IMPULSE,
    SV_LNSUM,
    SV_LOOSE,
    SV_MODE,
    SV_NIT,
    SV_PEEL,
    SV_PEN,
    SV_RES,
    SV_SLIP,
    SV_SUB,
    SV_T,
)

RECENTRE_AT = 100.0  # distance (scaled length, 1 cm) from the origin along t or o beyond which recentre shifts it


@jit
def recentre(state, z, hist, xoff, prm, pstart):  # type: ignore[no-untyped-def]
    """Move the origin along the plane to the centre of mass once it is ``RECENTRE_AT`` away
    along either in-plane axis (``t`` or ``o``).

    The system is invariant under translations along the plane (uniform gravity and field,
    the plane through the origin), but its rows subtract absolute positions: the lever
    ``r = a1 - x+`` of a robot 20 m down an incline (2e5 length units) carries an absolute
    rounding error of about 4e-11, which the friction and torque rows multiply by impulses
    and spin rates of hundreds, a residual floor above ``tol`` (loose steps, thousands of
    Newton iterations, energy in the ledger). Shifting ``x`` and the positions ``a1, a2``
    of the unknowns ``z`` and of every row of the warm-start history ``hist`` by the in-plane part ``s`` of ``x`` keeps every
    position O(1); ``xoff`` accumulates the shifts, which the record adds back. Runs that
    stay within ``RECENTRE_AT`` of the origin are never touched (the same arithmetic as
    before). Returns True if it shifted.
    """
    xt = prm[P_T] * state[0] + prm[P_T + 1] * state[1] + prm[P_T + 2] * state[2]
    xo = prm[P_O] * state[0] + prm[P_O + 1] * state[1] + prm[P_O + 2] * state[2]
    if abs(xt) <= RECENTRE_AT and abs(xo) <= RECENTRE_AT:
        return False
    for i in range(3):
        si = xt * prm[P_T + i] + xo * prm[P_O + i]
        state[i] -= si
        xoff[i] += si
        for r in range(-1, hist.shape[0]):
            zz = z if r < 0 else hist[r]
            off = 6
            for kp in range(pstart.shape[0] - 1):
                zz[off + B_A1 + i] -= si
                zz[off + B_A2 + i] -= si
                off += B_FIXED + pstart[kp + 1] - pstart[kp]
    return True


@jit
def recentre_undo(state, z, xoff, pstart):  # type: ignore[no-untyped-def]
    """Add the shifts :func:`recentre` made back to ``x`` and to ``a1, a2`` of ``z``."""
    for i in range(3):
        state[i] += xoff[i]
        off = 6
        for kp in range(pstart.shape[0] - 1):
            z[off + B_A1 + i] += xoff[i]
            z[off + B_A2 + i] += xoff[i]
            off += B_FIXED + pstart[kp + 1] - pstart[kp]


@jit_inline
def record_row(rec, row, state, z, sv, led, xoff, prm):  # type: ignore[no-untyped-def]
    """Write record row ``row``: time, state and ECP (positions plus the origin's shift
    ``xoff``, :func:`recentre`), the last commit's contact summary (and the adhesion it
    implies, from ``prm``) and the interval's counters from the scalars ``sv`` (``SV_*``; :func:`~.contact.contact_state`) and the
    energy ledger ``led`` (:mod:`.ledger`)."""
    ecp_off = int(sv[SV_ECP])
    rec[row, R_T] = sv[SV_T]
    for i in range(3):
        rec[row, R_X + i] = state[i] + xoff[i]
        rec[row, R_V + i] = state[7 + i]
        rec[row, R_W + i] = state[10 + i]
        rec[row, R_ECP + i] = z[ecp_off + B_A1 + i] + xoff[i] if ecp_off >= 0 else np.nan
    for i in range(4):
        rec[row, R_Q + i] = state[3 + i]
    rec[row, R_LN] = sv[SV_LNSUM]
    rec[row, R_ADH] = prm[P_ADHC] * (sv[SV_AREA] + sv[SV_PEEL])  # applied on the next step
    rec[row, R_AREA] = sv[SV_AREA]
    rec[row, R_MODE] = sv[SV_MODE]
    rec[row, R_SLIP] = sv[SV_SLIP]
    rec[row, R_NIT] = sv[SV_NIT]
    rec[row, R_RES] = sv[SV_RES]
    rec[row, R_FALLBACK] = sv[SV_FB]
    rec[row, R_SUB] = sv[SV_SUB]
    rec[row, R_PEN] = max(sv[SV_PEN], 0.0)
    rec[row, R_FAIL] = sv[SV_FAIL]
    rec[row, R_LOOSE] = sv[SV_LOOSE]
    rec[row, R_IMPULSE] = sv[SV_IMPULSE]
    for i in range(N_LED):
        rec[row, R_LED + i] = led[i]


@jit_inline
def reset_counters(sv):  # type: ignore[no-untyped-def]
    """Start a new record interval: zero the interval's counters in ``sv``."""
    for k in (SV_NIT, SV_RES, SV_FB, SV_SUB, SV_PEN, SV_FAIL, SV_LOOSE, SV_IMPULSE):
        sv[k] = 0.0


def n_records(n_steps: int, record_every: int) -> int:
    """Rows of ``rec`` for a run."""
    return -(-n_steps // record_every) + 1  # the last step is always recorded


def empty_record(n_steps: int, record_every: int) -> np.ndarray:
    """A ``rec`` array for a run."""
    return np.zeros((n_records(n_steps, record_every), N_REC))
