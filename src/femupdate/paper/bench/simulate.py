"""``femupdate bench simulate``: the speed of every integrator on the paper's bridge.

The real bridge of :mod:`femupdate.paper.problems.bridge` (10 DOF), linear with viscous dampers
(viscous truth) and with elasto-slip dampers (friction values), is shaken by an artificial
Eurocode-8 accelerogram at the paper's sampling: 4,768 samples at 1035 Hz, central differences
and the friction integrator with 10 substeps (47,680 steps), and by a record ten times longer
(the same accelerogram ten times in a row). Each prepared simulator's ``.run`` is timed
(``repeat`` times after one untimed warm-up: numba compiles or loads its cache), and the
preparation separately; outputs are the pier translations P1–P3 (the measured DOFs). Everything
runs with one BLAS thread (``threadpoolctl.threadpool_limits(1)``): small dense algebra is
fastest that way (with default threading a 22 × 22 ``expm`` took 8 ms instead of 0.03 ms on
2 cores).

When OpenSeesPy is installed, the same models run in it side by side
(:class:`femupdate.paper.bench.opensees.OpenSeesPeer`: Newmark at the sample rate and central
differences at the substep for the viscous bridge, central differences with ``ElasticPP`` for
the friction bridge). ``ratio_vs_opensees`` is OpenSees's median over ours (> 1: femupdate is
faster); ``compared_to`` says against which row:

- on a femupdate row: the OpenSees row of the same scheme and substeps (Newmark with Newmark;
  central differences and the friction integrator with central differences); for ``exact``,
  which has no OpenSees counterpart, the fastest OpenSees row of the model and record length;
- on an OpenSees row: the fastest femupdate row of the model and record length.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from femupdate.case import Model
from femupdate.errors import ConfigError, MissingDependencyError
from femupdate.model.system import System
from femupdate.paper.problems import bridge
from femupdate.problem.case_model import build_structure
from femupdate.simulate import prepare

__all__ = [
    "DEFAULT_FRICTION_VALUES",
    "LENGTH_FACTOR",
    "bridge_accelerogram",
    "print_simulate_rows",
    "run_simulate_benchmark",
    "simulate_table",
    "viscous_values",
]

#: Friction values of the bridge for this benchmark (provisional, until the case fixes its
#: truth): kr1 rotational at the abutments (N·m/rad), kr2–kr4 piers (N/m), fu1 (N·m), fu2–fu4 (N).
DEFAULT_FRICTION_VALUES: dict[str, float] = {
    "kr1": 2e4, "kr2": 1e5, "kr3": 1e6, "kr4": 1e5,
    "fu1": 20.0, "fu2": 30.0, "fu3": 150.0, "fu4": 30.0,
}
#: The long record is this many paper-length records in a row.
LENGTH_FACTOR = 10
#: Peak ground acceleration of the design spectrum (EC8 type 1, ground B), m/s².
DESIGN_PGA = 0.25 * 9.81
LENGTH_SCALE = 1.0 / 50.0  # the specimen's scale: model times are prototype times × √(1/50)
OUTPUT_NODES = bridge.MEASURED_NODES

#: femupdate's integrators per model: (method, substeps).
_OURS = {
    "bridge-viscous": (("exact", 1), ("newmark", 1), ("central_difference", bridge.SUBSTEPS),
                       ("nonlinear", bridge.SUBSTEPS)),
    "bridge-friction": (("nonlinear", bridge.SUBSTEPS),),
}
#: OpenSeesPy's per model: (method, substeps).
_THEIRS = {
    "bridge-viscous": (("newmark", 1), ("central_difference", bridge.SUBSTEPS)),
    "bridge-friction": (("central_difference", bridge.SUBSTEPS),),
}
_SAME_SCHEME = {"newmark": "newmark", "central_difference": "central_difference",
                "nonlinear": "central_difference", "phi nonlinear": "central_difference"}
#: Points per call of the φ rows: a whole evaluation of the error function (assembly, the
#: integrator's preparation, the simulation, the prediction's processing, the comparison) per
#: point, k points in one compiled call (what a population or a Jacobian asks).
PHI_BATCHES = (1, 10, 100)


def viscous_values() -> dict[str, float]:
    """The viscous bridge's truth values (``bridge.VISCOUS_PARAMETERS``)."""
    return {name: truth for name, _, truth, _, _ in bridge.VISCOUS_PARAMETERS}


