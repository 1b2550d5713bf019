"""The docs speak in the present tense: measurement history lives in docs/history.md only.

A page says what a thing does, when to choose it and one current figure with its command;
former figures, "before X", version stories and load averages go to docs/history.md. Two
checks: history lines are at most 5 % of the non-blank lines of docs/*.md (history.md
excluded), and no page is longer than 400 lines (the case-file reference and history.md
excepted). Each failure prints the per-page counts.
"""

from __future__ import annotations

import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[2] / "docs"
#: Pages the checks leave out: the history itself.
NOT_GUIDANCE = {"history.md"}
#: Pages allowed to be longer than MAX_LINES: the field-by-field reference, and the history.
LONG_PAGES = {"case-files.md", "history.md"}
MAX_LINES = 400
MAX_HISTORY_SHARE = 0.05
#: Words that mark a line as measurement history rather than guidance.
HISTORY = re.compile(
    r"\b(?:before|earlier|previously|formerly|no longer|used to|now|was|were|had|took|gave"
    r"|load average|load \d|at an earlier stop|this stop|since version|version \d+"
    r"|issue \d+|this session|one session|the session|fresh clone|scratch timings?"
    r"|the same day|tried|dropped|measured again)\b",
    re.IGNORECASE,
)

def is_history(line: str) -> bool:
    """Whether a line of a page carries a history marker (outside code, where it is a word)."""
    return HISTORY.search(line) is not None


def page_counts(page: Path) -> tuple[int, int, int]:
    """(lines, non-blank lines, history lines) of a page; fenced code blocks are not prose."""
    lines = page.read_text(encoding="utf-8").splitlines()
    nonblank = history = 0
    fenced = False
    for line in lines:
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not line.strip() or fenced:
            continue
        nonblank += 1
        history += is_history(line)
    return len(lines), nonblank, history


def pages() -> list[Path]:
    return sorted(p for p in DOCS.glob("*.md") if p.name not in NOT_GUIDANCE)


def counts_table(rows: dict[str, tuple[int, int, int]]) -> str:
    lines = [f"{'page':28s}{'lines':>7s}{'non-blank':>11s}{'history':>9s}{'share':>8s}"]
    for name, (n, nonblank, history) in sorted(rows.items(), key=lambda kv: -kv[1][2]):
        share = history / nonblank if nonblank else 0.0
        lines.append(f"{name:28s}{n:7d}{nonblank:11d}{history:9d}{share:8.1%}")
    return "\n".join(lines)


def test_the_markers_are_found() -> None:
    assert is_history("at an earlier stop it took 3 s")
    assert is_history("Before Broyden updates, 426 evaluations")
    assert is_history("measured at load average 13")
    assert is_history("since version 4 of the generator")
    assert not is_history("multistart-lm is the default search")
    assert not is_history("the beforehand")  # a marker is a whole word


def test_page_counts_skip_code_and_blank_lines(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("# Title\n\nbefore\n```text\nbefore\n```\nafter\n", encoding="utf-8")
    assert page_counts(page) == (7, 3, 1)


def test_history_lines_below_five_percent() -> None:
    rows = {p.name: page_counts(p) for p in pages()}
    nonblank = sum(r[1] for r in rows.values())
    history = sum(r[2] for r in rows.values())
    share = history / nonblank
    assert share <= MAX_HISTORY_SHARE, (
        f"{history} of {nonblank} non-blank lines of docs/*.md ({share:.1%}) are history, "
        f"above {MAX_HISTORY_SHARE:.0%}: move them to docs/history.md\n{counts_table(rows)}")


def test_no_page_over_400_lines() -> None:
    rows = {p.name: page_counts(p) for p in pages()}
    long = {name: r for name, r in rows.items() if r[0] > MAX_LINES and name not in LONG_PAGES}
    assert not long, (f"pages over {MAX_LINES} lines: {', '.join(sorted(long))}\n"
                      f"{counts_table(rows)}")


# The counts of a docs folder, page by page: python tests/docs/test_present_tense.py [DIR]
if __name__ == "__main__":
    import sys

    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else DOCS
    counts = {p.name: page_counts(p) for p in sorted(folder.glob("*.md"))
              if p.name not in NOT_GUIDANCE}
    if not counts:
        raise SystemExit(f"{folder}: no *.md pages")
    total_nonblank = sum(r[1] for r in counts.values())
    total_history = sum(r[2] for r in counts.values())
    print(counts_table(counts))
    print(f"all pages but history.md: {total_history} of {total_nonblank} non-blank lines "
          f"({total_history / total_nonblank:.1%}) are history")
