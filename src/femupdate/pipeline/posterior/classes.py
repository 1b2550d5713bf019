"""Model-class selection: the evidence of several model forms of the same data, side by side.

Each class (a case: the same trials and channels, another model or parameters) gets its
posterior and log-evidence log Z_i = log p(D | M_i) by TMCMC (:func:`run_posterior`); with
equal prior probabilities of the classes, their posterior probabilities are

    P(M_i | D) = Z_i / Σ_j Z_j = exp(log Z_i − logsumexp_j log Z_j).

The evidences are comparable only under one likelihood of the data: the error model's
effective counts N_c are measured once, at the first class's best fit, and every class uses
them (:func:`run_posterior`'s ``counts_from``); measured at each class's own best fit they
would make each class's likelihood a different function of the same residuals.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from femupdate.case import Case
from femupdate.inference.records import PosteriorRecord
from femupdate.pipeline.posterior.run import PosteriorResult, run_posterior
from femupdate.runs import Execution


@dataclass(frozen=True)
class ClassRow:
    """One model class of a comparison."""

    name: str
    log_evidence: float | None
    probability: float
    parameters: int
    best_nmse_percent: float
    nfev: int
    wall_s: float
    record: PosteriorRecord


def class_probabilities(log_evidences: Sequence[float | None]) -> np.ndarray:
    """Posterior probabilities of classes of equal prior probability from their
    log-evidences; a class without an evidence (its sampler did not reach β = 1) gets none
    (NaN) and is left out of the others' normalisation."""
    logz = np.array([np.nan if v is None else float(v) for v in log_evidences])
    out = np.full(logz.size, np.nan)
    ok = np.isfinite(logz)
    if ok.any():
        out[ok] = np.exp(logz[ok] - logsumexp(logz[ok]))
    return out


def compare_classes(cases: Mapping[str, Case], out_dir: Path, *, samples: int | None = None,
                    seed: int | None = None, workers: int | None = None,
                    execution: Execution | None = None, resume: bool = False
                    ) -> tuple[list[ClassRow], dict[str, PosteriorResult]]:
    """The posterior and evidence of every class (``out_dir/NAME`` each), side by side.

    Parameters
    ----------
    cases : mapping of name to Case
        The classes, the first the reference whose best fit fixes the error model's counts.
    out_dir : Path
    samples, seed, workers : int or None
        Override each case's ``[posterior]`` samples and seed, and ``[search]`` workers.
    execution : Execution or None
    resume : bool
        Continue each class's stores.
    """
    results: dict[str, PosteriorResult] = {}
    shared = None
    for name, case in cases.items():
        result = run_posterior(case, out_dir / name, samples=samples, seed=seed,
                               workers=workers, execution=execution, resume=resume,
                               counts_from=shared)
        shared = shared or result.error_model
        results[name] = result
    probs = class_probabilities([r.record.log_evidence for r in results.values()])
    rows = [ClassRow(name, r.record.log_evidence, float(p), len(r.record.names),
                     r.summary.best.nmse_percent, r.record.nfev, r.record.wall_s, r.record)
            for (name, r), p in zip(results.items(), probs, strict=True)]
    return rows, results


def format_classes(rows: Sequence[ClassRow]) -> str:
    """The comparison as a markdown table."""
    lines = ["| class | parameters | best NMSE % | log-evidence (over the runs) | "
             "P(class given data) | evaluations | wall s |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        logz = ("not reached" if r.log_evidence is None
                else f"{r.log_evidence:.2f}{r.record.evidence_spread()}")
        prob = "–" if not np.isfinite(r.probability) else f"{r.probability:.3g}"
        lines.append(f"| {r.name} | {r.parameters} | {r.best_nmse_percent:.3g} | {logz} | "
                     f"{prob} | {r.nfev:,} | {r.wall_s:.1f} |")
    return "\n".join(lines)
