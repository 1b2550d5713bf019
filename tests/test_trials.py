"""Several tests in one case: φ over the fitted trials, validation, score windows, delays.

A two-storey shear building recorded in three virtual trials (different motions, one at
another sampling rate); the model and parameters are shared.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from femupdate.case import load_case, parse_case
from femupdate.cli.commands import app
from femupdate.errors import ConfigError, DataError
from femupdate.pipeline.run import run_case, validate_case
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiment, load_experiments
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import TRUTH, data_section, model_section, parameter_list

OFF = {"k1": 3600.0, "k2": 2700.0, "c1": 1.0, "c2": 0.7}


def _spec(directory: Path, trials: list[dict[str, Any]] | None = None, **data: Any
          ) -> dict[str, Any]:
    spec: dict[str, Any] = {
        "case": {"name": "two-storey"},
        "model": model_section(),
        "parameters": parameter_list(log_k2=True),
        "data": data_section(directory, **data),
        "preprocess": {"highpass_hz": 0.5},
        "search": {"method": "ab", "runs": 1, "seed": 1, "max_evals": 60},
    }
    if trials is not None:
        spec["trials"] = trials
    return spec


def _trial(name: str, folder: str, **extra: Any) -> dict[str, Any]:
    return {"name": name, "directory": folder, **extra}


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three noisy virtual trials of the same truth: two at 200 Hz, one at 250 Hz."""
    root = tmp_path_factory.mktemp("trials")
    one = parse_case(_spec(root / "a"), source=root / "case.toml")
    for folder, seed, rate in (("a", 1, 200.0), ("b", 2, 200.0), ("c", 3, 250.0)):
        virtual_experiment(one, TRUTH, root / folder, seed=seed, rate=rate, duration=3.0,
                           snr=0.03)
    return root


def _three(records: Path, **extra: Any) -> Any:
    trials = [_trial("a", str(records / "a"), weight=1.0),
              _trial("b", str(records / "b"), weight=3.0),
              _trial("c", str(records / "c"), role="validate")]
    return parse_case(_spec(records / "a", trials, **extra), source=records / "case.toml")


def test_phi_is_the_weighted_mean_of_the_fitted_trials(records: Path) -> None:
    case = _three(records)
    problem = UpdateProblem(case, load_experiments(case))
    assert [t.name for t in problem.fitted] == ["a", "b"]
    x = case.to_search(OFF)
    alone = {}
    for name in ("a", "b", "c"):
        spec = parse_case(_spec(records / name), source=records / "case.toml")
        alone[name] = UpdateProblem(spec, load_experiment(spec))(x)
    assert problem(x) == pytest.approx((alone["a"] + 3.0 * alone["b"]) / 4.0, rel=1e-12)
    r = problem.residuals(x)
    assert r @ r == pytest.approx(problem(x), rel=1e-12)
    # The third trial is at another rate: simulated at its own step, scored, never fitted.
    assert problem.trials[2].experiment.dt == pytest.approx(1 / 250.0)


def test_run_reports_every_trial_and_validate_reproduces_it(records: Path,
                                                           tmp_path: Path) -> None:
    case = _three(records)
    result = run_case(case, tmp_path / "out", sensitivities=False)
    by_name = {t.name: t for t in result.summary.trials}
    assert [(t.name, t.role) for t in result.summary.trials] == [
        ("a", "fit"), ("b", "fit"), ("c", "validate")]
    best = result.summary.best
    assert best.phi == pytest.approx((by_name["a"].phi + 3 * by_name["b"].phi) / 4, rel=1e-12)
    # validate: the same figures from a direct computation at the same parameters
    checked = validate_case(case, best.params)
    for record in checked.trials:
        spec = parse_case(_spec(records / record.name), source=records / "case.toml")
        problem = UpdateProblem(spec, load_experiment(spec))
        assert record.phi == pytest.approx(problem(spec.to_search(best.params)), rel=1e-12)
        assert record.phi == pytest.approx(by_name[record.name].phi, rel=1e-12)
    assert {f.trial for f in checked.fits} == {"a", "b", "c"}
    (fit_c,) = [f for f in result.fits if f.trial == "c"]
    assert fit_c.role == "validate" and fit_c.phi == pytest.approx(by_name["c"].phi)
    # the report gives each trial's NMSE
    from femupdate.report.html import write_report

    text = write_report(tmp_path / "out").read_text()
    for name, role in (("a", "fit"), ("b", "fit"), ("c", "validate")):
        assert f"{name} ({role})" in text
    assert f"{100 * by_name['c'].phi:.4g}"[:4] in text


CASE_FILE = """\
[case]
name = "two-storey"
[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]
[[parameters]]
name = "k1"
lower = 1000.0
upper = 10000.0
[[parameters]]
name = "k2"
lower = 1000.0
upper = 10000.0
[[parameters]]
name = "c1"
lower = 0.0
upper = 5.0
[[parameters]]
name = "c2"
lower = 0.0
upper = 5.0
[data]
format = "csv"
time_column = "t"
input = { file = "table.csv", column = "table" }
outputs = [{ file = "floors.csv", column = "a1", node = "F1", dof = "ux" }]
[[trials]]
name = "a"
directory = "a"
[[trials]]
name = "c"
directory = "c"
role = "validate"
"""


