"""Check that tumblemc's imports point one way through its layers.

    python tools/check_imports.py [PACKAGE_DIR]

Parses every module of the package (default: ``tumblemc/`` next to this folder) with
:mod:`ast`, nothing imported or run, and prints one line per violation, ``path:line:
message``, exiting 1 if there is any:

- a module imports a module of a higher layer (:data:`LAYERS`; function-level and
  ``TYPE_CHECKING`` imports count too);
- a module imports another module's private name (``from m import _x``, ``m._x`` on an
  imported module) or a private module from outside its package;
- a kernel imports xarray, dask, distributed or matplotlib; a module outside ``viz/``
  imports matplotlib;
- analysis imports what runs a simulation (study, model.run, model.rows, the stepping
  kernels): an end-to-end sensitivity run is a study;
- a module has more than :data:`MAX_LINES` lines and is not in :data:`LONG_MODULES` (the
  ratchet: a module leaves the list once it is split, and none joins it);
- a module has no layer in :data:`LAYERS`;
- modules import each other in a loop (module-level imports, ``if TYPE_CHECKING`` ones
  included; an import inside a function is the deliberate way to defer one).

The layers, lowest first (a module may import its own layer and those below)::

    kernels <- schema, model, testing <- io, analysis <- study, lab, design <- viz <- reports <- cli
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

PACKAGE = "tumblemc"

#: layer of each module, by dotted prefix (the longest matching prefix wins); the package
#: root (``tumblemc/__init__.py``, the public facade) is the top layer
LAYERS: dict[str, int] = {
    "tumblemc.kernels": 0,
    # schema may import kernel constants; testing holds benchmark problems for every layer's tests
    "tumblemc.version": 0,
    "tumblemc.schema": 1,
    "tumblemc.model": 1,
    "tumblemc.testing": 1,
    # pure functions of Datasets and files
    "tumblemc.io": 2,
    "tumblemc.ncformat": 2,
    "tumblemc.analysis": 2,
    "tumblemc.study": 3,
    # bench tests and calibration: runs, summarised (figures in viz)
    "tumblemc.lab": 3,
    # design search: families of shapes, studies of designs
    "tumblemc.design": 3,
    "tumblemc.viz": 4,
    # run simulations and draw figures: only the command line may import them
    "tumblemc.reports": 5,
    "tumblemc.cli": 6,
    "tumblemc.__main__": 6,
    "tumblemc": 6,
}

LAYER_NAMES = {
    0: "kernels",
    1: "model",
    2: "io/analysis",
    3: "study",
    4: "viz",
    5: "reports",
    6: "cli",
}

#: third-party packages Numba code never imports
KERNEL_FORBIDDEN = ("xarray", "dask", "distributed", "matplotlib")

#: modules that run a simulation, which analysis/ never imports
SIMULATES = (
    "tumblemc.study",
    "tumblemc.model.run",
    "tumblemc.model.rows",
    "tumblemc.kernels.batch",
    "tumblemc.kernels.stepper",
    "tumblemc.kernels.step",
    "tumblemc.kernels.substep",
    "tumblemc.kernels.newton",
    "tumblemc.kernels.residual",
)

MAX_LINES = 500

#: modules allowed over MAX_LINES, kernels included: {path relative to the package: reason}.
#: A ratchet: shorten it, never lengthen it
LONG_MODULES: dict[str, str] = {
    "kernels/residual.py": "the residual and its Jacobian row by row (one formula each); to split by row block",
}


@dataclass(frozen=True)
class Module:
    """A module of the package: dotted name, file, parsed tree."""

    name: str
    path: Path
    tree: ast.Module
    n_lines: int

    @property
    def package(self) -> str:
        """The package the module belongs to (itself for an ``__init__.py``)."""
        return self.name if self.path.name == "__init__.py" else self.name.rpartition(".")[0]


def is_private(name: str) -> bool:
    """A leading underscore that is not a dunder (``_x``, not ``__version__``)."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def within(name: str, prefix: str) -> bool:
    """Whether dotted ``name`` is ``prefix`` or inside it."""
    return name == prefix or name.startswith(prefix + ".")


def layer_of(name: str) -> int | None:
    """Layer of a dotted module name, or None if :data:`LAYERS` does not place it."""
    if name == PACKAGE:
        return LAYERS[PACKAGE]
    best = max((p for p in LAYERS if p != PACKAGE and within(name, p)), key=len, default=None)
    return None if best is None else LAYERS[best]


