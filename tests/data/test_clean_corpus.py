"""The clean corpus: records of every kind of test, clean, on which the checks find nothing.

A check that fires on a clean record marks every run of it unsuccessful: a false alarm is as
wrong as a silent miss. The corpus holds virtual experiments made by femupdate's own simulators
(steady sines below, at and above the first mode, sine sweeps, white noise, earthquakes: EC8
artificial records and both El Centro 1940 records of the shared data; noise-free and with 2 %
sensor noise; short and tall buildings, a stiff bridge and 3-D frames of the examples, a
strongly hysteretic Bouc–Wen building at 1 kHz) and every real record of the shared data (the
six minishake trials, Northridge 2 with its recorded glitches repaired; every channel of both
Meloland earthquakes). Each is read as a case reads it (``load_experiments``: every check, on
the path ``femupdate run`` takes) and must give no finding. The defect corpus
(``test_defects_corpus.py``) shows that the same checks find every defect put into such
records.
"""

from __future__ import annotations

import os
import tomllib
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.signal

from femupdate.case import parse_case
from femupdate.data import defects
from femupdate.errors import FemupdateWarning
from femupdate.trials.checks import first_mode_hz
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import Motion, ec8_motion, recorded_motion, virtual_experiment

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("FEMUPDATE_DATA", REPO.parent / "shared" / "data"))
ELCENTRO = SHARED / "elcentro1940"
MINISHAKE = SHARED / "minishake_1story"
MELOLAND = SHARED / "cesmd_meloland"
REAL_TRIALS = ("elcentro_t1", "elcentro_t2", "northridge_t1", "northridge_t2", "sine2hz_t1",
               "sine2hz_t2")


# --------------------------------------------------------------------------- cases


def shear_spec(directory: Path, masses: list[float], stiffness: float, floors: list[int], *,
               damping: tuple[float, float] = (0.4, 5e-4),
               bouc_wen: dict[str, float] | None = None) -> dict[str, Any]:
    """A shear building of ``masses`` (kg) with one storey stiffness ``k`` (N/m) throughout,
    Rayleigh damping (α 1/s, β s), optionally a Bouc–Wen element in every storey, read from
    table.csv and floors.csv at ``floors``."""
    n = len(masses)
    model: dict[str, Any] = {"masses": masses, "stiffnesses": ["k"] * n}
    rayleigh: dict[str, Any] = {"alpha": damping[0], "beta": damping[1]}
    if bouc_wen:
        model["bouc_wen"] = bouc_wen
        # β K of the storey springs only (bouc_wen = false): the Bouc–Wen records keep the
        # yield drifts test_the_hysteretic_record_yields_far states
        rayleigh["bouc_wen"] = False
    return {
        "case": {"name": f"shear-{n}"},
        "model": {"shear_building": model, "rayleigh": rayleigh},
        "parameters": [{"name": "k", "lower": 0.5 * stiffness, "upper": 2.0 * stiffness,
                        "scale": "log", "nominal": stiffness}],
        "data": {"format": "csv", "directory": str(directory), "time_column": "t",
                 "input": {"file": "table.csv", "column": "table"},
                 "outputs": [{"file": "floors.csv", "column": f"a{f}", "node": f"F{f}",
                              "dof": "ux"} for f in floors]},
        "objective": {"quantity": "acceleration"},
    }


#: Bouc–Wen storeys (A = 1, β = γ, n = 8): they yield at (1 / (β + γ))^(1/n) = 6.5 mm.
BOUC_WEN = {"k": 4000.0, "alpha": 0.05, "beta": 1.6e17, "gamma": 1.6e17, "n": 8.0}
BOUC_WEN_YIELD = (1.0 / (2 * 1.6e17)) ** (1 / 8)


def first_mode(masses: list[float], stiffness: float) -> float:
    """The first natural frequency (Hz) of a uniform-stiffness shear building."""
    n = len(masses)
    k = stiffness * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    k[-1, -1] = stiffness
    m = np.diag(masses)
    w2 = np.linalg.eigvals(np.linalg.solve(m, k)).real
    return float(np.sqrt(w2.min()) / (2 * np.pi))


TWO = ([1.0, 0.8], 3000.0)          # first mode 6.1 Hz
THREE = ([1.0, 1.0, 1.0], 4000.0)   # first mode 4.5 Hz
RATE = 200.0


# --------------------------------------------------------------------------- motions


