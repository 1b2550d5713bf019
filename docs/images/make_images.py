"""Make the pictures of the README and the docs' front page, with femupdate itself.

    python docs/images/make_images.py [--data ../shared/data]

- ``one-storey-fit.png``: the README's worked case (``examples/quickstart/one-storey.toml``,
  the real one-storey specimen) run by ``femupdate run``, its report written by ``femupdate
  report``, and the first figure of the report's section "Measured against predicted" taken
  out of ``report.html`` as it is embedded there;
- ``docs-front-page.png``: the site built by ``mkdocs build`` and its front page rendered by
  headless Chromium at 1280 × 900.

Needs the shared data folder (the specimen's records) and, for the screenshot, ``chromium``.
"""

from __future__ import annotations

import argparse
import base64
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
CASE = "examples/quickstart/one-storey.toml"
SECTION = "Measured against predicted"


def first_figure_after(html: str, heading: str) -> bytes:
    """The PNG bytes of the first image embedded after the heading that contains ``heading``."""
    start = next(m.end() for m in re.finditer(r"<h2[^>]*>([^<]*)", html) if heading in m[1])
    image = re.search(r"data:image/png;base64,([A-Za-z0-9+/=]+)", html[start:])
    if image is None:
        raise SystemExit(f"no figure after {heading!r} in the report")
    return base64.b64decode(image[1])


def femupdate(*args: str, cwd: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    subprocess.run([sys.executable, "-m", "femupdate", *args], cwd=cwd, env=env, check=True)


def report_figure(data: Path) -> None:
    """Run the worked case in a scratch folder laid out like the checkout; keep the figure."""
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch) / "repo"
        work.mkdir()
        (work / "examples").symlink_to(REPO / "examples", target_is_directory=True)
        femupdate("run", CASE, "--out", "results", "--data", str(data), cwd=work)
        femupdate("report", "results", cwd=work)
        html = (work / "results" / "report.html").read_text(encoding="utf-8")
    (HERE / "one-storey-fit.png").write_bytes(first_figure_after(html, SECTION))


def front_page() -> None:
    """Build the site and screenshot its front page."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        raise SystemExit("chromium not found (apt-get install -y chromium)")
    with tempfile.TemporaryDirectory() as scratch:
        site = Path(scratch) / "site"
        subprocess.run([sys.executable, "-m", "mkdocs", "build", "--site-dir", str(site)],
                       cwd=REPO, check=True)
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                        "--hide-scrollbars", f"--screenshot={HERE / 'docs-front-page.png'}",
                        "--window-size=1280,900", (site / "index.html").as_uri()], check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data",
                        help="the shared data folder (holding minishake_1story/)")
    args = parser.parse_args()
    report_figure(args.data.resolve() / "minishake_1story")
    front_page()


if __name__ == "__main__":
    main()
