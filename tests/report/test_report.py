"""``write_report``: one self-contained HTML file that holds summary.json's numbers, every image
embedded and decodable, values at a bound flagged, the truth of a virtual experiment beside the
estimates, and what cannot be drawn said."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from conftest import DESCRIPTION

from femupdate.errors import FemupdateError
from femupdate.report.html import (
    BOUND_TOL,
    bound_flags,
    bound_positions,
    format_number,
    spectrum_limit,
    write_report,
)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
DATA_PNG = "data:image/png;base64,"


class Page(HTMLParser):
    """Image sources, and the tables with an id as rows of (text, class) cells."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.images: list[str] = []
        self.figures: list[str] = []
        #: Every src= and href= of the page.
        self.links: list[str] = []
        self.tables: dict[str, list[list[tuple[str, str]]]] = {}
        self.ids: set[str] = set()
        #: Ids given more than once (none on a valid page).
        self.repeated_ids: list[str] = []
        self._table: str | None = None
        self._cell: list[str] | None = None
        self._cls = ""
        self.feed(text)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if a.get("id"):
            if a["id"] in self.ids:
                self.repeated_ids.append(a["id"] or "")
            self.ids.add(a["id"] or "")
        self.links += [v or "" for k, v in attrs if k in ("src", "href")]
        if tag == "figure":
            self.figures.append((a.get("id") or "").removeprefix("figure-"))
        if tag == "img":
            self.images.append(a["src"] or "")
        elif tag == "table" and a.get("id"):
            self._table = a["id"]
            self.tables[self._table] = []
        elif tag == "tr" and self._table is not None:
            self.tables[self._table].append([])
        elif tag in ("td", "th") and self._table is not None:
            self._cell, self._cls = [], a.get("class") or ""

    def handle_endtag(self, tag: str) -> None:
        if tag == "table":
            self._table = None
        elif tag in ("td", "th") and self._cell is not None and self._table is not None:
            self.tables[self._table][-1].append(("".join(self._cell).strip(), self._cls))
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)

    def rows(self, table: str) -> list[dict[str, tuple[str, str]]]:
        """Body rows of a table as {header: (text, class)}."""
        header, *body = self.tables[table]
        return [dict(zip([h for h, _ in header], row, strict=True)) for row in body]

    def run_parameters(self) -> list[dict[str, tuple[str, str]]]:
        """The rows of the runs' parameter tables (``run-parameters``, ``-2`` …) joined."""
        ids = sorted((t for t in self.tables if t.startswith("run-parameters")),
                     key=lambda t: int(t.rsplit("-", 1)[1]) if t[-1].isdigit() else 1)
        joined: list[dict[str, tuple[str, str]]] = []
        for k, ident in enumerate(ids):
            for i, row in enumerate(self.rows(ident)):
                if k == 0:
                    joined.append(row)
                else:
                    assert row["run"] == joined[i]["run"]
                    joined[i].update(row)
        return joined


def parse(path: Path) -> tuple[Page, str]:
    text = path.read_text(encoding="utf-8")
    return Page(text), text


def number(cell: str) -> float:
    """A printed number back (thousands separators, plain exponents)."""
    return float(cell.split()[0].replace(",", ""))


def assert_printed(cell: str, value: float, digits: int = 4) -> None:
    """The cell shows ``value`` to ``digits`` significant digits."""
    rtol = 0.5 * 10.0 ** (1 - digits)
    assert math.isclose(number(cell), value, rel_tol=rtol, abs_tol=1e-300), (cell, value)


# ----------------------------------------------------------------------------- pure functions


@pytest.mark.parametrize(("value", "text"), [
    (1234.5678, "1235"), (0.012345678, "0.01235"), (2.1e11, "2.1e11"), (3.5e-5, "3.5e-5"),
    (-123456.0, "-1.235e5"), (12345, "12,345"), (0.0, "0"), (None, "–"), (math.nan, "–"),
    (math.inf, "∞"), (np.int64(300), "300"), (1.0, "1"), (1e4, "10000"), (0.5, "0.5"),
])
def test_format_number(value: object, text: str) -> None:
    assert format_number(value) == text


def test_bound_positions_linear_and_log() -> None:
    lower, upper = np.array([0.0, 500.0]), np.array([5.0, 5000.0])
    log = np.array([False, True])
    values = np.array([[0.0, 500.0], [5.0, 5000.0], [1.25, math.sqrt(500.0 * 5000.0)],
                       [2.5, -1.0]])
    pos = bound_positions(values, lower, upper, log)
    np.testing.assert_allclose(pos[:3], [[0.0, 0.0], [1.0, 1.0], [0.25, 0.5]], atol=1e-12)
    assert pos[3, 0] == 0.5 and pos[3, 1] == -np.inf  # a log parameter ≤ 0: below its bound


