"""Robust design search: robot families as functions of their dimensions, and the search for the best one.

:mod:`.families` (shapes, mass and magnetic volume from dimensions), :mod:`.config` (the
design TOML), :mod:`.evaluate` (common random numbers, estimates), :mod:`.strategies`
(proposals, the model's best), :mod:`.search` (the resumable loop), :mod:`.result` (the
netCDF file, Pareto set, hypervolume), :mod:`.sweep` (the authors' sweep repeated).
"""

from tumblemc.design.families import FAMILIES, build, get_family, profile_family

__all__ = ["FAMILIES", "build", "get_family", "profile_family"]
