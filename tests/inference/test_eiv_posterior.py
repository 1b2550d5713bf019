"""``femupdate posterior`` with error model ``"eiv"``: the case's records noisy at the table
too, on the small two-storey case; what it samples, what it records and what it says."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from two_storey import write_case

from femupdate.case import load_case
from femupdate.errors import ConfigError
from femupdate.inference.error_models import problem_error_model
from femupdate.inference.records import PosteriorRecord
from femupdate.pipeline.posterior.run import run_posterior


def test_the_posterior_samples_the_magnitude_adjusted_errors_in_the_variables(
        tmp_path: Path) -> None:
    case_path = write_case(tmp_path / "case", samples=200)
    got = run_posterior(load_case(case_path), tmp_path / "out", error_model="eiv", runs=2,
                        max_runs=2)
    assert got.record.reached and got.record.error_model == "eiv"
    model = got.error_model
    assert model.kind == "eiv" and len(model.spectral) == 1
    # the counts carry the magnitude adjustment of the Jacobian at the fit: not the raw ones
    problem = got.search.problem
    x = np.asarray(got.search.summary.runs[got.search.summary.best.run].x, dtype=float)
    raw = problem_error_model(problem, problem.residuals_batch(x[None, :])[0], "eiv", point=x)
    assert not np.allclose(model.counts, raw.counts)
    saved = got.summary.posterior.model_dump()  # summary.json: no line at this fit
    assert saved["error_model"] == "eiv" and saved["error_model_notes"] == []


def test_model_classes_refuse_a_whitening_error_model(tmp_path: Path) -> None:
    case_path = write_case(tmp_path / "case", samples=200)
    first = run_posterior(load_case(case_path), tmp_path / "a", error_model="eiv", runs=1)
    with pytest.raises(ConfigError, match="evidences would not be of one likelihood"):
        run_posterior(load_case(case_path), tmp_path / "b", error_model="eiv", runs=1,
                      counts_from=first.error_model)


def test_the_console_and_report_say_what_the_error_model_left_out() -> None:
    from rich.console import Console

    from femupdate.pipeline.posterior.console import print_posterior

    words = "error model 'eiv' left out 225.1–230.6 Hz of fitted trial 1"
    record = PosteriorRecord(method="tmcmc", error_model="eiv", samples=10, seed=1, nfev=10,
                             wall_s=0.1, reached=False, message="stopped", log_evidence=None,
                             ess=None, error_model_notes=[words])
    console = Console(record=True, width=400)
    print_posterior(record, console)
    assert words in console.export_text()