def _friction_values(friction: Mapping[str, float] | None,
                     viscous: Mapping[str, float]) -> dict[str, float]:
    """E and kp1–kp4 of the viscous truth, plus the friction element values."""
    values = {k: float(viscous[k]) for k in ("E", "kp1", "kp2", "kp3", "kp4")}
    values.update(DEFAULT_FRICTION_VALUES if friction is None else friction)
    return values


def bridge_accelerogram(n_samples: int = bridge.N_SAMPLES, *, seed: int = 2010,
                        repeats: int = 1) -> np.ndarray:
    """An artificial EC8 accelerogram at the specimen's scale, sampled at 1035 Hz (m/s²).

    The record matches the type-1 spectrum for ground B with a design PGA of 0.25 g in
    prototype time, and is compressed in time by √(1/50) (Cauchy–Froude similitude: the
    accelerations are unchanged). It starts from rest (``a_g(0) = 0``).

    Parameters
    ----------
    n_samples : int
        Samples of one record (>= 20).
    seed : int
        Seed of the random phases (``numpy.random.default_rng``).
    repeats : int
        Number of copies of the record in a row (>= 1).

    Returns
    -------
    ndarray, shape (n_samples · repeats,)
    """
    from femupdate.data.synth import EC8Spectrum, artificial_accelerogram

    if isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 20:
        raise ConfigError(f"n_samples = {n_samples!r} must be an integer >= 20")
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ConfigError(f"repeats = {repeats!r} must be an integer >= 1")
    dt = np.sqrt(1.0 / LENGTH_SCALE) / bridge.SAMPLE_RATE  # prototype sample interval
    record = artificial_accelerogram(EC8Spectrum(ag=DESIGN_PGA, ground="B"),
                                     (n_samples - 1) * dt, dt, np.random.default_rng(seed))
    return np.tile(record.acceleration[:n_samples], repeats)


def _timed(fn: Callable[[], object], repeat: int) -> tuple[float, float]:
    """Median and minimum wall time of ``fn()`` over ``repeat`` calls, after one warm-up."""
    fn()
    times = np.empty(repeat)
    for i in range(repeat):
        t0 = time.perf_counter()
        fn()
        times[i] = time.perf_counter() - t0
    return float(np.median(times)), float(times.min())


def _time_ours(system: System, dt: float, outputs: list[int], method: str, substeps: int,
               ag: np.ndarray, repeat: int) -> tuple[tuple[float, float], float]:
    """(median, min) of a prepared simulator's ``run``, and the median of ``prepare``."""
    prep = partial(prepare, system, dt, method=method, outputs=outputs, substeps=substeps)
    run = _timed(partial(prep().run, ag), repeat)
    return run, _timed(prep, repeat)[0]


def _row(engine: str, model: str, method: str, samples: int, substeps: int,
         run: tuple[float, float], prep: float, repeat: int) -> dict[str, Any]:
    return {
        "engine": engine, "model": model, "method": method, "samples": samples,
        "substeps": substeps, "steps": (samples - 1) * substeps, "median_s": run[0],
        "min_s": run[1], "prepare_median_s": prep, "repeat": repeat, "blas_threads": 1,
        "ratio_vs_opensees": None, "compared_to": None,
    }


