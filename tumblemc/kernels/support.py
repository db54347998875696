"""Support points: the lowest point of a piece over the plane, support heights, level edges."""

from __future__ import annotations

import math

from ._jit import jit
from .layout import (
    P_N,
)


@jit
def touching_centroid(x, R, geo, s0, s1, hts, cut, out):  # type: ignore[no-untyped-def]
    """``out`` = the centroid (world) of support points ``s0 .. s1 - 1`` whose height in
    ``hts`` is at most ``cut`` (:func:`lowest_point`, :func:`lowest_many`)."""
    for i in range(3):
        out[i] = 0.0
    cnt = 0
    for p in range(s0, s1):
        if hts[p - s0] <= cut:
            cnt += 1
            for i in range(3):
                wi = x[i]
                for j in range(3):
                    wi += R[3 * i + j] * geo.sup_pts[p, j]
                out[i] += wi
    for i in range(3):
        out[i] /= cnt


#: pieces with more support points than this take :func:`lowest_many` (the curved robot's
#: 226; the others have 8 to 16)
FAST_HEIGHT_POINTS = 32
#: relative margin of :func:`lowest_many`'s screening heights (see there)
FAST_HEIGHT_REL = 1e-12


@jit
def lowest_many(x, R, prm, geo, kp, out, tol, hts):  # type: ignore[no-untyped-def]
    """:func:`lowest_point` for a piece of many support points, bit for bit, at about a
    quarter of the arithmetic: a screening pass computes ``(R^T n) . p`` (three products
    per point instead of twelve), and only the points that can be within ``tol`` of the
    lowest get ``lowest_point``'s height, in its order of operations.

    The screening height plus ``n . x`` and ``lowest_point``'s height are ``n . (x + R p)``
    computed in two orders, each within about 20 ulps of ``|x|_1 + |p|_1`` of it
    (``|n_i|, |R_ij| <= 1``); ``mg``, 1e-12 of that sum plus 1, bounds their difference
    with a factor of over a hundred to spare. A point screened at more than ``tol + 2 mg``
    above the lowest screened one is then more than ``tol`` above the lowest point, and
    the lowest point is among those kept: the minimum, the touching set and the centroid
    are ``lowest_point``'s. ``hts`` holds the heights of the points kept and ``inf``
    elsewhere."""
    s0 = geo.sup_start[kp]
    s1 = geo.sup_start[kp + 1]
    xs = 1.0
    for i in range(3):
        xs += abs(x[i])
    m0 = prm[P_N] * R[0] + prm[P_N + 1] * R[3] + prm[P_N + 2] * R[6]
    m1 = prm[P_N] * R[1] + prm[P_N + 1] * R[4] + prm[P_N + 2] * R[7]
    m2 = prm[P_N] * R[2] + prm[P_N + 1] * R[5] + prm[P_N + 2] * R[8]
    fbest = math.inf
    pmax = 0.0
    for p in range(s0, s1):
        p0 = geo.sup_pts[p, 0]
        p1 = geo.sup_pts[p, 1]
        p2 = geo.sup_pts[p, 2]
        hf = m0 * p0 + m1 * p1 + m2 * p2
        hts[p - s0] = hf
        fbest = min(fbest, hf)
        pmax = max(pmax, abs(p0) + abs(p1) + abs(p2))
    cut = fbest + tol + 2.0 * FAST_HEIGHT_REL * (xs + pmax)
    best = math.inf
    for p in range(s0, s1):
        if hts[p - s0] <= cut:
            hgt = 0.0
            for i in range(3):
                wi = x[i]
                for j in range(3):
                    wi += R[3 * i + j] * geo.sup_pts[p, j]
                hgt += prm[P_N + i] * wi
            hts[p - s0] = hgt
            if hgt < best:
                best = hgt
        else:
            hts[p - s0] = math.inf
    touching_centroid(x, R, geo, s0, s1, hts, best + tol, out)
    return best - geo.sup_pad[kp]


