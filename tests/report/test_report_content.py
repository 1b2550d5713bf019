"""The report's content beyond the runs: the truth of a virtual experiment, the damping of the
best model, the channel delays, Rayleigh coefficients as parameters, 50 parameters, and the
place of the validation trials."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import RAYLEIGH_TRUTH, TINY_PNG, TRUTH, WIDE_STOREYS
from test_report import assert_printed, assert_self_contained, decode_png, number, parse

from femupdate.report.html import write_report
from femupdate.report.markup import Page
from femupdate.report.sections_model import section_validation


def shear_matrices(k: list[float], c: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """K and C of a shear building with unit masses, written out by hand."""
    n = len(k)
    stiff, damp = np.zeros((n, n)), np.zeros((n, n))
    for i in range(n):
        for matrix, v in ((stiff, k), (damp, c)):
            matrix[i, i] += v[i]
            if i + 1 < n:
                matrix[i, i] += v[i + 1]
                matrix[i, i + 1] = matrix[i + 1, i] = -v[i + 1]
    return stiff, damp


def poles(stiff: np.ndarray, damp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|λ|/2π and ζ of the underdamped modes (unit masses), ascending."""
    n = stiff.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-stiff, -damp]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    return np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)


# ----------------------------------------------------------------------------- the truth


def test_truth_of_the_virtual_experiment_beside_the_estimates(report: Path, summary: dict
                                                               ) -> None:
    page, text = parse(report)
    assert "Compared with the truth of a virtual experiment" in text
    assert "truth.json" in text
    params = {r["parameter"][0]: r for r in page.rows("parameters")}
    for name, value in TRUTH.items():
        assert number(params[name]["truth"][0]) == value
    for row in page.rows("spread"):
        name = row["parameter"][0]
        assert number(row["truth"][0]) == TRUTH[name]
        assert_printed(row["best − truth [%]"][0],
                       100.0 * (summary["best"]["params"][name] / TRUTH[name] - 1.0), 3)
    # The truth model's frequencies, from K and M written out by hand.
    stiff, _ = shear_matrices([TRUTH["k1"], TRUTH["k2"]], [0.0, 0.0])
    expected = np.sqrt(np.linalg.eigvalsh(stiff)) / (2 * np.pi)
    rows = page.rows("frequencies")
    for row, f in zip(rows, expected, strict=True):
        assert_printed(row["truth [Hz]"][0], f)
    assert "dashed: of the truth" in text  # the spectra mark them


def test_damping_ratios_of_the_best_model(report: Path, summary: dict) -> None:
    page, _ = parse(report)
    best = summary["best"]["params"]
    f, zeta = poles(*shear_matrices([best["k1"], best["k2"]], [best["c1"], best["c2"]]))
    rows = page.rows("damping")
    assert len(rows) == 2
    for row, fi, zi in zip(rows, f, zeta, strict=True):
        assert_printed(row["|λ|/2π [Hz]"][0], fi)
        assert_printed(row["ζ [%]"][0], 100.0 * zi)
        assert_printed(row["damped frequency [Hz]"][0], fi * math.sqrt(1.0 - zi**2))
    f_true, zeta_true = poles(*shear_matrices([TRUTH["k1"], TRUTH["k2"]],
                                              [TRUTH["c1"], TRUTH["c2"]]))
    for row, fi, zi in zip(rows, f_true, zeta_true, strict=True):
        assert_printed(row["truth |λ|/2π [Hz]"][0], fi)
        assert_printed(row["truth ζ [%]"][0], 100.0 * zi)
    # Storey dampers not in proportion to the storey stiffnesses: complex modes.
    assert best["c1"] / best["k1"] != best["c2"] / best["k2"]
    assert "non-proportional" in page.ids and "proportional" not in page.ids


