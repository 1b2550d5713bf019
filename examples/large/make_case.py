"""Write a large shear-building case file: ``shear-building-1000.toml`` and its truth.

A uniform building of ``storeys`` floors of 1 kg with storey stiffnesses in ``groups``
parameters (consecutive storeys share one), ``k0 = 64 n²`` N/m at the nominal point (first
mode near 2 Hz, modes about 4 Hz apart at every size), Rayleigh damping (α = 0.4 1/s,
β = 5e-4 s), absolute accelerations at floors n/3, 2n/3 and n. Records at 100 Hz: the fitted
band reaches 50 Hz (Nyquist), so the reduced path keeps the modes up to 100 Hz (25 of them).

    python examples/large/make_case.py                 # shear-building-1000.toml, truth.json
    python examples/large/make_case.py --storeys 200 --out /tmp/sb200.toml

The records themselves are a virtual experiment (nothing large is committed)::

    femupdate synth examples/large/shear-building-1000.toml \
        --truth examples/large/truth.json --out examples/large/data --snr 0 \
        --rate 100 --duration 20 --length-scale 1
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from femupdate.paper.bench.large_building import case_text, truth

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--storeys", type=int, default=1000)
    parser.add_argument("--groups", type=int, default=10)
    parser.add_argument("--out", type=Path, default=None,
                        help="the case file (default: shear-building-N.toml here); truth.json "
                             "beside it")
    args = parser.parse_args(argv)
    out = args.out or HERE / f"shear-building-{args.storeys}.toml"
    out.write_text(case_text(args.storeys, args.groups), encoding="utf-8")
    (out.parent / "truth.json").write_text(
        json.dumps(truth(args.storeys, args.groups), indent=1) + "\n", encoding="utf-8")
    print(f"wrote {out} and {out.parent / 'truth.json'}")


if __name__ == "__main__":
    main()
