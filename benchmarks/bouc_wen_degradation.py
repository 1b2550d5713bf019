"""Baber–Wen degradation of the Bouc–Wen element (issue 34) against OpenSeesPy's BoucWen.

    python benchmarks/bouc_wen_degradation.py [--quick] [--figure PATH] [--json PATH]

1. **One element under a prescribed history.** k = 1e4 N/m, α = 0.1, A = 1, β = 150, γ = 50,
   n = 1.5 (z_u = 29 mm), driven through a growing sine from rest (4 s, 1.1 Hz, amplitude
   6 → 26 mm) in N increments, with the degradation rates δ_A, δ_ν, δ_η (1/J) together and
   one at a time; OpenSeesPy's ``uniaxialMaterial BoucWen`` with the same rates driven through
   the same strains (``testUniaxialMaterial``/``setStrain``). Per N: the NMSE of femupdate's
   force history against OpenSees's (sum of squared differences over the sum of squares), and
   for scale the NMSE between the degrading and the undegraded loop.
2. **In a structure.** A two-storey shear building (masses 1.0 and 0.8 kg, mass-proportional
   damping 0.6/s) on two Bouc–Wen links (k = 4000 and 3000 N/m, α = 0.1, β = 7.5e5 and 1e6,
   γ = 2.5e5, n = 2) with δ_A, δ_ν, δ_η = 1, 2, 1 per J, under a 2 s sine burst (3 Hz,
   8 m/s², 200 Hz samples); OpenSeesPy's transient analysis of the same building
   (``zeroLength`` elements with the degrading ``BoucWen`` material, node masses,
   ``UniformExcitation``). Central differences against its ``CentralDifference`` at the same
   substep (largest floor-displacement difference relative to the peak), the implicit path
   against its ``Newmark`` with Newton iterations (NMSE), and the implicit path against
   femupdate's central differences at 40 substeps.
3. **The figure** (``--figure``, default ``docs/images/bouc-wen-degradation.png``): the loops
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
from femupdate.model.structure import shear_building
from femupdate.paper.bench.opensees import import_opensees
from femupdate.simulate import simulate

LAW = (1e4, 0.1, 1.0, 150.0, 50.0, 1.5)  # k, alpha, A, beta, gamma, n
RATES = {"all three": (0.05, 0.1, 0.05), "delta_a": (0.1, 0.0, 0.0),
         "delta_nu": (0.0, 0.2, 0.0), "delta_eta": (0.0, 0.0, 0.1)}
STEPS = (2000, 8000, 32000)
MASSES = (1.0, 0.8)
STOREYS = [{"k": 4000.0, "alpha": 0.1, "A": 1.0, "beta": 7.5e5, "gamma": 2.5e5, "n": 2.0,
            "delta_a": 1.0, "delta_nu": 2.0, "delta_eta": 1.0},
           {"k": 3000.0, "alpha": 0.1, "A": 1.0, "beta": 1.0e6, "gamma": 2.5e5, "n": 2.0,
            "delta_a": 1.0, "delta_nu": 2.0, "delta_eta": 1.0}]
DT = 0.005
RAYLEIGH_ALPHA = 0.6
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


def record() -> np.ndarray:
    t = np.arange(400) * DT
    return 8.0 * np.sin(2.0 * np.pi * 3.0 * t) * np.sin(np.pi * t / t[-1]) ** 2


def building(degrading: bool = True):
    laws = STOREYS if degrading else [{k: v for k, v in law.items() if not k.startswith("delta")}
                                      for law in STOREYS]
    s = shear_building(list(MASSES), [0.0, 0.0], bouc_wen=laws)
    s.set_rayleigh(alpha=RAYLEIGH_ALPHA)
    return s.assemble()


def opensees_building(ops, ag: np.ndarray, substeps: int, scheme: str = "central", *,
                      dt: float = DT, masses=MASSES, laws=STOREYS,
                      rayleigh_alpha: float = RAYLEIGH_ALPHA,
                      beta_kinit: float = 0.0) -> np.ndarray:
    """Floor displacements of a shear building on zero-length ``BoucWen`` storeys by OpenSees:
    ``"central"`` differences or ``"newmark"`` (average acceleration, Newton iterations);
    ``laws`` with the degradation rates ``delta_a, delta_nu, delta_eta`` (default 0);
    ``beta_kinit``: Rayleigh's β on the storeys' initial stiffness. The tests' OpenSees checks
    call it too (tests/simulate/test_bouc_wen_opensees.py)."""
    ops.wipe()
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    for node in range(1, len(masses) + 2):
        ops.node(node, 0.0)
    ops.fix(1, 1)
    for node, mass in enumerate(masses, start=2):
        ops.mass(node, mass)
    for tag, law in enumerate(laws, start=1):
        # argument order: alpha ko n gamma beta Ao deltaA deltaNu deltaEta
        ops.uniaxialMaterial("BoucWen", tag, law["alpha"], law["k"], law["n"], law["gamma"],
                             law["beta"], law["A"],
                             *(law.get(key, 0.0) for key in ("delta_a", "delta_nu",
                                                             "delta_eta")))
        # a zeroLength element takes part in Rayleigh damping only when told (-doRayleigh)
        ops.element("zeroLength", tag, tag, tag + 1, "-mat", tag, "-dir", 1,
                    *(("-doRayleigh", 1) if beta_kinit else ()))
    ops.rayleigh(rayleigh_alpha, 0.0, beta_kinit, 0.0)
    ops.timeSeries("Path", 1, "-dt", dt, "-values", *ag.tolist())
    ops.pattern("UniformExcitation", 1, 1, "-accel", 1)
    ops.constraints("Plain")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    if scheme == "newmark":
        ops.test("NormDispIncr", 1e-14, 50)
        ops.algorithm("Newton")
        ops.integrator("Newmark", 0.5, 0.25)
    else:
        ops.algorithm("Linear")
        ops.integrator("CentralDifference")
    ops.analysis("Transient")
    out = np.zeros((ag.size, len(masses)))
    for k in range(1, ag.size):
        if ops.analyze(substeps, dt / substeps) != 0:
            raise RuntimeError(f"OpenSees failed at sample {k}")
        out[k] = [ops.nodeDisp(node, 1) for node in range(2, len(masses) + 2)]
    ops.wipe()
    return out


def structure(ops, quick: bool) -> None:
    ag = record()
    system = building()
    plain = simulate(building(False), DT, ag=ag, method="nonlinear", substeps=40).displacement
    explicit = simulate(system, DT, ag=ag, method="nonlinear", substeps=40).displacement
    peak = np.abs(plain).max()
    print(f"\n2. Two-storey building, degrading links: degradation moves the response by "
          f"{np.abs(explicit - plain).max() / peak:.2f} of its peak ({1e3 * peak:.1f} mm)")
    print(f"{'substeps':>9} {'central vs OpenSees':>20}")
    for count in (10, 20) if quick else (10, 20, 40):
        ours = simulate(system, DT, ag=ag, method="nonlinear", substeps=count).displacement
        gap = np.abs(ours - opensees_building(ops, ag, count, "central")).max() / peak
        print(f"{count:>9} {gap:>20.2e}")
    print(f"{'substeps':>9} {'implicit vs Newmark':>20} {'implicit vs central 40':>23}")
    for count in (5, 10) if quick else (5, 10, 20):
        ours = simulate(system, DT, ag=ag, method="implicit", substeps=count).displacement
        theirs = opensees_building(ops, ag, count, "newmark")
        print(f"{count:>9} {nmse(ours, theirs):>20.2e} {nmse(ours, explicit):>23.2e}")


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
    print("1. One element, force-history NMSE")
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
    structure(ops, args.quick)
    if figure_path is not None:
        figure(ops, figure_path)
        print(f"figure: {figure_path}")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
