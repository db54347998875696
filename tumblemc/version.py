"""The installed version of tumblemc.

``0.1.0.dev0`` when run from a source tree that is not installed. Lowest layer: the
model and the study files record it as provenance.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tumblemc")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.1.0.dev0"

__all__ = ["__version__"]
