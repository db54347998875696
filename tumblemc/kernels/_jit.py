"""The one jit policy of tumblemc.

Every Numba function in :mod:`tumblemc.kernels` is compiled through :func:`jit` (or
:func:`jit_alloc`, for the few that allocate):

- ``cache=True``: compiled code is written to ``NUMBA_CACHE_DIR`` (or ``__pycache__``) so
  a second process starts in well under a second instead of recompiling.
- ``nogil=True``: kernels release the GIL, so threads (dask's threaded scheduler) can run
  simulations concurrently.
- ``fastmath`` is **off**: fastmath lets LLVM assume no NaN/inf, which compiles away the
  ``x != x`` checks the solver relies on to detect a diverged step.
- ``error_model="numpy"``: a division by zero gives inf/NaN (caught by those checks)
  instead of raising inside a Newton loop.
- ``boundscheck`` follows Numba's default (off, or ``NUMBA_BOUNDSCHECK=1`` to debug).
- **No reference counting** (``_nrt=False``, Numba's option for code compiled without
  its runtime) in every kernel but the few that allocate (the time loops ``run`` and
  ``run_batch``, which own every array of a run, and ``_impact_guess``): with the runtime
  on, a compiled function takes an atomic reference on each array it receives or takes
  out of a tuple, and drops it on return, about 16% of a time step
  (docs/kernel_experiments.md, "Where a step goes now"). The arrays a kernel sees are
  borrowed from its caller, which outlives the call. The rule that keeps this safe: a
  :func:`jit` kernel never allocates an array (Numba refuses to compile it) and never
  returns one (tests/test_runtime.py checks every compiled kernel's return type).
"""

from __future__ import annotations

import numba

JIT_OPTIONS: dict[str, object] = {"cache": True, "nogil": True, "error_model": "numpy"}


def jit(func):  # type: ignore[no-untyped-def]
    """Compile ``func`` with the project's jit policy, without reference counting (see module docstring)."""
    return numba.njit(**JIT_OPTIONS, _nrt=False)(func)


def jit_alloc(func):  # type: ignore[no-untyped-def]
    """As :func:`jit`, with Numba's runtime (reference counting) on: for kernels that allocate arrays."""
    return numba.njit(**JIT_OPTIONS)(func)