def _phi_rows(repeat: int, seed: int, say: Callable[[str], None]) -> list[dict[str, Any]]:
    """φ per evaluation of the bridge's update problems (viscous and friction, on a virtual
    experiment of the paper's length with 2 % noise), for each batch size of PHI_BATCHES."""
    import tempfile

    from femupdate.case import parse_case
    from femupdate.problem.update import UpdateProblem
    from femupdate.trials.experiment import load_experiments

    rows = []
    rng = np.random.default_rng(seed)
    with tempfile.TemporaryDirectory(prefix="femupdate-bench-phi-") as tmp:
        for model, method, sub in (("viscous", "exact", 1),
                                   ("friction", "nonlinear", bridge.SUBSTEPS)):
            data = Path(tmp) / model
            case = parse_case(bridge.bridge_case(model, "narrow", directory=str(data)),
                              source=data / "case.toml")
            bridge.ensure_records(case, bridge.truth(model), data, seed=seed, snr=0.02)
            problem = UpdateProblem(case, load_experiments(case))
            low, high = np.array(case.bounds).T
            samples = problem.experiment.t.size
            for k in PHI_BATCHES:
                say(f"femupdate bridge-{model} φ, batches of {k}")
                points = low + (high - low) * rng.random((k, low.size))
                calls = max(1, repeat // k) if method == "exact" else max(1, repeat // (2 * k))
                median, least = _timed(partial(problem.evaluate_batch, points), calls)
                rows.append(_row("femupdate", f"bridge-{model}", f"phi {method} k={k}",
                                 samples, sub, (median / k, least / k), 0.0, calls))
    return rows


def _opensees_module(opensees: bool | None) -> Any:
    """The OpenSees module, or None when it is not wanted or (for ``None``) not installed."""
    if opensees is False:
        return None
    from femupdate.paper.bench.opensees import import_opensees

    try:
        return import_opensees()
    except MissingDependencyError:
        if opensees:
            raise
        return None


def _add_ratios(rows: list[dict[str, Any]]) -> None:
    """Fill ``ratio_vs_opensees`` and ``compared_to`` (module docstring)."""
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["model"], row["samples"]), []).append(row)
    for group in groups.values():
        ours = [r for r in group if r["engine"] == "femupdate"]
        theirs = [r for r in group if r["engine"] == "openseespy"]
        if not ours or not theirs:
            continue
        simulations = [r for r in ours if not r["method"].startswith("phi")] or ours
        fastest_ours = min(simulations, key=lambda r: r["median_s"])
        fastest_theirs = min(theirs, key=lambda r: r["median_s"])
        for row in theirs:
            row["ratio_vs_opensees"] = row["median_s"] / fastest_ours["median_s"]
            row["compared_to"] = (f"femupdate {fastest_ours['method']} "
                                  f"x{fastest_ours['substeps']} (fastest)")
        for row in ours:
            scheme = _SAME_SCHEME.get(row["method"].split(" k=")[0])
            peer = next((r for r in theirs if r["method"] == scheme
                         and r["substeps"] == row["substeps"]), None)
            label = "same scheme"
            if peer is None:
                peer, label = fastest_theirs, "fastest"
            row["ratio_vs_opensees"] = peer["median_s"] / row["median_s"]
            row["compared_to"] = f"openseespy {peer['method']} x{peer['substeps']} ({label})"


