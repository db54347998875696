"""Scaled units of the kernels (MODEL.md, "Numerics that matter").

SI magnitudes of this problem span ~16 orders (inertia ~1e-14 kg m^2, impulses ~1e-10 N s),
so the kernels work in units where the step's unknowns are O(1):

- length ``LENGTH = 1e-4 m`` (the cuboid's height; shapes are given in micrometres),
- mass: the robot's mass ``m``,
- time ``sqrt(LENGTH / g)`` (about 3.2 ms),

so that the weight ``m g`` is the force unit. ``e_r`` (a length) is scaled with the
length unit. Results are converted back to SI at the API boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

LENGTH_M = 1e-4


@dataclass(frozen=True)
class Units:
    """Conversion factors from scaled to SI units for one robot (mass) and gravity."""

    mass: float  # kg
    g: float = 9.81  # m/s^2
    length: float = LENGTH_M  # m

    @property
    def time(self) -> float:
        """Time unit, s."""
        return math.sqrt(self.length / self.g)

    @property
    def velocity(self) -> float:
        """Velocity unit, m/s."""
        return self.length / self.time

    @property
    def force(self) -> float:
        """Force unit (the weight), N."""
        return self.mass * self.g

    @property
    def torque(self) -> float:
        """Torque unit (weight x length), N m."""
        return self.force * self.length

    @property
    def energy(self) -> float:
        """Energy unit (weight x length), J."""
        return self.force * self.length

    @property
    def inertia(self) -> float:
        """Moment of inertia unit, kg m^2."""
        return self.mass * self.length**2

    @property
    def area(self) -> float:
        """Area unit, m^2."""
        return self.length**2
