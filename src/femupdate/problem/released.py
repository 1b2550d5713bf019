"""The structure of a multi-support case with its support groups' DOFs released.

:class:`femupdate.evaluation.supports.SupportEvaluator` assembles it in compiled code to get the
blocks that couple the moving supports to the free DOFs (``K_fs``, ``M_fs``, ``C_fs``), as
:meth:`femupdate.model.structure.Structure.support_coupling` releases them.
"""

from __future__ import annotations

import typing

from femupdate.case.model_sections import Mass, Model
from femupdate.problem.case_model import build_structure

if typing.TYPE_CHECKING:
    from femupdate.model.structure import Structure

__all__ = ["released_model", "released_structure"]


def released_model(model: Model) -> tuple[Model, list[tuple[str, str]]]:
    """The case's ``[model]`` with its support groups' DOFs released and a unit mass on each.

    Parameters
    ----------
    model : Model
        A validated case's model with ``support_groups``.

    Returns
    -------
    released : Model
        The same model (not validated again) with those DOFs free. The unit masses keep its
        mass matrix positive definite (a support node often carries no mass) and touch only
        the released DOFs' diagonal: the free block and the free-support blocks are the
        model's own.
    supports : list of (node, dof)
        The released DOFs, group after group (the order of ``CaseModel``'s supports).
    """
    supports = [(node, model.group_dof(g)) for g in model.support_groups for node in g.nodes]
    moving = set(supports)
    kept = []
    for support in model.supports:
        dofs = [d for d in support.dofs if (support.node, d) not in moving]
        if dofs:
            kept.append(support.model_copy(update={"dofs": dofs}))
    masses = [*model.masses, *(Mass(node=node, m=1.0, dofs=[dof]) for node, dof in supports)]
    return model.model_copy(update={"supports": kept, "masses": masses}), supports


def released_structure(model: Model) -> tuple[Structure, list[tuple[str, str]]]:
    """:func:`released_model` built (``build_structure``), and its released DOFs."""
    released, supports = released_model(model)
    return build_structure(released), supports
