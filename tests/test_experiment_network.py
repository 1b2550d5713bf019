"""Cases reading network records ([data] format = "csmip" / "at2"): the channels chosen, their
units, the record checks they go through, and the events of a station compared."""

from __future__ import annotations

import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from data.test_data_io import need
from data.test_network import ARCHIVES, cosmos_channel, write_at2
from femupdate.case import parse_case
from femupdate.data.network import read_network_records
from femupdate.errors import ConfigError, DataError, FemupdateWarning
from femupdate.trials.experiment import load_experiment, load_experiments, read_measurement
from femupdate.trials.virtual import write_records
from femupdate.units import STANDARD_GRAVITY as G


def _case(folder: Path, input_column: Any, output_column: Any, *, file: str,
          trials: list[dict[str, Any]] | None = None, fmt: str = "csmip",
          **data: Any) -> Any:
    spec: dict[str, Any] = {
        "case": {"name": "meloland"},
        "model": {"shear_building": {"masses": [1000.0], "stiffnesses": ["k1"],
                                     "dampers": ["c1"]}},
        "parameters": [{"name": "k1", "lower": 1e5, "upper": 1e9, "scale": "log"},
                       {"name": "c1", "lower": 0.0, "upper": 1e5}],
        "data": {"format": fmt, "directory": str(folder),
                 "input": {"file": file, "column": input_column},
                 "outputs": [{"file": file, "column": output_column, "node": "F1",
                              "dof": "ux", "name": "deck"}], **data},
    }
    if trials is not None:
        spec["trials"] = trials
    return parse_case(spec, source=folder / "case.toml")


def test_a_case_reads_channels_of_an_archive_in_si_units() -> None:
    path = need(ARCHIVES[1])
    case = _case(path.parent, 2, "Deck: Middle of Bridge / Tran", file=path.name)
    m = read_measurement(case)
    footing, deck = read_network_records(path, [2, 7])
    assert m.n_samples == 8750 and m.dt == pytest.approx(0.01)
    # cm/s² in the file, m/s² here: the peaks of the header, scaled
    assert np.max(np.abs(m["input"])) == pytest.approx(abs(footing.peak) / 100, abs=1e-5)
    np.testing.assert_array_equal(m["deck"], deck.acceleration)
    experiment = load_experiment(case)
    assert experiment.defects == ()  # the checks ran and found nothing


def test_the_record_checks_run_on_network_channels() -> None:
    path = need(ARCHIVES[1])
    case = _case(path.parent, 7, "Deck: Middle of Bridge / Tran", file=path.name)
    with pytest.warns(FemupdateWarning, match="duplicate"):
        experiment = load_experiment(case)
    assert [f.kind for f in experiment.defects] == ["duplicate"]


def test_a_channel_the_archive_lacks_is_named() -> None:
    path = need(ARCHIVES[0])
    case = _case(path.parent, 2, 27, file=path.name)
    with pytest.raises(DataError, match=r"no channel 27 \(allowed: channels 1-26\)"):
        read_measurement(case)


