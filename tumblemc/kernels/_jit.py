"""The one jit policy of tumblemc.

Every Numba function in :mod:`tumblemc.kernels` is compiled through :func:`jit` (or
:func:`jit_alloc`, for the few that allocate):

- ``cache=True``: compiled code is written to ``NUMBA_CACHE_DIR`` (or ``__pycache__``) so
  a second process starts in well under a second instead of recompiling. Numba keys a
  cached function by its own source file only, so a kernel that calls one in another file
  (``run_batch`` calls ``stepper.run``) would be loaded stale after that file changed.
  With ``NUMBA_CACHE_DIR`` set, the cache therefore lives in a subfolder named by a digest
  of every kernel source file (:func:`kernels_cache_dir`): any kernel edit starts a fresh
  cache. (Without it, Numba's ``__pycache__`` next to the sources applies; an installed
  package's files change only by reinstalling, which replaces them all.)
- ``nogil=True``: kernels release the GIL, so threads (dask's threaded scheduler) can run
  simulations concurrently.
- ``fastmath`` is **off**: fastmath lets LLVM assume no NaN/inf, which compiles away the
  ``x != x`` checks the solver relies on to detect a diverged step.
- ``error_model="numpy"``: a division by zero gives inf/NaN (caught by those checks)
  instead of raising inside a Newton loop.
- ``boundscheck`` follows Numba's default (off, or ``NUMBA_BOUNDSCHECK=1`` to debug).
- **Inlined stages** (:func:`jit_inline`, ``inline="always"``): the time loop's per-step
  stages (one step, a sub-step's solve, the ladder, the commit) are functions in the
  source, in the shape of the algorithm, and compile into their one caller (the loop
  ``stepper.march``): each takes about a hundred arrays in its records, and passing them
  as calls cost a cheap step 1.22x (docs/notes/kernel_experiments.md).
- **No reference counting** (``_nrt=False``, Numba's option for code compiled without
  its runtime) in every kernel but the few that allocate (the time loops ``run`` and
  ``run_batch``, which own every array of a run, and the impact guesses, which solve
  small systems with LAPACK; :func:`jit_alloc` asks for the runtime explicitly, since
  Numba otherwise compiles a callee with its caller's setting, and the guesses are called
  from kernels without it): with the runtime
  on, a compiled function takes an atomic reference on each array it receives or takes
  out of a tuple, and drops it on return, about 16% of a time step
  (docs/kernel_experiments.md, "Where a step goes now"). The arrays a kernel sees are
  borrowed from its caller, which outlives the call. The rule that keeps this safe: a
  :func:`jit` kernel never allocates an array (Numba refuses to compile it) and never
  returns one (tests/test_runtime.py checks every compiled kernel's return type).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

JIT_OPTIONS: dict[str, object] = {"cache": True, "nogil": True, "error_model": "numpy"}

#: prefix of the cache subfolder of one version of the kernel sources
CACHE_PREFIX = "kernels-"


def kernels_digest(folder: Path | None = None) -> str:
    """Digest of every ``*.py`` file of ``folder`` (default: this package), names and contents."""
    h = hashlib.sha256()
    for p in sorted((folder or Path(__file__).resolve().parent).glob("*.py")):
        h.update(p.name.encode())
        h.update(b"\0")
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def kernels_cache_dir(base: str, digest: str) -> str:
    """The cache folder under ``base`` for kernel sources of ``digest`` (``base`` itself if it is one already)."""
    name = CACHE_PREFIX + digest
    return base if Path(base).name == name else os.path.join(base, name)


if os.environ.get("NUMBA_CACHE_DIR"):
    # the environment too: Numba re-reads it when it compiles, and worker processes inherit it
    os.environ["NUMBA_CACHE_DIR"] = kernels_cache_dir(os.environ["NUMBA_CACHE_DIR"], kernels_digest())
    numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]


def jit(func):  # type: ignore[no-untyped-def]
    """Compile ``func`` with the project's jit policy, without reference counting (see module docstring)."""
    return numba.njit(**JIT_OPTIONS, _nrt=False)(func)


def jit_inline(func):  # type: ignore[no-untyped-def]
    """As :func:`jit`, inlined into its caller at Numba's IR level (``inline="always"``).

    For the time loop's per-step stages (one step, a sub-step's solve, the ladder, the
    commit): each takes about a hundred arrays in its records, and a call passes them all,
    which costs more than a cheap step's own work (measured: 1.22x per step as calls). The
    stages stay functions in the source, in the shape of the algorithm.
    """
    return numba.njit(**JIT_OPTIONS, _nrt=False, inline="always")(func)


def jit_alloc(func):  # type: ignore[no-untyped-def]
    """As :func:`jit`, with Numba's runtime (reference counting) on: for kernels that allocate arrays.

    ``_nrt=True`` is explicit: a kernel compiled without the runtime (``one_step``) calls the
    impact guesses, and Numba would otherwise compile them with its caller's setting.
    """
    return numba.njit(**JIT_OPTIONS, _nrt=True)(func)
