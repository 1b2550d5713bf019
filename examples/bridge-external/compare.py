"""How closely the two external bridges reproduce the built-in one.

    PYTHONPATH=src python examples/bridge-external/compare.py [--candidates 5] [--json out.json]

On the viscous bridge's noise-free virtual experiment (femupdate.paper.problems.bridge), at the
truth and at random candidates inside the narrow bounds, each model's absolute accelerations at
P1–P3, its φ and its natural frequencies against the built-in model's:

- the Python function (bridge_model.py, state-space lsim) against the built-in ``exact``;
- the OpenSeesPy model (bridge_opensees.py, nodal base load, Newmark) against the built-in
  ``newmark`` with the same substeps (the same scheme: they should agree to rounding), and its
  φ against the built-in ``exact`` (what the Newmark discretisation costs);
- the beam-mass trap: the OpenSeesPy model under UniformExcitation and with the nodal load,
  its beams' mass consistent, lumped by the element, or on the nodes (the base-load check
  switched off to measure it).

Differences are max |a − a_ref| / max |a_ref| over all samples and channels.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import parse_case
from femupdate.errors import ConfigError
from femupdate.model.modes import natural_frequencies
from femupdate.paper.problems import bridge
from femupdate.problem.update import UpdateProblem
from femupdate.simulate import prepare

HERE = Path(__file__).resolve().parent
OUTPUTS = [[2, 2], [3, 2], [4, 2]]  # OpenSees node tags of P1, P2, P3; DOF 2 = uy


def python_model() -> dict[str, Any]:
    """The case file's ``[model.python]`` of the function."""
    return {"python": {"function": f"{HERE / 'bridge_model.py'}:predict",
                       "frequencies": f"{HERE / 'bridge_model.py'}:frequencies"}}


def opensees_model(substeps: int = 10, excitation: str = "nodal", build: str = "build",
                   check: bool = True) -> dict[str, Any]:
    """The case file's ``[model.opensees]`` (and the substeps, a ``[preprocess]`` field)."""
    return {"opensees": {"build": f"{HERE / 'bridge_opensees.py'}:{build}", "outputs": OUTPUTS,
                         "direction": 2, "excitation": excitation, "algorithm": "linear",
                         "n_modes": 6, "eigen_solver": "-fullGenLapack",
                         "check_base_load": check}, "substeps": substeps}


def external(ref: UpdateProblem, model: dict[str, Any]) -> UpdateProblem:
    """The reference bridge case with its model replaced by an external one."""
    spec = ref.case.to_dict()
    substeps = model.pop("substeps", None)
    spec["model"] = model
    if substeps is not None:
        spec["preprocess"]["substeps"] = substeps
    return UpdateProblem(parse_case(spec, source=ref.case.source), ref.experiment)


def predict(problem: UpdateProblem, x: np.ndarray) -> np.ndarray:
    """The external model's accelerations at the outputs."""
    return problem.simulate(x).acceleration


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def builtin(problem: UpdateProblem, x: np.ndarray, method: str, substeps: int) -> np.ndarray:
    sim = prepare(problem.system(x), problem.experiment.dt, method=method,
                  outputs=problem.model.outputs, substeps=substeps)
    return sim.run(problem.experiment.ag).acceleration


def candidates(problem: UpdateProblem, n: int, seed: int) -> list[np.ndarray]:
    """The truth, then ``n`` uniform draws inside the bounds."""
    truth = problem.case.to_search(bridge.truth("viscous"))
    low, high = np.array(problem.bounds).T
    rng = np.random.default_rng(seed)
    return [truth] + [low + (high - low) * rng.random(low.size) for _ in range(n)]


def compare(n: int, seed: int) -> dict[str, Any]:
    ref = bridge.viscous_problem()
    xs = candidates(ref, n, seed)
    out: dict[str, Any] = {"candidates": len(xs), "seed": seed}

    py = external(ref, python_model())
    acc = [rel(predict(py, x), builtin(ref, x, "exact", 1)) for x in xs]
    phi = [abs(py(x) - ref(x)) / ref(x) for x in xs[1:]]
    freq = [rel(py.frequencies(x), natural_frequencies(ref.system(x))[0][:6]) for x in xs]
    out["python_vs_exact"] = {"acceleration": max(acc), "phi_rel": max(phi),
                              "frequencies_rel": max(freq), "phi_at_truth": py(xs[0]),
                              "builtin_phi_at_truth": ref(xs[0])}
    py.close()

    for substeps in (1, 10):
        ops = external(ref, opensees_model(substeps))
        acc = [rel(predict(ops, x), builtin(ref, x, "newmark", substeps)) for x in xs]
        phi = [abs(ops(x) - ref(x)) / ref(x) for x in xs[1:]]
        out[f"opensees_newmark{substeps}"] = {
            "acceleration_vs_builtin_newmark": max(acc),
            "acceleration_vs_exact": rel(predict(ops, xs[0]), builtin(ref, xs[0], "exact", 1)),
            "phi_rel_vs_exact": max(phi), "phi_at_truth": ops(xs[0])}
        if substeps == 10:
            freq = [rel(ops.frequencies(x), natural_frequencies(ref.system(x))[0][:6])
                    for x in xs]
            out[f"opensees_newmark{substeps}"]["frequencies_rel"] = max(freq)
        ops.close()

    truth, newmark = xs[0], builtin(ref, xs[0], "newmark", 10)
    exact_freqs = natural_frequencies(ref.system(truth))[0][:6]
    for build in ("build", "build_lumped", "build_nodal_mass"):
        for excitation in ("uniform", "nodal"):
            ops = external(ref, opensees_model(10, excitation, build, check=False))
            out[f"trap_{build}_{excitation}"] = {
                "acceleration_vs_builtin_newmark": rel(predict(ops, truth), newmark),
                "phi_at_truth": ops(truth),
                "frequencies_hz": ops.frequencies(truth).round(3).tolist(),
                "exact_frequencies_hz": exact_freqs.round(3).tolist()}
            ops.close()
            if excitation == "uniform":
                out[f"trap_{build}_{excitation}"]["base_load_check"] = base_load_check(
                    external(ref, opensees_model(10, excitation, build)), truth)
    return out


def base_load_check(problem: UpdateProblem, x: np.ndarray) -> str:
    """"passed", or the ConfigError of the base-load check."""
    try:
        predict(problem, x)
    except ConfigError as exc:
        return f"refused: {exc}"
    finally:
        problem.close()
    return "passed"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--candidates", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    out = compare(args.candidates, args.seed)
    for key, value in out.items():
        print(f"{key}: {value}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
