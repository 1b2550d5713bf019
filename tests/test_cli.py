"""The command line: help for every command, the dynamic benchmark's JSON and figures."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
from plugins import register_optimizers
from typer.testing import CliRunner

from femupdate.cli.commands import app

register_optimizers()  # the comparison optimizers (benchmarks/plugins) are tested here too

runner = CliRunner()


def _commands(typer_app) -> list[list[str]]:
    import typer.main

    group = typer.main.get_command(typer_app)
    out: list[list[str]] = []

    def walk(cmd, prefix: list[str]) -> None:
        out.append(prefix)
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, [*prefix, name])

    walk(group, [])
    return out


@pytest.mark.parametrize("words", _commands(app), ids=lambda w: " ".join(w) or "femupdate")
def test_every_command_has_help(words: list[str]) -> None:
    result = runner.invoke(app, [*words, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output


def test_bench_dynamic_json_and_plots(tmp_path: Path) -> None:
    out = tmp_path / "dyn.json"
    plots = tmp_path / "figs"
    result = runner.invoke(app, ["bench", "dynamic", "--method", "ab", "--runs", "3",
                                 "--seed", "1", "--workers", "1", "--json", str(out),
                                 "--plots", str(plots)])
    assert result.exit_code == 0, result.output
    data = json.loads(out.read_text())
    for key in ("method", "runs", "successes", "success_ratio", "evals_min", "evals_mean",
                "evals_median", "evals_max", "wall_s"):
        assert key in data
    assert data["method"] == "ab" and data["runs"] == 3
    assert len(data["per_run"]) == 3
    successes = [r for r in data["per_run"] if r["success"]]
    assert data["successes"] == len(successes)
    if successes:
        assert data["evals_min"] == min(r["nfev"] for r in successes)
    pngs = sorted(p.name for p in plots.glob("*.png"))
    assert pngs == ["fig2_phi_ab.png", "fig3_beta_ab.png", "fig4_parameters_ab.png",
                    "fig5_response_ab.png"]
    for p in plots.glob("*.png"):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_python_dash_m_entry_point() -> None:
    proc = subprocess.run([sys.executable, "-m", "femupdate", "--help"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0
    assert "bench" in proc.stdout and "demo" in proc.stdout


def test_unknown_method_is_a_clear_error(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "femupdate", "bench", "dynamic", "--method",
                           "nelder", "--runs", "1", "--workers", "1"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "nelder" in proc.stdout and "ab" in proc.stdout


def test_bench_bridge_resume_continues_the_stored_runs(tmp_path: Path) -> None:
    common = ["bench", "bridge", "--runs", "2", "--max-evals", "30", "--workers", "1",
              "--work-dir", str(tmp_path)]
    first = runner.invoke(app, [*common, "--json", str(tmp_path / "a.json")])
    assert first.exit_code == 0, first.output
    # As if killed before run 1 started: its rows gone, run 0 done.
    with sqlite3.connect(tmp_path / "out-viscous-narrow-ab" / "results.sqlite") as db:
        for table in ("evaluations", "traces", "checkpoints"):
            db.execute(f"DELETE FROM {table} WHERE run = 1")
        db.execute("UPDATE runs SET status = 'pending', nfev = 0, nit = 0, best_phi = NULL, "
                   "wall_s = 0, result = NULL WHERE run = 1")
    again = runner.invoke(app, [*common, "--resume", "--json", str(tmp_path / "b.json")])
    assert again.exit_code == 0, again.output
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("a.json", "b.json"))
    assert [(r["phi"], r["nfev"], r["x"]) for r in a["runs"]] == [
        (r["phi"], r["nfev"], r["x"]) for r in b["runs"]]
    assert b["runs"][0]["wall_s"] == a["runs"][0]["wall_s"]  # run 0 kept, not run again
    assert b["runs"][1]["wall_s"] != a["runs"][1]["wall_s"]  # run 1 run again


def test_bench_bridge_seed_seeds_the_runs_too(tmp_path: Path) -> None:
    # --seed S: the accelerogram and run i's SeedSequence (child i of SeedSequence(S)).
    result = runner.invoke(app, ["bench", "bridge", "--runs", "2", "--max-evals", "10",
                                 "--workers", "1", "--seed", "3", "--work-dir", str(tmp_path),
                                 "--json", str(tmp_path / "3.json")])
    assert result.exit_code == 0, result.output
    runs = json.loads((tmp_path / "3.json").read_text())["runs"]
    assert [r["seed"] for r in runs] == [{"entropy": 3, "spawn_key": [i]} for i in range(2)]


@pytest.mark.parametrize(("text", "expected"), [("{tolfun: 0}", "neither a JSON file"),
                                                ("[0]", "expected a JSON object")])
def test_bench_bridge_options_must_be_a_json_object(text: str, expected: str) -> None:
    from femupdate.errors import ConfigError

    result = runner.invoke(app, ["bench", "bridge", "--options", text, "--runs", "1"])
    assert isinstance(result.exception, ConfigError)
    assert "--options" in str(result.exception) and expected in str(result.exception)


def test_bench_bridge_json_has_the_summary_keys_and_the_truth(tmp_path: Path) -> None:
    out = tmp_path / "bridge.json"
    result = runner.invoke(app, ["bench", "bridge", "--model", "viscous", "--runs", "2",
                                 "--max-evals", "40", "--workers", "1", "--work-dir",
                                 str(tmp_path / "work"), "--json", str(out),
                                 "--options", '{"restarts": 2, "sigma_min": 0.28}'])
    assert result.exit_code == 0, result.output
    data = json.loads(out.read_text())
    assert {"runs", "best", "spread", "benchmark"} <= set(data)
    bench = data["benchmark"]
    assert {"truth", "noise_floor", "truth_frequencies_hz", "parameter_errors",
            "frequency_errors", "within_1_5_noise_floor"} <= set(bench)
    assert len(data["runs"]) == len(bench["frequency_errors"]) == 2
    for run, errors, freq_errors in zip(data["runs"], bench["parameter_errors"],
                                        bench["frequency_errors"], strict=True):
        assert {"seed", "success", "status", "stop", "phi", "nfev", "params",
                "at_bounds", "restarts"} <= set(run)
        assert run["nfev"] <= 40
        assert run["restarts"] == 2  # σ falls below 0.28 after a few failures
        for name, value in bench["truth"].items():
            assert errors[name] == pytest.approx(run["params"][name] / value - 1.0)
        assert len(freq_errors) == 4
    assert bench["within_1_5_noise_floor"] == sum(r["phi"] <= 1.5 * bench["noise_floor"]
                                                  for r in data["runs"])
    assert "noise floor" in result.output
    assert ("restarts (searches that converged or stalled): 4 in all, in 2 of 2 runs"
            in result.output)


def test_bench_bridge_methods_side_by_side_with_options_per_method(tmp_path: Path) -> None:
    out = tmp_path / "rows.json"
    result = runner.invoke(app, ["bench", "bridge", "--method", "ab,multistart-lm,scipy-lsq",
                                 "--runs", "1", "--max-evals", "60", "--workers", "1",
                                 "--work-dir", str(tmp_path), "--json", str(out),
                                 "--options", '{"ab": {"restarts": 3, "sigma_min": 0.28}}'],
                           terminal_width=100)
    assert result.exit_code == 0, result.output
    rows = json.loads(out.read_text())
    assert [r["method"] for r in rows] == ["ab", "multistart-lm", "scipy-lsq"]
    assert rows[0]["settings"]["options"] == {"restarts": 3, "sigma_min": 0.28}
    assert rows[1]["settings"]["options"] == {}
    assert rows[0]["runs"][0]["restarts"] == 3 and rows[2]["runs"][0]["nfev"] == 60
    table = result.output[result.output.index("methods side by side"):]
    assert all(m in table for m in ("ab", "multistart-lm", "scipy-lsq", "≤1.5× floor"))


def test_bench_dynamic_runs_the_residual_methods(tmp_path: Path) -> None:
    out = tmp_path / "rows.json"
    result = runner.invoke(app, ["bench", "dynamic", "--method", "multistart-lm,scipy-lsq",
                                 "--runs", "4", "--workers", "1", "--json", str(out)])
    assert result.exit_code == 0, result.output
    rows = json.loads(out.read_text())
    assert [r["method"] for r in rows] == ["multistart-lm", "scipy-lsq"]
    assert rows[0]["successes"] >= 3  # φ < 1e-10: the paper's target


def test_success_count_and_verdict_say_what_each_means_where_they_disagree() -> None:
    # Issue 33: the noise-free bridge printed 'successful runs 25/25' beside 'verdict: not
    # converged: … 21 different minima' with nothing to reconcile them.
    from types import SimpleNamespace

    from femupdate.cli.tables import disagreement_words

    def summary(converged: bool, target: float | None, successes: int) -> SimpleNamespace:
        return SimpleNamespace(settings={"f_target": target}, successes=successes,
                               runs=[None] * 25,
                               verdict=SimpleNamespace(converged=converged, minima=21))

    words = disagreement_words(summary(False, 1e-6, 25))  # type: ignore[arg-type]
    assert words is not None and words.startswith(
        "success and verdict differ: 25 of 25 runs reached φ ≤ f_target = 1e-06")
    assert "21 different minima" in words
    assert disagreement_words(summary(True, 1e-6, 25)) is None  # type: ignore[arg-type]
    assert disagreement_words(summary(False, None, 0)) is None  # type: ignore[arg-type]
    assert disagreement_words(summary(False, 1e-6, 0)) is None  # type: ignore[arg-type]


def test_a_rounded_zero_is_printed_without_a_sign() -> None:
    # Issue 33: `femupdate modes` printed ζ "-0.000" (a damping ratio of -1e-17).
    from femupdate.cli.tables import _unsigned_zero

    assert _unsigned_zero(f"{-1e-17:.3f}") == "0.000"
    assert _unsigned_zero(f"{-0.0004:.3f}") == "0.000"
    assert _unsigned_zero(f"{-0.25:.3f}") == "-0.250" and _unsigned_zero("1.500") == "1.500"


def test_undamped_modes_pair_with_the_damped_mode_of_nearest_frequency() -> None:
    # Issue 33: with overdamped poles (dashpots, hysteretic links) the damped list is longer,
    # and pairing by position gave ζ 0 % or 100 % against the wrong modes.
    import numpy as np

    from femupdate.cli.tables import pair_modes

    undamped = np.array([1.0, 5.0, 12.0])
    damped = np.array([0.3, 1.01, 4.9, 11.8, 40.0])  # two real poles: 0.3 and 40 Hz
    assert pair_modes(undamped, damped).tolist() == [1, 2, 3]
    assert pair_modes(undamped, damped[:2]).tolist() == [1, 0, -1]  # none left for the third
    assert pair_modes(np.array([0.0, 2.0]), np.array([0.0, 2.0])).tolist() == [0, 1]
