"""
# The paper's first benchmark: a two-mode free vibration

Eight parameters of two damped modes (frequency, damping ratio, amplitude and phase of each)
identified from 5 s of free vibration sampled every 0.01 s, φ = NMSE, success when φ < 1e−10
within 50,000 evaluations (Zapico-Valle et al. 2010, §4; [the method](../../method.md)). The
paper's adaptive Beta search (AB) beside femupdate's default, multistart-lm.

The full benchmark, 100 runs per method, with the paper's Figs. 2–5:

```bash
femupdate bench dynamic --method ab --runs 100 --workers 2 --plots figs
femupdate bench dynamic --method all --runs 100
```

This page runs 10 runs per method when the documentation is built; `FEMUPDATE_DOCS_QUICK=0`
runs 100.
"""

import os

import numpy as np

from femupdate.paper.bench.dynamic import run_benchmark, run_with_history
from femupdate.paper.problems.dynamic import LOWER, PARAMETER_NAMES, TRUTH, UPPER, DynamicProblem
from femupdate.report.figures import plot_beta, plot_fit, plot_parameters, plot_phi

QUICK = os.environ.get("FEMUPDATE_DOCS_QUICK", "1") != "0"
RUNS = 10 if QUICK else 100

# %%
# ## Repeated runs, as the paper's Table 2
#
# Each run starts from its own child of one `SeedSequence` (seed 0), so the same command gives
# the same table, bit for bit.

for method in ("ab", "multistart-lm"):
    row = run_benchmark(method, runs=RUNS, seed=0)
    print(f"{method:>14}: {row['successes']}/{row['runs']} runs reach φ < 1e-10, "
          f"evaluations of the successful runs: mean {row['evals_mean']:,.0f}, "
          f"median {row['evals_median']:,.0f}")

# %%
# ## One AB run in detail (the paper's Figs. 2–5)
#
# Run 0 again with its history: φ of the best point so far, the Beta distributions' shape
# parameters and step size σ, each parameter against evaluations, and the fitted response.

outcome = run_with_history("ab", seed=0, run_index=0)
history = outcome.history
print(f"run 0: φ = {outcome.fun:.2e} after {outcome.nfev:,} evaluations")
for name, found, true in zip(PARAMETER_NAMES, outcome.x, TRUTH, strict=True):
    print(f"  {name:>6} = {found:9.5f}   (truth {true:g})")

fig_phi = plot_phi([history["fun"]], title="Fig. 2: φ of the best point so far")

# %%
fig_beta = plot_beta(history, list(PARAMETER_NAMES), title="Fig. 3: Beta parameters and σ")

# %%
fig_parameters = plot_parameters(
    history["x"], history["fun"], list(PARAMETER_NAMES), truth=TRUTH.tolist(),
    bounds=list(zip(LOWER, UPPER, strict=True)), title="Fig. 4: parameters, best so far")

# %%
problem = DynamicProblem()
predicted = problem.target - problem.residuals(outcome.x) * np.sqrt(problem.target_energy)
fig_fit = plot_fit(problem.t, problem.target, predicted, channels=["y"], unit="−",
                   nmse_percent=[100 * outcome.fun], title="Fig. 5: target and best fit")
