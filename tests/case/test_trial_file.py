"""A trial's ``file``: every channel of the trial read from one other file (another event of
one station, archived under the same channel numbers)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.errors import ConfigError
from femupdate.trials.experiment import load_experiments
from two_storey_case import two_storey_spec


def _case(directory: Path, trials: list[dict]) -> object:
    return parse_case(two_storey_spec(directory, trials=trials), source=directory / "c.toml")


def test_file_replaces_the_file_of_every_channel(tmp_path: Path) -> None:
    case = _case(tmp_path, [{"name": "first"},
                            {"name": "second", "role": "validate", "file": "event2.csv"}])
    first, second = case.trial_specs()
    assert first.data.input.file == "table.csv"
    assert {o.file for o in first.data.outputs} == {"floors.csv"}
    assert second.data.input.file == "event2.csv"
    assert [o.file for o in second.data.outputs] == ["event2.csv", "event2.csv"]
    # the channels themselves are [data]'s: same columns, nodes and DOFs
    assert [(o.column, o.node, o.dof) for o in second.data.outputs] == [
        (o.column, o.node, o.dof) for o in first.data.outputs]


def test_file_replaces_the_files_of_the_trials_own_channels_too(tmp_path: Path) -> None:
    own = {"file": "x.csv", "column": "a1", "node": "F1", "dof": "ux"}
    case = _case(tmp_path, [{"name": "t", "file": "event2.csv", "outputs": [own]}])
    (spec,) = case.trial_specs()
    assert [o.file for o in spec.data.outputs] == ["event2.csv"]
    assert spec.data.input.file == "event2.csv"


def test_a_trial_without_file_keeps_the_fingerprint(tmp_path: Path) -> None:
    # cases written before the field existed keep their fingerprint (resumable runs)
    case = _case(tmp_path, [{"name": "first"}])
    assert "file" not in case.to_dict()["trials"][0]
    with_file = _case(tmp_path, [{"name": "first", "file": "event2.csv"}])
    assert with_file.to_dict()["trials"][0]["file"] == "event2.csv"
    assert with_file.fingerprint() != case.fingerprint()


def test_file_must_be_a_string(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"trials\[0\]\.file"):
        _case(tmp_path, [{"name": "t", "file": 3}])


def test_the_records_are_read_from_the_trials_file(tmp_path: Path) -> None:
    """Two events in two CSV files of the same columns: each trial reads its own."""
    t = np.arange(400) / 100.0
    rng = np.random.default_rng(7)
    for name, gain in (("event1.csv", 1.0), ("event2.csv", 2.0)):
        rows = np.column_stack([t, gain * rng.standard_normal((t.size, 3))])
        np.savetxt(tmp_path / name, rows, delimiter=",", header="t,table,a1,a2", comments="")
    spec = two_storey_spec(tmp_path, trials=[{"name": "one", "file": "event1.csv"},
                                             {"name": "two", "file": "event2.csv"}])
    case = parse_case(spec, source=tmp_path / "c.toml")
    one, two = load_experiments(case)
    ratio = np.std(two.ag) / np.std(one.ag)
    assert ratio == pytest.approx(2.0, rel=0.2)
