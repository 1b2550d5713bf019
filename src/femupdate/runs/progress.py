"""Progress of a set of runs: a rich progress bar and/or a JSON-lines log.

Given each run's budget, the bar moves with the evaluations: its length is the evaluation budget
of the set (runs × ``max_evals``; a run that ends early, at its target or by a stopping
criterion, completes its share at once), so it advances with every chunk, and the time left is
estimated from the pace of this session. Beside it: runs finished out of the total, the best φ so
far over all runs (a sampler's: the lowest tempering exponent β of its runs), the evaluations
done, the time elapsed and left (fitting 80 columns). Without a
budget it counts finished runs and shows the evaluations per second. The log (``log_json``) gets
one JSON object per line and event: ``start``, ``chunk`` (a run advanced), ``run`` (a run
finished), ``not_needed`` (the first runs agreed: ``runs_needed`` of ``runs``), ``end``; each
with ``time`` (Unix seconds) and ``elapsed`` (seconds since start), and where it applies
``run``, ``nfev``, ``best_phi`` (null when not finite) and ``status``. The file is appended to,
so a resumed set continues the same log.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.text import Text


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


class RunProgress:
    """Reports a set of runs; a context manager.

    Parameters
    ----------
    total_runs : int
        Runs in the set (including those already done in an earlier session).
    label : str
        Shown before the bar, e.g. ``"ab on the bridge"``.
    quiet : bool
        No bar (the log, if any, is still written).
    log_json : path or None
        Append one JSON line per event to this file.
    console : rich.console.Console or None
        Where the bar goes (default: standard error).
    max_evals : int or None
        The budget of each run: the bar then measures evaluations (of ``total_runs ×
        max_evals``) and shows the time left; None: it measures finished runs.
    """

    def __init__(self, total_runs: int, *, label: str = "runs", quiet: bool = False,
                 log_json: str | os.PathLike[str] | None = None,
                 console: Console | None = None, max_evals: int | None = None) -> None:
        self.total_runs = total_runs
        self.max_evals = max_evals
        self.budget_done = 0  # evaluations, plus the unused budget of finished runs
        self.label = label
        self.quiet = quiet
        self.log_path = None if log_json is None else Path(log_json)
        self.console = console
        self.best_phi = math.inf
        self.runs_done = 0
        self.evals = 0  # over all runs, including earlier sessions
        self.session_evals = 0
        self._t0 = time.perf_counter()
        self._log: IO[str] | None = None
        self._bar: Progress | None = None
        self._task: TaskID | None = None
        self._stages: dict[int, tuple[float, float]] = {}  # run → (last stage, acceptance)
        self._beta: dict[int, float] = {}  # a sampler's runs: run → its tempering exponent
        self.needed: int | None = None  # runs needed, once the first ones agreed

    # -- lifecycle ---------------------------------------------------------------------------

    def __enter__(self) -> RunProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self, *, runs_done: int = 0, evals: int = 0, best_phi: float = math.inf,
              budget_done: int | None = None, **extra: Any) -> None:
        """Begin (with what earlier sessions already did, when resuming).

        ``budget_done``: the share of the budget used already (evaluations of unfinished runs
        plus ``max_evals`` per finished run); default ``evals``.
        """
        self.runs_done = runs_done
        self.evals = evals
        self.best_phi = best_phi
        self.budget_done = evals if budget_done is None else budget_done
        self._t0 = time.perf_counter()
        if self.log_path is not None:
            self.log_path.parent.mkdir(parents=True, exist_ok=True)
            self._log = self.log_path.open("a", encoding="utf-8")
        self._write("start", runs=self.total_runs, runs_done=runs_done, nfev=evals,
                    best_phi=_finite_or_none(best_phi), **extra)
        if not self.quiet:
            console = self.console or Console(stderr=True)
            by_evals = self.max_evals is not None
            if by_evals:
                # Compact, to fit 80 columns: the label goes on its own line above the bar, and
                # the pace shows as the time left (the rate is in the log).
                runs = "1 run" if self.total_runs == 1 else f"{self.total_runs} runs"
                console.print(Text(f"{self.label}: {runs} of at most "
                                   f"{self.max_evals:,} evaluations"))
                columns: tuple[ProgressColumn, ...] = (
                    BarColumn(bar_width=10),
                    TextColumn("{task.fields[runs]} runs · {task.fields[state]} · "
                               "{task.fields[evals]} evals"),
                    TimeElapsedColumn(),
                    TimeRemainingColumn(),
                    TextColumn("left"),
                )
            else:
                columns = (
                    TextColumn("{task.description}"),
                    BarColumn(),
                    MofNCompleteColumn(),
                    TextColumn("runs · {task.fields[state]} · {task.fields[evals]} evals "
                               "· {task.fields[rate]} evals/s"),
                    TimeElapsedColumn(),
                )
            self._bar = Progress(*columns, console=console)
            self._bar.start()
            total, completed = self._extent()
            self._task = self._bar.add_task(self.label, total=total, completed=completed,
                                            **self._fields())

    def close(self) -> None:
        """Stop the bar, log ``end`` and close the log (idempotent)."""
        if self._bar is not None:
            self._refresh()
            self._bar.stop()
            self._bar = None
        if self._log is not None:
            self._write("end", runs_done=self.runs_done, nfev=self.evals,
                        best_phi=_finite_or_none(self.best_phi),
                        session_evals=self.session_evals, rate=self.rate())
            self._log.close()
            self._log = None

    # -- events ------------------------------------------------------------------------------

    def chunk(self, run: int, nfev: int, best_phi: float, new_evals: int) -> None:
        """Run ``run`` advanced by ``new_evals`` to ``nfev`` evaluations, best φ ``best_phi``."""
        self.evals += new_evals
        self.session_evals += new_evals
        self.budget_done += new_evals
        self.best_phi = min(self.best_phi, best_phi)
        self._write("chunk", run=run, nfev=nfev, best_phi=_finite_or_none(best_phi))
        self._refresh()

    def stages(self, run: int, trace: Mapping[str, np.ndarray]) -> None:
        """A sampler's stages from its trace rows of a chunk (``stage``, ``beta``,
        ``acceptance``, ``weights_ess``: TMCMC's): a line and a ``stage`` log event as each
        new stage begins, with the tempering exponent, the effective sample size of its
        weights and the acceptance rate of the previous stage's moves. Nothing for traces
        without stages (the searches)."""
        stage = trace.get("stage")
        if stage is None or not len(stage):
            return
        seen = self._stages.get(run, (-1.0, math.nan))
        for i, k in enumerate(stage.tolist()):
            previous_acceptance = float(trace["acceptance"][i - 1]) if i else seen[1]
            if k != seen[0]:
                beta, ess = float(trace["beta"][i]), float(trace["weights_ess"][i])
                self._write("stage", run=run, stage=int(k), beta=beta, weights_ess=ess,
                            acceptance=_finite_or_none(previous_acceptance))
                if self._bar is not None and k > 0:
                    self._bar.console.print(Text(stage_line(run, int(k), beta, ess,
                                                            previous_acceptance)))
            seen = (k, float(trace["acceptance"][i]))
        self._stages[run] = seen
        self._beta[run] = float(trace["beta"][-1])
        self._refresh()

    def run_done(self, run: int, nfev: int, best_phi: float, status: str) -> None:
        """Run ``run`` finished (after its last :meth:`chunk`)."""
        self.runs_done += 1
        if self.max_evals is not None:  # its unused budget is done too
            self.budget_done += max(self.max_evals - nfev, 0)
        self.best_phi = min(self.best_phi, best_phi)
        self._write("run", run=run, nfev=nfev, best_phi=_finite_or_none(best_phi),
                    status=status)
        self._refresh()

    def not_needed(self, needed: int, agreeing: int) -> None:
        """Only runs 0 … ``needed`` − 1 are needed: ``agreeing`` of them ended at the same best
        φ (``[search] agree``). The bar completes, a line says so, and the log gets a
        ``not_needed`` event."""
        self.needed = needed
        self._write("not_needed", runs_needed=needed, runs=self.total_runs,
                    agreeing=agreeing)
        if self._bar is not None:
            who = "they" if agreeing == needed else f"{agreeing} of them"
            self._bar.console.print(Text(
                f"{needed} of {self.total_runs} runs were needed: {who} ended at the same "
                f"best φ; the others are not run"))
        self._refresh()

    # -- internals ---------------------------------------------------------------------------

    def rate(self) -> float:
        """Evaluations per second in this session."""
        elapsed = time.perf_counter() - self._t0
        return self.session_evals / elapsed if elapsed > 0 else 0.0

    def _extent(self) -> tuple[int, int]:
        """(total, completed) of the bar: evaluations of the budget, or runs."""
        if self.needed is not None:  # the rest is not needed: the bar is full
            done = self.budget_done if self.max_evals is not None else self.needed
            return max(done, 1), max(done, 1)
        if self.max_evals is None:
            return self.total_runs, self.runs_done
        return self.total_runs * self.max_evals, self.budget_done

    def _fields(self) -> dict[str, str]:
        best = "–" if not math.isfinite(self.best_phi) else f"{self.best_phi:.3e}"
        # a sampler's bar shows its own state, the tempering of its runs, not a φ
        state = (f"lowest β {min(self._beta.values()):.4g}" if self._beta
                 else f"best φ {best}")
        return {"best": best, "state": state, "evals": f"{self.evals:,}",
                "rate": f"{self.rate():,.0f}",
                "runs": (f"{self.runs_done}/{self.total_runs}" if self.needed is None else
                         f"{self.needed} of {self.total_runs}")}

    def _refresh(self) -> None:
        if self._bar is not None and self._task is not None:
            total, completed = self._extent()
            self._bar.update(self._task, total=total, completed=completed, **self._fields())

    def _write(self, event: str, **fields: Any) -> None:
        if self._log is None:
            return
        line = {"event": event, "time": time.time(),
                "elapsed": time.perf_counter() - self._t0, **fields}
        self._log.write(json.dumps(line, allow_nan=False) + "\n")
        self._log.flush()


def stage_line(run: int, stage: int, beta: float, ess: float, acceptance: float) -> str:
    """A sampler's line as its run ``run`` begins stage ``stage`` (under 80 columns): the
    tempering exponent, the effective samples of the stage's weights and the acceptance of
    the previous stage's moves (left out when there were none)."""
    acc = "" if not math.isfinite(acceptance) else f", previous acceptance {acceptance:.2f}"
    return f"run {run}: stage {stage}, β = {beta:.4g}, weights' ESS {ess:,.0f}{acc}"
