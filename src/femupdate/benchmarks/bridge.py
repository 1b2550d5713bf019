"""Benchmark 2 of the paper: the 1:50 four-span bridge on a shaking table (METHOD.md §8).

The measured data of the paper are not available, so the case is rebuilt as a virtual
experiment: a known "truth" model of the same form, shaken by an artificial Eurocode-8
accelerogram, recorded by noisy accelerometers, and processed as the paper did.

Nominal geometry (chosen, not the paper's, which is not given): four equal 2.8 m spans of an
80 × 80 × 5 mm square hollow steel deck (κ = 0.44), 48 kg of added mass lumped at each of the five
nodes, abutment springs kp1 = 1e8 N/m and pier springs 3.2e5, 1.9e6 and 4.5e5 N/m. With E =
2.1e11 Pa this puts the first four frequencies at 11.67, 13.67, 25.81 and 35.24 Hz (paper,
measured: 11.60, 13.60, 25.75, 35.00 Hz).

Nodes A1, P1, P2, P3, A2 with DOFs (uy, rz): transverse translation and rotation about the
vertical axis, so P1–P3 translations are the paper's DOFs 3, 5 and 7.
"""

from __future__ import annotations

from typing import Any

SPAN = 2.8
SECTION_B, SECTION_T = 0.08, 0.005
ADDED_MASS = 48.0
NODES = ("A1", "P1", "P2", "P3", "A2")
MEASURED_NODES = ("P1", "P2", "P3")
PAPER_FREQUENCIES_HZ = (11.60, 13.60, 25.75, 35.00)
SAMPLE_RATE = 1035.0
N_SAMPLES = 4768
SUBSTEPS = 10

#: (name, unit, truth, narrow band, broad band) of the viscous model (Tables 3–6).
VISCOUS_PARAMETERS: tuple[tuple[str, str, float, tuple[float, float], tuple[float, float]], ...] = (
    ("E", "Pa", 2.1e11, (1e11, 3e11), (0.0, 3e11)),
    ("kp1", "N/m", 1e8, (1e7, 5e8), (0.0, 5e8)),
    ("kp2", "N/m", 3.2e5, (1e5, 1e6), (0.0, 1e6)),
    ("kp3", "N/m", 1.9e6, (1e6, 1e7), (0.0, 1e7)),
    ("kp4", "N/m", 4.5e5, (1e5, 1e6), (0.0, 1e6)),
    ("c1", "N·m·s/rad", 5.0, (0.0, 10.0), (0.0, 1000.0)),
    ("c2", "N·s/m", 400.0, (0.0, 1000.0), (0.0, 1000.0)),
    ("c3", "N·s/m", 3000.0, (1000.0, 10000.0), (0.0, 10000.0)),
    ("c4", "N·s/m", 6.0, (0.0, 10.0), (0.0, 1000.0)),
)


def _deck(dampers: list[dict[str, Any]], frictions: list[dict[str, Any]]) -> dict[str, Any]:
    b, t = SECTION_B, SECTION_T
    area = b * b - (b - 2 * t) ** 2
    inertia = (b**4 - (b - 2 * t) ** 4) / 12.0
    return {
        "dofs_per_node": 2,
        "direction": "y",
        "nodes": [{"name": n, "x": round(i * SPAN, 6)} for i, n in enumerate(NODES)],
        "beams": [
            {"nodes": [NODES[i], NODES[i + 1]], "E": "E", "nu": 0.3, "A": area, "I": inertia,
             "rho": 7850.0, "kappa": 0.44, "name": f"deck{i + 1}"}
            for i in range(4)
        ],
        "springs": [
            {"node": n, "dof": "uy", "k": k, "name": f"spring_{n}"}
            for n, k in zip(NODES, ("kp1", "kp2", "kp3", "kp4", "kp1"), strict=True)
        ],
        "dampers": dampers,
        "frictions": frictions,
        "masses": [{"node": n, "m": ADDED_MASS} for n in NODES],
    }


def viscous_model() -> dict[str, Any]:
    """The ``[model]`` table of the viscous bridge (nine parameters, Eq. 18)."""
    dampers = [
        {"node": "A1", "dof": "rz", "c": "c1", "name": "hinge_A1"},
        {"node": "A2", "dof": "rz", "c": "c1", "name": "hinge_A2"},
        {"node": "P1", "dof": "uy", "c": "c2", "name": "damper_P1"},
        {"node": "P2", "dof": "uy", "c": "c3", "name": "damper_P2"},
        {"node": "P3", "dof": "uy", "c": "c4", "name": "damper_P3"},
    ]
    return _deck(dampers, [])


def friction_model() -> dict[str, Any]:
    """The ``[model]`` table of the frictional bridge (thirteen parameters, Eqs. 19–21)."""
    frictions = [
        {"node": "A1", "dof": "rz", "k_r": "kr1", "f_u": "fu1", "name": "hinge_A1"},
        {"node": "A2", "dof": "rz", "k_r": "kr1", "f_u": "fu1", "name": "hinge_A2"},
        {"node": "P1", "dof": "uy", "k_r": "kr2", "f_u": "fu2", "name": "damper_P1"},
        {"node": "P2", "dof": "uy", "k_r": "kr3", "f_u": "fu3", "name": "damper_P2"},
        {"node": "P3", "dof": "uy", "k_r": "kr4", "f_u": "fu4", "name": "damper_P3"},
    ]
    return _deck([], frictions)