def sine(f_hz: float, amplitude: float = 2.0, duration: float = 10.0, rate: float = RATE,
         ramp: float = 0.0) -> Motion:
    """A steady sine (noise-free samples: its crests recur exactly every period when the
    rate is a multiple of the frequency), optionally ramped up over ``ramp`` s."""
    t = np.arange(int(duration * rate)) / rate
    envelope = np.clip(t / ramp, 0.0, 1.0) if ramp else 1.0
    return Motion(amplitude * envelope * np.sin(2 * np.pi * f_hz * t), 1 / rate,
                  f"sine {f_hz:g} Hz")


def stepped_sine(frequencies: tuple[float, ...], dwell: float = 4.0,
                 rate: float = RATE) -> Motion:
    """Sine dwells, one after the other, each ramped up and down over 0.5 s."""
    t = np.arange(int(dwell * rate)) / rate
    ramp = np.clip(np.minimum(t, dwell - t) / 0.5, 0.0, 1.0)
    ag = np.concatenate([ramp * np.sin(2 * np.pi * f * t) for f in frequencies])
    return Motion(2.0 * ag, 1 / rate, f"stepped sine {frequencies} Hz")


def pulse(width: float = 0.1, duration: float = 6.0, rate: float = RATE) -> Motion:
    """One half-sine pulse of ``width`` s at 1 s, at rest before and after: a free decay."""
    t = np.arange(int(duration * rate)) / rate
    inside = (t >= 1.0) & (t <= 1.0 + width)
    ag = np.where(inside, 5.0 * np.sin(np.pi * (t - 1.0) / width), 0.0)
    return Motion(ag, 1 / rate, f"half-sine pulse of {width:g} s")


def sweep(f0: float, f1: float, duration: float = 20.0, rate: float = RATE) -> Motion:
    t = np.arange(int(duration * rate)) / rate
    ag = 2.0 * scipy.signal.chirp(t, f0, duration, f1) * np.clip(t / 0.5, 0, 1)
    return Motion(ag, 1 / rate, f"sweep {f0:g}–{f1:g} Hz")


def white(seed: int, band_hz: float, duration: float = 10.0, rate: float = RATE) -> Motion:
    rng = np.random.default_rng(seed)
    b, a = scipy.signal.butter(4, band_hz, fs=rate)
    ag = scipy.signal.lfilter(b, a, rng.standard_normal(int(duration * rate)))
    return Motion(2.0 * ag / np.std(ag), 1 / rate, f"white noise to {band_hz:g} Hz")


def elcentro_linear(scale: float, rate: float = 1000.0) -> Motion:
    """El Centro NS interpolated linearly to ``rate`` (a kink at every recorded sample)."""
    from femupdate.data.datasets import read_elcentro

    path = ELCENTRO / "elcentro_NS_1940_peknold_g_dt0.02.dat"
    if not path.is_file():
        pytest.skip(f"the shared El Centro records are absent ({path})")
    t, ag = read_elcentro(path)
    fine = np.arange(0.0, t[-1], 1.0 / rate)
    return Motion(scale * np.interp(fine, t, ag), 1.0 / rate,
                  f"El Centro NS × {scale:g}, linear to {rate:g} Hz")


def earthquake(seed: int, duration: float = 10.0, rate: float = RATE) -> Motion:
    return ec8_motion(np.random.default_rng(seed), rate=rate, duration=duration,
                      length_scale=1.0)


def elcentro(name: str, rate: float = RATE, length_scale: float = 1.0) -> Motion:
    path = ELCENTRO / name
    if not path.is_file():
        pytest.skip(f"the shared El Centro records are absent ({path})")
    return recorded_motion(path, rate=rate, length_scale=length_scale)


# --------------------------------------------------------------------------- the corpus


@dataclass(frozen=True)
class Clean:
    """A clean record: its test kind, and how it is made (into a folder, giving the case)."""

    name: str
    kind: str  # sine, stepped sine, sweep, white noise, earthquake, pulse
    make: Callable[[Path], dict[str, Any]]


def virtual(building: tuple[list[float], float], floors: list[int], motion: Callable[[], Motion],
            *, snr: float = 0.02, **spec: Any) -> Callable[[Path], dict[str, Any]]:
    """A virtual experiment of a shear building under a motion (noise-free for snr = 0)."""
    def make(folder: Path) -> dict[str, Any]:
        masses, k = building
        case_spec = shear_spec(folder, masses, k, floors, **spec)
        case = parse_case(case_spec, source=folder / "case.toml")
        truth = {p.name: p.nominal for p in case.parameters}
        noise = {} if snr else {"offset": 0.0, "drift": 0.0}
        virtual_experiment(case, truth, folder, motion=motion(), snr=snr, seed=3, **noise)
        return case_spec
    return make


