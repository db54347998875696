"""Profile geometry in the body y-z plane.

Circular arcs, sampled outlines, exact area moments (rational arithmetic), the convex hull
and its faces (which real material each hull face touches: face or line contact). Used by
:func:`tumblemc.model.shapes.profile.extruded`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from tumblemc.model.shapes.types import (
    GROUPS,
    REL_TOL,
    cross2,
)


@dataclass(frozen=True)
class Arc:
    """A circular arc replacing profile edge ``a -> b`` (CCW profile).

    sign : +1 bulging outward (adds material), -1 bulging inward (removes material).
    th0, th1 : polar angles (about ``centre``) of ``a`` and ``b``; the arc runs from th0
        to th1 through ``mid`` = the direction of the bulge.
    beta : half the arc's opening angle (< pi / 2 + tiny: minor arcs only).
    """

    centre: np.ndarray
    radius: float
    sign: int
    th0: float
    th1: float
    beta: float
    mid: np.ndarray

    def angles(self, n: int) -> np.ndarray:
        """Polar angles of ``n + 1`` equally spaced points from th0 to th1."""
        return self.th0 + (self.th1 - self.th0) * np.arange(n + 1) / n

    def points(self, n: int) -> np.ndarray:
        """The arc sampled at ``n + 1`` equally spaced points (:meth:`angles`), shape (n + 1, 2)."""
        th = self.angles(n)
        return self.centre + self.radius * np.column_stack([np.cos(th), np.sin(th)])


def make_arc(a: np.ndarray, b: np.ndarray, radius: float) -> Arc:
    """Minor arc of signed ``radius`` on edge ``a -> b`` of a CCW profile."""
    r = abs(radius)
    c = float(np.hypot(*(b - a)))
    beta = math.asin(min(1.0, c / (2.0 * r)))
    t = (b - a) / c
    n_out = np.array([t[1], -t[0]])  # exterior is on the right of a CCW profile
    sign = 1 if radius > 0 else -1
    mid = sign * n_out
    centre = 0.5 * (a + b) - mid * r * math.cos(beta)
    thm = math.atan2(mid[1], mid[0])
    # a lies at thm + delta with delta = +-beta
    delta = beta if cross2(mid, a - centre) > 0 else -beta
    return Arc(centre, r, sign, thm + delta, thm - delta, beta, mid)


def sample_outline(v: np.ndarray, arcs: dict[int, Arc], step: float) -> np.ndarray:
    """Closed outline: vertices with arcs sampled at most ``step`` rad apart."""
    pts = []
    for i in range(len(v)):
        pts.append(v[i])
        if i in arcs:
            arc = arcs[i]
            n = max(4, math.ceil(abs(arc.th1 - arc.th0) / step))
            pts.extend(arc.points(n)[1:-1])
    pts.append(v[0])
    return np.array(pts)


def polygon_moments(v: np.ndarray) -> list[Fraction]:
    """[A, Sy, Sz, Syy, Szz, Syz] of a CCW polygon about the origin.

    Exact rational arithmetic on the given floats (Green's theorem; ``S_ab`` = integral of
    a b dA).
    """
    acc = [Fraction(0)] * 6
    q = [(Fraction(float(y)), Fraction(float(z))) for y, z in v]
    for (y0, z0), (y1, z1) in zip(q, q[1:] + q[:1], strict=True):
        c = y0 * z1 - y1 * z0
        terms = [c / 2, (y0 + y1) * c / 6, (z0 + z1) * c / 6, (y0 * y0 + y0 * y1 + y1 * y1) * c / 12]
        terms += [(z0 * z0 + z0 * z1 + z1 * z1) * c / 12, (y0 * z1 + 2 * y0 * z0 + 2 * y1 * z1 + y1 * z0) * c / 24]
        acc = [a + t for a, t in zip(acc, terms, strict=True)]
    return acc


def segment_moments(arc: Arc) -> np.ndarray:
    """[A, Sy, Sz, Syy, Szz, Syz] about the origin of the circular segment between the arc and its chord.

    Positive; the caller adds or removes it.
    """
    r, b = arc.radius, arc.beta
    sb, cb = math.sin(b), math.cos(b)
    area = r * r * (b - sb * cb)
    m1 = 2.0 / 3.0 * r**3 * sb**3  # first moment along mid, about the centre
    mww = r**4 / 4.0 * (b + sb * cb) - r**4 * sb * cb**3 / 2.0
    muu = r**4 / 4.0 * (b - sb * cb) - r**4 * sb**3 * cb / 6.0
    w = arc.mid
    u = np.array([-w[1], w[0]])
    o = arc.centre
    first = area * o + m1 * w
    second = area * np.outer(o, o) + m1 * (np.outer(o, w) + np.outer(w, o)) + muu * np.outer(u, u) + mww * np.outer(w, w)
    return np.array([area, first[0], first[1], second[0, 0], second[1, 1], second[0, 1]])


def area_moments(v: np.ndarray, arcs: dict[int, Arc]) -> list[Fraction]:
    """[A, Sy, Sz, Syy, Szz, Syz] of the profile about the origin.

    The polygon exactly, plus or minus the circular segments of its arcs (closed forms in
    floating point).
    """
    m = polygon_moments(v)
    for arc in arcs.values():
        m = [a + arc.sign * Fraction(float(t)) for a, t in zip(m, segment_moments(arc), strict=True)]
    return m


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Indices of the strict convex hull of ``points`` (M, 2), CCW.

    Nearly collinear points are dropped (relative tolerance ``REL_TOL`` on the turn's sine).
    """
    order = np.lexsort((points[:, 1], points[:, 0]))

    def turn_ok(o: int, a: int, b: int) -> bool:
        da, db = points[a] - points[o], points[b] - points[a]
        return bool(cross2(da, db) > REL_TOL * math.hypot(*da) * math.hypot(*db))

    def chain(idx: np.ndarray) -> list[int]:
        out: list[int] = []
        for k in idx:
            while len(out) >= 2 and not turn_ok(out[-2], out[-1], int(k)):
                out.pop()
            out.append(int(k))
        return out

    lower, upper = chain(order), chain(order[::-1])
    return np.array(lower[:-1] + upper[:-1])


