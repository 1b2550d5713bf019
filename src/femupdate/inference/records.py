"""What ``summary.json`` holds of the uncertainty: typed records, written and read back.

``Summary.laplace`` (every least-squares run: the Gauss–Newton approximation at the best fit)
and ``Summary.posterior`` (``femupdate posterior``: the samples of TMCMC) are optional fields,
so a summary written before them still reads. Everything is in physical units; intervals are
the 5 and 95 % quantiles (a 90 % credible interval).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["LaplaceRecord", "Marginal", "PosteriorRecord", "StageRecord", "SurrogateCheckRecord",
           "marginals"]


class _Record(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Marginal(_Record):
    """One quantity's posterior: mean, standard deviation and 5/50/95 % quantiles."""

    mean: float
    sd: float
    q05: float
    q50: float
    q95: float


class LaplaceRecord(_Record):
    """The Laplace (Gauss–Newton) approximation at the best fit (``summary.json laplace``).

    ``params``: each parameter's marginal (a log-scale parameter's is lognormal: Gaussian in
    log10); ``correlations``: of the search-space coordinates, in ``names`` order (None where
    a parameter has no variance the data fix); ``undetermined``: the parameters whose 90 %
    interval covers most of their bounds (``sentences`` says so in words); ``not_quadratic``:
    the determined ones whose φ is far from quadratic over their interval, for which the
    Gaussian is not to be trusted (said in words too); ``note``: why it is missing, if it is;
    ``noise``: per fitted trial the noise levels an error model fitted, for a plug-in that
    fits them (none of the product's kinds does: empty); ``caveats``: what else to know
    before trusting the intervals.
    """

    error_model: str = ""
    names: list[str] = Field(default_factory=list)
    params: dict[str, Marginal] = Field(default_factory=dict)
    correlations: list[list[float | None]] = Field(default_factory=list)
    undetermined: list[str] = Field(default_factory=list)
    not_quadratic: list[str] = Field(default_factory=list)
    sentences: list[str] = Field(default_factory=list)
    nfev: int = 0
    note: str | None = None
    noise: list[dict[str, Any]] = Field(default_factory=list)
    caveats: list[str] = Field(default_factory=list)

    def flagged_sentences(self) -> list[str]:
        """The sentences worth saying: of the parameters the data do not determine, and of
        those the Gaussian at the best fit does not describe."""
        flagged = [*self.undetermined, *self.not_quadratic]
        return [s for s in self.sentences
                if any(s.startswith((f"{n} ", f"{n}:")) for n in flagged)]


class StageRecord(_Record):
    """One TMCMC stage: its tempering exponent, acceptance rate and effective sample size."""

    beta: float
    acceptance: float
    ess: float


class SurrogateCheckRecord(_Record):
    """How a surrogate-aided posterior (``method = "surrogate"``) got there
    (:mod:`femupdate.inference.surrogate`): its true model runs (all included) and design
    batches, the last batch's log-likelihood error against its tolerance (nats), and the
    final check at ``check_runs`` of its samples run on the true model: the importance weights
    exp(true − surrogate log L)'s effective share (``check_ess``, at least ``min_check_ess``
    to pass), each mean's shift under them in posterior sds (``shifts_sd``), each sd's ratio,
    the share of the reweighted posterior inside each 90 % interval (``coverage``) and of
    the surrogate's inside the reweighted one's (``reverse_coverage``), both within
    ``coverage_band`` to pass; ``failures``: each design point where the model failed, with
    its message; ``history``: runs and error after each batch."""

    model_runs: int
    iterations: int
    accuracy_nats: float
    tolerance_nats: float
    check_runs: int
    check_ess: float
    min_check_ess: float
    shifts_sd: dict[str, float | None] = Field(default_factory=dict)
    sd_ratios: dict[str, float | None] = Field(default_factory=dict)
    coverage: dict[str, float | None] = Field(default_factory=dict)
    reverse_coverage: dict[str, float | None] = Field(default_factory=dict)
    coverage_band: list[float] = Field(default_factory=list)
    check_error_nats: float
    passed: bool
    failures: list[str] = Field(default_factory=list)
    history: list[dict[str, float]] = Field(default_factory=list)


