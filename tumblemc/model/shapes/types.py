"""Robot shapes as data.

A shape is a union of convex pieces, each an intersection of smooth convex constraints in
body coordinates, with the adhering area of each face.

Body frame: x = width or thickness (the rotation axis of tumbling), y = length,
z = height, origin at the centre of mass. The robot starts lying with body +z along -n,
pointing into the plane (MODEL.md, "Frames and state"). All lengths in metres.

Contact with a plane only touches a piece's convex hull, so a piece is its hull; each hull
constraint carries the area of real material that touches the plane when that face alone
is down, and whether that contact is a line contact (a curved face, or a hull face that
only bridges edges of the body).

Every shape of the library is one piece, a profile in the body y-z plane extruded along x
(:func:`extruded`). Rule for the adhering area of a hull face (MODEL.md, "Shapes"):

- a hull face that coincides with real flat faces of the profile adheres with the real
  part: ``overlap length x thickness``, ``line=False``;
- a hull face that only bridges (touches the real profile at vertices only) is a line
  contact, ``line=True``, with the nominal area ``hull edge length x thickness``;
- a convex outward arc on the hull is a ``cylinder_x`` constraint, ``line=True``, with its
  real area ``arc length x thickness``;
- the two thickness faces ``+-x`` are real: the profile's area, ``line=False``.

The time-stepper uses ``line_contact_fraction x area`` for a line contact (and for two or
more faces touching at once, the smallest of their areas), so the nominal area of a
bridging face only enters scaled by that fraction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tumblemc.kernels import layout as L
from tumblemc.kernels.geometry import Geometry
from tumblemc.model.units import LENGTH_M

KINDS = {"plane": L.C_PLANE, "cylinder_x": L.C_CYL_X}


#: how ``Shape.inertia_per_mass`` was obtained
MASS_MODELS = ("profile", "aluminum_robot")


#: allowed range of every dimension (m): anything outside is a unit mistake
MIN_DIM_M, MAX_DIM_M = 1e-6, 1e-1


#: default sampling sagitta of curved hull faces for the kernel's support points, m
ARC_TOL_M = 1e-8


#: angular step of arcs in the plotted outline
OUTLINE_STEP_RAD = math.radians(1.0)


#: most vertices of a profile (its checks compare all pairs of edges)
MAX_VERTICES = 2000


#: geometric tolerance of the hull construction, relative to the profile's size
REL_TOL = 1e-9


#: the aluminum robot (MODEL.md, Table 3): the paper's cuboid, 0.8 x 0.4 x 0.1 mm (L x W x H)
ALUMINUM_ROBOT_LWH_M = (800e-6, 400e-6, 100e-6)


#: body directions by which hull faces are grouped and ordered (the cuboid's order)
GROUPS = (("+y", (1.0, 0.0)), ("-y", (-1.0, 0.0)), ("+z", (0.0, 1.0)), ("-z", (0.0, -1.0)))


def cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """2-D cross product ``a_y b_z - a_z b_y`` of (..., 2) arrays (positive: ``b`` turns CCW from ``a``)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


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

    def value(self, p: np.ndarray) -> np.ndarray:
        """``f`` at body points ``p`` (..., 3), m."""
        p = np.asarray(p, dtype=float)
        d = self.data
        if self.kind == "plane":
            return p[..., 0] * d[0] + p[..., 1] * d[1] + p[..., 2] * d[2] - d[3]
        return np.hypot(p[..., 1] - d[0], p[..., 2] - d[1]) - d[2]


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
    mass_model : how ``inertia_per_mass`` was obtained: ``"profile"`` (uniform density
        over the extruded profile) or ``"aluminum_robot"`` (the 0.8 x 0.4 x 0.1 mm cuboid
        of the aluminum robot, MODEL.md: non-cuboid shapes keep its inertia).
    profile_area : area of the real y-z profile, m^2.
    cm_shift : (y, z) of the profile's area centroid in the coordinates the profile was
        given in, m: the body frame is the given one shifted by ``-cm_shift``.
    """

    name: str
    pieces: tuple[Piece, ...]
    outline: np.ndarray
    thickness: float
    hull_perimeter: float
    inertia_per_mass: np.ndarray
    mass_model: str = "profile"
    profile_area: float = math.nan
    cm_shift: tuple[float, float] = (0.0, 0.0)

    def inertia(self, mass: float) -> np.ndarray:
        """Body-frame inertia about the CM, kg m^2."""
        return mass * self.inertia_per_mass

    def mass(self, density: float) -> float:
        """Mass (kg) of the extruded profile at uniform ``density`` (kg/m^3).

        ``density x profile_area x thickness``. The simulated mass comes from the Params
        preset; this helps choose it for a new shape.
        """
        if (
            isinstance(density, bool)
            or not isinstance(density, (int, float, np.integer, np.floating))
            or not (math.isfinite(density) and density > 0)
        ):
            raise ValueError(f"density={density!r} is not allowed (allowed: a finite value > 0, kg/m^3)")
        if not math.isfinite(self.profile_area):
            raise ValueError(f"shape {self.name!r} has no profile_area, so its mass cannot be computed")
        return float(density) * self.profile_area * self.thickness

    def rest_height(self) -> float:
        """CM height above the plane when lying with body +z along -n (MODEL.md).

        The exact largest body z of the pieces (support points, and the top of any
        ``cylinder_x`` face whose top lies on the piece).
        """
        return max(_piece_top(p) for p in self.pieces)

    def rest_face_area(self, line_contact_fraction: float, rule: str = "face_fraction", width: float = 5e-6) -> float:
        """Adhering area (m^2) in the initial pose, lying with body +z along -n.

        With the time-stepper's rule: the faces of the lowest piece(s) whose outward normal
        is body +z at the rest height (one flat face: its area; one line face or several:
        line contact by :meth:`line_area`); if none (the piece stands on an edge along x),
        the constraints active on that edge, as line contact.
        """
        h = self.rest_height()
        total = 0.0
        for p in self.pieces:
            top = _piece_top(p)
            if top < h - 1e-12:
                continue
            down = [c for c in p.constraints if _touches_top(c, p, top)]
            if len(down) == 1 and not down[0].line:
                total += down[0].area
            elif down:
                total += self.line_area(down, p, rule, line_contact_fraction, width)
            else:
                pts = p.support_points[p.support_points[:, 2] >= top - 1e-12]
                centre = pts.mean(axis=0)
                active = [c for c in p.constraints if abs(float(c.value(centre))) <= 1e-12]
                if active:
                    total += self.line_area(active, p, rule, line_contact_fraction, width)
        return total

    def hull_faces(self) -> list[tuple[Constraint, np.ndarray]]:
        """Each hull face of the y-z profile (constraints not normal to x) with its polyline.

        The (K, 2) polyline is in the body y-z plane, m: the two end points of a flat face,
        the sampled points of a curved one (for plots).
        """
        out = []
        for p in self.pieces:
            pts = p.support_points
            top = pts[pts[:, 0] >= pts[:, 0].max() - 1e-12]
            size = float(np.ptp(top[:, 1:], axis=0).max())
            for c in p.constraints:
                if c.kind == "plane" and abs(c.data[0]) > 0.5:
                    continue
                on = top[np.abs(c.value(top)) <= REL_TOL * size + p.support_pad]
                yz = on[:, 1:]
                if len(yz) < 2:
                    continue
                if c.kind == "plane":
                    t = np.array([-c.data[2], c.data[1]])
                    s = yz @ t
                    yz = yz[[int(np.argmin(s)), int(np.argmax(s))]]
                else:  # by angle about the axis, measured from the middle direction
                    rel = yz - np.array(c.data[:2])
                    mid = rel.mean(axis=0)
                    yz = yz[np.argsort(np.arctan2(cross2(mid, rel), rel @ mid))]
                out.append((c, yz))
        return out

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
        cllen = np.zeros(len(cons))
        cedge = np.zeros((len(cons), len(cons)))
        for k, p in enumerate(self.pieces):
            ll, ee = segment_lengths(p)
            a, b = pstart[k], pstart[k + 1]
            cllen[a:b] = ll / LENGTH_M
            cedge[a:b, a:b] = ee / LENGTH_M
        return Geometry(ctype, cdata, carea, cline, pstart, np.ascontiguousarray(sup_pts), sup_start, sup_pad, cllen, cedge)

    def line_area(self, constraints: list[Constraint], piece: Piece, rule: str, fraction: float, width: float) -> float:
        """Adhering area (m^2) of the line or point contact of ``constraints`` of ``piece``.

        The time-stepper's rule (:func:`tumblemc.kernels.stepper._line_area`): ``"strip"``,
        ``width`` x the touching segment (:func:`segment_lengths`; ``width^2`` for a point),
        or ``"face_fraction"``, ``fraction`` x the smallest face area.
        """
        if rule == "face_fraction":
            return fraction * min(c.area for c in constraints)
        ll, ee = segment_lengths(piece)
        idx = [piece.constraints.index(c) for c in constraints]
        if len(idx) == 1:
            return width * float(ll[idx[0]])
        if len(idx) == 2 and ee[idx[0], idx[1]] > 0.0:
            return width * float(ee[idx[0], idx[1]])
        return width * width


def _piece_top(p: Piece) -> float:
    """Exact largest body z of a piece: its support points, or a cylinder's top on it."""
    top = float(np.max(p.support_points[:, 2]))
    for c in p.constraints:
        if c.kind == "cylinder_x":
            apex = np.array([0.0, c.data[0], c.data[1] + c.data[2]])
            if all(float(o.value(apex)) <= 1e-12 for o in p.constraints if o is not c):
                top = max(top, float(apex[2]))
    return top


