"""The time loop's records: the run's inputs, its solver memory and temporaries, and the
step frame (state, unknowns, touching flags, ledger and scalars) that snapshots copy."""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ._jit import jit
from .newton import make_workspace

Model = namedtuple("Model", ["prm", "geo"])
Model.__doc__ = """One robot on one substrate: its run constants ``prm`` (float64[N_PRM], ``P_*``) and
its :class:`Geometry`."""

Start = namedtuple("Start", ["state", "t0", "area0", "touch0"])
Start.__doc__ = """Where a run starts: ``state`` float64[13] (``x (3), Q (4), v (3), w (3)``, scaled;
updated in place), the time ``t0``, the adhering area ``area0`` and whether it touches
(``touch0``): the robot starts lying on a face, so the first step already feels that face's
adhesion."""

Clock = namedtuple("Clock", ["h", "n_steps", "record_every"])
Clock.__doc__ = """The time grid of a run: step length ``h`` (scaled), ``n_steps``, and a record row
every ``record_every`` steps."""

Buffers = namedtuple("Buffers", ["ws", "ws6", "z", "z6", "zsave"])
Buffers.__doc__ = """A run's solver memory, reusable across runs: the workspaces of the full system and
of the 6-unknown free-flight system (:class:`~.newton.Workspace`) and the unknowns ``z``
(warm start in, last solution out), ``z6`` and ``zsave`` (float64[n], [6], [n]). Build with
:func:`make_buffers`."""

Scratch = namedtuple("Scratch", ["sc", "R", "tmp", "tmp2", "tmp3", "cg", "qs", "iters", "prob", "prob6", "hts"])
Scratch.__doc__ = """The time loop's small temporaries, allocated once per run: step data ``sc`` (N_SC),
the rotation ``R`` (9, row-major), three 3-vectors, the blocks of ``constraint_eval`` (N_CG)
and ``quat_step`` (N_QS), the solver's iteration counters ``iters`` (int64[3]), the two
systems a step solves (:class:`~.residual.Problem`, sharing ``sc``): with contact (``prob``)
and in free flight (``prob6``), and the support points' heights ``hts`` (float64, at least
the most support points of a piece; :func:`lowest_point`)."""

Frame = namedtuple("Frame", ["state", "z", "touching", "led", "sv"])
Frame.__doc__ = """What a (sub-)step changes: ``state`` float64[13], unknowns ``z`` float64[n],
``touching`` int64[K] (the pieces touching after the last commit), the energy ledger ``led``
float64[N_LED] and the scalars ``sv`` float64[N_SV] (``SV_*`` in :mod:`.layout`). A refined
landing and a rescue pass keep the step's start in a frame of their own and return to it
with :func:`copy_frame`."""

Loop = namedtuple("Loop", ["zwarm", "zbest", "hist", "edir", "ls", "lw", "xoff", "xw", "refine", "rescue"])
Loop.__doc__ = """The time loop's own memory, allocated once per run: the sub-step's warm start
``zwarm`` and best attempt ``zbest`` (float64[n]), the last contact solutions ``hist``
(float64[6, n], row 0 the latest: the extrapolated warm start), the level edge's direction
``edir`` (3), the ledger terms ``ls`` of the (sub-)step being committed and the ledger's
work array ``lw``, the origin's shift ``xoff`` (3, :func:`~.recording.recentre`), the
early-decision window's start ``xw`` (3), and the two snapshot frames: ``refine`` (the start
of a refined landing) and ``rescue`` (the step's start, kept at its first halving)."""


@jit
def copy_frame(src, dst, n_sv):  # type: ignore[no-untyped-def]
    """Copy frame ``src`` into ``dst``: arrays whole, and the first ``n_sv`` scalars
    (``N_SNAP`` or ``N_SNAP_STEP``)."""
    for i in range(src.state.shape[0]):
        dst.state[i] = src.state[i]
    for i in range(src.z.shape[0]):
        dst.z[i] = src.z[i]
    for i in range(src.touching.shape[0]):
        dst.touching[i] = src.touching[i]
    for i in range(src.led.shape[0]):
        dst.led[i] = src.led[i]
    for i in range(n_sv):
        dst.sv[i] = src.sv[i]


def make_buffers(n: int) -> Buffers:
    """Solver memory for a system of ``n`` unknowns (:class:`Buffers`)."""
    return Buffers(ws=make_workspace(n), ws6=make_workspace(6), z=np.zeros(n), z6=np.zeros(6), zsave=np.zeros(n))