class PosteriorRecord(_Record):
    """The sampled posterior (``summary.json posterior``).

    ``correlations``: of the parameters over every sample (search space: log10 on a log
    scale), in ``names`` order; ``joint_correlations``: of the parameters, natural frequencies
    and damping ratios over the ``modes_from`` samples whose modes were computed, in
    ``joint_names`` order.

    ``reached`` is False when a sampler run ran out of budget before the tempering exponent
    reached 1: then ``message`` says so, and no samples, marginals or evidence are reported.

    ``runs`` independent runs are pooled: ``samples`` counts all their samples, ``nfev`` and
    ``wall_s`` (the runs' own times) are summed, ``stages`` are the first run's,
    ``log_evidence`` is the log of the mean of the runs' evidences (``log_evidence_runs``).
    ``ess_params``: each parameter's effective samples, the smaller of the runs' own
    estimates and what the scatter of their means shows (``ess`` is the smallest); ``rhat``:
    Gelman–Rubin's R̂ (None with one run); ``unsettled``: the parameters with too few
    effective samples for their intervals to be trusted, and ``agreement`` the verdict in
    words (:mod:`femupdate.pipeline.posterior.agreement`).

    ``surrogate``: with ``method = "surrogate"``, its design and final check
    (:class:`SurrogateCheckRecord`; ``nfev`` is then its true model runs).

    ``start_phi``: φ of the fit the error model and the first population come from (the
    search's best, or a better fit the sampler found: ``recentred`` times sampled again);
    ``start_warnings``: what the start's checks said, in words (the search's best not found
    again, a better fit found, :mod:`femupdate.pipeline.posterior.start`);
    ``error_model_notes``: what the error model left out of the records, in words
    (:meth:`~femupdate.inference.likelihood.ErrorModel.notes`).
    """

    method: str
    error_model: str
    samples: int
    seed: int | None
    nfev: int
    wall_s: float
    reached: bool
    message: str
    log_evidence: float | None
    ess: float | None
    stages: list[StageRecord] = Field(default_factory=list)
    names: list[str] = Field(default_factory=list)
    params: dict[str, Marginal] = Field(default_factory=dict)
    correlations: list[list[float | None]] = Field(default_factory=list)
    frequencies_hz: dict[str, Marginal] = Field(default_factory=dict)
    damping_ratios: dict[str, Marginal] = Field(default_factory=dict)
    modes_from: int = 0
    joint_names: list[str] = Field(default_factory=list)
    joint_correlations: list[list[float | None]] = Field(default_factory=list)
    undetermined: list[str] = Field(default_factory=list)
    sentences: list[str] = Field(default_factory=list)
    failed_evaluations: int = 0
    failure: str | None = None
    runs: int = 1
    log_evidence_runs: list[float] = Field(default_factory=list)
    ess_params: dict[str, float | None] = Field(default_factory=dict)
    rhat: dict[str, float | None] = Field(default_factory=dict)
    unsettled: list[str] = Field(default_factory=list)
    agreement: str = ""
    start_phi: float | None = None
    recentred: int = 0
    start_warnings: list[str] = Field(default_factory=list)
    error_model_notes: list[str] = Field(default_factory=list)
    surrogate: SurrogateCheckRecord | None = None

    def evidence_spread(self) -> str:
        """" (runs: LOW to HIGH, sd S)" of the log-evidence over several runs, else ""."""
        runs = np.asarray(self.log_evidence_runs, dtype=float)
        if runs.size < 2:
            return ""
        return (f" (runs: {runs.min():.6g} to {runs.max():.6g}, sd "
                f"{runs.std(ddof=1):.2g})")


def marginals(samples: np.ndarray, names: list[str]) -> dict[str, Marginal]:
    """Mean, sd and 5/50/95 % quantiles of each column of equally weighted ``samples`` (k, n)
    (NaN rows, e.g. a mode that could not be computed, left out column by column)."""
    out = {}
    for j, name in enumerate(names):
        col = samples[:, j]
        col = col[np.isfinite(col)]
        if col.size == 0:
            continue
        q05, q50, q95 = np.quantile(col, [0.05, 0.5, 0.95])
        out[name] = Marginal(mean=float(col.mean()), sd=float(col.std(ddof=1)) if col.size > 1
                             else 0.0, q05=float(q05), q50=float(q50), q95=float(q95))
    return out


def correlation_rows(matrix: np.ndarray) -> list[list[float | None]]:
    """A correlation matrix as JSON rows, None where it is not defined (NaN)."""
    return [[None if not np.isfinite(v) else float(v) for v in row] for row in matrix]


def as_dict(record: BaseModel | None) -> dict[str, Any] | None:
    return None if record is None else record.model_dump()
