"""`eiv`'s likelihood along kp1, with and without the taper before its transform (issue 36).

Usage::

    python benchmarks/eiv_taper.py --replicates 12 --prior
    python benchmarks/eiv_taper.py --quick     # CI: one record

The records, truths and search seeds of the product's calibration rows (benchmarks/posterior.py
``--product``), low-passed at 100 Hz: each record fitted by the example's own ``[search]``
(``f_target`` removed), then ``eiv`` built at that fit as ``femupdate posterior`` builds it:
its transform of the prewhitened blocks tapered (src/femupdate/inference/input_noise.py,
``taper``). Beside it the same whitening with an untapered transform (the rectangular window
``eiv`` had before). Per record:

- ℓ along kp1 alone, the others at the truth, at 81 steps of 1e-5 and of 1e-4 of its range
  centred on the truth: how many local maxima, and ℓ's range. A line above the band (the
  abutments' mode, whose phase over the record turns with kp1) leaks into the band through
  the rectangular window's sidelobes and makes ℓ a comb of needles; the taper's sidelobes
  fall as 1/Δf³.
- 2(ℓ(mode) − ℓ(truth)) under the tapered likelihood, its mode climbed from the search's fit
  (least squares on the whitened residuals, each block weighted by ℓ's slope, until ℓ rises
  less than 1e-3): χ² with as many degrees of freedom as parameters where the likelihood is
  right (its mean, and the share beyond its 90 % quantile, against 0.10).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
from posterior import searched_record, searched_records
from scipy.optimize import least_squares
from scipy.stats import chi2

from femupdate.inference.error_models import problem_error_model
from femupdate.inference.jacobian import residual_jacobian
from femupdate.inference.likelihood import ErrorModel

#: The scans: steps (share of kp1's range) and steps each side of the truth
STEPS, HALF_WIDTH = (1e-5, 1e-4), 40
#: Rounds of the climb to the mode at most
ROUNDS = 8


def untapered(model: ErrorModel) -> ErrorModel:
    """The same whitening with the rectangular window (no taper) before the transform."""
    return dataclasses.replace(model, spectral=tuple(
        dataclasses.replace(trial, taper_fraction=0.0) for trial in model.spectral))


def scan(loglike_rows: Any, centre: np.ndarray, j: int, step: float) -> tuple[int, float]:
    """(local maxima, range) of ℓ along parameter j through ``centre`` (unit cube)."""
    points = np.repeat(centre[None, :], 2 * HALF_WIDTH + 1, axis=0)
    points[:, j] = np.clip(centre[j] + step * np.arange(-HALF_WIDTH, HALF_WIDTH + 1), 0, 1)
    values = loglike_rows(points)
    rises = np.diff(values)
    return int(np.sum((rises[:-1] > 0) & (rises[1:] < 0))), float(np.ptp(values))


def replicate(i: int, root: Path, prior_truths: bool, lowpass_hz: float) -> dict[str, Any]:
    """One calibration record: the scans, and the statistic at the truth."""
    problem, prior, unit, r, truth = searched_record(i, root, prior_truths, lowpass_hz)
    x = prior.to_search(unit)
    _, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
    tapered = problem_error_model(problem, r, "eiv", jac, point=x)

    def residuals(points: np.ndarray) -> np.ndarray:
        return problem.residuals_batch(prior.to_search(np.clip(points, 0.0, 1.0)))

    def loglike(z: np.ndarray) -> float:
        return float(tapered.loglike_rows(residuals(z[None, :]))[0])

    truth_unit = prior.from_physical(np.asarray(truth))
    kp1 = list(prior.names).index("kp1")
    row: dict[str, Any] = {"replicate": i, "dim": prior.dim}
    for name, model in (("untapered", untapered(tapered)), ("tapered", tapered)):
        for step in STEPS:
            row[f"{name} {step:g}"] = scan(lambda p, m=model: m.loglike_rows(residuals(p)),
                                           truth_unit, kp1, step)
    mode = climbed_mode(tapered, residuals, unit)
    row["statistic"] = 2.0 * (loglike(mode) - loglike(truth_unit))
    return row


def climbed_mode(model: ErrorModel, residuals: Any, start: np.ndarray) -> np.ndarray:
    """The likelihood's mode (unit cube), climbed from ``start`` by least squares on the
    whitened residuals (``residuals``: points (k, n) → rows), each block weighted by ℓ's slope,
    until ℓ rises less than 1e-3."""

    def loglike(z: np.ndarray) -> float:
        return float(model.loglike_rows(residuals(z[None, :]))[0])

    mode = np.asarray(start, dtype=float)
    top = loglike(mode)
    for _ in range(ROUNDS):
        scale = np.sqrt(model.weights(residuals(mode[None, :])[0]))
        point = least_squares(
            lambda z, scale=scale: model.whiten(residuals(z[None, :]))[0] * scale, mode,
            bounds=(0.0, 1.0), diff_step=1e-6, x_scale="jac", xtol=1e-15, ftol=1e-15,
            gtol=1e-15, max_nfev=200).x
        value = loglike(point)
        if value < top + 1e-3:
            break
        mode, top = point, value
    return mode


def describe(row: dict[str, Any]) -> str:
    """One record's line: the scans, then the statistic."""
    scans = ", ".join(
        f"{step:g}: untapered {row[f'untapered {step:g}'][0]} "
        f"({row[f'untapered {step:g}'][1]:.1f}), tapered {row[f'tapered {step:g}'][0]} "
        f"({row[f'tapered {step:g}'][1]:.1f})" for step in STEPS)
    return (f"local maxima of ℓ along kp1 (range of ℓ) at steps of {scans}; "
            f"2(ℓ(mode) − ℓ(truth)) {row['statistic']:.2f}")


def main() -> None:
    rows = searched_records(__doc__.split("\n\n")[0], 12, replicate, describe)
    dim = rows[0]["dim"]
    statistic = np.array([row["statistic"] for row in rows])
    for name in ("untapered", "tapered"):
        print(f"{name}: median local maxima over {len(rows)} records "
              + ", ".join(f"{np.median([row[f'{name} {step:g}'][0] for row in rows]):g} at "
                          f"steps of {step:g}" for step in STEPS))
    print(f"tapered: 2(ℓ(mode) − ℓ(truth)) mean {statistic.mean():.2f} (χ²({dim}): {dim}), "
          f"beyond χ²({dim})'s 90 % quantile in {np.mean(statistic > chi2.ppf(0.9, dim)):.2f} "
          "(0.10)")


if __name__ == "__main__":
    main()
