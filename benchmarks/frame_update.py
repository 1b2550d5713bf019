"""Update the four Bouc–Wen parameters of a 3-D frame on 100 links under a two-component
recorded earthquake, from noise-free and 2 %-noise records, and sample the posterior: in one run.

The case is examples/frames/links-frame-100.toml (a two-storey frame of 5 × 5 columns, each
foot on four Bouc–Wen links; its header says why these four parameters: the links' stiffness
scale, post-yield ratio alpha, yield-deformation scale and exponent n). Its truth,
examples/frames/links-frame-100-truth.json, is simulated under the two horizontal free-field
components of the 1979 Imperial Valley earthquake at the Meloland Road Overcrossing (CESMD/CSMIP
station 01336, channels 15 on x and 24 on y, read from ../shared/data/cesmd_meloland by the
network reader), ``--seconds`` from ``--start``; the virtual experiment
(``femupdate.trials.virtual``, what ``femupdate synth`` runs) writes the records twice, without
noise and with 2 % rms noise on every channel (no offsets or drifts).

Each set of records is updated by ``run_case`` with the case's defaults (what ``femupdate run``
calls: multistart-lm, the case's runs, seed and budget); the 2 %-noise records then get the
posterior by ``run_posterior`` (what ``femupdate posterior`` runs) with the case's
``[posterior]``: TMCMC from the Laplace Gaussian at the best fit, then importance sampling, one
run of 200 samples, not sampled again from a better fit it finds (the default, four runs of
1,000, more while a parameter is unsettled, and up to two re-centred passes, would take
several times the 30 minutes this benchmark is for). ``--surrogate`` runs the
surrogate-aided posterior instead (``run_case_surrogate``: TMCMC on a Gaussian-process surrogate
trained at 300 model runs at most, checked against true runs at its samples), which on this
case does not reach its accuracy within its 300 runs and reports no samples.

Printed, per set: the model evaluations, the wall time, the best fit against the truth and the
Laplace 90 % interval at the best fit; for the posterior: its model runs, wall time, 90 %
intervals and whether each holds the truth, and the surrogate's check. ``--quick`` (CI) runs a
0.3 s segment, one run of 20 evaluations per set and no posterior: a check that the script runs.

    python benchmarks/frame_update.py [--seconds 4] [--start 3] [--out DIR] [--surrogate] [--quick]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from femupdate.case import Case, load_case
from femupdate.data.network import read_network_records
from femupdate.inference.records import Marginal
from femupdate.pipeline.posterior.run import run_posterior
from femupdate.pipeline.posterior.surrogate import run_case_surrogate
from femupdate.pipeline.results import SUMMARY_FILE, read_summary
from femupdate.pipeline.run import run_case, with_data_directory
from femupdate.runs import Execution
from femupdate.trials.virtual import Motion, virtual_experiment

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "examples" / "frames" / "links-frame-100.toml"
TRUTH = ROOT / "examples" / "frames" / "links-frame-100-truth.json"
DATA = ROOT.parent / "shared" / "data"
EVENT = "cesmd_meloland/imperialvalley1979_ce01336.zip"
CHANNELS = (15, 24)  # free field 360° (x), 270° (y)
NOISE = 0.02


def free_field(data: Path, start: float, seconds: float) -> Motion:
    """The two free-field components (m/s², a column each) of the segment, as recorded."""
    path = data / EVENT
    if not path.is_file():
        raise SystemExit(f"{path}: not found; give --data, the folder with cesmd_meloland/")
    x, y = read_network_records(path, CHANNELS)
    first, n = round(start / x.dt), round(seconds / x.dt)
    ag = np.column_stack([x.acceleration[first:first + n], y.acceleration[first:first + n]])
    return Motion(ag, x.dt, f"{EVENT}: channels {CHANNELS[0]} on x and {CHANNELS[1]} on y, "
                  f"{seconds:g} s from {start:g} s")


def records(case: Case, truth: dict[str, float], motion: Motion, out: Path,
            snr: float) -> Case:
    """The case reading the truth's records (``snr``: rms noise / rms signal) written to
    ``out``."""
    virtual_experiment(case, truth, out, seed=0, motion=motion, snr=snr, offset=0.0, drift=0.0)
    return with_data_directory(case, out)


def holds(m: Marginal, value: float) -> str:
    return "yes" if m.q05 <= value <= m.q95 else "NO"


def update(case: Case, truth: dict[str, float], out: Path, label: str, quick: bool) -> None:
    """``run_case`` on the case's defaults (one run of 20 evaluations with ``quick``);
    prints evaluations, wall time, the best fit against the truth and its Laplace interval."""
    start = time.perf_counter()
    result = run_case(case, out, **({"runs": 1, "max_evals": 20} if quick else {}))
    wall = time.perf_counter() - start
    s = result.summary
    evals = sum(r.nfev for r in s.runs)
    print(f"\n{label}: {len(s.runs)} runs, {evals} evaluations "
          f"({', '.join(str(r.nfev) for r in s.runs)}), {wall:.0f} s wall "
          f"({wall / max(evals, 1):.2f} s per evaluation, the fit's analysis included); "
          f"best φ {s.best.phi:.3g}, NMSE {s.best.nmse_percent:.3g} %")
    laplace = s.laplace.params if s.laplace is not None else {}
    print(f"  {'parameter':>12} {'truth':>8} {'best':>10} {'error':>9}   Laplace 90 % interval")
    for name, value in truth.items():
        best = s.best.params[name]
        m = laplace.get(name)
        interval = (f"[{m.q05:.6g}, {m.q95:.6g}] holds the truth: {holds(m, value)}"
                    if m is not None else "(none)")
        print(f"  {name:>12} {value:8.4g} {best:10.6g} {best / value - 1:+9.1e}   {interval}")


def posterior(case: Case, truth: dict[str, float], out: Path, surrogate: bool) -> None:
    """The posterior in ``out``, beside the update's results there (its search is reused):
    ``run_posterior`` on the case's ``[posterior]``, or ``run_case_surrogate``."""
    start = time.perf_counter()
    if surrogate:
        run_case_surrogate(case, out, seed=case.search.seed, progress=None)
        record = read_summary(out / SUMMARY_FILE).posterior
    else:
        record = run_posterior(case, out, execution=Execution(quiet=True)).record
    wall = time.perf_counter() - start
    assert record is not None
    print(f"\nposterior ({record.method}, error model {record.error_model}, {record.runs} runs): "
          f"{record.nfev} model runs, {wall:.0f} s wall ({wall / max(record.nfev, 1):.2f} s "
          f"per run); reached: {record.reached}; {record.agreement or record.message}")
    for words in record.start_warnings:
        print(f"  {words}")
    if record.surrogate is not None:
        check = record.surrogate
        print(f"  check at {check.check_runs} true runs: effective share {check.check_ess:.2f} "
              f"(at least {check.min_check_ess:.2f}), passed: {check.passed}")
    print(f"  {'parameter':>12} {'truth':>8} {'median':>10}   90 % interval   holds the truth")
    for name, value in truth.items():
        m = record.params.get(name)
        if m is None:
            print(f"  {name:>12} {value:8.4g}   (no samples)")
            continue
        print(f"  {name:>12} {value:8.4g} {m.q50:10.6g}   [{m.q05:.6g}, {m.q95:.6g}]   "
              f"{holds(m, value)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0, help="record segment (s)")
    parser.add_argument("--start", type=float, default=3.0, help="segment start (s)")
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path, help="keep the records and results here")
    parser.add_argument("--quick", action="store_true", help="a 0.3 s segment, 20 evaluations "
                        "per update, no posterior")
    parser.add_argument("--surrogate", action="store_true", help="the surrogate-aided "
                        "posterior instead of the case's sampled one")
    args = parser.parse_args()
    seconds = 0.3 if args.quick else args.seconds
    case = load_case(CASE)
    truth = json.loads(TRUTH.read_text())
    motion = free_field(args.data, args.start, seconds)
    print(f"{case.label}: {len(truth)} parameters; {motion.description} "
          f"({motion.ag.shape[0]} samples at {1 / motion.dt:g} Hz)")
    with tempfile.TemporaryDirectory() as scratch:
        root = args.out or Path(scratch)
        total = time.perf_counter()
        for label, snr in (("noise-free", 0.0), ("2 % noise", NOISE)):
            tag = "clean" if snr == 0 else "noisy"
            noisy = records(case, truth, motion, root / f"records-{tag}", snr)
            update(noisy, truth, root / f"update-{tag}", f"{label} records", args.quick)
            if snr > 0 and not args.quick:
                posterior(noisy, truth, root / f"update-{tag}", args.surrogate)
        print(f"\nin all: {time.perf_counter() - total:.0f} s wall")


if __name__ == "__main__":
    main()
