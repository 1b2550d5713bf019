"""``femupdate posterior`` through the run machinery: the posterior of a small case, same seed
same samples, SIGKILL then --resume gives the identical samples, Dask, a failed evaluation
inside a stage, a budget too small to reach the posterior, and bad input."""

from __future__ import annotations

import math
import os
import signal
from pathlib import Path

import numpy as np
import pytest
from two_storey import TRUTH, kill_posterior_when, write_case

from femupdate.case import load_case, parse_case
from femupdate.errors import ConfigError, DataError
from femupdate.inference.method import SampledProblem
from femupdate.pipeline.posterior.run import POSTERIOR_DIR, PosteriorResult, run_posterior
from femupdate.pipeline.results import POSTERIOR_FILE, read_summary
from femupdate.runs import Execution
from femupdate.runs.store import FILENAME


@pytest.fixture(scope="module")
def case_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_case(tmp_path_factory.mktemp("two-storey"))


@pytest.fixture(scope="module")
def result(case_path: Path) -> PosteriorResult:
    return run_posterior(load_case(case_path), case_path.parent / "out")


def _samples(out: Path) -> np.ndarray:
    with np.load(out / POSTERIOR_FILE) as data:
        return data["samples"]


@pytest.mark.slow
def test_the_posterior_holds_the_truth_and_is_written(result: PosteriorResult,
                                                      case_path: Path) -> None:
    record = result.record
    assert record.reached and record.log_evidence is not None and math.isfinite(
        record.log_evidence)
    assert record.error_model == "neff"  # the default
    # four runs (more while a parameter was unsettled), each ending with its importance
    # stage's draws resampled: more samples than its population of 200
    runs = record.runs
    assert runs in (4, 8, 12) and record.samples > 200 * runs
    assert result.samples.shape == (record.samples, 4)
    assert record.unsettled == [] and record.agreement.startswith(
        f"the {runs} independent runs agree")
    assert set(record.ess_params) == set(TRUTH) and record.ess == min(record.ess_params.values())
    assert all(abs(r - 1.0) < 0.05 for r in record.rhat.values())
    assert len(record.log_evidence_runs) == runs and min(record.log_evidence_runs) <= (
        record.log_evidence) <= max(record.log_evidence_runs)
    for name, value in TRUTH.items():  # 2 % noise: the truth is a few sd from the mean
        m = record.params[name]
        assert m.q05 < m.q50 < m.q95 and abs(m.mean - value) < 4.0 * m.sd, (name, m, value)
    assert set(record.frequencies_hz) == {"f1", "f2"} and record.modes_from == 20
    joint = np.array(record.joint_correlations, dtype=float)
    assert record.joint_names == ["k1", "k2", "c1", "c2", "f1", "f2", "zeta1", "zeta2"]
    assert joint.shape == (8, 8) and np.allclose(np.diag(joint), 1.0)
    assert [s.beta for s in record.stages][-1] == 1.0
    summary = read_summary(case_path.parent / "out" / "summary.json")
    assert summary.posterior == record and summary.laplace is not None
    assert np.array_equal(_samples(case_path.parent / "out"), result.samples)
    assert 0.0 < result.bands[0].coverage.min() <= 1.0


@pytest.mark.slow
def test_the_report_renders_the_posterior(result: PosteriorResult, case_path: Path) -> None:
    from femupdate.report.html import render_report

    html = render_report(case_path.parent / "out")
    for ident in ('id="laplace"', 'id="posterior"', 'id="stages"', 'id="figure-corner"',
                  'id="figure-frequency-posteriors"', 'id="coverage"', 'id="figure-bands-0"',
                  'id="figure-posterior-correlation"'):
        assert ident in html, ident


