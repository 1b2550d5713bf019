"""``[posterior]``: the settings of ``femupdate posterior`` (the full posterior by TMCMC).

A case without the section gets its defaults (:data:`DEFAULT_POSTERIOR`), and saves nothing
for it, so its fingerprint is what it was before the section existed. What one field cannot
check alone (a prior outside its parameter's bounds, a log-uniform prior on a non-positive
bound, too few samples for the number of parameters) is checked by :func:`posterior_issues`
from the case's validator.
"""

from __future__ import annotations

import math
import typing
from typing import Literal

from pydantic import Field

from femupdate.case.fields import Section, format_value, integer_field, number_field
from femupdate.case.issues import Issue, did_you_mean

if typing.TYPE_CHECKING:
    from femupdate.case.schema import Case

#: Samples per parameter a TMCMC population needs at least: its proposal covariance is
#: estimated from the population, which must have many more members than dimensions.
SAMPLES_PER_PARAMETER = 10


class PriorSpec(Section):
    """``[posterior.priors] NAME = {kind = ..., ...}``: a parameter's prior.

    ``uniform`` (the default of every parameter) is uniform on the search interval: in
    physical units log-uniform where ``scale = "log"``; ``log-uniform`` says so explicitly (it
    needs ``scale = "log"``). ``normal`` takes ``mean`` and ``sd`` in the parameter's units;
    ``lognormal`` its ``median`` and ``sigma`` (the standard deviation of its natural log).
    Every prior is truncated to the parameter's bounds.
    """

    kind: Literal["uniform", "log-uniform", "normal", "lognormal"]
    mean: number_field() | None = None
    sd: number_field(gt=0.0) | None = None
    median: number_field(gt=0.0) | None = None
    sigma: number_field(gt=0.0) | None = None

    def spec(self) -> dict[str, float | str]:
        """The prior as :class:`femupdate.inference.priors.Prior` takes it."""
        kind = "uniform" if self.kind == "log-uniform" else self.kind
        return {"kind": kind, **{k: v for k in PRIOR_FIELDS[self.kind]
                                 if (v := getattr(self, k)) is not None}}


#: The narrowest normal (lognormal) prior: sd (sigma) as a share of the parameter's range
#: (of log(upper/lower)).
PRIOR_WIDTH_MIN = 1e-9

#: The fields each kind of prior takes.
PRIOR_FIELDS = {"uniform": (), "log-uniform": (), "normal": ("mean", "sd"),
                "lognormal": ("median", "sigma")}


class PosteriorSection(Section):
    """``[posterior]``: samples, error model, seed and budget of the sampled posterior.

    ``samples``: TMCMC's population through the tempering stages (each run ends with its
    importance draws at β = 1, resampled: as many as its effective samples need);
    ``ess``: the effective samples every parameter needs to be settled (runs are added until
    it has them, up to ``max_runs``; unset, 400, saved only when given);
    ``runs``: independent runs (seeds: the children of ``seed``, which unset is
    ``[search] seed``), pooled, whose agreement
    checks each parameter's effective samples (one run cannot check itself); ``max_runs``:
    while a parameter is unsettled, ``runs`` more are added, up to this many in all (none to
    one run);
    ``error_model``: "neff" or "eiv" (the kinds of :mod:`femupdate.inference.error_models`
    but "known", which needs the error's σ; "eiv" for a noisy table record on a linear model
    of femupdate's own); unset, the default, "neff", for both the sampled posterior and the
    Laplace record at the best fit;
    ``max_evals``: its budget (a run that cannot reach the posterior within it says so);
    ``modes_samples``: how many of the samples the modes and predictive bands are computed
    at; ``start``: the Gaussian at the best fit (Laplace, inflated) or the prior, as TMCMC's
    first population; ``recentre``: how many times at most the posterior is sampled again
    from a better fit the sampler finds than the one it started from (0: never; it is then
    said in words, :mod:`femupdate.pipeline.posterior.start`); ``surrogate``: the surrogate-aided
    posterior (:mod:`femupdate.inference.surrogate`: TMCMC on a Gaussian-process surrogate
    trained at 300 model runs at most); unset, on for an external model
    (``[model.python]``, ``[model.opensees]``) and off for femupdate's own."""

    samples: integer_field(ge=20, le=1_000_000) = 1000
    runs: integer_field(ge=1, le=64) = 4
    ess: integer_field(ge=10, le=10_000_000) | None = None
    max_runs: integer_field(ge=1, le=256) = 12
    error_model: Literal["neff", "eiv"] | None = None
    seed: integer_field(ge=0, le=2**63 - 1) | None = None
    max_evals: integer_field(ge=1, le=10**9) = 1_000_000
    modes_samples: integer_field(ge=0, le=100_000) = 200
    start: Literal["laplace", "prior"] = "laplace"
    recentre: integer_field(ge=0, le=8) = 2
    priors: dict[str, PriorSpec] = Field(default_factory=dict)
    surrogate: bool | None = None