def test_two_recorders_are_said_and_their_rates_need_resampling() -> None:
    path = need(ARCHIVES[0])  # 1979: recorder 0164 at 50 Hz, 0165 at 100 Hz, no start times
    case = _case(path.parent, 14, 7, file=path.name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        with pytest.raises(DataError, match=r"different rates.*CHAN14\.V2: 100 Hz.*resample_hz"):
            read_measurement(case)
    resampled = _case(path.parent, 14, 7, file=path.name)
    resampled = parse_case({**resampled.to_dict(), "preprocess": {"resample_hz": 100.0}},
                           source=path.parent / "case.toml")
    with pytest.warns(FemupdateWarning) as said:
        m = read_measurement(resampled)
    words = [str(w.message) for w in said]
    assert any("channels of different recorders" in w for w in words)
    assert any("differ in length" in w and "only their overlap is used" in w for w in words)
    assert "recorder 0164: channel 7" in m.notes[0]
    assert m.dt == pytest.approx(0.01)


def test_trials_on_two_events_say_their_channel_sets_differ() -> None:
    old, new = need(ARCHIVES[0]), need(ARCHIVES[1])
    trials = [{"name": "1979", "input": {"file": old.name, "column": 2},
               "outputs": [{"file": old.name, "column": 7, "node": "F1", "dof": "ux",
                            "name": "deck"}]},
              {"name": "2010", "role": "validate"}]
    case = _case(old.parent, 2, 7, file=new.name, trials=trials)
    with pytest.warns(FemupdateWarning, match=r"imperialvalley1979_ce01336.zip has no "
                                              r"channel 27-28"):
        experiments = load_experiments(case)
    assert [e.dt for e in experiments] == [0.02, 0.01]


def _event_folder(source: Path, folder: Path, relocate: str | None = None) -> Path:
    """Channels 2 and 7 of an archive as a folder; ``relocate`` moves channel 7 elsewhere."""
    folder.mkdir()
    with zipfile.ZipFile(source) as z:
        for name in ("CHAN002.V2", "CHAN007.V2"):
            text = z.read(name).decode("latin-1")
            if relocate and name == "CHAN007.V2":
                text = text.replace("Location: Deck: Middle of Bridge  ",
                                    f"Location: {relocate}", 1)
            (folder / name).write_text(text, encoding="latin-1")
    return folder


def test_a_channel_number_naming_two_sensors_in_two_events_is_refused(tmp_path: Path) -> None:
    source = need(ARCHIVES[1])
    _event_folder(source, tmp_path / "one")
    _event_folder(source, tmp_path / "two", relocate="Freefield")
    assert read_network_records(tmp_path / "two", [7])[0].location == "Freefield"
    trials = [{"name": "one", "directory": str(tmp_path / "one")},
              {"name": "two", "directory": str(tmp_path / "two")}]
    case = _case(tmp_path / "one", 2, 7, file=".", trials=trials)
    with pytest.raises(DataError, match=r"channel 7 is 'Deck: Middle of Bridge / Tran' in "
                                        r".*one but 'Freefield / Tran' in .*two"):
        load_experiments(case)
    # picked by location, each event gives its own channel: no conflict (one has no deck)
    by_place = _case(tmp_path / "one", 2, "Deck: Middle of Bridge / Tran", file=".",
                     trials=trials)
    with pytest.raises(DataError, match="no channel at 'Deck: Middle of Bridge / Tran'"):
        load_experiments(by_place)


def test_units_and_rates_come_from_the_header(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"unit.*network records say their units"):
        _case(tmp_path, 1, 1, file="a.AT2", fmt="at2", unit="g")
    with pytest.raises(ConfigError, match=r"rate.*their interval in the header"):
        _case(tmp_path, 1, 1, file="a.AT2", fmt="at2", rate=100.0)


def test_a_virtual_experiment_does_not_write_network_records(tmp_path: Path) -> None:
    case = _case(tmp_path, 1, 1, file="a.AT2", fmt="at2")
    with pytest.raises(ConfigError, match="read, not written"):
        write_records(case, tmp_path, np.arange(3) * 0.01,
                      {"input": np.zeros(3), "deck": np.zeros(3)})


def test_an_at2_case(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    ground = 0.1 * rng.standard_normal(400)
    write_at2(tmp_path / "ground.AT2", ground, 0.01)
    write_at2(tmp_path / "deck.AT2", 2.0 * ground + 0.05 * rng.standard_normal(400), 0.01)
    case = _case(tmp_path, 1, 1, file="ground.AT2", fmt="at2")
    case = parse_case({**case.to_dict(), "data": {
        **case.to_dict()["data"],
        "outputs": [{"file": "deck.AT2", "column": 1, "node": "F1", "dof": "ux",
                     "name": "deck"}]}}, source=tmp_path / "case.toml")
    m = read_measurement(case)
    np.testing.assert_allclose(m["input"], ground * G, rtol=1e-7)
    assert m.n_samples == 400 and m.dt == pytest.approx(0.01)


def test_a_cosmos_case(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    ground = np.round(30.0 * rng.standard_normal(300), 5)
    roof = np.round(2.0 * ground + rng.standard_normal(300), 5)
    (tmp_path / "event.V2c").write_text("\n".join(
        cosmos_channel(ground, 0.005, number=1, direction="Up", location="Ground level")
        + cosmos_channel(roof, 0.005, number=9, direction="Up", location="Roof")) + "\n")
    case = _case(tmp_path, "Ground level", 9, file="event.V2c", fmt="cosmos")
    m = read_measurement(case)
    np.testing.assert_allclose(m["input"], ground / 100, rtol=0, atol=1e-15)
    np.testing.assert_allclose(m["deck"], roof / 100, rtol=0, atol=1e-15)
    assert m.rate == pytest.approx(200.0)
