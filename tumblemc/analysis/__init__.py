"""Analyses of study results: pure functions of Datasets that never run a simulation.

Maps and intervals, critical-incline curves, Sobol estimators, screening, PRIM.
"""