def test_validate_command(records: Path, tmp_path: Path) -> None:
    import json

    path = records / "validate-case.toml"
    path.write_text(CASE_FILE)
    out = tmp_path / "validation"
    result = CliRunner().invoke(app, ["validate", str(path), "--params", json.dumps(OFF),
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    saved = json.loads((out / "validation.json").read_text())
    assert [t["name"] for t in saved["trials"]] == ["a", "c"]
    assert {p.name for p in out.glob("fit-*.png")} == {"fit-a.png", "fit-c.png"}
    direct = validate_case(load_case(path), OFF)
    assert [t["phi"] for t in saved["trials"]] == [t.phi for t in direct.trials]
    assert "NMSE" in result.output and "validate" in result.output
    # the model's natural frequencies, printed and recorded: the 2-storey shear building's
    # closed form, det(K − ω²M) = 0 with M = diag(m1, m2), K = [[k1 + k2, −k2], [−k2, k2]]
    (m1, m2), k1, k2 = (1.0, 0.8), OFF["k1"], OFF["k2"]
    b, c = -((k1 + k2) * m2 + k2 * m1) / (m1 * m2), k1 * k2 / (m1 * m2)
    omega2 = (-b + np.array([-1.0, 1.0]) * np.sqrt(b * b - 4 * c)) / 2
    expected = np.sqrt(omega2) / (2 * np.pi)
    np.testing.assert_allclose(saved["frequencies_hz"], expected, rtol=1e-10)
    assert saved["frequencies_hz"] == direct.frequencies_hz
    said = " ".join(result.output.split())
    assert ("natural frequencies of the model [Hz]: "
            + ", ".join(f"{f:.3f}" for f in expected)) in said
    assert max(map(len, result.output.splitlines())) <= 80  # CliRunner: 80 columns


def test_a_split_record_is_simulated_through(records: Path) -> None:
    # One record: the first part fitted, the rest validated. The validation NMSE must be that
    # of the same part of ONE simulation of the whole record (no restart at rest mid-record).
    trials = [_trial("early", str(records / "a"), score_window=[0.0, 1.8]),
              _trial("late", str(records / "a"), role="validate", score_window=[1.8, 3.0])]
    case = parse_case(_spec(records / "a", trials), source=records / "case.toml")
    late = validate_case(case, OFF).trials[1]
    whole = parse_case(_spec(records / "a"), source=records / "case.toml")
    problem = UpdateProblem(whole, load_experiment(whole))
    exp = problem.experiment
    prediction = problem.prediction(problem.simulate(OFF))
    t = exp.t + exp.start_s
    part = (t >= 1.8 - 1e-9) & (t <= 3.0 + 1e-9)
    measured, predicted = exp.target[part], prediction[part]
    # displacements: the two integration constants of each channel fitted over the part
    basis = np.column_stack([np.ones(part.sum()), t[part]])
    d = predicted - measured
    d -= basis @ np.linalg.lstsq(basis, d, rcond=None)[0]
    corrected = predicted - d
    per_channel = (d**2).sum(axis=0) / (corrected**2).sum(axis=0)
    assert late.phi == pytest.approx(per_channel.mean(), rel=1e-10)
    assert late.samples == exp.t.size  # the whole record was simulated


def test_a_delay_band_holding_a_mode_is_refused(records: Path) -> None:
    # Known zero delay; the model's first mode (about 6.5 Hz) lies in the default 1–10 Hz band.
    spec = _spec(records / "a")
    spec["data"]["outputs"][0]["delay"] = "auto"
    case = parse_case(spec, source=records / "case.toml")
    with pytest.raises(ConfigError, match=r"delay_band_hz: got \[1, 10\] Hz, but the model .* "
                                          r"natural frequency at \d+\.\d+ Hz in it"):
        load_experiment(case)
    spec["preprocess"]["delay_band_hz"] = [0.6, 3.0]  # well below the mode: accepted
    exp = load_experiment(parse_case(spec, source=records / "case.toml"))
    assert abs(exp.delays["F1.ux"]) < 0.5 / 200.0


def test_trial_errors_name_the_trial(records: Path) -> None:
    bad = [_trial("a", str(records / "a"),
                  outputs=[{"file": "floors.csv", "column": "a1", "node": "F9", "dof": "ux"}])]
    with pytest.raises(ConfigError, match=r"trials\[0\]\.outputs\[0\]\.node: unknown node 'F9'"):
        parse_case(_spec(records / "a", bad), source="c.toml")
    with pytest.raises(ConfigError, match=r"no trial has role = \"fit\""):
        parse_case(_spec(records / "a", [_trial("a", "x", role="validate")]), source="c.toml")
    with pytest.raises(ConfigError, match=r"duplicate trial name 'a'"):
        parse_case(_spec(records / "a", [_trial("a", "x"), _trial("a", "y")]), source="c.toml")
    with pytest.raises(ConfigError, match=r"trials\[0\]\.score_window: .* outside window"):
        parse_case(_spec(records / "a", [_trial("a", "x", window=[0.0, 1.0],
                                                score_window=[0.5, 2.0])]), source="c.toml")


def test_a_glitched_record_runs_with_repair_and_the_summary_says_so(records: Path,
                                                                   tmp_path: Path) -> None:
    import shutil

    folder = tmp_path / "glitched"
    shutil.copytree(records / "a", folder)
    lines = (folder / "floors.csv").read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line[:1].isdigit() or line[:1] == "-")
    row = head + 300
    del lines[row]                               # a dropped sample
    lines.insert(row + 100, lines[row + 99])     # a row written twice
    (folder / "floors.csv").write_text("\n".join(lines) + "\n")
    spec = _spec(folder)
    with pytest.raises(DataError, match=r"floors\.csv: 2 glitch.*dropped samples.*repeated "
                                        r"time stamp.*repair = true"):
        run_case(parse_case(spec, source=tmp_path / "case.toml"), None)
    spec["data"]["repair"] = True
    result = run_case(parse_case(spec, source=tmp_path / "case.toml"), tmp_path / "out",
                      sensitivities=False)
    notes = result.summary.trials[0].notes
    assert len(notes) == 2 and all("floors.csv: repaired line" in n for n in notes)
    assert np.isfinite(result.summary.best.phi)