@pytest.mark.usefixtures("tables_only")
def test_the_bridge_benchmarks_truth_comes_first(results_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(results_dir, out, ignore=shutil.ignore_patterns("report*"))
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    truth = {k: 1.1 * v for k, v in TRUTH.items()}
    summary["benchmark"] = {
        "model": "viscous", "band": "narrow", "seed": 0, "snr": 0.02, "f_target": None,
        "data": "virtual-bridge", "truth": truth, "noise_floor": 4e-4,
        "truth_frequencies_hz": [5.0, 12.0], "parameter_errors": [], "frequency_errors": [],
        "within_1_5_noise_floor": None}
    path.write_text(json.dumps(summary))
    page, text = parse(write_report(out))
    params = {r["parameter"][0]: r for r in page.rows("parameters")}
    assert_printed(params["k1"]["truth"][0], truth["k1"])
    assert [number(r["truth [Hz]"][0]) for r in page.rows("frequencies")] == [5.0, 12.0]
    assert "bridge benchmark" in text and "noise floor" in text


@pytest.mark.usefixtures("tables_only")
def test_a_truth_file_that_does_not_fit_the_case_is_not_used(results_dir: Path,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(results_dir, out, ignore=shutil.ignore_patterns("report*"))
    data = tmp_path / "other-data"
    data.mkdir()
    (data / "truth.json").write_text(json.dumps({"k1": 1.0, "kx": 2.0}))
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    summary["case"]["data"]["directory"] = str(data)
    path.write_text(json.dumps(summary))
    page, text = parse(write_report(out))
    assert "truth.json not used" in text and "kx" in text
    assert "truth" not in page.rows("parameters")[0]
    assert "truth [Hz]" not in page.rows("frequencies")[0]


# ----------------------------------------------------------------------------- Rayleigh


@pytest.fixture(scope="module")
def rayleigh_report(rayleigh_dir: Path) -> Path:
    return write_report(rayleigh_dir)


def test_rayleigh_coefficients_as_parameters(rayleigh_dir: Path, rayleigh_report: Path
                                             ) -> None:
    summary = json.loads((rayleigh_dir / "summary.json").read_text())
    page, text = parse(rayleigh_report)
    assert_self_contained(page, text)
    assert {"fit", "spectra", "parameters"} <= set(page.figures)
    assert "α = parameter alpha, β = parameter beta" in text
    params = {r["parameter"][0]: r for r in page.rows("parameters")}
    assert number(params["alpha"]["truth"][0]) == RAYLEIGH_TRUTH["alpha"]
    # Rayleigh damping is proportional: ζ_i = α / (2 ω_i) + β ω_i / 2 at the best model's ω_i.
    best = summary["best"]["params"]
    assert "proportional" in page.ids and "non-proportional" not in page.ids
    for row, f in zip(page.rows("damping"), summary["best"]["frequencies_hz"], strict=True):
        omega = 2 * np.pi * f
        assert_printed(row["|λ|/2π [Hz]"][0], f)
        assert_printed(row["ζ [%]"][0], 100.0 * (best["alpha"] / (2 * omega)
                                                  + best["beta"] * omega / 2))


def test_channel_delays_with_their_band(rayleigh_dir: Path, rayleigh_report: Path) -> None:
    summary = json.loads((rayleigh_dir / "summary.json").read_text())
    page, _ = parse(rayleigh_report)
    rows = {r["channel"][0]: r for r in page.rows("delays")}
    assert set(rows) == set(summary["delays_s"]) == {"F1.ux", "F3.ux"}
    assert_printed(rows["F3.ux"]["delay [s]"][0], 0.01)
    assert rows["F3.ux"]["how"][0] == "given in the case"
    assert_printed(rows["F1.ux"]["delay [ms]"][0], 1e3 * summary["delays_s"]["F1.ux"])
    assert "estimated" in rows["F1.ux"]["how"][0] and "1–2.5 Hz" in rows["F1.ux"]["how"][0]


def test_without_delays_the_report_says_so(report: Path) -> None:
    page, text = parse(report)
    assert "delays" not in page.tables
    assert "No channel delay was removed" in text


# ----------------------------------------------------------------------------- 50 parameters


def test_fifty_parameters(wide_dir: Path) -> None:
    summary = json.loads((wide_dir / "summary.json").read_text())
    names = list(summary["best"]["params"])
    assert len(names) == 2 * WIDE_STOREYS == 50
    page, text = parse(write_report(wide_dir))
    assert_self_contained(page, text)
    assert set(page.figures) == {"phi", "beta", "parameters", "spread", "fit", "spectra",
                                 "correlation"}
    for src in page.images:
        image = decode_png(src)
        # One panel for all the parameters, not 50: no image grows with them beyond a page.
        assert image.shape[0] <= 2000 and image.shape[1] <= 1300
    assert "all 50 in one panel" in text
    runs = page.run_parameters()  # 6 parameters to a table: 9 tables
    assert len(runs) == 2 and "run-parameters-9" in page.tables
    for row, run in zip(runs, summary["runs"], strict=True):
        for name in names:
            cell = next(v for k, v in row.items() if k.split()[0] == name)
            assert_printed(cell[0], run["params"][name])
    assert [r["parameter"][0] for r in page.rows("spread")] == names
    assert [r["parameter"][0] for r in page.rows("identifiability")] == names
    assert len(page.rows("channels-nmse")) == 5


# ----------------------------------------------------------------------------- validation


def test_validation_section() -> None:
    page = Page()
    assert section_validation({}, page) == ""  # one trial: no section
    assert not page.figures
    html = section_validation({"trial 2": {"F1": 0.01, "F2": 0.02}, "trial 3": {"F1": 0.5}},
                              page)
    from test_report import Page as Parsed

    parsed = Parsed(html)
    rows = parsed.rows("validation")
    assert [r["trial"][0] for r in rows] == ["trial 2", "trial 3"]
    assert number(rows[0]["F2: NMSE %"][0]) == 2.0 and rows[1]["F2: NMSE %"][0] == "–"
    assert page.figures == ["validation"]


def test_a_report_of_one_trial_has_no_validation_section(report: Path) -> None:
    page, text = parse(report)
    assert "section-validation" not in page.ids and "8. Validation" not in text  # one trial: none
    # the sections after it are numbered on (they jumped from 7 to 9), and the note of the
    # missing posterior shows its command as code, not in literal backticks
    assert "7. Identifiability" in text and "8. Uncertainty" in text and "9. " not in text
    html = report.read_text(encoding="utf-8")
    assert "`" not in html and "<code>femupdate posterior CASE.toml --out DIR</code>" in html


def test_one_channel_draws_one_bar_per_trial(monkeypatch: pytest.MonkeyPatch) -> None:
    # With one channel a trial's NMSE over its channels ("all") is that channel's: drawn and
    # tabulated once, not as two equal bars.
    drawn = []
    monkeypatch.setattr("femupdate.report.markup.png_bytes",
                        lambda fig: drawn.append(fig) or TINY_PNG)
    html = section_validation({"a (fit)": {"all": 0.02, "roof": 0.02},
                               "b (validate)": {"all": 0.3, "roof": 0.3}}, Page())
    from test_report import Page as Parsed

    rows = Parsed(html).rows("validation")
    assert [list(r) for r in rows] == [["trial", "roof: NMSE %"]] * 2
    (fig,) = drawn
    assert len(fig.axes[0].patches) == 2  # one bar per trial
    drawn.clear()
    section_validation({"a (fit)": {"all": 0.02, "F1": 0.01, "F2": 0.03}}, Page())
    assert len(drawn[0].axes[0].patches) == 3  # two channels: "all" is their mean, kept


def test_a_method_without_beta_trace_has_no_not_drawn_box(many_runs_dir: Path) -> None:
    page, text = parse(write_report(many_runs_dir))
    assert "multistart-lm" in text
    assert "missing" not in page.ids and "Not drawn" not in text
    assert "figure-beta" not in page.ids and "a, b and σ" not in text
    assert len(page.rows("runs")) == 25
    assert {r["stop"][1] for r in page.rows("runs")} == {"code"}


def test_a_count_of_one_is_singular() -> None:
    # Issue 33: the report's model line read '1 storeys; 1 free DOFs'.
    from femupdate.report.sections_runs import _counted

    assert _counted(1, "storeys") == "1 storey" and _counted(1, "free DOFs") == "1 free DOF"
    assert _counted(2, "storeys") == "2 storeys" and _counted(1, "masses") == "1 mass"
    assert _counted(0, "beams") == "0 beams"


def test_the_simulation_row_names_the_integrator_the_run_used() -> None:
    from types import SimpleNamespace

    from femupdate.report.sections_runs import _simulation_text

    case = SimpleNamespace(simulation_method="nonlinear")
    chosen = {"method": "implicit", "n_dof": 32, "substeps": 8, "hht_alpha": 0.0,
              "chosen": "central differences would need 9 substeps per sample"}
    ran = SimpleNamespace(case=case, summary=SimpleNamespace(simulation=chosen))
    text = _simulation_text(ran)
    assert text.startswith("implicit (HHT α = 0, 8 substeps; full model, 32 DOFs)")
    assert "would need 9 substeps" in text
    # a summary of an earlier version, without the record: the case's path
    old = SimpleNamespace(case=case, summary=SimpleNamespace(simulation=None))
    assert _simulation_text(old) == "nonlinear"
