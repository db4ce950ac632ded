"""Form-feature regions on the boundary surface: min-cut extraction and automatic candidates.

Two tools (Masuda, Ogawa et al., "Preserving form features", §4.3 and §6):

:func:`feature_region`
    The user selects a band of the surface that contains the feature's
    border and separates the surface into exactly two parts; the border is
    the minimum cut of the band's face graph, with capacities that are small
    across sharp edges (Katz & Tal 2003, "Hierarchical mesh decomposition
    using fuzzy clustering and cuts", §3.4: ``1 / (1 + d / mean(d))`` with the
    angular distance ``d = 1 - cos(dihedral)``). The smaller part is the feature.
:func:`feature_candidates`
    The papers' future work, automated: the surface is split into patches at
    sharp edges (dihedral angle above a threshold), and each patch is fitted as
    a plane, a cylinder (a ``hole`` when its normals point at the axis, a
    ``boss`` when they point away) or ``other``. Each candidate is a named
    vertex selection usable in a SPEC.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components, maximum_flow

from ..errors import SpecError, format_ids
from ..mesh import Mesh
from ..ops.unique import unique

__all__ = ["FeatureCandidate", "feature_region", "feature_candidates", "face_adjacency"]

#: Integer scale of the max-flow capacities (scipy's maximum_flow takes integers).
CAPACITY_SCALE = 1_000_000


def _face_normals(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    area2 = np.linalg.norm(N, axis=1)
    return N / np.maximum(area2, 1e-300)[:, None], 0.5 * area2


def face_adjacency(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of faces that share an edge, and the shared edges.

    Parameters
    ----------
    F : (k, 3) int array
        Boundary faces (a closed manifold surface: each edge in two faces).

    Returns
    -------
    pairs : (e, 2) int array
        Face indices.
    edges : (e, 2) int array
        The shared edge's vertices.
    """
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    owner = np.tile(np.arange(F.shape[0]), 3)
    Es = np.sort(E, axis=1)
    order = np.lexsort((Es[:, 1], Es[:, 0]))
    Es, owner = Es[order], owner[order]
    same = np.all(Es[1:] == Es[:-1], axis=1)
    i = np.flatnonzero(same)
    return np.stack([owner[i], owner[i + 1]], axis=1), Es[i]