def test_bound_flags_use_the_tolerance_of_the_range() -> None:
    pos = np.array([0.0, 0.5 * BOUND_TOL, 2 * BOUND_TOL, 0.5, 1 - 2 * BOUND_TOL,
                    1 - 0.5 * BOUND_TOL, 1.0, -np.inf])
    assert bound_flags(pos).tolist() == [-1, -1, 0, 0, 0, 1, 1, -1]


def test_spectrum_limit() -> None:
    f = np.linspace(0.0, 100.0, 101)
    amp = np.zeros((101, 2))
    amp[10, 0] = 1.0  # all the energy at 10 Hz
    assert spectrum_limit(f, amp) == 15.0
    amp[90, 1] = 1.0  # half of it at 90 Hz: 1.5 × 90 is beyond Nyquist
    assert spectrum_limit(f, amp) == 100.0
    assert spectrum_limit(f, np.zeros(101)) == 100.0


# ----------------------------------------------------------------------------- the report


def decode_png(src: str) -> np.ndarray:
    """An embedded image back as pixels (rows, columns, channels)."""
    import base64
    import io

    from matplotlib.image import imread

    assert src.startswith(DATA_PNG), src[:40]
    data = base64.b64decode(src.removeprefix(DATA_PNG), validate=True)
    assert data[:8] == PNG_SIGNATURE
    return imread(io.BytesIO(data), format="png")


def assert_self_contained(page: Page, text: str) -> None:
    """Every src= and href= is a data URI or an anchor on the page; nothing else is loaded."""
    for link in page.links:
        assert link.startswith(("data:", "#")), link[:60]
        if link.startswith("#"):
            assert link[1:] in page.ids, link
    assert not page.repeated_ids, f"ids given more than once: {page.repeated_ids}"
    for tag in ("<link", "<script", "<iframe", "<object", "<embed", "url(", "@import"):
        assert tag not in text.lower(), tag


def test_every_image_is_embedded_and_decodes(report: Path) -> None:
    page, text = parse(report)
    assert report.name == "report.html"
    assert set(page.figures) == {"phi", "beta", "parameters", "spread", "fit", "spectra",
                                 "correlation"}
    assert len(page.images) == len(page.figures)
    for src in page.images:
        image = decode_png(src)
        assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    assert_self_contained(page, text)
    assert not (report.parent / "report").exists()  # no figure files beside the page


def test_the_page_alone_is_the_whole_report(report: Path, tmp_path: Path) -> None:
    # Moved away from its results directory, the page has everything it shows.
    alone = tmp_path / "alone.html"
    alone.write_bytes(report.read_bytes())
    page, text = parse(alone)
    assert_self_contained(page, text)
    assert "results.sqlite" not in "".join(page.links)


def test_runs_table_holds_the_summary(report: Path, summary: dict) -> None:
    page, text = parse(report)
    rows = page.rows("runs")
    assert len(rows) == len(summary["runs"]) == 3
    names = list(summary["best"]["params"])
    for row, run in zip(rows, summary["runs"], strict=True):
        run_cell = row["run"][0]
        assert int(run_cell.split()[0]) == run["index"]
        assert ("best" in run_cell) == (run["index"] == summary["best"]["run"])
        assert_printed(row["NMSE %"][0], 100.0 * run["phi"])
        assert int(row["evaluations"][0].replace(",", "")) == run["nfev"]
        assert row["success"][0] == ("yes" if run["success"] else "no")
        assert row["stop"] == ("max_evals", "code")  # the code; in full in the legend
        assert "restarts" not in row  # no run restarted
    assert '<p class="note" id="stop-legend">stop: max_evals = 300 (3 runs).</p>' in text
    params = page.run_parameters()
    assert [int(r["run"][0]) for r in params] == [r["index"] for r in summary["runs"]]
    for row, run in zip(params, summary["runs"], strict=True):
        for name in names:
            cell = next(v for k, v in row.items() if k.split()[0] == name)
            assert_printed(cell[0], run["params"][name])


def test_best_parameters_and_frequencies(report: Path, summary: dict) -> None:
    page, text = parse(report)
    best = summary["best"]
    for row in page.rows("spread"):
        name = row["parameter"][0]
        assert_printed(row["best"][0], best["params"][name])
    freqs = page.rows("frequencies")
    assert len(freqs) == len(best["frequencies_hz"]) == 2
    for row, f in zip(freqs, best["frequencies_hz"], strict=True):
        assert_printed(row["best model [Hz]"][0], f)
    channels = {r["channel"][0]: r["NMSE %"][0] for r in page.rows("channels-nmse")}
    for ch, value in best["nmse_per_channel"].items():
        assert_printed(channels[ch], 100.0 * value)
    # The re-simulated best model reproduces the stored φ: no warning.
    assert "changed since the runs" not in text


