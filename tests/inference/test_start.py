"""The start's verdict (femupdate.pipeline.posterior.start): a posterior sampled from a search that
missed the minimum follows the better fit its sampler finds, says so, and stays seeded and
resumable; the search's verdict is relayed."""

from __future__ import annotations

import os
import signal
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from two_storey import TRUTH, kill_posterior_when, write_case

from femupdate.case import load_case
from femupdate.pipeline.posterior.run import (
    POSTERIOR_DIR,
    RECENTRED_DIR,
    PosteriorResult,
    run_posterior,
)
from femupdate.pipeline.posterior.start import better_fit, polish, search_sentence
from femupdate.pipeline.results import VerdictRecord
from femupdate.runs.store import FILENAME
from femupdate.runs.verdict import SAME_PHI


def _outcome(phi: float) -> SimpleNamespace:
    return SimpleNamespace(fun=phi, x=np.zeros(2))


def test_a_better_fit_must_beat_the_start_by_more_than_the_verdicts_tolerance() -> None:
    start = 1.0
    assert better_fit([_outcome(1.0 - 0.5 * SAME_PHI)], start) is None
    assert better_fit([_outcome(np.inf), _outcome(np.nan)], start) is None
    found = better_fit([_outcome(0.9), _outcome(0.5), _outcome(2.0)], start)
    assert found is not None and found.fun == 0.5


def _verdict(converged: bool) -> VerdictRecord:
    return VerdictRecord(converged=converged, agreeing_runs=[0], confirmations=1, minima=1,
                         phi_range=[0.1, 0.1], fits=True, words="not converged: because")


def test_the_searchs_verdict_is_said_only_when_it_did_not_converge() -> None:
    assert search_sentence(None, False) is None
    assert search_sentence(_verdict(True), False) is None
    words = search_sentence(_verdict(False), False)
    assert words is not None and "'not converged: because'" in words
    assert "search's best fit" in words
    followed = search_sentence(_verdict(False), True)
    assert followed is not None and "the better fit the sampler found" in followed


def test_polish_climbs_to_the_least_squares_minimum() -> None:
    target = np.array([0.3, -1.2])

    def residuals(x: np.ndarray) -> np.ndarray:
        return np.array([x[0] - target[0], 2.0 * (x[1] - target[1]), 0.1])

    x, phi, evals = polish(residuals, [(-2.0, 2.0), (-2.0, 2.0)], np.array([1.5, 1.0]),
                           np.random.SeedSequence(1))
    assert np.allclose(x, target, atol=1e-6) and phi == pytest.approx(0.01)
    assert 0 < evals <= 1000