@pytest.mark.slow
def test_the_report_and_console_say_when_the_runs_disagree(result: PosteriorResult,
                                                           case_path: Path,
                                                           tmp_path: Path) -> None:
    import shutil

    from rich.console import Console

    from femupdate.pipeline.posterior.console import print_posterior
    from femupdate.pipeline.results import write_summary
    from femupdate.report.html import render_report

    out = tmp_path / "unsettled"
    shutil.copytree(case_path.parent / "out", out)
    words = "UNSETTLED: the 4 runs do not pin down k1 (the runs disagree: ...)"
    record = result.record.model_copy(update={"unsettled": ["k1"], "agreement": words})
    write_summary(result.summary.model_copy(update={"posterior": record}), out)
    html = render_report(out)
    assert 'id="posterior-agreement"' in html and "UNSETTLED" in html
    console = Console(record=True, width=200)
    print_posterior(record, console)
    assert f"verdict: {words}" in console.export_text()


def test_one_run_says_it_cannot_check_itself(case_path: Path, tmp_path: Path) -> None:
    got = run_posterior(load_case(case_path), tmp_path / "one", runs=1)
    assert got.record.runs == 1 and got.record.samples > 200  # the importance draws
    assert all(r is None for r in got.record.rhat.values())
    assert got.record.agreement.startswith("one run: whether independent runs agree was not "
                                           "checked")


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_sigkill_then_resume_gives_the_identical_samples(result: PosteriorResult,
                                                         case_path: Path,
                                                         tmp_path: Path) -> None:
    out = tmp_path / "killed"
    # killed past the first stage, before the end (4 × 3,200 evaluations)
    code = kill_posterior_when(case_path, out, out / POSTERIOR_DIR / FILENAME, 500, 2e-3)
    assert code == -signal.SIGKILL, "the sampler ended before it was killed"
    assert not (out / POSTERIOR_FILE).exists()
    resumed = run_posterior(load_case(case_path), out, resume=True)
    assert resumed.samples.tobytes() == result.samples.tobytes()
    assert resumed.record.log_evidence == result.record.log_evidence


@pytest.mark.slow
def test_dask_gives_the_same_samples(result: PosteriorResult, case_path: Path,
                                     tmp_path: Path) -> None:
    distributed = pytest.importorskip("dask.distributed", reason="needs the 'dask' extra")
    # Workers as threads: the tasks, the scatter and the chunks go through Dask as on a real
    # cluster, without starting two interpreters (tests/runs/test_dask.py does that).
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        remote = run_posterior(load_case(case_path), tmp_path / "dask",
                               execution=Execution(scheduler=cluster.scheduler_address,
                                                   chunk_evals=400))
    assert remote.samples.tobytes() == result.samples.tobytes()


@pytest.mark.slow
def test_two_workers_give_the_same_samples(result: PosteriorResult, case_path: Path,
                                           tmp_path: Path) -> None:
    # One run and two workers: each stage's population is spread over them.
    got = run_posterior(load_case(case_path), tmp_path / "two", workers=2)
    assert got.samples.tobytes() == result.samples.tobytes()


