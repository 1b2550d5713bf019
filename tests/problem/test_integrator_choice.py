"""The integrator of a nonlinear case without ``[simulation] method``, chosen once at the
nominal point (femupdate.problem.case_model.choose_integrator), and the step-halving check that
``femupdate run`` states with it (femupdate.problem.reduced_path.step_halving)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from femupdate.case import load_case
from femupdate.errors import FemupdateWarning, SimulationError
from femupdate.problem.case_model import CaseModel
from femupdate.problem.reduced_path import (
    STEP_HALVING_WARN,
    describe_simulation,
    simulation_record,
)
from femupdate.problem.update import UpdateProblem
from femupdate.simulate.implicit import ImplicitSimulator
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment

#: A body (1 kg) on a column (k2) on a footing (50 g) held by a stiff Bouc–Wen link (3e6 N/m,
#: yield at 1 mm): the footing's mode is at 1.5 kHz, the body's at 8 Hz. Central differences
#: need 47 substeps per sample of 0.01 s to be stable; the response is the body's.
ON_A_LINK = """\
[case]
name = "on-a-link"

[model.shear_building]
masses = [0.05, 1.0]
stiffnesses = [10.0, "k2"]
dampers = [0.5, "c2"]

[model.shear_building.bouc_wen]
k = [3e6, 1.0]
alpha = 0.1
beta = 750.0
gamma = 250.0

[[parameters]]
name = "k2"
lower = 1000.0
upper = 10000.0
nominal = 2500.0

[[parameters]]
name = "c2"
lower = 0.0
upper = 5.0
nominal = 0.6
"""

#: One storey on a soft slider (k_r 500 N/m beside a 2,000 N/m column): 8 Hz at most.
SOFT_SLIDER = """\
[case]
name = "soft-slider"

[model.shear_building]
masses = [1.0]
stiffnesses = ["k1"]
dampers = [0.5]

[model.shear_building.frictions]
k_r = 500.0
f_u = 0.5

[[parameters]]
name = "k1"
lower = 1000.0
upper = 3000.0
nominal = 2000.0
"""

OUTPUT = """\
[data]
format = "csv"
directory = "data"
time_column = "t"

[data.input]
file = "table.csv"
column = "table"

[[data.outputs]]
file = "floors.csv"
column = "a"
node = "F{floor}"
dof = "ux"
"""

TRUTH = {"on-a-link": {"k2": 2500.0, "c2": 0.6}, "soft-slider": {"k1": 2000.0}}
DT = 0.01


def _case(folder: Path, model: str, substeps: int, method: str | None = None,
          records: bool = True):
    """The case in ``folder`` with noise-free records of its truth (2 s at 100 Hz) made by
    ``femupdate synth``'s path (its own integrator choice)."""
    floor = 2 if "on-a-link" in model else 1
    simulation = f'\n[simulation]\nmethod = "{method}"\n' if method else ""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "case.toml").write_text(model + "\n" + OUTPUT.format(floor=floor) + simulation
                                      + f"\n[preprocess]\nsubsteps = {substeps}\n")
    case = load_case(folder / "case.toml")
    if records:
        virtual_experiment(case, TRUTH[case.case.name], folder / "data", seed=2, duration=2.0,
                           rate=1.0 / DT, snr=0.0, offset=0.0, drift=0.0, length_scale=1.0)
    return case


def _record(case) -> tuple[dict, list[warnings.WarningMessage]]:
    problem = UpdateProblem(case, load_experiments(case))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        record = simulation_record(problem)
    return record, [w for w in caught if issubclass(w.category, FemupdateWarning)
                    and "step-halving" in str(w.message)]