def _dihedral_cos(N: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Cosine of the angle between the normals of adjacent faces (1 = flat)."""
    return np.clip(np.einsum("ij,ij->i", N[pairs[:, 0]], N[pairs[:, 1]]), -1.0, 1.0)


def feature_region(mesh: Mesh, band: np.ndarray) -> dict[str, Any]:
    """The feature region bounded by the minimum cut through a band of the surface.

    Parameters
    ----------
    mesh : Mesh
    band : (k,) int array
        Boundary vertex ids. The boundary faces with all three vertices in
        ``band`` form the band; removing them must leave exactly two
        edge-connected parts of the surface.

    Returns
    -------
    dict
        ``ids`` (sorted vertex ids of the feature region, its border included),
        ``faces`` (its boundary face indices), ``cut_edges`` (the border as
        vertex pairs), ``cut_capacity`` (sum of the cut's capacities) and
        ``area``.

    Raises
    ------
    SpecError
        The band selects no face, or does not separate the surface into two
        parts (the message gives the count).
    """
    F = mesh.F
    V = mesh.V
    band = np.asarray(band, np.int64)
    inb = np.zeros(mesh.n, bool)
    inb[band] = True
    fband = inb[F].all(axis=1)
    if not fband.any():
        raise SpecError(f"the band ({band.size} vertices, first {format_ids(band, 5)}) contains no "
                        "boundary face (a face needs all three vertices in the band)", code="empty_band")
    pairs, edges = face_adjacency(F)
    nf = F.shape[0]
    out = np.flatnonzero(~fband)
    keep = ~fband[pairs].any(axis=1)
    G = sp.coo_matrix((np.ones(int(keep.sum())), (pairs[keep, 0], pairs[keep, 1])), shape=(nf, nf))
    ncomp, lab = connected_components(G, directed=False)
    parts = unique(lab[out])
    if parts.size != 2:
        raise SpecError(f"the band must separate the surface into exactly two parts; it leaves "
                        f"{parts.size}", code="band_not_separating", parts=int(parts.size))
    N, area = _face_normals(V, F)
    cosd = _dihedral_cos(N, pairs)
    dist = 1.0 - cosd
    mean = float(dist.mean()) if dist.size else 1.0
    cap = 1.0 / (1.0 + dist / max(mean, 1e-12))
    # network: band faces keep their index, part A collapses to the source, part B to the sink
    node = np.arange(nf)
    src, snk = nf, nf + 1
    node[lab == parts[0]] = src
    node[lab == parts[1]] = snk
    node[fband] = np.flatnonzero(fband)
    a, b = node[pairs[:, 0]], node[pairs[:, 1]]
    use = a != b
    ci = np.maximum(1, np.round(cap[use] * CAPACITY_SCALE)).astype(np.int32)
    rows = np.concatenate([a[use], b[use]])
    cols = np.concatenate([b[use], a[use]])
    C = sp.csr_matrix((np.concatenate([ci, ci]), (rows, cols)), shape=(nf + 2, nf + 2))
    C.sum_duplicates()
    res = maximum_flow(C, src, snk)
    residual = C - res.flow
    residual.data[residual.data < 0] = 0
    residual.eliminate_zeros()
    reach = breadth_first_order(residual, src, directed=True, return_predecessors=False)
    side = np.zeros(nf + 2, bool)
    side[reach] = True
    face_side = side[node]  # True: source side
    A_area, B_area = float(area[face_side].sum()), float(area[~face_side].sum())
    feat = face_side if A_area <= B_area else ~face_side
    fids = np.flatnonzero(feat)
    cut = feat[pairs[:, 0]] != feat[pairs[:, 1]]
    return {"ids": unique(F[fids]), "faces": fids, "cut_edges": edges[cut],
            "cut_capacity": int(res.flow_value), "area": float(area[fids].sum())}


@dataclass
class FeatureCandidate:
    """One surface patch between sharp edges, with its best-fitting primitive.

    Attributes
    ----------
    name : str
        ``plane_3``, ``hole_1``, ``boss_2``, ``other_4`` (numbered per kind).
    kind : {"plane", "hole", "boss", "other"}
    ids : (k,) int array
        Vertex ids of the patch (its border included).
    faces : int
        Number of boundary faces.
    area : float
    params : dict
        ``plane``: ``point``, ``normal``. ``hole``/``boss``: ``axis``
        (unit), ``center`` (a point on the axis), ``radius``, ``length``.
        Every kind: ``rms`` (fit residual, length units).
    """

    name: str
    kind: str
    ids: np.ndarray
    faces: int
    area: float
    params: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-compatible form; ``selection`` is ready to paste into a SPEC."""
        p = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.params.items()}
        return {"name": self.name, "kind": self.kind, "vertices": int(self.ids.size), "faces": self.faces,
                "area": self.area, **p, "selection": {"ids": self.ids.tolist()}}


def _fit_plane(P: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    c = (w[:, None] * P).sum(0) / w.sum()
    X = P - c
    _, vec = np.linalg.eigh((w[:, None] * X).T @ X)
    n = vec[:, 0]
    return c, n, float(np.sqrt(np.mean((X @ n) ** 2)))


def _fit_cylinder(P: np.ndarray, N: np.ndarray, w: np.ndarray, C: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, float, float, float, bool]:
    """Axis from the normals (they are orthogonal to it), circle fit in the orthogonal plane.

    Returns ``axis, center, radius, rms, length, normals_point_inward``.
    """
    _, vec = np.linalg.eigh((w[:, None] * N).T @ N)
    axis = vec[:, 0]
    e1 = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    x, y = P @ e1, P @ e2
    # algebraic circle fit (Kasa): x^2 + y^2 = 2 a x + 2 b y + c
    M = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
    (a, b, c), *_ = np.linalg.lstsq(M, x ** 2 + y ** 2, rcond=None)
    r = float(np.sqrt(max(c + a * a + b * b, 0.0)))
    # refine axis, centre and radius by geometric least squares on the vertices (facet normals
    # only approximate the axis; the vertices lie on the CAD surface)
    from scipy.optimize import least_squares

    def resid(q: np.ndarray) -> np.ndarray:
        ax = axis + q[0] * e1 + q[1] * e2
        ax = ax / np.linalg.norm(ax)
        cpt = (a + q[2]) * e1 + (b + q[3]) * e2
        d = P - cpt
        return np.linalg.norm(d - np.outer(d @ ax, ax), axis=1) - (r + q[4])

    if P.shape[0] >= 6 and r > 0:
        q = least_squares(resid, np.zeros(5), x_scale=np.array([1.0, 1.0, r, r, r]), xtol=1e-15,
                          ftol=1e-15, gtol=1e-15, max_nfev=200).x
        axis = axis + q[0] * e1 + q[1] * e2
        axis /= np.linalg.norm(axis)
        base = (a + q[2]) * e1 + (b + q[3]) * e2
        r += float(q[4])
        e1 = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
        a, b = float(base @ e1), float(base @ e2)
        x, y = P @ e1, P @ e2
    t = P @ axis
    center = a * e1 + b * e2 + float(t.mean()) * axis
    rms = float(np.sqrt(np.mean((np.hypot(x - a, y - b) - r) ** 2)))
    # face normals vs. the direction from the axis to each face centroid
    cx, cy = C @ e1 - a, C @ e2 - b
    radial = np.column_stack([cx, cy]) / np.maximum(np.hypot(cx, cy), 1e-300)[:, None]
    nr = (N @ e1) * radial[:, 0] + (N @ e2) * radial[:, 1]
    inward = float((w * nr).sum()) < 0
    return axis, center, r, rms, float(t.max() - t.min()), inward


def feature_candidates(mesh: Mesh, angle_deg: float = 30.0, tol: float = 1e-3,
                       min_faces: int = 4) -> list[FeatureCandidate]:
    """Segment the boundary at sharp edges and fit each patch as plane, cylinder or other.

    Parameters
    ----------
    mesh : Mesh
    angle_deg : float
        Edges whose faces' normals differ by more than this are sharp.
    tol : float
        A fit is accepted when its rms residual is at most ``tol`` times the
        patch size (the diagonal of its bounding box).
    min_faces : int
        Smaller patches are not reported.

    Returns
    -------
    list of FeatureCandidate
        Largest first within each kind; names numbered per kind.

    Examples
    --------
    >>> from solver.mesh import mesh_from_arrays
    >>> from solver.testing import cube_mesh
    >>> kinds = [c.kind for c in feature_candidates(mesh_from_arrays(*cube_mesh(3)))]
    >>> kinds.count("plane")
    6
    """
    F = mesh.F
    V = mesh.V
    if not F.size:
        return []
    N, area = _face_normals(V, F)
    pairs, _ = face_adjacency(F)
    smooth = _dihedral_cos(N, pairs) >= np.cos(np.radians(angle_deg))
    nf = F.shape[0]
    G = sp.coo_matrix((np.ones(int(smooth.sum())), (pairs[smooth, 0], pairs[smooth, 1])), shape=(nf, nf))
    npatch, lab = connected_components(G, directed=False)
    found: list[tuple[str, float, np.ndarray, int, dict]] = []
    for p in range(npatch):
        fids = np.flatnonzero(lab == p)
        if fids.size < min_faces:
            continue
        ids = unique(F[fids])
        P = V[ids]
        size = float(np.linalg.norm(P.max(0) - P.min(0)))
        w = area[fids]
        Cf = V[F[fids]].mean(axis=1)
        c, n, rms_plane = _fit_plane(Cf, w)
        flat = float(np.min((N[fids] @ n) * np.sign((w * (N[fids] @ n)).sum())))
        if rms_plane <= tol * size and flat >= np.cos(np.radians(angle_deg)):
            n = n * np.sign((w * (N[fids] @ n)).sum())
            found.append(("plane", float(w.sum()), ids, fids.size,
                          {"point": c, "normal": n, "rms": rms_plane}))
            continue
        axis, center, r, rms, length, inward = _fit_cylinder(P, N[fids], w, Cf)
        # the vertices (exactly on the CAD surface) decide; facet normals tilt by the faceting
        if r > 0 and rms <= tol * size and r < 10 * size:
            kind = "hole" if inward else "boss"
            found.append((kind, float(w.sum()), ids, fids.size,
                          {"axis": axis, "center": center, "radius": r, "length": length, "rms": rms}))
        else:
            found.append(("other", float(w.sum()), ids, fids.size, {"rms": min(rms_plane, rms)}))
    out: list[FeatureCandidate] = []
    for kind in ("hole", "boss", "plane", "other"):
        mine = sorted((f for f in found if f[0] == kind), key=lambda f: -f[1])
        for k, (_, a, ids, nfc, params) in enumerate(mine, start=1):
            out.append(FeatureCandidate(f"{kind}_{k}", kind, ids, nfc, a, params))
    return out
