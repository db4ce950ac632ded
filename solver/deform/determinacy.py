"""Whether the constraints determine every body and every boundary shell.

The method's systems leave a body's (or a boundary shell's) rigid motion
undetermined unless some fixed or handle vertex holds it, directly or
through ties. Internal voids can instead be positioned by the volume around
them (``SPEC.voids == "volume"``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import ConstraintError, format_ids
from ..mesh import Mesh

__all__ = ["free_shells", "spread"]


def spread(has: np.ndarray, labels: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Mark every component tied (by vertex ``pairs``) to a marked one.

    Parameters
    ----------
    has : (k,) bool array
        Marked components.
    labels : (n,) int array
        Component of each vertex.
    pairs : (t, 2) int array
        Tied vertex pairs.

    Returns
    -------
    (k,) bool array
    """
    if not len(pairs) or has.all():
        return has
    la, lb = labels[pairs[:, 0]], labels[pairs[:, 1]]
    k = has.size
    G = sp.coo_matrix((np.ones(la.size), (la, lb)), shape=(k, k))
    _, grp = connected_components(G, directed=False)
    held = np.zeros(grp.max() + 1, bool)
    held[grp[has]] = True
    return held[grp]


def free_shells(mesh: Mesh, constrained: np.ndarray, ties: np.ndarray, voids: str) -> np.ndarray:
    """Boundary vertices of internal voids that no constraint holds (positioned by the volume).

    Parameters
    ----------
    mesh : Mesh
    constrained : (n,) bool array
        Fixed and handle (corner) vertices.
    ties : (t, 2) int array
    voids : {"volume", "refuse"}

    Returns
    -------
    free : (n,) bool array
        Vertices of boundary shells with no constrained vertex (empty unless
        ``voids == "volume"``).

    Raises
    ------
    ConstraintError
        ``unconstrained_component``: a body has no fixed or handle vertex;
        ``unconstrained_shell``: a boundary shell has none and voids are refused.
    """
    bodies = mesh.body_labels
    nb = int(bodies.max()) + 1
    has = np.zeros(nb, bool)
    has[bodies[constrained & mesh.referenced]] = True
    has = spread(has, bodies, ties)  # a body tied to a held one is held
    if not has.all():
        b = int(np.flatnonzero(~has)[0])
        verts = np.flatnonzero(bodies == b)
        raise ConstraintError(
            f"body {b} of {nb} ({verts.size} vertices, first {format_ids(verts, 5)}) has no fixed "
            "or handle vertex: its position is undetermined. Add a selection that touches it.",
            code="unconstrained_component", component=b, vertices=int(verts.size))
    shells = mesh.shell_labels
    ns = int(shells.max()) + 1 if mesh.boundary.any() else 0
    free = np.zeros(mesh.n, bool)
    if not ns:
        return free
    has_s = np.zeros(ns, bool)
    has_s[shells[constrained & mesh.boundary]] = True
    tb = ties[mesh.boundary[ties].all(axis=1)] if len(ties) else ties
    has_s = spread(has_s, shells, tb)
    if has_s.all():
        return free
    if voids == "volume":
        # internal voids: positioned by the surrounding volume (rotation extended through the
        # tets, translation by the interior's mean-value rows in the joint solve)
        return mesh.boundary & ~has_s[np.maximum(shells, 0)]
    s = int(np.flatnonzero(~has_s)[0])
    verts = np.flatnonzero(shells == s)
    raise ConstraintError(
        f"boundary shell {s} of {ns} ({verts.size} vertices, first {format_ids(verts, 5)}) has "
        "no fixed or handle vertex. It is an internal void or an unconstrained surface: the "
        "method's rotation and boundary systems leave its rigid motion undetermined. Add a "
        "selection on it (e.g. fix it, or select it with a sphere/box).",
        code="unconstrained_shell", shell=s, vertices=int(verts.size))
