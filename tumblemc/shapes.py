"""Robot shapes as data: unions of convex pieces, each an intersection of smooth convex
constraints in body coordinates, with the adhering area of each face.

Body frame: x = width (the rotation axis of tumbling), y = length, z = height, origin at
the centre of mass. Contact with a plane only touches a piece's convex hull, so a piece is
its hull; each hull constraint carries the area of real material that touches the plane
when that face alone is down, and whether that contact is a line contact (a curved face,
or a hull face that only bridges edges of the body).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels import layout as L
from .kernels.stepper import Geometry
from .units import LENGTH_M

KINDS = {"plane": L.C_PLANE, "cylinder_x": L.C_CYL_X}


@dataclass(frozen=True)
class Constraint:
    """One smooth convex constraint ``f(y) <= 0`` of a piece (SI).

    kind : ``"plane"`` with ``data = (nx, ny, nz, d)``, ``f = n.y - d`` (|n| = 1, d in m),
        or ``"cylinder_x"`` with ``data = (cy, cz, R, 0)`` (m): a cylinder along body x.
    area : adhering area (m^2) when this face alone touches the plane.
    line : True if this face alone touching the plane is line contact.
    label : a name for plots and docs.
    """

    kind: str
    data: tuple[float, float, float, float]
    area: float
    line: bool = False
    label: str = ""


@dataclass(frozen=True)
class Piece:
    """A convex piece: its constraints and points bounding it from below.

    support_points : (P, 3) array, m. For a polytope, its vertices (``support_pad = 0``);
        for curved faces, sampled points with ``support_pad`` >= the sampling sagitta, so
        that ``min_p n.p - pad`` never overestimates the piece's lowest point.
    """

    constraints: tuple[Constraint, ...]
    support_points: np.ndarray
    support_pad: float = 0.0


@dataclass(frozen=True)
class Shape:
    """A robot shape.

    name : identifier used by ``simulate(shape=...)``.
    pieces : convex pieces (each with its own contact block in the time-stepper).
    outline : (N, 2) closed polygon of the body outline in the y-z plane, m (plots).
    thickness : extent along x, m.
    hull_perimeter : perimeter of the convex hull of the y-z profile, m; the no-slip
        distance per field revolution.
    inertia_per_mass : 3x3 body inertia about the CM divided by the mass, m^2.
    """

    name: str
    pieces: tuple[Piece, ...]
    outline: np.ndarray
    thickness: float
    hull_perimeter: float
    inertia_per_mass: np.ndarray

    def inertia(self, mass: float) -> np.ndarray:
        """Body-frame inertia about the CM, kg m^2."""
        return mass * self.inertia_per_mass

    def rest_height(self) -> float:
        """CM height above the plane when lying with body +z along -n (MODEL.md)."""
        return max(float(np.max(p.support_points[:, 2])) + p.support_pad for p in self.pieces)

    def rest_face_area(self, line_contact_fraction: float) -> float:
        """Adhering area (m^2) in the initial pose, lying with body +z along -n: the
        constraints of the lowest piece(s) whose outward normal is body +z at the rest
        height, with the same rule as the time-stepper (one flat face: its area; otherwise
        ``line_contact_fraction`` x the smallest)."""
        h = self.rest_height()
        total = 0.0
        for p in self.pieces:
            if float(np.max(p.support_points[:, 2])) + p.support_pad < h - 1e-12:
                continue
            down = [c for c in p.constraints if c.kind == "plane" and abs(c.data[2] - 1.0) < 1e-9 and abs(c.data[3] - h) < 1e-12]
            if len(down) == 1 and not down[0].line:
                total += down[0].area
            elif down:
                total += line_contact_fraction * min(c.area for c in down)
        return total

    def geometry(self) -> Geometry:
        """Kernel arrays in scaled units (length unit ``tumblemc.units.LENGTH_M``)."""
        cons = [c for p in self.pieces for c in p.constraints]
        ctype = np.array([KINDS[c.kind] for c in cons], dtype=np.int64)
        cdata = np.zeros((len(cons), 4))
        for i, c in enumerate(cons):
            d = np.asarray(c.data, dtype=float)
            if c.kind == "plane":
                cdata[i] = [d[0], d[1], d[2], d[3] / LENGTH_M]
            else:
                cdata[i] = [d[0] / LENGTH_M, d[1] / LENGTH_M, d[2] / LENGTH_M, 0.0]
        carea = np.array([c.area for c in cons]) / LENGTH_M**2
        cline = np.array([int(c.line) for c in cons], dtype=np.int64)
        pstart = np.cumsum([0] + [len(p.constraints) for p in self.pieces]).astype(np.int64)
        sup_pts = np.concatenate([p.support_points for p in self.pieces]) / LENGTH_M
        sup_start = np.cumsum([0] + [len(p.support_points) for p in self.pieces]).astype(np.int64)
        sup_pad = np.array([p.support_pad for p in self.pieces]) / LENGTH_M
        return Geometry(ctype, cdata, carea, cline, pstart, np.ascontiguousarray(sup_pts), sup_start, sup_pad)


def cuboid(length: float = 800e-6, width: float = 400e-6, height: float = 100e-6) -> Shape:
    """The paper's cuboid robot (MODEL.md "Shapes"): L (y) x W (x) x H (z), in m.

    One piece with six half-spaces, all real faces: the big faces ``+-z`` adhere with
    ``L W``, the sides ``+-x`` with ``L H``, the ends ``+-y`` with ``W H``.
    """
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
    ipm = np.diag([length**2 + height**2, width**2 + height**2, width**2 + length**2]) / 12.0
    return Shape("cuboid", (Piece(cons, verts),), outline, width, 2 * (length + height), ipm)


SHAPES = {"cuboid": cuboid}


def get_shape(shape: str | Shape) -> Shape:
    if isinstance(shape, Shape):
        return shape
    if shape not in SHAPES:
        raise ValueError(f"shape={shape!r} is unknown (allowed: {', '.join(sorted(SHAPES))})")
    return SHAPES[shape]()
