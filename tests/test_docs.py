"""Every command and snippet of the user documentation runs.

The fenced code blocks of README.md and docs/*.md tagged ``sh``, ``bash`` or ``console``
(commands) and ``python`` (snippets) are extracted and run, so that the docs cannot drift
from the code:

* the blocks of one document run in document order in one temporary working directory
  (the document's own folder: a snippet writes a dataset, a later command reads it);
* the Python snippets of one document share one namespace (they chain, as a reader who
  pastes them one after the other into one session would run them);
* a long document is cut into independent chains (``CHAINS``: a block that needs nothing
  from the blocks above it starts a chain of its own, with its own folder and namespace),
  so that its blocks run on both pytest-xdist workers;
* a shell block runs with ``bash -e`` and ``railfem`` on PATH; it must exit with code 0
  (``console`` blocks: only the lines starting with ``$ ``).

An HTML comment on the line before a block marks it:

* ``<!-- doctest: slow -->``: heavy (more than ~20 s: fits, diagnoses, studies, full
  sweeps); runs only with ``-m slow``, after the document's earlier default blocks;
* ``<!-- doctest: skip REASON -->``: never run. Reserved for the commands that install
  packages and the test command itself; ``SKIPPED`` below lists them and a test checks
  the list against the docs.

Skipped blocks (4):

* README.md, ``bash scripts/setup.sh && railfem track ...``: installs system and Python packages;
* README.md, ``bash scripts/setup.sh && python3 -m ruff check && python3 -m pytest``: installs packages, runs the tests;
* README.md, ``python3 -m venv ...`` (set-up into a virtual environment): installs packages;
* README.md, ``python3 -m pytest`` (the test commands): the test suite itself.

Blocks in documents that a reader runs from a clone (examples, benchmarks) are not in the
user docs; tests/test_examples.py runs the examples.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SHELL = {"sh", "bash", "console"}
PYTHON = {"python", "py"}
#: (document, reason) of every block marked skip; the module docstring says why
SKIPPED = [
    ("README.md", "installs system and Python packages"),
    ("README.md", "installs packages and runs the test suite"),
    ("README.md", "installs packages into a virtual environment"),
    ("README.md", "the test suite itself"),
]
#: a shell block with one of these may not run from the doc test (it installs or recurses)
MUST_SKIP = ("scripts/setup.sh", "pytest", "pip install", "venv")
#: (document, text of a block): that block needs nothing the blocks above it made or defined
#: and starts a chain of its own (own working directory, namespace and xdist group); the
#: blocks below it, up to the next chain start, belong to its chain
CHAINS = [
    ("README.md", "railfem track --preset site --h 20 --f-high 1000 --out out/site"),
    ("README.md", 'rf.io.write_dataset("site_hammer", m)'),
]
TIMEOUT = 1800

_FENCE = re.compile(r"^```\s*([A-Za-z0-9_+-]*)\s*$")
_MARK = re.compile(r"^<!--\s*doctest:\s*(slow|skip)\b\s*(.*?)\s*-->\s*$")


@dataclass(frozen=True, kw_only=True)
class Block:
    doc: str
    line: int
    lang: str
    text: str
    mark: str = ""
    reason: str = ""

    @property
    def id(self) -> str:
        return f"{self.doc}:{self.line}"


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of ``path`` in a language that runs, with their marks."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out, i = [], 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        lang, start = m.group(1).lower(), i
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        prev = next((lines[k] for k in range(start - 1, -1, -1) if lines[k].strip()), "")
        mark = _MARK.match(prev.strip())
        if lang in SHELL | PYTHON:
            out.append(Block(doc=path.relative_to(ROOT).as_posix(), line=start + 1, lang=lang,
                             text="\n".join(lines[start + 1:j]) + "\n",
                             mark=mark.group(1) if mark else "",
                             reason=mark.group(2) if mark else ""))
        i = j + 1
    return out


ALL = [b for p in DOCS for b in blocks(p)]


def chain(block: Block) -> str:
    """The chain ``block`` belongs to: its document, with '#n' after the n-th chain start
    (CHAINS) at or above it."""
    n = sum(1 for b in ALL if b.doc == block.doc and b.line <= block.line
            and any(doc == b.doc and text in b.text for doc, text in CHAINS))
    return block.doc if n == 0 else f"{block.doc}#{n}"


@dataclass
class DocState:
    """One document's working directory, Python namespace and the blocks already run."""

    cwd: Path
    namespace: dict = field(default_factory=lambda: {"__name__": "__doc__"})
    done: set = field(default_factory=set)


