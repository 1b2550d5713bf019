"""Time ``femupdate report`` on results with many parameters.

Builds, once per size, a results directory of a shear building with a stiffness and a damper
parameter per storey (2 × storeys parameters; every 5th floor measured): a noise-free virtual
experiment of 2 s at 120 Hz, then ``run_case`` with 2 runs of 20 AB evaluations (and the
identifiability analysis, as ``femupdate run``). Then prints the wall and CPU time of
``write_report``, the size of the page and the time per part (loading, each section). With
``--work`` the results directories are kept there and reused; without it they are built in a
temporary directory removed at the end (building the 200-parameter one takes about 30 s).

    python benchmarks/report_speed.py [--parameters 50 200] [--work report-speed]
    python benchmarks/report_speed.py --quick     # 10 parameters: a smoke run (CI)
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from femupdate.case import Case, parse_case
from femupdate.pipeline.run import run_case
from femupdate.trials.virtual import virtual_experiment


def shear_building(storeys: int, data_dir: Path) -> Case:
    ks, cs = [f"k{i + 1}" for i in range(storeys)], [f"c{i + 1}" for i in range(storeys)]
    return parse_case({
        "case": {"name": f"{storeys}-storey shear building"},
        "model": {"shear_building": {"masses": [1.0] * storeys, "stiffnesses": ks,
                                     "dampers": cs}},
        "parameters": ([{"name": k, "lower": 500.0, "upper": 5000.0, "unit": "N/m"}
                        for k in ks]
                       + [{"name": c, "lower": 0.0, "upper": 5.0, "unit": "N·s/m"} for c in cs]),
        "data": {"format": "csv", "directory": str(data_dir.resolve()), "time_column": "t",
                 "input": {"file": "table.csv", "column": "a"},
                 "outputs": [{"file": "floors.csv", "column": f"f{i}", "node": f"F{i}",
                              "dof": "ux"} for i in range(1, storeys + 1, 5)]},
        "search": {"method": "ab", "runs": 2, "seed": 1, "max_evals": 20},
    })


def results_dir(parameters: int, work: Path) -> Path:
    """The results directory of a case with ``parameters`` parameters (built if absent)."""
    root = work / f"p{parameters}"
    out = root / "out"
    if (out / "summary.json").is_file():
        return out
    case = shear_building(parameters // 2, root / "data")
    truth = {n: 2000.0 if n.startswith("k") else 1.0 for n in case.parameter_names}
    virtual_experiment(case, truth, root / "data", seed=0, duration=2.0, rate=120.0, snr=0.0,
                       offset=0.0, drift=0.0)
    start = time.perf_counter()
    run_case(case, out, workers=1)
    print(f"{parameters} parameters: results built in {time.perf_counter() - start:.1f} s")
    return out


def time_sections(out: Path) -> dict[str, float]:
    """Seconds per part of the report (figures drawn and encoded as the page does)."""
    from threadpoolctl import threadpool_limits

    from femupdate.pipeline.results import load_results
    from femupdate.report import sections_model, sections_runs
    from femupdate.report.facts import context
    from femupdate.report.markup import Page

    times = {}
    with threadpool_limits(limits=1):
        start = time.perf_counter()
        ctx = context(load_results(out))
        times["load"] = time.perf_counter() - start
        page = Page()
        parts = {
            "case": lambda: sections_runs.section_case(ctx),
            "runs": lambda: sections_runs.section_runs(ctx),
            "convergence": lambda: sections_runs.section_convergence(ctx, page),
            "spread": lambda: sections_runs.section_spread(ctx, page),
            "fit": lambda: sections_model.section_fit(ctx, page),
            "modes": lambda: sections_model.section_modes(ctx),
            "identifiability": lambda: sections_model.section_identifiability(ctx, page),
        }
        for name, part in parts.items():
            start = time.perf_counter()
            part()
            times[name] = time.perf_counter() - start
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parameters", type=int, nargs="+", default=[50, 200])
    parser.add_argument("--work", type=Path, default=None,
                        help="keep the results directories here and reuse them "
                             "(default: a temporary directory, removed at the end)")
    parser.add_argument("--quick", action="store_true",
                        help="one case of 10 parameters (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.parameters = [10]
    if args.work is not None:
        time_reports(args.parameters, args.work)
    else:
        with tempfile.TemporaryDirectory(prefix="report-speed-") as work:
            time_reports(args.parameters, Path(work))


def time_reports(parameters: list[int], work: Path) -> None:
    """Print the report's times for each size in ``parameters`` (results under ``work``)."""
    from femupdate.report.html import write_report

    # Matplotlib and the report modules imported before timing: a command pays this once.
    write_report(results_dir(parameters[0], work))
    for n in parameters:
        out = results_dir(n, work)
        wall, cpu = time.perf_counter(), time.process_time()
        path = write_report(out)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        parts = ", ".join(f"{k} {v:.2f}" for k, v in time_sections(out).items())
        print(f"{n} parameters: report in {wall:.2f} s (CPU {cpu:.2f} s), "
              f"{path.stat().st_size / 1e6:.1f} MB; parts [s]: {parts}")


if __name__ == "__main__":
    main()
