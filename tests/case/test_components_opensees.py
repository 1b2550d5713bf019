"""Two components of base motion on a hysteretic 3-D frame case against OpenSeesPy: the case's
implicit integrator (Newmark, Newton on the Bouc–Wen links) and OpenSees's Newmark with two
``UniformExcitation`` patterns (x and y) on the same frame, at the same step. The beams are
massless (the mass sits on the nodes): OpenSees's ``UniformExcitation`` would count a beam's
own mass twice (docs/frames-3d.md)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from test_components_case import (
    COLUMNS,
    COMPONENTS,
    DT,
    ECCENTRIC,
    FIXED,
    GIRDERS,
    K_PARAMETER,
    LINKED,
    _nmse,
    _record,
)
from test_components_case import FRAME as _FRAME

from femupdate.case import parse_case
from femupdate.errors import MissingDependencyError
from femupdate.problem.case_model import CaseModel

E, NU, AREA, INERTIA, TORSION, KAPPA = 2.1e11, 0.3, 5.4e-3, 2.5e-5, 3.1e-7, 5.0 / 6.0
MASS, ROTARY, CORNER = 1000.0, 10.0, 3000.0
FOOT = 50.0  # on the feet's ux, uy: the links' DOFs need inertia when the beams have none
FEET = "".join(f'\n    {{ node = "{a}", m = {FOOT}, dofs = ["ux", "uy"] }},' for a, _ in COLUMNS)
LINK = {"k": 2e7, "alpha": 0.1, "beta": 375.0, "gamma": 125.0}
SOFT = 1e3  # the soft spring beside each link
ALPHA = 0.2  # Rayleigh, on the mass only: both codes alike
XYZ = {"A0": (0.0, 0.0, 0.0), "B0": (4.0, 0.0, 0.0), "C0": (4.0, 4.0, 0.0),
       "D0": (0.0, 4.0, 0.0), "A1": (0.0, 0.0, 3.0), "B1": (4.0, 0.0, 3.0),
       "C1": (4.0, 4.0, 3.0), "D1": (0.0, 4.0, 3.0)}


def _case(nonlinear: bool, substeps: int):
    section = f'E = "E", nu = {NU}, A = {AREA}, Iy = {INERTIA}, Iz = {INERTIA}, J = {TORSION}'
    beams = ",\n".join(
        [f'    {{ nodes = ["{a}", "{b}"], {section}, vecxz = [1.0, 0.0, 0.0] }}'
         for a, b in COLUMNS]
        + [f'    {{ nodes = ["{a}", "{b}"], {section}, vecxz = [0.0, 0.0, 1.0] }}'
           for a, b in GIRDERS])
    text = _FRAME.format(beams=beams, feet=LINKED if nonlinear else FIXED,
                         extra=ECCENTRIC + FEET if nonlinear else "",
                         parameters=K_PARAMETER if nonlinear else "", inputs=COMPONENTS,
                         simulation=f'[simulation]\nmethod = "implicit"\n[preprocess]\n'
                                    f'substeps = {substeps}')
    text = text.replace("rayleigh = { alpha = 0.2, beta = 1e-4 }",
                        f"rayleigh = {{ alpha = {ALPHA} }}")
    return parse_case(tomllib.loads(text))


def _opensees(ops, ag: np.ndarray, nonlinear: bool, substeps: int) -> np.ndarray:
    """Relative displacements (ux, uy) of the roof corner C1 by OpenSees."""
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    tags = {name: i + 1 for i, name in enumerate(XYZ)}
    for name, xyz in XYZ.items():
        ops.node(tags[name], *xyz)
    for name in ("A1", "B1", "C1", "D1"):
        m = MASS + (CORNER if nonlinear and name == "C1" else 0.0)
        ops.mass(tags[name], m, m, m, ROTARY, ROTARY, ROTARY)
    shear = E / (2.0 * (1.0 + NU))
    for e, (a, b) in enumerate(COLUMNS + GIRDERS, start=1):
        ops.geomTransf("Linear", e, *((1.0, 0.0, 0.0) if (a, b) in COLUMNS else (0.0, 0.0, 1.0)))
        ops.element("ElasticTimoshenkoBeam", e, tags[a], tags[b], E, shear, AREA, TORSION,
                    INERTIA, INERTIA, KAPPA * AREA, KAPPA * AREA, e)
    feet = [a for a, _ in COLUMNS]
    if not nonlinear:
        for foot in feet:
            ops.fix(tags[foot], 1, 1, 1, 1, 1, 1)
    else:
        ops.uniaxialMaterial("Elastic", 1, SOFT)
        # argument order: alpha ko n gamma beta Ao deltaA deltaNu deltaEta
        ops.uniaxialMaterial("BoucWen", 2, LINK["alpha"], LINK["k"], 1.0, LINK["gamma"],
                             LINK["beta"], 1.0, 0.0, 0.0, 0.0)
        for i, foot in enumerate(feet):
            ground = 100 + i
            ops.node(ground, *XYZ[foot])
            ops.fix(ground, 1, 1, 1, 1, 1, 1)
            ops.fix(tags[foot], 0, 0, 1, 1, 1, 1)
            ops.mass(tags[foot], FOOT, FOOT, 0.0, 0.0, 0.0, 0.0)
            for d in (1, 2):
                ops.element("zeroLength", 1000 + 10 * i + d, ground, tags[foot], "-mat", 2,
                            "-dir", d)
                ops.element("zeroLength", 2000 + 10 * i + d, ground, tags[foot], "-mat", 1,
                            "-dir", d)
    ops.rayleigh(ALPHA, 0.0, 0.0, 0.0)
    for d in (1, 2):
        ops.timeSeries("Path", d, "-dt", DT, "-values", *ag[:, d - 1].tolist())
        ops.pattern("UniformExcitation", d, d, "-accel", d)
    ops.constraints("Plain")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    ops.test("NormDispIncr", 1e-14, 50)
    ops.algorithm("Newton")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    out = np.zeros((ag.shape[0], 2))
    for k in range(1, ag.shape[0]):
        assert ops.analyze(substeps, DT / substeps) == 0
        out[k] = ops.nodeDisp(tags["C1"], 1), ops.nodeDisp(tags["C1"], 2)
    ops.wipe()
    return out


@pytest.mark.slow
@pytest.mark.parametrize(("nonlinear", "substeps", "limit"), [(False, 4, 1e-12),
                                                              (True, 5, 1e-4), (True, 20, 1e-5)])
def test_two_components_agree_with_opensees(nonlinear, substeps, limit):
    """Linear: the same Newmark scheme, equal to rounding. Bouc–Wen links: OpenSees updates z
    by backward Euler (first order in the step), femupdate by Runge–Kutta over the increment:
    the difference shrinks with the step."""
    try:
        from femupdate.external.openseespy import import_opensees

        ops = import_opensees()
    except MissingDependencyError:
        pytest.skip("openseespy is not installed (pip install 'femupdate[opensees]')")
    values = {"E": E, "k": LINK["k"]} if nonlinear else {"E": E}
    ag = np.column_stack([_record(200, seed=4), _record(200, seed=5)]) * 4.0
    ours = CaseModel(_case(nonlinear, substeps)).simulate(values, ag, DT).displacement
    peer = _opensees(ops, ag, nonlinear, substeps)
    assert np.abs(peer).max() > 1e-3
    nmse = _nmse(ours, peer)
    print(f"nonlinear={nonlinear} substeps={substeps}: NMSE {nmse:.3g}")
    assert nmse <= limit, f"NMSE {nmse:.3g} against OpenSees"