def test_a_stiff_link_without_method_takes_the_implicit_scheme(tmp_path):
    """The case that central differences refuse at its step runs: its records are made and
    fitted on the implicit scheme chosen at the nominal point (φ = 0 at the truth)."""
    case = _case(tmp_path, ON_A_LINK, substeps=16)
    problem = UpdateProblem(case, load_experiments(case))
    trial = problem.fitted[0]
    assert trial.model.method == "implicit" and not trial.compiled
    choice = trial.model.choices[DT]
    assert (choice.explicit_substeps, choice.stable_substeps) == (94, 47)
    assert "central differences would need 94 substeps" in choice.reason
    assert problem(case.to_search(TRUTH["on-a-link"])) < 1e-20
    assert problem(case.to_search({"k2": 3000.0, "c2": 0.6})) > 1e-3


def test_the_choice_is_held_over_the_search(tmp_path):
    """Once chosen at the nominal point, the integrator stays for every parameter value."""
    case = _case(tmp_path, ON_A_LINK, substeps=16, records=False)
    model = CaseModel(case, dt=DT)
    assert model.method == "implicit" and list(model.choices) == [DT]
    softest = {"k2": 1000.0, "c2": 5.0}
    assert isinstance(model.simulator(softest, DT), ImplicitSimulator)
    assert list(model.choices) == [DT]  # no second choice at another point
    lazy = CaseModel(case)  # synth, modes: the choice at the first simulation at each dt
    assert lazy.method == "nonlinear" and not lazy.choices
    assert lazy.method_for(DT) == "implicit" and list(lazy.choices) == [DT]


def test_an_explicit_method_is_obeyed(tmp_path):
    """``method = "nonlinear"`` keeps central differences, which refuse the step as they did;
    ``method = "implicit"`` on a soft model keeps the implicit scheme."""
    stiff = _case(tmp_path / "stiff", ON_A_LINK, substeps=16, method="nonlinear",
                  records=False)
    model = CaseModel(stiff, dt=DT)
    assert model.method == "nonlinear" and not model.choices
    with pytest.raises(SimulationError, match=r"use substeps >= 47 at dt = 0\.01 s, or "
                                              r"method 'implicit'"):
        model.simulate(TRUTH["on-a-link"], [0.0, 1.0, 0.0], DT)
    soft = _case(tmp_path / "soft", SOFT_SLIDER, substeps=4, method="implicit", records=False)
    model = CaseModel(soft, dt=DT)
    assert model.method == "implicit" and not model.choices


def test_a_soft_slider_keeps_central_differences(tmp_path):
    case = _case(tmp_path, SOFT_SLIDER, substeps=4)
    problem = UpdateProblem(case, load_experiments(case))
    trial = problem.fitted[0]
    assert trial.model.method == "nonlinear" and trial.compiled
    choice = trial.model.choices[DT]
    assert choice.explicit_substeps == 1 and "central differences need 1 substep " in choice.reason
    assert problem(case.to_search(TRUTH["soft-slider"])) < 1e-20


def test_the_record_and_its_line_say_the_choice_and_the_step_halving_check(tmp_path):
    case = _case(tmp_path, ON_A_LINK, substeps=16)
    record, warned = _record(case)
    assert not warned
    assert record["method"] == "implicit" and record["hht_alpha"] == 0.0
    assert (record["substeps"], record["explicit_substeps"], record["stable_substeps"]) == (
        16, 94, 47)
    check = record["step_halving"]
    assert check["substeps"] == [16, 32] and check["at"] == "the nominal point"
    assert 0.0 < check["nmse"] < 1e-5
    line = describe_simulation(record)
    assert line.startswith("simulation: implicit (HHT α = 0, 16 substeps; full model, 2 DOFs), "
                           "chosen at the nominal point: central differences would need 94 "
                           "substeps per sample at the nominal point")
    rounding = record["rounding"]
    assert rounding["step"] == 1e-10 and rounding["nmse"] < 1e-16  # a smooth model
    assert line.endswith(f"; step-halving check at the nominal point: NMSE {check['nmse']:.2g} "
                         f"between 16 and 32 substeps; rounding check: NMSE "
                         f"{rounding['nmse']:.2g} for parameters moved by 1e-10")
    soft, _ = _record(_case(tmp_path / "soft", SOFT_SLIDER, substeps=4, method="nonlinear"))
    assert "chosen" not in soft and "hht_alpha" not in soft
    assert describe_simulation(soft).startswith(
        "simulation: nonlinear (central differences, 4 substeps; full model, 1 DOF); "
        "step-halving check at the nominal point: NMSE ")


