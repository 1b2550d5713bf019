"""Every fenced code block of README.md and docs/*.md runs as written (issue 23).

What "runs" means for each language:

- ``python``: executed, each block in a fresh namespace;
- ``toml``: parsed; a whole case file (one with a ``[case]`` table) is validated as a case;
- ``bash``: every line is a ``femupdate`` command (``\\`` continues a line), run in order with
  the blocks before it in the same document (so that ``run`` then ``report`` work);
- ``text`` and untagged blocks are output or diagrams, not run; the ``text`` block right after
  a ``femupdate run`` block is what it printed, and its lines must be in the real output (the
  wall time and the results path excepted).

Code runs in a temporary folder laid out like the checkout (``examples/`` linked, the shared
data folder beside it), so relative paths resolve and nothing is written into the repository.
A block that must not run is preceded by ``<!-- no-run: reason -->``: the reason is required,
and ``test_the_blocks_not_run_are_listed`` prints the list (``pytest -rA`` shows it).
Blocks that read the real records of ``../shared/data`` skip when it is absent.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

from femupdate.case import parse_case

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: Languages a block is run in; every other block is shown text.
RUN = ("python", "bash", "toml")
#: Paths in a block that read the real records of the shared data folder.
NEEDS_DATA = ("examples/quickstart", "examples/minishake-1story")
#: Lines of printed output that differ from run to run.
VARYING_OUTPUT = ("wall ", "results in ")
NO_RUN = re.compile(r"^<!--\s*no-run:\s*(.*?)\s*-->$")
FENCE = re.compile(r"^```(\S*)\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced code block: where it is, its language and text, and why it is not run."""

    document: Path
    line: int
    language: str
    text: str
    no_run: str | None

    @property
    def label(self) -> str:
        return f"{self.document.relative_to(ROOT)}:{self.line}"


def code_blocks(document: Path) -> list[Block]:
    """The fenced blocks of a markdown file, with the no-run reason of the line before each."""
    lines = document.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        fence = FENCE.match(lines[i])
        if fence is None:
            i += 1
            continue
        end = next((j for j in range(i + 1, len(lines)) if lines[j].strip() == "```"), None)
        assert end is not None, f"{document.name}:{i + 1}: a code block is never closed"
        before = next((lines[k].strip() for k in range(i - 1, -1, -1) if lines[k].strip()), "")
        marker = NO_RUN.match(before)
        blocks.append(Block(document, i + 1, fence.group(1).lower(),
                            "\n".join(lines[i + 1:end]) + "\n",
                            marker.group(1) if marker else None))
        i = end + 1
    return blocks


ALL_BLOCKS = [b for d in DOCUMENTS for b in code_blocks(d)]


def _blocks(language: str) -> list[Block]:
    return [b for b in ALL_BLOCKS if b.language == language and b.no_run is None]


def _needs_missing_data(block: Block) -> bool:
    return not DATA.is_dir() and any(p in block.text for p in NEEDS_DATA)


@pytest.fixture
def checkout_copy(tmp_path: Path) -> Path:
    """A working folder laid out like the checkout: examples/ linked, shared/ beside it."""
    work = tmp_path / "repo"
    work.mkdir()
    (work / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    if DATA.parent.is_dir():
        (tmp_path / "shared").symlink_to(DATA.parent, target_is_directory=True)
    return work


def test_every_block_is_run_or_says_why_not() -> None:
    """A block in a run language either runs or carries a no-run reason; markers sit only on
    blocks, and every block is closed (code_blocks asserts it)."""
    assert len(ALL_BLOCKS) > 10
    for block in ALL_BLOCKS:
        if block.no_run is not None:
            assert block.no_run, f"{block.label}: a no-run marker needs a reason"
    for document in DOCUMENTS:
        markers = _markers_outside_blocks(document)
        marked = sum(1 for b in ALL_BLOCKS if b.document == document and b.no_run is not None)
        assert markers == marked, f"{document.name}: a no-run marker not right before a block"


def _markers_outside_blocks(document: Path) -> int:
    """How many no-run markers the document has outside its code blocks."""
    inside, count = False, 0
    for line in document.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line) and not inside:
            inside = True
        elif inside and line.strip() == "```":
            inside = False
        elif not inside and NO_RUN.match(line.strip()):
            count += 1
    return count


