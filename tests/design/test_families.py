"""Design families: mass and inertia against closed forms and an independent polygon integration; the named shapes bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumblemc
from tumblemc.design.families import END_LENGTH_M, FAMILIES, build, ends_area, get_family, profile_family
from tumblemc.model.params import PRESETS
from tumblemc.model.shapes.types import ALUMINUM_ROBOT_LWH_M

UM = 1e-6
CUBOID_V = ALUMINUM_ROBOT_LWH_M[0] * ALUMINUM_ROBOT_LWH_M[1] * ALUMINUM_ROBOT_LWH_M[2]


def _tri_moments(poly: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """Area, centroid and central second moments (Syy, Szz, Syz) of a simple polygon by a signed triangle fan.

    Each triangle (origin, p_i, p_i+1) contributes its signed area, its centroid and its own
    second moments (vertex formula); the totals are moved to the centroid by the parallel-axis
    theorem. Independent of tumblemc's Green's-theorem integrals.
    """
    A = cy = cz = syy = szz = syz = 0.0
    n = len(poly)
    for i in range(n):
        a = np.zeros(2)
        b, c = poly[i], poly[(i + 1) % n]
        ar = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
        g = (a + b + c) / 3
        ys, zs = np.array([a[0], b[0], c[0]]), np.array([a[1], b[1], c[1]])
        # second moments of a triangle about the origin: A/6 (sum x_i^2 + sum_{i<j} x_i x_j)
        myy = ar / 6 * (ys @ ys + ys[0] * ys[1] + ys[1] * ys[2] + ys[2] * ys[0])
        mzz = ar / 6 * (zs @ zs + zs[0] * zs[1] + zs[1] * zs[2] + zs[2] * zs[0])
        myz = ar / 12 * (2 * ys @ zs + ys[0] * zs[1] + ys[1] * zs[0] + ys[1] * zs[2] + ys[2] * zs[1] + ys[2] * zs[0] + ys[0] * zs[2])
        A += ar
        cy += ar * g[0]
        cz += ar * g[1]
        syy += myy
        szz += mzz
        syz += myz
    cy, cz = cy / A, cz / A
    return abs(A), cy, cz, syy / A - cy * cy, szz / A - cz * cz, syz / A - cy * cz


def _inertia_from_polygon(poly: np.ndarray, thickness: float, mass: float) -> np.ndarray:
    _, _, _, yy, zz, yz = _tri_moments(poly)
    t2 = thickness**2 / 12
    return mass * np.array([[yy + zz, 0, 0], [0, t2 + zz, -yz], [0, -yz, t2 + yy]])


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("preset", ["paper", "aluminum"])
@pytest.mark.parametrize("dims", [{}, {"length": 600 * UM, "width": 250 * UM, "height": 180 * UM}])
def test_cuboid_mass_and_inertia_closed_form(preset: str, dims: dict) -> None:
    d = build("cuboid", dims, preset, "density")
    L, W, H = (dims or {}).get("length", 800 * UM), (dims or {}).get("width", 400 * UM), (dims or {}).get("height", 100 * UM)
    rho = PRESETS[preset].mass / CUBOID_V
    m = rho * L * W * H
    assert d.mass == pytest.approx(m, rel=1e-12)
    want = m / 12 * np.diag([L**2 + H**2, W**2 + H**2, W**2 + L**2])
    assert _rel(d.shape.inertia(d.mass), want) < 1e-9
    assert d.V_m == pytest.approx(PRESETS[preset].V_m * L * W * H / CUBOID_V, rel=1e-12)


POLY_CASES = [
    ("spiked", {}),
    ("spiked", {"spike_base": 350 * UM, "apex_z": 500 * UM, "bar_height": 120 * UM}),
    ("spiked_ends", {}),
    ("spiked_ends", {"spike_base": 400 * UM, "spike_height": 400 * UM}),  # the spikes of a side meet at mid-length
    ("spiked_ends", {"spike_base": 50 * UM, "spike_height": 50 * UM, "thickness": 200 * UM}),
]


@pytest.mark.parametrize(("family", "dims"), POLY_CASES)
def test_polygon_families_against_a_triangle_fan(family: str, dims: dict) -> None:
    fam = get_family(family)
    d = build(family, dims, "aluminum", "density")
    full = fam.dims(dims)
    assert fam.profile is not None
    poly = fam.profile(**full)
    area = _tri_moments(poly)[0]
    t = full["thickness"]
    rho = PRESETS["aluminum"].mass / CUBOID_V
    assert d.mass == pytest.approx(rho * area * t, rel=1e-9)
    assert _rel(d.shape.inertia(d.mass), _inertia_from_polygon(poly, t, d.mass)) < 1e-9


def _curved_polygon(r_outer: float, r_inner: float, half_angle_deg: float, n: int) -> np.ndarray:
    a = math.radians(half_angle_deg)
    th = np.linspace(-a, a, n + 1)
    outer = np.column_stack([r_outer * np.sin(th), r_outer * np.cos(th)])
    inner = np.column_stack([r_inner * np.sin(th[::-1]), r_inner * np.cos(th[::-1])])
    return np.vstack([outer, inner])


@pytest.mark.parametrize("dims", [{}, {"r_outer": 1500 * UM, "r_inner": 1000 * UM, "half_angle_deg": 40.0}])
def test_curved_against_refined_polygons(dims: dict) -> None:
    """The arcs' exact integrals against polygons of n and 2n segments, Richardson-extrapolated (error O(n^-4))."""
    fam = get_family("curved")
    full = fam.dims(dims)
    d = build("curved", dims, "aluminum", "density")
    est = []
    for n in (2000, 4000):
        poly = _curved_polygon(full["r_outer"], full["r_inner"], full["half_angle_deg"], n)
        area = _tri_moments(poly)[0]
        est.append((area, _inertia_from_polygon(poly, full["thickness"], 1.0)))
    area = (4 * est[1][0] - est[0][0]) / 3
    ipm = (4 * est[1][1] - est[0][1]) / 3
    rho = PRESETS["aluminum"].mass / CUBOID_V
    assert d.mass == pytest.approx(rho * area * full["thickness"], rel=1e-9)
    assert _rel(d.shape.inertia_per_mass, ipm) < 1e-9


