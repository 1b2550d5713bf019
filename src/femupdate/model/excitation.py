"""Base excitation of a ``Structure``: the influence vector, the seismic load and the support
coupling blocks.

Under a rigid base motion ``a_g(t)`` along a direction every translation along it moves by the
same amount (:func:`rigid_translation`); the load on the free DOFs is ``-p a_g`` with
``p = M_ff r_f + M_fc r_c`` (:func:`seismic_vector`): consistent beam masses carry inertia from
moving supports (fixed DOFs) into the free DOFs. Supports moving by records of their own need
the free–support blocks of ``K``, ``M`` and ``C`` (:func:`coupling_blocks`, for
:mod:`femupdate.simulate.multisupport`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from femupdate.errors import ModelError
from femupdate.model.system import System

__all__ = ["DEFAULT_DIRECTION", "coupling_blocks", "rigid_translation", "seismic_vector"]

#: Default base-excitation direction for each ``dofs_per_node``.
DEFAULT_DIRECTION = {1: "x", 2: "y", 3: "x", 6: "x"}


def rigid_translation(global_dof_names: np.ndarray, node_dof_names: Sequence[str], dpn: int,
                      direction: str | None) -> np.ndarray:
    """Rigid base translation over all global DOFs (fixed ones included): 1 on the
    translations along ``direction`` (default :data:`DEFAULT_DIRECTION`), 0 elsewhere."""
    if direction is None:
        direction = DEFAULT_DIRECTION[dpn]
    name = f"u{direction}"
    if not isinstance(direction, str) or name not in node_dof_names:
        allowed = [d[1] for d in node_dof_names if d.startswith("u")]
        raise ModelError(
            f"direction = {direction!r}; allowed {allowed} for dofs_per_node={dpn}"
        )
    return (global_dof_names == name).astype(float)


def seismic_vector(m: np.ndarray | sp.spmatrix, r: np.ndarray, rigid: np.ndarray,
                   coupling: tuple[np.ndarray, np.ndarray, np.ndarray], beam_m: np.ndarray,
                   n: int) -> np.ndarray | None:
    """``M_ff r_f + M_fc r_c``, or None when no beam mass couples a fixed DOF (then ``M r``).

    ``coupling`` is the beams' (free row, entry of the stack, global fixed column) triple of
    :func:`femupdate.model.topology.beam_plan`, ``beam_m`` their mass stack.
    """
    rows, keep, gcols = coupling
    if not rows.size:
        return None
    return m @ r + np.bincount(rows, weights=beam_m.reshape(-1)[keep] * rigid[gcols],
                               minlength=n)


def coupling_blocks(released: System, supports: Sequence[tuple[str, str]],
                    free_labels: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``K_fs``, ``M_fs``, ``C_fs`` from the system assembled with the supports released:
    rows in ``free_labels`` order, columns in the order of ``supports``."""
    index = {label: i for i, label in enumerate(released.dof_labels)}
    cols = [index[f"{node}.{dof}"] for node, dof in supports]
    rows = [index[label] for label in free_labels]
    return tuple(sp.csr_matrix(mat)[rows][:, cols].toarray()  # type: ignore[return-value]
                 for mat in (released.K, released.M, released.C))
