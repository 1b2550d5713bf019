"""
# Your own model: a Python function and an OpenSeesPy script

A model femupdate does not build itself enters a case file as a Python function
(`[model.python]`: `predict(params, ag, dt)` returns the measured channels) or as an OpenSeesPy
build function (`[model.opensees]`: femupdate runs the analysis under the measured base
motion). Both run in a child process of their own. Here the paper's viscous bridge, written
both ways in `examples/bridge-external/` (`bridge_model.py`: numpy and scipy only;
`bridge_opensees.py`: `ElasticTimoshenkoBeam`, `zeroLength` springs and dampers), is updated
from the same virtual experiment as the built-in model. See
[Your own model](../../external-models.md).

The full comparison (the three models updated, about 2.5 minutes, most of it OpenSees):

```bash
python examples/bridge-external/update.py
femupdate run examples/bridge-external/opensees.toml --out results/bridge-opensees
```

When the documentation is built this page updates the Python function and evaluates the
OpenSeesPy model at the truth and at the function's result (OpenSees takes about 0.3 s an
evaluation); `FEMUPDATE_DOCS_QUICK=0` updates the OpenSeesPy model too.
"""

import os
import tempfile
from pathlib import Path

import numpy as np

from femupdate.case import load_case
from femupdate.paper.problems import bridge
from femupdate.pipeline.run import run_case, with_data_directory
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments

QUICK = os.environ.get("FEMUPDATE_DOCS_QUICK", "1") != "0"

# The build runs this file from docs/examples; the repository is two folders up.
EXAMPLES = Path.cwd().resolve().parents[1] / "examples" / "bridge-external"
work = Path(tempfile.mkdtemp(prefix="femupdate-docs-external-"))
bridge.viscous_problem(work, snr=0.0).close()  # the noise-free records, written once
true_values = bridge.truth("viscous")

# %%
# ## The Python function
#
# `python.toml` names `bridge_model.py:predict` and `bridge_model.py:frequencies`; the rest of
# the case (parameters, data, processing, search) is as for the built-in model.

case_py = with_data_directory(load_case(EXAMPLES / "python.toml"), work)
print("[model.python]", case_py.model.python.function)
result_py = run_case(case_py, runs=1, workers=1, sensitivities=False)
best_py = result_py.summary.best
print(f"φ = {best_py.phi:.3e} after {result_py.summary.runs[0].nfev} evaluations")
for name in ("E", "kp2", "kp3", "kp4"):
    print(f"  {name:>3}: {100 * (best_py.params[name] / true_values[name] - 1):+.3f} % "
          "from the truth")
result_py.problem.close()

# %%
# ## The OpenSeesPy script
#
# `opensees.toml` names `bridge_opensees.py:build`, the output nodes and DOFs, and
# `excitation = "nodal"`: OpenSees's UniformExcitation would count the beams' consistent mass
# twice, which femupdate's base-load check refuses.

case_os = with_data_directory(load_case(EXAMPLES / "opensees.toml"), work)
if QUICK:
    problem = UpdateProblem(case_os, load_experiments(case_os))
    for label, values in (("truth", true_values), ("the function's best", best_py.params)):
        phi = problem(case_os.to_search(values))
        freqs = problem.frequencies(values)[:4]
        print(f"OpenSeesPy at {label}: φ = {phi:.3e}, frequencies "
              + ", ".join(f"{f:.3f}" for f in freqs) + " Hz")
    print("the function's frequencies at its best:",
          ", ".join(f"{f:.3f}" for f in best_py.frequencies_hz[:4]), "Hz")
    problem.close()
else:
    result_os = run_case(case_os, runs=1, workers=2, sensitivities=False)
    best_os = result_os.summary.best
    print(f"OpenSeesPy: φ = {best_os.phi:.3e} after {result_os.summary.runs[0].nfev} "
          "evaluations")
    for name in ("E", "kp2", "kp3", "kp4"):
        print(f"  {name:>3}: {best_os.params[name] / best_py.params[name] - 1:+.1e} "
              "from the function's")
    print("frequencies against the function's:", np.array(best_os.frequencies_hz[:4])
          / np.array(best_py.frequencies_hz[:4]) - 1)
    result_os.problem.close()

# %%
# φ of the truth is not zero for OpenSees: its Newmark integration at ten substeps a sample has
# a period error that the exact discretisation of the function and the built-in model does not
# have (1.8e−7 against 6e−22; `examples/bridge-external/README.md` measures it).
