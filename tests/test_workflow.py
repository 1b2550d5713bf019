"""The updating workflow end to end on a synthetic case, and bad input through it.

A two-storey shear building with storey stiffnesses and dampers as parameters: a virtual
experiment writes its CSV records from a known truth, ``run_case`` reads, processes and fits
them and writes summary.json. Noise-free records (no noise, offsets or drift) make the truth
the exact global minimum, so the fit must recover it.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from femupdate.case import load_case
from femupdate.errors import ConfigError, DataError
from femupdate.model.modes import natural_frequencies
from femupdate.pipeline.results import load_fits, read_summary
from femupdate.pipeline.run import UpdateResult, run_case
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import MODEL_AND_DATA, TRUTH

MASSES = (1.0, 0.8)
RATE = 200.0

CASE = MODEL_AND_DATA + """\
[objective]
quantity = "displacement"
experimental_parameters = true

[search]
method = "cmaes"
options = { popsize = 8 }
runs = 3
seed = 7
max_evals = 3000
f_target = 1e-8
"""


def _closed_form_frequencies(k1: float, k2: float) -> np.ndarray:
    """Roots of det(K − ω² M) = m1 m2 ω⁴ − (m1 k2 + m2 (k1 + k2)) ω² + k1 k2, in Hz."""
    m1, m2 = MASSES
    w2 = np.roots([m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2])
    return np.sort(np.sqrt(w2.real)) / (2 * np.pi)


def _write_case(folder: Path, text: str = CASE) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "case.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("two-storey")
    case = load_case(_write_case(folder))
    virtual_experiment(case, TRUTH, folder / "data", seed=3, rate=RATE, duration=4.0,
                       snr=0.0, offset=0.0, drift=0.0)
    return folder


@pytest.fixture(scope="module")
def result(case_dir: Path) -> UpdateResult:
    return run_case(load_case(case_dir / "case.toml"), case_dir / "out")


def test_virtual_experiment_writes_the_case_files(case_dir: Path) -> None:
    assert {p.name for p in (case_dir / "data").iterdir()} >= {"table.csv", "floors.csv",
                                                               "truth.json", "manifest.json"}
    assert json.loads((case_dir / "data" / "truth.json").read_text()) == TRUTH


def test_run_case_recovers_the_truth(result: UpdateResult) -> None:
    best = result.summary.best
    assert best.phi < 1e-8
    for name in ("k1", "k2"):
        assert best.params[name] == pytest.approx(TRUTH[name], rel=5e-3)
    for name in ("c1", "c2"):
        assert best.params[name] == pytest.approx(TRUTH[name], rel=2e-2)


def test_best_frequencies_are_the_truth_s(result: UpdateResult) -> None:
    exact = _closed_form_frequencies(TRUTH["k1"], TRUTH["k2"])
    truth_model, _ = natural_frequencies(result.problem.system(TRUTH))
    assert truth_model == pytest.approx(exact, rel=1e-12)
    assert result.summary.best.frequencies_hz == pytest.approx(exact, rel=2e-3)


def test_summary_json(result: UpdateResult, case_dir: Path) -> None:
    summary = json.loads((case_dir / "out" / "summary.json").read_text())
    assert len(summary["runs"]) == 3
    for run in summary["runs"]:
        assert {"seed", "success", "status", "stop", "phi", "nfev", "params"} <= set(run)
        assert set(run["params"]) == set(TRUTH)
        assert 1 <= run["nfev"] <= 3000
        # success means reaching f_target here
        assert run["success"] == (run["phi"] <= 1e-8)
        # runs that found the truth end inside the box, none at an improper minimum
        assert run["at_bounds"] == {} or not run["success"]
    assert {"phi", "params", "frequencies_hz"} <= set(summary["best"])
    assert summary["best"]["phi"] == min(run["phi"] for run in summary["runs"])
    assert set(summary["spread"]["params"]) == set(TRUTH)
    # Read back typed, equal to what the run returned; the best fit is kept beside it.
    assert read_summary(case_dir / "out" / "summary.json") == result.summary
    (fit,) = load_fits(case_dir / "out" / "fit.npz")
    assert fit.phi == pytest.approx(result.summary.best.phi, rel=1e-12)
    assert fit.channels == ("F1.ux", "F2.ux") and fit.role == "fit"


# ----------------------------------------------------------------------------- bad input


def _broken_copy(case_dir: Path, tmp_path: Path, text: str = CASE) -> Path:
    """A copy of the case and its records in ``tmp_path``; returns the data folder."""
    _write_case(tmp_path, text)
    shutil.copytree(case_dir / "data", tmp_path / "data")
    return tmp_path / "data"


def _run(tmp_path: Path) -> None:
    run_case(load_case(tmp_path / "case.toml"), None, runs=1, max_evals=5)


def _edit_floors(data: Path, row: int, column: int, value: str) -> int:
    """Replace one field of floors.csv; returns its 1-based line number."""
    path = data / "floors.csv"
    lines = path.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    fields = lines[first + row].split(",")
    fields[column] = value
    lines[first + row] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    return first + row + 1


def test_missing_data_file(case_dir: Path, tmp_path: Path) -> None:
    data = _broken_copy(case_dir, tmp_path)
    (data / "floors.csv").unlink()
    with pytest.raises(DataError, match="file not found") as info:
        _run(tmp_path)
    assert str(data / "floors.csv") in str(info.value)


def test_missing_column(case_dir: Path, tmp_path: Path) -> None:
    _broken_copy(case_dir, tmp_path, CASE.replace('column = "a2"', 'column = "a3"'))
    with pytest.raises(DataError) as info:
        _run(tmp_path)
    message = str(info.value)
    assert "floors.csv" in message and "'a3'" in message
    assert "'a1', 'a2'" in message  # the columns there are


def test_non_numeric_data(case_dir: Path, tmp_path: Path) -> None:
    line = _edit_floors(_broken_copy(case_dir, tmp_path), row=10, column=2, value="abc")
    with pytest.raises(DataError) as info:
        _run(tmp_path)
    message = str(info.value)
    assert "floors.csv" in message and "'abc'" in message and f"line {line}" in message
    assert "'a2'" in message


def test_nan_samples(case_dir: Path, tmp_path: Path) -> None:
    line = _edit_floors(_broken_copy(case_dir, tmp_path), row=20, column=2, value="nan")
    with pytest.raises(DataError) as info:
        _run(tmp_path)
    message = str(info.value)
    assert "floors.csv" in message and "nan" in message.lower() and f"line {line}" in message
    assert "'a2'" in message


def test_files_at_different_rates(case_dir: Path, tmp_path: Path) -> None:
    data = _broken_copy(case_dir, tmp_path)
    path = data / "floors.csv"
    lines = path.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    slow = [",".join([repr(2 * float(line.split(",")[0])), *line.split(",")[1:]])
            for line in lines[first + 1:]]
    path.write_text("\n".join(lines[:first + 1] + slow) + "\n")
    with pytest.raises(DataError) as info:
        _run(tmp_path)
    message = str(info.value)
    assert str(tmp_path / "case.toml") in message
    assert "table.csv: 200 Hz" in message and "floors.csv: 100 Hz" in message
    assert "set [preprocess] resample_hz = 200" in message
    assert "to resample all channels to one rate" in message
    # doing what the message says: the floors are resampled to 200 Hz, and the run proceeds
    text = CASE.replace("[objective]", "[preprocess]\nresample_hz = 200.0\n\n[objective]")
    _write_case(tmp_path, text)
    _run(tmp_path)


def _config_error(tmp_path: Path, text: str) -> str:
    path = _write_case(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_case(path)
    message = str(info.value)
    assert str(path) in message
    return message


def test_parameter_used_but_not_declared(tmp_path: Path) -> None:
    text = CASE.replace('dampers = ["c1", "c2"]', 'dampers = ["c1", "c3"]')
    message = _config_error(tmp_path, text)
    assert "model.shear_building.dampers[1]" in message and "'c3'" in message


def test_parameter_declared_but_unused(tmp_path: Path) -> None:
    text = CASE.replace("[data]", '[[parameters]]\nname = "k9"\nlower = 1.0\nupper = 2.0\n\n'
                        "[data]")
    message = _config_error(tmp_path, text)
    assert "parameters[4]" in message and "'k9'" in message and "never uses" in message


def test_reversed_bounds(tmp_path: Path) -> None:
    text = CASE.replace('name = "c2"\nlower = 0.0\nupper = 5.0',
                        'name = "c2"\nlower = 5.0\nupper = 0.5')
    message = _config_error(tmp_path, text)
    assert "parameters[3]" in message and "'c2'" in message
    assert "lower = 5" in message and "upper = 0.5" in message


# ----------------------------------------------------------------------------- channel delays

DELAY = 0.0173  # s: 3.46 samples at 200 Hz

DELAY_CASE = """\
[case]
name = "late roof"

