"""
# The paper's bridge: a virtual shake-table test

The 1:50 four-span bridge of Zapico-Valle et al. (2010, §5): a steel deck on two abutments and
three piers, shaken transversely; nine parameters (Young's modulus E, the supports' springs
kp1–kp4, the dampers c1–c4) identified from the displacements of the three pier heads. Here the
records are a virtual experiment: the true model's response to an EC8-compatible
accelerogram, with 2 % noise, a sensor offset and drift added.

The full benchmark, 25 runs per method, the paper's tables:

```bash
femupdate bench bridge --model viscous --snr 0.02 --method multistart-lm,ab
femupdate bench bridge --model friction --snr 0.02 --method multistart-lm
```

This page runs 3 runs of femupdate's default search when the documentation is built;
`FEMUPDATE_DOCS_QUICK=0` runs 25.
"""

import os
import tempfile
from pathlib import Path

from femupdate.case import parse_case
from femupdate.paper.problems.bridge import bridge_case, ensure_records, truth
from femupdate.pipeline.run import run_case
from femupdate.report.figures import plot_fit

QUICK = os.environ.get("FEMUPDATE_DOCS_QUICK", "1") != "0"
RUNS = 3 if QUICK else 25

# %%
# ## The case and its records
#
# `bridge_case` gives the case as the dict a case file holds (the TOML files in
# `examples/bridge/` are the same cases); `ensure_records` writes the virtual experiment.

work = Path(tempfile.mkdtemp(prefix="femupdate-docs-bridge-"))
spec = bridge_case("viscous", "narrow", directory=str(work / "data"))
spec["search"].pop("f_target")  # noisy records: no absolute target, the runs are compared
case = parse_case(spec, source=work / "viscous-narrow.toml")
true_values = truth("viscous")
ensure_records(case, true_values, work / "data", seed=0, snr=0.02)
for p in case.parameters:
    print(f"{p.name:>4} in [{p.lower:.3g}, {p.upper:.3g}] {p.unit or ''}")

# %%
# ## The update
#
# multistart-lm: space-filling starts, a bounded Levenberg–Marquardt on the residual time
# histories, restarts ([how it works](../../multistart-lm.md)).

result = run_case(case, work / "out", runs=RUNS, workers=1)
summary = result.summary
for run in summary.runs:
    print(f"run {run.index}: NMSE {100 * run.phi:.4f} %, {run.nfev} evaluations")
print("best run against the truth:")
for name, value in summary.best.params.items():
    print(f"  {name:>4} = {value:10.4g}  ({100 * (value / true_values[name] - 1):+.2f} %)")
print("natural frequencies of the best model [Hz]:",
      ", ".join(f"{f:.3f}" for f in summary.best.frequencies_hz[:4]))

# %%
# The abutments' spring kp1 and the dampers c1 and c4 are found less well than E and kp2–kp4:
# they hardly change φ (the sensitivities in `femupdate report` say so). The fit of the pier
# displacements, measured against predicted, with the residual under each channel:

fit = result.fit
fig_fit = plot_fit(fit.t, fit.measured, fit.predicted, channels=fit.channels, unit=fit.unit,
                   title="viscous bridge, 2 % noise: the best run")