@pytest.mark.slow
def test_a_failed_evaluation_in_a_stage_is_recorded_not_fatal(
        case_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fast = SampledProblem.residuals_batch

    def fails_for_stiff_k1(self: SampledProblem, X: np.ndarray, **kw: object) -> np.ndarray:
        rows = fast(self, X, **kw)
        rows[X[:, 0] > math.log10(4010.0)] = np.inf  # the model "diverges" there
        return rows

    monkeypatch.setattr(SampledProblem, "residuals_batch", fails_for_stiff_k1)
    got = run_posterior(load_case(case_path), tmp_path / "failing")
    assert got.record.reached and got.record.failed_evaluations > 0
    assert "started from the prior" in got.record.message  # no Jacobian beside the bound
    # nor the count of the default error model, which needs that Jacobian: 'neff', said
    assert got.record.error_model == "neff"
    assert got.record.params["k1"].q95 <= 4010.0  # never accepted where it failed


def test_a_budget_too_small_says_so_and_reports_no_posterior(case_path: Path,
                                                             tmp_path: Path) -> None:
    folder = tmp_path / "small"
    folder.mkdir()
    (folder / "data").symlink_to(case_path.parent / "data")
    got = run_posterior(load_case(write_case(folder, max_evals=300)), folder / "out")
    assert not got.record.reached and got.record.log_evidence is None
    assert "β =" in got.record.message and "max_evals" in got.record.message
    assert got.samples.size == 0 and not got.record.params
    assert not (folder / "out" / POSTERIOR_FILE).exists()


def test_all_zero_records_are_a_one_line_error(case_path: Path, tmp_path: Path) -> None:
    from femupdate.trials.experiment import load_experiments

    case = load_case(case_path)
    experiments = load_experiments(case)
    experiments[0].target[:, 1] = 0.0
    with pytest.raises(DataError, match=r"channel\(s\) F2.ux is all zero") as err:
        run_posterior(case, tmp_path / "zero", experiments=experiments)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("posterior", "message"), [
    ({"samples": 30}, r"posterior\.samples: got 30 for 4 parameters \(allowed: at least 40"),
    ({"priors": {"k1": {"kind": "normal", "mean": 50.0, "sd": 10.0}}},
     r"posterior\.priors\.k1\.mean: got 50, outside the bounds .*\[1000, 10000\]"),
    ({"priors": {"c1": {"kind": "log-uniform"}}},
     r"posterior\.priors\.c1\.kind: 'log-uniform' on parameter 'c1' whose lower bound is 0"),
    ({"priors": {"c1": {"kind": "lognormal", "median": 1.0, "sigma": 0.5}}},
     r"'lognormal' on parameter 'c1' whose lower bound is 0"),
    ({"priors": {"k3": {"kind": "uniform"}}}, r"no parameter 'k3'"),
    ({"error_model": "white"}, r"posterior\.error_model: got 'white'"),
])
def test_bad_posterior_settings_are_one_line_errors(case_path: Path, posterior: dict,
                                                    message: str) -> None:
    data = load_case(case_path).to_dict()
    data["posterior"] = posterior
    with pytest.raises(ConfigError, match=message):
        parse_case(data)


def test_too_few_samples_given_on_the_command_line_are_refused(case_path: Path,
                                                               tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"samples: got 25 for 4 parameters \(allowed: at "
                                          r"least 40"):
        run_posterior(load_case(case_path), tmp_path / "few", samples=25)
    assert not (tmp_path / "few").exists()  # refused before anything is written


def test_the_case_file_offers_the_error_models_of_the_registry() -> None:
    import typing

    from femupdate.case.posterior_section import PosteriorSection
    from femupdate.inference.error_models import case_kinds

    offered, unset = typing.get_args(PosteriorSection.model_fields["error_model"].annotation)
    assert typing.get_args(offered) == case_kinds() and unset is type(None)


def test_unset_the_sampler_and_the_laplace_record_take_the_default(case_path: Path) -> None:
    from femupdate.inference.best_fit import case_error_kind
    from femupdate.inference.error_models import DEFAULT_KIND
    from femupdate.pipeline.posterior.run import posterior_settings

    data = load_case(case_path).to_dict()
    data["posterior"].pop("error_model", None)
    unset = parse_case(data)
    assert (posterior_settings(unset).error_model, case_error_kind(unset)) == (
        DEFAULT_KIND, DEFAULT_KIND) == ("neff", "neff")
    data.pop("posterior")
    bare = parse_case(data)
    assert (posterior_settings(bare).error_model, case_error_kind(bare)) == ("neff", "neff")
    data["posterior"] = {"error_model": "tau"}
    with pytest.raises(ConfigError, match="error_model"):
        parse_case(data)


def test_a_case_without_posterior_keeps_its_fingerprint(case_path: Path) -> None:
    data = load_case(case_path).to_dict()
    assert "ess" not in data["posterior"]  # an ESS target not given is not saved either
    data.pop("posterior")
    case = parse_case(data)
    assert "posterior" not in case.to_dict()


def test_laplace_at_the_best_fit_agrees_with_the_samples(result: PosteriorResult) -> None:
    # Four parameters nearly linear over their posterior: the Gaussian at the best fit and
    # TMCMC's samples, under the same error model, must tell the same story.
    from femupdate.inference.best_fit import laplace_record

    sampled = result.record
    best = result.summary.runs[result.summary.best.run].x
    laplace = laplace_record(result.search.problem, np.asarray(best), kind=sampled.error_model)
    assert laplace.note is None and not laplace.undetermined
    for name, m in sampled.params.items():
        g = laplace.params[name]
        assert 0.7 < g.sd / m.sd < 1.4, (name, g.sd, m.sd)
        assert abs(g.q50 - m.q50) < 0.5 * m.sd, (name, g.q50, m.q50)


