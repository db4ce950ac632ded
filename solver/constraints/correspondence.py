"""The geometric part of symmetry, cyclic, surface-tie and target constraints, resolved once on the rest mesh."""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..errors import MAX_IDS, SpecError
from ..mesh import Mesh
from ..ops.closest_point import TriangleSurface
from .matching import Matching, match, reflection, rotation
from .selection import midside_mask
from .spec import CyclicEntry, ResolvedSpec, SymmetryEntry, TargetEntry

__all__ = ["Correspondences", "correspondences", "MatchedEntry", "InteriorMirror", "TargetPoints", "read_surface",
           "interior_pairs", "SYMMETRY_TOL", "SURFACE_TIE_TOL"]

#: Default matching tolerance of symmetry and cyclic constraints, relative to the mesh diagonal.
SYMMETRY_TOL = 1e-6
#: Default distance within which a boundary node of A is tied to B's faces, relative to the diagonal.
SURFACE_TIE_TOL = 1e-3


@dataclass(frozen=True, eq=False)
class MatchedEntry:
    """One symmetry or cyclic entry resolved: slave-to-master rows and the nodes on its plane or axis.

    Attributes
    ----------
    kind : {"symmetry", "cyclic"}
    index : int
    name : str
    matching : Matching
        Corner nodes (the solve's unknowns).
    fixed_nodes : (k,) int array
        Corner nodes on the plane (symmetry) or the axis (cyclic).
    N : (r, 3) float array
        Their constrained directions: the plane normal (1 row) or two normals of the axis.
    c : (3,) float array
        A point of the plane or axis.
    midside : Matching or None
        Mid-side slave nodes, set from the master side after placement.
    inner : (k, 2) int array
        Mirror symmetry: interior corner node pairs ``(negative side, positive side)``
        that are each other's image within the tolerance (empty for cyclic entries
        and for meshes not mirror-matched inside).
    inner_on : (j,) int array
        Interior corner nodes on the plane.
    """

    kind: str
    index: int
    name: str
    matching: Matching
    fixed_nodes: np.ndarray
    N: np.ndarray
    c: np.ndarray
    midside: Matching | None = None
    inner: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))
    inner_on: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


@dataclass(frozen=True, eq=False)
class InteriorMirror:
    """Interior nodes of one mirror symmetry held as images: ``p_dst = A p_src + t``, and nodes on the plane.

    Built by :func:`~solver.deform.constraint_set.constraint_set` from
    :attr:`MatchedEntry.inner`, once it knows which nodes are fixed or in a
    handle: a constrained node is the source of its free partner, else the
    positive side is. ``derived`` pairs have a constrained source and a free
    destination (the split solve holds the destination like a handle node);
    every pair and on-plane node is set exactly after the solve (:meth:`apply`).

    Attributes
    ----------
    name : str
    A : (3, 3) float array
    t : (3,) float array
    src, dst : (k,) int arrays
    derived : (k,) bool array
    on : (j,) int array
        Free interior nodes on the plane (their normal coordinate is the plane's).
    n, c : (3,) float arrays
        The plane's unit normal and a point of it.
    """

    name: str
    A: np.ndarray
    t: np.ndarray
    src: np.ndarray
    dst: np.ndarray
    derived: np.ndarray
    on: np.ndarray
    n: np.ndarray
    c: np.ndarray

    def apply(self, P: np.ndarray) -> None:
        """Set the destinations to the images of their sources and the on-plane nodes onto the plane, in place."""
        if self.dst.size:
            P[self.dst] = P[self.src] @ self.A.T + self.t
        if self.on.size:
            P[self.on] -= np.outer((P[self.on] - self.c) @ self.n, self.n)


