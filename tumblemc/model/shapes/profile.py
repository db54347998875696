"""User-defined robot profiles.

Validation of a polygon (with optional circular arcs) and :func:`extruded`, which turns it
into a :class:`~tumblemc.model.shapes.types.Shape` (hull, contact constraints, adhering
areas, mass properties).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from tumblemc.model.shapes.hull import Arc, area_moments, face_order, hull_faces, make_arc, sample_outline
from tumblemc.model.shapes.types import (
    ALUMINUM_ROBOT_LWH_M,
    ARC_TOL_M,
    MASS_MODELS,
    MAX_DIM_M,
    MAX_VERTICES,
    MIN_DIM_M,
    OUTLINE_STEP_RAD,
    REL_TOL,
    Constraint,
    Piece,
    Shape,
    cross2,
)


def _dim_error(arg: str, what: str | None, value: float) -> ValueError:
    hint = "looks like micrometres; give metres" if value > MAX_DIM_M else "give metres"
    name = f"{arg}={value!r} m" if what is None else f"{arg}: {what} = {value!r} m"
    return ValueError(f"{name} is outside {MIN_DIM_M:g}..{MAX_DIM_M:g} m ({hint})")


def check_dim(arg: str, value: Any) -> float:
    """Check a length argument ``arg`` of a shape.

    Returns
    -------
    float
        ``value`` as a float, m.

    Raises
    ------
    ValueError
        If ``value`` is not a finite number from ``MIN_DIM_M`` to ``MAX_DIM_M``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not math.isfinite(float(value)):
        raise ValueError(f"{arg}={value!r} is not allowed (allowed: a finite length in metres, {MIN_DIM_M:g}..{MAX_DIM_M:g})")
    x = float(value)
    if not MIN_DIM_M <= x <= MAX_DIM_M:
        raise _dim_error(arg, None, x)
    return x


def _check_profile(profile: Any) -> np.ndarray:
    """(N, 2) float array of a valid profile, as given (orientation unchanged)."""
    try:
        v = np.array(profile, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"profile={profile!r} is not allowed (allowed: an (N, 2) array of (y, z) vertices in metres, N >= 3)") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"profile has shape {v.shape} (allowed: (N, 2), the (y, z) vertices in metres)")
    if not 3 <= len(v) <= MAX_VERTICES:
        raise ValueError(f"profile has {len(v)} vertices (allowed: at least 3, at most {MAX_VERTICES})")
    if not np.all(np.isfinite(v)):
        bad = np.argwhere(~np.isfinite(v))[0]
        raise ValueError(f"profile[{bad[0]}] = {v[bad[0]].tolist()} is not finite (allowed: finite (y, z) in metres)")
    sv = np.linalg.svd(v - v.mean(axis=0), compute_uv=False)
    if sv[-1] <= REL_TOL * sv[0]:
        raise ValueError(
            f"profile has zero area: its {len(v)} vertices are (nearly) collinear (allowed: a simple polygon enclosing an area)"
        )
    for k, axis in enumerate("yz"):
        ext = float(np.ptp(v[:, k]))
        if not MIN_DIM_M <= ext <= MAX_DIM_M:
            raise _dim_error("profile", f"its extent along {axis}", ext)
    size = float(np.ptp(v, axis=0).max())
    d = np.hypot(v[:, None, 0] - v[None, :, 0], v[:, None, 1] - v[None, :, 1])
    ri, rj = np.nonzero(np.triu(d <= REL_TOL * size, 1))
    if len(ri):
        raise ValueError(
            f"profile has repeated vertices {int(ri[0])} and {int(rj[0])} at {v[ri[0]].tolist()} "
            "(allowed: each vertex once; the polygon closes itself, do not repeat the first vertex)"
        )
    hit = _self_intersection(v)
    if hit is not None:
        i, j = hit
        raise ValueError(
            f"profile is self-intersecting: edges {i} ({v[i].tolist()} to {v[(i + 1) % len(v)].tolist()}) and {j} "
            f"({v[j].tolist()} to {v[(j + 1) % len(v)].tolist()}) cross or touch (allowed: a simple polygon)"
        )
    area = 0.5 * math.fsum(cross2(v, np.roll(v, -1, axis=0)))
    if abs(area) <= REL_TOL * size**2:
        raise ValueError(f"profile has (near-)zero area {area!r} m^2 (allowed: a simple polygon enclosing an area)")
    return v


