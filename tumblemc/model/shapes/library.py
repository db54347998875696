"""The paper's four robot shapes (MODEL.md, "Shapes").

:func:`cuboid`, :func:`spiked`, :func:`spiked_ends` and :func:`curved`, the :data:`SHAPES`
registry and :func:`get_shape`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from tumblemc.model.shapes.profile import check_dim, cuboid_inertia, extruded
from tumblemc.model.shapes.types import ALUMINUM_ROBOT_LWH_M, MASS_MODELS, Constraint, Piece, Shape


def cuboid(length: float = 800e-6, width: float = 400e-6, height: float = 100e-6, *, mass_from: str = "profile") -> Shape:
    """The paper's cuboid robot (MODEL.md "Shapes"): L (y) x W (x) x H (z), in m.

    One piece with six half-spaces, all real faces: the big faces ``+-z`` adhere with
    ``L W``, the sides ``+-x`` with ``L H``, the ends ``+-y`` with ``W H``. Written out in
    closed form (``extruded`` of its rectangle gives the same constraints, areas and
    inertia; the tests check that). ``mass_from="aluminum_robot"``: the aluminum robot's
    inertia whatever the dimensions (the authors' design sweep; the same at the defaults).
    """
    if mass_from not in MASS_MODELS:
        raise ValueError(f"mass_from={mass_from!r} is not allowed (allowed: {', '.join(MASS_MODELS)})")
    for nm, v in (("length", length), ("width", width), ("height", height)):
        if not (np.isfinite(v) and 1e-6 <= v <= 1e-1):
            raise ValueError(f"{nm}={v!r} is out of range (allowed: 1e-6 to 1e-1 m; give SI metres)")
    hx, hy, hz = width / 2, length / 2, height / 2
    cons = (
        Constraint("plane", (1.0, 0.0, 0.0, hx), length * height, label="+x side"),
        Constraint("plane", (-1.0, 0.0, 0.0, hx), length * height, label="-x side"),
        Constraint("plane", (0.0, 1.0, 0.0, hy), width * height, label="+y end"),
        Constraint("plane", (0.0, -1.0, 0.0, hy), width * height, label="-y end"),
        Constraint("plane", (0.0, 0.0, 1.0, hz), length * width, label="+z face"),
        Constraint("plane", (0.0, 0.0, -1.0, hz), length * width, label="-z face"),
    )
    verts = np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    outline = np.array([[-hy, -hz], [hy, -hz], [hy, hz], [-hy, hz], [-hy, -hz]])
    ipm = cuboid_inertia(*((length, width, height) if mass_from == "profile" else ALUMINUM_ROBOT_LWH_M))
    return Shape("cuboid", (Piece(cons, verts),), outline, width, 2 * (length + height), ipm, mass_from, length * height)


def _relabel(shape: Shape, labels: dict[str, str]) -> Shape:
    """Replace generic face labels of a one-piece shape by descriptive ones."""
    (piece,) = shape.pieces
    cons = tuple(replace(c, label=labels.get(c.label, c.label)) for c in piece.constraints)
    return replace(shape, pieces=(replace(piece, constraints=cons),))


def spiked_profile(length: float, bar_height: float, spike_base: float, apex_z: float) -> list[tuple[float, float]]:
    """The spiked robot's profile (y, z), m: a bar with one triangular spike on each long side at mid-length."""
    hy, hz, hb = length / 2, bar_height / 2, spike_base / 2
    return [(-hy, -hz), (-hb, -hz), (0.0, -apex_z), (hb, -hz), (hy, -hz), (hy, hz), (hb, hz), (0.0, apex_z), (-hb, hz), (-hy, hz)]


def spiked_ends_profile(length: float, bar_height: float, spike_base: float, spike_height: float) -> list[tuple[float, float]]:
    """The spiked-ends robot's profile (y, z), m: a bar with four corner spikes, base flush with each end.

    With ``spike_base = length / 2`` the two spikes of a side meet at mid-length: one vertex there.
    """
    hy, hz, b = length / 2, bar_height / 2, spike_base
    az, ay = hz + spike_height, hy - b / 2
    prof = [
        (-hy, -hz),
        (-ay, -az),
        (-hy + b, -hz),
        (hy - b, -hz),
        (ay, -az),
        (hy, -hz),
        (hy, hz),
        (ay, az),
        (hy - b, hz),
        (-hy + b, hz),
        (-ay, az),
        (-hy, hz),
    ]
    if abs(2 * b - length) <= 1e-12 * length:
        prof[2], prof[8] = (0.0, -hz), (0.0, hz)
        prof = [p for k, p in enumerate(prof) if k not in (3, 9)]
    return prof


def spiked(
    length: float = 800e-6,
    bar_height: float = 150e-6,
    spike_base: float = 200e-6,
    apex_z: float = 325e-6,
    thickness: float = 300e-6,
    *,
    mass_from: str = "aluminum_robot",
) -> Shape:
    """Spiked robot (MODEL.md "Shapes").

    A bar ``length x bar_height`` with one triangular spike on each long side at mid-length
    (base ``spike_base``, apex at ``z = +-apex_z``), extruded by ``thickness`` (m). Inertia:
    see ``mass_from`` in :func:`extruded` (default: the aluminum robot's, as in the paper).

    Hull faces (defaults; normals in body (y, z); areas in um^2):

    ==========================  ===================  ========  ====================
    face                        outward normal       area      contact
    ==========================  ===================  ========  ====================
    +x side, -x side            (+-1 along x)        170000    real profile
    +y end, -y end              (+-1, 0)             45000     real, 150 x 300
    +z flank +y, +z flank -y    (+-0.530, 0.848)     141510    line: end corner to apex
    -z flank +y, -z flank -y    (+-0.530, -0.848)    141510    line: end corner to apex
    ==========================  ===================  ========  ====================

    Hull perimeter 2186.8 um. The robot starts standing on its +z spike apex.
    """
    for nm, val in (("length", length), ("bar_height", bar_height), ("spike_base", spike_base), ("apex_z", apex_z)):
        check_dim(nm, val)
    if not spike_base < length:
        raise ValueError(f"spike_base={spike_base!r} is not allowed (allowed: < length = {length!r} m)")
    if not apex_z > bar_height / 2:
        raise ValueError(f"apex_z={apex_z!r} is not allowed (allowed: > bar_height / 2 = {bar_height / 2!r} m)")
    prof = spiked_profile(length, bar_height, spike_base, apex_z)
    shp = extruded(prof, thickness, name="spiked", mass_from=mass_from)
    labels = {"+y face": "+y end", "-y face": "-y end", "+z bridge #1": "+z flank +y", "+z bridge #2": "+z flank -y"}
    labels |= {"-z bridge #1": "-z flank -y", "-z bridge #2": "-z flank +y"}
    return _relabel(shp, labels)


def spiked_ends(
    length: float = 800e-6,
    bar_height: float = 150e-6,
    spike_base: float = 100e-6,
    spike_height: float = 125e-6,
    thickness: float = 300e-6,
    *,
    mass_from: str = "aluminum_robot",
) -> Shape:
    """Spiked-ends robot (MODEL.md "Shapes").

    A bar ``length x bar_height`` with four triangular corner spikes (base ``spike_base``
    flush with each end, height ``spike_height``, apex above the middle of the base),
    extruded by ``thickness`` (m). Inertia: see ``mass_from`` in :func:`extruded` (default:
    the aluminum robot's).

    Hull faces (defaults; normals in body (y, z); areas in um^2):

    ========================  =====================  ========  =========================
    face                      outward normal         area      contact
    ========================  =====================  ========  =========================
    +x side, -x side          (+-1 along x)          145000    real profile
    +y end, -y end            (+-1, 0)               45000     real, 150 x 300
    four spike flanks         (+-0.928, +-0.371)     40389     real, 134.6 x 300
    +z bridge, -z bridge      (0, +-1)               210000    line: apex to apex (700)
    ========================  =====================  ========  =========================

    Hull perimeter 2238.5 um. The robot starts lying on its +z bridge (two apex lines).
    """
    for nm, val in (("length", length), ("bar_height", bar_height), ("spike_base", spike_base), ("spike_height", spike_height)):
        check_dim(nm, val)
    if not spike_base <= length / 2:
        raise ValueError(
            f"spike_base={spike_base!r} is not allowed: the spikes of one side would overlap (allowed: <= length / 2 = {length / 2!r} m)"
        )
    prof = spiked_ends_profile(length, bar_height, spike_base, spike_height)
    shp = extruded(prof, thickness, name="spiked_ends", mass_from=mass_from)
    labels = {"+y face #1": "+y flank -z", "+y face #2": "+y end", "+y face #3": "+y flank +z"}
    labels |= {"-y face #1": "-y flank +z", "-y face #2": "-y end", "-y face #3": "-y flank -z"}
    return _relabel(shp, labels)


def curved(
    r_outer: float = 1250e-6,
    r_inner: float = 1100e-6,
    half_angle_deg: float = 25.0,
    thickness: float = 400e-6,
    *,
    mass_from: str = "aluminum_robot",
) -> Shape:
    """Curved robot (MODEL.md "Shapes").

    An annular sector of radii ``r_outer`` and ``r_inner`` (m) and half-angle
    ``half_angle_deg``, extruded by ``thickness``, its centre of curvature on the body z
    axis below the CM, so that the outer arc bulges toward +z and the robot starts lying on
    it. Inertia: see ``mass_from`` in :func:`extruded` (default: the aluminum robot's).

    Hull faces (defaults; normals in body (y, z); areas in um^2):

    ======================  ======================  ========  ============================
    face                    outward normal          area      contact
    ======================  ======================  ========  ============================
    +x side, -x side        (+-1 along x)           153807    real profile
    +y end, -y end          (+-0.906, -0.423)       60000     real radial faces, 150 x 400
    +z arc (cylinder_x)     radial, (0, 1) at top   436332    line: real outer arc
    -z chord                (0, -1)                 371904    line: chord of the inner arc
    ======================  ======================  ========  ============================

    The centre of curvature is at body ``z = -1139.6`` um (``cm_shift``); hull perimeter
    2320.6 um (arc 1090.8 + chord 929.8 + ends 2 x 150).
    """
    for nm, val in (("r_outer", r_outer), ("r_inner", r_inner)):
        check_dim(nm, val)
    if not r_inner < r_outer:
        raise ValueError(f"r_inner={r_inner!r} is not allowed (allowed: < r_outer = {r_outer!r} m)")
    if isinstance(half_angle_deg, bool) or not isinstance(half_angle_deg, (int, float)) or not 0.0 < half_angle_deg < 90.0:
        raise ValueError(f"half_angle_deg={half_angle_deg!r} is not allowed (allowed: 0 < half_angle_deg < 90)")
    a = math.radians(half_angle_deg)
    s, c = math.sin(a), math.cos(a)
    # centre of curvature at the origin here; extruded re-centres at the centroid
    prof = [(-r_inner * s, r_inner * c), (r_inner * s, r_inner * c), (r_outer * s, r_outer * c), (-r_outer * s, r_outer * c)]
    shp = extruded(prof, thickness, arcs={0: -r_inner, 2: r_outer}, name="curved", mass_from=mass_from)
    return _relabel(shp, {"+y face": "+y end", "-y face": "-y end", "+z arc": "+z outer arc", "-z bridge": "-z inner chord"})


SHAPES: dict[str, Callable[[], Shape]] = {"cuboid": cuboid, "spiked": spiked, "spiked_ends": spiked_ends, "curved": curved}


def get_shape(shape: str | Shape) -> Shape:
    """A shape by name (its defaults) from :data:`SHAPES`, or the Shape itself."""
    if isinstance(shape, Shape):
        return shape
    if shape not in SHAPES:
        raise ValueError(f"shape={shape!r} is unknown (allowed: {', '.join(sorted(SHAPES))})")
    return SHAPES[shape]()
