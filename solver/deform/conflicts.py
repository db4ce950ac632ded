"""Where conflicting constraints are: their nodes, the selections holding each, the largest residual.

A REPORT lists conflicting (and redundant) constraints by SPEC entry, each with
the vertices of its rows. An editor or a person reading a refusal wants them
the other way round: which nodes, in which selections (regions), and by how
much they miss. :func:`conflict_details` turns entries into those typed details
of ``ConstraintError("conflicting_constraints")``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..constraints.rows import REPORT_IDS

__all__ = ["conflict_details"]


def conflict_details(entries: list[dict[str, Any]], sel_ids: dict[str, np.ndarray]) -> dict[str, Any]:
    """The nodes of constraint entries, the selections holding each node, and the largest residual.

    Parameters
    ----------
    entries : list of dict
        REPORT constraint entries (``kind``, ``name``, ``vertices``, optional ``residual``).
    sel_ids : dict of str to (k,) int array
        The SPEC's selections, resolved to vertex ids.

    Returns
    -------
    dict
        ``nodes``: the entries' vertex ids, ascending (the first :data:`REPORT_IDS`);
        ``regions``: for each node, the names of the selections that hold it, in SPEC order,
        then the entries on it as ``"kind name"``; ``residual``: the largest residual
        of the entries (0.0 for redundant ones, which hold).

    Examples
    --------
    >>> e = [{"kind": "point", "name": "pull", "vertices": [7], "residual": 1.5}]
    >>> conflict_details(e, {"FIXED": np.array([3, 7]), "LOAD": np.array([9])})
    {'nodes': [7], 'regions': [['FIXED', 'point pull']], 'residual': 1.5}
    """
    verts = [int(v) for e in entries for v in e.get("vertices", [])]
    nodes = np.unique(np.asarray(verts, np.int64))[:REPORT_IDS]
    regions: list[list[str]] = [[] for _ in nodes]
    for name, ids in sel_ids.items():
        for k in np.flatnonzero(np.isin(nodes, ids)):
            regions[int(k)].append(name)
    at = {int(v): k for k, v in enumerate(nodes)}
    for e in entries:
        label = f"{e['kind']} {e['name']}"
        for v in e.get("vertices", []):
            j = at.get(int(v))
            if j is not None and label not in regions[j]:
                regions[j].append(label)
    residual = max((float(e.get("residual", 0.0)) for e in entries), default=0.0)
    return {"nodes": nodes.tolist(), "regions": regions, "residual": residual}
