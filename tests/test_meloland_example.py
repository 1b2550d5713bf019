"""The Meloland Road Overcrossing example (examples/meloland): a real instrumented bridge.

Runs the example's case with a small budget on the two CSMIP archives in ../shared/data
(skipped when they are absent): the case loads with both events, the fitted model matches the
2010 records better than the nominal model (the literature's values), and it is scored on the
unseen 1979 records.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import signal
from typer.testing import CliRunner

from data.test_data_io import need
from femupdate.case import load_case
from femupdate.cli.commands import app

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "meloland"
CASE = EXAMPLE / "meloland.toml"
MULTI = EXAMPLE / "multisupport.toml"
sys.path.insert(0, str(EXAMPLE))  # the script is an example, not part of the package
import spectral_ratio  # noqa: E402

FIT, CHECK = "calexico-2010", "imperial-valley-1979"
CHANNELS = {"ch3-deck-S-abutment", "ch5-deck-S-span", "ch7-deck-bent", "ch9-deck-N-span",
            "ch13-deck-N-abutment"}


def _cli(*args: str) -> None:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "120"})
    assert result.exit_code == 0, result.output


def _trials(path: Path) -> dict[str, dict]:
    data = json.loads(path.read_text())
    return {t["name"]: t for t in data["trials"]}


def test_case_names_both_events_and_the_transverse_deck_channels() -> None:
    case = load_case(CASE)
    roles = {t.name: t.role for t in case.trials}
    assert roles == {FIT: "fit", CHECK: "validate"}
    assert [p.name for p in case.parameters] == ["k_col", "k_abut", "alpha", "beta"]


def test_multisupport_case_drives_each_support_by_its_ground_record() -> None:
    """The bent's spring ends on the footing (channel 2), each abutment's on its embankment
    (2010: channels 11 and 26; 1979: channel 11 for both, 26 being on the other recorder)."""
    case = load_case(MULTI)
    uniform = load_case(CASE)
    roles = {t.name: t.role for t in case.trials}
    assert roles == {FIT: "fit", CHECK: "validate"}
    assert case.parameters == uniform.parameters
    groups = {g.name: g.nodes for g in case.model.support_groups}
    assert groups == {"south": ["G_SA"], "bent": ["G_BENT"], "north": ["G_NA"]}
    specs = {s.name: s.data for s in case.trial_specs()}
    columns = {name: {g: (c.file, c.column) for g, c in data.inputs.items()}
               for name, data in specs.items()}
    assert columns[FIT] == {"south": ("calexico2010_ce01336.zip", 11),
                            "bent": ("calexico2010_ce01336.zip", 2),
                            "north": ("calexico2010_ce01336.zip", 26)}
    assert columns[CHECK] == {"south": ("imperialvalley1979_ce01336.zip", 11),
                              "bent": ("imperialvalley1979_ce01336.zip", 2),
                              "north": ("imperialvalley1979_ce01336.zip", 11)}
    for data in specs.values():
        assert {c.label for c in data.outputs} == CHANNELS
    # the same deck: with every support moved alike it has the uniform model's modes
    from femupdate.model.modes import natural_frequencies
    from femupdate.problem.case_model import CaseModel

    nominal = case.nominal()
    f_multi = natural_frequencies(CaseModel(case).system(nominal)).freqs_hz
    f_uniform = natural_frequencies(CaseModel(uniform).system(nominal)).freqs_hz
    np.testing.assert_allclose(f_multi, f_uniform, rtol=1e-10)


@pytest.mark.slow
@pytest.mark.parametrize("path", [CASE, MULTI], ids=["uniform", "multisupport"])
def test_fits_better_than_nominal_and_validates_on_the_other_event(tmp_path: Path,
                                                                   path: Path) -> None:
    need("cesmd_meloland/calexico2010_ce01336.zip")
    need("cesmd_meloland/imperialvalley1979_ce01336.zip")
    case = load_case(path)
    nominal = {p.name: p.nominal_value for p in case.parameters}
    (tmp_path / "nominal.json").write_text(json.dumps(nominal))
    _cli("validate", str(path), "--params", str(tmp_path / "nominal.json"),
         "--json", str(tmp_path / "nominal-out.json"))
    _cli("run", str(path), "--out", str(tmp_path / "run"), "--runs", "1",
         "--max-evals", "300")
    _cli("validate", str(path), "--params", str(tmp_path / "run" / "summary.json"),
         "--json", str(tmp_path / "best-out.json"))
    before = _trials(tmp_path / "nominal-out.json")
    after = _trials(tmp_path / "best-out.json")
    assert set(after) == {FIT, CHECK}
    for name in (FIT, CHECK):
        assert set(after[name]["nmse_per_channel"]) == CHANNELS
    # the fit improves on the literature's values on the event it is fitted to ...
    assert after[FIT]["phi"] < 0.8 * before[FIT]["phi"]
    # ... and predicts the unseen event: every deck channel's shape, NMSE below 100 %
    assert all(v < 1.0 for v in after[CHECK]["nmse_per_channel"].values())
    assert after[CHECK]["phi"] < before[CHECK]["phi"]


def test_spectral_ratio_finds_the_frequency_of_a_base_excited_oscillator() -> None:
    """White noise through an oscillator of 3 Hz, 5 % damping: the peak of the absolute
    acceleration's transmissibility, (1 + (2 ζ r)²) / ((1 - r²)² + (2 ζ r)²), is at r ≈ 1."""
    rate, fn, zeta = 100.0, 3.0, 0.05
    wn = 2 * np.pi * fn
    # absolute acceleration over base acceleration: (2 ζ wn s + wn²) / (s² + 2 ζ wn s + wn²)
    system = signal.lti([2 * zeta * wn, wn**2], [1.0, 2 * zeta * wn, wn**2])
    base = np.random.default_rng(35).standard_normal(12_000)
    t = np.arange(base.size) / rate
    _, deck, _ = signal.lsim(system, base, t)
    f, gain = spectral_ratio.peak_frequency(base, deck, rate)
    assert abs(f - fn) <= 1 / spectral_ratio.SEGMENT_S
    assert gain > 5.0  # about 1 / (2 ζ) = 10 at resonance, smeared by the segments


def test_spectral_ratio_of_both_events() -> None:
    data = need("cesmd_meloland/calexico2010_ce01336.zip").parent
    need("cesmd_meloland/imperialvalley1979_ce01336.zip")
    for archive in spectral_ratio.EVENTS.values():
        base, deck = spectral_ratio.read_network_records(data / archive, channels=[2, 7])
        f, _ = spectral_ratio.peak_frequency(base.acceleration, deck.acceleration, base.rate)
        assert 2.5 < f < 3.5  # the deck's first transverse mode, near 2.9 Hz in both