def segment_lengths(p: Piece) -> tuple[np.ndarray, np.ndarray]:
    """Touching segments of a piece's line contacts (m), for the strip rule (MODEL.md, "Forces").

    Returns ``(ll, ee)``: ``ll[i]``, for a line constraint touching alone, the total length
    of the segments along x it touches with: the piece's x extent for a cylinder's line, and
    that extent times the number of profile vertices on a hull face that bridges edges;
    ``ee[i, j]`` the length of the straight edge two constraints share (the distance of the
    support points on both, if those lie on a line), 0 for a point, a curved edge (a
    cylinder's rim on an end cap), or a bridging hull face meeting an end cap (the segment
    spans the gap between the bridged corners: they touch at points).
    """
    pts = p.support_points
    size = float(np.ptp(pts, axis=0).max())
    tol = REL_TOL * size + p.support_pad + 1e-15
    m = len(p.constraints)
    on = np.array([np.abs(c.value(pts)) <= tol for c in p.constraints])
    x_extent = float(np.ptp(pts[:, 0]))
    ll = np.zeros(m)
    for i, c in enumerate(p.constraints):
        if not c.line:
            continue
        if c.kind == "cylinder_x":
            ll[i] = x_extent
        else:
            yz = np.unique(np.round(pts[on[i]][:, 1:] / max(size, 1e-300), 9), axis=0)
            ll[i] = x_extent * len(yz)
    ee = np.zeros((m, m))
    for i in range(m):
        for j in range(i + 1, m):
            bridging = any(c.line and c.kind == "plane" for c in (p.constraints[i], p.constraints[j]))
            both = pts[on[i] & on[j]]
            if len(both) < 2:
                continue
            d = both - both[0]
            far = d[int(np.argmax(np.linalg.norm(d, axis=1)))]
            length = float(np.linalg.norm(far))
            off_line = np.linalg.norm(d - np.outer(d @ far / length**2, far), axis=1) if length > 0 else d[:, 0]
            # a bridging hull face meets another face along real material only where the
            # segment runs along x (the extrusion of a hull vertex: an apex, an end corner);
            # across an end cap it spans the gap between the corners it bridges
            along_x = float(np.abs(far[1:]).max()) <= tol
            if length > 0 and float(np.max(off_line)) <= tol and (along_x or not bridging):
                ee[i, j] = ee[j, i] = length
    return ll, ee


def _touches_top(c: Constraint, p: Piece, top: float) -> bool:
    """Whether face ``c`` of piece ``p`` has outward normal +z where it reaches ``top``."""
    if c.kind == "plane":
        return abs(c.data[2] - 1.0) < 1e-9 and abs(c.data[3] - top) < 1e-12
    apex = np.array([0.0, c.data[0], c.data[1] + c.data[2]])
    return abs(float(apex[2]) - top) < 1e-12 and all(float(o.value(apex)) <= 1e-12 for o in p.constraints if o is not c)