def _self_intersection(p: np.ndarray) -> tuple[int, int] | None:
    """First pair of edges of the closed polygon ``p`` (N, 2) that touch or cross.

    Neighbours sharing their common vertex do not count (a neighbour folding back does).
    """
    n = len(p)
    a, b = p, np.roll(p, -1, axis=0)
    size = float(np.ptp(p, axis=0).max())
    eps = REL_TOL * size**2
    # neighbours: a fold-back (angle 0) makes them overlap
    d0, d1 = b - a, np.roll(b - a, -1, axis=0)
    fold = (np.abs(cross2(d0, d1)) <= REL_TOL * np.hypot(*d0.T) * np.hypot(*d1.T)) & (np.einsum("ij,ij->i", d0, d1) < 0)
    if np.any(fold):
        first = int(np.argmax(fold))
        return first, (first + 1) % n
    i, j = np.triu_indices(n, 2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]
    p1, p2, q1, q2 = a[i], b[i], a[j], b[j]
    o1, o2 = cross2(p2 - p1, q1 - p1), cross2(p2 - p1, q2 - p1)
    o3, o4 = cross2(q2 - q1, p1 - q1), cross2(q2 - q1, p2 - q1)
    proper = (o1 * o2 < 0) & (o3 * o4 < 0)

    def on_seg(s0: np.ndarray, s1: np.ndarray, q: np.ndarray, o: np.ndarray) -> np.ndarray:
        lo, hi = np.minimum(s0, s1) - REL_TOL * size, np.maximum(s0, s1) + REL_TOL * size
        return (np.abs(o) <= eps) & np.all((q >= lo) & (q <= hi), axis=1)

    touch = on_seg(p1, p2, q1, o1) | on_seg(p1, p2, q2, o2) | on_seg(q1, q2, p1, o3) | on_seg(q1, q2, p2, o4)
    hit = proper | touch
    if np.any(hit):
        k = int(np.argmax(hit))
        return int(i[k]), int(j[k])
    return None


def _check_arcs(arcs: Any, v: np.ndarray) -> dict[int, float]:
    if arcs is None:
        return {}
    if not isinstance(arcs, Mapping):
        raise ValueError(f"arcs={arcs!r} is not allowed (allowed: None or a mapping {{edge index: signed radius in m}})")  # noqa: TRY004
    n = len(v)
    out: dict[int, float] = {}
    for k, rad in arcs.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not -n <= int(k) < n:
            raise ValueError(f"arcs key {k!r} is not allowed (allowed: an edge index 0..{n - 1}; edge i joins vertex i to vertex i+1)")
        ki = int(k) % n
        if ki in out:
            raise ValueError(f"arcs gives edge {ki} twice (keys {k!r} and another index of the same edge)")
        if isinstance(rad, bool) or not isinstance(rad, (int, float, np.integer, np.floating)) or not math.isfinite(float(rad)) or rad == 0:
            raise ValueError(f"arcs[{k!r}]={rad!r} is not allowed (allowed: a finite nonzero signed radius in m; > 0 bulges outward)")
        r = abs(float(rad))
        if r > MAX_DIM_M:
            raise _dim_error(f"arcs[{k!r}]", "the radius", r)
        chord = float(np.hypot(*(v[(ki + 1) % n] - v[ki])))
        if r < 0.5 * chord * (1.0 - 1e-12):
            raise ValueError(
                f"arcs[{k!r}]={rad!r} is too small for edge {ki} of length {chord!r} m "
                f"(allowed: |radius| >= half the edge, {0.5 * chord!r} m)"
            )
        out[ki] = float(rad)
    return out