@jit
def lowest_point(x, R, prm, geo, kp, out, tol, hts):  # type: ignore[no-untyped-def]
    """Lowest point of piece ``kp``: returns its height minus the pad; ``out`` receives the
    centroid (world) of the support points within ``tol`` of the lowest one, the
    middle of the touching face or edge, a good first guess of the ECP. ``hts`` (float64,
    at least the piece's support points) receives their heights: one pass computes them,
    the second only compares. Pieces of more than ``FAST_HEIGHT_POINTS`` points (the curved
    robot's 226) take :func:`lowest_many`, the same results, where ``hts`` holds the
    heights of the points near the lowest only. ``tol`` >= 0."""
    s0 = geo.sup_start[kp]
    s1 = geo.sup_start[kp + 1]
    if s1 - s0 > FAST_HEIGHT_POINTS:
        return lowest_many(x, R, prm, geo, kp, out, tol, hts)
    best = math.inf
    for p in range(s0, s1):
        hgt = 0.0
        for i in range(3):
            wi = x[i]
            for j in range(3):
                wi += R[3 * i + j] * geo.sup_pts[p, j]
            hgt += prm[P_N + i] * wi
        hts[p - s0] = hgt
        if hgt < best:
            best = hgt
    touching_centroid(x, R, geo, s0, s1, hts, best + tol, out)
    return best - geo.sup_pad[kp]


@jit
def level_edge(x, R, prm, geo, kp, tol, edge):  # type: ignore[no-untyped-def]
    """Guess 10's edge: the half length of the segment joining the two lowest support points
    of piece ``kp`` at the pose ``x``, ``R`` when they lie within ``tol`` of each other in
    height and every other support point lies more than ``tol`` above the lowest (a level
    edge, not a vertex or a face; a curved piece's line has more points and returns 0);
    ``edge`` receives its unit direction (world). Returns 0 otherwise."""
    p0, p1, h0, h1, h2 = lowest_three(x, R, prm, geo, kp)
    if p1 < 0 or h1 - h0 > tol or h2 - h0 <= tol:
        return 0.0
    el = 0.0
    for i in range(3):
        d = 0.0
        for j in range(3):
            d += R[3 * i + j] * (geo.sup_pts[p1, j] - geo.sup_pts[p0, j])
        edge[i] = d
        el += d * d
    el = math.sqrt(el)
    if el < 1e-9:
        return 0.0
    for i in range(3):
        edge[i] /= el
    return 0.5 * el


@jit
def support_height(x, R, prm, geo, p):  # type: ignore[no-untyped-def]
    """Height along ``n`` of support point ``p`` at the pose ``x``, ``R``."""
    hgt = 0.0
    for i in range(3):
        wi = x[i]
        for j in range(3):
            wi += R[3 * i + j] * geo.sup_pts[p, j]
        hgt += prm[P_N + i] * wi
    return hgt


@jit
def lowest_three(x, R, prm, geo, kp):  # type: ignore[no-untyped-def]
    """The lowest and second-lowest support points of piece ``kp`` at the pose ``x``, ``R``
    and the heights of the three lowest: ``(p0, p1, h0, h1, h2)`` (``-1`` and ``inf`` where
    the piece has fewer points; a tie goes to the point listed first)."""
    p0 = -1
    p1 = -1
    h0 = math.inf
    h1 = math.inf
    h2 = math.inf
    for p in range(geo.sup_start[kp], geo.sup_start[kp + 1]):
        hgt = support_height(x, R, prm, geo, p)
        if hgt < h0:
            h2 = h1
            p1 = p0
            h1 = h0
            p0 = p
            h0 = hgt
        elif hgt < h1:
            h2 = h1
            p1 = p
            h1 = hgt
        elif hgt < h2:
            h2 = hgt
    return p0, p1, h0, h1, h2
