"""Population methods to compare with: differential evolution (scipy) and a GA (pymoo).

Both work on the unit box and leave the budget and the target to ``minimize``. Neither can be
pickled: a checkpointed ``de`` or ``ga`` run restarts from its seed instead of resuming.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from femupdate.errors import ConfigError, FemupdateError
from femupdate.optimize.base import (
    KeepsBest,
    check_batch,
    check_option_names,
    int_option,
    real_option,
)
from plugins.threaded import Abort, Handoff, ThreadedSolver


def _run_solver(handoff: Handoff, n: int, settings: dict[str, Any]) -> None:
    """Body of the worker thread: scipy's DE until it converges or is aborted."""
    from scipy.optimize import differential_evolution

    try:
        res = differential_evolution(handoff, [(0.0, 1.0)] * n, vectorized=True,
                                     updating="deferred", polish=False, **settings)
    except Abort:
        handoff.say("aborted")
    except BaseException as exc:  # handed to the main thread, raised there
        handoff.say("error", exc)
    else:
        handoff.say("done", res)


def _population(x: np.ndarray) -> np.ndarray:
    """scipy's vectorized argument (n, S) as rows (S, n)."""
    return np.array(x.T, dtype=float)


class DifferentialEvolution(ThreadedSolver):
    """scipy's ``differential_evolution`` driven as ask/tell. Not picklable.

    The solver runs in a worker thread (``vectorized=True, updating="deferred"``: one call of
    the objective per population), which hands each population to :meth:`ask` and waits for
    :meth:`tell` (:mod:`femupdate.optimize.threaded`).

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        The solver's Generator (and the Latin hypercube of the initial population) are seeded
        from it.
    popsize : int
        Individuals per generation (total, not scipy's multiplier); default 15·n as scipy's.
    tol : float
        scipy's relative convergence tolerance (std of the energies ≤ tol·|mean|); when it
        fires, ``stop()`` returns ``{"de_tol": tol}``.
    mutation : float or (float, float)
        Differential weight, or a dither range, in [0, 2].
    recombination : float
        Crossover probability in [0, 1].
    """

    name = "de"

    def __init__(self, n: int, rng: np.random.Generator, *, popsize: int, tol: float,
                 mutation: float | tuple[float, float], recombination: float) -> None:
        from scipy.stats import qmc

        self.n = n
        self.tol = tol
        solver_rng = np.random.default_rng(int(rng.integers(2**63)))
        init = qmc.LatinHypercube(d=n, rng=solver_rng).random(popsize)
        settings = {"init": init, "rng": solver_rng, "tol": tol, "atol": 0.0,
                    "mutation": mutation, "recombination": recombination,
                    "maxiter": 2**62}
        self.best_x = np.full(n, 0.5)
        self._setup(_run_solver, (n, settings), _population)

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """The values of the population from the last :meth:`ask` (failures as inf)."""
        self._answer(xs, fs, lambda values: values)

    def stop(self) -> dict[str, object]:
        """``{"de_tol": tol}`` once scipy's own convergence criterion ended the solver."""
        kind, _ = self._next_message()  # waits until the solver asks again or ends
        return {"de_tol": self.tol} if kind == "done" else {}


def _mutation_option(value: Any) -> float | tuple[float, float]:
    if isinstance(value, Sequence) and not isinstance(value, str):
        if len(value) != 2:
            raise ConfigError(
                f"option 'mutation' of method 'de' must be a number or a pair (low, high) in "
                f"[0, 2], got {value!r}"
            )
        lo = real_option("de", "mutation", value[0], 0.0, 2.0)
        hi = real_option("de", "mutation", value[1], 0.0, 2.0)
        if not lo < hi:  # type: ignore[operator]
            raise ConfigError(f"option 'mutation' of method 'de': need low < high, got {value!r}")
        return (lo, hi)  # type: ignore[return-value]
    return real_option("de", "mutation", value, 0.0, 2.0)  # type: ignore[return-value]


_DE_OPTIONS = ("popsize", "tol", "mutation", "recombination")


def make_de(n: int, rng: np.random.Generator, **options: Any) -> DifferentialEvolution:
    """Differential evolution. Options: ``popsize`` (int ≥ 5, default 15·n), ``tol`` (≥ 0,
    default 0.01), ``mutation`` (default (0.5, 1)), ``recombination`` (default 0.7)."""
    check_option_names("de", options, _DE_OPTIONS)
    popsize = int_option("de", "popsize", options.get("popsize", 15 * n), 5)
    tol = real_option("de", "tol", options.get("tol", 0.01), 0.0, high_open=True)
    mutation = _mutation_option(options.get("mutation", (0.5, 1.0)))
    recombination = real_option("de", "recombination", options.get("recombination", 0.7),
                                0.0, 1.0)
    return DifferentialEvolution(n, rng, popsize=popsize, tol=tol,  # type: ignore[arg-type]
                                 mutation=mutation, recombination=recombination)


class GeneticAlgorithm(KeepsBest):
    """pymoo's single-objective GA through its native ask/tell, on the unit box. Not picklable
    by contract (a checkpointed ``ga`` run restarts).

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        pymoo's own Generator is seeded from it. pymoo 0.6.2 draws only from that Generator
        (``Algorithm.setup`` calls ``np.random.default_rng(seed)``): numpy's global state is
        neither seeded nor used, and runs repeat bit for bit.
    popsize : int
        Population size and offspring per generation (pymoo's default 100).

    Notes
    -----
    Duplicate elimination is on (pymoo's default), so a generation may ask for fewer than
    ``popsize`` new candidates.
    """

    def __init__(self, n: int, rng: np.random.Generator, *, popsize: int) -> None:
        from pymoo.algorithms.soo.nonconvex.ga import GA
        from pymoo.core.problem import Problem
        from pymoo.core.termination import NoTermination

        self.n = n
        self.problem = Problem(n_var=n, n_obj=1, xl=np.zeros(n), xu=np.ones(n))
        self.algorithm = GA(pop_size=popsize)
        self.algorithm.setup(self.problem, termination=NoTermination(),
                             seed=int(rng.integers(2**63)), verbose=False)
        self._pop: Any = None
        self.best_x = np.full(n, 0.5)

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("the 'ga' optimizer cannot be pickled: ga runs restart from their "
                        "seed instead of resuming")

    def ask(self) -> np.ndarray:
        """The offspring to evaluate (the initial population first), shape (k, n)."""
        self._pop = self.algorithm.ask()
        return np.array(self._pop.get("X"), dtype=float)

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """Values of the last asked candidates (failures as inf)."""
        from pymoo.core.evaluator import Evaluator
        from pymoo.problems.static import StaticProblem

        xs, fs = check_batch(xs, fs, self.n)
        if self._pop is None or len(self._pop) != fs.shape[0]:
            raise FemupdateError("tell() must follow ask() with one value per asked row")
        self._keep_best(xs, fs)
        Evaluator().eval(StaticProblem(self.problem, F=fs[:, None]), self._pop)
        self.algorithm.tell(infills=self._pop)
        self._pop = None

    def stop(self) -> dict[str, object]:
        """The GA has no criterion of its own here."""
        return {}

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """No per-step trace."""
        return {}

    def close(self) -> None:
        """Nothing to release."""


def make_ga(n: int, rng: np.random.Generator, **options: Any) -> GeneticAlgorithm:
    """Genetic algorithm. Options: ``popsize`` (int ≥ 2, default 100)."""
    check_option_names("ga", options, ("popsize",))
    popsize = int_option("ga", "popsize", options.get("popsize", 100), 2)
    return GeneticAlgorithm(n, rng, popsize=popsize)