def _arc_crosses_neighbour(v: np.ndarray, arcs: dict[int, Arc]) -> np.ndarray | None:
    """A point where an arc meets a straight neighbouring edge other than at their shared vertex, or None.

    The edge's line through the shared vertex ``p`` meets the arc's circle once more, at
    ``p + t d`` with ``t = -2 d.(p - centre)`` (``d`` unit, pointing along the edge away
    from ``p``); it counts if it lies on the edge and on the arc.
    """
    n = len(v)
    size = float(np.ptp(v, axis=0).max())
    for k, arc in arcs.items():
        ends = []
        if (k - 1) % n not in arcs:
            ends.append((v[k], v[(k - 1) % n]))
        if (k + 1) % n not in arcs:
            ends.append((v[(k + 1) % n], v[(k + 2) % n]))
        span = arc.th1 - arc.th0
        for p, far in ends:
            length = float(np.linalg.norm(far - p))
            d = (far - p) / length
            t = -2.0 * float(d @ (p - arc.centre))
            if not REL_TOL * size < t <= length:
                continue
            x = p + t * d
            u = (math.atan2(x[1] - arc.centre[1], x[0] - arc.centre[0]) - arc.th0 + math.pi) % (2 * math.pi) - math.pi
            if REL_TOL < u / span < 1.0 - REL_TOL:
                return x
    return None


def cuboid_inertia(length: float, width: float, height: float) -> np.ndarray:
    """Inertia per mass of a uniform cuboid about its centre (body axes x = W, y = L, z = H)."""
    return np.diag([length**2 + height**2, width**2 + height**2, width**2 + length**2]) / 12.0


def _aluminum_robot_ipm() -> np.ndarray:
    return cuboid_inertia(*ALUMINUM_ROBOT_LWH_M)