def real(trial: str) -> Callable[[Path], dict[str, Any]]:
    """A minishake trial as examples/minishake-1story/trials.toml reads it."""
    def make(folder: Path) -> dict[str, Any]:
        if not MINISHAKE.is_dir():
            pytest.skip(f"the shared minishake data are absent ({MINISHAKE})")
        return {
            "case": {"name": f"minishake-{trial}"},
            "model": {"shear_building": {"masses": [0.179], "stiffnesses": ["k1"],
                                         "dampers": ["c1"]}},
            "parameters": [{"name": "k1", "lower": 500.0, "upper": 20000.0, "scale": "log",
                            "nominal": 2830.0},
                           {"name": "c1", "lower": 0.0, "upper": 5.0, "nominal": 0.5}],
            "data": {"format": "csv", "directory": str(MINISHAKE),
                     "time_column": "SampleTimeFine", "time_unit": "us", "skip_rows": 1,
                     "unit": "m/s2", "repair": trial == "northridge_t2",
                     "input": {"file": f"stiff1_{trial}_ground.csv", "column": "Acc_X"},
                     "outputs": [{"file": f"stiff1_{trial}_top.csv", "column": "Acc_X",
                                  "node": "F1", "dof": "ux", "name": "roof",
                                  "delay": "auto"}]},
            "preprocess": {"highpass_hz": 1.0},
        }
    return make


def example(path: str, truth: dict[str, float], motion: Callable[[], Motion], *,
            snr: float = 0.0) -> Callable[[Path], dict[str, Any]]:
    """An example case's virtual experiment (as its header's ``femupdate synth`` makes it)."""
    def make(folder: Path) -> dict[str, Any]:
        spec = tomllib.loads((REPO / path).read_text())
        spec["data"]["directory"] = str(folder)
        case = parse_case(spec, source=folder / "case.toml")
        noise = {} if snr else {"offset": 0.0, "drift": 0.0}
        virtual_experiment(case, truth, folder, motion=motion(), snr=snr, seed=5, **noise)
        return spec
    return make


def frame_with_links(directory: Path) -> dict[str, Any]:
    """The 3-D frame of the examples with a Bouc–Wen link from each first-floor corner to
    the base along x (n = 8: sharp yielding at 0.5 mm), solved step by step."""
    spec = tomllib.loads((REPO / "examples/frame3d/frame.toml").read_text())
    spec.pop("simulation", None)
    spec["data"]["directory"] = str(directory)
    shape = 0.5 * FRAME_LINK_YIELD ** -8.0
    spec["model"]["rayleigh"]["bouc_wen"] = False  # β K of the frame only, as above
    spec["model"]["bouc_wen"] = [{"node": n, "dof": "ux", "k": 2e7, "alpha": 0.05,
                                  "beta": shape, "gamma": shape, "n": 8.0}
                                 for n in ("A1", "B1", "C1", "D1")]
    return spec


def linked_frame(folder: Path) -> dict[str, Any]:
    spec = frame_with_links(folder)
    case = parse_case(spec, source=folder / "case.toml")
    virtual_experiment(case, FRAME_TRUTH, folder, motion=elcentro_linear(FRAME_SCALE),
                       snr=0.0, offset=0.0, drift=0.0, seed=5)
    return spec


F2, F3 = first_mode(*TWO), first_mode(*THREE)
BRIDGE_TRUTH = {"E": 2.1e11, "kp1": 1e8, "kp2": 3.2e5, "kp3": 1.9e6, "kp4": 4.5e5, "c1": 5.0,
                "c2": 400.0, "c3": 3000.0, "c4": 6.0}
FRAME_TRUTH = {"E1": 2.1e11, "E2": 1.9e11, "m_roof": 900.0}
FRAME_LINK_YIELD = 5e-4  # m
FRAME_SCALE = 1.6  # El Centro × 1.6 (0.5 g): the links yield 7.7 times over

