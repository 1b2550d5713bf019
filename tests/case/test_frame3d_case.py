"""3-D frame case files: the two-span beam with a record per support, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.case.frame3d_case import load_frame3d_case
from femupdate.errors import ConfigError, DataError, ModelError
from femupdate.paper.bench.frame3d_check import SUPPORT_GROUPS, support_records, two_span_beam
from femupdate.simulate.multisupport import multi_support_response

DT = 0.01


def _case_text(n_elements: int = 8, beam_extra: str = "", motions: str | None = None) -> str:
    nodes = "\n".join(f'[[frame3d.nodes]]\nname = "P{i}"\nx = {40.0 * i / (2 * n_elements)}'
                      for i in range(2 * n_elements + 1))
    beams = "\n".join(
        f'[[frame3d.beams]]\nnodes = ["P{i}", "P{i + 1}"]\nE = "E"\nnu = 0.2\nA = 0.5\n'
        f"Iy = 0.02\nIz = 0.04\nJ = 0.03\nrho = 2500.0\nvecxz = [0.0, 0.0, 1.0]\n{beam_extra}"
        for i in range(2 * n_elements))
    supports = (f'[[frame3d.supports]]\nnode = "P0"\n'
                f'[[frame3d.supports]]\nnode = "P{n_elements}"\ndofs = ["uy", "uz", "rx"]\n'
                f'[[frame3d.supports]]\nnode = "P{2 * n_elements}"\ndofs = ["uy", "uz", "rx"]\n')
    if motions is None:
        motions = "".join(
            f'[[ground_motion]]\nfile = "r{g}.csv"\ndt = {DT}\ncolumn = {g}\n'
            f'dofs = ["{dof}"]\n' for g, (dof,) in enumerate(SUPPORT_GROUPS))
    return (f"[values]\nE = 3e10\n{nodes}\n{beams}\n{supports}"
            f"[frame3d.rayleigh]\nalpha = 0.2\nbeta = 2e-4\n{motions}")


@pytest.fixture
def folder(tmp_path):
    acc = support_records(120, DT)
    for g in range(3):
        np.savetxt(tmp_path / f"r{g}.csv", acc, delimiter=",")
    np.savetxt(tmp_path / "short.csv", acc[:100], delimiter=",")
    return tmp_path


def test_case_gives_the_frame_and_records(folder):
    (folder / "case.toml").write_text(_case_text())
    _, _, model, groups, acc, dt = load_frame3d_case(folder / "case.toml")
    assert dt == DT and acc.shape == (120, 3)
    assert groups == [list(g) for g in SUPPORT_GROUPS]
    direct = two_span_beam().assemble()
    np.testing.assert_allclose(model.system.K, direct.system.K, rtol=1e-14, atol=1e-6)
    np.testing.assert_allclose(model.system.M, direct.system.M, rtol=1e-14, atol=1e-12)
    ours = multi_support_response(model, groups, acc, dt, method="newmark")
    theirs = multi_support_response(direct, SUPPORT_GROUPS, support_records(120, DT), DT,
                                    method="newmark")
    np.testing.assert_allclose(ours.total, theirs.total, atol=1e-12 * np.abs(theirs.total).max())


@pytest.mark.parametrize(
    ("motions", "error", "match"),
    [
        ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndofs = ["P0.uz"]\n'
         '[[ground_motion]]\nfile = "short.csv"\ndt = 0.01\ndofs = ["P8.uz"]\n',
         DataError, "differ in length"),
        ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndofs = ["P0.uz"]\n'
         '[[ground_motion]]\nfile = "r1.csv"\ndt = 0.02\ndofs = ["P8.uz"]\n',
         DataError, "differ in rate"),
        ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndofs = ["P3.uz"]\n',
         ConfigError, r"ground_motion\[0\]\.dofs: 'P3\.uz' is not a support DOF"),
        ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndofs = ["P0.uz"]\n'
         '[[ground_motion]]\nfile = "r1.csv"\ndt = 0.01\ndofs = ["P0.uz"]\n',
         ConfigError, "already follows"),
        ('[[ground_motion]]\nfile = "none.csv"\ndt = 0.01\ndofs = ["P0.uz"]\n',
         DataError, "file not found"),
        ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ncolumn = 7\ndofs = ["P0.uz"]\n',
         DataError, "column = 7"),
    ],
)
def test_bad_ground_motions_are_one_line(folder, motions, error, match):
    (folder / "case.toml").write_text(_case_text(motions=motions))
    with pytest.raises(error, match=match) as err:
        load_frame3d_case(folder / "case.toml")
    assert "\n" not in str(err.value)
    assert "case.toml" in str(err.value)


def test_bad_field_names_file_and_field(folder):
    (folder / "case.toml").write_text(_case_text(beam_extra="kappa_y = -1.0\n"))
    with pytest.raises(ConfigError, match=r"case\.toml: frame3d\.beams\.0\.kappa_y") as err:
        load_frame3d_case(folder / "case.toml")
    assert len(str(err.value).splitlines()) == 16  # one line per beam


def test_mechanism_in_a_case_names_the_file_and_dofs(folder):
    text = _case_text().replace('[[frame3d.supports]]\nnode = "P0"\n',
                                '[[frame3d.supports]]\nnode = "P0"\ndofs = ["uy", "uz", "rx"]\n')
    (folder / "case.toml").write_text(text)
    match = r"case\.toml: frame3d: .*mechanism.*P0\.ux.*P16\.ux"
    with pytest.raises(ModelError, match=match) as err:
        load_frame3d_case(folder / "case.toml")
    assert "\n" not in str(err.value)


def test_cli_simulates_and_writes(folder):
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    (folder / "case.toml").write_text(_case_text())
    result = CliRunner().invoke(app, ["frame3d", str(folder / "case.toml"), "--out",
                                      str(folder / "out"), "--method", "newmark"])
    assert result.exit_code == 0, result.output
    assert "3 record(s) of 120 samples" in result.output
    total = np.loadtxt(folder / "out" / "total_displacement.csv", delimiter=",", skiprows=1)
    assert total.shape == (120, 1 + 90)  # 17 nodes × 6 - 12 support DOFs
    _, _, model, groups, acc, dt = load_frame3d_case(folder / "case.toml")
    expected = multi_support_response(model, groups, acc, dt, method="newmark").total
    np.testing.assert_allclose(total[:, 1:], expected, rtol=1e-15,
                               atol=1e-15 * np.abs(expected).max())


def test_a_property_may_be_an_expression_of_the_values(folder):
    (folder / "case.toml").write_text(_case_text())
    plain = load_frame3d_case(folder / "case.toml")[2]
    text = _case_text().replace('E = 3e10\n', 'E0 = 1.5e10\n', 1).replace('E = "E"',
                                                                           'E = "2 * E0"')
    (folder / "case.toml").write_text(text)
    derived = load_frame3d_case(folder / "case.toml")[2]
    assert np.array_equal(derived.system.K, plain.system.K)
    (folder / "case.toml").write_text(text.replace('"2 * E0"', '"2 * E1"'))
    with pytest.raises(ConfigError, match=r"frame3d\.beams\[0\]\.E: '2 \* E1' names 'E1', "
                       r"which has no value \(allowed: names given in \[values\]: E0\)"):
        load_frame3d_case(folder / "case.toml")


def test_direction_and_angle_move_every_support(folder):
    """``direction``: every support's DOF along it follows the record; ``angle``: the record's
    x and y components (cos θ, sin θ) move every support along x and along y."""
    motions = ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndirection = "z"\n'
               '[[ground_motion]]\nfile = "r1.csv"\ndt = 0.01\ncolumn = 1\nangle = 30.0\n')
    (folder / "case.toml").write_text(_case_text(motions=motions))
    _, _, _, groups, acc, _ = load_frame3d_case(folder / "case.toml")
    assert groups == [["P0.uz", "P8.uz", "P16.uz"], ["P0.ux"], ["P0.uy", "P8.uy", "P16.uy"]]
    record = support_records(120, DT)[:, 1]
    np.testing.assert_allclose(acc[:, 1], record * np.cos(np.pi / 6), rtol=1e-15)
    np.testing.assert_allclose(acc[:, 2], record * 0.5, rtol=1e-15)


@pytest.mark.parametrize(("motions", "match"), [
    ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndirection = "y"\ndofs = ["P0.uy"]\n',
     r"ground_motion\[0\]: dofs and direction of dofs, direction, angle given"),
    ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\nangle = 360.0\n',
     r"ground_motion\.0\.angle"),
    ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndirection = "y"\n'
     '[[ground_motion]]\nfile = "r1.csv"\ndt = 0.01\ndofs = ["P8.uy"]\n',
     r"ground_motion\[1\]\.dofs: 'P8\.uy' already follows ground_motion\[0\]"),
    ('[[ground_motion]]\nfile = "r0.csv"\ndt = 0.01\ndirection = "y"\n'
     '[[ground_motion]]\nfile = "r1.csv"\ndt = 0.01\nangle = 45.0\n',
     r"ground_motion\[1\]\.angle: 'P0\.uy' already follows ground_motion\[0\]"),
])
def test_bad_uniform_ground_motions_are_one_line(folder, motions, match):
    (folder / "case.toml").write_text(_case_text(motions=motions))
    with pytest.raises(ConfigError, match=match) as err:
        load_frame3d_case(folder / "case.toml")
    assert len(str(err.value).splitlines()) == 1 and "case.toml" in str(err.value)