def test_validate_with_the_posterior_gives_bands_and_coverage(result: PosteriorResult,
                                                              case_path: Path,
                                                              tmp_path: Path) -> None:
    from femupdate.errors import FemupdateError
    from femupdate.pipeline.posterior.validate import validate_posterior

    out = case_path.parent / "out"
    bands = validate_posterior(load_case(case_path), out, samples=15)
    assert [b.trial for b in bands] == ["two-storey"] and bands[0].samples == 15
    assert bands[0].q05.shape == bands[0].measured.shape
    assert np.all((bands[0].coverage > 0.0) & (bands[0].coverage <= 1.0))
    with pytest.raises(FemupdateError, match="no posterior samples"):
        validate_posterior(load_case(case_path), tmp_path)


def test_the_command_says_when_it_did_not_reach_the_posterior(case_path: Path,
                                                              tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    folder = tmp_path / "cli"
    folder.mkdir()
    (folder / "data").symlink_to(case_path.parent / "data")
    path = write_case(folder, max_evals=300)
    got = CliRunner().invoke(app, ["posterior", str(path), "--out", str(folder / "out"),
                                   "--quiet"], terminal_width=100)
    assert got.exit_code == 1, got.output  # finished, but not a posterior: scripts can tell
    assert ("NOT A POSTERIOR: 4 of 4 sampler runs stopped before tempering exponent β = 1"
            in " ".join(got.output.split()))
    assert "raise [posterior] max_evals and resume" in " ".join(got.output.split())


def test_a_laplace_gaussian_mostly_outside_the_bounds_is_capped_or_left_for_the_prior(
        ) -> None:
    from femupdate.pipeline.posterior.run import start_reference

    rng = np.random.default_rng(0)
    inside = (np.full(3, 0.5), np.diag([0.01, 0.02, 0.01]))
    reference, note = start_reference(*inside, rng)
    assert note is None and reference[1] is inside[1]
    # three coordinates the data do not determine, their Gaussian far wider than the range,
    # centred at a bound: capped at half the range, it holds enough of its mass inside
    wide = (np.array([0.0, 1.0, 0.0]), np.diag([25.0, 16.0, 9.0]))
    reference, note = start_reference(*wide, rng)
    assert "capped" in note and np.allclose(np.sqrt(np.diag(reference[1])), 0.5)
    # twelve at their bounds: even capped, too little of it is inside
    corner = (np.zeros(12), np.eye(12) * 25.0)
    reference, note = start_reference(*corner, rng)
    assert reference is None and note.startswith("the prior")


def test_a_report_without_the_corner_extra_leaves_the_corner_plot_out(
        result: PosteriorResult, case_path: Path, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    # Issue 33: `femupdate report` on a posterior refused the whole report without `corner`.
    import shutil

    from femupdate import _optional
    from femupdate.errors import MissingDependencyError
    from femupdate.report.html import write_report

    def missing(module: str, extra: str) -> None:
        raise MissingDependencyError(f"{module!r} is needed for this feature but is not "
                                     f"installed; install it with: pip install "
                                     f"'femupdate[{extra}]'")

    monkeypatch.setattr(_optional, "require", missing)
    out = tmp_path / "out"
    shutil.copytree(case_path.parent / "out", out)
    html = write_report(out).read_text(encoding="utf-8")
    assert "corner plot not drawn: &#x27;corner&#x27; is needed" in html or (
        "corner plot not drawn: 'corner' is needed" in html)
    assert "pip install" in html and "predictive band</figcaption>" in html


@pytest.mark.slow
def test_without_a_posterior_seed_the_search_seed_makes_it_reproducible(tmp_path: Path
                                                                        ) -> None:
    path = write_case(tmp_path / "case", samples=40)
    path.write_text(path.read_text().replace("seed = 5\n", ""))
    case = load_case(path)
    assert case.posterior.seed is None and case.search.seed == 7
    one = run_posterior(case, tmp_path / "one", runs=1, recentre=0)
    two = run_posterior(case, tmp_path / "two", runs=1, recentre=0)
    assert one.record.seed == 7 and one.samples.tobytes() == two.samples.tobytes()


def test_the_error_model_is_chosen_on_the_command_line_among_the_case_kinds(
        case_path: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    with pytest.raises(ConfigError, match=r"error_model: got 'tau' \(allowed: neff, eiv\)"):
        run_posterior(load_case(case_path), tmp_path / "tau", error_model="tau")
    assert not (tmp_path / "tau").exists()  # refused before anything is written
    got = CliRunner().invoke(app, ["posterior", str(case_path), "--out", str(tmp_path / "cli"),
                                   "--error-model", "adjusted"])
    assert isinstance(got.exception, ConfigError) and "allowed: neff, eiv" in str(got.exception)
    assert "--error-model" in CliRunner().invoke(app, ["posterior", "--help"]).output


def test_from_a_results_directory_the_search_is_not_run_again(result: PosteriorResult,
                                                               case_path: Path,
                                                               tmp_path: Path) -> None:
    searched = case_path.parent / "out"
    before = read_summary(searched / "summary.json").posterior
    got = run_posterior(load_case(case_path), tmp_path / "sampled", search_from=searched,
                        runs=1, recentre=0)
    assert not (tmp_path / "sampled" / FILENAME).exists()  # no search in --out
    assert [r.nfev for r in got.search.summary.runs] == [  # none added to the store
        r.nfev for r in result.search.summary.runs]
    assert got.search.summary.best.phi == result.search.summary.best.phi
    assert read_summary(tmp_path / "sampled" / "summary.json").posterior.reached
    # the search's own directory keeps the posterior it holds: --from erases no result
    assert before is not None and read_summary(searched / "summary.json").posterior == before
    with pytest.raises(ConfigError, match=r"--from .*: no search results there"):
        run_posterior(load_case(case_path), tmp_path / "x", search_from=tmp_path / "none")


@pytest.mark.slow
def test_runs_are_added_until_every_parameter_has_the_ess_asked_for(tmp_path: Path) -> None:
    case = load_case(write_case(tmp_path / "case", samples=40))
    few = run_posterior(case, tmp_path / "few", runs=2, max_runs=4, recentre=0, ess=10)
    assert few.record.runs == 2 and few.record.unsettled == []
    many = run_posterior(case, tmp_path / "many", runs=2, max_runs=4, recentre=0,
                         ess=10_000_000)
    assert many.record.runs == 4 and many.record.unsettled == list(many.record.names)
    with pytest.raises(ConfigError, match=r"ess: got 5 \(allowed"):
        run_posterior(case, tmp_path / "bad", ess=5)


@pytest.mark.slow
def test_the_importance_stage_runs_through_the_posterior(case_path: Path, tmp_path: Path
                                                         ) -> None:
    """TMCMC's options beyond the case's (``tmcmc=``) reach every run: with the importance
    stage the runs hand back their weighted draws resampled (more samples than the
    population) and the same seed gives the same samples."""
    case = load_case(case_path)
    got = run_posterior(case, tmp_path / "a", runs=2,
                        tmcmc={"final": "importance", "ess": 300})
    again = run_posterior(case, tmp_path / "b", runs=2,
                          tmcmc={"final": "importance", "ess": 300})
    assert got.record.reached and got.samples.shape[0] > 2 * 200
    assert got.samples.tobytes() == again.samples.tobytes()
    assert all(v is not None and v > 0 for v in got.record.ess_params.values())


@pytest.mark.slow
def test_runs_that_fall_back_to_moves_say_so(case_path: Path, tmp_path: Path) -> None:
    """Importance sampling dropped for moves (forced: ``fallback = 1``) in every run: the
    runs still reach β = 1, and the message says how many fell back."""
    got = run_posterior(load_case(case_path), tmp_path / "moves", runs=2, max_runs=2,
                        recentre=0, tmcmc={"fallback": 1.0})
    assert got.record.reached and got.samples.shape[0] == 2 * 200
    assert "2 of them by moves to β = 1" in got.record.message
