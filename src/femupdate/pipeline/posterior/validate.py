"""``femupdate validate --posterior DIR``: the posterior's predictive bands on any trials."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from femupdate.case import Case
from femupdate.errors import FemupdateError
from femupdate.pipeline.posterior.bands import Bands, noise_levels, trial_bands
from femupdate.pipeline.posterior.run import thinned
from femupdate.pipeline.results import POSTERIOR_FILE, SUMMARY_FILE, read_summary
from femupdate.problem.update import TrialProblem
from femupdate.trials.experiment import Experiment, load_experiments

#: Samples the bands are computed at, by default.
DEFAULT_SAMPLES = 200


def posterior_samples(results_dir: Path, names: Sequence[str]) -> np.ndarray:
    """The physical samples of ``results_dir/posterior.npz``, columns in ``names`` order;
    FemupdateError naming the file when there are none or they are of other parameters."""
    path = Path(results_dir) / POSTERIOR_FILE
    if not path.is_file():
        raise FemupdateError(f"{path}: no posterior samples (allowed: the --out directory of "
                             "`femupdate posterior`, after it reached the posterior)")
    with np.load(path, allow_pickle=False) as data:
        stored = [str(n) for n in data["names"]]
        samples = data["samples"]
    if sorted(stored) != sorted(names):
        raise FemupdateError(f"{path}: samples of the parameters {stored}, the case has "
                             f"{list(names)} (allowed: the posterior of this case's parameters)")
    return samples[:, [stored.index(n) for n in names]]


def validate_posterior(case: Case, results_dir: Path, *, samples: int = DEFAULT_SAMPLES,
                       seed: int = 0, experiments: Sequence[Experiment] | None = None
                       ) -> list[Bands]:
    """The 5–95 % predictive bands of the posterior in ``results_dir`` on every trial of
    ``case`` (fitted or not), at ``samples`` of its samples, with the noise levels of the
    fit (its summary's channel errors); the noise draws from ``seed``."""
    names = case.parameter_names
    subset = thinned(posterior_samples(results_dir, names), samples)
    summary = read_summary(Path(results_dir) / SUMMARY_FILE)
    levels = noise_levels(summary)
    rng = np.random.default_rng(seed)
    out = []
    for exp in experiments or load_experiments(case):
        bands = trial_bands(TrialProblem(case, exp), subset, names, levels, rng)
        if bands is not None:
            out.append(bands)
    return out