# The search is starved (25 evaluations: it ends at a poor point of its start pool), so the
# sampler, started from the Gaussian there, finds far better fits.
@pytest.fixture(scope="module")
def starved_case(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = write_case(tmp_path_factory.mktemp("starved"))
    path.write_text(path.read_text().replace("max_evals = 1500", "max_evals = 25"))
    return path


@pytest.fixture(scope="module")
def recentred(starved_case: Path) -> PosteriorResult:
    return run_posterior(load_case(starved_case), starved_case.parent / "out")


@pytest.mark.slow
def test_a_starved_search_is_followed_to_the_better_fit(recentred: PosteriorResult) -> None:
    record, search_phi = recentred.record, recentred.summary.best.phi
    assert record.recentred >= 1 and record.start_phi is not None
    assert record.start_phi < 0.1 * search_phi  # the search ended far from the minimum
    assert record.start_warnings[0].startswith("the sampler found a better fit than the "
                                               "search's")
    assert any(w.startswith("the search's verdict is 'not converged")
               for w in record.start_warnings)
    for name, value in TRUTH.items():  # sampled around the minimum, not the search's end
        m = record.params[name]
        assert abs(m.mean - value) < 4.0 * m.sd, (name, m, value)
    # every pass counts its evaluations: more than the last pass's four runs
    assert record.nfev > 4 * 200


@pytest.mark.slow
def test_without_recentring_the_better_fit_is_said(starved_case: Path,
                                                    tmp_path: Path) -> None:
    got = run_posterior(load_case(starved_case), tmp_path / "said", recentre=0)
    assert got.record.recentred == 0
    assert got.record.start_phi == pytest.approx(got.summary.best.phi)
    assert got.record.start_warnings[0].startswith("the sampler found a better fit than the "
                                                   "one it started from")


@pytest.mark.slow
def test_the_console_and_report_show_the_start_warnings(recentred: PosteriorResult,
                                                         starved_case: Path) -> None:
    from rich.console import Console

    from femupdate.pipeline.posterior.console import print_posterior
    from femupdate.report.html import render_report

    console = Console(record=True, width=400)
    print_posterior(recentred.record, console)
    assert "start: the sampler found a better fit" in console.export_text()
    html = render_report(starved_case.parent / "out")
    assert 'id="posterior-start-0"' in html and "The sampler found a better fit" in html


@pytest.mark.slow
def test_recentred_same_seed_same_samples(recentred: PosteriorResult, starved_case: Path,
                                          tmp_path: Path) -> None:
    again = run_posterior(load_case(starved_case), tmp_path / "again")
    assert again.samples.tobytes() == recentred.samples.tobytes()
    assert again.record.start_phi == recentred.record.start_phi


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_sigkill_while_recentred_then_resume_gives_the_identical_samples(
        recentred: PosteriorResult, starved_case: Path, tmp_path: Path) -> None:
    out = tmp_path / "killed"
    # killed while it samples again from the better fit
    code = kill_posterior_when(starved_case, out,
                               out / POSTERIOR_DIR / f"{RECENTRED_DIR}-1" / FILENAME, 1, 1e-3)
    assert code == -signal.SIGKILL, "the sampler ended before it was killed"
    resumed = run_posterior(load_case(starved_case), out, resume=True)
    assert resumed.samples.tobytes() == recentred.samples.tobytes()
    assert resumed.record.start_phi == recentred.record.start_phi


@pytest.mark.slow
def test_restart_discards_the_recentred_stores(recentred: PosteriorResult, starved_case: Path,
                                               tmp_path: Path) -> None:
    import shutil

    out = tmp_path / "restarted"
    shutil.copytree(starved_case.parent / "out", out)
    assert (out / POSTERIOR_DIR / f"{RECENTRED_DIR}-1").is_dir()
    got = run_posterior(load_case(starved_case), out, restart=True, recentre=0)
    assert got.record.recentred == 0
    assert not any((out / POSTERIOR_DIR).glob(f"{RECENTRED_DIR}-*/*.sqlite*"))


@pytest.mark.slow
def test_runs_are_added_while_a_parameter_is_unsettled(tmp_path: Path) -> None:
    # 40 samples per run, each ending with moves (the importance stage would reach its ESS):
    # four runs hold far fewer than 400 effective samples together
    case = load_case(write_case(tmp_path / "few", samples=40))
    moves = {"final": "moves"}
    got = run_posterior(case, tmp_path / "out", max_runs=12, tmcmc=moves)
    record = got.record
    assert record.runs in (8, 12) and record.samples == 40 * record.runs
    assert "runs added, 4 at a time, while a parameter was unsettled: 4 → " in record.message
    if record.runs == 8:  # stopped because they settled
        assert record.unsettled == []
    assert (tmp_path / "out" / POSTERIOR_DIR / "more-1" / FILENAME).is_file()
    again = run_posterior(case, tmp_path / "again", max_runs=12, tmcmc=moves)
    assert again.samples.tobytes() == got.samples.tobytes()
    # the first four runs are those of a set that may not add any
    four = run_posterior(case, tmp_path / "four", max_runs=4, tmcmc=moves)
    assert four.record.runs == 4 and four.record.unsettled
    assert got.samples[:160].tobytes() == four.samples.tobytes()


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_without_a_seed_a_recentred_pass_killed_still_resumes(tmp_path: Path) -> None:
    # No seed ([posterior] nor [search]): the runs' entropy is fresh but stored, and the
    # polish and the start's choices follow from the stored points, so the resume is not
    # refused.
    path = write_case(tmp_path / "unseeded")
    path.write_text(path.read_text().replace("max_evals = 1500", "max_evals = 25")
                    .replace("seed = 5\n", "").replace("seed = 7\n", ""))
    out = tmp_path / "out"
    code = kill_posterior_when(path, out, out / POSTERIOR_DIR / f"{RECENTRED_DIR}-1" / FILENAME,
                               1, 1e-3)
    assert code == -signal.SIGKILL, "the sampler ended before it was killed"
    resumed = run_posterior(load_case(path), out, resume=True)
    assert resumed.record.reached and resumed.record.recentred >= 1
    assert resumed.record.seed is None
