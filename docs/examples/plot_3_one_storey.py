"""
# A real structure: a one-storey specimen, fitted, validated, reported

A one-storey steel-strip model on a mini shake table, shaken six times on one day (El Centro
×2, Northridge ×2, a 2 Hz sine ×2), its table and roof accelerations recorded by two IMUs at
120 Hz (data: Chern & Perez, the mdof project, BSD-2-Clause). The linear storey (stiffness k1,
damper c1; the mass is known) is fitted to El Centro trial 1 and then predicts the five trials
it was not fitted to. `examples/minishake-1story/trials.toml` is the case file; its comments
give the reasons for each setting.

The same from the command line, and the study that compares three model forms:

```bash
femupdate run examples/minishake-1story/trials.toml --out results/trials
femupdate validate examples/minishake-1story/trials.toml --params results/trials/summary.json
femupdate report results/trials
python examples/minishake-1story/study.py
```

The records are not part of femupdate: they are read from the shared data folder beside the
repository (`../shared/data`, or `$FEMUPDATE_DATA`). Without them this page says so and skips
the rest. It runs 2 runs when the documentation is built; `FEMUPDATE_DOCS_QUICK=0` runs the
case's 4.
"""

import os
import tempfile
from pathlib import Path

from femupdate.case import load_case
from femupdate.pipeline.run import run_case, validate_case, with_data_directory
from femupdate.report.figures import plot_fit
from femupdate.report.html import write_report

QUICK = os.environ.get("FEMUPDATE_DOCS_QUICK", "1") != "0"
RUNS = 2 if QUICK else None  # None: the case's [search] runs

# The build runs this file from docs/examples; the repository is two folders up.
REPO = Path.cwd().resolve().parents[1]
CASE_FILE = REPO / "examples" / "minishake-1story" / "trials.toml"
data_root = Path(os.environ.get("FEMUPDATE_DATA", REPO.parent / "shared" / "data"))
data_dir = data_root / "minishake_1story"
have_data = data_dir.is_dir()
if not have_data:
    print(f"SKIPPED: the records are not in {data_dir} (set FEMUPDATE_DATA to the shared data "
          "folder): nothing below runs")

# %%
# ## Fit El Centro 1
#
# The case holds all six trials; five have `role = "validate"` and are only predicted.

if have_data:
    case = with_data_directory(load_case(CASE_FILE), data_dir)
    out = Path(tempfile.mkdtemp(prefix="femupdate-docs-one-storey-"))
    result = run_case(case, out, runs=RUNS, workers=1)
    best = result.summary.best
    print(f"best: NMSE {100 * best.phi:.2f} %, " + ", ".join(
        f"{name} = {value:.4g}" for name, value in best.params.items()))
    print(f"first natural frequency: {best.frequencies_hz[0]:.2f} Hz")

# %%
# ## Validate on every trial
#
# The fitted parameters, fixed, simulated on each trial over its whole record: what
# `femupdate validate` prints.

if have_data:
    validation = validate_case(case, best.params)
    for trial in validation.trials:
        print(f"{trial.name:>14} ({trial.role:>8}): NMSE {100 * trial.phi:6.2f} %")
    fits = {f.trial: f for f in validation.fits}
    sine = fits["sine-1"]
    fig_sine = plot_fit(sine.t, sine.measured, sine.predicted, channels=sine.channels,
                        unit=sine.unit, title="sine-1, predicted (not fitted)")

# %%
# The linear storey fitted to an earthquake record over-predicts the sine trials' response:
# its damping is too low for the table's large motion there. `study.py` fits a storey whose
# damping rises with the table's motion, which predicts every trial within 40 %.
#
# ## The report
#
# `femupdate report DIR` writes one self-contained HTML file, figures embedded.

if have_data:
    report = write_report(out)
    print(f"{report.name}: {report.stat().st_size / 1e6:.1f} MB")
