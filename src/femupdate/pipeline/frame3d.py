"""A 3-D frame case file end to end: read, simulate under its records, write the responses.

What ``femupdate frame3d`` runs. The case file, its frame and its records are read and checked
by :func:`femupdate.case.frame3d_case.load_frame3d_case`; the response is the pseudo-static
plus dynamic split of :mod:`femupdate.simulate.multisupport`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from femupdate.case.frame3d_case import load_frame3d_case

__all__ = ["run_frame3d_case"]


def run_frame3d_case(path: str | os.PathLike[str], out: str | os.PathLike[str] | None = None,
                     *, method: str = "exact") -> list[str]:
    """Simulate a 3-D frame case; write the responses as CSV; return summary lines.

    Writes ``<out>/total_displacement.csv``, ``dynamic_displacement.csv`` and
    ``absolute_acceleration.csv`` (a column per free DOF after the time) when ``out`` is given.
    """
    from femupdate.simulate.multisupport import multi_support_response

    _, _, model, groups, acc, dt = load_frame3d_case(path)
    resp = multi_support_response(model, groups, acc, dt, method=method)
    labels = model.system.dof_labels
    lines = [f"{model.system.n_dof} free DOFs, {len(model.support_labels)} support DOFs, "
             f"{len(groups)} record(s) of {acc.shape[0]} samples at dt = {dt:g} s ({method})"]
    peak = np.abs(resp.total).max(axis=0)
    j = int(np.argmax(peak))
    lines.append(f"largest total displacement {peak[j]:.4g} at {labels[j]}; pseudo-static part "
                 f"up to {np.abs(resp.pseudo_static).max():.4g}")
    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        header = "t," + ",".join(labels)
        for name, arr in (("total_displacement", resp.total),
                          ("dynamic_displacement", resp.dynamic),
                          ("absolute_acceleration", resp.acceleration)):
            np.savetxt(folder / f"{name}.csv", np.column_stack([resp.t, arr]), delimiter=",",
                       header=header, comments="")
        lines.append(f"wrote total_displacement.csv, dynamic_displacement.csv, "
                     f"absolute_acceleration.csv in {folder}")
    return lines