@dataclass
class HullFace:
    """A face of the profile's hull.

    Straight from ``p0`` to ``p1``, or the whole outward arc ``arc`` (from ``p0`` to ``p1``,
    CCW about its centre).
    """

    p0: np.ndarray
    p1: np.ndarray
    arc: Arc | None = None

    @property
    def length(self) -> float:
        """Length of the face (chord of a straight face, arc length of an arc), m."""
        if self.arc is None:
            return float(math.hypot(*(self.p1 - self.p0)))
        return self.arc.radius * (self.arc.th1 - self.arc.th0)

    @property
    def normal(self) -> np.ndarray:
        """Outward unit normal (of a straight face; at the middle of an arc)."""
        if self.arc is None:
            d = self.p1 - self.p0
            return np.array([d[1], -d[0]]) / math.hypot(*d) + 0.0
        return self.arc.mid


def farthest_on_arc(arc: Arc, centre: np.ndarray) -> float:
    """Largest distance from ``centre`` to a point of ``arc`` (exact)."""
    ends = arc.centre + arc.radius * np.array([[math.cos(arc.th0), math.sin(arc.th0)], [math.cos(arc.th1), math.sin(arc.th1)]])
    best = float(np.hypot(*(ends - centre).T).max())
    d = arc.centre - centre
    dist = math.hypot(*d)
    if dist > 0.0:  # the circle's farthest point from centre, if it lies on the arc
        off = (math.atan2(d[1], d[0]) - 0.5 * (arc.th0 + arc.th1) + math.pi) % (2.0 * math.pi) - math.pi
        if abs(off) <= arc.beta:
            best = max(best, dist + arc.radius)
    return best


def hull_faces(v: np.ndarray, arcs: dict[int, Arc], step: float, user_edge: dict[int, int]) -> list[HullFace]:
    """Hull of a CCW profile with arcs: straight faces and whole outward arcs, CCW.

    Built from the vertices and the outward arcs sampled ``step`` rad apart. An outward
    arc on the hull becomes one ``cylinder_x`` constraint, so its circle must contain the
    whole hull (else the hull is not the intersection of its faces); then the arc lies on
    the hull from end to end, between corners.
    """
    nv = len(v)
    out_arcs = {k: a for k, a in arcs.items() if a.sign > 0}
    nsamp = {k: max(2, math.ceil((a.th1 - a.th0) / step)) for k, a in out_arcs.items()}
    allp = np.concatenate([v] + [out_arcs[k].points(nsamp[k])[1:-1] for k in out_arcs])
    owner = [-1] * nv + [k for k in out_arcs for _ in range(1, nsamp[k])]
    h = [int(i) for i in convex_hull(allp)]
    on_hull = sorted({owner[i] for i in h if owner[i] >= 0})
    size = float(np.ptp(v, axis=0).max())
    for k in on_hull:
        arc = out_arcs[k]
        reach = max([float(np.hypot(*(v - arc.centre).T).max())] + [farthest_on_arc(out_arcs[j], arc.centre) for j in out_arcs if j != k])
        if reach > arc.radius + REL_TOL * size:
            raise ValueError(
                f"arcs[{user_edge[k]}]: the circle of this outward arc (radius {arc.radius!r} m) does not contain the rest of the "
                f"profile's hull (a point {reach - arc.radius:.3g} m outside), so the hull is not the intersection of planes and "
                "this cylinder (allowed: outward arcs on the hull whose circle contains the whole hull, like the curved robot's; "
                "a capsule or rounded corners would need several convex pieces)"
            )
    faces: list[HullFace] = []
    m = len(h)
    e = next(i for i in range(m) if owner[h[i]] < 0)  # start at a vertex
    h = h[e:] + h[:e]
    i = 0
    while i < m:
        p, q = h[i], h[(i + 1) % m]
        if not (owner[p] < 0 and p in on_hull and owner[q] == p):
            faces.append(HullFace(allp[p].copy(), allp[q].copy()))
            i += 1
            continue
        k = p  # vertex k starts arc k
        # the whole arc k from vertex k to vertex k+1: its interior samples come next
        i += nsamp[k]
        if h[i % m] != (k + 1) % nv:
            raise AssertionError("an outward arc inside its own circle must lie on the hull from end to end")
        faces.append(HullFace(v[k].copy(), v[(k + 1) % nv].copy(), out_arcs[k]))
    return faces


def face_order(faces: list[HullFace]) -> list[tuple[str, HullFace]]:
    """Hull faces grouped by the body direction nearest their outward normal.

    Groups in the order +y, -y, +z, -z (the cuboid's), and by polar angle within a group.
    """
    keyed = []
    for f in faces:
        n = f.normal
        g = int(np.argmax([n @ np.array(d) for _, d in GROUPS]))
        ax = GROUPS[g][1]
        rel = (math.atan2(n[1], n[0]) - math.atan2(ax[1], ax[0]) + math.pi) % (2.0 * math.pi) - math.pi
        keyed.append((g, rel, f))
    keyed.sort(key=lambda t: (t[0], t[1]))
    return [(GROUPS[g][0], f) for g, _, f in keyed]