def interior_pairs(mesh: Mesh, M: np.ndarray, t: np.ndarray, h: np.ndarray, tol: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Interior corner nodes that are each other's mirror image, and those on the plane.

    Parameters
    ----------
    mesh : Mesh
    M, t : the reflection ``p -> M p + t``
    h : (n,) float array
        Signed distance of every node to the plane.
    tol : float

    Returns
    -------
    pairs : (k, 2) int array
        ``(negative side, positive side)`` nodes within ``tol`` of each other's image.
    on : (j,) int array
    """
    from scipy.spatial import cKDTree

    inner = ~mesh.boundary & mesh.referenced
    neg = np.flatnonzero(inner & (h < -tol))
    pos = np.flatnonzero(inner & (h > tol))
    on = np.flatnonzero(inner & (np.abs(h) <= tol))
    if not neg.size or not pos.size:
        return np.zeros((0, 2), np.int64), on
    d, j = cKDTree(mesh.V[pos]).query(mesh.V[neg] @ M.T + t, distance_upper_bound=tol)
    hit = np.isfinite(d)
    return np.c_[neg[hit], pos[j[hit]]].astype(np.int64), on


@dataclass(frozen=True, eq=False)
class TargetPoints:
    """A target entry resolved: its boundary nodes and their points on the target surface.

    Attributes
    ----------
    index : int
    name : str
    ids : (k,) int array
        Corner nodes that land on the surface.
    q : (k, 3) float array
        Their target points.
    mid_ids : (j,) int array
        Mid-side nodes of the selection on the boundary, held at their target points too.
    mid_q : (j, 3) float array
    surface : TriangleSurface
        For measuring the distance after a solve.
    """

    index: int
    name: str
    ids: np.ndarray
    q: np.ndarray
    mid_ids: np.ndarray
    mid_q: np.ndarray
    surface: TriangleSurface


@dataclass(frozen=True, eq=False)
class Correspondences:
    """Every symmetry, cyclic, surface-tie and target constraint of a SPEC, resolved."""

    mapped: list[MatchedEntry] = field(default_factory=list)
    surface_ties: list[tuple[str, Matching]] = field(default_factory=list)
    targets: list[TargetPoints] = field(default_factory=list)

    @property
    def links(self) -> np.ndarray:
        """(l, 2) node pairs joined by these constraints (for determinacy)."""
        parts = [np.c_[m.slaves, m.masters[:, 0]] for _, m in self.surface_ties]
        parts += [np.c_[e.matching.slaves, e.matching.masters[:, 0]] for e in self.mapped]
        return np.concatenate(parts) if parts else np.zeros((0, 2), np.int64)


def _perp_pair(t: np.ndarray) -> np.ndarray:
    a = np.eye(3)[int(np.argmin(np.abs(t)))]
    n1 = np.cross(t, a)
    n1 /= np.linalg.norm(n1)
    return np.stack([n1, np.cross(t, n1)])


def read_surface(surface: object, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a target surface: a file path or ``{"vertices", "triangles"}``.

    Raises
    ------
    SpecError
        An unreadable file, no triangles, or bad arrays.
    """
    if isinstance(surface, dict):
        try:
            V = np.asarray(surface["vertices"], dtype=np.float64).reshape(-1, 3)
            F = np.asarray(surface["triangles"], dtype=np.int64).reshape(-1, 3)
        except (TypeError, ValueError) as e:
            raise SpecError(f"{where}: vertices must be (n, 3) numbers and triangles (k, 3) indices ({e})",
                            field=where) from None
    else:
        import meshio

        path = str(surface)
        if not os.path.isfile(path):
            raise SpecError(f"{where}: no such surface file: {path}", code="file_not_found", field=where)
        try:
            m = meshio.read(path)
        except Exception as e:  # meshio raises many types
            raise SpecError(f"{where}: cannot read the surface {os.path.basename(path)!r}: {e}",
                            code="unreadable_file", field=where) from None
        V = np.asarray(m.points, np.float64)
        if V.shape[1] == 2:
            V = np.c_[V, np.zeros(len(V))]
        tris = [np.asarray(c.data, np.int64) for c in m.cells if c.type == "triangle"]
        F = np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)
    if not len(F):
        raise SpecError(f"{where}: the target surface has no triangles", field=where)
    if F.min() < 0 or F.max() >= len(V) or not np.isfinite(V).all():
        raise SpecError(f"{where}: triangle indices out of range or non-finite vertices", field=where)
    return V, F


