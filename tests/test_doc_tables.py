"""benchmarks/doc_tables.py: the Markdown tables the benchmark scripts write for the docs."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

HELPER = Path(__file__).resolve().parents[1] / "benchmarks" / "doc_tables.py"
_spec = importlib.util.spec_from_file_location("doc_tables", HELPER)
doc_tables = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(doc_tables)


def test_write_table_writes_the_table_and_its_command(tmp_path: Path) -> None:
    path = doc_tables.write_table("demo-table", ("method", "µs"), [("ab", 13.0), ("ib", "12.5")],
                                  "python benchmarks/demo.py --table", "Load 1.0.",
                                  directory=tmp_path)
    assert path == tmp_path / "demo-table.md"
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[:4] == ["| method | µs |", "|---|---|", "| ab | 13.0 |", "| ib | 12.5 |"]
    assert lines[-1].startswith("*Written by `python benchmarks/demo.py --table` on ")
    assert lines[-1].endswith(". Load 1.0.*")


def test_the_default_directory_is_docs_tables() -> None:
    assert doc_tables.TABLES == HELPER.parents[1] / "docs" / "tables"


@pytest.mark.parametrize("name", ["Bad", "has space", "../up", "trailing-", ""])
def test_a_bad_name_is_refused(name: str, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="table name"):
        doc_tables.write_table(name, ("a",), [("1",)], "cmd", directory=tmp_path)


def test_a_row_of_the_wrong_width_or_a_pipe_is_refused() -> None:
    with pytest.raises(ValueError, match="row 1: 1 cells, the header has 2"):
        doc_tables.markdown_table(("a", "b"), [("1",)])
    with pytest.raises(ValueError, match=r"holds '\|'"):
        doc_tables.markdown_table(("a",), [("x | y",)])


def test_the_committed_tables_are_included_by_the_benchmarks_page() -> None:
    page = (HELPER.parents[1] / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    for table in sorted(doc_tables.TABLES.glob("*.md")):
        assert f'--8<-- "tables/{table.name}"' in page, f"{table.name} is not included"