CORPUS: list[Clean] = [
    # steady sines of a 3-storey building at and below its first mode, and of a 2-storey one
    # across it; noise-free (their samples recur every period) and with 2 % noise
    *[Clean(f"three-storey-sine-{r:g}f1-{'free' if snr == 0 else 'noisy'}", "sine",
            virtual(THREE, [1, 2, 3], lambda r=r: sine(r * F3, ramp=0.0), snr=snr))
      for r in (0.1, 0.3, 0.6, 1.0) for snr in (0.0, 0.02)],
    *[Clean(f"two-storey-sine-{f:g}hz-{'free' if snr == 0 else 'noisy'}", "sine",
            virtual(TWO, [1, 2], lambda f=f: sine(f, ramp=1.0), snr=snr))
      for f in (2.0, 10.0) for snr in (0.0, 0.02)],
    *[Clean(f"two-storey-sweep-{'free' if snr == 0 else 'noisy'}", "sweep",
            virtual(TWO, [1, 2], lambda: sweep(0.5, 20.0), snr=snr)) for snr in (0.0, 0.02)],
    Clean("three-storey-sweep-below-f1", "sweep",
          virtual(THREE, [1, 2, 3], lambda: sweep(0.2, 0.8 * F3))),
    *[Clean(f"{name}-stepped-sine-{'free' if snr == 0 else 'noisy'}", "stepped sine",
            virtual(building, floors, lambda f=f: stepped_sine((0.3 * f, 0.6 * f, f)),
                    snr=snr))
      for name, building, floors, f in (("two-storey", TWO, [1, 2], F2),
                                        ("three-storey", THREE, [1, 2, 3], F3))
      for snr in (0.0, 0.02)],
    *[Clean(f"{name}-pulse-{'free' if snr == 0 else 'noisy'}", "pulse",
            virtual(building, floors, pulse, snr=snr))
      for name, building, floors in (("two-storey", TWO, [1, 2]),
                                     ("three-storey", THREE, [1, 2, 3]))
      for snr in (0.0, 0.02)],
    *[Clean(f"two-storey-white-{band:g}hz-{'free' if snr == 0 else 'noisy'}", "white noise",
            virtual(TWO, [1, 2], lambda band=band: white(4, band), snr=snr))
      for band, snr in ((30.0, 0.0), (30.0, 0.02), (60.0, 0.02))],
    *[Clean(f"two-storey-ec8-seed-{s}-{'free' if snr == 0 else 'noisy'}", "earthquake",
            virtual(TWO, [1, 2], lambda s=s: earthquake(s), snr=snr))
      for s, snr in ((1, 0.0), (2, 0.02))],
    *[Clean(f"two-storey-{name.split('_')[1]}-elcentro", "earthquake",
            virtual(TWO, [1, 2], lambda name=name: elcentro(name)))
      for name in ("elcentro_NS_1940_peknold_g_dt0.02.dat",
                   "elcentro_S00E_1940_cms2_dt0.02.dat")],
    # tall: adjacent top floors of a 200-storey building move almost alike (ρ ≈ 0.9999)
    *[Clean(f"200-storey-top-floors-{'free' if snr == 0 else 'noisy'}", "earthquake",
            virtual(([1.0] * 200, 64.0 * 200 ** 2), [100, 199, 200],
                    lambda: earthquake(7, duration=20.0, rate=100.0), snr=snr))
      for snr in (0.0, 0.02)],
    # stiff: the paper's bridge (modes 20–40 Hz, 1035 Hz) and the 3-D frames of the examples
    Clean("bridge-example-ec8", "earthquake",
          example("examples/bridge/viscous-broad.toml", BRIDGE_TRUTH,
                  lambda: ec8_motion(np.random.default_rng(0), rate=1035.0, duration=4.6))),
    *[Clean(f"frame3d-example-{which}", "earthquake",
            example(f"examples/frame3d/{which}.toml", FRAME_TRUTH,
                    lambda: earthquake(6, duration=8.0)))
      for which in ("frame", "building")],
    # strongly hysteretic at 1 kHz: Bouc–Wen storeys driven to 7.6 times their yield drift
    # (test_the_hysteretic_record_yields_far), its input with a kink at every 0.02 s
    *[Clean(f"bouc-wen-1khz-elcentro-{'free' if snr == 0 else 'noisy'}", "earthquake",
            virtual(([1.0] * 3, 200.0), [1, 2, 3], lambda: elcentro_linear(5.0), snr=snr,
                    bouc_wen=BOUC_WEN)) for snr in (0.0, 0.02)],
    Clean("frame3d-bouc-wen-links-1khz", "earthquake", linked_frame),
    # every real record of the shared data
    *[Clean(f"minishake-{trial}", "sine" if trial.startswith("sine") else "earthquake",
            real(trial)) for trial in REAL_TRIALS],
]


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("clean-corpus")


