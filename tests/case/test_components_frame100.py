"""A case file of a 3-D frame on 100 zero-length Bouc–Wen links under both horizontal
free-field components of a recorded earthquake (Meloland 1979, read by the network reader):
the implicit and explicit integrators of the case path agree.

The frame is benchmarks/hysteretic_frame.py's (5 × 5 columns, two storeys, rigid floors, each
column foot on four links: ux, uy, rx, ry), written as a case file, with a soft spring beside
each link (the case's mechanism check counts no hysteretic stiffness)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.problem.case_model import CaseModel

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
EVENT = DATA / "cesmd_meloland" / "imperialvalley1979_ce01336.zip"
NX = NY = 5
STOREYS = 2
E, AREA, INERTIA, TORSION, RHO, HEIGHT, BAY = 2.1e11, 1e-2, 1e-4, 2e-4, 7850.0, 3.5, 5.0
STIFF = 1e3  # each link, times the column's own stiffness


def frame_case(method: str, substeps: int) -> str:
    """The TOML text of the frame (module docstring)."""
    section = (f"E = {E}, nu = 0.3, A = {AREA}, Iy = {INERTIA}, Iz = {INERTIA}, "
               f"J = {TORSION}, rho = {RHO}")
    nodes, beams, masses, supports, links, springs, floors = [], [], [], [], [], [], []
    k_shear = STIFF * 12 * E * INERTIA / HEIGHT**3
    k_rot = STIFF * 4 * E * INERTIA / HEIGHT
    for i in range(NX):
        for j in range(NY):
            for f in range(STOREYS + 1):
                nodes.append(f'{{ name = "N{i}{j}{f}", x = {i * BAY}, y = {j * BAY}, '
                             f"z = {f * HEIGHT} }}")
            supports.append(f'{{ node = "N{i}{j}0", dofs = ["uz", "rz"] }}')
            for dof, k, z_u in (("ux", k_shear, 3e-6), ("uy", k_shear, 3e-6),
                                ("rx", k_rot, 1.5e-6), ("ry", k_rot, 1.5e-6)):
                links.append(f'{{ node = "N{i}{j}0", dof = "{dof}", k = {k}, alpha = 0.1, '
                             f"beta = {0.75 / z_u}, gamma = {0.25 / z_u} }}")
                springs.append(f'{{ node = "N{i}{j}0", dof = "{dof}", k = 1e3 }}')
            for f in range(STOREYS):
                beams.append(f'{{ nodes = ["N{i}{j}{f}", "N{i}{j}{f + 1}"], {section}, '
                             "vecxz = [1.0, 0.0, 0.0] }")
    for f in range(1, STOREYS + 1):
        for i in range(NX):
            for j in range(NY):
                for a, b in (((i, j), (i + 1, j)), ((i, j), (i, j + 1))):
                    if b[0] < NX and b[1] < NY:
                        beams.append(f'{{ nodes = ["N{a[0]}{a[1]}{f}", "N{b[0]}{b[1]}{f}"], '
                                     f"{section}, vecxz = [0.0, 0.0, 1.0] }}")
                masses.append(f'{{ node = "N{i}{j}{f}", m = 4000.0, dofs = ["ux", "uy"] }}')
        others = ", ".join(f'"N{i}{j}{f}"' for i in range(NX) for j in range(NY)
                           if (i, j) != (0, 0))
        floors.append(f'{{ master = "N00{f}", nodes = [{others}] }}')
    lists = {"nodes": nodes, "beams": beams, "masses": masses, "supports": supports,
             "bouc_wen": links, "springs": springs, "diaphragms": floors}
    model = "\n".join(f"{key} = [\n" + ",\n".join(f"    {v}" for v in values) + ",\n]"
                      for key, values in lists.items())
    return f"""\
[case]
name = "frame-100-links"

[model]
dofs_per_node = 6
{model}

[data]
format = "csv"
time_column = "t"
[[data.components]]
direction = "x"
file = "base.csv"
column = "ax"
[[data.components]]
direction = "y"
file = "base.csv"
column = "ay"
[[data.outputs]]
file = "roof.csv"
column = "x"
node = "N002"
dof = "ux"
[[data.outputs]]
file = "roof.csv"
column = "y"
node = "N002"
dof = "uy"
[[data.outputs]]
file = "roof.csv"
column = "x1"
node = "N001"
dof = "ux"

[simulation]
method = "{method}"
[preprocess]
substeps = {substeps}
"""


@pytest.mark.slow
def test_frame_on_100_links_two_recorded_components_implicit_against_explicit():
    if not EVENT.exists():
        pytest.skip(f"the Meloland records are not in {EVENT.parent}")
    from femupdate.data.network import read_network_records
    from femupdate.simulate.implicit import explicit_stable_step

    x, y = read_network_records(EVENT, [15, 24])  # free field, 360° and 270°
    first, n = round(3.0 / x.dt), round(0.3 / x.dt) + 1
    ag = np.column_stack([x.acceleration[first:first + n], y.acceleration[first:first + n]])
    implicit = CaseModel(parse_case(tomllib.loads(frame_case("implicit", 5))))
    structure = implicit.structure
    assert structure.assemble({}, direction="x").n_bouc_wen == 100
    substeps = int(np.ceil(x.dt / (0.95 * explicit_stable_step(implicit.system({})))))
    explicit = CaseModel(parse_case(tomllib.loads(frame_case("nonlinear", substeps))))
    got = implicit.simulate({}, ag, x.dt)
    ref = explicit.simulate({}, ag, x.dt)
    nmse = float(np.sum((got.displacement - ref.displacement) ** 2)
                 / np.sum(ref.displacement**2))
    print(f"{structure.n_dof} DOFs, 100 links; explicit {substeps} steps per sample; "
          f"implicit (5) against explicit: NMSE {nmse:.2g}")
    assert np.abs(ref.displacement).max() > 1e-6
    assert nmse <= 1e-4
