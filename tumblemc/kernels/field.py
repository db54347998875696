"""The applied field of a run: the paper's rotating field or a field program (MODEL.md, "Field programs").

``prm[P_FPROG]`` segments of ``FSEG`` numbers follow the run constants (``prm[N_PRM:]``,
built by :mod:`tumblemc.model.fields`); with none, the field is the paper's,
``P_TORQ x R_x(2 pi f t) u``, computed by :func:`field_dir` exactly as before programs.
"""

from __future__ import annotations

import math

from ._jit import jit
from .layout import FS_AMP, FS_BIAS, FS_FREQ, FS_PSI0, FS_S, FS_T0, FS_W, FSEG, N_PRM, P_FIELD_ON, P_FPROG, P_FREQ, P_TORQ, P_U


@jit
def field_dir(prm, t, out):  # type: ignore[no-untyped-def]
    """Unit field ``R_x(2 pi f t) u`` of the paper (MODEL.md, "Field and magnetisation")."""
    a = 2.0 * math.pi * prm[P_FREQ] * t
    c = math.cos(a)
    s = math.sin(a)
    u1 = prm[P_U + 1]
    u2 = prm[P_U + 2]
    out[0] = prm[P_U]
    out[1] = c * u1 - s * u2
    out[2] = s * u1 + c * u2


@jit
def program_field(prm, t, out):  # type: ignore[no-untyped-def]
    """``V_m |E| B(t)`` of the field program at scaled time ``t`` (the segment with the latest start <= t)."""
    n = int(prm[P_FPROG])
    k = 0
    for j in range(1, n):
        if prm[N_PRM + j * FSEG + FS_T0] <= t:
            k = j
    b = N_PRM + k * FSEG
    psi = 2.0 * math.pi * prm[b + FS_FREQ] * (t - prm[b + FS_T0]) + prm[b + FS_PSI0]
    c = math.cos(psi) * prm[b + FS_AMP]
    s = math.sin(psi) * prm[b + FS_AMP]
    for i in range(3):
        out[i] = c * prm[b + FS_S + i] + s * prm[b + FS_W + i] + prm[b + FS_BIAS + i]


@jit
def field_work_bound(prm, duration):  # type: ignore[no-untyped-def]
    """The most work the field can do on the magnet in ``duration`` (scaled).

    Paper's field: ``|m||B| (2 + 2 pi f T)``. Program: per segment, ``2 |m| max|B|`` (the
    magnetic energy's range) plus ``|m| |B_rot| 2 pi f`` times the segment's time in
    ``[0, T]`` (the work of the field's turning). :func:`field_work_between` from 0.
    """
    return field_work_between(prm, 0.0, duration)


@jit
def field_energy_range(prm):  # type: ignore[no-untyped-def]
    """The magnetic energy's range, ``2 |m| max|B|`` (scaled): what a magnet can exchange with the
    body by turning, whatever the field does (the first term of :func:`field_work_between`,
    at the program's strongest segment)."""
    if prm[P_FIELD_ON] < 0.5:
        return 0.0
    n = int(prm[P_FPROG])
    if n == 0:
        return 2.0 * prm[P_TORQ]
    best = 0.0
    for k in range(n):
        b = N_PRM + k * FSEG
        bias = math.sqrt(prm[b + FS_BIAS] ** 2 + prm[b + FS_BIAS + 1] ** 2 + prm[b + FS_BIAS + 2] ** 2)
        best = max(best, 2.0 * (abs(prm[b + FS_AMP]) + bias))
    return best


@jit
def field_work_between(prm, ta, tb):  # type: ignore[no-untyped-def]
    """The most work the field can do on the magnet between the times ``ta`` and ``tb``
    (scaled): per segment of a program that overlaps ``[ta, tb]``, its energy range plus
    its turning over the overlap (the paper's field: one segment). The energy range counts
    even for an empty interval, as in the ledger's bound."""
    if prm[P_FIELD_ON] < 0.5:
        return 0.0
    n = int(prm[P_FPROG])
    if n == 0:
        return prm[P_TORQ] * (2.0 + 2.0 * math.pi * prm[P_FREQ] * (tb - ta))
    tot = 0.0
    for k in range(n):
        b = N_PRM + k * FSEG
        lo = max(prm[b + FS_T0], ta)
        hi = min(prm[b + FSEG + FS_T0], tb) if k + 1 < n else tb
        if hi < lo:
            continue
        bias = math.sqrt(prm[b + FS_BIAS] ** 2 + prm[b + FS_BIAS + 1] ** 2 + prm[b + FS_BIAS + 2] ** 2)
        amp = abs(prm[b + FS_AMP])
        tot += 2.0 * (amp + bias) + amp * 2.0 * math.pi * abs(prm[b + FS_FREQ]) * (hi - lo)
    return tot


__all__ = ["field_dir", "field_energy_range", "field_work_between", "field_work_bound", "program_field"]
