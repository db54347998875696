"""The installed version of tumblemc and the git commit its code comes from.

``0.1.0.dev0`` when run from a source tree that is not installed. Lowest layer: the
model and the study files record it as provenance.

The commit (:func:`build_info`) is read where the code is, never where Python happens to
run: from the checkout when this module is a tracked file of one (a source tree or an
editable install, so the answer follows every commit and edit), else from
``tumblemc/_build_info.py``, which setuptools-scm writes into the wheel when the package
is built (``pip install .``; ``[tool.setuptools_scm]`` in ``pyproject.toml``) and which is
not in git. A wheel installed into a virtual environment inside a clone is not a tracked
file there, so it reports the commit it was built from, not the clone's.
"""

from __future__ import annotations

import subprocess
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

try:
    __version__ = version("tumblemc")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.1.0.dev0"


def _git(*args: str, cwd: Path) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, timeout=10, check=True).stdout.strip()


def _checkout(path: Path | None = None) -> tuple[str, bool] | None:
    """Commit and dirty flag of the checkout ``path`` (this module) is a tracked file of, or None."""
    here = Path(path or __file__).resolve()
    try:
        _git("ls-files", "--error-unmatch", "--", here.name, cwd=here.parent)
        sha = _git("rev-parse", "HEAD", cwd=here.parent)
        # setuptools-scm's test too: changes to tracked files, untracked files ignored
        dirty = bool(_git("status", "--porcelain", "--untracked-files=no", cwd=here.parent))
    except (OSError, subprocess.SubprocessError):
        return None
    return sha, dirty


def build_info() -> dict[str, Any]:
    """The git commit of the running tumblemc code and whether its tree was dirty.

    Returns
    -------
    dict
        ``git_sha`` (str: the full commit hash, or ``"unknown"``), ``git_dirty`` (int:
        1 if tracked files differed from that commit, 0 if not, -1 unknown) and
        ``git_sha_source`` (str: ``"checkout"``, read now from the git tree the code is
        imported from; ``"build"``, recorded when the installed package was built;
        ``"none"``, e.g. a wheel built from a source archive rather than a checkout).
    """
    live = _checkout()
    if live is not None:
        return {"git_sha": live[0], "git_dirty": int(live[1]), "git_sha_source": "checkout"}
    try:
        built = import_module("tumblemc._build_info")
    except ImportError:
        built = None
    node, dirty = getattr(built, "node", None), getattr(built, "dirty", None)
    if isinstance(node, str) and node.startswith("g") and isinstance(dirty, bool):  # setuptools-scm's git node: "g" + hash
        return {"git_sha": node[1:], "git_dirty": int(dirty), "git_sha_source": "build"}
    return {"git_sha": "unknown", "git_dirty": -1, "git_sha_source": "none"}


__all__ = ["__version__", "build_info"]