#: The settings of a case without ``[posterior]``.
DEFAULT_POSTERIOR = PosteriorSection()


def posterior_issues(case: Case) -> list[Issue]:
    """Cross-field problems of ``[posterior]``: priors of unknown parameters, out of their
    bounds or impossible on them, and too few samples for the number of parameters."""
    section = case.posterior
    if section is None:
        return []
    issues: list[Issue] = []
    params = {p.name: p for p in case.parameters}
    need = SAMPLES_PER_PARAMETER * max(len(params), 1)
    if section.runs > section.max_runs:
        issues.append(("posterior.runs", f"got {section.runs} with max_runs = "
                       f"{section.max_runs}", "runs <= max_runs, the most runs there may be"))
    if section.samples < need:
        issues.append(("posterior.samples", f"got {section.samples} for {len(params)} "
                       f"parameters", f"at least {need} ({SAMPLES_PER_PARAMETER} per "
                       "parameter)"))
    for name, prior in section.priors.items():
        where = f"posterior.priors.{name}"
        par = params.get(name)
        if par is None:
            issues.append((where, f"no parameter {name!r}{did_you_mean(name, list(params))}",
                           f"one of {', '.join(params) or '(no parameters)'}"))
            continue
        low, high = format_value(par.lower), format_value(par.upper)
        fields = PRIOR_FIELDS[prior.kind]
        missing = [k for k in fields if getattr(prior, k) is None]
        extra = [k for k in ("mean", "sd", "median", "sigma")
                 if k not in fields and getattr(prior, k) is not None]
        if missing or extra:
            takes = " and ".join(fields) if fields else "nothing else (it spans the bounds)"
            what = ([f"without {' and '.join(missing)}"] if missing else []) + (
                [f"with {' and '.join(extra)}"] if extra else [])
            issues.append((where, f"a {prior.kind} prior {', '.join(what)}",
                           f"a {prior.kind} prior takes {takes}"))
            continue
        if prior.kind in ("log-uniform", "lognormal") and par.lower <= 0.0:
            issues.append((f"{where}.kind", f"{prior.kind!r} on parameter {name!r} whose "
                           f"lower bound is {low}", "a lower bound > 0, or kind = 'uniform' "
                           "or 'normal'"))
            continue
        if prior.kind == "log-uniform" and par.scale != "log":
            issues.append((f"{where}.kind", f"'log-uniform' on parameter {name!r} searched "
                           "on a linear scale", f"scale = 'log' on parameter {name!r} (its "
                           "uniform prior is then log-uniform), or kind = 'uniform'"))
        width = {"normal": (prior.sd, par.upper - par.lower, "sd"),
                 "lognormal": (prior.sigma, math.log(par.upper / max(par.lower, 1e-300)),
                               "sigma")}.get(prior.kind)
        if width is not None and width[0] < PRIOR_WIDTH_MIN * width[1]:
            # sd = 1e-320 ended in 'NOT A POSTERIOR … raise max_evals' with exit 0
            issues.append((f"{where}.{width[2]}", f"got {format_value(width[0])}, a degenerate "
                           f"prior (below {PRIOR_WIDTH_MIN:g} of the range of {name!r}: no "
                           "sampler resolves it)", f"{width[2]} >= "
                           f"{format_value(PRIOR_WIDTH_MIN * width[1])}; to hold {name!r} "
                           "fixed, give the value in [model] instead of a parameter"))
            continue
        if prior.kind == "normal" and not par.lower <= typing.cast(float, prior.mean) \
                <= par.upper:
            issues.append((f"{where}.mean", f"got {format_value(prior.mean)}, outside the "
                           f"bounds of {name!r}", f"a value in [{low}, {high}]"))
        if prior.kind == "lognormal" and not par.lower <= typing.cast(float, prior.median) \
                <= par.upper:
            issues.append((f"{where}.median", f"got {format_value(prior.median)}, outside the "
                           f"bounds of {name!r}", f"a value in [{low}, {high}]"))
    return issues
