"""How far the magnitude adjustment alone is from the sandwich, per parameter, for `eiv`.

Usage::

    python benchmarks/eiv_curvature.py --replicates 18 --prior --lowpass-hz 100
    python benchmarks/eiv_curvature.py --quick     # CI: one record

The records, truths and search seeds of the product's calibration rows (benchmarks/posterior.py
``--product``): each record fitted by the example's own ``[search]`` (``f_target`` removed),
then, at the best fit, the unadjusted ``eiv`` and its Jacobian over 1 % steps (as
``femupdate posterior`` takes them), H its Gauss–Newton precision and V the exact variance of
its score (``score_meats``). The magnitude adjustment k = n / tr(H⁻¹V), which ``eiv`` takes,
gives each parameter the sd √(diag(H⁻¹)/k), the sandwich's on average over the parameters;
the sandwich itself gives √diag(H⁻¹VH⁻¹). Printed per record: their ratio per parameter, and
k; then the range of each parameter's ratio over the records. (A curvature adjustment that gave
``eiv`` the sandwich in every direction was tried and dropped: docs/history.md, "The curvature
adjustment of `eiv`".)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from posterior import searched_record, searched_records

from femupdate.inference.error_models import problem_error_model
from femupdate.inference.input_noise import score_meats
from femupdate.inference.jacobian import residual_jacobian


def sd_ratios(precision: np.ndarray, meat: np.ndarray) -> tuple[np.ndarray, float]:
    """(the sandwich's sd over the magnitude adjustment's, per parameter; k)."""
    inverse = np.linalg.inv(precision)
    k = precision.shape[0] / float(np.trace(inverse @ meat))
    sandwich = inverse @ meat @ inverse
    return np.sqrt(np.diag(sandwich)) / np.sqrt(np.diag(inverse) / k), k


def replicate(i: int, root: Path, prior_truths: bool, lowpass_hz: float | None
              ) -> dict[str, Any]:
    """One calibration record: its search's fit, then the ratios there."""
    problem, prior, unit, r, _ = searched_record(i, root, prior_truths, lowpass_hz)
    x = prior.to_search(unit)
    r_jac, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
    model = problem_error_model(problem, r, "eiv", None, point=x)
    ((precision, meat),) = score_meats(problem, model, x, r, [(r_jac, jac)])
    ratios, k = sd_ratios(precision, meat)
    return {"replicate": i, "names": list(prior.names), "ratios": ratios, "k": k}


def main() -> None:
    rows = searched_records(
        __doc__.split("\n\n")[0], 18, replicate,
        lambda row: f"k {row['k']:.3f}; sandwich sd / magnitude-adjusted sd: " + " ".join(
            f"{n} {v:.2f}" for n, v in zip(row["names"], row["ratios"], strict=True)))
    ratios = np.array([row["ratios"] for row in rows])
    print(f"\nsandwich sd / magnitude-adjusted sd over {len(rows)} records (least–most):")
    print("  ".join(f"{n} {lo:.2f}–{hi:.2f}" for n, lo, hi
                    in zip(rows[0]["names"], ratios.min(axis=0), ratios.max(axis=0),
                           strict=True)))


if __name__ == "__main__":
    main()
