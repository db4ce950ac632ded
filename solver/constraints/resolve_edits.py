"""A SPEC's edits resolved on a mesh, each kind by its module.

:mod:`solver.constraints.edits` resolves the ``radius``, ``twist``, ``map``, ``offset`` and
``lattice`` entries, :mod:`solver.constraints.feature_edits` the ``fillet``, ``distance`` and
``angle`` ones.
"""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh
from .edit_entries import AngleEntry, DistanceEntry, EditEntry, FilletEntry
from .edits import Edit, resolve_edit
from .feature_edits import angle_edit, distance_edit, fillet_edit

__all__ = ["resolve_edits"]


def resolve_edits(mesh: Mesh, edits: tuple[EditEntry, ...], sel_ids: dict[str, np.ndarray]) -> tuple[Edit, ...]:
    """Resolve a SPEC's edits on ``mesh`` (:attr:`solver.constraints.spec.ResolvedSpec.edits`, in that order).

    Parameters
    ----------
    mesh : Mesh
    edits : tuple of entries
    sel_ids : dict of str to (k,) int array
        Every node each selection names.

    Returns
    -------
    tuple of Edit

    Raises
    ------
    SpecError
        As :func:`~solver.constraints.edits.resolve_edit`,
        :func:`~solver.constraints.feature_edits.fillet_edit`,
        :func:`~solver.constraints.feature_edits.distance_edit` and
        :func:`~solver.constraints.feature_edits.angle_edit` refuse.
    """
    sets = {k: np.unique(v) for k, v in sel_ids.items()}  # every edit's nodes sorted, each once
    out: list[Edit] = []
    for e in edits:
        if isinstance(e, FilletEntry):
            out.append(fillet_edit(mesh, e, sets))
        elif isinstance(e, DistanceEntry):
            out.append(distance_edit(mesh, e, sets))
        elif isinstance(e, AngleEntry):
            out.append(angle_edit(mesh, e, sets))
        else:
            out.append(resolve_edit(mesh, e, sets))
    return tuple(out)
