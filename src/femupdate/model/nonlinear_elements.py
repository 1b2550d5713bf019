"""The friction and Bouc–Wen elements of a ``Structure`` at parameter values.

The topology keeps their end DOFs (first end free, :func:`femupdate.model.topology.odd_link_dofs`)
and their properties; per assembly they are evaluated into the ``FrictionElements`` and
``BoucWenElements`` the nonlinear integrators read, and renumbered when rigid diaphragms leave
some DOFs out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from femupdate.model.hysteresis import check_bouc_wen_parameters
from femupdate.model.system import BoucWenElements, FrictionElements

if TYPE_CHECKING:
    from femupdate.model.diaphragm import Diaphragms
    from femupdate.model.topology import Topology

__all__ = ["bouc_wen_elements", "friction_elements", "reindexed"]


def friction_elements(topo: Topology, p: np.ndarray) -> FrictionElements | None:
    """The elasto-slip elements at parameter vector ``p`` (None without any)."""
    if not topo.friction_i.size:
        return None
    return FrictionElements(
        dof_i=topo.friction_i.copy(),
        dof_j=topo.friction_j.copy(),
        k_r=topo.friction_kr.evaluate(p).copy(),
        f_u=topo.friction_fu.evaluate(p).copy(),
    )


def bouc_wen_elements(topo: Topology, p: np.ndarray) -> BoucWenElements | None:
    """The Bouc–Wen elements at parameter vector ``p`` (None without any); the (β, γ) pairs
    and the other properties are checked together here."""
    if not topo.bouc_wen_i.size:
        return None
    table = np.column_stack([prop.evaluate(p) for prop in topo.bouc_wen_props])
    names = topo.bouc_wen_props[0].names
    check_bouc_wen_parameters(table, names)
    return BoucWenElements(dof_i=topo.bouc_wen_i.copy(), dof_j=topo.bouc_wen_j.copy(),
                           table=table, names=names)


def reindexed(floors: Diaphragms, friction: FrictionElements | None,
              bouc_wen: BoucWenElements | None
              ) -> tuple[FrictionElements | None, BoucWenElements | None]:
    """The elements with their end DOFs numbered among the independent DOFs of ``floors``."""
    if friction is not None:
        friction = FrictionElements(floors.reindex(friction.dof_i, "friction"),
                                    floors.reindex(friction.dof_j, "friction"),
                                    friction.k_r, friction.f_u)
    if bouc_wen is not None:
        bouc_wen = BoucWenElements(floors.reindex(bouc_wen.dof_i, "Bouc–Wen"),
                                   floors.reindex(bouc_wen.dof_j, "Bouc–Wen"),
                                   bouc_wen.table, bouc_wen.names)
    return friction, bouc_wen
