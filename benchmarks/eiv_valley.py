"""Where `eiv`'s posterior puts its mass on the bridge's records from the prior (issue 36).

Usage::

    python benchmarks/eiv_valley.py --replicates 20 --prior
    python benchmarks/eiv_valley.py --quick     # CI: one record, a short emcee run

The records, truths and search seeds of the product's calibration rows (benchmarks/posterior.py
``--product``), low-passed at 100 Hz. Per record, three 90 % intervals of each parameter:

- the product's: ``femupdate posterior`` with ``error_model = "eiv"`` and its other defaults
  (``run_posterior``, search included);
- emcee's, on the likelihood the product samples (``eiv`` built at the same search's fit,
  magnitude-adjusted), from the Gaussian at its mode: a peer sampler, to tell the sampler
  from the posterior;
- the Gaussian's at the likelihood's mode (climbed from the fit, as benchmarks/eiv_taper.py
  climbs it) with its Gauss–Newton precision over steps of 1e-4 of each range: a
  frequentist interval centred on the mode.

Printed per record: each interval's ends and the truth in sds of that Gaussian from the
mode; then, over the records, the share of intervals holding the truth per parameter for each
of the three, the largest gap between the product's and emcee's ends (in those sds), and
where emcee's median lies from the mode for E and kp1.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
from eiv_taper import climbed_mode
from posterior import (
    SEED,
    emcee_run,
    product_replicate,
    searched_record,
    searched_records,
)
from scipy.stats import norm

from femupdate.inference.error_models import problem_error_model
from femupdate.inference.jacobian import LOCAL_STEP, residual_jacobian
from femupdate.inference.laplace import laplace
from femupdate.paper.problems import bridge

#: emcee's walkers, and its evaluations at most per record (``--quick``: a short run)
WALKERS = 40
EMCEE_EVALS = 4_000 if "--quick" in sys.argv else 100_000
#: emcee stops early once its least effective sample size (ArviZ, second half) is this
EMCEE_ESS = 400
#: The half-width of a 90 % interval of a Gaussian, in sds
Z90 = float(norm.ppf(0.95))


def replicate(i: int, root: Path, prior_truths: bool, lowpass_hz: float) -> dict[str, Any]:
    """One record: the product's, emcee's and the mode's Gaussian's intervals."""
    child = np.random.SeedSequence(SEED).spawn(i + 1)[i]
    product = product_replicate(i, child, root / "product", 0, 0, 0, error_model="eiv",
                                truth=None if prior_truths else bridge.truth("viscous"),
                                lowpass_hz=lowpass_hz)
    problem, prior, unit, r, truth = searched_record(i, root / "emcee", prior_truths,
                                                     lowpass_hz)
    x = prior.to_search(unit)
    _, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
    model = problem_error_model(problem, r, "eiv", jac, point=x)

    def residuals(points: np.ndarray) -> np.ndarray:
        return problem.residuals_batch(prior.to_search(np.clip(points, 0.0, 1.0)))

    mode = climbed_mode(model, residuals, unit)
    r_mode, local = residual_jacobian(problem.residuals_batch, problem.bounds,
                                      prior.to_search(mode), step=LOCAL_STEP)
    gaussian = laplace(local, r_mode, mode, model, prior)
    sd = np.sqrt(np.diag(gaussian.cov_unit))
    rng = np.random.default_rng(np.random.SeedSequence([SEED, i]))
    samples = emcee_run(problem, model, prior, gaussian, rng, WALKERS, EMCEE_ESS,
                        EMCEE_EVALS)["samples"]

    def in_sds(unit_values: np.ndarray) -> np.ndarray:
        return (np.asarray(unit_values) - mode) / sd

    ends = np.array([product["intervals"][n] for n in prior.names]).T  # (2, n), physical
    product_unit = np.column_stack([prior.from_physical_column(j, ends[:, j])
                                    for j in range(prior.dim)])
    return {"replicate": i, "names": list(prior.names),
            "truth": in_sds(prior.from_physical(np.asarray(truth))),
            "product": in_sds(product_unit),
            "emcee": in_sds(np.quantile(samples, [0.05, 0.95], axis=0)),
            "emcee_median": in_sds(np.median(samples, axis=0))}


def held(row: dict[str, Any]) -> dict[str, np.ndarray]:
    """Whether each interval holds the truth, per parameter."""
    t = row["truth"]
    return {"product": (row["product"][0] <= t) & (t <= row["product"][1]),
            "emcee": (row["emcee"][0] <= t) & (t <= row["emcee"][1]),
            "mode's Gaussian": np.abs(t) <= Z90}


def describe(row: dict[str, Any]) -> str:
    """One record's lines: per parameter the truth and the intervals, in the Gaussian's sds
    from the mode."""
    return "\n".join(
        f"  {n:4s} truth {row['truth'][j]:+6.2f}  product [{row['product'][0, j]:+6.2f}, "
        f"{row['product'][1, j]:+6.2f}]  emcee [{row['emcee'][0, j]:+6.2f}, "
        f"{row['emcee'][1, j]:+6.2f}]  mode's Gaussian [{-Z90:+.2f}, {Z90:+.2f}]"
        for j, n in enumerate(row["names"]))


def main() -> None:
    rows = searched_records(__doc__.split("\n\n")[0], 20, replicate,
                            lambda row: "\n" + describe(row))
    names = rows[0]["names"]
    print(f"\nshare of 90 % intervals holding the truth over {len(rows)} records:")
    for label in ("product", "emcee", "mode's Gaussian"):
        shares = np.mean([held(row)[label] for row in rows], axis=0)
        print(f"  {label:16s} " + " ".join(f"{n} {s:.2f}" for n, s in zip(names, shares,
                                                                           strict=True)))
    gap = max(float(np.max(np.abs(row["product"] - row["emcee"]))) for row in rows)
    print(f"largest gap between the product's and emcee's interval ends: {gap:.2f} sd")
    for name in ("E", "kp1"):
        j = names.index(name)
        medians = np.array([row["emcee_median"][j] for row in rows])
        print(f"emcee's median of {name} from the mode: mean |·| {np.mean(np.abs(medians)):.2f} "
              f"sd, largest {medians[np.argmax(np.abs(medians))]:+.2f} sd")


if __name__ == "__main__":
    main()
