"""One adhesion rule for every shape (MODEL.md, "Forces").

Line contact adheres over a strip of width ``line_contact_width`` along the touching
segment, point contact over ``width^2``; the authors' cuboid rule stays as
``line_adhesion = "face_fraction"``.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumblemc
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.shapes.types import segment_lengths
from tumblemc.testing import SNAP_HOP, SNAP_HOP_DT

W = 5e-6  # the default line_contact_width
C = tumblemc.PRESETS["aluminum"].adhesion_C


def _by_label(name: str) -> dict[str, int]:
    return {c.label: i for i, c in enumerate(get_shape(name).pieces[0].constraints)}


def test_cuboid_edges_of_the_tumbling_gait_give_the_authors_values() -> None:
    """The edges along the width and the length: strip area == 0.05 x the smaller face's area."""
    sh = get_shape("cuboid")
    p = sh.pieces[0]
    _, ee = segment_lengths(p)
    areas = [c.area for c in p.constraints]
    checked = 0
    for i in range(len(areas)):
        for j in range(i + 1, len(areas)):
            if ee[i, j] in (400e-6, 800e-6):  # the edges the robot tumbles over and rolls onto
                strip = sh.line_area([p.constraints[i], p.constraints[j]], p, "strip", 0.05, W)
                assert strip == pytest.approx(0.05 * min(areas[i], areas[j]), rel=1e-12)
                checked += 1
    assert checked == 8


def test_segment_lengths_of_the_paper_shapes() -> None:
    """Straight edges where faces meet; a bridging hull face touches along its bridged corners."""
    ll, ee = segment_lengths(get_shape("spiked").pieces[0])
    lab = _by_label("spiked")
    assert ll[lab["+z flank +y"]] == pytest.approx(600e-6)  # end corner + apex, 300 um each
    assert ee[lab["+z flank +y"], lab["+z flank -y"]] == pytest.approx(300e-6)  # the apex line
    assert ee[lab["+z flank +y"], lab["+x side"]] == 0.0  # across the cap: two corners, points
    ll, ee = segment_lengths(get_shape("curved").pieces[0])
    assert max(ll) == pytest.approx(800e-6) and sorted(set(np.round(ll * 1e6, 6)))[1] == pytest.approx(400.0)


@pytest.mark.parametrize(
    ("shape", "strip", "face_fraction"),
    [
        ("cuboid", 0.32e-6, 0.32e-6),  # lies on its L x W face: face contact under both rules
        ("curved", W * 400e-6, 0.05 * 0.436e-6),  # rolls on its outer arc: the 5%-of-the-arc rule (MODEL.md, "Forces")
        ("spiked", W * 300e-6, None),  # on a spike apex line
        ("spiked_ends", W * 600e-6, None),  # the bridging face on two apex lines
    ],
)
def test_rest_area_under_both_rules(shape: str, strip: float, face_fraction: float | None) -> None:
    sh = get_shape(shape)
    assert sh.rest_face_area(0.05, "strip", W) == pytest.approx(strip, rel=1e-9)
    if face_fraction is not None:
        assert sh.rest_face_area(0.05, "face_fraction", W) == pytest.approx(face_fraction, rel=2e-3)


def test_kernel_area_matches_the_python_rule_on_the_rolling_arc() -> None:
    """The kernel's adhering area equals the Python rule's on the curved robot rocking on its arc.

    In line contact it is w l, l the arc's line (400 um) or an edge it shares, or w^2 at a
    point; with face_fraction, 5% of the arc face.
    """
    kw = {"shape": "curved", "preset": "aluminum", "incline_deg": 0.0, "duration_s": 1.0}
    strip = tumblemc.simulate(**kw)  # type: ignore[arg-type]
    mode = strip["contact_mode"].values
    area = strip["contact_area"].values[mode == 1]
    assert area.size > 0
    ll, ee = segment_lengths(get_shape("curved").pieces[0])
    allowed = {W * v for v in (*ll[ll > 0], *ee[ee > 0].ravel())} | {W * W}
    assert all(min(abs(a - b) / b for b in allowed) <= 1e-12 for a in area)
    assert np.isclose(area, W * 400e-6, rtol=1e-12).any()
    frac = tumblemc.simulate(line_adhesion="face_fraction", **kw)  # type: ignore[arg-type]
    a2 = frac["contact_area"].values[frac["contact_mode"].values == 1]
    assert np.isclose(a2, 0.05 * get_shape("curved").pieces[0].constraints[_by_label("curved")["+z outer arc"]].area, rtol=1e-12).any()


def test_vertex_contact_is_width_squared() -> None:
    sh = get_shape("cuboid")
    p = sh.pieces[0]
    corner = [c for c in p.constraints if c.label in ("+x side", "+y end", "+z face")] or list(p.constraints[:3])
    assert sh.line_area(corner[:3], p, "strip", 0.05, W) == W * W


def test_line_adhesion_is_validated() -> None:
    with pytest.raises(ValueError, match="line_adhesion"):
        tumblemc.simulate(line_adhesion="glue", duration_s=0.001)
    with pytest.raises(ValueError, match="line_contact_width"):
        tumblemc.simulate(line_contact_width=-1.0, duration_s=0.001)


def test_peel_release_costs_the_work_of_adhesion_and_lowers_the_snap_hop() -> None:
    """adhesion_release="peel" costs the work of adhesion.

    A released face's adhesion holds until it has done C x peel_length per released area, so
    the adhesion does more negative work and, with a long enough peel, the snap hop
    (``tumblemc.testing.SNAP_HOP``) is lower; the force law is the default.
    """
    kw = {**SNAP_HOP, "dt": SNAP_HOP_DT, "duration_s": 2.0, "record_every": 10}
    force = tumblemc.simulate(**kw)  # type: ignore[arg-type]
    peel = tumblemc.simulate(adhesion_release="peel", peel_length=1e-4, **kw)  # type: ignore[arg-type]
    assert force.attrs["adhesion_release"] == "force"
    assert float(peel["work_adhesion"][-1]) < float(force["work_adhesion"][-1])
    assert float(peel["position"][:, 2].max()) < 0.9 * float(force["position"][:, 2].max())
    assert peel.attrs["status"] == 0 and peel.attrs["contact_gain_ratio"] < 1e-3
    with pytest.raises(ValueError, match="adhesion_release"):
        tumblemc.simulate(adhesion_release="glue", duration_s=0.001)