def run_simulate_benchmark(
    repeat: int = 20,
    opensees: bool | None = None,
    *,
    seed: int = 2010,
    opensees_repeat: int | None = None,
    viscous: Mapping[str, float] | None = None,
    friction: Mapping[str, float] | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """Time every integrator on the bridge, viscous and frictional, and OpenSeesPy beside them.

    Parameters
    ----------
    repeat : int
        Timed runs per femupdate row (>= 1); the median and minimum are reported.
    opensees : bool or None
        Time OpenSeesPy too: ``None`` when it is installed, ``True`` always (raises
        ``MissingDependencyError`` without it), ``False`` never.
    seed : int
        Seed of the accelerogram.
    opensees_repeat : int, optional
        Timed runs per OpenSeesPy row (default ``min(repeat, 5)``: a long OpenSees run takes
        seconds).
    viscous : mapping, optional
        Values of the viscous bridge (default its truth, :func:`viscous_values`); E and
        kp1–kp4 are used by the friction bridge too.
    friction : mapping, optional
        kr1–kr4 and fu1–fu4 of the friction bridge (default :data:`DEFAULT_FRICTION_VALUES`).
    progress : callable, optional
        Called with a line of text before each row is timed.

    Returns
    -------
    list of dict
        One row per engine, model, record length and integrator: ``engine`` ("femupdate" /
        "openseespy"), ``model`` ("bridge-viscous" / "bridge-friction"), ``method``,
        ``samples``, ``substeps``, ``steps``, ``median_s`` and ``min_s`` (per simulation),
        ``prepare_median_s``, ``repeat``, ``blas_threads`` (1), ``ratio_vs_opensees`` and
        ``compared_to`` (None without an OpenSeesPy row for the model and length).
    """
    for name, value in (("repeat", repeat), ("opensees_repeat", opensees_repeat)):
        if name == "opensees_repeat" and value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConfigError(f"{name} = {value!r} must be an integer >= 1")
    if opensees not in (None, True, False):
        raise ConfigError(f"opensees = {opensees!r}; allowed True, False or None (if installed)")
    os_repeat = min(repeat, 5) if opensees_repeat is None else opensees_repeat
    say = progress or (lambda _text: None)
    viscous = viscous_values() if viscous is None else dict(viscous)
    tables = {"bridge-viscous": (bridge.viscous_model(), viscous),
              "bridge-friction": (bridge.friction_model(), _friction_values(friction, viscous))}
    ops = _opensees_module(opensees)
    dt = 1.0 / bridge.SAMPLE_RATE
    short = bridge_accelerogram(bridge.N_SAMPLES, seed=seed)
    records = (short, np.tile(short, LENGTH_FACTOR))
    rows: list[dict[str, Any]] = []
    with threadpool_limits(limits=1):
        for name, (table, values) in tables.items():
            model = Model.model_validate(table)
            system: System = build_structure(model).assemble(values)
            outputs = [system.dof_labels.index(f"{n}.uy") for n in OUTPUT_NODES]
            for ag in records:
                for method, sub in _OURS[name]:
                    say(f"femupdate {name} {method} x{sub}, {ag.size} samples")
                    run, prep = _time_ours(system, dt, outputs, method, sub, ag, repeat)
                    rows.append(_row("femupdate", name, method, ag.size, sub, run, prep, repeat))
            if ops is None:
                continue
            from femupdate.paper.bench.opensees import OpenSeesPeer

            peer = OpenSeesPeer(model, values, ops=ops)
            prep = _timed(peer.build, os_repeat)[0]
            for ag in records:
                for method, sub in _THEIRS[name]:
                    say(f"openseespy {name} {method} x{sub}, {ag.size} samples")
                    run = _timed(partial(peer.run, ag, dt, method=method, substeps=sub,
                                         outputs=outputs), os_repeat)
                    rows.append(_row("openseespy", name, method, ag.size, sub, run, prep,
                                     os_repeat))
        rows += _phi_rows(repeat, seed, say)
    _add_ratios(rows)
    return rows


def _ms(seconds: float | None) -> str:
    if seconds is None:
        return "–"
    ms = 1e3 * seconds
    return f"{ms:,.0f}" if ms >= 100 else f"{ms:.3g}"


_SHORT = {"central_difference": "cd", "nonlinear": "fric-cd", "openseespy": "OpenSees",
          "femupdate": "ours", "phi ": "φ "}


def _short(text: str) -> str:
    for long, short in _SHORT.items():
        text = text.replace(long, short)
    return text


def _method_label(row: Mapping[str, Any]) -> str:
    """'newmark', 'cd x10', 'φ k=10': the scheme and its substeps when more than one; for φ
    only the batch size (the scheme is the model's: exact, or fric-cd x10)."""
    if row["method"].startswith("phi"):
        return "φ " + row["method"].split()[-1]
    steps = f" x{row['substeps']}" if row["substeps"] > 1 else ""
    return _short(row["method"]) + steps


def _ratio_label(row: Mapping[str, Any]) -> str:
    """The ratio against the same scheme, or marked * against the other engine's fastest."""
    ratio = row["ratio_vs_opensees"]
    if ratio is None:
        return "–"
    return f"{ratio:,.0f}" + ("*" if "(fastest)" in (row["compared_to"] or "") else "")


def simulate_table(rows: list[dict[str, Any]]) -> Any:
    """The rows as a ``rich.table.Table`` (times in ms per simulation), 80 columns wide
    (the fastest of each row's repetitions is in the JSON)."""
    from rich import box
    from rich.table import Table

    table = Table(title="Bridge, 10 DOF, 1035 Hz, 1 BLAS thread: ms per simulation",
                  caption="ratio = OpenSees median / ours for the same scheme (* against the "
                          "other engine's fastest); xN = N substeps; cd = central differences; "
                          "fric-cd = femupdate's nonlinear integrator; φ k=n = whole "
                          "evaluations of the error function (viscous: exact, friction: "
                          "fric-cd x10), n points a call, per point",
                  box=box.SIMPLE_HEAD, pad_edge=False)
    for col in ("engine", "model", "method", "samples", "median", "prepare", "n", "ratio"):
        table.add_column(col, justify="left" if col in ("engine", "model", "method")
                         else "right", no_wrap=True)
    for r in rows:
        table.add_row(_short(r["engine"]), r["model"].removeprefix("bridge-"),
                      _method_label(r), f"{r['samples']:,}", _ms(r["median_s"]),
                      _ms(r["prepare_median_s"]), str(r["repeat"]),
                      _ratio_label(r))
    return table


def print_simulate_rows(rows: list[dict[str, Any]], console: Any | None = None) -> None:
    """Print the rows of :func:`run_simulate_benchmark` as a rich table."""
    if console is None:
        from rich.console import Console

        console = Console()
    console.print(simulate_table(rows))