def test_the_step_halving_check_falls_as_the_fourth_power_of_the_step(tmp_path):
    """The implicit scheme is second order: each halving of the step divides the difference
    of the predictions by about 2⁴ = 16 in NMSE; too long a step is warned about."""
    nmse = {}
    for substeps in (1, 2, 4, 8):
        case = _case(tmp_path / str(substeps), ON_A_LINK, substeps=substeps)
        record, warned = _record(case)
        nmse[substeps] = record["step_halving"]["nmse"]
        assert bool(warned) == (nmse[substeps] > STEP_HALVING_WARN)
    print("step-halving check (NMSE) by substeps:",
          ", ".join(f"{k}: {v:.2g}" for k, v in nmse.items()))  # docs/hysteresis.md
    assert nmse[2] > 1e-2 and nmse[8] < STEP_HALVING_WARN
    for coarse in (1, 2, 4):
        assert 8.0 < nmse[coarse] / nmse[2 * coarse] < 32.0
    _, warned = _record(_case(tmp_path / "2", ON_A_LINK, substeps=2, records=False))
    assert "raise [preprocess] substeps" in str(warned[0].message)


def test_femupdate_run_prints_the_choice_and_saves_it(tmp_path):
    """``femupdate run`` on the stiff link: the line after its table, the record in
    summary.json."""
    import json

    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    case = _case(tmp_path, ON_A_LINK, substeps=16)
    text = case.source.read_text() + "\n[search]\nruns = 1\nseed = 1\nmax_evals = 30\n"
    case.source.write_text(text)
    result = CliRunner().invoke(app, ["run", str(case.source), "--out", str(tmp_path / "res")])
    assert result.exit_code == 0, result.output
    said = " ".join(result.output.split())  # the console wraps long lines
    assert ("simulation: implicit (HHT α = 0, 16 substeps; full model, 2 DOFs), chosen at the "
            "nominal point: central differences would need 94 substeps") in said
    assert "step-halving check at the nominal point: NMSE" in said
    record = json.loads((tmp_path / "res" / "summary.json").read_text())["simulation"]
    assert record["method"] == "implicit" and record["explicit_substeps"] == 94
    assert record["step_halving"]["substeps"] == [16, 32]
    assert 0.0 < record["step_halving"]["nmse"] < 1e-5


def test_a_step_halving_check_that_cannot_run_says_why(tmp_path):
    """Central differences given at a step they refuse: the check fails, says why, warns."""
    _case(tmp_path, ON_A_LINK, substeps=16)  # the records, on the implicit scheme
    refused = _case(tmp_path, ON_A_LINK, substeps=16, method="nonlinear", records=False)
    record, warned = _record(refused)
    check = record["step_halving"]
    assert record["method"] == "nonlinear" and check["nmse"] == float("inf")
    assert "use substeps >= 47" in check["failure"]
    assert "step-halving check at the nominal point: failed (nonlinear: the time step" in (
        describe_simulation(record))
    assert "failed (nonlinear: the time step" in str(warned[0].message)


def test_the_line_names_each_trials_integrator_when_they_differ():
    """Trials sampled at different intervals choose for themselves; the line says so."""
    record = {"method": "implicit", "n_dof": 2, "substeps": 4, "hht_alpha": 0.0,
              "chosen": "central differences would need 9 substeps …",
              "trial_methods": {"slow": "implicit", "fast": "nonlinear"}}
    assert describe_simulation(record) == (
        "simulation: implicit (HHT α = 0, 4 substeps; full model, 2 DOFs), chosen at the "
        "nominal point: central differences would need 9 substeps …; by trial: slow implicit, "
        "fast nonlinear")


