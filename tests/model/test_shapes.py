"""Shape library (``tumblemc.shapes``): hulls, face areas, mass properties, pictures.

Oracles: closed forms of MODEL.md "Shapes" and of polygon / annular-sector area moments,
scipy's convex hull, a Monte Carlo volume integral, and ``cuboid()`` itself for
``extruded`` of its rectangle.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from matplotlib.figure import Figure
from matplotlib.path import Path
from scipy.spatial import ConvexHull, QhullError

import tumblemc
from tumblemc.model.shapes.library import SHAPES, cuboid, curved, get_shape, spiked, spiked_ends
from tumblemc.model.shapes.profile import extruded
from tumblemc.model.shapes.types import ARC_TOL_M, Constraint, Shape

UM = 1e-6
TIGHT = 1e-12  # relative: closed forms evaluated in floating point
ON_HULL_M = 1e-15  # |f| of a point on the hull (coordinates ~1e-3 m, rounding ~1e-19 m)
MODEL_PERIMETER_UM = {"cuboid": 1800.0, "spiked": 2187.0, "spiked_ends": 2239.0, "curved": 2321.0}
PROPERTY = settings(max_examples=40, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow])


def _values(shape: Shape, pts: np.ndarray) -> np.ndarray:
    """(P, M) constraint values at body points ``pts`` (P, 3) of a one-piece shape."""
    return np.column_stack([c.value(pts) for c in shape.pieces[0].constraints])


def _outline_3d(shape: Shape) -> np.ndarray:
    yz = np.asarray(shape.outline)
    return np.concatenate([np.column_stack([np.full(len(yz), s * shape.thickness / 2), yz]) for s in (-1.0, 1.0)])


def _face(shape: Shape, label: str) -> Constraint:
    return next(c for c in shape.pieces[0].constraints if c.label == label)


# ---- the library: MODEL.md dimensions, faces, perimeters -------------------------------


@pytest.mark.parametrize("name", list(MODEL_PERIMETER_UM))
def test_hull_perimeter_is_models_no_slip_distance(name: str) -> None:
    # MODEL.md gives the values rounded to the micrometre
    assert get_shape(name).hull_perimeter / UM == pytest.approx(MODEL_PERIMETER_UM[name], abs=0.5)


def test_library_hull_faces_match_closed_forms() -> None:
    s = spiked()
    flank = math.hypot(400.0, 250.0) * 300.0 * UM**2
    assert s.hull_perimeter == pytest.approx((300.0 + 4 * math.hypot(400.0, 250.0)) * UM, rel=TIGHT)
    assert [c.label for c in s.pieces[0].constraints] == [
        "+x side",
        "-x side",
        "+y end",
        "-y end",
        "+z flank +y",
        "+z flank -y",
        "-z flank -y",
        "-z flank +y",
    ]
    for c in s.pieces[0].constraints:
        expect = {"s": (170000.0 * UM**2, False), "e": (45000.0 * UM**2, False), "f": (flank, True)}[c.label.split()[1][0]]
        assert (c.area, c.line) == (pytest.approx(expect[0], rel=TIGHT), expect[1]), c.label
    np.testing.assert_allclose(
        _face(s, "+z flank +y").data,
        [0.0, 250 / math.hypot(400, 250), 400 / math.hypot(400, 250), 325e-6 * 400 / math.hypot(400, 250)],
        rtol=TIGHT,
    )

    e = spiked_ends()
    sf = math.hypot(50.0, 125.0)
    assert e.hull_perimeter == pytest.approx((300.0 + 4 * sf + 1400.0) * UM, rel=TIGHT)
    assert (_face(e, "+x side").area, _face(e, "+y end").area) == (
        pytest.approx(145000 * UM**2, rel=TIGHT),
        pytest.approx(45000 * UM**2, rel=TIGHT),
    )
    for lab in ("+y flank +z", "+y flank -z", "-y flank +z", "-y flank -z"):
        assert (_face(e, lab).area, _face(e, lab).line) == (pytest.approx(sf * 300 * UM**2, rel=TIGHT), False)
    for lab in ("+z bridge", "-z bridge"):
        assert (_face(e, lab).area, _face(e, lab).line) == (pytest.approx(700 * 300 * UM**2, rel=TIGHT), True)
        assert _face(e, lab).data[3] == pytest.approx(200 * UM, rel=TIGHT)

    c = curved()
    R, r, a, T = 1250 * UM, 1100 * UM, math.radians(25.0), 400 * UM
    rbar = 2 / 3 * (R**3 - r**3) / (R**2 - r**2) * math.sin(a) / a  # centroid of an annular sector
    assert c.cm_shift == (0.0, pytest.approx(rbar, rel=TIGHT))
    arc = _face(c, "+z outer arc")
    assert arc.kind == "cylinder_x" and arc.line
    np.testing.assert_allclose(arc.data, [0.0, -rbar, R, 0.0], atol=1e-18)
    assert arc.area == pytest.approx(2 * a * R * T, rel=TIGHT)
    chord = _face(c, "-z inner chord")
    assert chord.line and chord.area == pytest.approx(2 * r * math.sin(a) * T, rel=TIGHT)
    assert chord.data[3] == pytest.approx(rbar - r * math.cos(a), rel=TIGHT)
    for lab in ("+y end", "-y end"):
        assert (_face(c, lab).area, _face(c, lab).line) == (pytest.approx(150 * 400 * UM**2, rel=TIGHT), False)
    assert _face(c, "+x side").area == pytest.approx(a * (R**2 - r**2), rel=TIGHT)
    assert c.hull_perimeter == pytest.approx(2 * a * R + 2 * r * math.sin(a) + 2 * 150 * UM, rel=TIGHT)


@pytest.mark.parametrize("name", list(SHAPES))
def test_hull_contains_the_body_and_every_face_touches_it(name: str) -> None:
    shp = get_shape(name)
    piece = shp.pieces[0]
    f = _values(shp, _outline_3d(shp))
    assert f.max() <= ON_HULL_M
    fs = _values(shp, piece.support_points)
    assert fs.max() <= ON_HULL_M
    # no redundant constraint: each touches the body along a line or a face
    touching = (np.abs(fs) <= ON_HULL_M + piece.support_pad).sum(axis=0)
    assert touching.min() >= 2
    # a prism's hull faces, each its length x thickness, add up to the perimeter x thickness
    faces = [c for c in piece.constraints if not (c.kind == "plane" and abs(c.data[0]) > 0.5)]
    assert math.fsum(c.area for c in faces) == pytest.approx(shp.hull_perimeter * shp.thickness, rel=TIGHT)


@pytest.mark.parametrize("name", list(SHAPES))
@given(data=st.data())
@PROPERTY
def test_points_outside_the_hull_violate_a_constraint(name: str, data: st.DataObject) -> None:
    shp = get_shape(name)
    hull = ConvexHull(np.asarray(shp.outline)[:-1])
    lo, hi = np.min(shp.outline, axis=0), np.max(shp.outline, axis=0)
    span = hi - lo
    y = data.draw(st.floats(lo[0] - 0.3 * span[0], hi[0] + 0.3 * span[0]))
    z = data.draw(st.floats(lo[1] - 0.3 * span[1], hi[1] + 0.3 * span[1]))
    x = data.draw(st.floats(-shp.thickness, shp.thickness))
    dist = max(float(np.max(hull.equations @ [y, z, 1.0])), abs(x) - shp.thickness / 2)
    # the outline samples arcs 1 deg apart (sagitta < 0.05 um): stay clear of the boundary
    assume(abs(dist) > 0.2 * UM)
    f = _values(shp, np.array([[x, y, z]]))[0]
    assert (f.max() > 0) == (dist > 0)


def test_support_points_with_pad_bound_the_curved_hull_from_below() -> None:
    shp = curved()
    piece = shp.pieces[0]
    arc = _face(shp, "+z outer arc")
    cy, cz, R, _ = arc.data
    half = math.radians(25.0)
    th = np.linspace(0.5 * math.pi - half, 0.5 * math.pi + half, 200001)
    dense = np.column_stack([np.zeros_like(th), cy + R * np.cos(th), cz + R * np.sin(th)])
    for ang in np.linspace(0, 2 * math.pi, 721):
        n = np.array([0.0, math.cos(ang), math.sin(ang)])
        assert (piece.support_points @ n).min() - piece.support_pad <= (dense @ n).min() + 1e-18
    assert 0 < piece.support_pad <= 1.01 * ARC_TOL_M


def test_rest_pose_heights_and_adhering_areas() -> None:
    frac = 0.05
    assert cuboid().rest_face_area(frac) == pytest.approx(800 * 400 * UM**2, rel=TIGHT)
    s, e, c = spiked(), spiked_ends(), curved()
    # spiked stands on its spike apex (two bridging flanks), spiked ends on its bridge
    assert s.rest_height() == pytest.approx(325 * UM, rel=TIGHT)
    assert s.rest_face_area(frac) == pytest.approx(frac * _face(s, "+z flank +y").area, rel=TIGHT)
    assert e.rest_height() == pytest.approx(200 * UM, rel=TIGHT)
    assert e.rest_face_area(frac) == pytest.approx(frac * _face(e, "+z bridge").area, rel=TIGHT)
    # curved lies on its outer arc: the exact top of the cylinder, not a sample plus pad
    assert c.rest_height() == pytest.approx(1250 * UM - c.cm_shift[1], rel=TIGHT)
    assert c.rest_face_area(frac) == pytest.approx(frac * _face(c, "+z outer arc").area, rel=TIGHT)


# ---- extruded: the cuboid, hulls of random profiles, arcs ----------------------------


def test_extruded_rectangle_is_the_cuboid() -> None:
    ref = cuboid()
    ext = extruded(ref.outline[:-1], ref.thickness, name="cuboid")
    for a, b in zip(ref.pieces[0].constraints, ext.pieces[0].constraints, strict=True):
        assert (a.kind, a.data, a.area, a.line) == (b.kind, b.data, b.area, b.line)
    np.testing.assert_array_equal(ext.pieces[0].support_points, ref.pieces[0].support_points)
    np.testing.assert_allclose(ext.inertia_per_mass, ref.inertia_per_mass, rtol=1e-15, atol=0)
    assert (ext.hull_perimeter, ext.profile_area, ext.pieces[0].support_pad) == (ref.hull_perimeter, ref.profile_area, 0.0)
    np.testing.assert_array_equal(ext.outline, ref.outline)
    for preset, incline in (("paper", 0.0), ("aluminum", 30.0)):
        a = tumblemc.simulate(shape="cuboid", preset=preset, incline_deg=incline, duration_s=0.05)
        b = tumblemc.simulate(shape=ext, preset=preset, incline_deg=incline, duration_s=0.05)
        for var in ("position", "quaternion", "velocity", "omega", "normal_force", "adhesion_force", "contact_mode"):
            np.testing.assert_array_equal(a[var].values, b[var].values, err_msg=var)


def test_extruded_is_frame_and_orientation_free() -> None:
    ref = cuboid(600e-6, 300e-6, 120e-6)
    shift = np.array([3.1e-4, -7.7e-5])
    moved = extruded(ref.outline[:-1][::-1] + shift, 300e-6)  # clockwise, off-centre
    np.testing.assert_allclose(moved.cm_shift, shift, rtol=1e-12)
    for a, b in zip(ref.pieces[0].constraints, moved.pieces[0].constraints, strict=True):
        np.testing.assert_allclose(b.data, a.data, rtol=1e-9, atol=1e-15)
        assert b.area == pytest.approx(a.area, rel=1e-12) and b.line == a.line
    np.testing.assert_allclose(moved.inertia_per_mass, ref.inertia_per_mass, rtol=1e-9, atol=1e-22)


@st.composite
def profiles(draw: st.DrawFn) -> np.ndarray:
    """Draw a random simple polygon in metres.

    Convex (hull of random points) or star-shaped (angles sorted about the origin,
    consecutive gaps < pi; usually non-convex).
    """
    scale = draw(st.floats(50e-6, 2e-3))
    if draw(st.booleans()):
        pts = np.array(draw(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=3, max_size=12)))
        try:
            hull = ConvexHull(pts)
        except QhullError:  # degenerate (collinear) input
            assume(False)
        poly = pts[hull.vertices]
    else:
        n = draw(st.integers(4, 12))
        w = np.array(draw(st.lists(st.floats(1.0, 2.0), min_size=n, max_size=n)))
        ang = draw(st.floats(0, 2 * math.pi)) + np.cumsum(w) / w.sum() * 2 * math.pi
        rad = np.array(draw(st.lists(st.floats(0.25, 1.0), min_size=n, max_size=n)))
        poly = np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    area = 0.5 * abs(np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1]))
    edges = np.hypot(*(poly - np.roll(poly, -1, axis=0)).T)
    assume(area > 0.05 and edges.min() > 1e-3 and np.ptp(poly, axis=0).min() > 0.05)
    poly = poly * scale
    return poly[::-1] if draw(st.booleans()) else poly


@given(poly=profiles(), data=st.data())
@PROPERTY
def test_extruded_hull_of_random_profiles(poly: np.ndarray, data: st.DataObject) -> None:
    thick = 200e-6
    shp = extruded(poly, thick)
    body = poly - np.array(shp.cm_shift)
    hull = ConvexHull(body)
    size = float(np.ptp(body, axis=0).max())
    # the body's vertices satisfy every constraint, the hull's vertices touch
    pts = np.concatenate([np.column_stack([np.full(len(body), s * thick / 2), body]) for s in (-1, 1)])
    assert _values(shp, pts).max() <= 1e-12 * size
    assert shp.hull_perimeter == pytest.approx(hull.area, rel=1e-9)  # a 2-D hull's "area" is its perimeter
    assert shp.profile_area == pytest.approx(
        0.5 * abs(np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1])), rel=1e-12
    )
    faces = shp.pieces[0].constraints[2:]
    assert len(faces) <= len(hull.vertices) and all(c.area > 0 for c in faces)
    # every vertex of scipy's hull lies on one of the hull faces
    on = np.abs(_values(shp, np.column_stack([np.zeros(len(hull.vertices)), body[hull.vertices]]))[:, 2:]).min(axis=1)
    assert on.max() <= 1e-12 * size
    if len(hull.vertices) == len(poly):  # convex: every hull face is a whole real face
        assert not any(c.line for c in faces)
        assert math.fsum(c.area for c in faces) == pytest.approx(shp.hull_perimeter * thick, rel=1e-9)
    # random points: outside the hull some f > 0, inside none
    lo, hi = body.min(axis=0), body.max(axis=0)
    q = np.array(
        [
            data.draw(st.floats(-thick, thick)),
            data.draw(st.floats(lo[0] - 0.2 * size, hi[0] + 0.2 * size)),
            data.draw(st.floats(lo[1] - 0.2 * size, hi[1] + 0.2 * size)),
        ]
    )
    dist = max(float(np.max(hull.equations @ [q[1], q[2], 1.0])), abs(q[0]) - thick / 2)
    assume(abs(dist) > 1e-9 * size)
    assert (_values(shp, q[None, :])[0].max() > 0) == (dist > 0)
    # perpendicular-axis theorem of the lamina, and a symmetric positive inertia
    ipm = shp.inertia_per_mass
    assert ipm[0, 0] == pytest.approx(ipm[1, 1] + ipm[2, 2] - thick**2 / 6, rel=1e-9)
    np.testing.assert_array_equal(ipm, ipm.T)
    assert np.linalg.eigvalsh(ipm).min() > 0


def _dense_outline(poly: np.ndarray, arcs: dict[int, float], n: int = 4000) -> np.ndarray:
    """The outline with every arc replaced by ``n`` chords.

    An independent construction: the minor arc through both ends, bulging to the right
    of a CCW edge if radius > 0.
    """
    ccw = np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1]) > 0
    out = []
    for i in range(len(poly)):
        p0, p1 = poly[i], poly[(i + 1) % len(poly)]
        out.append(p0)
        if i in arcs:
            rad, half = abs(arcs[i]), np.linalg.norm(p1 - p0) / 2
            t = (p1 - p0) / (2 * half)
            bulge = np.array([t[1], -t[0]]) * np.sign(arcs[i]) * (1 if ccw else -1)
            centre = (p0 + p1) / 2 - bulge * math.sqrt(rad**2 - half**2)
            a0, a1 = (math.atan2(*(p - centre)[::-1]) for p in (p0, p1))
            sweep = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
            th = a0 + sweep * np.arange(1, n) / n
            out.extend(centre + rad * np.column_stack([np.cos(th), np.sin(th)]))
    return np.array(out)


@given(poly=profiles(), edge=st.integers(0, 11), factor=st.floats(0.5, 4.0), outward=st.booleans())
@PROPERTY
def test_extruded_with_an_arc_matches_a_dense_polygon(poly: np.ndarray, edge: int, factor: float, outward: bool) -> None:
    edge %= len(poly)
    chord = float(np.linalg.norm(poly[(edge + 1) % len(poly)] - poly[edge]))
    radius = max(factor, 0.5 + 1e-9) * chord * (1 if outward else -1)
    try:
        shp = extruded(poly, 200e-6, arcs={edge: radius}, mass_from="profile")
    except ValueError as err:  # the two refusals that depend on the arc
        assert any(w in str(err) for w in ("self-intersecting with the arcs", "does not contain the rest", "inside out"))
        assume(False)
    dense = _dense_outline(poly, {edge: radius}) - np.array(shp.cm_shift)
    size = float(np.ptp(dense, axis=0).max())
    pts = np.concatenate([np.column_stack([np.full(len(dense), s * 100e-6), dense]) for s in (-1, 1)])
    assert _values(shp, pts).max() <= 1e-12 * size
    assert shp.hull_perimeter == pytest.approx(ConvexHull(dense).area, rel=1e-6)
    y, z = dense[:, 0], dense[:, 1]
    y1, z1 = np.roll(y, -1), np.roll(z, -1)
    c = y * z1 - y1 * z
    area = c.sum() / 2
    assert shp.profile_area == pytest.approx(abs(area), rel=1e-6)
    cy, cz = ((y + y1) * c).sum() / (6 * area), ((z + z1) * c).sum() / (6 * area)
    assert math.hypot(cy, cz) <= 1e-6 * size
    syy = ((y * y + y * y1 + y1 * y1) * c).sum() / (12 * area)
    szz = ((z * z + z * z1 + z1 * z1) * c).sum() / (12 * area)
    syz = ((y * z1 + 2 * y * z + 2 * y1 * z1 + y1 * z) * c).sum() / (24 * area)
    ipm = shp.inertia_per_mass
    np.testing.assert_allclose(
        [ipm[0, 0], ipm[2, 2] - 200e-6**2 / 12, ipm[1, 1] - 200e-6**2 / 12, -ipm[1, 2]],
        [syy + szz, syy, szz, syz],
        rtol=1e-5,
        atol=1e-5 * (syy + szz),
    )


A, B, T_MC, R_TOP = 300e-6, 100e-6, 200e-6, 900e-6
#: a bar with an outward arc over its whole top and an inward notch in its bottom
NOTCHED = np.array([(-2 * A, -B), (-A, -B), (A, -B), (2 * A, -B), (2 * A, B), (-2 * A, B)])
NOTCHED_ARCS = {4: R_TOP, 1: -1.5 * A}


def test_arcs_on_the_hull_and_a_partly_real_face() -> None:
    shp = extruded(NOTCHED, T_MC, arcs=NOTCHED_ARCS)
    beta = math.asin(2 * A / R_TOP)
    assert shp.hull_perimeter == pytest.approx(4 * A + 4 * B + 2 * beta * R_TOP, rel=1e-12)
    arc = _face(shp, "+z arc")
    assert arc.kind == "cylinder_x" and arc.line and arc.area == pytest.approx(2 * beta * R_TOP * T_MC, rel=1e-12)
    assert arc.data[2] == R_TOP
    # the bottom hull face is real on both sides of the notch only
    bottom = _face(shp, "-z face")
    assert bottom.area == pytest.approx(2 * A * T_MC, rel=1e-12) and not bottom.line
    assert _values(shp, _outline_3d(shp)).max() <= 1e-12 * A
    assert 0 < shp.pieces[0].support_pad <= 1.01 * ARC_TOL_M


@pytest.mark.parametrize(
    ("profile", "arcs"),
    [
        ([(-1e-4, -1e-4), (1e-4, -1e-4), (1e-4, 1e-4), (-1e-4, 1e-4)], {0: 1e-4, 1: 1e-4, 2: 1e-4, 3: 1e-4}),  # rounded square
        ([(-4e-4, -5e-5), (4e-4, -5e-5), (4e-4, 5e-5), (-4e-4, 5e-5)], {1: 5e-5, 3: 5e-5}),  # capsule
        ([(-4e-4, -5e-5), (4e-4, -5e-5), (4e-4, 5e-5), (2e-4, 5e-5), (-2e-4, 5e-5), (-4e-4, 5e-5)], {3: 2e-4}),  # bump on a side
    ],
)
def test_arcs_whose_circle_misses_the_hull_are_refused(profile: list, arcs: dict) -> None:
    with pytest.raises(ValueError, match=r"arcs\[\d\]: the circle of this outward arc .* does not contain the rest"):
        extruded(profile, 300e-6, arcs=arcs)


# ---- bad input --------------------------------------------------------------------------

SQUARE = [(0.0, 0.0), (4e-4, 0.0), (4e-4, 4e-4), (0.0, 4e-4)]


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"profile": [(0.0, 0.0), (1e-4, 0.0)]}, ["profile", "2 vertices", "at least 3"]),
        ({"profile": [(0.0, 0.0), (1e-4, math.nan), (0.0, 1e-4)]}, ["profile[1]", "nan", "finite"]),
        ({"profile": [1e-4, 2e-4, 3e-4]}, ["profile", "(3,)", "(N, 2)"]),
        ({"profile": "square"}, ["profile", "square"]),
        ({"profile": SQUARE + [SQUARE[0]]}, ["repeated vertices 0 and 4", "do not repeat the first"]),
        ({"profile": SQUARE[:2] + [SQUARE[1]] + SQUARE[2:]}, ["repeated vertices 1 and 2"]),
        ({"profile": [(0.0, 0.0), (1e-4, 1e-4), (2e-4, 2e-4 + 1e-17)]}, ["profile", "zero area"]),
        ({"profile": [(0.0, 0.0), (4e-4, 4e-4), (4e-4, 0.0), (0.0, 4e-4)]}, ["profile is self-intersecting", "edges 0", "and 2"]),
        (
            {"profile": [(0.0, 0.0), (800.0, 0.0), (800.0, 100.0), (0.0, 100.0)]},
            ["profile", "800.0", "looks like micrometres; give metres"],
        ),
        ({"profile": [(0.0, 0.0), (4e-7, 0.0), (4e-7, 4e-7)]}, ["profile", "4e-07", "give metres"]),
        ({"thickness": 300.0}, ["thickness", "300.0", "looks like micrometres"]),
        ({"thickness": math.inf}, ["thickness", "inf"]),
        ({"arcs": {0: 1e-4}}, ["arcs[0]", "0.0001", "half the edge"]),
        ({"arcs": {7: 3e-4}}, ["arcs key 7", "0..3"]),
        ({"arcs": {0: 0.0}}, ["arcs[0]", "nonzero"]),
        ({"arcs": [3e-4]}, ["arcs", "mapping"]),
        (
            {"profile": [(0.0, 0.0), (4e-4, 0.0), (4e-4, 1e-4), (0.0, 1e-4)], "arcs": {0: -2.0001e-4}},
            ["profile is self-intersecting with the arcs", "-0.00020001"],
        ),
        ({"arcs": {0: 3e-4, -4: 3e-4}}, ["arcs", "edge 0 twice"]),
        ({"mass_from": "steel"}, ["mass_from", "steel", "profile", "aluminum_robot"]),
        ({"name": ""}, ["name", "non-empty"]),
        ({"arc_tol": 1e-3}, ["arc_tol", "0.001"]),
    ],
)
def test_extruded_bad_input_is_a_clear_error(kwargs: dict, words: list[str]) -> None:
    args = {"profile": SQUARE, "thickness": 300e-6, **kwargs}
    with pytest.raises(ValueError) as err:
        extruded(args.pop("profile"), args.pop("thickness"), **args)
    for w in words:
        assert w in str(err.value)


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: spiked(apex_z=50e-6), ["apex_z", "5e-05", "bar_height"]),
        (lambda: spiked(length=800.0), ["length", "800.0", "micrometres"]),
        (lambda: spiked_ends(spike_base=500e-6), ["spike_base", "length / 2"]),
        (lambda: curved(r_inner=1300e-6), ["r_inner", "r_outer"]),
        (lambda: curved(half_angle_deg=95.0), ["half_angle_deg", "95.0"]),
        (lambda: curved(mass_from="lead"), ["mass_from", "lead"]),
        (lambda: cuboid().mass(-2700.0), ["density", "-2700.0"]),
        (lambda: get_shape("sphere"), ["shape", "sphere", "spiked_ends"]),
    ],
)
def test_library_bad_input_is_a_clear_error(call, words: list[str]) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError) as err:
        call()
    for w in words:
        assert w in str(err.value)


# ---- mass properties ---------------------------------------------------------------------


def test_inertia_default_is_the_aluminum_robots_and_profile_on_request() -> None:
    alu = cuboid(800e-6, 400e-6, 100e-6).inertia_per_mass
    for make in (spiked, spiked_ends, curved):
        assert make().mass_model == "aluminum_robot"
        np.testing.assert_array_equal(make().inertia_per_mass, alu)
        own = make(mass_from="profile")
        assert own.mass_model == "profile" and not np.allclose(own.inertia_per_mass, alu)
    assert cuboid().mass_model == "profile"
    assert cuboid().mass(2700.0) == pytest.approx(2700.0 * 800e-6 * 100e-6 * 400e-6, rel=TIGHT)
    assert spiked().mass(2700.0) == pytest.approx(2700.0 * 170000e-12 * 300e-6, rel=TIGHT)


def test_inertia_of_rectangles_is_the_closed_form() -> None:
    for L, H, W, off in ((800e-6, 100e-6, 400e-6, (0.0, 0.0)), (1.3e-3, 0.37e-3, 0.21e-3, (2e-3, -5e-4))):
        rect = np.array([(-L / 2, -H / 2), (L / 2, -H / 2), (L / 2, H / 2), (-L / 2, H / 2)]) + off
        ipm = extruded(rect, W).inertia_per_mass
        np.testing.assert_allclose(ipm, np.diag([L**2 + H**2, W**2 + H**2, W**2 + L**2]) / 12, rtol=1e-12, atol=1e-24)


def test_inertia_of_the_annular_sector_is_the_closed_form() -> None:
    R, r, a, T = 1250e-6, 1100e-6, math.radians(25.0), 400e-6
    shp = curved(mass_from="profile")
    area = a * (R**2 - r**2)
    syy = (R**4 - r**4) / 4 * (a - math.sin(a) * math.cos(a))  # about the centre of curvature
    szz = (R**4 - r**4) / 4 * (a + math.sin(a) * math.cos(a))
    zbar = 2 * math.sin(a) * (R**3 - r**3) / 3 / area
    szz_c = szz - area * zbar**2
    expect = np.diag([(syy + szz_c) / area, T**2 / 12 + szz_c / area, T**2 / 12 + syy / area])
    np.testing.assert_allclose(shp.inertia_per_mass, expect, rtol=1e-9, atol=1e-24)
    assert shp.profile_area == pytest.approx(area, rel=1e-12)


def test_inertia_of_a_circular_sector_is_the_closed_form() -> None:
    rho, beta, T = 500e-6, math.radians(35.0), 100e-6  # apex at the origin, axis along +z
    pts = [(0.0, 0.0), (rho * math.sin(beta), rho * math.cos(beta)), (-rho * math.sin(beta), rho * math.cos(beta))]
    shp = extruded(pts, T, arcs={1: rho})
    area = rho**2 * beta
    zbar = 2 * rho * math.sin(beta) / (3 * beta)
    syy = rho**4 / 4 * (beta - math.sin(beta) * math.cos(beta))
    szz_c = rho**4 / 4 * (beta + math.sin(beta) * math.cos(beta)) - area * zbar**2
    assert shp.cm_shift == (pytest.approx(0.0, abs=1e-18), pytest.approx(zbar, rel=1e-12))
    np.testing.assert_allclose(
        shp.inertia_per_mass, np.diag([(syy + szz_c) / area, T**2 / 12 + szz_c / area, T**2 / 12 + syy / area]), rtol=1e-9, atol=1e-24
    )


def test_inertia_of_a_non_convex_profile_with_arcs_by_monte_carlo() -> None:
    """Volume integrals by uniform sampling agree with the exact ones.

    1e6 points, fixed seed: each estimate within 4 standard errors of the exact integrals.
    """
    prof, a, b, T = NOTCHED, A, B, T_MC
    shp = extruded(prof, T, arcs=NOTCHED_ARCS, mass_from="profile")

    def segment(p0: np.ndarray, p1: np.ndarray, radius: float, q: np.ndarray) -> np.ndarray:
        """Points of q in the circular segment cut by chord p0-p1 on its outer (right) side."""
        c, t = 0.5 * (p0 + p1), (p1 - p0) / np.linalg.norm(p1 - p0)
        out = np.array([t[1], -t[0]]) * np.sign(radius)
        r = abs(radius)
        centre = c - out * math.sqrt(r**2 - (np.linalg.norm(p1 - p0) / 2) ** 2)
        return (np.hypot(*(q - centre).T) <= r) & ((q - c) @ out > 0)

    rng = np.random.default_rng(20240607)
    n = 1_000_000
    lo, hi = np.array([-2 * a, -b]), np.array([2 * a, b + R_TOP - math.sqrt(R_TOP**2 - 4 * a**2)])
    q = lo + (hi - lo) * rng.random((n, 2))
    x = T * (rng.random(n) - 0.5)
    inside = Path(prof).contains_points(q) | segment(prof[4], prof[5], R_TOP, q)
    inside &= ~segment(prof[1], prof[2], -1.5 * a, q)
    box = float(np.prod(hi - lo))
    frac = inside.mean()
    assert shp.profile_area == pytest.approx(box * frac, abs=4 * box * math.sqrt(frac * (1 - frac) / n))
    p = np.column_stack([x, q - np.array(shp.cm_shift)])[inside]
    m = len(p)
    centroid_se = p[:, 1:].std(axis=0) / math.sqrt(m)
    assert np.all(np.abs(p[:, 1:].mean(axis=0)) <= 4 * centroid_se)
    r2 = np.einsum("ij,ij->i", p, p)
    for i in range(3):
        for j in range(3):
            sample = (r2 if i == j else 0.0) - p[:, i] * p[:, j]
            if not np.any(sample):
                continue
            est, se = sample.mean(), sample.std() / math.sqrt(m)
            assert abs(shp.inertia_per_mass[i, j] - est) <= 4 * se, (i, j, shp.inertia_per_mass[i, j], est, se)


# ---- simulation and pictures -------------------------------------------------------------


@pytest.mark.parametrize("name", ["spiked", "spiked_ends", "curved"])
def test_new_shapes_simulate(name: str) -> None:
    ds = tumblemc.simulate(shape=name, preset="aluminum", duration_s=0.05)
    assert ds.attrs["status"] == 0 and ds.attrs["failed_steps"] == 0
    assert ds.attrs["hull_perimeter"] == get_shape(name).hull_perimeter
    # penetration as the stepper measures it: at most the support pad of a curved face, plus
    # what the solver's tolerance admits in the gap row (tol x the length unit, 1e-4 m)
    assert float(ds["penetration"].max()) <= get_shape(name).pieces[0].support_pad + tumblemc.SolverOptions().tol * 1e-4


def test_plot_shapes_writes_png(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from tumblemc.viz.run import plot_shapes

    out = tmp_path / "shapes.png"
    fig = plot_shapes(path=out)
    assert isinstance(fig, Figure) and len([ax for ax in fig.axes if ax.get_visible()]) == len(SHAPES)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert "45000 µm²" in texts and "line" in texts
    one = plot_shapes([extruded(SQUARE, 300e-6, arcs={2: 3e-4})])
    assert len([ax for ax in one.axes if ax.get_visible()]) == 1


def test_an_inward_arc_leaving_a_sharp_tip_outside_its_neighbour_is_refused() -> None:
    """Regression, found by the property test above.

    An inward arc on one side of a tall diamond starts 0.5 deg beyond the tip's 28 deg
    opening, crosses the neighbouring edge and comes back within the outline's sampling
    step.
    """
    poly = np.array([[0.0, 1.953125e-3], [-4.8828125e-4, 0.0], [0.0, -1.953125e-3], [4.8828125e-4, 0.0]])
    chord = float(np.linalg.norm(poly[1] - poly[0]))
    with pytest.raises(ValueError, match="self-intersecting with the arcs"):
        extruded(poly, 200e-6, arcs={0: -1.046875 * chord}, mass_from="profile")
    extruded(poly, 200e-6, arcs={0: -1.2 * chord}, mass_from="profile")  # a shallower arc stays inside
