"""Every benchmark script under benchmarks/ runs to the end in its quick mode.

The scripts are not imported by the package, so nothing else notices when one rots (an API it
uses renamed, a keyword that became required). Each runs here as a user runs it, in a
subprocess from the repository root with ``--quick``; a script whose optional dependency is
absent is skipped with the reason.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BENCHMARKS = REPO / "benchmarks"

#: Seconds one quick run may take here: ~20 s on a quiet machine, more with numba compiling
#: its cache on a fresh checkout and with other jobs sharing the cores (dask_runs.py, 5 s at a
#: load of 3.5, passed 300 s once at a load average near 200 on 2 cores): a guard against a
#: hang, not a speed test.
TIMEOUT_S = 600


def _opensees_missing() -> str | None:
    from femupdate.errors import MissingDependencyError
    from femupdate.external.openseespy import import_opensees

    try:
        import_opensees()
    except MissingDependencyError as exc:
        return str(exc)
    return None


def _shared_data_missing() -> str | None:
    data = REPO.parent / "shared" / "data" / "minishake_1story"
    return None if data.is_dir() else f"needs the shared mini shake-table records ({data})"


def _meloland_missing() -> str | None:
    data = REPO.parent / "shared" / "data" / "cesmd_meloland"
    return None if data.is_dir() else f"needs the shared Meloland records ({data})"


def _module_missing(*modules: str) -> str | None:
    for module in modules:
        try:
            found = importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:  # its parent package is absent
            found = False
        if not found:
            return f"needs {module!r}"
    return None


#: script -> (a line its output must contain, what to check for a skip)
QUICK = {
    "abutment_line.py": ("fit excluded (Δℓ > 10)", lambda: None),
    "agreement_stop.py": ("runs needed over the 1 records", lambda: None),
    "bridge_posterior.py": ("emcee's evaluations per effective sample over the default's",
                            lambda: _module_missing("emcee", "arviz")),
    "bouc_wen_degradation.py": ("vs OpenSees", _opensees_missing),
    "building3d_scale.py": ('"reached_1e-6": 2', _opensees_missing),
    "coco_bbob.py": ("targets hit", lambda: _module_missing("cocoex", "cma")),
    "craig_bampton.py": ("full / reduced", lambda: None),
    "derived_fields.py": ("ms/point in a batch", lambda: None),
    "dask_runs.py": ("dask results identical to inline: True",
                     lambda: _module_missing("dask.distributed")),
    "eiv_curvature.py": ("magnitude-adjusted sd over 1 records", lambda: None),
    "eiv_taper.py": ("χ²(9)'s 90 % quantile in", lambda: None),
    "eiv_valley.py": ("largest gap between the product's and emcee's interval ends",
                      lambda: _module_missing("emcee", "arviz")),
    "evaluation_cost.py": ("3-DOF shear building", lambda: None),
    "external_parallel.py": ("results identical across the three: True",
                             lambda: _module_missing("dask.distributed") or _opensees_missing()),
    "frame3d_opensees.py": ("worst ", _opensees_missing),
    "frame_update.py": ("2 % noise records: 1 runs, ", _meloland_missing),
    "friction_kernels.py": ("jacobian batch, per point", lambda: None),
    "hysteresis.py": ("4. Three storeys, a slider per storey", lambda: None),
    "hysteretic_frame.py": ("cost per second of record, explicit / implicit",
                            lambda: _meloland_missing()),
    "jacobian_cost.py": ("fd err", lambda: None),
    "jenkins_reliability.py": ("verdict: ", _shared_data_missing),
    "large_case.py": ("ms per evaluation at the margin", lambda: None),
    "model_classes.py": ("β = 1 reached", _shared_data_missing),
    "multistart_budget.py": ("by phase: pool", lambda: None),
    "multisupport_evaluation.py": ("speed-up:", _meloland_missing),
    "multisupport_opensees.py": ("(target 1e-8)", _opensees_missing),
    "optimizer_overhead.py": ("scipy-lsq", lambda: None),
    "posterior.py": ("evaluations per effective sample, emcee / TMCMC",
                     lambda: _module_missing("emcee", "arviz")),
    "ripple_weighing.py": ("share holding the truth", lambda: None),
    "reduced_case.py": ("exact/reduced", lambda: None),
    "report_speed.py": ("10 parameters: report in", lambda: None),
    "scale.py": ("peak memory of a 48-parameter multistart-lm run", _opensees_missing),
    "frame3d_scale.py": ('"reached_1e-6": 2', _opensees_missing),
    "shared_record.py": ("3. multistart-lm on a 48-storey building", lambda: None),
    "simulate_kernels.py": ("friction", lambda: None),
    "surrogate_posterior.py": ("truth inside the surrogate posterior's 90 % interval",
                               lambda: _module_missing("sklearn") or _opensees_missing()),
}


#: Modules of benchmarks/ that are not benchmark scripts: a helper the scripts import, and the
#: command line with the benchmark plug-ins registered.
HELPERS = {"doc_tables.py", "with_plugins.py"}


def test_every_benchmark_has_a_quick_run() -> None:
    assert sorted(QUICK) == sorted(p.name for p in BENCHMARKS.glob("*.py")
                                   if p.name not in HELPERS)


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(QUICK))
def test_quick_mode_runs(script: str, tmp_path: Path) -> None:
    expected, missing = QUICK[script]
    reason = missing()
    if reason:
        pytest.skip(f"{script} --quick {reason}")
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(BENCHMARKS / script), "--quick"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert proc.returncode == 0, f"{script} --quick failed:\n{proc.stderr[-3000:]}"
    assert expected in proc.stdout, f"{script} --quick printed:\n{proc.stdout[-3000:]}"
    assert list(tmp_path.iterdir()) == [], f"{script} --quick wrote into the working folder"
