"""`femupdate modes` of a frame held only by Bouc–Wen links, with Rayleigh damping
(examples/hysteresis/portal-on-links.toml): its modes from the initial stiffness and its
damping ratios from the damping matrix, on the dense path and on the reduced (sparse) one:
ζ = β ω / 2 for every mode (C = β K₀ is proportional)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from femupdate.cli.commands import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "hysteresis"
PORTAL = (EXAMPLE / "portal-on-links.toml").read_text()
BETA = 2e-4  # its [model] rayleigh


def _modes(tmp_path: Path, text: str) -> dict[str, list[float]]:
    case, out = tmp_path / "portal.toml", tmp_path / "modes.json"
    case.write_text(text)
    result = CliRunner().invoke(app, ["modes", str(case), "--json", str(out)])
    assert result.exit_code == 0, result.output
    assert " 0.000 │" not in result.output and "100.000" not in result.output
    return json.loads(out.read_text())


@pytest.mark.parametrize("method", ["", '[simulation]\nmethod = "reduced"\n'])
def test_frame_on_links_has_rayleigh_ratios(tmp_path: Path, method: str) -> None:
    got = _modes(tmp_path, PORTAL + method)
    f = np.array(got["frequencies_hz"])
    zeta = np.array(got["damping_ratios"])
    assert f[0] == pytest.approx(5.373, abs=1e-3)  # the sway of the frame on its links
    np.testing.assert_allclose(zeta[:f.size], BETA * np.pi * f, rtol=1e-8)
    np.testing.assert_allclose(got["damped_frequencies_hz"][:f.size],
                               f * np.sqrt(1.0 - zeta[:f.size] ** 2), rtol=1e-8)


def test_dense_and_reduced_modes_agree(tmp_path: Path) -> None:
    dense = _modes(tmp_path, PORTAL)
    reduced = _modes(tmp_path, PORTAL + '[simulation]\nmethod = "reduced"\n')
    n = len(reduced["frequencies_hz"])
    np.testing.assert_allclose(reduced["frequencies_hz"], dense["frequencies_hz"][:n],
                               rtol=1e-8)