@pytest.fixture(scope="session")
def states(tmp_path_factory):
    made: dict[str, DocState] = {}

    def get(doc: str) -> DocState:
        if doc not in made:
            made[doc] = DocState(cwd=tmp_path_factory.mktemp(Path(doc).stem))
        return made[doc]

    return get


def _shell(block: Block, cwd: Path) -> None:
    text = block.text
    if block.lang == "console":
        text = "\n".join(ln[2:] for ln in text.splitlines() if ln.startswith("$ ")) + "\n"
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env.setdefault("MPLBACKEND", "Agg")
    r = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", text], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=TIMEOUT)
    assert r.returncode == 0, (f"{block.id}: exit code {r.returncode}\n--- commands\n{text}"
                               f"--- stdout\n{r.stdout[-3000:]}\n--- stderr\n{r.stderr[-3000:]}")


def _python(block: Block, state: DocState) -> None:
    old = Path.cwd()
    os.chdir(state.cwd)
    try:
        code = compile(block.text, f"{block.id} (python)", "exec")
        exec(code, state.namespace)  # noqa: S102  (the snippet is the documentation's own)
    finally:
        os.chdir(old)
        import matplotlib.pyplot as plt

        plt.close("all")


def _run(block: Block, state: DocState) -> None:
    if block.lang in SHELL:
        _shell(block, state.cwd)
    else:
        _python(block, state)
    state.done.add(block.line)


def _params():
    for b in ALL:
        marks = [pytest.mark.xdist_group(chain(b))]  # a chain's blocks: one worker
        if b.mark == "slow":
            marks.append(pytest.mark.slow)
        elif b.mark == "skip":
            marks.append(pytest.mark.skip(reason=b.reason or "marked skip in the docs"))
        yield pytest.param(b, id=f"{b.id}-{b.lang}", marks=marks)


@pytest.mark.parametrize("block", list(_params()))
def test_doc_block(block: Block, states):
    """The block runs; its chain's earlier default blocks run first when they have not."""
    state = states(chain(block))
    for b in ALL:
        if b.doc != block.doc or b.line >= block.line or chain(b) != chain(block):
            continue
        if b.mark == "" and b.line not in state.done:
            _run(b, state)
    _run(block, state)


def test_every_doc_has_blocks_and_known_languages():
    """The extraction finds the blocks (a changed fence syntax would silently test nothing)."""
    assert len(ALL) >= 20, [b.id for b in ALL]
    assert any(b.lang in PYTHON for b in ALL) and any(b.lang in SHELL for b in ALL)


def test_skipped_blocks_are_the_listed_ones():
    """Only the set-up and test commands are skipped, and the module docstring lists them."""
    skipped = [(b.doc, b.reason) for b in ALL if b.mark == "skip"]
    assert skipped == SKIPPED
    assert f"Skipped blocks ({len(SKIPPED)})" in __doc__


def test_every_chain_start_names_one_block():
    """A CHAINS entry that matches no block (the docs changed) or several would silently
    move blocks between chains."""
    for doc, text in CHAINS:
        hits = [b.id for b in ALL if b.doc == doc and text in b.text]
        assert len(hits) == 1, (doc, text, hits)


def test_installing_and_recursing_blocks_are_marked_skip():
    """A block that installs packages or runs pytest must be marked skip, not run."""
    bad = [b.id for b in ALL if b.lang in SHELL and b.mark != "skip"
           and any(s in b.text for s in MUST_SKIP)]
    assert not bad, f"mark these <!-- doctest: skip REASON -->: {bad}"