def test_case_section_and_escaping(report: Path) -> None:
    page, text = parse(report)
    assert "&lt;b&gt;test&lt;/b&gt; &amp; friends" in text
    assert DESCRIPTION not in text
    params = {r["parameter"][0]: r for r in page.rows("parameters")}
    assert params["k2"]["scale"][0] == "log" and number(params["k2"]["upper"][0]) == 5000.0
    assert params["c1"]["unit"][0] == "N·s/m"
    assert "numpy" in text and "<script" not in text  # versions from the store; no JavaScript
    assert "Rayleigh" not in text  # the model has none


def test_identifiability_section(report: Path) -> None:
    page, _ = parse(report)
    rows = page.rows("identifiability")
    assert [r["parameter"][0] for r in rows] == ["k1", "k2", "c1", "c2"]
    for r in rows:
        assert number(r["Δφ for a 1 % change"][0]) >= 0.0
        assert r["determined"][0] in ("yes", "no")
    assert "undetermined" in page.ids


@pytest.mark.usefixtures("tables_only")
def test_parameters_at_a_bound_are_flagged(copy_results: Callable[[], Path]) -> None:
    out = copy_results()
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    summary["runs"][0]["params"]["c2"] = 0.0                 # exactly the lower bound
    summary["runs"][1]["params"]["k2"] = 5000.0 * (1 - 1e-4)  # log scale, within 1e-3
    summary["runs"][2]["params"]["c1"] = 0.02                 # 4e-3 of the range: inside
    path.write_text(json.dumps(summary))
    page, _ = parse(write_report(out))
    rows = page.rows("runs")
    params = page.run_parameters()
    assert rows[0]["improper minimum"] == ("c2 (lower)", "bound")
    assert "bound" in params[0]["c2 [N·s/m]"][1]
    assert rows[1]["improper minimum"] == ("k2 (upper)", "bound")
    assert "bound" not in params[2]["c1 [N·s/m]"][1]
    assert rows[2]["improper minimum"] == ("", "")
    assert "improper" in page.ids


@pytest.mark.usefixtures("tables_only")
def test_restarts_are_shown_with_the_stop(copy_results: Callable[[], Path]) -> None:
    out = copy_results()
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    summary["runs"][0]["restarts"] = 2
    summary["runs"][1]["restarts"] = 1
    path.write_text(json.dumps(summary))
    page, text = parse(write_report(out))
    rows = page.rows("runs")
    assert [r["restarts"][0] for r in rows] == ["2", "1", "0"]
    assert all(r["stop"][0] == "max_evals" for r in rows)  # the code stays short
    assert 'title="max_evals = 300 (after 2 restarts)"' in text  # in full on hovering


@pytest.mark.usefixtures("tables_only")
def test_runs_not_needed_are_counted_with_the_planned_runs(
        copy_results: Callable[[], Path]) -> None:
    out = copy_results()
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    summary["verdict"]["planned"] = 25  # as if the first 3 runs agreed ([search] agree)
    summary["settings"]["agree"] = 2
    path.write_text(json.dumps(summary))
    _, text = parse(write_report(out))
    assert "3 of 25 runs (the others were not needed) of" in text
    assert "3 of 25 (the others were not needed: [search] agree = 2)" in text


def test_without_store_or_fit_the_report_says_what_it_could_not_draw(
        copy_results: Callable[[], Path]) -> None:
    out = copy_results()
    (out / "results.sqlite").unlink()
    (out / "fit.npz").unlink()
    summary = json.loads((out / "summary.json").read_text())
    stale = out / "report" / "phi.png"  # a figure file of an earlier version's report
    stale.parent.mkdir()
    stale.write_bytes(PNG_SIGNATURE)

    page, text = parse(write_report(out))
    assert not stale.parent.exists()
    assert "missing" in page.ids
    assert "results.sqlite" in text and "fit.npz" in text
    for what in ("φ against evaluations", "a, b and σ against step",
                 "measured against predicted time histories and spectra"):
        assert f"{what} not drawn" in text
    assert set(page.figures) == {"spread", "correlation"}
    for src in page.images:
        decode_png(src)
    row = page.rows("frequencies")[0]
    assert_printed(row["best model [Hz]"][0], summary["best"]["frequencies_hz"][0])


def test_missing_summary_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FemupdateError, match=r"summary\.json") as info:
        write_report(tmp_path)
    assert str(tmp_path / "summary.json") in str(info.value)
    with pytest.raises(FemupdateError, match="results directory not found"):
        write_report(tmp_path / "nowhere")
    (tmp_path / "summary.json").write_text('{"case": ')
    with pytest.raises(FemupdateError, match=r"summary\.json:1:\d+: not valid JSON"):
        write_report(tmp_path)
    (tmp_path / "summary.json").write_text('{"case": {}}')
    with pytest.raises(FemupdateError, match=r"missing .*runs, best"):
        write_report(tmp_path)
