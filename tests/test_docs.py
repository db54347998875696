"""The documentation runs: its shell commands parse with today's CLI, and README's Python runs.

Every ``tumblemc ...`` line of a fenced ``bash``/``sh``/``console`` block in README.md,
docs/ and data/README.md is parsed by :func:`tumblemc.cli.build_parser` (nothing is
executed; ``bench`` passes its arguments on and is skipped), and each ``studies/*.toml``
it names must exist. The ``python`` blocks of README.md and of the guides that take over
from it (:data:`PYTHON_DOCS`) run in a temporary folder: the short ones in the fast tier,
the one that runs a study in the slow tier, the SLURM one not at all (it needs a cluster).
Every relative link of the markdown files, and every ``docs/...`` path they name, exists.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pytest

from tumblemc.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
DOC_FILES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), ROOT / "data" / "README.md"]
SHELL_TAGS = ("```bash", "```sh", "```console")


def fenced_blocks(path: Path, tags: tuple[str, ...]) -> list[tuple[int, str]]:
    """(first line number, text) of every fenced block of ``path`` opened by one of ``tags``."""
    blocks: list[tuple[int, str]] = []
    inside = keep = False
    lines: list[str] = []
    start = 0
    for i, line in enumerate(path.read_text().splitlines(), 1):
        s = line.strip()
        if not inside and s.startswith("```"):
            inside, keep, lines, start = True, s in tags, [], i + 1
        elif inside and s == "```":
            inside = False
            if keep:
                blocks.append((start, "\n".join(lines)))
        elif inside:
            lines.append(line)
    return blocks


def shell_commands() -> list[tuple[str, list[str]]]:
    """(where, argv after ``tumblemc``) of every documented ``tumblemc`` command."""
    out: list[tuple[str, list[str]]] = []
    for path in DOC_FILES:
        for start, text in fenced_blocks(path, SHELL_TAGS):
            for k, line in enumerate(text.replace("\\\n", " ").splitlines()):
                for part in re.split(r"&&|;", line.split(" #")[0]):
                    m = re.match(r"^(?:\S*/)?tumblemc\s+(.*)$", part.strip())
                    if m:
                        out.append((f"{path.relative_to(ROOT)}:{start + k}", shlex.split(m.group(1))))
    return out


COMMANDS = shell_commands()


def test_the_docs_hold_commands():
    """The collector finds the README's commands (a parser that finds nothing tests nothing)."""
    where = {w.split(":")[0] for w, _ in COMMANDS}
    assert "README.md" in where
    assert any(argv[:2] == ["study", "run"] for _, argv in COMMANDS)
    assert len(COMMANDS) >= 15


@pytest.mark.parametrize(("where", "argv"), COMMANDS, ids=[w for w, _ in COMMANDS])
def test_documented_command_parses(where, argv):
    try:
        build_parser().parse_args(argv)
    except SystemExit as e:  # argparse's way to refuse
        pytest.fail(f"{where}: `tumblemc {shlex.join(argv)}` does not parse (exit {e.code})")
    for a in argv:
        if re.fullmatch(r"studies/[\w.-]+\.toml", a):
            assert (ROOT / a).is_file(), f"{where}: {a} does not exist"


#: the files whose ``python`` blocks run: the README and the guides it points to for runs and studies
PYTHON_DOCS = [ROOT / "README.md", ROOT / "docs" / "guide" / "runs.md", ROOT / "docs" / "guide" / "studies.md"]
README_PY = [(path, start, code) for path in PYTHON_DOCS for start, code in fenced_blocks(path, ("```python",))]


def _kind(code: str) -> str:
    if "dask_jobqueue" in code:
        return "cluster"
    if "run_study(" in code:
        return "slow"
    return "smoke" if SMOKE_RESULT in code else "fast"  # smoke: the smoke study's file, made by the README's shell command


#: the smoke study's result, which a block may open after the README's shell command made it
SMOKE_RESULT = "results/smoke.nc"
MARKS = {"fast": [], "slow": [pytest.mark.slow], "smoke": [pytest.mark.slow], "cluster": [pytest.mark.skip("needs a SLURM cluster")]}


@pytest.mark.parametrize(
    "code",
    [
        pytest.param(
            code,
            id=f"{path.relative_to(ROOT)}:{start}",
            marks=MARKS[_kind(code)],
        )
        for path, start, code in README_PY
    ],
)
def test_readme_python_runs(code, tmp_path, monkeypatch, capsys):
    shutil.copytree(ROOT / "studies", tmp_path / "studies")
    monkeypatch.chdir(tmp_path)
    if _kind(code) == "smoke":  # as `tumblemc study run studies/smoke.toml` leaves it
        from tumblemc import load_config, run_study

        run_study(load_config("studies/smoke.toml"), out=SMOKE_RESULT, progress=False)
    exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    capsys.readouterr()


def test_readme_has_python_of_every_kind():
    kinds = {_kind(code) for _, _, code in README_PY}
    assert kinds == {"fast", "slow", "smoke", "cluster"}
    assert any(path.name == "README.md" for path, _, _ in README_PY)


#: every markdown page whose links are checked
LINKED_DOCS = [
    *DOC_FILES,
    *(ROOT / p for p in ("CHANGELOG.md", "experiments/README.md", "studies/README.md", "notebooks/README.md")),
]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
DOCS_PATH = re.compile(r"(?<![\w/.])(docs/[\w/.-]*\w)")


def test_the_docs_links_resolve():
    """Relative links (anchors aside) and ``docs/...`` paths named in the text point at files that exist."""
    broken = []
    for path in LINKED_DOCS:
        text = path.read_text()
        for m in LINK.finditer(text):
            target = m.group(1).split("#")[0]
            if target and not re.match(r"^[a-z]+:", target) and not (path.parent / target).exists():
                broken.append(f"{path.relative_to(ROOT)}: link {m.group(1)}")
        broken += [f"{path.relative_to(ROOT)}: path {m.group(1)}" for m in DOCS_PATH.finditer(text) if not (ROOT / m.group(1)).exists()]
    assert not broken, "\n".join(broken)


def test_the_docs_index_reaches_every_page():
    """docs/index.md links every page of docs/guide and docs/notes (a page nobody links is lost)."""
    index = (ROOT / "docs" / "index.md").read_text()
    linked = {(ROOT / "docs" / m.group(1).split("#")[0]).resolve() for m in LINK.finditer(index)}
    pages = [p for sub in ("guide", "notes") for p in sorted((ROOT / "docs" / sub).glob("*.md"))]
    missing = [str(p.relative_to(ROOT)) for p in pages if p.resolve() not in linked]
    assert not missing, f"docs/index.md does not link {missing}"