def _faces_within(F: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return F[mask[F].all(axis=1)]


def _symmetry(mesh: Mesh, k: int, e: SymmetryEntry, tol: float, mid: np.ndarray) -> MatchedEntry:
    V, B = mesh.V, mesh.boundary
    n, c = np.asarray(e.normal), np.asarray(e.point)
    M, t = reflection(c, n)
    h = (V - c) @ n
    corner_b = B & mesh.referenced
    pos, neg, on = corner_b & (h > tol), corner_b & (h < -tol), corner_b & (np.abs(h) <= tol)
    # the positive side's faces, with those that cross the plane (nodes near it map onto them)
    faces = mesh.F[(h[mesh.F] > tol).any(axis=1) | (np.abs(h[mesh.F]) <= tol).all(axis=1)]
    m = match(V, np.flatnonzero(neg), np.flatnonzero(pos | on), faces, M, t, tol, f"SPEC.symmetry[{k}] ({e.name!r})")
    mm = None
    if mid.any():
        bm = _boundary_midside(mesh, mid)
        hm = (V - c) @ n
        mm = match(V, np.flatnonzero(bm & (hm < -tol)), np.flatnonzero((pos | on | bm) & (hm >= -tol)), faces, M, t,
                   tol, f"SPEC.symmetry[{k}] ({e.name!r}) mid-side nodes", require_all=False)
    inner, inner_on = interior_pairs(mesh, M, t, h, tol)
    return MatchedEntry("symmetry", k, e.name, m, np.flatnonzero(on), n[None, :], c, mm, inner, inner_on)


def _cyclic(mesh: Mesh, k: int, e: CyclicEntry, tol: float, sel_ids: dict[str, np.ndarray],
            mid: np.ndarray) -> MatchedEntry:
    V, B = mesh.V, mesh.boundary
    R, t = rotation(np.asarray(e.point), np.asarray(e.direction), e.angle_deg)
    a_ids, b_ids = sel_ids[e.faces[0]], sel_ids[e.faces[1]]
    in_a = np.zeros(mesh.n, bool)
    in_a[a_ids] = True
    in_b = np.zeros(mesh.n, bool)
    in_b[b_ids] = True
    corner_b = B & mesh.referenced
    o, d = np.asarray(e.point), np.asarray(e.direction)
    rel = V - o
    radial = np.linalg.norm(rel - np.outer(rel @ d, d), axis=1)
    on_axis = corner_b & (radial <= tol) & (in_a | in_b)
    masters = corner_b & in_a
    faces = _faces_within(mesh.F, masters)
    slaves = np.flatnonzero(corner_b & in_b & ~in_a & ~on_axis)
    m = match(V, slaves, np.flatnonzero(masters & ~on_axis), faces, R, t, tol, f"SPEC.cyclic[{k}] ({e.name!r})")
    mm = None
    if mid.any():
        bm = _boundary_midside(mesh, mid)
        mm = match(V, np.flatnonzero(bm & in_b & ~in_a), np.flatnonzero((masters | bm) & in_a), faces, R, t, tol,
                   f"SPEC.cyclic[{k}] ({e.name!r}) mid-side nodes", require_all=False)
    return MatchedEntry("cyclic", k, e.name, m, np.flatnonzero(on_axis), _perp_pair(d), o, mm)


def _boundary_midside(mesh: Mesh, mid: np.ndarray) -> np.ndarray:
    from .selection import node_masks

    _, on_b = node_masks(mesh)
    return mid & on_b


def _target(mesh: Mesh, k: int, e: TargetEntry, sel_ids: dict[str, np.ndarray], mid: np.ndarray,
            diag: float) -> TargetPoints:
    from .selection import node_masks

    where = f"SPEC.targets[{k}] ({e.name!r})"
    TV, TF = read_surface(e.surface, f"SPEC.targets[{k}].surface")
    surf = TriangleSurface(TV, TF)
    _, on_b = node_masks(mesh)
    ids_all = sel_ids[e.selection]
    ids_all = ids_all[on_b[ids_all]]
    ids, mids = ids_all[~mid[ids_all]], ids_all[mid[ids_all]]
    if not ids.size:
        raise SpecError(f"{where}: selection {e.selection!r} has no boundary node", code="empty_selection",
                        field=f"targets[{k}]")

    normals = _node_normals(mesh) if e.method == "normal" else None

    def project(nodes: np.ndarray) -> np.ndarray:
        P = mesh.V[nodes]
        cp = surf.closest(P)
        if normals is None:
            return cp.points
        hit = surf.along(P, normals[nodes])
        use = hit.tri >= 0
        if e.tolerance is not None:
            use &= hit.dist <= e.tolerance
        out = cp.points.copy()
        out[use] = hit.points[use]  # along the rest normal; the closest point where the line misses
        return out

    q = project(ids)
    mq = project(mids) if mids.size else np.zeros((0, 3))
    far = np.linalg.norm(q - mesh.V[ids], axis=1)
    if e.tolerance is not None and (far > e.tolerance).any():
        bad = ids[far > e.tolerance]
        raise SpecError(f"{where}: {bad.size} nodes are farther than {e.tolerance:g} from the target surface "
                        f"(largest {far.max():.3g})", code="target_too_far", nodes=bad[:MAX_IDS].tolist())
    return TargetPoints(k, e.name, ids, q, mids, mq, surf)


def _node_normals(mesh: Mesh) -> np.ndarray:
    """(n, 3) unit rest normals of boundary nodes (area-weighted face normals; mid-side: their edge's)."""
    from ..ops.elements import midside_edges

    F, V = mesh.F, mesh.V
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros((mesh.n, 3))
    for j in range(3):
        np.add.at(N, F[:, j], fn)
    if mesh.T10 is not None:
        mids, a, b = midside_edges(mesh.T10)
        N[mids] = N[a] + N[b]
    return N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)


