"""Baber–Wen degradation of the Bouc–Wen element (issue 34) against OpenSeesPy's BoucWen.

    python benchmarks/bouc_wen_degradation.py [--quick] [--figure PATH] [--json PATH]

1. **One element under a prescribed history.** k = 1e4 N/m, α = 0.1, A = 1, β = 150, γ = 50,
   n = 1.5 (z_u = 29 mm), driven through a growing sine from rest (4 s, 1.1 Hz, amplitude
   6 → 26 mm) in N increments, with the degradation rates δ_A, δ_ν, δ_η (1/J) together and
   one at a time; OpenSeesPy's ``uniaxialMaterial BoucWen`` with the same rates driven through
   the same strains (``testUniaxialMaterial``/``setStrain``). Per N: the NMSE of femupdate's
   force history against OpenSees's (sum of squared differences over the sum of squares), and
   for scale the NMSE between the degrading and the undegraded loop.
2. **The figure** (``--figure``, default ``docs/images/bouc-wen-degradation.png``): the loops
   at N = 8,000 with all three rates, femupdate and OpenSees, and the undegraded loop; the
   hysteretic energy e = ∫ (1 − α) k z dy beside it.

``--quick`` (for CI): N = 2,000 and 8,000 only, and no figure unless ``--figure`` is given.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from femupdate.model.hysteresis import bouc_wen_history, bouc_wen_loop
from femupdate.paper.bench.opensees import import_opensees

LAW = (1e4, 0.1, 1.0, 150.0, 50.0, 1.5)  # k, alpha, A, beta, gamma, n
RATES = {"all three": (0.05, 0.1, 0.05), "delta_a": (0.1, 0.0, 0.0),
         "delta_nu": (0.0, 0.2, 0.0), "delta_eta": (0.0, 0.0, 0.1)}
STEPS = (2000, 8000, 32000)
FIGURE = Path(__file__).resolve().parents[1] / "docs" / "images" / "bouc-wen-degradation.png"


def history(count: int) -> np.ndarray:
    t = np.linspace(0.0, 4.0, count + 1)
    return 0.02 * (0.3 + t / 4.0) * np.sin(2.0 * np.pi * 1.1 * t)


def opensees_stress(ops, y: np.ndarray, rates: tuple[float, float, float]) -> np.ndarray:
    k, alpha, A, beta, gamma, n = LAW
    ops.wipe()
    # argument order: tag alpha ko n gamma beta Ao deltaA deltaNu deltaEta
    ops.uniaxialMaterial("BoucWen", 1, alpha, k, n, gamma, beta, A, *rates)
    ops.testUniaxialMaterial(1)
    out = np.empty(y.size)
    for i, value in enumerate(y):
        ops.setStrain(float(value))
        out[i] = ops.getStress()
    ops.wipe()
    return out


def nmse(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.sum((a - ref) ** 2) / np.sum(ref**2))


def figure(ops, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rates = RATES["all three"]
    y = history(8000)
    ours, _, energy = bouc_wen_history(y, *LAW, *rates)
    theirs = opensees_stress(ops, y, rates)
    plain, _ = bouc_wen_loop(y, *LAW)
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), width_ratios=(3, 2))
    left.plot(1e3 * y, plain, color="0.75", lw=1.0, label="undegraded")
    left.plot(1e3 * y, theirs, color="tab:blue", lw=2.5, label="OpenSees BoucWen")
    left.plot(1e3 * y, ours, color="tab:red", lw=0.9, ls="--", label="femupdate")
    left.set_xlabel("deformation y [mm]")
    left.set_ylabel("force [N]")
    left.set_title(f"δ_A, δ_ν, δ_η = {rates[0]}, {rates[1]}, {rates[2]} 1/J: "
                   f"NMSE {nmse(ours, theirs):.1e}", fontsize=10)
    left.legend(loc="upper left", fontsize=8)
    t = np.linspace(0.0, 4.0, y.size)
    right.plot(t, energy, color="tab:red")
    right.set_xlabel("time [s]")
    right.set_ylabel("hysteretic energy e [J]")
    right.set_title("e = ∫ (1 − α) k z dy", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps, no figure")
    parser.add_argument("--figure", type=Path, default=None,
                        help=f"where to draw the figure (default {FIGURE}; none with --quick)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    steps = STEPS[:2] if args.quick else STEPS
    figure_path = args.figure if args.figure is not None or args.quick else FIGURE
    ops = import_opensees()
    rows = []
    print(f"{'rates':>10} {'N':>6} {'vs OpenSees':>12} {'vs undegraded':>14}")
    for name, rates in RATES.items():
        for count in steps:
            y = history(count)
            ours, _ = bouc_wen_loop(y, *LAW, *rates)
            theirs = opensees_stress(ops, y, rates)
            plain, _ = bouc_wen_loop(y, *LAW)
            row = {"rates": name, "steps": count, "nmse_opensees": nmse(ours, theirs),
                   "nmse_undegraded": nmse(plain, theirs)}
            rows.append(row)
            print(f"{name:>10} {count:>6} {row['nmse_opensees']:>12.2e} "
                  f"{row['nmse_undegraded']:>14.2e}")
    if figure_path is not None:
        figure(ops, figure_path)
        print(f"figure: {figure_path}")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
