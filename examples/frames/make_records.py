"""The records of a frame case under two recorded components (examples/frames/isolated-frame.toml
by default, or ``--case``): its truth model shaken by both horizontal free-field components of a
recorded earthquake at once, the sensors' noise added.

The components are read with femupdate's network reader from the CSMIP archive of the 1979
Imperial Valley earthquake at the Meloland Road Overcrossing (CESMD station 01336; the data's
provenance is in ../shared/data/cesmd_meloland/PROVENANCE.md): channel 15 (free field, 360°)
on x and channel 24 (free field, 270°) on y, a segment of ``--seconds`` from ``--start``,
scaled by ``--scale`` (the recorded 0.3 m/s² barely strain the links). The virtual experiment
(``femupdate.trials.virtual``) writes the files the case reads (both components, the outputs)
in the case's ``[data] directory``, with ``truth.json`` and ``manifest.json``. The truth is
``--truth``, by default ``truth.json`` beside isolated-frame.toml and ``<case>-truth.json``
beside another case.

    python examples/frames/make_records.py [--case CASE] [--data ../shared/data] [--snr 0.02]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from femupdate.case import load_case
from femupdate.trials.virtual import Motion, recorded_motion, virtual_experiment

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1].parent / "shared" / "data"
EVENT = "cesmd_meloland/imperialvalley1979_ce01336.zip"
CHANNELS = (15, 24)  # free field 360° (x), 270° (y)
RATE = 100.0  # Hz, the rate of these channels


def free_field(data: Path, start: float, seconds: float, scale: float) -> Motion:
    """The two free-field components (m/s², a column each) of the segment, scaled: what
    ``femupdate synth --motion ARCHIVE --channels 15,24 --motion-start 3 --motion-seconds 8
    --motion-scale 10 --length-scale 1 --rate 100`` reads."""
    return recorded_motion(data / EVENT, rate=RATE, length_scale=1.0, channels=CHANNELS,
                           start=start, seconds=seconds, scale=scale)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA, help="the shared data folder")
    parser.add_argument("--start", type=float, default=3.0, help="segment start, s")
    parser.add_argument("--seconds", type=float, default=8.0, help="segment length, s")
    parser.add_argument("--scale", type=float, default=10.0, help="factor on the records")
    parser.add_argument("--snr", type=float, default=0.02, help="noise rms / signal rms")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--case", type=Path, default=HERE / "isolated-frame.toml")
    parser.add_argument("--truth", type=Path, help="truth values (JSON)")
    args = parser.parse_args()
    case_file = args.case
    case = load_case(case_file)
    truth_file = args.truth or (case_file.parent / ("truth.json"
                                                    if case_file.name == "isolated-frame.toml"
                                                    else f"{case_file.stem}-truth.json"))
    truth = json.loads(truth_file.read_text())
    motion = free_field(args.data, args.start, args.seconds, args.scale)
    assert case.data is not None and case.data.directory is not None
    out = case_file.parent / case.data.directory
    manifest = virtual_experiment(case, truth, out, seed=args.seed, motion=motion,
                                  snr=args.snr, offset=0.0, drift=0.0)
    print(f"{manifest['motion']}; {manifest['samples']} samples; wrote "
          f"{', '.join(manifest['files'])} in {out}")


if __name__ == "__main__":
    main()