def test_hht_alpha_reaches_the_implicit_scheme_and_is_refused_where_none_runs(tmp_path):
    """[simulation] hht_alpha: the chosen implicit scheme takes it (said in the record), and
    the step-halving check's φ moves with it; a linear case or central differences refuse it."""
    import tomllib

    from femupdate.case import parse_case
    from femupdate.errors import ConfigError

    def parse(text: str):
        return parse_case(tomllib.loads(text))

    case = _case(tmp_path / "damped", ON_A_LINK + "\n[simulation]\nhht_alpha = -0.1\n",
                 substeps=4)
    model = CaseModel(case, dt=DT)
    simulator = model.simulator(TRUTH["on-a-link"], DT)
    assert isinstance(simulator, ImplicitSimulator) and simulator.alpha == -0.1
    damped, _ = _record(case)
    assert damped["hht_alpha"] == -0.1
    assert describe_simulation(damped).startswith("simulation: implicit (HHT α = -0.1, 4 ")
    plain, _ = _record(_case(tmp_path / "plain", ON_A_LINK, substeps=4))
    assert plain["hht_alpha"] == 0.0
    assert damped["step_halving"]["nmse"] != plain["step_halving"]["nmse"]
    with pytest.raises(ConfigError, match=r"simulation\.hht_alpha: got -0\.1 but the "
                       r"simulation method is 'nonlinear'"):
        parse(ON_A_LINK + '\n[simulation]\nmethod = "nonlinear"\nhht_alpha = -0.1\n')
    with pytest.raises(ConfigError, match=r"simulation\.hht_alpha"):
        parse(SOFT_SLIDER.replace("[model.shear_building.frictions]\nk_r = 500.0\n"
                                       "f_u = 0.5\n", "") + "\n[simulation]\nhht_alpha = -0.05\n")
    with pytest.raises(ConfigError, match=r"simulation\.hht_alpha"):
        parse(ON_A_LINK + "\n[simulation]\nhht_alpha = -0.5\n")


@pytest.mark.slow
def test_the_rounding_check_warns_of_links_chattering_on_massless_feet(tmp_path):
    """examples/frames/links-frame-100.toml without its footings: a change of 1e-10 in the
    parameters moves the prediction by NMSE ~1e-7 (the links on the columns' feet chatter when
    they reverse); with them ~1e-19. Only the first is warned about."""
    import json
    import re
    import tomllib

    from femupdate.case import parse_case
    from femupdate.problem.reduced_path import ROUNDING_WARN

    folder = Path(__file__).resolve().parents[2] / "examples" / "frames"
    text = re.sub(r"substeps = 16", "substeps = 60",
                  (folder / "links-frame-100.toml").read_text())
    truth = json.loads((folder / "links-frame-100-truth.json").read_text())
    found = {}
    for name, keep in (("without footings", False), ("with footings", True)):
        lines = text if keep else "\n".join(line for line in text.splitlines()
                                            if "m = 2000.0" not in line)
        spec = tomllib.loads(lines)
        spec["data"]["directory"] = str(tmp_path / name)
        case = parse_case(spec, source=tmp_path / f"{name}.toml")
        virtual_experiment(case, truth, tmp_path / name, seed=1, duration=2.0, rate=100.0,
                           pga_g=0.3, length_scale=1.0, snr=0.02, offset=0.0, drift=0.0)
        problem = UpdateProblem(case, load_experiments(case))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            record = simulation_record(problem)
        found[name] = (record["rounding"]["nmse"],
                       [w for w in caught if "not smooth at rounding level" in str(w.message)])
    chatter, warned = found["without footings"]
    assert chatter > 1e3 * ROUNDING_WARN and len(warned) == 1
    assert "give those DOFs their mass (a footing)" in str(warned[0].message)
    smooth, quiet = found["with footings"]
    assert smooth < 1e-3 * ROUNDING_WARN and not quiet
