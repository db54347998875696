"""Test configuration: compiled kernels go to an ignored cache folder of the checkout."""

from __future__ import annotations

import os
from pathlib import Path

# Must happen before numba is imported (tumblemc imports it).
os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".numba_cache"))
os.environ.setdefault("MPLBACKEND", "Agg")
