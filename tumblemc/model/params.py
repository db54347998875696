"""Physical parameters and presets (SI, validated, frozen); the solver's options are in :mod:`tumblemc.model.solver_options`.

Glossary (paper symbol -> name here; units SI unless the name says otherwise):

===================  ==========================  ==========================================
paper                tumblemc                    meaning
===================  ==========================  ==========================================
m                    ``mass``                    robot mass, kg
F_elect              ``F_elect``                 electrostatic force along -n, N
mu                   ``mu``                      friction coefficient
phi                  ``offset_deg``              magnetisation offset angle, degrees
(MODEL.md)           ``offset_axis``             body axis about which phi tilts E (x: width)
V_m                  ``V_m``                     magnetic volume, m^3
abs(E)               ``magnetization``           magnetisation, A/m
C                    ``adhesion_C``              adhesion per contact area, N/m^2
(MODEL.md)           ``line_contact_fraction``   adhering fraction of the smaller face's
                                                 area in point/line contact
e_t, e_o, e_r        ``e_t``, ``e_o``, ``e_r``   friction ellipsoid (e_r is a length, m)
g                    ``g``                       gravity, m/s^2
p_t, p_o, p_r, p_n   ``lam_* = p_* / h``         contact forces (kernels use forces)
a1, a2               ``a1``, ``a2``              equivalent contact points
sigma                ``sigma``                   slip-speed multiplier
l_i, l_s             ``l_i``, ``l_s``            normal-cone multipliers
===================  ==========================  ==========================================
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

_INF = math.inf
_POSITIVE = "> 0"


_NONNEG = ">= 0"
_ELLIPSOID = "ratios of the friction ellipsoid beyond 1e3 (or a radius beyond 10 m) make friction one-dimensional"


def check_number(name: str, value: Any, rule: str, lo: float | None = None, hi: float | None = None) -> float:
    """Validate a scalar: finite float satisfying ``rule``; raise ValueError naming it."""
    if isinstance(value, (bool, np.bool_, str, bytes)):  # "0.4" is not converted silently
        raise ValueError(f"{name}={value!r} is not a number (allowed: a finite value {rule})")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}={value!r} is not a number (allowed: a finite value {rule})") from None
    ok = math.isfinite(x)
    if ok and rule == _POSITIVE:
        ok = x > 0.0
    elif ok and rule == _NONNEG:
        ok = x >= 0.0
    if ok and lo is not None:
        ok = x >= lo
    if ok and hi is not None:
        ok = x <= hi
    if not ok:
        rng = rule if lo is None and hi is None else f"in [{lo}, {hi}]"
        raise ValueError(f"{name}={value!r} is out of range (allowed: a finite value {rng})")
    return x


@dataclass(frozen=True)
class PhysicalRange:
    """Allowed values of a parameter.

    Two tiers: the physical range ``lo``..``hi`` (``lo_open``: ``lo`` itself excluded), the
    domain of the physics and of a study's distributions (which are truncated to it); and
    inside it the *plausible* range ``plausible_lo``..``plausible_hi`` (closed), beyond
    which no microrobot lies and the solver's cost is not bounded; ``why`` says why, in the
    words of the error message. :meth:`check` enforces both.
    """

    lo: float
    hi: float
    lo_open: bool
    hi_open: bool
    units: str
    long_name: str
    plausible_lo: float = -_INF
    plausible_hi: float = _INF
    why: str = ""

    def describe(self) -> str:
        """Describe the range in words, for error messages (:func:`describe_interval`)."""
        return describe_interval(self.lo, self.hi, self.lo_open, self.hi_open)

    def describe_plausible(self) -> str:
        """The values :meth:`check` accepts, in words, with the units."""
        lo_open = self.lo_open and self.plausible_lo <= self.lo
        hi_open = self.hi_open and self.plausible_hi >= self.hi
        lo, hi = max(self.lo, self.plausible_lo), min(self.hi, self.plausible_hi)
        return describe_interval(lo, hi, lo_open, hi_open) + ("" if self.units == "1" else f" {self.units}")

    def contains(self, x: float) -> bool:
        """Whether ``x`` lies in the physical range."""
        above = x > self.lo if self.lo_open else x >= self.lo
        below = x < self.hi if self.hi_open else x <= self.hi
        return above and below

    def plausible(self, x: Any) -> Any:
        """Whether ``x`` (a number or an array) is finite, physical and plausible (elementwise)."""
        x = np.asarray(x, dtype=float)
        above = x > self.lo if self.lo_open else x >= self.lo
        below = x < self.hi if self.hi_open else x <= self.hi
        return np.isfinite(x) & above & below & (x >= self.plausible_lo) & (x <= self.plausible_hi)

    def implausible(self, name: str, value: Any) -> str:
        """The one-line message for a ``value`` of ``name`` outside the plausible range."""
        return f"{name}={value!r} is implausible (allowed: {self.describe_plausible()}; {self.why})"

    def check(self, name: str, value: Any) -> float:
        """Check ``value`` against the range.

        Returns
        -------
        float
            ``value`` as a float if it is a finite number in the range.

        Raises
        ------
        ValueError
            Otherwise, naming ``name``, the value and the range.
        """
        if isinstance(value, (bool, np.bool_, str, bytes)):  # "0.4" is not converted silently
            raise ValueError(f"{name}={value!r} is not a number (allowed: {self.describe()})")
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name}={value!r} is not a number (allowed: {self.describe()})") from None
        if not (math.isfinite(x) and self.contains(x)):
            raise ValueError(f"{name}={value!r} is out of range (allowed: {self.describe()})")
        if not self.plausible_lo <= x <= self.plausible_hi:
            raise ValueError(self.implausible(name, value))
        return x


#: THE range table: allowed values, units and description of every physical parameter
#: (:class:`Params`) and run input (:func:`tumblemc.model.run.run_inputs`). Params,
#: run_inputs, study configs and the samplers all check against it.
RANGES: dict[str, PhysicalRange] = {
    "mass": PhysicalRange(
        *(0.0, _INF, True, True, "kg", "robot mass", 1e-12, 1.0),
        "1e-12 kg is a 10 um cube of water and 1 kg no microrobot; lighter bodies make the contact solve stiff and slow",
    ),
    "F_elect": PhysicalRange(
        *(0.0, _INF, False, True, "N", "electrostatic force", 0.0, 1.0),
        "electroadhesion reaches about 10 kPa, so 1 N would need a face of 1 cm^2",
    ),
    "mu": PhysicalRange(
        *(0.0, _INF, False, True, "1", "friction coefficient", 0.0, 100.0),
        "dry friction coefficients lie below about 2; 100 already never slips",
    ),
    "offset_deg": PhysicalRange(-180.0, 180.0, False, False, "degree", "magnetisation offset angle"),
    "V_m": PhysicalRange(
        *(0.0, _INF, False, True, "m^3", "magnetic volume", 0.0, 1e-6),
        "a magnet of more than 1 cm^3 is not a microrobot's",
    ),
    "magnetization": PhysicalRange(
        *(0.0, _INF, False, True, "A/m", "magnetisation", 0.0, 2e6),
        "no material saturates above 1.95e6 A/m (FeCo; NdFeB 1.1e6)",
    ),
    "adhesion_C": PhysicalRange(
        *(0.0, _INF, False, True, "N/m^2", "adhesion per contact area", 0.0, 1e6),
        "1 MPa is ten times gecko setae, the strongest dry adhesion measured",
    ),
    "line_contact_fraction": PhysicalRange(0.0, 1.0, False, False, "1", "adhering fraction in point/line contact (face_fraction rule)"),
    "peel_length": PhysicalRange(0.0, 1e-3, False, False, "m", "separation over which a released face peels (peel release)"),
    "line_contact_width": PhysicalRange(0.0, 1e-3, False, False, "m", "width of the adhering strip of a line contact (strip rule)"),
    "e_t": PhysicalRange(0.0, _INF, True, True, "1", "friction ellipsoid e_t", 1e-3, 1e3, _ELLIPSOID),
    "e_o": PhysicalRange(0.0, _INF, True, True, "1", "friction ellipsoid e_o", 1e-3, 1e3, _ELLIPSOID),
    "e_r": PhysicalRange(0.0, _INF, True, True, "m", "friction ellipsoid e_r", 1e-9, 10.0, _ELLIPSOID),
    "g": PhysicalRange(
        *(0.0, _INF, True, True, "m/s^2", "gravity", 0.01, 1000.0),
        "from a small moon (0.01 m/s^2) to a bench centrifuge at 100 g",
    ),
    "field_mT": PhysicalRange(
        *(0.0, 10_000.0, False, False, "mT", "rotating field magnitude (0 switches the field off)", 0.0, 1000.0),
        "1 T is beyond any coil system that turns a field; microrobot rigs reach about 0.1 T",
    ),
    # run inputs (tumblemc.model.run.run_inputs); a study narrows the field and the
    # frequency to > 0, never widens a range
    "incline_deg": PhysicalRange(-89.0, 89.0, False, False, "degree", "substrate incline"),
    "freq_hz": PhysicalRange(0.0, 10_000.0, False, False, "Hz", "field rotation frequency"),
    "duration_s": PhysicalRange(0.0, 1e4, False, False, "s", "simulated time"),
    "periods": PhysicalRange(0.0, 1e6, True, False, "1", "simulated time in field periods"),
    "dt": PhysicalRange(1e-9, 0.1, False, False, "s", "time step"),
    # pointing error of a study's field axis (tumblemc.study.fieldcfg), nominal 0
    "axis_yaw_deg": PhysicalRange(-90.0, 90.0, False, False, "degree", "field axis turned about world z"),
    "axis_pitch_deg": PhysicalRange(-90.0, 90.0, False, False, "degree", "field axis tilted out of the horizontal plane"),
    "lift_m": PhysicalRange(0.0, 1.0, False, False, "m", "initial height above the resting pose"),
}


def describe_interval(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> str:
    """Describe the interval from ``lo`` to ``hi`` in words (``"a number in [0, 1)"``).

    Infinite bounds are left out; ``lo_open``/``hi_open`` exclude the bound itself.
    """
    if math.isinf(lo) and math.isinf(hi):
        return "a finite number"
    if math.isinf(hi):
        return f"a number {'>' if lo_open else '>='} {lo:g}"
    if math.isinf(lo):
        return f"a number {'<' if hi_open else '<='} {hi:g}"
    return f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def magnetisation_dir(offset_deg: float, offset_axis: Any = (1.0, 0.0, 0.0)) -> np.ndarray:
    """Unit body-frame magnetisation.

    The length axis tilted by ``offset_deg`` about the unit ``offset_axis`` (Rodrigues;
    MODEL.md: ``(0, cos phi, sin phi)`` for the width axis).
    """
    k = np.asarray(offset_axis, dtype=float).reshape(3)
    y = np.array([0.0, 1.0, 0.0])
    phi = math.radians(offset_deg)
    return y * math.cos(phi) + np.cross(k, y) * math.sin(phi) + k * (k @ y) * (1.0 - math.cos(phi))


#: the numeric fields of :class:`Params`, each checked against :data:`RANGES`; this order is
#: also the ``mc`` sampler's slot order (``study.distributions.UNCERTAIN_PARAMS``, which puts
#: ``field_mT`` after ``g``, before the later fields): append only
NUMERIC_FIELDS = (
    "mass",
    "F_elect",
    "mu",
    "offset_deg",
    "V_m",
    "magnetization",
    "adhesion_C",
    "line_contact_fraction",
    "e_t",
    "e_o",
    "e_r",
    "g",
    "line_contact_width",
    "peel_length",
)

#: how adhesion lets go of a released face: "force" (default, the paper's law: a force that
#: vanishes with the face) or "peel" (its adhesion holds until it has done the work
#: C x peel_length per released area)
ADHESION_RELEASE_OPTIONS = ("force", "peel")

#: the adhesion rules of line and point contact (MODEL.md, "Forces"): "strip" (default),
#: C x line_contact_width x the touching segment's length (x width^2 at a point), or
#: "face_fraction", the authors' cuboid rule line_contact_fraction x the smallest face area
LINE_ADHESION_OPTIONS = ("strip", "face_fraction")


@dataclass(frozen=True)
class Params:
    """Physical parameters of one robot on one substrate (paper Tables 1 and 3; SI).

    Every field can be overridden by name: ``PRESETS["paper"].replace(mu=0.4)`` or
    ``simulate(mu=0.4)``. Construction validates every field and raises ``ValueError``
    naming the field, the value and the allowed range.
    """

    mass: float
    F_elect: float
    mu: float
    offset_deg: float
    V_m: float
    magnetization: float
    adhesion_C: float
    line_contact_fraction: float = 0.05
    e_t: float = 1.0
    e_o: float = 1.0
    e_r: float = 0.1
    offset_axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    electrostatic_in_flight: bool = True
    g: float = 9.81
    line_contact_width: float = 5e-6
    line_adhesion: str = "strip"
    peel_length: float = 1e-5
    adhesion_release: str = "force"

    def __post_init__(self) -> None:
        for name in NUMERIC_FIELDS:
            object.__setattr__(self, name, RANGES[name].check(name, getattr(self, name)))
        axis = self.offset_axis
        try:
            a = np.asarray(axis, dtype=float).reshape(3)
        except (TypeError, ValueError):
            raise ValueError(f"offset_axis={axis!r} is not a 3-vector (allowed: a nonzero finite 3-vector in body axes)") from None
        if not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0.0:
            raise ValueError(f"offset_axis={axis!r} is not allowed (allowed: a nonzero finite 3-vector in body axes)")
        object.__setattr__(self, "offset_axis", tuple(float(v) for v in a / np.linalg.norm(a)))
        if not isinstance(self.electrostatic_in_flight, (bool, np.bool_)):
            raise ValueError(f"electrostatic_in_flight={self.electrostatic_in_flight!r} is not allowed (allowed: True or False)")
        if self.adhesion_release not in ADHESION_RELEASE_OPTIONS:
            allowed = ", ".join(map(repr, ADHESION_RELEASE_OPTIONS))
            raise ValueError(f"adhesion_release={self.adhesion_release!r} is not allowed (allowed: {allowed})")
        if self.line_adhesion not in LINE_ADHESION_OPTIONS:
            raise ValueError(
                f"line_adhesion={self.line_adhesion!r} is not allowed (allowed: {', '.join(map(repr, LINE_ADHESION_OPTIONS))})"
            )

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of all parameters, in field order."""
        return tuple(f.name for f in dataclasses.fields(cls))

    def replace(self, **overrides: Any) -> Params:
        """A copy with ``overrides`` applied; unknown names are a ValueError."""
        unknown = sorted(set(overrides) - set(self.field_names()))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown} (allowed: {', '.join(self.field_names())})")
        return dataclasses.replace(self, **overrides)

    def magnetisation_dir(self) -> np.ndarray:
        """Unit body-frame magnetisation (:func:`magnetisation_dir`)."""
        return magnetisation_dir(self.offset_deg, self.offset_axis)

    def as_attrs(self) -> dict[str, Any]:
        """Flat netCDF-friendly attributes (SI)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            out[f.name] = list(v) if isinstance(v, tuple) else (int(v) if isinstance(v, bool) else v)
        return out


PRESETS: dict[str, Params] = {
    # paper Table 1: original robot on paper
    "paper": Params(mass=1.6071e-7, F_elect=3.2022e-6, mu=0.3, offset_deg=27.0, V_m=2.9e-11, magnetization=15000.0, adhesion_C=3.7148),
    # paper Table 3: improved robot on aluminum
    "aluminum": Params(mass=6.94e-8, F_elect=0.0, mu=0.54, offset_deg=0.0, V_m=3.2e-11, magnetization=51835.0, adhesion_C=26.1771),
}


def get_preset(preset: str | Params) -> Params:
    """Return the :data:`PRESETS` entry named ``preset`` (a :class:`Params` is returned as is).

    Raises
    ------
    ValueError
        If ``preset`` is not a known preset name.
    """
    if isinstance(preset, Params):
        return preset
    if preset not in PRESETS:
        raise ValueError(f"preset={preset!r} is unknown (allowed: {', '.join(sorted(PRESETS))})")
    return PRESETS[preset]


def check_choice(name: str, value: Any, allowed: tuple[str, ...]) -> str:
    """``value`` if it is one of ``allowed``, else a ValueError naming it and the choices."""
    if value not in allowed:
        raise ValueError(f"{name}={value!r} is not allowed (allowed: {', '.join(allowed)})")
    return str(value)


def check_vector(name: str, vec: Any) -> tuple[float, float, float]:
    """``vec`` as a finite 3-tuple (SI, world frame), else a ValueError naming it."""
    try:
        arr = np.asarray(vec, dtype=float)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise ValueError(f"{name}={vec!r} is not allowed (allowed: a finite 3-vector, world frame, SI)")
    return (float(arr[0]), float(arr[1]), float(arr[2]))