def correspondences(mesh: Mesh, spec: ResolvedSpec, sel_ids: dict[str, np.ndarray], diag: float) -> Correspondences:
    """Resolve the symmetry, cyclic, surface-tie and target constraints of ``spec`` on ``mesh``.

    Raises
    ------
    ConstraintError
        ``unmatched_nodes`` when the two sides of a symmetry or cyclic constraint do not match.
    SpecError
        An unreadable target surface, a target selection without boundary nodes.
    """
    mid = midside_mask(mesh)
    mapped = [_symmetry(mesh, k, e, e.tolerance if e.tolerance is not None else SYMMETRY_TOL * diag, mid)
              for k, e in enumerate(spec.symmetry)]
    mapped += [_cyclic(mesh, k, e, e.tolerance if e.tolerance is not None else SYMMETRY_TOL * diag, sel_ids, mid)
               for k, e in enumerate(spec.cyclic)]
    ties = []
    if isinstance(spec.ties, dict) and spec.ties.get("surface"):
        tol = float(spec.ties.get("surface_tolerance", SURFACE_TIE_TOL * diag))
        B = mesh.boundary & mesh.referenced
        for k, (a, b) in enumerate(spec.ties["surface"]):
            in_b = np.zeros(mesh.n, bool)
            in_b[sel_ids[b]] = True
            faces = _faces_within(mesh.F, B & in_b)
            sl = sel_ids[a]
            sl = sl[B[sl] & ~in_b[sl]]
            m = match(mesh.V, sl, np.zeros(0, np.int64), faces, np.eye(3), np.zeros(3), tol,
                      f"SPEC.ties.surface[{k}]", require_all=False)
            if not m.slaves.size:
                raise SpecError(f"SPEC.ties.surface[{k}]: no boundary node of {a!r} lies within {tol:.3g} of the "
                                f"boundary faces of {b!r}", code="empty_selection", field="ties.surface")
            ties.append((f"surface:{a}-{b}", m))
    targets = [_target(mesh, k, e, sel_ids, mid, diag) for k, e in enumerate(spec.targets)]
    return Correspondences(mapped, ties, targets)