def test_the_blocks_not_run_are_listed() -> None:
    skipped = [f"{b.label} [{b.language}]: {b.no_run}" for b in ALL_BLOCKS
               if b.no_run is not None]
    print("blocks not run:\n  " + "\n  ".join(skipped))
    assert all(b.language in RUN for b in ALL_BLOCKS if b.no_run is not None), (
        "a no-run marker on a block that would not run anyway")


@pytest.mark.slow
@pytest.mark.parametrize("block", _blocks("python"), ids=lambda b: b.label)
def test_python_block_runs(block: Block, checkout_copy: Path,
                           monkeypatch: pytest.MonkeyPatch) -> None:
    if _needs_missing_data(block):
        pytest.skip(f"{block.label} reads {DATA}, which is absent")
    monkeypatch.chdir(checkout_copy)
    exec(compile(block.text, block.label, "exec"), {"__name__": "__docs__"})


@pytest.mark.parametrize("block", _blocks("toml"), ids=lambda b: b.label)
def test_toml_block_parses(block: Block, tmp_path: Path) -> None:
    data = tomllib.loads(block.text)
    if "case" in data:  # a whole case file
        parse_case(data, source=tmp_path / "case.toml")


def _commands(block: Block) -> list[list[str]]:
    """The femupdate commands of a bash block, each as its arguments after ``femupdate``."""
    joined = block.text.replace("\\\n", " ")
    commands = []
    for line in joined.splitlines():
        words = shlex.split(line, comments=True)
        if not words:
            continue
        assert words[0] == "femupdate", (
            f"{block.label}: {line!r} is not a femupdate command: run only those, or mark the "
            "block <!-- no-run: reason -->")
        commands.append(words[1:])
    return commands


def _printed_after(block: Block) -> Block | None:
    """The text block that shows what ``block`` printed, if the document gives one."""
    blocks = [b for b in ALL_BLOCKS if b.document == block.document]
    later = blocks[blocks.index(block) + 1:]
    if later and later[0].language == "text" and "prints" in _between(block, later[0]):
        return later[0]
    return None


def _between(first: Block, second: Block) -> str:
    lines = first.document.read_text(encoding="utf-8").splitlines()
    end_of_first = first.line + first.text.count("\n")
    return "\n".join(lines[end_of_first:second.line - 1])


def _squeezed(text: str) -> str:
    return " ".join(text.split())


BASH_DOCUMENTS = sorted({b.document for b in _blocks("bash")})


@pytest.mark.slow
@pytest.mark.parametrize("document", BASH_DOCUMENTS, ids=lambda d: str(d.relative_to(ROOT)))
def test_bash_blocks_run(document: Path, checkout_copy: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    for block in (b for b in _blocks("bash") if b.document == document):
        if _needs_missing_data(block):
            pytest.skip(f"{block.label} reads {DATA}, which is absent")
        for args in _commands(block):
            done = subprocess.run([sys.executable, "-m", "femupdate", *args], cwd=checkout_copy,
                                  env=env, capture_output=True, text=True, timeout=600)
            assert done.returncode == 0, f"{block.label}: femupdate {' '.join(args)}\n" + (
                done.stdout + done.stderr)[-3000:]
        printed = _printed_after(block)
        if printed is not None:
            output = _squeezed(done.stdout + done.stderr)
            for line in printed.text.splitlines():
                if line.strip() and not any(v in line for v in VARYING_OUTPUT):
                    assert _squeezed(line) in output, (
                        f"{printed.label}: {line.strip()!r} is not what it prints now:\n"
                        + done.stdout[-3000:])


def test_the_api_page_documents_every_public_name() -> None:
    """docs/api.md has one ``::: module.NAME`` directive per name of ``femupdate.__all__``,
    each naming where the object is defined."""
    import importlib
    import types

    import femupdate

    directives = re.findall(r"^::: ([\w.]+)$", (ROOT / "docs" / "api.md").read_text(),
                            flags=re.MULTILINE)
    documented = {path.rsplit(".", 1)[1]: path for path in directives}
    assert set(documented) == set(femupdate.__all__) - {"__version__"}
    for name, path in documented.items():
        module, attribute = path.rsplit(".", 1)
        public = getattr(femupdate, name)
        if isinstance(public, types.ModuleType):  # femupdate.simulate: callable as its function
            public = getattr(public, name)
        assert getattr(importlib.import_module(module), attribute) is public
