"""What the viscous bridge's records say about kp1: the abutment modes' line (issue 36).

    python benchmarks/abutment_line.py --replicates 50 [--prior] [--lowpass-hz 100]
                                       [--band-hz 100] [--needle] [--out rows.jsonl]
    python benchmarks/abutment_line.py --quick     # CI: one record

Each replicate is a record of benchmarks/posterior.py's product calibration (the same truth,
noise and search seed), fitted by the example's own ``[search]`` (``f_target`` removed): least
squares on the displacement records, as ``femupdate run`` ends. Then a likelihood that weighs
each frequency by its noise is evaluated at that fit and at the truth: errors in the variables
(src/femupdate/inference/input_noise.py), with the model's response to the table's noise
rebuilt at each point, so that the whitening and its log-determinant follow θ (``eiv-all`` fixes
them at the fit), over every frequency ``eiv-all``'s gain rule keeps (its leakage rule, applied
with the levels fitted at the search's fit, leaves most of them out on this bridge). Its noise
levels are fitted three ways (``--band-hz``: over the frequencies up to it only):

- ``at fit``: at the search's fit, as ``eiv-all`` fits them;
- ``lines out``: the same, with the frequencies where the fit's whitened residual holds a line
  (power beyond the 1e-3 tail of its χ², Bonferroni over the frequencies) left out of the
  fit of the levels, not of the likelihood: a deterministic misfit is not noise;
- ``oracle``: at the truth.

Beside them, ``eiv-all`` itself as the lab builds it at the fit (fixed whitening, its own
frequencies and levels). Prints per record kp1's error (share of its range), the frequencies
this likelihood weighs and those ``eiv-all`` keeps, the table noise level each way over the
oracle's, Δℓ = ℓ(truth) − ℓ(fit) each way, and the strongest line of the fit's whitened
residual under the oracle's levels; then the share of records whose Δℓ exceeds 10 (the fit
e^10 times less likely than the truth) and, with ``--needle``, how far ℓ falls along kp1 from
the truth under the oracle's levels (the width of its peak).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from posterior import problem_error_model, searched_record
from scipy.stats import chi2

from femupdate.inference.input_noise import (
    GAIN_RANGE,
    TrialWhitening,
    _prewhitened,
    block_scales,
    decayed_impulse_responses,
    fit_noise_levels,
    noise_transfers,
    offset_regressors,
    whitened_nuisance,
    whitening_matrices,
    without_offsets,
)

#: A frequency of the fit's whitened residual is a line when its power is beyond this tail of
#: its χ² (2C degrees of freedom), Bonferroni over the frequencies
LINE_TAIL = 1e-3
#: Rounds of fitting the levels and leaving the lines out
LINE_ROUNDS = 3
#: Δℓ beyond which the fit is called excluded
EXCLUDED = 10.0
#: Offsets of kp1 from the truth (share of its range) for ``--needle``
NEEDLE = (1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2)


class Trial:
    """The one fitted trial of the bridge with the fixed parts of ``eiv-all`` built at the search's
    fit (its AR prewhitening and block scales), the frequencies this likelihood weighs, and
    the noise paths at each point it is evaluated at (built once a point)."""

    def __init__(self, problem: Any, fit_x: np.ndarray, fit_r: np.ndarray,
                 band_hz: float | None = None) -> None:
        (self.trial,) = problem.fitted
        self.problem = problem
        self.model = problem_error_model(problem, fit_r, "eiv-all", point=fit_x)
        (fixed,) = self.model.spectral
        self.blocks = list(fixed.blocks)
        self.ar = self.model.ar[self.blocks]
        self.starts = self.model.starts[self.blocks]
        self.stops = self.model.stops[self.blocks]
        raw = self.raw(fit_r)
        self.scales = block_scales(self.trial, problem.values(fit_x), raw)
        # every frequency eiv's gain rule keeps, not only those its leakage rule keeps at the
        # fit: there its fitted levels leave most of them out (see the module docstring)
        self.n = raw.shape[0] - self.ar.shape[1]
        *_, centre = paths = decayed_impulse_responses(self.trial, problem.values(fit_x))
        gain = noise_transfers(*paths[:2], centre, self.scales, self.ar, self.n)[3]
        bins = np.arange(1, (self.n + 1) // 2)
        bins = bins[np.all(gain[bins] / gain[bins].max(axis=0) >= GAIN_RANGE, axis=1)]
        if band_hz is not None:
            bins = bins[bins / (self.n * self.trial.experiment.dt) <= band_hz]
        self.bins = bins
        self.leakage_kept = fixed.bins.size
        self._points: dict[bytes, dict[str, Any]] = {}

    def raw(self, r: np.ndarray) -> np.ndarray:
        """The trial's residual blocks (N, C) of a residual vector."""
        return np.column_stack([r[a:b] for a, b in zip(self.starts, self.stops, strict=True)])

    def at(self, x: np.ndarray) -> dict[str, Any]:
        """At search point ``x``: the prewhitened residual blocks, their transform less the
        offsets' and drifts' fit, the table's transfer and each sensor's gain at the kept
        frequencies through the prewhitening, and the offsets' and drifts' responses."""
        key = np.asarray(x, dtype=float).tobytes()
        if key not in self._points:
            raw = self.raw(self.problem.residuals(x))
            values = self.problem.values(x)
            input_path, output_paths, centre = decayed_impulse_responses(self.trial, values)
            _, _, transfer, gain = noise_transfers(input_path, output_paths, centre,
                                                   self.scales, self.ar, self.n)
            regressors = offset_regressors(self.trial, values, self.scales, raw.shape[0])
            self._points[key] = {
                "prewhitened": _prewhitened(raw, self.ar), "regressors": regressors,
                "coefficients": np.fft.rfft(without_offsets(raw, regressors, self.ar),
                                            axis=0)[self.bins],
                "transfer": transfer[self.bins], "gain": gain[self.bins]}
        return self._points[key]

    def levels(self, x: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, float]:
        """Noise levels (each sensor's, the table's) fitted by Whittle's likelihood to the
        residual at search point ``x`` over the kept frequencies, as ``eiv-all`` fits them."""
        point = self.at(x)
        return fit_noise_levels(point["coefficients"][keep], point["gain"][keep],
                                point["transfer"][keep], self.n)

    def loglike(self, x: np.ndarray, levels: tuple[np.ndarray, float]
                ) -> tuple[float, np.ndarray]:
        """(ℓ, whitened power per frequency) at search point ``x`` with the noise levels
        ``levels``: −½‖P w‖² − Σ_k log det S_k − ½ log det(B_wᵀB_w), w the whitened residual, P
        the projection off the whitened offset and drift responses B_w, all built at ``x``."""
        sigma_outputs, sigma_input = levels
        point, n = self.at(x), self.n
        transfer, gain = point["transfer"], point["gain"]
        whitening = TrialWhitening(
            tuple(self.blocks), self.bins,
            whitening_matrices(gain, transfer, sigma_outputs, sigma_input, n),
            sigma_outputs, sigma_input, 0.0, taper_fraction=0.0)  # its rfft is untapered
        d = n * sigma_outputs ** 2 * gain
        log_det = float(np.sum(np.log(d)) + np.sum(np.log1p(
            n * sigma_input ** 2 * np.sum(np.abs(transfer) ** 2 / d, axis=1))))
        basis, singular = whitened_nuisance(whitening, point["regressors"], self.ar)
        pre = point["prewhitened"]
        w = whitening.apply([pre[:, c][None, :] for c in range(pre.shape[1])])[0]
        w -= basis @ (basis.T @ w)
        channels, frequencies = pre.shape[1], self.bins.size
        half = channels * frequencies
        power = (w[:half] ** 2 + w[half:] ** 2).reshape(channels, frequencies).sum(axis=0)
        return -0.5 * float(w @ w) - log_det - float(np.sum(np.log(singular))), power

    def levels_without_lines(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        """:meth:`levels` at ``x``, refitted with the frequencies where the whitened residual
        there holds a line left out (``LINE_ROUNDS`` rounds)."""
        frequencies = self.bins.size
        threshold = chi2.isf(LINE_TAIL / frequencies, 2 * len(self.blocks))
        keep = np.ones(frequencies, dtype=bool)
        for _ in range(LINE_ROUNDS):
            levels = self.levels(x, keep)
            keep = self.loglike(x, levels)[1] <= threshold
        return self.levels(x, keep)


def replicate(i: int, root: Path, prior_truth: bool, lowpass_hz: float | None,
              needle: bool, band_hz: float | None = None) -> dict[str, Any]:
    """One record: the search's fit, then ℓ at it and at the truth under each way of fitting
    the noise levels."""
    problem, prior, unit, r, truth_values = searched_record(i, root, prior_truth, lowpass_hz)
    fit_x, truth_x = prior.to_search(unit), prior.to_search(prior.from_physical(truth_values))
    trial = Trial(problem, fit_x, r, band_hz)
    every = np.ones(trial.bins.size, dtype=bool)
    ways = {"at fit": trial.levels(fit_x, every),
            "lines out": trial.levels_without_lines(fit_x),
            "oracle": trial.levels(truth_x, every)}
    row: dict[str, Any] = {"replicate": i, "names": list(prior.names),
                           "fit_error": (unit - prior.from_physical(truth_values)).tolist(),
                           "delta": {}, "table_level": {},
                           "frequencies": [int(trial.bins.size), int(trial.leakage_kept)]}
    # eiv as femupdate's lab builds it: fixed at the fit, its own frequencies and levels
    row["delta"]["eiv"] = (trial.model.loglike(problem.residuals(truth_x))
                           - trial.model.loglike(r))
    for way, levels in ways.items():
        at_truth, _ = trial.loglike(truth_x, levels)
        at_fit, power = trial.loglike(fit_x, levels)
        row["delta"][way] = at_truth - at_fit
        row["table_level"][way] = levels[1] / ways["oracle"][1]
        if way == "oracle":
            k = int(np.argmax(power))
            row["line_hz"] = float(trial.bins[k] / trial.n / trial.trial.experiment.dt)
            row["line_power"] = float(power[k])
    if needle:
        truth_unit = prior.from_physical(truth_values)
        peak = trial.loglike(truth_x, ways["oracle"])[0]
        row["needle"] = {}
        for offset in NEEDLE:
            drops = []
            for sign in (-1.0, 1.0):
                u = truth_unit.copy()
                u[1] += sign * offset
                drops.append(peak - trial.loglike(prior.to_search(u), ways["oracle"])[0])
            row["needle"][offset] = drops
    return row


def summary(rows: list[dict[str, Any]]) -> str:
    """The share of records whose fit each way excludes, and Δℓ's median and range."""
    lines = [f"\n{len(rows)} records: Δℓ = ℓ(truth) − ℓ(the search's fit)",
             f"{'noise levels':12s} {'fit excluded (Δℓ > 10)':>24s} {'median Δℓ':>12s} "
             f"{'least':>10s} {'most':>12s}"]
    for way in ("eiv", "at fit", "lines out", "oracle"):
        delta = np.array([row["delta"][way] for row in rows])
        lines.append(f"{way:12s} {int(np.sum(delta > EXCLUDED)):>17d} of {len(rows):<4d} "
                     f"{np.median(delta):12.1f} {delta.min():10.1f} {delta.max():12.1f}")
    hz = np.array([row["line_hz"] for row in rows])
    common = float(np.median(hz))
    near = int(np.sum(np.abs(hz - common) < 1.0))
    lines.append(f"the oracle's strongest line in the fit's residual: {near} of {len(rows)} "
                 f"records at {common:.1f} Hz")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--replicates", type=int, default=50)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--prior", action="store_true", help="truths drawn from the prior")
    parser.add_argument("--lowpass-hz", type=float, default=None)
    parser.add_argument("--band-hz", type=float, default=None,
                        help="the likelihood over frequencies up to this one only")
    parser.add_argument("--needle", action="store_true",
                        help="the oracle's log-likelihood along kp1 about the truth")
    parser.add_argument("--out", type=Path, default=None, help="append each record (JSON lines)")
    parser.add_argument("--quick", action="store_true", help="one record")
    args = parser.parse_args()
    replicates = 1 if args.quick else args.replicates
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.first, args.first + replicates):
            row = replicate(i, Path(tmp), args.prior, args.lowpass_hz,
                            args.needle or args.quick, args.band_hz)
            rows.append(row)
            if args.out:
                with args.out.open("a") as f:
                    f.write(json.dumps(row) + "\n")
            deltas = ", ".join(f"{way} {value:.1f}" for way, value in row["delta"].items())
            levels = ", ".join(f"{way} {value:.2f}" for way, value
                               in row["table_level"].items() if way != "oracle")
            kept, everyone = row["frequencies"][1], row["frequencies"][0]
            print(f"replicate {i}: kp1's error {row['fit_error'][1]:+.4f} of its range; "
                  f"frequencies weighed {everyone}, by eiv {kept}; table noise level over the "
                  f"oracle's: {levels}; Δℓ: {deltas}; line {row['line_power']:.0f} at "
                  f"{row['line_hz']:.1f} Hz", flush=True)
            for offset, drops in row.get("needle", {}).items():
                print(f"  kp1 ∓ {offset:g} of its range: ℓ falls {drops[0]:.1f}, "
                      f"{drops[1]:.1f}")
    print(summary(rows))


if __name__ == "__main__":
    main()
