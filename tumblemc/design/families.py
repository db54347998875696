"""Design families: robot shapes as functions of their dimensions (MODEL.md, "Designs").

A :class:`Family` builds a :class:`~tumblemc.model.shapes.types.Shape` from named
dimensions (m) and says which of them it has; :func:`build` turns a family, its
dimensions, a substrate preset and a mass rule into a :class:`Design`: the shape and the
``mass`` and ``V_m`` the run must use.

Mass rules (:data:`MASS_RULES`):

- ``"density"`` (default): uniform density ``rho = m / (L W H)`` of the preset's cuboid
  (0.8 x 0.4 x 0.1 mm; paper 5.02e3, aluminum robot 2.17e3 kg/m^3); mass ``rho x volume``,
  inertia integrated over the extruded profile (exact polygon and circular-segment
  integrals, :func:`tumblemc.model.shapes.profile.extruded`); magnetic volume
  ``V_m x volume / cuboid volume`` (the magnetised share of the body kept).
- ``"ends"``: mass and inertia as ``"density"``; only the end segments are magnetised, as
  the paper's robots are built (two NdFeB-doped SU-8 ends, a plain middle): the part of
  the body with ``|y| >= length / 2 - end_length`` (``end_length`` = 200 um, a quarter of
  the preset cuboid's length), ``V_mag = V_m x ends volume / the preset cuboid's ends
  volume``. Polygon profiles only (the curved family is refused).
- ``"fixed"``: the authors' design sweep: mass, inertia and magnetic volume of the preset's
  robot whatever the dimensions (only the contact hull changes). The named shapes at their
  default dimensions are then today's shapes, bit for bit.

A design that cannot be built (spikes longer than the body allows, radii out of order, a
self-intersecting profile) raises ``ValueError`` with the reason, from the shape library.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tumblemc.model.params import get_preset
from tumblemc.model.shapes.library import cuboid, curved, spiked, spiked_ends, spiked_ends_profile, spiked_profile
from tumblemc.model.shapes.profile import extruded
from tumblemc.model.shapes.types import ALUMINUM_ROBOT_LWH_M, Shape

MASS_RULES = ("density", "ends", "fixed")
#: the magnetised end segments of the ``"ends"`` rule, m (a quarter of the preset cuboid's length)
END_LENGTH_M = 200e-6
_CUBOID_VOLUME = ALUMINUM_ROBOT_LWH_M[0] * ALUMINUM_ROBOT_LWH_M[1] * ALUMINUM_ROBOT_LWH_M[2]


@dataclass(frozen=True)
class Family:
    """A parametrised shape.

    name : the family's name (``family = "..."`` in a design file).
    defaults : every dimension (m, or degree for ``*_deg``) and its default, in the
        builder's keyword order; the defaults are the paper's shape.
    builder : ``builder(mass_from=..., **dims) -> Shape``.
    profile : ``profile(**dims) -> (N, 2)`` polygon (y, z) of the body, m, for the
        ``"ends"`` rule (None: no polygon profile, the rule is refused).
    """

    name: str
    defaults: Mapping[str, float]
    builder: Callable[..., Shape]
    profile: Callable[..., np.ndarray] | None = None

    def unit(self, var: str) -> str:
        """The unit of dimension ``var``: ``"degree"`` or ``"m"``."""
        return "degree" if var.endswith("_deg") else "m"

    def dims(self, values: Mapping[str, float]) -> dict[str, float]:
        """The defaults with ``values`` in place; an unknown name is refused with the known ones."""
        unknown = sorted(set(values) - set(self.defaults))
        if unknown:
            raise ValueError(f"{unknown[0]!r} is not a dimension of the {self.name} family (allowed: {', '.join(self.defaults)})")
        return {k: float(values.get(k, v)) for k, v in self.defaults.items()}


def _spiked_ends_profile(length: float, bar_height: float, spike_base: float, spike_height: float, thickness: float) -> np.ndarray:
    return np.array(spiked_ends_profile(length, bar_height, spike_base, spike_height))


def _spiked_profile(length: float, bar_height: float, spike_base: float, apex_z: float, thickness: float) -> np.ndarray:
    return np.array(spiked_profile(length, bar_height, spike_base, apex_z))


def _cuboid_profile(length: float, width: float, height: float) -> np.ndarray:
    return np.array([(-length / 2, -height / 2), (length / 2, -height / 2), (length / 2, height / 2), (-length / 2, height / 2)])


FAMILIES: dict[str, Family] = {
    "cuboid": Family("cuboid", {"length": 800e-6, "width": 400e-6, "height": 100e-6}, cuboid, _cuboid_profile),
    "spiked": Family(
        "spiked",
        {"length": 800e-6, "bar_height": 150e-6, "spike_base": 200e-6, "apex_z": 325e-6, "thickness": 300e-6},
        spiked,
        _spiked_profile,
    ),
    "spiked_ends": Family(
        "spiked_ends",
        {"length": 800e-6, "bar_height": 150e-6, "spike_base": 100e-6, "spike_height": 125e-6, "thickness": 300e-6},
        spiked_ends,
        _spiked_ends_profile,
    ),
    "curved": Family(
        "curved",
        {"r_outer": 1250e-6, "r_inner": 1100e-6, "half_angle_deg": 25.0, "thickness": 400e-6},
        curved,
        None,
    ),
}


def register_family(family: Family) -> None:
    """Add a family (any parametrised extruded profile) under ``family.name``."""
    FAMILIES[family.name] = family


def profile_family(name: str, profile: Callable[..., Any], defaults: Mapping[str, float], thickness_var: str = "thickness") -> Family:
    """A family from a parametrised polygon ``profile(**dims) -> (N, 2)`` (y, z), m, extruded by ``dims[thickness_var]``."""
    if thickness_var not in defaults:
        raise ValueError(f"thickness_var={thickness_var!r} is not a dimension (allowed: {', '.join(defaults)})")

    def build(mass_from: str = "profile", **dims: float) -> Shape:
        return extruded(np.asarray(profile(**dims), dtype=float), dims[thickness_var], name=name, mass_from=mass_from)

    def prof(**dims: float) -> np.ndarray:
        return np.asarray(profile(**dims), dtype=float)

    return Family(name, dict(defaults), build, prof)


def get_family(name: str) -> Family:
    """The family called ``name``; an unknown one is refused with the known names."""
    if name not in FAMILIES:
        raise ValueError(f"family={name!r} is unknown (allowed: {', '.join(sorted(FAMILIES))})")
    return FAMILIES[name]


@dataclass(frozen=True)
class Design:
    """A buildable robot: its shape and the mass and magnetic volume its runs use (per preset)."""

    family: str
    dims: Mapping[str, float]
    shape: Shape
    mass: float
    V_m: float
    volume: float
    mass_rule: str

    def overrides(self) -> dict[str, float]:
        """``simulate`` keywords that follow from the design: ``mass`` and ``V_m``."""
        return {"mass": self.mass, "V_m": self.V_m}


def _polygon_area(p: np.ndarray) -> float:
    y, z = p[:, 0], p[:, 1]
    return 0.5 * abs(math.fsum(y * np.roll(z, -1) - np.roll(y, -1) * z))


def _clip(p: np.ndarray, sign: float, c: float) -> np.ndarray:
    """The part of polygon ``p`` with ``sign * y >= c`` (Sutherland-Hodgman on one half-plane)."""
    out: list[np.ndarray] = []
    n = len(p)
    for i in range(n):
        a, b = p[i], p[(i + 1) % n]
        da, db = sign * a[0] - c, sign * b[0] - c
        if da >= 0:
            out.append(a)
        if (da >= 0) != (db >= 0):
            out.append(a + (b - a) * (da / (da - db)))
    return np.array(out) if len(out) >= 3 else np.zeros((0, 2))


def ends_area(profile: np.ndarray, length: float, end_length: float = END_LENGTH_M) -> float:
    """Area of the profile's end segments ``|y| >= length / 2 - end_length`` (profile centred on y = 0), m^2."""
    c = length / 2 - end_length
    return sum(_polygon_area(q) for q in (_clip(profile, 1.0, c), _clip(profile, -1.0, c)) if len(q))


