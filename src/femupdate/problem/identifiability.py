"""Which parameters the data determine: sensitivities of the residuals at a solution.

The residual vector r(p) is scaled so that φ = ‖r‖² (Eq. 1). Its Jacobian with respect to
*relative* parameter changes, J_i = ∂r/∂ln p_i (or per unit of the search range for a parameter
at 0), is computed by central differences. A parameter the data cannot determine shows as a
column of J that is tiny (φ hardly changes when it moves) or nearly parallel to others (a small
singular value of J; a correlation near ±1 in (JᵀJ)⁻¹).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from femupdate.problem.update import UpdateProblem


def residuals(problem: UpdateProblem, values: dict[str, float]) -> np.ndarray:
    """Residuals r with φ = ‖r‖², at physical parameter ``values`` (inf-filled if failed)."""
    return problem.residuals(values)


@dataclass(frozen=True)
class Identifiability:
    """Sensitivities of φ's residuals at a solution.

    Attributes
    ----------
    names : tuple of str
    values : ndarray (n,)
        Physical parameter values at the solution.
    steps : ndarray (n,)
        The parameter change that one unit of the Jacobian column stands for (|p|, or the
        bound range for a parameter at 0).
    jacobian : ndarray (m, n)
    phi_change_1pct : ndarray (n,)
        ‖0.01 J_i‖²: the increase of φ (to second order) when the parameter alone moves by
        1 % of its step.
    singular_values : ndarray (n,)
        Of J, descending.
    correlations : ndarray (n, n)
        Of the parameter estimates, from the pseudo-inverse of JᵀJ.
    undetermined : tuple of str
        Parameters the data cannot determine (see :func:`identifiability`).
    """

    names: tuple[str, ...]
    values: np.ndarray
    steps: np.ndarray
    jacobian: np.ndarray
    phi_change_1pct: np.ndarray
    singular_values: np.ndarray
    correlations: np.ndarray
    undetermined: tuple[str, ...]

    def to_dict(self) -> dict[str, object]:
        return {
            "names": list(self.names),
            "values": self.values.tolist(),
            "phi_change_1pct": dict(zip(self.names, self.phi_change_1pct.tolist(), strict=True)),
            "singular_values": self.singular_values.tolist(),
            "correlations": self.correlations.tolist(),
            "undetermined": list(self.undetermined),
        }


def identifiability(problem: UpdateProblem, x: np.ndarray, *, rel_step: float = 1e-3,
                    tol: float = 1e-3) -> Identifiability:
    """Sensitivity analysis at search point ``x``.

    A parameter is *undetermined* when φ changes by less than ``tol`` × the most sensitive
    parameter's change for the same relative move, or when it dominates (largest component)
    a right singular vector whose singular value is below ``tol`` × the largest.
    """
    names = problem.names
    values = problem.values(np.asarray(x, dtype=float))
    p = np.array([values[n] for n in names])
    ranges = np.array([par.upper - par.lower for par in problem.case.parameters])
    steps = np.where(np.abs(p) > 0, np.abs(p), ranges)
    columns = []
    for i, name in enumerate(names):
        h = rel_step * steps[i]
        up = dict(values, **{name: p[i] + h})
        down = dict(values, **{name: max(p[i] - h, 0.0) if p[i] >= 0 else p[i] - h})
        dp = up[name] - down[name]
        columns.append((residuals(problem, up) - residuals(problem, down)) / dp * steps[i])
    jac = np.column_stack(columns)
    col_norm = np.linalg.norm(jac, axis=0)
    phi_1pct = (0.01 * col_norm) ** 2
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    corr = estimate_correlations(jac)
    weak = set(np.flatnonzero(col_norm < tol * col_norm.max()).tolist())
    weak |= {int(np.argmax(np.abs(vt[k]))) for k in range(sv.size) if sv[k] < tol * sv[0]}
    return Identifiability(
        names=names, values=p, steps=steps, jacobian=jac, phi_change_1pct=phi_1pct,
        singular_values=sv, correlations=corr,
        undetermined=tuple(names[i] for i in sorted(weak)),
    )


def estimate_correlations(jac: np.ndarray) -> np.ndarray:
    """Correlations of the least-squares estimates from the Jacobian (m, n): the covariance
    (JᵀJ)⁺ scaled by its diagonal.

    A parameter that the data leave without variance (a zero column: pinv's null space) has
    no correlation with any other: its row and column are NaN (dividing by a clipped tiny
    variance overflowed instead).
    """
    cov = np.linalg.pinv(jac.T @ jac)
    var = np.diag(cov)
    d = np.sqrt(np.where(var > 0.0, var, np.nan))
    with np.errstate(invalid="ignore"):
        return np.clip(cov / np.outer(d, d), -1.0, 1.0)


def strong_correlations(names: list[str] | tuple[str, ...], correlations: np.ndarray,
                        threshold: float = 0.9) -> list[tuple[str, str, float]]:
    """Pairs of parameters whose estimates correlate beyond ``threshold`` in magnitude.

    Such a pair is a diagonal valley of φ: the data fix a combination of the two, not each.
    Sorted by decreasing |ρ|.
    """
    corr = np.asarray(correlations, dtype=float)
    pairs = [(names[i], names[j], float(corr[i, j]))
             for i in range(len(names)) for j in range(i + 1, len(names))
             if abs(corr[i, j]) > threshold]
    return sorted(pairs, key=lambda pair: -abs(pair[2]))
