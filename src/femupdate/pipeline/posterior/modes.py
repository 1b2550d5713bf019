"""Natural frequencies and damping ratios of the model over posterior samples."""

from __future__ import annotations

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.model.modes import damped_modes
from femupdate.problem.update import UpdateProblem

#: Modes reported per sample (the summary's best model reports as many).
N_MODES = 6


def sample_modes(problem: UpdateProblem, samples: np.ndarray, n_modes: int = N_MODES
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The first modes' frequencies (Hz) and damping ratios at each physical sample (k, n).

    The frequencies are those of the damped (complex) modes, |λ|/2π, and ζ = −Re λ/|λ|, of
    femupdate's own models (friction elements stuck); an external model gives its undamped
    frequencies, and no damping ratios. A sample whose modes cannot be computed is NaN.
    """
    names = problem.names
    rows_f: list[np.ndarray] = []
    rows_z: list[np.ndarray] = []
    external = problem.model.external is not None
    for row in np.atleast_2d(samples):
        values = dict(zip(names, row.tolist(), strict=True))
        try:
            if external:
                f, z = problem.frequencies(values)[:n_modes], np.empty(0)
            else:
                modes = damped_modes(problem.system(values))
                f, z = modes.freqs_hz[:n_modes], modes.damping_ratios[:n_modes]
        except FemupdateError:
            f, z = np.full(n_modes, np.nan), np.full(n_modes, np.nan)
        rows_f.append(f)
        rows_z.append(z)
    width_f = min((r.size for r in rows_f), default=0)
    width_z = min((r.size for r in rows_z), default=0)
    return (np.array([r[:width_f] for r in rows_f]).reshape(len(rows_f), width_f),
            np.array([r[:width_z] for r in rows_z]).reshape(len(rows_z), width_z))
