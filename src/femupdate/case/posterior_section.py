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
    """``[posterior.priors] NAME = {kind = ..., mean = ..., sd = ...}``: a parameter's prior.

    ``uniform`` (between the bounds) and ``log-uniform`` need nothing else; ``normal`` takes
    ``mean`` and ``sd`` in the parameter's units, ``lognormal`` the ``mean`` and ``sd`` of its
    natural logarithm. Every prior is truncated to the parameter's bounds.
    """

    kind: Literal["uniform", "log-uniform", "normal", "lognormal"]
    mean: number_field() | None = None
    sd: number_field(gt=0.0) | None = None


class PosteriorSection(Section):
    """``[posterior]``: samples, error model, seed and budget of the sampled posterior."""

    samples: integer_field(ge=20, le=1_000_000) = 2000
    error_model: Literal["neff", "iid", "ar1"] = "neff"
    seed: integer_field(ge=0, le=2**63 - 1) | None = None
    max_evals: integer_field(ge=1, le=10**9) = 1_000_000
    modes_samples: integer_field(ge=0, le=100_000) = 200
    priors: dict[str, PriorSpec] = Field(default_factory=dict)


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
        needs = prior.kind in ("normal", "lognormal")
        if needs and (prior.mean is None or prior.sd is None):
            issues.append((where, f"a {prior.kind} prior without "
                           + " and ".join(k for k in ("mean", "sd")
                                          if getattr(prior, k) is None),
                           "mean and sd (sd > 0)"))
            continue
        if not needs and (prior.mean is not None or prior.sd is not None):
            issues.append((where, f"mean and sd given to a {prior.kind} prior",
                           "no mean or sd: it spans the bounds"))
        if prior.kind in ("log-uniform", "lognormal") and par.lower <= 0.0:
            issues.append((f"{where}.kind", f"{prior.kind!r} on parameter {name!r} whose "
                           f"lower bound is {low}", "a lower bound > 0, or kind = 'uniform' "
                           "or 'normal'"))
            continue
        if prior.kind == "normal" and prior.mean is not None and not (
                par.lower <= prior.mean <= par.upper):
            issues.append((f"{where}.mean", f"got {format_value(prior.mean)}, outside the "
                           f"bounds of {name!r}", f"a value in [{low}, {high}]"))
        if prior.kind == "lognormal" and prior.mean is not None and not (
                math.log(par.lower) <= prior.mean <= math.log(par.upper)):
            issues.append((f"{where}.mean", f"got {format_value(prior.mean)} (the mean of "
                           f"ln {name}), outside the bounds", f"a value in "
                           f"[{format_value(math.log(par.lower))}, "
                           f"{format_value(math.log(par.upper))}] (ln of the bounds)"))
    return issues
