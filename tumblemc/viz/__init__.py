"""Figures and animations (viz layer): matplotlib's object API, no pyplot state.

Modules: :mod:`~tumblemc.viz.run` (one run, the shape library), :mod:`~tumblemc.viz.study`
(a study's maps and runs), :mod:`~tumblemc.viz.sensitivity` (Sobol indices, success
against a parameter, PRIM), :mod:`~tumblemc.viz.animation` with
:mod:`~tumblemc.viz.scene` (animated side view of a run) and :mod:`~tumblemc.viz.style`
(the shared look). Viz reads Datasets from the layers below and never runs a simulation
itself, except through the functions it is handed.
"""
