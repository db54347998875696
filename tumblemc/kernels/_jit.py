"""The one jit policy of tumblemc.

Every Numba function in :mod:`tumblemc.kernels` is compiled through :func:`jit`:

- ``cache=True``: compiled code is written to ``NUMBA_CACHE_DIR`` (or ``__pycache__``) so
  a second process starts in well under a second instead of recompiling.
- ``nogil=True``: kernels release the GIL, so threads (dask's threaded scheduler) can run
  simulations concurrently.
- ``fastmath`` is **off**: fastmath lets LLVM assume no NaN/inf, which compiles away the
  ``x != x`` checks the solver relies on to detect a diverged step.
- ``error_model="numpy"``: a division by zero gives inf/NaN (caught by those checks)
  instead of raising inside a Newton loop.
- ``boundscheck`` follows Numba's default (off, or ``NUMBA_BOUNDSCHECK=1`` to debug).
"""

from __future__ import annotations

import numba

JIT_OPTIONS: dict[str, object] = {"cache": True, "nogil": True, "error_model": "numpy"}


def jit(func):  # type: ignore[no-untyped-def]
    """Compile ``func`` with the project's jit policy (see module docstring)."""
    return numba.njit(**JIT_OPTIONS)(func)