def extruded(
    profile: Any,
    thickness: float,
    *,
    arcs: Mapping[int, float] | None = None,
    name: str = "extruded",
    mass_from: str = "profile",
    arc_tol: float = ARC_TOL_M,
) -> Shape:
    """A robot made by extruding a 2-D profile in the body y-z plane along x.

    Parameters
    ----------
    profile : (N, 2) array_like of float, m
        Vertices ``(y, z)`` of a simple polygon, convex or not, in either orientation,
        N >= 3, each vertex once (the polygon closes itself). Any frame: the shape is
        re-centred at the profile's area centroid (the CM at uniform density).
    thickness : float, m
        Extent along body x (the rotation axis of tumbling).
    arcs : mapping int -> float, optional
        Circular arcs replacing straight edges: ``{i: radius}`` replaces edge ``i`` (from
        vertex ``i`` to vertex ``i+1``, index in the order given) with the minor circular
        arc of ``|radius|`` (m) through both vertices; ``radius > 0`` bulges outward (adds
        material), ``< 0`` bulges inward (removes it). ``|radius|`` must be at least half
        the edge; half the edge gives a semicircle.
    name : str
        The shape's name (``simulate`` stores it; ``get_shape`` only knows the library's).
    mass_from : {"profile", "aluminum_robot"}
        ``"profile"``: inertia of the extruded profile at uniform density (exact polygon
        and circular-segment integrals). ``"aluminum_robot"``: the aluminum robot's
        inertia (its 0.8 x 0.4 x 0.1 mm cuboid), as the paper does for its shapes.
    arc_tol : float, m
        Largest sagitta between the sampled support points of a curved hull face (the
        kernel's ``support_pad``).

    Returns
    -------
    Shape
        One convex piece: constraints ``+x``, ``-x`` (area: the profile's), then the hull
        faces of the profile grouped by the body direction nearest their outward normal
        (``+y``, ``-y``, ``+z``, ``-z``, the order of :func:`cuboid`) and by angle within a
        group. A straight hull face is a plane; a hull face on an outward arc is a
        ``cylinder_x`` constraint (line contact). Areas and line flags follow the rule in
        the module docstring. ``cm_shift`` holds the centroid in the given coordinates.

    Raises
    ------
    ValueError
        Naming the argument, the value and what is allowed: fewer than 3 vertices,
        non-finite values, repeated vertices, (near-)zero area, a self-intersecting
        outline (arcs included), arcs that do not fit their edge or turn the outline
        inside out, an outward arc on the hull whose circle does not contain the whole
        hull (see Notes), or any dimension outside 1e-6..1e-1 m (a profile in
        micrometres).

    Notes
    -----
    Contact with a plane only touches the convex hull (MODEL.md, "Shapes"): a non-convex
    profile acts through its hull, and its notches never touch the plane. The mass
    properties use the real (non-convex) profile: area, centroid and second moments are
    Green's-theorem sums over the polygon in exact rational arithmetic, plus or minus the
    closed-form moments of each arc's circular segment, rounded once.

    A piece is the intersection of its constraints, and an arc's constraint is its whole
    circle; so an outward arc on the hull is allowed only if its circle contains the whole
    hull (the curved robot's outer arc, a bulging side of a bar). Rounded corners, a
    capsule's ends or a bump in the middle of a side would make the intersection smaller
    than the hull and are refused; they would need one piece per arc.
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"name={name!r} is not allowed (allowed: a non-empty string)")
    if mass_from not in MASS_MODELS:
        raise ValueError(f"mass_from={mass_from!r} is not allowed (allowed: {', '.join(MASS_MODELS)})")
    if (
        isinstance(arc_tol, bool)
        or not isinstance(arc_tol, (int, float, np.floating))
        or not (math.isfinite(arc_tol) and 0.0 < arc_tol <= 1e-6)
    ):
        raise ValueError(f"arc_tol={arc_tol!r} is not allowed (allowed: a finite sagitta in metres, 0 < arc_tol <= 1e-6)")
    v = _check_profile(profile)
    thick = check_dim("thickness", thickness)
    radii = _check_arcs(arcs, v)
    n = len(v)
    user_edge = {k: k for k in range(n)}  # edge index here -> as given (for messages)
    if 0.5 * math.fsum(cross2(v, np.roll(v, -1, axis=0))) < 0:  # make it CCW, vertex 0 first
        v = np.roll(v[::-1], 1, axis=0)
        radii = {n - 1 - k: r for k, r in radii.items()}
        user_edge = {n - 1 - k: k for k in range(n)}
    arc_geo = {k: make_arc(v[k], v[(k + 1) % n], r) for k, r in radii.items()}
    outline = sample_outline(v, arc_geo, OUTLINE_STEP_RAD)
    hit = _self_intersection(outline[:-1]) if radii else None
    near = None if hit is None else (outline[hit[0]], outline[hit[1]])
    if near is None and radii:
        # an arc can leave its vertex on the wrong side of the neighbouring edge and come
        # back within one sampling step: intersect each arc's circle with those edges exactly
        cross_at = _arc_crosses_neighbour(v, arc_geo)
        near = None if cross_at is None else (cross_at, cross_at)
    if near is not None:
        raise ValueError(
            f"profile is self-intersecting with the arcs={dict(arcs or {})!r}: its outline near {near[0].tolist()} and "
            f"{near[1].tolist()} crosses or touches itself (allowed: arcs that keep the outline simple)"
        )

    # centroid and moments about it, exactly (so that a rectangle gives cuboid()'s bits)
    mo = area_moments(v, arc_geo)
    area_q = mo[0]
    if not float(area_q) > REL_TOL * float(np.ptp(outline, axis=0).max()) ** 2:
        raise ValueError(
            f"profile with the arcs={dict(arcs or {})!r} has area {float(area_q)!r} m^2: an inward arc that swallows the polygon "
            "turns the outline inside out (allowed: arcs that leave a positive area)"
        )
    cy, cz = mo[1] / area_q, mo[2] / area_q
    # squared lengths of the equivalent rectangle: 12 S / A (L^2 and H^2 for a cuboid)
    ly2 = float(12 * (mo[3] - area_q * cy * cy) / area_q)
    lz2 = float(12 * (mo[4] - area_q * cz * cz) / area_q)
    syz = float((mo[5] - area_q * cy * cz) / area_q)
    area = float(area_q)
    cm = np.array([float(cy), float(cz)])
    v = v - cm
    arc_geo = {k: replace(a, centre=a.centre - cm) for k, a in arc_geo.items()}
    outline = outline - cm
    if mass_from == "profile":
        ipm = np.array(
            [[(ly2 + lz2) / 12.0, 0.0, 0.0], [0.0, (thick**2 + lz2) / 12.0, 0.0 - syz], [0.0, 0.0 - syz, (thick**2 + ly2) / 12.0]]
        )
    else:
        ipm = _aluminum_robot_ipm()

    # hull of the profile: constraints, areas, support points
    size = float(np.ptp(v, axis=0).max())
    tol = REL_TOL * size
    min_r = min((a.radius for a in arc_geo.values() if a.sign > 0), default=1.0)
    step = 2.0 * math.acos(max(-1.0, 1.0 - arc_tol / min_r)) if arc_geo else 1.0
    faces = hull_faces(v, arc_geo, step, user_edge)
    straight = [(v[i], v[(i + 1) % n]) for i in range(n) if i not in arc_geo]
    hx = thick / 2.0
    cons = [
        Constraint("plane", (1.0, 0.0, 0.0, hx), area, label="+x side"),
        Constraint("plane", (-1.0, 0.0, 0.0, hx), area, label="-x side"),
    ]
    ordered = face_order(faces)
    counts: dict[str, int] = {}
    for g, _ in ordered:
        counts[g] = counts.get(g, 0) + 1
    seen: dict[str, int] = {}
    pad = 0.0
    sup: list[np.ndarray] = []
    for g, f in ordered:
        seen[g] = seen.get(g, 0) + 1
        tag = f" #{seen[g]}" if counts[g] > 1 else ""
        if f.arc is not None:
            a = f.arc
            cons.append(
                Constraint("cylinder_x", (float(a.centre[0]), float(a.centre[1]), a.radius, 0.0), f.length * thick, True, f"{g} arc{tag}")
            )
            k = max(2, math.ceil((a.th1 - a.th0) / step))  # as in hull_faces
            sup.append(a.points(k)[1:-1])
            pad = max(pad, a.radius * (1.0 - math.cos(0.5 * (a.th1 - a.th0) / k)) * (1.0 + 1e-6))
        else:
            nrm = f.normal
            d = float(np.max(v @ nrm))  # through p0, p1 and any near-collinear vertex the hull merged
            t = (f.p1 - f.p0) / f.length
            real = 0.0
            for a0, a1 in straight:
                if abs(float(nrm @ a0) - d) <= tol and abs(float(nrm @ a1) - d) <= tol:
                    s0, s1 = sorted((float(t @ (a0 - f.p0)), float(t @ (a1 - f.p0))))
                    real += max(0.0, min(s1, f.length) - max(s0, 0.0))
            if real > tol:
                cons.append(Constraint("plane", (0.0, float(nrm[0]), float(nrm[1]), d), real * thick, False, f"{g} face{tag}"))
            else:
                cons.append(Constraint("plane", (0.0, float(nrm[0]), float(nrm[1]), d), f.length * thick, True, f"{g} bridge{tag}"))
        sup.append(f.p0[None, :])
    yz = np.concatenate(sup)
    pts3 = np.concatenate([np.column_stack([np.full(len(yz), s * hx), yz]) for s in (-1.0, 1.0)])
    pts3 = pts3[np.lexsort((pts3[:, 2], pts3[:, 1], pts3[:, 0]))]
    perimeter = math.fsum(f.length for f in faces)
    piece = Piece(tuple(cons), np.ascontiguousarray(pts3), pad)
    return Shape(name, (piece,), outline, thick, perimeter, ipm, mass_from, area, (float(cm[0]), float(cm[1])))
