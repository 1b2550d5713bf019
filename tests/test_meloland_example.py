"""The Meloland Road Overcrossing example (examples/meloland): a real instrumented bridge.

Runs the example's case with a small budget on the two CSMIP archives in ../shared/data
(skipped when they are absent): the case loads with both events, the fitted model matches the
2010 records better than the nominal model (the literature's values), and it is scored on the
unseen 1979 records.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from data.test_data_io import need
from femupdate.case import load_case
from femupdate.cli import app

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "meloland" / "meloland.toml"
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


@pytest.mark.slow
def test_fits_better_than_nominal_and_validates_on_the_other_event(tmp_path: Path) -> None:
    need("cesmd_meloland/calexico2010_ce01336.zip")
    need("cesmd_meloland/imperialvalley1979_ce01336.zip")
    case = load_case(CASE)
    nominal = {p.name: p.nominal_value for p in case.parameters}
    (tmp_path / "nominal.json").write_text(json.dumps(nominal))
    _cli("validate", str(CASE), "--params", str(tmp_path / "nominal.json"),
         "--json", str(tmp_path / "nominal-out.json"))
    _cli("run", str(CASE), "--out", str(tmp_path / "run"), "--runs", "1",
         "--max-evals", "300")
    _cli("validate", str(CASE), "--params", str(tmp_path / "run" / "summary.json"),
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