def test_ends_rule_magnetises_only_the_ends() -> None:
    # the preset cuboid: its ends are the reference, so V_mag = V_m
    c = build("cuboid", {}, "aluminum", "ends")
    assert c.V_m == pytest.approx(PRESETS["aluminum"].V_m, rel=1e-12)
    # a longer cuboid has the same ends: the same magnetic volume, more mass
    long = build("cuboid", {"length": 1200 * UM}, "aluminum", "ends")
    assert long.V_m == pytest.approx(PRESETS["aluminum"].V_m, rel=1e-12)
    assert long.mass == pytest.approx(1.5 * c.mass, rel=1e-12)
    # spiked ends: the corner spikes lie in the ends, so they add magnetic volume
    se = build("spiked_ends", {}, "aluminum", "ends")
    fam = get_family("spiked_ends")
    assert fam.profile is not None
    prof = fam.profile(**fam.dims({}))
    ends = ends_area(prof, 800 * UM)
    # 2 ends of 200 x 150 um plus four spikes of base 100 and height 125
    assert ends == pytest.approx(2 * END_LENGTH_M * 150 * UM + 4 * 0.5 * 100 * UM * 125 * UM, rel=1e-12)
    assert se.V_m == pytest.approx(PRESETS["aluminum"].V_m * ends * 300 * UM / (2 * END_LENGTH_M * 100 * UM * 400 * UM), rel=1e-12)
    with pytest.raises(ValueError, match="needs a polygon profile"):
        build("curved", {}, "aluminum", "ends")


@pytest.mark.parametrize("name", ["cuboid", "spiked", "spiked_ends", "curved"])
def test_named_shapes_bit_for_bit_under_the_fixed_rule(name: str) -> None:
    for preset in ("paper", "aluminum"):
        d = build(name, {}, preset, "fixed")
        kw = {"preset": preset, "incline_deg": 20.0, "duration_s": 0.3}
        a = tumblemc.simulate(shape=name, **kw)
        b = tumblemc.simulate(shape=d.shape, **kw, **d.overrides())
        for v in a.data_vars:
            assert np.array_equal(a[v].values, b[v].values, equal_nan=True), (name, preset, v)


@pytest.mark.parametrize(
    ("family", "dims", "words"),
    [
        ("spiked_ends", {"spike_base": 500 * UM}, ["spike_base", "overlap"]),
        ("spiked", {"spike_base": 900 * UM}, ["spike_base", "length"]),
        ("curved", {"r_inner": 1300 * UM}, ["r_inner", "r_outer"]),
        ("cuboid", {"height": 0.5}, ["height", "out of range"]),
        ("cuboid", {"depth": 1e-4}, ["depth", "not a dimension", "length, width, height"]),
        ("hexagon", {}, ["hexagon", "unknown"]),
    ],
)
def test_unbuildable_designs_are_refused_with_the_reason(family: str, dims: dict, words: list[str]) -> None:
    with pytest.raises(ValueError) as e:
        build(family, dims)
    for w in words:
        assert w in str(e.value)


def test_a_user_profile_family() -> None:
    def trapezoid(base: float, top: float, height: float, thickness: float) -> np.ndarray:
        return np.array([(-base / 2, -height / 2), (base / 2, -height / 2), (top / 2, height / 2), (-top / 2, height / 2)])

    fam = profile_family("trapezoid", trapezoid, {"base": 800 * UM, "top": 500 * UM, "height": 150 * UM, "thickness": 300 * UM})
    d = build(fam, {"top": 300 * UM}, "aluminum", "density")
    poly = trapezoid(800 * UM, 300 * UM, 150 * UM, 300 * UM)
    assert _rel(d.shape.inertia(d.mass), _inertia_from_polygon(poly, 300 * UM, d.mass)) < 1e-9
    assert "trapezoid" not in FAMILIES  # only register_family adds it
    bow = profile_family("bow", lambda w, thickness: np.array([(0, 0), (w, w), (w, 0), (0, w)]), {"w": 1e-4, "thickness": 1e-4})
    with pytest.raises(ValueError, match="self-intersecting|cannot be built"):
        build(bow, {}, "aluminum")
