"""The defect corpus: defective records made from clean ones, each flagged with its kind.

Clean records: virtual experiments of a two-storey shear building (three noisy seeds and a
noise-free one) and the six real minishake trials (shared data; skipped when absent). Each
defective record is one of them with one defect put in by the code below, at several
severities; it must be flagged with its kind (a finding, or for a drift that no resampling
asked for, the one-line error naming it). The clean ones must raise nothing.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.data.defects import KINDS
from femupdate.errors import ConfigError, DataError, FemupdateWarning
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import ec8_motion, virtual_experiment

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("FEMUPDATE_DATA", REPO.parent / "shared" / "data"))
MINISHAKE = SHARED / "minishake_1story"
REAL_TRIALS = ("elcentro_t1", "elcentro_t2", "northridge_t1", "northridge_t2", "sine2hz_t1",
               "sine2hz_t2")
TRUTH = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}
SYNTH_RATE = 200.0


def synth_spec(directory: Path, **data: Any) -> dict[str, Any]:
    """A two-storey shear building (first mode 6.1 Hz) read from table.csv and floors.csv."""
    channels = data.pop("channels", {})
    spec: dict[str, Any] = {
        "case": {"name": "two-storey"},
        "model": {"shear_building": {"masses": [1.0, 0.8], "stiffnesses": ["k1", "k2"],
                                     "dampers": ["c1", "c2"]}},
        "parameters": [{"name": "k1", "lower": 1000.0, "upper": 10000.0, "scale": "log",
                        "nominal": 4000.0},
                       {"name": "k2", "lower": 1000.0, "upper": 10000.0, "scale": "log",
                        "nominal": 2500.0},
                       {"name": "c1", "lower": 0.0, "upper": 5.0},
                       {"name": "c2", "lower": 0.0, "upper": 5.0}],
        "data": {"format": "csv", "directory": str(directory), "time_column": "t",
                 "input": {"file": "table.csv", "column": "table", **channels.get("input", {})},
                 "outputs": [{"file": "floors.csv", "column": "a1", "node": "F1", "dof": "ux",
                              **channels.get("a1", {})},
                             {"file": "floors.csv", "column": "a2", "node": "F2",
                              "dof": "ux"}], **data},
        "preprocess": {"highpass_hz": 0.5},
        "search": {"method": "ab", "runs": 1, "seed": 1, "max_evals": 60},
    }
    return spec


def real_spec(directory: Path, trial: str, **data: Any) -> dict[str, Any]:
    """The minishake case of examples/minishake-1story/elcentro.toml on one trial."""
    return {
        "case": {"name": f"minishake-{trial}"},
        "model": {"shear_building": {"masses": [0.179], "stiffnesses": ["k1"],
                                     "dampers": ["c1"]}},
        "parameters": [{"name": "k1", "lower": 500.0, "upper": 20000.0, "scale": "log",
                        "nominal": 2830.0},
                       {"name": "c1", "lower": 0.0, "upper": 5.0, "nominal": 0.5}],
        "data": {"format": "csv", "directory": str(directory), "time_column": "SampleTimeFine",
                 "time_unit": "us", "skip_rows": 1, "unit": "m/s2",
                 "repair": trial == "northridge_t2",
                 "input": {"file": f"stiff1_{trial}_ground.csv", "column": "Acc_X"},
                 "outputs": [{"file": f"stiff1_{trial}_top.csv", "column": "Acc_X",
                              "node": "F1", "dof": "ux", "name": "roof", "delay": "auto"}],
                 **data},
        "preprocess": {"highpass_hz": 1.0},
    }


# --------------------------------------------------------------------------- files


def read_plain(path: Path) -> tuple[list[str], np.ndarray]:
    """A CSV written by femupdate (a comment line, then a header): names and values."""
    lines = path.read_text().splitlines()
    body = [s for s in lines if not s.startswith("#")]
    return body[0].split(","), np.loadtxt(body[1:], delimiter=",", ndmin=2)


def write_plain(path: Path, names: list[str], values: np.ndarray) -> None:
    np.savetxt(path, values, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def read_xsens(path: Path) -> tuple[list[str], list[str], np.ndarray]:
    """An Xsens DOT export: its preamble lines, column names and values."""
    lines = path.read_text().splitlines()
    at = next(i for i, s in enumerate(lines) if s.startswith("PacketCounter"))
    values = np.genfromtxt(lines[at + 1:], delimiter=",")
    return lines[:at], lines[at].split(","), values


def write_xsens(path: Path, preamble: list[str], names: list[str], values: np.ndarray) -> None:
    rows = [",".join(f"{v:.17g}" if j != 1 else f"{v:.0f}" for j, v in enumerate(row))
            for row in values]
    path.write_text("\n".join([*preamble, ",".join(names), *rows]) + "\n")


# --------------------------------------------------------------------------- the corpus


@dataclass(frozen=True)
class Record:
    """One record of the corpus: where it comes from, what is done to it, what it must give."""

    name: str
    source: str          # "synth" (a clean virtual record set) or "real:<trial>"
    kind: str | None     # the kind it must be flagged with; None: clean, nothing found
    edit: Callable[[Path], dict[str, Any]] | None = None  # edits files, returns case changes

    @property
    def needs_shared(self) -> bool:
        return self.source.startswith("real:")


def _floors(fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
            ) -> Callable[[Path], dict[str, Any]]:
    """An edit of floors.csv: fn(t, values) -> (t, values)."""
    def edit(folder: Path) -> dict[str, Any]:
        names, v = read_plain(folder / "floors.csv")
        t, rest = fn(v[:, 0].copy(), v[:, 1:].copy())
        write_plain(folder / "floors.csv", names, np.column_stack([t, rest]))
        return {}
    return edit


def _table(fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
           ) -> Callable[[Path], dict[str, Any]]:
    def edit(folder: Path) -> dict[str, Any]:
        names, v = read_plain(folder / "table.csv")
        t, rest = fn(v[:, 0].copy(), v[:, 1:].copy())
        write_plain(folder / "table.csv", names, np.column_stack([t, rest]))
        return {}
    return edit


def _both(fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
          **case: Any) -> Callable[[Path], dict[str, Any]]:
    def edit(folder: Path) -> dict[str, Any]:
        _floors(fn)(folder)
        _table(fn)(folder)
        return case
    return edit


def _case(**changes: Any) -> Callable[[Path], dict[str, Any]]:
    return lambda folder: changes


def _spike(value: float | str, at: float = 0.55, width: int = 1, col: int = 0
           ) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    def fn(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        i = int(at * t.size)
        peak = float(np.max(np.abs(v[:, col])))
        v[i:i + width, col] = peak * float(value[:-1]) if isinstance(value, str) else value
        return t, v
    return fn


def _clip(share: float, col: int = 0
          ) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    def fn(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        limit = share * float(np.max(np.abs(v[:, col])))
        v[:, col] = np.clip(v[:, col], -limit, limit)
        return t, v
    return fn


def _delay_values(seconds: float
                  ) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The samples moved later by ``seconds`` under unchanged time stamps (zeros before)."""
    def fn(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = round(seconds * SYNTH_RATE)
        out = np.zeros_like(v)
        out[k:] = v[:-k]
        return t, out
    return fn


def _copy_column(src: int, dst: int, digits: int = 17, factor: float = 1.0
                 ) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Column ``dst`` a copy of ``src`` as an export gives it: times ``factor`` (a unit) and
    rounded to ``digits`` significant digits."""
    def fn(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        v[:, dst] = [float(f"{x:.{digits}g}") for x in v[:, src] * factor]
        return t, v
    return fn


def _spikes(values: tuple[float, ...], rows: tuple[int, ...], col: int = 0
            ) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``values`` at the ``rows`` given (negative: from the end)."""
    def fn(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        for row, value in zip(rows, values, strict=True):
            v[row, col] = value
        return t, v
    return fn


def _table_is_floor(folder: Path) -> dict[str, Any]:
    """The table record is the first floor's (the same file exported twice)."""
    _, floors = read_plain(folder / "floors.csv")
    write_plain(folder / "table.csv", ["t", "table"], floors[:, :2])
    return {}


def _rows(stop: int) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    return lambda t, v: (t[:stop], v[:stop])


def _every(k: int) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    return lambda t, v: (t[::k], v[::k])


def _time_scale(factor: float, **case: Any) -> Callable[[Path], dict[str, Any]]:
    return _both(lambda t, v: (t * factor, v), **case)


def _g_to(column: str) -> Callable[[Path], dict[str, Any]]:
    """The channel's file holds g but the case declares m/s²."""
    if column == "table":
        return _table(lambda t, v: (t, v / 9.80665))
    return _floors(lambda t, v: (t, np.column_stack([v[:, 0] / 9.80665, v[:, 1]])))


def _drift(ppm: float, resample: bool = True) -> Callable[[Path], dict[str, Any]]:
    """The floors' clock runs ``ppm`` fast: its stamps stretched (rows in step)."""
    def edit(folder: Path) -> dict[str, Any]:
        _floors(lambda t, v: (t[0] + (t - t[0]) * (1 + 1e-6 * ppm), v))(folder)
        return {"preprocess": {"highpass_hz": 0.5, "resample_hz": SYNTH_RATE}} if resample else {}
    return edit


SYNTH: list[Record] = [
    # clocks: the floors' stamps start late (rows in step), or run at another rate
    *[Record(f"synth-clock-offset-{s}s", "synth", "clock-offset", _floors(
        lambda t, v, s=s: (t + s, v))) for s in (0.2, 1.0, 3.0)],
    *[Record(f"synth-clock-drift-{p}ppm", "synth", "clock-drift", _drift(p))
      for p in (2000, 5000)],
    Record("synth-clock-drift-no-resampling", "synth", "clock-drift", _drift(5000, False)),
    # an output whose samples lag the input's by seconds under the same stamps
    *[Record(f"synth-misaligned-{s}s", "synth", "misaligned", _floors(_delay_values(s)))
      for s in (1.0, 2.5)],
    # the same record twice
    Record("synth-duplicate-table-is-floor", "synth", "duplicate", _table_is_floor),
    Record("synth-duplicate-floors", "synth", "duplicate", _floors(_copy_column(0, 1))),
    Record("synth-duplicate-6-digits", "synth", "duplicate", _floors(_copy_column(0, 1, 6))),
    Record("synth-duplicate-in-g", "synth", "duplicate",
           _floors(_copy_column(0, 1, 8, 1 / 9.80665))),
    # spikes and absurd values
    Record("synth-spike-1e308", "synth", "spike", _floors(_spike(1e308))),
    Record("synth-spike-1e5", "synth", "spike", _floors(_spike(1e5))),
    Record("synth-spike-5x-peak", "synth", "spike", _floors(_spike("5x", at=0.3))),
    Record("synth-spike-2-samples", "synth", "spike", _floors(_spike("3x", width=2, col=1))),
    Record("synth-spike-in-table", "synth", "spike", _table(_spike("4x", at=0.8))),
    # at the record's ends, of either sign, two-sided, non-finite: in any channel
    *[Record(f"synth-spike-{v:g}-row-{r}-col-{c}", "synth", "spike",
             _floors(_spikes((v,), (r,), c))) for v, r, c in
      ((1e5, -1, 0), (1e308, -1, 1), (-1e5, -2, 0), (1e5, 0, 1), (1e308, 1, 0))],
    *[Record(f"synth-spike-table-row-{r}", "synth", "spike", _table(_spikes((50.0,), (r,))))
      for r in (0, -1)],
    *[Record(f"synth-glitch-two-sided-rows-{r}", "synth", "spike",
             _floors(_spikes((1e5, -1e5), (r, r + 1)))) for r in (0, 700, -2)],
    Record("synth-glitch-two-sided-table", "synth", "spike",
           _table(_spikes((60.0, -60.0), (900, 901)))),
    # a dead channel: one value throughout
    Record("synth-constant-channel", "synth", "saturation",
           _floors(lambda t, v: (t, np.column_stack([np.full(t.size, 0.3), v[:, 1]])))),
    # saturated sensors
    *[Record(f"synth-saturation-{int(100 * s)}pct", "synth", "saturation",
             _floors(_clip(s, col=1))) for s in (0.9, 0.7, 0.5)],
    # units: one channel in g declared m/s², one declared g; a strong motion declared g
    Record("synth-unit-table-in-g", "synth", "unit", _g_to("table")),
    Record("synth-unit-floor-in-g", "synth", "unit", _g_to("a1")),
    Record("synth-unit-floor-declared-g", "synth", "unit",
           _case(channels={"a1": {"unit": "g"}})),
    Record("synth-unit-all-declared-g", "synth-strong", "unit", _case(unit="g")),
    # time units and rates
    Record("synth-time-ms-declared-s", "synth", "time-unit", _time_scale(1e3)),
    Record("synth-time-s-declared-ms", "synth", "time-unit", _case(time_unit="ms")),
    Record("synth-time-us-declared-ms", "synth", "time-unit", _time_scale(1e6, time_unit="ms")),
    Record("synth-rate-10hz", "synth", "rate", _both(_every(20))),
    Record("synth-rate-declared", "synth", "rate", _case(time_column=None, rate=8.0)),
    # too short
    Record("synth-short-2-samples", "synth", "short", _both(_rows(2))),
    Record("synth-short-20-samples", "synth", "short", _both(_rows(20))),
    Record("synth-short-window", "synth", "short", _case(window=[1.0, 1.4])),
]


def _real_edit(which: str, fn: Callable[[list[str], np.ndarray], np.ndarray], **case: Any
               ) -> Callable[[Path], dict[str, Any]]:
    """An edit of a real trial's ``ground`` or ``top`` export: fn(names, values) -> values."""
    def edit(folder: Path) -> dict[str, Any]:
        path = next(folder.glob(f"*_{which}.csv"))
        preamble, names, values = read_xsens(path)
        write_xsens(path, preamble, names, fn(names, values))
        return case
    return edit


def _real_col(names: list[str], name: str) -> int:
    return names.index(name)


def _real_shift_stamps(seconds: float) -> Callable[[list[str], np.ndarray], np.ndarray]:
    def fn(names: list[str], v: np.ndarray) -> np.ndarray:
        v[:, _real_col(names, "SampleTimeFine")] += seconds * 1e6
        return v
    return fn


def _real_roll(seconds: float) -> Callable[[list[str], np.ndarray], np.ndarray]:
    def fn(names: list[str], v: np.ndarray) -> np.ndarray:
        j, k = _real_col(names, "Acc_X"), round(seconds * 120)
        v[1:, j] = np.concatenate((np.full(k, v[1, j]), v[1:-k, j]))
        return v
    return fn


def _real_spike(value: float, at: float = 0.5) -> Callable[[list[str], np.ndarray], np.ndarray]:
    def fn(names: list[str], v: np.ndarray) -> np.ndarray:
        v[int(at * v.shape[0]), _real_col(names, "Acc_X")] = value
        return v
    return fn


def _real_rows(values: tuple[float, ...], rows: tuple[int, ...]
               ) -> Callable[[list[str], np.ndarray], np.ndarray]:
    def fn(names: list[str], v: np.ndarray) -> np.ndarray:
        for row, value in zip(rows, values, strict=True):
            v[row, _real_col(names, "Acc_X")] = value
        return v
    return fn


def _real_clip(share: float) -> Callable[[list[str], np.ndarray], np.ndarray]:
    def fn(names: list[str], v: np.ndarray) -> np.ndarray:
        j = _real_col(names, "Acc_X")
        limit = share * float(np.max(np.abs(v[1:, j])))
        v[1:, j] = np.clip(v[1:, j], -limit, limit)
        return v
    return fn


def _real_copy_ground(folder: Path) -> dict[str, Any]:
    ground = next(folder.glob("*_ground.csv"))
    next(folder.glob("*_top.csv")).write_bytes(ground.read_bytes())
    return {}


REAL: list[Record] = [
    *[Record(f"real-{tr}-clock-offset-{s}s", f"real:{tr}", "clock-offset",
             _real_edit("top", _real_shift_stamps(s))) for tr, s in
      (("elcentro_t1", 7.0), ("northridge_t2", 18.0), ("sine2hz_t1", 12.0))],
    *[Record(f"real-{tr}-misaligned-{s}s", f"real:{tr}", "misaligned",
             _real_edit("top", _real_roll(s))) for tr, s in
      (("elcentro_t1", 7.0), ("northridge_t1", 4.0))],
    Record("real-elcentro_t2-duplicate", "real:elcentro_t2", "duplicate", _real_copy_ground),
    *[Record(f"real-{tr}-spike-{v:g}", f"real:{tr}", "spike",
             _real_edit(which, _real_spike(v))) for tr, which, v in
      (("elcentro_t1", "top", 1e308), ("northridge_t1", "top", 1e5),
       ("sine2hz_t2", "ground", 40.0))],
    *[Record(f"real-{tr}-{which}-spike-rows-{'-'.join(map(str, r))}", f"real:{tr}", "spike",
             _real_edit(which, _real_rows(v, r))) for tr, which, v, r in
      (("elcentro_t1", "top", (1e5,), (1,)), ("sine2hz_t1", "ground", (-1e5,), (-2,)),
       ("northridge_t1", "ground", (60.0,), (-1,)), ("elcentro_t2", "ground", (1e308,), (-1,)),
       ("sine2hz_t2", "top", (1e5, -1e5), (1500, 1501)),
       ("elcentro_t2", "top", (80.0, -80.0), (-2, -1)))],
    *[Record(f"real-{tr}-saturation-{int(100 * s)}pct", f"real:{tr}", "saturation",
             _real_edit("top", _real_clip(s))) for tr, s in
      (("elcentro_t2", 0.9), ("sine2hz_t1", 0.6))],
    *[Record(f"real-{tr}-unit-declared-g", f"real:{tr}", "unit", _case(unit="g"))
      for tr in ("elcentro_t1", "northridge_t1")],
    Record("real-sine2hz_t2-time-us-declared-s", "real:sine2hz_t2", "time-unit",
           _case(time_unit="s")),
    Record("real-elcentro_t1-time-us-declared-ms", "real:elcentro_t1", "time-unit",
           _case(time_unit="ms")),
    Record("real-elcentro_t2-short", "real:elcentro_t2", "short", _case(window=[10.0, 10.1])),
]

CLEAN: list[Record] = [
    *[Record(f"synth-clean-seed-{s}", f"synth:{s}", None) for s in (1, 2, 3)],
    Record("synth-clean-noise-free", "synth:free", None),
    Record("synth-clean-strong", "synth-strong", None),
    *[Record(f"real-{tr}-clean", f"real:{tr}", None) for tr in REAL_TRIALS],
]
CORPUS = SYNTH + REAL + CLEAN


@pytest.fixture(scope="module")
def clean_synth(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Clean virtual record sets: two EC8 motions (0.25 g), noisy with noise seeds 1–3, one
    noise-free, one of the first motion scaled to 1 g."""
    root = tmp_path_factory.mktemp("clean")
    case = parse_case(synth_spec(root), source=root / "case.toml")
    first, second = (ec8_motion(np.random.default_rng(seed), rate=SYNTH_RATE, duration=8.0,
                                length_scale=1.0) for seed in (1, 2))
    strong = replace(first, ag=4.0 * first.ag, description=f"{first.description} × 4")
    for name, motion, kwargs in (("1", first, {"seed": 1}), ("2", second, {"seed": 2}),
                                 ("3", first, {"seed": 3}),
                                 ("free", second, {"seed": 4, "snr": 0.0, "offset": 0.0,
                                                   "drift": 0.0}),
                                 ("strong", strong, {"seed": 5})):
        virtual_experiment(case, TRUTH, root / name, motion=motion, rate=SYNTH_RATE,
                           **{"snr": 0.02, **kwargs})
    return root


def _source_folder(record: Record, clean_synth: Path, into: Path) -> tuple[Path, str | None]:
    """A copy of the record's clean files in ``into`` (the trial name for real ones)."""
    into.mkdir(parents=True)
    if record.needs_shared:
        if not MINISHAKE.is_dir():
            pytest.skip(f"the shared minishake data are absent ({MINISHAKE})")
        trial = record.source.split(":", 1)[1]
        for side in ("ground", "top"):
            name = f"stiff1_{trial}_{side}.csv"
            (into / name).write_bytes((MINISHAKE / name).read_bytes())
        return into, trial
    name = {"synth": "1", "synth-strong": "strong"}.get(record.source,
                                                       record.source.split(":")[-1])
    for file in ("table.csv", "floors.csv"):
        (into / file).write_bytes((clean_synth / name / file).read_bytes())
    return into, None


def _merge(spec: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    for key, value in changes.items():
        if key in ("preprocess",):
            spec[key] = {**spec[key], **value}
        elif key == "channels":
            continue
        elif value is None:
            spec["data"].pop(key, None)
        else:
            spec["data"][key] = value
    return spec


def found_kinds(record: Record, clean_synth: Path, tmp: Path) -> set[str]:
    """The kinds of defect the checks report on the record (a DataError counts by the kinds
    its message names)."""
    folder, trial = _source_folder(record, clean_synth, tmp / "records")
    changes = record.edit(folder) if record.edit else {}
    if trial is None:
        spec = synth_spec(folder, channels=changes.get("channels", {}))
    else:
        spec = real_spec(folder, trial)
    case = parse_case(_merge(spec, changes), source=folder / "case.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        try:
            experiments = load_experiments(case)
        except (DataError, ConfigError) as exc:
            return {kind for kind in KINDS if f": {kind}:" in str(exc)} or {f"error: {exc}"}
    return {f.kind for e in experiments for f in e.defects}


@pytest.mark.slow
@pytest.mark.parametrize("record", CORPUS, ids=[r.name for r in CORPUS])
def test_each_record_is_flagged_with_its_kind_and_clean_ones_raise_nothing(
        record: Record, clean_synth: Path, tmp_path: Path) -> None:
    kinds = found_kinds(record, clean_synth, tmp_path)
    if record.kind is None:
        assert kinds == set(), f"false alarm on a clean record: {kinds}"
    else:
        assert record.kind in kinds, f"{record.name}: expected {record.kind}, found {kinds}"


def test_the_corpus_is_large_and_covers_every_kind() -> None:
    defective = [r for r in CORPUS if r.kind is not None]
    assert len(defective) >= 40
    assert {r.kind for r in defective} == set(KINDS)
    assert sum(r.kind is None and r.needs_shared for r in CORPUS) == len(REAL_TRIALS)


# --------------------------------------------------------------------------- end to end


def _case_on(record: Record, clean_synth: Path, tmp: Path, **data: Any) -> Any:
    folder, _ = _source_folder(record, clean_synth, tmp / "records")
    changes = record.edit(folder) if record.edit else {}
    spec = _merge(synth_spec(folder, channels=changes.get("channels", {})), changes)
    spec["data"].update(data)
    return parse_case(spec, source=folder / "case.toml")


def _record(name: str) -> Record:
    return next(r for r in CORPUS if r.name == name)


def test_a_run_on_a_defective_record_is_no_success_and_says_why(clean_synth: Path,
                                                                tmp_path: Path) -> None:
    from femupdate.pipeline.results import read_summary
    from femupdate.pipeline.run import run_case

    case = _case_on(_record("synth-spike-1e5"), clean_synth, tmp_path)
    with pytest.warns(FemupdateWarning, match=r"floors\.csv: channel 'F1\.ux': spike: "):
        result = run_case(case, tmp_path / "out", runs=2, max_evals=40)
    summary = read_summary(tmp_path / "out" / "summary.json")
    assert summary.successes == 0 and not any(r.success for r in summary.runs)
    assert summary.success_rule.startswith("none: 1 defect(s)")
    assert [(d.kind, d.channel, d.status) for d in summary.defects] == [
        ("spike", "F1.ux", "open")]
    assert result.summary.defects == summary.defects


def test_accept_silences_a_check_by_name_and_the_verdict_decides(clean_synth: Path,
                                                                tmp_path: Path) -> None:
    from femupdate.pipeline.run import run_case
    from femupdate.runs.verdict import success_rule

    case = _case_on(_record("synth-spike-1e5"), clean_synth, tmp_path, accept=["spike"])
    result = run_case(case, None, runs=2, max_evals=40)
    assert [(d.kind, d.status) for d in result.summary.defects] == [("spike", "accepted")]
    # the accepted defect no longer makes every run a failure: the verdict's rule applies
    # (here the spike, kept in the record, leaves a flat valley the runs end apart in)
    assert result.summary.success_rule == success_rule(None)


def test_the_spike_repair_restores_the_clean_record(clean_synth: Path, tmp_path: Path) -> None:
    clean = load_experiments(_case_on(_record("synth-clean-seed-1"), clean_synth,
                                      tmp_path / "a"))[0]
    spiked = _case_on(_record("synth-spike-1e308"), clean_synth, tmp_path / "b",
                      repair_defects=["spike"])
    with pytest.warns(FemupdateWarning, match="spike: .*repaired"):
        (repaired,) = load_experiments(spiked)
    assert [(d.kind, d.status) for d in repaired.defects] == [("spike", "repaired")]
    # one sample replaced by the mean of its neighbours: the processed record moves by a
    # small fraction of its scale, where the spike itself was 1e308
    error = np.max(np.abs(repaired.accelerations - clean.accelerations))
    assert error < 0.05 * np.max(np.abs(clean.accelerations))


def test_the_clock_offset_repair_aligns_by_row(clean_synth: Path, tmp_path: Path) -> None:
    clean = load_experiments(_case_on(_record("synth-clean-seed-1"), clean_synth,
                                      tmp_path / "a"))[0]
    offset = _case_on(_record("synth-clock-offset-1.0s"), clean_synth, tmp_path / "b")
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        (shifted,) = load_experiments(offset)
    texts = [str(w.message) for w in said]
    assert any("clock-offset: 1601 and 1601 rows (in step)" in t for t in texts), texts
    assert not any("differ in length" in t for t in texts), texts  # they do not
    assert shifted.t.size < clean.t.size  # aligned on the stamps: only the overlap
    repaired_case = _case_on(_record("synth-clock-offset-1.0s"), clean_synth, tmp_path / "c",
                             repair_defects=["clock-offset"])
    (repaired,) = load_experiments(repaired_case)
    assert [(d.kind, d.status) for d in repaired.defects] == [("clock-offset", "repaired")]
    np.testing.assert_array_equal(repaired.target, clean.target)


def test_unknown_check_names_are_refused_with_the_allowed_ones(clean_synth: Path,
                                                               tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"data\.accept.*spik.*clock-offset"):
        _case_on(_record("synth-clean-seed-1"), clean_synth, tmp_path / "a", accept=["spik"])
    with pytest.raises(ConfigError, match=r"data\.repair_defects.*unit.*spike"):
        _case_on(_record("synth-clean-seed-1"), clean_synth, tmp_path / "b",
                 repair_defects=["unit"])


CASE_TOML = """
[case]
name = "two-storey"
[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]
[[parameters]]
name = "k1"
lower = 1000.0
upper = 10000.0
scale = "log"
[[parameters]]
name = "k2"
lower = 1000.0
upper = 10000.0
scale = "log"
[[parameters]]
name = "c1"
lower = 0.0
upper = 5.0
[[parameters]]
name = "c2"
lower = 0.0
upper = 5.0
[data]
format = "csv"
directory = "records"
time_column = "t"
input = { file = "table.csv", column = "table" }
outputs = [{ file = "floors.csv", column = "a1", node = "F1", dof = "ux" },
           { file = "floors.csv", column = "a2", node = "F2", dof = "ux" }]
[preprocess]
highpass_hz = 0.5
[search]
method = "ab"
runs = 1
seed = 1
max_evals = 30
"""


def _cli_run(record: Record, clean_synth: Path, tmp: Path) -> tuple[str, Path]:
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    tmp.mkdir()
    folder, _ = _source_folder(record, clean_synth, tmp / "records")
    record.edit(folder) if record.edit else None
    (tmp / "case.toml").write_text(CASE_TOML)
    out = tmp / "out"
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        result = CliRunner().invoke(app, ["run", str(tmp / "case.toml"), "--out", str(out),
                                          "--quiet"], terminal_width=400)
    assert result.exit_code == 0, result.output
    lines = [str(w.message) for w in said if issubclass(w.category, FemupdateWarning)]
    assert all("\n" not in line for line in lines)  # one line each
    return " ".join([*lines, *result.output.split()]), out


@pytest.mark.slow
def test_the_cli_says_each_defect_in_one_line_and_the_report_shows_them(
        clean_synth: Path, tmp_path: Path) -> None:
    from femupdate.report.html import render_report
    from femupdate.report.sections_defects import section_defects

    output, out = _cli_run(_record("synth-duplicate-floors"), clean_synth, tmp_path / "dup")
    assert ("floors.csv: channel 'F2.ux': duplicate: identical to channel 'F1.ux' sample for "
            "sample") in output
    assert "not a success: 1 defect(s)" in output
    page = render_report(out)
    assert 'id="defects"' in page and "identical to channel" in page
    assert "no run of this fit counts as a success" in page
    assert section_defects([]) == ""  # no findings: no section


def test_files_of_equal_length_are_not_said_to_differ_in_length(clean_synth: Path,
                                                                 tmp_path: Path) -> None:
    """Stamps 6 samples apart (no clock offset yet): the overlap warning says what differs."""
    late = Record("late", "synth", None, _floors(lambda t, v: (t + 0.03, v)))
    with pytest.warns(FemupdateWarning, match="hold as many samples but their time stamps "
                                              "start apart") as said:
        load_experiments(_case_on(late, clean_synth, tmp_path))
    assert not any("differ in length" in str(w.message) for w in said)


def test_validate_keeps_the_defects(clean_synth: Path, tmp_path: Path) -> None:
    from femupdate.pipeline.run import validate_case

    case = _case_on(_record("synth-saturation-70pct"), clean_synth, tmp_path)
    with pytest.warns(FemupdateWarning, match="channel 'F2.ux': saturation: "):
        validation = validate_case(case, TRUTH)
    found = validation.to_dict()["defects"]
    assert [d["kind"] for d in found] == ["saturation", "saturation"]  # clipped both ways
    assert ["top" in found[0]["evidence"], "bottom" in found[1]["evidence"]] == [True, True]


# --------------------------------------------------------------------------- issue 33


def test_validate_says_a_spike_in_the_last_row(clean_synth: Path, tmp_path: Path) -> None:
    from femupdate.pipeline.run import validate_case

    last = Record("last-row", "synth", "spike", _floors(_spikes((1e5,), (-1,))))
    with pytest.warns(FemupdateWarning, match=r"channel 'F1\.ux': spike: 1 isolated sample\(s\) "
                                              r"far off the signal: 1e\+05 m/s² at t = 8 s "
                                              r"\(sample 1600 of 1601\)"):
        validation = validate_case(_case_on(last, clean_synth, tmp_path / "a"), TRUTH)
    assert [d["kind"] for d in validation.to_dict()["defects"]] == ["spike"]
    # repaired, the record is the clean one but for that sample
    clean = validate_case(_case_on(_record("synth-clean-seed-1"), clean_synth, tmp_path / "b"),
                          TRUTH)
    repaired = validate_case(_case_on(last, clean_synth, tmp_path / "c",
                                      repair_defects=["spike"]), TRUTH)
    assert [d.status for d in repaired.defects] == ["repaired"]
    assert repaired.trials[0].phi == pytest.approx(clean.trials[0].phi, rel=0.05)


def test_an_absurd_last_sample_is_an_error_naming_the_channel_and_the_spike(
        clean_synth: Path, tmp_path: Path) -> None:
    """1e308 in the last row: integrated it overflows every sum of squares; the error says
    which channel and why, and names the spike that makes it."""
    last = Record("last-row", "synth", "spike", _floors(_spikes((1e308,), (-1,))))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        with pytest.raises(DataError, match=r"channel 'F1\.ux': the processed record peaks at "
                                            r".*beyond what a sum of squares can hold.*the "
                                            r"checks found: .*spike: .*1e\+308 m/s²"):
            load_experiments(_case_on(last, clean_synth, tmp_path))


def test_the_cli_run_on_an_absurd_last_sample_says_the_spike(clean_synth: Path,
                                                            tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    tmp_path.mkdir(exist_ok=True)
    folder, _ = _source_folder(_record("synth-clean-seed-1"), clean_synth, tmp_path / "records")
    _floors(_spikes((1e308,), (-1,)))(folder)
    (tmp_path / "case.toml").write_text(CASE_TOML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        result = CliRunner().invoke(app, ["run", str(tmp_path / "case.toml"), "--out",
                                          str(tmp_path / "out"), "--quiet"], terminal_width=400)
    # the command raises the one-line DataError that femupdate.cli.main prints (exit code 2)
    assert isinstance(result.exception, DataError), result.output
    text = str(result.exception)
    assert "channel 'F1.ux': the processed record peaks at" in text
    assert "spike: 1 isolated sample(s) far off the signal: 1e+308 m/s²" in text
    assert "\n" not in text


def test_a_spike_in_a_sample_the_trial_does_not_use_is_not_said(clean_synth: Path,
                                                               tmp_path: Path) -> None:
    """Outside ``[data] window`` a spike touches no fitted sample; inside it, it is said."""
    spiked = Record("early", "synth", "spike", _floors(_spikes((1e5,), (100,))))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        (outside,) = load_experiments(_case_on(spiked, clean_synth, tmp_path / "a",
                                               window=[2.0, 8.0]))
        (inside,) = load_experiments(_case_on(spiked, clean_synth, tmp_path / "b",
                                              window=[0.0, 6.0]))
    assert outside.defects == ()
    assert [d.kind for d in inside.defects] == ["spike"]


def test_a_spike_in_a_resampled_record_is_found_on_the_file_as_read(clean_synth: Path,
                                                                   tmp_path: Path) -> None:
    """Resampling would smear a spike over many samples (a burst, not a spike): it is found
    on the file's own samples, and the repair interpolates it there, before resampling."""
    spiked = Record("resampled", "synth", "spike", _floors(_spikes((200.0,), (800,))))
    case = _case_on(spiked, clean_synth, tmp_path / "a")
    case = case.model_copy(update={"preprocess": case.preprocess.model_copy(
        update={"resample_hz": 150.0})})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        (found,) = load_experiments(case)
    assert [(d.kind, "sample 800 of 1601" in d.evidence) for d in found.defects] == [
        ("spike", True)]


def test_an_nmse_that_is_not_finite_says_which_channel_and_why() -> None:
    from femupdate.trials.checks import nonfinite_causes

    measured = np.ones((10, 3))
    measured[4, 1] = np.nan
    predicted = np.ones((10, 3))
    predicted[6:, 2] = np.inf
    lines = nonfinite_causes(["a", "b", "c"], np.array([0.1, np.inf, np.inf]), measured,
                             predicted)
    assert lines == [
        "channel 'b': NMSE inf: the measurement holds 1 non-finite sample(s), the first at "
        "scored sample 4",
        "channel 'c': NMSE inf: the prediction holds 4 non-finite sample(s), the first at "
        "scored sample 6 (the model's output diverged, or overflowed in its processing)"]
    (failed,) = nonfinite_causes(["a"], np.array([np.nan]), np.ones((5, 1)), None,
                                 "an unstable step")
    assert failed == ("channel 'a': NMSE nan: the simulation failed at these parameter values "
                      "(an unstable step)")
    huge = np.ones((5, 1))
    huge[2] = 1e300
    (overflow,) = nonfinite_causes(["a"], np.array([np.inf]), np.ones((5, 1)), huge)
    assert "the prediction peaks at 1e+300, beyond what a sum of squares can hold" in overflow