def _extent_y(profile: np.ndarray) -> float:
    return float(np.ptp(profile[:, 0]))


def build(family: str | Family, dims: Mapping[str, float] | None = None, preset: str = "aluminum", mass_rule: str = "density") -> Design:
    """A design of ``family`` at ``dims`` (missing ones at their defaults) for substrate ``preset``.

    Raises ValueError naming the dimension and the reason when the design cannot be built,
    and for an unknown family, dimension or mass rule.
    """
    fam = family if isinstance(family, Family) else get_family(family)
    if mass_rule not in MASS_RULES:
        raise ValueError(f"mass_rule={mass_rule!r} is unknown (allowed: {', '.join(MASS_RULES)})")
    d = fam.dims(dims or {})
    p = get_preset(preset)
    try:
        shape = fam.builder(mass_from="aluminum_robot" if mass_rule == "fixed" else "profile", **d)
    except ValueError as e:
        raise ValueError(f"the {fam.name} design {_fmt(d)} cannot be built: {e}") from None
    volume = shape.profile_area * shape.thickness
    if mass_rule == "fixed":
        return Design(fam.name, d, shape, p.mass, p.V_m, volume, mass_rule)
    rho = p.mass / _CUBOID_VOLUME
    mass = rho * volume
    if mass_rule == "density":
        vm = p.V_m * volume / _CUBOID_VOLUME
    else:
        if fam.profile is None:
            raise ValueError(f"mass_rule='ends' needs a polygon profile; the {fam.name} family has none (allowed: density, fixed)")
        prof = fam.profile(**d)
        prof = prof - np.array([0.5 * (prof[:, 0].max() + prof[:, 0].min()), 0.0])
        ref = ALUMINUM_ROBOT_LWH_M
        ref_ends = 2 * END_LENGTH_M * ref[2] * ref[1]
        vm = p.V_m * ends_area(prof, _extent_y(prof)) * shape.thickness / ref_ends
    return Design(fam.name, d, shape, mass, vm, volume, mass_rule)


def _fmt(d: Mapping[str, float]) -> str:
    return "(" + ", ".join(f"{k}={v * 1e6:.4g} um" if not k.endswith("_deg") else f"{k}={v:.4g}" for k, v in d.items()) + ")"


__all__ = [
    "END_LENGTH_M",
    "FAMILIES",
    "MASS_RULES",
    "Design",
    "Family",
    "build",
    "ends_area",
    "get_family",
    "profile_family",
    "register_family",
]
