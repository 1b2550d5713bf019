"""The report in a real browser: headless Chromium opens the page alone, offline, and decodes
every image, with nothing logged to the console but the probe.

Needs Debian's ``chromium`` (``apt-get install -y chromium``); skipped without it.
"""

from __future__ import annotations

import json
import re
import subprocess
from html import unescape
from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")

pytestmark = pytest.mark.skipif(
    not CHROMIUM.exists(),
    reason="headless Chromium not installed (/usr/bin/chromium; Debian: apt-get install -y "
           "chromium): the report is not rendered in a browser")

#: Records, once the page has loaded, what the browser made of its images and which resources
#: it fetched (data URIs are not fetched: the list must stay empty).
PROBE = """<script>
window.addEventListener("load", () => {
  const images = Array.from(document.images);
  const result = {
    images: images.length,
    decoded: images.filter(i => i.complete && i.naturalWidth > 0).length,
    widths: images.map(i => i.naturalWidth),
    resources: performance.getEntriesByType("resource").map(e => e.name)};
  document.body.setAttribute("data-probe", JSON.stringify(result));
  console.log("probe: " + JSON.stringify(result));
});
</script>"""


def open_in_chromium(html: str, tmp_path: Path) -> tuple[dict, list[str]]:
    """Load ``html`` (with the probe) alone in an empty folder; the probe's result and the
    console messages."""
    folder = tmp_path / "page"
    folder.mkdir()
    page = folder / "report.html"
    page.write_text(html.replace("</body>", PROBE + "</body>"), encoding="utf-8")
    command = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
               "--no-first-run", "--disable-background-networking",
               "--disable-component-update", "--disable-sync",
               f"--user-data-dir={tmp_path / 'profile'}",
               "--host-resolver-rules=MAP * ~NOTFOUND",  # offline: no name resolves
               "--enable-logging=stderr", "--v=0", "--virtual-time-budget=10000",
               "--dump-dom", page.as_uri()]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = re.search(r'data-probe="([^"]*)"', proc.stdout)
    assert found, "the probe did not run: " + proc.stderr[-2000:]
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    return json.loads(unescape(found.group(1))), console


#: Once laid out, measures every table's horizontal overflow: how far each table (and the
#: whole page) is wider than the space it has, in CSS pixels (0: it fits).
OVERFLOW_PROBE = """<script>
window.addEventListener("load", () => {
  const page = document.documentElement;
  const tables = Array.from(document.querySelectorAll("table")).map(t => {
    const box = t.parentElement;  // the scrolling wrapper, or the section
    return {id: t.id || t.className || "?",
            over: box.classList.contains("scroll") ? box.scrollWidth - box.clientWidth
                  : t.getBoundingClientRect().width - box.clientWidth};
  });
  const result = {viewport: window.innerWidth, page: page.scrollWidth - page.clientWidth,
                  tables: tables};
  document.body.setAttribute("data-overflow", JSON.stringify(result));
});
</script>"""


def overflow_in_chromium(html: str, tmp_path: Path, width: int) -> dict:
    """The overflow probe's result for ``html`` laid out in a window ``width`` px wide."""
    folder = tmp_path / f"w{width}"
    folder.mkdir()
    page = folder / "report.html"
    page.write_text(html.replace("</body>", OVERFLOW_PROBE + "</body>"), encoding="utf-8")
    command = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-background-networking", "--disable-component-update",
               "--disable-sync", f"--user-data-dir={folder / 'profile'}",
               "--hide-scrollbars", f"--window-size={width},900",
               "--virtual-time-budget=10000", "--dump-dom", page.as_uri()]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = re.search(r'data-overflow="([^"]*)"', proc.stdout)
    assert found, "the probe did not run: " + proc.stderr[-2000:]
    return json.loads(unescape(found.group(1)))


def image_widths(html: str) -> list[int]:
    return [int(w) for w in re.findall(r'<img src="data:[^"]*" width="(\d+)"', html)]


def test_chromium_opens_the_report_alone_and_decodes_every_image(report: Path,
                                                                 tmp_path: Path) -> None:
    html = report.read_text(encoding="utf-8")
    probe, console = open_in_chromium(html, tmp_path)
    assert probe["images"] == 7 and probe["decoded"] == 7
    assert probe["widths"] == image_widths(html)  # decoded at the size the page declares
    assert probe["resources"] == []
    assert len(console) == 1 and "probe:" in console[0], console


def test_the_browser_check_sees_a_broken_page(tmp_path: Path) -> None:
    # A broken image, a file that is not there, one from the network and a script error: the
    # same checks fail on them.
    html = ('<!DOCTYPE html><html><body><img src="data:image/png;base64,AAAA" width="10">'
            '<img src="missing.png" width="10"><img src="http://example.com/x.png">'
            "<script>notDefined();</script></body></html>")
    probe, console = open_in_chromium(html, tmp_path)
    assert probe["images"] == 3 and probe["decoded"] == 0
    assert probe["resources"] == ["http://example.com/x.png"]
    assert any("Uncaught ReferenceError" in line for line in console), console


@pytest.mark.parametrize("width", [1280, 800])
@pytest.mark.parametrize("results", ["many_runs_dir", "wide_dir"])
def test_no_table_overflows_the_window(results: str, width: int, tmp_path: Path,
                                       request: pytest.FixtureRequest) -> None:
    # 25 runs of multistart-lm (stop codes, restarts), and 50 parameters: every table fits
    # the window's width, none scrolls sideways, and neither does the page.
    from femupdate.report.html import render_report

    html = render_report(request.getfixturevalue(results))
    probe = overflow_in_chromium(html, tmp_path, width)
    assert probe["viewport"] == width
    assert len(probe["tables"]) >= 8
    assert [t for t in probe["tables"] if t["over"] > 0.5] == [], probe
    assert probe["page"] <= 0, probe


def test_the_overflow_check_sees_a_table_too_wide(tmp_path: Path) -> None:
    cells = "".join(f"<td>{'x' * 30}{i}</td>" for i in range(12))
    html = (f'<!DOCTYPE html><html><body><div style="overflow-x: auto"><table id="wide">'
            f"<tr>{cells}</tr></table></div>{'<table><tr><td>1</td></tr></table>' * 7}"
            "</body></html>")
    probe = overflow_in_chromium(html, tmp_path, 800)
    over = {t["id"]: t["over"] for t in probe["tables"]}
    assert over["wide"] > 100