def load(package_dir: Path) -> dict[str, Module]:
    """Parse every ``.py`` file under ``package_dir`` (whose name is the package's)."""
    root = package_dir.parent
    modules = {}
    for path in sorted(package_dir.rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        text = path.read_text(encoding="utf-8")
        name = ".".join(parts)
        modules[name] = Module(name, path, ast.parse(text, filename=str(path)), len(text.splitlines()))
    return modules


def resolve(mod: Module, node: ast.ImportFrom) -> str:
    """Absolute module name of a ``from ... import`` (relative imports resolved)."""
    if not node.level:
        return node.module or ""
    base = mod.package.split(".")
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(mod: Module, known: set[str], deferred: bool = True) -> list[tuple[int, str, str | None]]:
    """Every import of the module as ``(line, module, name)``.

    ``name`` is the name taken from ``module`` by ``from module import name`` when it is
    not itself a module, else None. Imports anywhere in the file count (``if
    TYPE_CHECKING`` too); with ``deferred=False``, not those inside a function body.
    """
    out: list[tuple[int, str, str | None]] = []

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if not deferred and isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
                continue
            if isinstance(child, ast.Import):
                out.extend((child.lineno, alias.name, None) for alias in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = resolve(mod, child)
                for alias in child.names:
                    sub = f"{base}.{alias.name}"
                    out.append((child.lineno, sub, None) if sub in known else (child.lineno, base, alias.name))
            visit(child)

    visit(mod.tree)
    return out


def module_aliases(mod: Module, known: set[str]) -> dict[str, str]:
    """Local names bound to a module of the package (``import a.b as m``, ``from a import b``)."""
    out = {}
    for node in ast.walk(mod.tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname and alias.name in known:
                    out[alias.asname] = alias.name
        elif isinstance(node, ast.ImportFrom):
            base = resolve(mod, node)
            for alias in node.names:
                if f"{base}.{alias.name}" in known:
                    out[alias.asname or alias.name] = f"{base}.{alias.name}"
    return out


def check_module(mod: Module, known: set[str], rel: str) -> list[tuple[int, str]]:
    """Violations of one module as ``(line, message)``."""
    found: list[tuple[int, str]] = []
    own = layer_of(mod.name)
    if own is None:
        return [(1, f"{mod.name} has no layer: add it to LAYERS in tools/check_imports.py")]
    for line, target, name in imports(mod, known):
        top = target.split(".")[0]
        if top != PACKAGE:
            if own == 0 and top in KERNEL_FORBIDDEN:
                found.append((line, f"kernel {mod.name} imports {top}: kernels take and return arrays only"))
            elif top == "matplotlib" and not within(mod.name, f"{PACKAGE}.viz"):
                found.append((line, f"{mod.name} imports matplotlib: figures are drawn in {PACKAGE}.viz only"))
            continue
        theirs = layer_of(target)
        if theirs is not None and theirs > own:
            found.append(
                (
                    line,
                    f"{mod.name} ({LAYER_NAMES[own]} layer) imports {target} ({LAYER_NAMES[theirs]} layer): "
                    "imports point down the layers only",
                )
            )
        if within(mod.name, "tumblemc.analysis") and any(within(target, s) for s in SIMULATES):
            found.append((line, f"{mod.name} imports {target}: analysis never runs a simulation (that is a study)"))
        if name is not None and is_private(name) and target != mod.name:
            found.append((line, f"{mod.name} imports the private name {name} of {target}"))
        leaf_parent, _, leaf = target.rpartition(".")
        if is_private(leaf) and not within(mod.package, leaf_parent):
            found.append((line, f"{mod.name} imports the private module {target} from outside its package"))
    aliases = module_aliases(mod, known)
    for node in ast.walk(mod.tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and is_private(node.attr)
            and aliases[node.value.id] != mod.name
        ):
            found.append((node.lineno, f"{mod.name} uses the private name {node.attr} of {aliases[node.value.id]}"))
    if mod.n_lines > MAX_LINES and rel not in LONG_MODULES:
        found.append((1, f"{mod.name} has {mod.n_lines} lines (more than {MAX_LINES}): split it"))
    return found


def import_loops(modules: dict[str, Module]) -> list[list[str]]:
    """The import loops: strongly connected groups of modules (Tarjan), each sorted."""
    known = set(modules)
    graph = {
        name: sorted({target for _, target, _ in imports(mod, known, deferred=False) if target in known} - {name})
        for name, mod in modules.items()
    }
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    loops: list[list[str]] = []

    def strongconnect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                loops.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            strongconnect(v)
    return sorted(loops)


def check(package_dir: Path) -> list[str]:
    """Every violation in the package at ``package_dir``, as ``path:line: message`` lines."""
    modules = load(package_dir)
    known = set(modules)
    lines = []
    for mod in modules.values():
        rel = mod.path.relative_to(package_dir).as_posix()
        shown = mod.path.relative_to(package_dir.parent).as_posix()
        lines += [f"{shown}:{line}: {msg}" for line, msg in sorted(set(check_module(mod, known, rel)))]
    for group in import_loops(modules):
        shown = modules[group[0]].path.relative_to(package_dir.parent).as_posix()
        lines.append(f"{shown}:1: import loop among {', '.join(group)}: defer one import into a function or move the shared part")
    return lines


def main(argv: list[str] | None = None) -> int:
    """Check the package named on the command line (default: the repository's); 1 on a violation."""
    args = sys.argv[1:] if argv is None else argv
    package_dir = Path(args[0]) if args else Path(__file__).resolve().parents[1] / PACKAGE
    if not (package_dir / "__init__.py").is_file():
        print(f"check_imports: {package_dir} is not a package", file=sys.stderr)
        return 2
    violations = check(package_dir)
    for v in violations:
        print(v)
    n = len(load(package_dir))
    print(f"check_imports: {n} modules, {len(violations)} violation(s)", file=sys.stderr)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
