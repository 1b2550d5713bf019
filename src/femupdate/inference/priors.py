"""Priors of a case's parameters, on the search's unit cube and in physical units.

Every parameter has bounds (``lower``, ``upper``) and a ``scale``; its prior is truncated to
the bounds:

- ``uniform`` (the default): uniform on the search interval, which is log-uniform in physical
  units where ``scale = "log"`` (the search space is log10 there);
- ``normal``: mean ``mean``, standard deviation ``sd`` (physical units), truncated;
- ``lognormal``: median ``median`` (physical units) and ``sigma``, the standard deviation of
  ln x, truncated.

Proposed case-file syntax, on a parameter::

    [[parameters]]
    name = "kp2"
    lower = 1e5
    upper = 1e6
    prior = {kind = "normal", mean = 3e5, sd = 1e5}

The maps between the unit cube and the search space are those of
:func:`femupdate.minimize` (x = low + (high − low)·ξ, the paper's Eq. 8) and of the case
(10**x on a log scale, :meth:`femupdate.case.schema.Parameter.to_physical`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from femupdate.errors import ConfigError

#: Prior kinds and their fields.
PRIOR_FIELDS: dict[str, tuple[str, ...]] = {
    "uniform": (),
    "normal": ("mean", "sd"),
    "lognormal": ("median", "sigma"),
}
LN10 = math.log(10.0)


def _fmt(x: float) -> str:
    return f"{x:.6g}"


class Prior:
    """Independent priors of named parameters, truncated to their bounds (pydantic-free).

    Parameters
    ----------
    names : sequence of str
    lower, upper : sequence of float
        Bounds in physical units (lower < upper; lower > 0 where the scale is log).
    scales : sequence of {"linear", "log"}, optional
        Default all linear.
    specs : mapping name -> mapping, optional
        A parameter's prior: ``{"kind": "normal", "mean": .., "sd": ..}`` or ``{"kind":
        "lognormal", "median": .., "sigma": ..}`` or ``{"kind": "uniform"}``; the others are
        uniform on their search interval.
    source : str
        How errors name where the priors come from (a case file).
    """

    def __init__(self, names: Sequence[str], lower: Sequence[float], upper: Sequence[float],
                 scales: Sequence[str] | None = None,
                 specs: Mapping[str, Mapping[str, Any]] | None = None, *,
                 source: str = "priors") -> None:
        self.names = tuple(str(n) for n in names)
        self.source = source
        d = len(self.names)
        self.lower = np.asarray(lower, dtype=float).reshape(-1)
        self.upper = np.asarray(upper, dtype=float).reshape(-1)
        self.scales = tuple(scales) if scales is not None else ("linear",) * d
        if d == 0 or self.lower.size != d or self.upper.size != d or len(self.scales) != d:
            raise ConfigError(f"{source}: parameters: names, lower, upper and scales must have "
                              f"one entry per parameter (allowed: ≥ 1 parameter), got {d}, "
                              f"{self.lower.size}, {self.upper.size}, {len(self.scales)}")
        if len(set(self.names)) != d:
            raise ConfigError(f"{source}: parameters: names repeat (allowed: unique names)")
        for i, name in enumerate(self.names):
            self._check_bounds(i, name)
        specs = dict(specs or {})
        unknown = sorted(set(specs) - set(self.names))
        if unknown:
            raise ConfigError(f"{source}: prior of unknown parameter(s) {unknown} (allowed: "
                              f"{list(self.names)})")
        self.kinds: tuple[str, ...] = tuple(
            self._check_spec(i, name, specs.get(name)) for i, name in enumerate(self.names))
        self.params: tuple[dict[str, float], ...] = tuple(
            {k: float(v) for k, v in (specs.get(name) or {}).items() if k != "kind"}
            for name in self.names)
        self.is_log = np.array([s == "log" for s in self.scales])
        with np.errstate(divide="ignore", invalid="ignore"):
            self.search_low = np.where(self.is_log, np.log10(self.lower), self.lower)
            self.search_high = np.where(self.is_log, np.log10(self.upper), self.upper)
        self.span = self.search_high - self.search_low
        # Truncated physical distributions: (frozen scipy distribution, cdf(lower), mass).
        self._dists: list[tuple[Any, float, float] | None] = []
        for i, kind in enumerate(self.kinds):
            if kind == "uniform":
                self._dists.append(None)
                continue
            p = self.params[i]
            dist = (stats.norm(p["mean"], p["sd"]) if kind == "normal"
                    else stats.lognorm(s=p["sigma"], scale=p["median"]))
            a, b = float(dist.cdf(self.lower[i])), float(dist.cdf(self.upper[i]))
            if not b - a > 0.0:
                raise ConfigError(f"{source}: parameters[{self.names[i]}].prior: no "
                                  f"probability within the bounds (allowed: a prior with mass "
                                  f"in [{_fmt(self.lower[i])}, {_fmt(self.upper[i])}])")
            self._dists.append((dist, a, b - a))

    # -- construction and checks --------------------------------------------------------------

    @classmethod
    def from_case(cls, case: Any,
                  specs: Mapping[str, Mapping[str, Any]] | None = None) -> Prior:
        """The prior of a validated case's parameters; ``specs`` as in the constructor (the
        integration reads them from the case's ``prior`` fields, when the schema has them)."""
        params = case.parameters
        if specs is None:
            specs = {p.name: dict(p.prior) for p in params
                     if getattr(p, "prior", None) is not None}
        return cls([p.name for p in params], [p.lower for p in params],
                   [p.upper for p in params], [p.scale for p in params], specs,
                   source=str(case.label))

    def _where(self, name: str, field: str) -> str:
        return f"{self.source}: parameters[{name}].{field}"

    def _check_bounds(self, i: int, name: str) -> None:
        low, high = float(self.lower[i]), float(self.upper[i])
        if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
            raise ConfigError(f"{self._where(name, 'upper')}: got bounds [{_fmt(low)}, "
                              f"{_fmt(high)}] (allowed: finite, lower < upper)")
        if self.scales[i] not in ("linear", "log"):
            raise ConfigError(f"{self._where(name, 'scale')}: got {self.scales[i]!r} "
                              f"(allowed: 'linear', 'log')")
        if self.scales[i] == "log" and low <= 0.0:
            raise ConfigError(f"{self._where(name, 'lower')}: got {_fmt(low)} with scale = "
                              f"'log': a log-uniform prior needs a positive range (allowed: "
                              f"lower > 0, or scale = 'linear')")

    def _check_spec(self, i: int, name: str, spec: Mapping[str, Any] | None) -> str:
        if spec is None:
            return "uniform"
        if not isinstance(spec, Mapping):
            raise ConfigError(f"{self._where(name, 'prior')}: got {spec!r} (allowed: a table "
                              f"such as {{kind = \"normal\", mean = .., sd = ..}})")
        kind = spec.get("kind", "uniform")
        if kind not in PRIOR_FIELDS:
            raise ConfigError(f"{self._where(name, 'prior.kind')}: got {kind!r} (allowed: "
                              f"{', '.join(map(repr, PRIOR_FIELDS))})")
        fields = PRIOR_FIELDS[kind]
        given = set(spec) - {"kind"}
        if given != set(fields):
            raise ConfigError(f"{self._where(name, 'prior')}: a {kind} prior takes "
                              f"{', '.join(fields) or 'no fields'}, got "
                              f"{', '.join(sorted(given)) or 'none'}")
        values = {}
        for field in fields:
            v = spec[field]
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ConfigError(f"{self._where(name, 'prior.' + field)}: got {v!r} "
                                  f"(allowed: a finite number)")
            values[field] = float(v)
        low, high = float(self.lower[i]), float(self.upper[i])
        inside = f"a value in [{_fmt(low)}, {_fmt(high)}]"
        if kind == "normal":
            if not low <= values["mean"] <= high:
                raise ConfigError(f"{self._where(name, 'prior.mean')}: got "
                                  f"{_fmt(values['mean'])}, outside the bounds (allowed: "
                                  f"{inside})")
            if values["sd"] <= 0.0:
                raise ConfigError(f"{self._where(name, 'prior.sd')}: got {_fmt(values['sd'])}"
                                  f" (allowed: sd > 0)")
        elif kind == "lognormal":
            if not (low <= values["median"] <= high and values["median"] > 0.0):
                raise ConfigError(f"{self._where(name, 'prior.median')}: got "
                                  f"{_fmt(values['median'])} (allowed: {inside}, > 0)")
            if values["sigma"] <= 0.0:
                raise ConfigError(f"{self._where(name, 'prior.sigma')}: got "
                                  f"{_fmt(values['sigma'])} (allowed: sigma > 0, the standard "
                                  f"deviation of ln x)")
        return kind

    @property
    def dim(self) -> int:
        return len(self.names)

    # -- maps ----------------------------------------------------------------------------------

    def to_search(self, unit: np.ndarray) -> np.ndarray:
        """Search-space points (log10 on log scales) of unit-cube points (..., d)."""
        return self.search_low + self.span * np.asarray(unit, dtype=float)

    def to_unit(self, search: np.ndarray) -> np.ndarray:
        """Unit-cube points of search-space points (..., d)."""
        return (np.asarray(search, dtype=float) - self.search_low) / self.span

    def search_to_physical(self, search: np.ndarray) -> np.ndarray:
        """Physical values of search-space points."""
        search = np.asarray(search, dtype=float)
        return np.where(self.is_log, 10.0 ** np.where(self.is_log, search, 0.0), search)

    def physical_to_search(self, values: np.ndarray) -> np.ndarray:
        """Search-space points of physical values."""
        values = np.asarray(values, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.is_log, np.log10(np.where(self.is_log, values, 1.0)), values)

    def to_physical(self, unit: np.ndarray) -> np.ndarray:
        """Physical values of unit-cube points."""
        return self.search_to_physical(self.to_search(unit))

    def from_physical(self, values: np.ndarray) -> np.ndarray:
        """Unit-cube points of physical values."""
        return self.to_unit(self.physical_to_search(values))

    # -- sampling and densities ----------------------------------------------------------------

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``n`` independent draws: (unit-cube points (n, d), physical values (n, d)), by the
        inverse CDF of each truncated marginal of one (n, d) array of uniforms from ``rng``."""
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ConfigError(f"prior sample size: got {n!r} (allowed: an integer ≥ 1)")
        u = rng.random((int(n), self.dim))
        unit = u.copy()
        for i, entry in enumerate(self._dists):
            if entry is None:
                continue
            dist, a, mass = entry
            x = np.clip(dist.ppf(a + mass * u[:, i]), self.lower[i], self.upper[i])
            unit[:, i] = np.clip(self.from_physical_column(i, x), 0.0, 1.0)
        return unit, self.to_physical(unit)

    def from_physical_column(self, i: int, x: np.ndarray) -> np.ndarray:
        """Unit-cube coordinate of parameter ``i``'s physical values ``x``."""
        search = np.log10(x) if self.is_log[i] else x
        return (search - self.search_low[i]) / self.span[i]

    def logpdf_unit(self, unit: np.ndarray) -> np.ndarray:
        """log density on the unit cube of points (k, d): shape (k,); −inf outside the cube.
        A uniform prior on the search interval is 0 there (density 1)."""
        unit = np.atleast_2d(np.asarray(unit, dtype=float))
        inside = np.all((unit >= 0.0) & (unit <= 1.0), axis=1)
        out = np.zeros(unit.shape[0])
        if any(entry is not None for entry in self._dists):
            physical = self.to_physical(np.clip(unit, 0.0, 1.0))
            for i, entry in enumerate(self._dists):
                if entry is None:
                    continue
                dist, _, mass = entry
                x = physical[:, i]
                jac = self.span[i] * (LN10 * x if self.is_log[i] else 1.0)  # dx/dξ
                out += dist.logpdf(x) - math.log(mass) + np.log(jac)
        out[~inside] = -np.inf
        return out

    def logpdf(self, values: np.ndarray) -> np.ndarray:
        """log density in physical units of values (k, d): shape (k,); −inf outside the
        bounds (a log-uniform marginal is 1/(x · ln(upper/lower)))."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        inside = np.all((values >= self.lower) & (values <= self.upper), axis=1)
        out = np.zeros(values.shape[0])
        safe = np.clip(values, self.lower, self.upper)
        for i, entry in enumerate(self._dists):
            x = safe[:, i]
            if entry is None:
                if self.is_log[i]:
                    out += -np.log(x) - math.log(LN10 * self.span[i])
                else:
                    out += -math.log(self.span[i])
            else:
                dist, _, mass = entry
                out += dist.logpdf(x) - math.log(mass)
        out[~inside] = -np.inf
        return out

    def curvature_unit(self, unit: np.ndarray, step: float = 1e-4) -> tuple[np.ndarray,
                                                                            np.ndarray]:
        """Gradient (d,) and diagonal Hessian (d,) of :meth:`logpdf_unit` at a point of the
        cube, by central differences of each (separable) marginal; zero for uniform ones."""
        xi = np.clip(np.asarray(unit, dtype=float).reshape(-1), step, 1.0 - step)
        grad = np.zeros(self.dim)
        hess = np.zeros(self.dim)
        for i, entry in enumerate(self._dists):
            if entry is None:
                continue
            pts = np.repeat(xi[None, :], 3, axis=0)
            pts[:, i] += (-step, 0.0, step)
            lo, mid, hi = self._marginal_logpdf_unit(i, pts[:, i])
            grad[i] = (hi - lo) / (2 * step)
            hess[i] = (hi - 2 * mid + lo) / step ** 2
        return grad, hess

    def _marginal_logpdf_unit(self, i: int, xi: np.ndarray) -> np.ndarray:
        dist, _, mass = self._dists[i]
        search = self.search_low[i] + self.span[i] * xi
        x = 10.0 ** search if self.is_log[i] else search
        jac = self.span[i] * (LN10 * x if self.is_log[i] else 1.0)
        return dist.logpdf(x) - math.log(mass) + np.log(jac)

    def quantiles_search(self, probs: Sequence[float]) -> np.ndarray:
        """Quantiles of each marginal in the search space: shape (len(probs), d)."""
        probs = np.asarray(probs, dtype=float)
        out = np.empty((probs.size, self.dim))
        for i, entry in enumerate(self._dists):
            if entry is None:
                out[:, i] = self.search_low[i] + self.span[i] * probs
            else:
                dist, a, mass = entry
                x = np.clip(dist.ppf(a + mass * probs), self.lower[i], self.upper[i])
                out[:, i] = np.log10(x) if self.is_log[i] else x
        return out

    def std_search(self) -> np.ndarray:
        """Standard deviation of each marginal in the search space (uniform: span/√12;
        the others by quadrature of the truncated marginal's quantile function)."""
        probs = (np.arange(2000) + 0.5) / 2000
        q = self.quantiles_search(probs)
        return q.std(axis=0)

    def describe(self) -> list[str]:
        """One line per parameter: its prior in words."""
        lines = []
        for i, name in enumerate(self.names):
            bounds = f"[{_fmt(self.lower[i])}, {_fmt(self.upper[i])}]"
            kind, p = self.kinds[i], self.params[i]
            if kind == "uniform":
                what = "log-uniform" if self.is_log[i] else "uniform"
                lines.append(f"{name}: {what} on {bounds}")
            elif kind == "normal":
                lines.append(f"{name}: normal, mean {_fmt(p['mean'])}, sd {_fmt(p['sd'])}, "
                             f"truncated to {bounds}")
            else:
                lines.append(f"{name}: lognormal, median {_fmt(p['median'])}, σ(ln) "
                             f"{_fmt(p['sigma'])}, truncated to {bounds}")
        return lines