[model.shear_building]
masses = [1.0]
stiffnesses = [4000.0]

[data]
format = "csv"
time_column = "t"

[data.input]
file = "records.csv"
column = "table"

[[data.outputs]]
file = "records.csv"
column = "roof"
node = "F1"
dof = "ux"
name = "roof"
{delay}
[preprocess]
highpass_hz = {highpass}

[objective]
quantity = "acceleration"
"""


TABLE_FREQS = np.arange(0.3, 40.0, 0.2)  # Hz: a broadband record, below 200 Hz's Nyquist
TABLE_PHASES = np.random.default_rng(11).uniform(0.0, 2 * np.pi, TABLE_FREQS.size)


def _table(t: np.ndarray) -> np.ndarray:
    """A sum of sines on a 0.2 Hz grid with random phases: known exactly at any time."""
    waves = np.sin(2 * np.pi * TABLE_FREQS * t[:, None] + TABLE_PHASES)
    return waves.sum(axis=1) / np.sqrt(TABLE_FREQS.size)


@pytest.fixture(scope="module")
def late_records(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """table(t) and a roof that moves with the table but is recorded DELAY late."""
    folder = tmp_path_factory.mktemp("late")
    t = np.arange(4000) / RATE + 1.5  # the clock does not start at 0
    rows = np.column_stack([t, _table(t), _table(t - DELAY)])
    np.savetxt(folder / "records.csv", rows, delimiter=",", header="t,table,roof",
               comments="")
    return folder


def _experiment(folder: Path, delay: str, highpass: float = 0.0):
    from femupdate.trials.experiment import load_experiment

    path = folder / f"case-{abs(hash((delay, highpass)))}.toml"
    path.write_text(DELAY_CASE.format(delay=delay, highpass=highpass))
    return load_experiment(load_case(path))


@pytest.mark.parametrize(("delay", "highpass"), [
    (f"delay = {DELAY}", 0.0), ('delay = "auto"', 0.0), ('delay = "auto"', 0.5),
])
def test_a_late_channel_is_realigned(late_records: Path, delay: str, highpass: float) -> None:
    exp = _experiment(late_records, delay, highpass)
    assert set(exp.delays) == {"roof"}
    assert exp.delays["roof"] == pytest.approx(DELAY, abs=2e-5)
    # ceil(3.46) samples beyond the record and 4 where the shift is approximate, at each end
    trim = 4 + 4
    assert exp.t.size == 4000 - 2 * trim
    np.testing.assert_allclose(exp.t, np.arange(exp.t.size) / RATE, atol=1e-9)
    # the roof now moves with the table, sample for sample, but for the error of the
    # estimated delay times the table's largest slope (40 Hz at most: 2π 40 Σ|amplitudes|)
    roof, table = exp.accelerations[:, 0], exp.ag
    scale = np.std(table)
    slope = 2 * np.pi * TABLE_FREQS.sum() / np.sqrt(TABLE_FREQS.size)
    missed = abs(exp.delays["roof"] - DELAY) * slope
    assert np.max(np.abs(roof - table)) < 5e-3 * scale + missed
    assert np.max(np.abs(roof - table)[100:-100]) < 1e-4 * scale + missed
    if highpass == 0.0:  # no filter: the table record itself, trimmed
        t = np.arange(4000) / RATE + 1.5
        np.testing.assert_array_equal(table, _table(t)[trim:-trim])


def test_without_a_delay_nothing_is_shifted_or_trimmed(late_records: Path) -> None:
    exp = _experiment(late_records, "")
    assert exp.delays == {}
    assert exp.t.size == 4000
    roof, table = exp.accelerations[:, 0], exp.ag
    # the record as it was: 3.46 samples late, far from the table at 31 Hz
    assert np.max(np.abs(roof - table)) > 0.5 * np.std(table)
    same = _experiment(late_records, "delay = 0.0")
    np.testing.assert_array_equal(same.accelerations, exp.accelerations)
    assert same.delays == {}


def test_delay_errors_name_the_case(late_records: Path) -> None:
    from femupdate.trials.experiment import load_experiment

    with pytest.raises(DataError) as info:
        _experiment(late_records, "delay = 10.0")  # as long as half the 20 s record
    message = str(info.value)
    assert ".toml" in message and "delay of 10 s" in message and "too few" in message
    # the band is checked against the rate of the files once read (Nyquist 100 Hz)
    text = DELAY_CASE.format(delay='delay = "auto"', highpass=0.0)
    path = late_records / "band.toml"
    path.write_text(text.replace("highpass_hz = 0.0",
                                 "highpass_hz = 0.0\ndelay_band_hz = [1.0, 120.0]"))
    with pytest.raises(ConfigError) as info:
        load_experiment(load_case(path))
    message = str(info.value)
    assert str(path) in message and "preprocess.delay_band_hz" in message
    assert "[1, 120]" in message and "200 Hz" in message
    assert "Nyquist frequency 100 Hz" in message


# ----------------------------------------------------------------------------- [search] workers


def _workers_case(case_dir: Path, tmp_path: Path, workers: int) -> Path:
    text = CASE.replace("runs = 3", "runs = 2").replace("max_evals = 3000", "max_evals = 40")
    _broken_copy(case_dir, tmp_path, text + f"workers = {workers}\n")
    return tmp_path / "case.toml"


def test_search_workers_takes_effect(case_dir: Path, tmp_path: Path) -> None:
    case = load_case(_workers_case(case_dir, tmp_path, 2))
    two = run_case(case, None, sensitivities=False)
    assert two.summary.settings["workers"] == 2
    one = run_case(case, None, workers=1, sensitivities=False)  # an explicit override wins
    assert one.summary.settings["workers"] == 1
    assert [r.phi for r in one.summary.runs] == [r.phi for r in two.summary.runs]


def test_cli_workers_override_the_case_only_when_given(case_dir: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    path = _workers_case(case_dir, tmp_path, 2)
    for extra, expected in (([], 2), (["--workers", "1"], 1)):
        out = tmp_path / f"out{expected}"
        result = CliRunner().invoke(app, ["run", str(path), "--out", str(out), "--quiet",
                                          *extra])
        assert result.exit_code == 0, result.output
        assert read_summary(out / "summary.json").settings["workers"] == expected