def findings_of(spec: dict[str, Any], folder: Path) -> list[str]:
    """Every finding the checks give on the case's records, as the lines they print."""
    case = parse_case(spec, source=folder / "case.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemupdateWarning)
        experiments = load_experiments(case)
    return [f.describe() for e in experiments for f in e.defects]


#: Records that take more than 5 s to make and read here (measured with --durations):
#: run by CI, left out of the everyday suite.
SLOW = ("200-storey-top-floors-free", "200-storey-top-floors-noisy",
        "bouc-wen-1khz-elcentro-free", "bouc-wen-1khz-elcentro-noisy",
        "two-storey-ec8-seed-2-noisy")


@pytest.mark.parametrize("record", [pytest.param(r, marks=pytest.mark.slow) if r.name in SLOW
                                    else r for r in CORPUS], ids=[r.name for r in CORPUS])
def test_a_clean_record_gives_no_finding(record: Clean, folders: Path) -> None:
    folder = folders / record.name
    folder.mkdir()
    spec = record.make(folder)
    assert findings_of(spec, folder) == []


# --------------------------------------------------------------------------- Meloland


def meloland(event: str) -> dict[str, tuple[float, np.ndarray]]:
    """Every channel of an event, read by femupdate's network reader: (dt s, acceleration
    m/s²) by source file."""
    from femupdate.data.network import read_network_records

    path = MELOLAND / event
    if not path.is_file():
        pytest.skip(f"the shared Meloland records are absent ({path})")
    return {ch.source: (ch.dt, ch.acceleration) for ch in read_network_records(path)}


@pytest.mark.parametrize("event", ["imperialvalley1979_ce01336.zip",
                                   "calexico2010_ce01336.zip"])
def test_every_channel_of_both_meloland_earthquakes_is_clean(event: str) -> None:
    """A network's processed records (band-passed, at 50 to 100 Hz): no spike, no flat top, no
    copy among 26 and 28 channels (several pairs of them correlate closely: the deck and the
    abutments move together)."""
    channels = meloland(event)
    assert len(channels) >= 26
    found = []
    groups: dict[tuple[float, int], dict[str, np.ndarray]] = {}
    for name, (dt, y) in channels.items():
        found += defects.check_spikes(name, y, dt * np.arange(y.size), event)
        found += defects.check_saturation(name, y, event)
        groups.setdefault((dt, y.size), {})[name] = y
    for group in groups.values():  # channels on one time base
        found += defects.check_duplicates(group, {})
    assert [f.describe() for f in found] == []


def test_the_corpus_holds_every_kind_of_test() -> None:
    assert set(SLOW) <= {r.name for r in CORPUS}
    kinds = {r.kind for r in CORPUS}
    assert len(CORPUS) >= 30
    assert kinds == {"sine", "stepped sine", "sweep", "white noise", "earthquake", "pulse"}
    assert sum(r.name.startswith("minishake-") for r in CORPUS) == len(REAL_TRIALS)


def test_the_hysteretic_record_yields_far() -> None:
    """The Bouc–Wen building and the 3-D frame with Bouc–Wen links of the corpus are driven
    well into their hysteresis: 7 to 9 times their yield deformation."""
    from femupdate.problem.case_model import CaseModel

    spec = shear_spec(Path("."), [1.0] * 3, 200.0, [1, 2, 3], bouc_wen=BOUC_WEN)
    case = parse_case(spec, source=Path("case.toml"))
    motion = elcentro_linear(5.0)
    response = CaseModel(case).simulate({"k": 200.0}, motion.ag, motion.dt)
    drift = np.abs(response.displacement[:, 0]).max() / BOUC_WEN_YIELD
    assert 7.0 <= drift <= 9.0
    frame = parse_case(frame_with_links(Path(".")), source=Path("case.toml"))
    motion = elcentro_linear(FRAME_SCALE)
    response = CaseModel(frame).simulate(FRAME_TRUTH, motion.ag, motion.dt)
    # B1.ux (the first output) is the deformation of the link at B1
    assert 7.0 <= np.abs(response.displacement[:, 0]).max() / FRAME_LINK_YIELD <= 9.0


@pytest.mark.slow
def test_a_1000_storey_building_at_1035_hz_for_50_s_is_clean(tmp_path: Path) -> None:
    """The synth defaults (1035 Hz, an EC8 motion at model scale 1:50, 2 % noise) on a
    1000-storey building whose first mode is at 0.79 Hz: its record has almost no energy
    below a third of that mode, where the unit check estimates a gain."""
    from femupdate.paper.bench.large_building import case_text

    text = case_text(1000, 10, data_directory=str(tmp_path)).replace(
        "masses = [\n  1.0", "masses = [\n  6.4").replace(" 1.0,", " 6.4,")
    spec = tomllib.loads(text)
    case = parse_case(spec, source=tmp_path / "case.toml")
    assert first_mode_hz(case) == pytest.approx(0.79, abs=0.01)
    truth = dict(case.nominal())
    virtual_experiment(case, truth, tmp_path, duration=50.0, rate=1035.0, seed=0)
    assert findings_of(spec, tmp_path) == []
