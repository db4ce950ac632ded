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
    ``boss`` when they point away) or ``other``. The cylinder's axis may have
    any orientation: it is the null direction of the patch's normals, refined
    with the centre and radius on the vertices. A bore blended into its
    neighbours by a fillet or chamfer has no sharp edge around it; when no
    primitive fits a whole patch and the patch has a loop a bore could close
    (two border loops that are not small islands, or a handle), the cylinders that close around their
    axis are grown out of it and the rest is fitted again. Each candidate is a
    named vertex selection usable in a SPEC.
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
#: A cylinder found inside a larger patch is a bore (or a boss) when its vertices leave no gap
#: around the axis wider than this (radians); a fillet's quarter cylinder stays with its patch.
MAX_BORE_GAP = np.pi / 2
#: A seed ring whose vertices are farther than this (over the radius) from the circle fitted about
#: the normals' null direction is not fitted further (coarse gmsh cylinders stay below 0.03).
SEED_MISFIT = 0.05


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


def _plane_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to ``axis`` (unit) and to each other."""
    e1 = -axis[int(np.argmin(np.abs(axis)))] * axis
    e1[int(np.argmin(np.abs(axis)))] += 1.0
    e1 /= np.sqrt(e1 @ e1)
    a0, a1, a2 = axis
    return e1, np.array([a1 * e1[2] - a2 * e1[1], a2 * e1[0] - a0 * e1[2], a0 * e1[1] - a1 * e1[0]])


def _refine_cylinder(X: np.ndarray, axis: np.ndarray, base: np.ndarray, r: float, give_up: float | None = None
                     ) -> tuple[np.ndarray, np.ndarray, float]:
    """Gauss-Newton on the distances of ``X`` (centred points) to the cylinder surface.

    Each step tilts the axis, moves ``base`` (a point on the axis) in the plane
    orthogonal to it and changes the radius; the basis is rebuilt around the
    new axis, so the parametrisation stays free of singularities. With
    ``give_up``, the iteration stops after three steps whose rms distance is
    still above ``give_up`` times the radius: points on a cylinder are fitted
    to round-off by then.
    """
    def resid(ax: np.ndarray, c: np.ndarray, rho: float) -> tuple[np.ndarray, ...]:
        e1, e2 = _plane_basis(ax)
        Y = X @ np.column_stack([e1, e2, ax])
        x, y = Y[:, 0] - c @ e1, Y[:, 1] - c @ e2
        dist = np.maximum(np.hypot(x, y), 1e-300)
        return dist - rho, x / dist, y / dist, Y[:, 2] - c @ ax, e1, e2

    f, ux, uy, t, e1, e2 = resid(axis, base, r)
    cost = float(f @ f)
    for it in range(60):
        if give_up is not None and it >= 3 and cost > give_up ** 2 * r * r * X.shape[0]:
            break
        J = np.column_stack([-t * ux, -t * uy, -ux, -uy, -np.ones_like(t)])
        try:
            step = np.linalg.solve(J.T @ J, -(J.T @ f))
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(J, -f, rcond=None)[0]
        for _ in range(6):  # halve a step that does not lower the cost (none does once converged)
            ax = axis + step[0] * e1 + step[1] * e2
            ax /= np.sqrt(ax @ ax)
            c = base + step[2] * e1 + step[3] * e2
            c -= (c @ ax) * ax  # the axis point nearest the centroid
            res = resid(ax, c, r + step[4])
            cn = float(res[0] @ res[0])
            if cn <= cost:
                break
            step = 0.5 * step
        else:
            break
        small = np.abs(step[:2]).max() < 1e-15 and np.abs(step[2:]).max() < 1e-15 * max(r, 1e-300)
        axis, base, r = ax, c, r + float(step[4])
        f, ux, uy, t, e1, e2 = res
        if small or cn >= cost * (1 - 1e-14):
            break
        cost = cn
    return axis, base, r


def _fit_cylinder(P: np.ndarray, N: np.ndarray, w: np.ndarray, C: np.ndarray, give_up: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray, float, float, float, bool]:
    """Axis from the normals (they are orthogonal to it), circle fit in the orthogonal plane.

    The axis is the normals' null direction (the eigenvector of their
    area-weighted scatter with the smallest eigenvalue), so any orientation
    is found. The circle fit in the plane orthogonal to it is then refined
    by geometric least squares on the vertices: facet normals only
    approximate the axis, the vertices lie on the CAD surface.

    Returns ``axis, center, radius, rms, length, normals_point_inward``;
    ``give_up`` is passed to :func:`_refine_cylinder`.
    """
    _, vec = np.linalg.eigh((w[:, None] * N).T @ N)
    axis = vec[:, 0]
    e1, e2 = _plane_basis(axis)
    m0 = P.mean(axis=0)
    X = P - m0
    x, y = X @ e1, X @ e2
    # algebraic circle fit (Kasa): x^2 + y^2 = 2 a x + 2 b y + c
    M = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
    (a, b, c), *_ = np.linalg.lstsq(M, x ** 2 + y ** 2, rcond=None)
    r = float(np.sqrt(max(c + a * a + b * b, 0.0)))
    base = a * e1 + b * e2
    if P.shape[0] >= 6 and r > 0:
        axis, base, r = _refine_cylinder(X, axis, base, r, give_up)
    d = X - base
    t = d @ axis
    dist = np.linalg.norm(d - np.outer(t, axis), axis=1)
    center = m0 + base + float(t.mean()) * axis
    rms = float(np.sqrt(np.mean((dist - r) ** 2)))
    # face normals vs. the direction from the axis to each face centroid
    dc = C - m0 - base
    radial = dc - np.outer(dc @ axis, axis)
    radial /= np.maximum(np.linalg.norm(radial, axis=1), 1e-300)[:, None]
    inward = float((w * np.einsum("ij,ij->i", N, radial)).sum()) < 0
    return axis, center, r, rms, float(t.max() - t.min()), inward


def _cylinder_params(P: np.ndarray, N: np.ndarray, w: np.ndarray, C: np.ndarray) -> tuple[str, dict[str, Any]]:
    axis, center, r, rms, length, inward = _fit_cylinder(P, N, w, C)
    return ("hole" if inward else "boss"), {"axis": axis, "center": center, "radius": r, "length": length,
                                            "rms": rms}


def _fit_patch(V: np.ndarray, F: np.ndarray, N: np.ndarray, area: np.ndarray, fids: np.ndarray, tol: float,
               cos_sharp: float) -> tuple[str, float, np.ndarray, int, dict] | None:
    """The plane or cylinder that fits the faces ``fids`` within ``tol``, or None."""
    ids = unique(F[fids])
    P = V[ids]
    size = float(np.linalg.norm(P.max(0) - P.min(0)))
    w = area[fids]
    Cf = V[F[fids]].mean(axis=1)
    c, n, rms_plane = _fit_plane(Cf, w)
    side = np.sign((w * (N[fids] @ n)).sum())
    if rms_plane <= tol * size and float(np.min((N[fids] @ n) * side)) >= cos_sharp:
        return "plane", float(w.sum()), ids, fids.size, {"point": c, "normal": n * side, "rms": rms_plane}
    kind, params = _cylinder_params(P, N[fids], w, Cf)
    # the vertices (exactly on the CAD surface) decide; facet normals tilt by the faceting
    r = params["radius"]
    if r > 0 and params["rms"] <= tol * size and r < 10 * size:
        return kind, float(w.sum()), ids, fids.size, params
    return None


def _other(V: np.ndarray, F: np.ndarray, N: np.ndarray, area: np.ndarray, fids: np.ndarray
           ) -> tuple[str, float, np.ndarray, int, dict]:
    ids = unique(F[fids])
    w = area[fids]
    Cf = V[F[fids]].mean(axis=1)
    rms_plane = _fit_plane(Cf, w)[2]
    rms = _fit_cylinder(V[ids], N[fids], w, Cf)[3]
    return "other", float(w.sum()), ids, fids.size, {"rms": min(rms_plane, rms)}


def _off_cylinder(P: np.ndarray, axis: np.ndarray, center: np.ndarray, r: float) -> np.ndarray:
    """Distance of each point ``P`` (m, 3) from the cylinder surface."""
    d = P - center
    return np.abs(np.linalg.norm(d - np.outer(d @ axis, axis), axis=1) - r)


def _has_loops(V: np.ndarray, Fp: np.ndarray) -> bool:
    """Whether a patch (faces ``Fp``) has a loop that bounds no disk in it: two border loops, or a handle.

    A cylinder that closes around its axis is such a loop; a patch shaped as a
    disk or a sphere (an organic surface between sharp edges) holds none.
    Border loops shorter than 5% of the patch's size (the diagonal of its
    bounding box) are islands of small patches cut out of it, and do not count.
    """
    E = np.sort(np.concatenate([Fp[:, [0, 1]], Fp[:, [1, 2]], Fp[:, [2, 0]]]), axis=1)
    E, count = np.unique(E, axis=0, return_counts=True)
    ids = unique(Fp)
    chi = ids.size - E.shape[0] + Fp.shape[0]
    B = E[count == 1]
    loops = long = 0
    if B.size:
        vb, inv = np.unique(B, return_inverse=True)
        inv = inv.reshape(-1, 2)
        G = sp.coo_matrix((np.ones(inv.shape[0]), (inv[:, 0], inv[:, 1])), shape=(vb.size, vb.size))
        loops, lab = connected_components(G, directed=False)
        length = np.bincount(lab[inv[:, 0]], weights=np.linalg.norm(V[B[:, 0]] - V[B[:, 1]], axis=1),
                             minlength=loops)
        P = V[ids]
        long = int(np.count_nonzero(length >= 0.05 * np.linalg.norm(P.max(0) - P.min(0))))
    return long >= 2 or 2 - chi - loops >= 2


def _largest_gap(P: np.ndarray, axis: np.ndarray, center: np.ndarray) -> float:
    """The largest angle (radians) around ``axis`` between consecutive points of ``P``."""
    e1, e2 = _plane_basis(axis)
    d = P - center
    ang = np.sort(np.arctan2(d @ e2, d @ e1))
    return float(np.max(np.diff(np.concatenate([ang, ang[:1] + 2 * np.pi]))))


def _cylinders_inside(V: np.ndarray, F: np.ndarray, N: np.ndarray, area: np.ndarray, fids: np.ndarray,
                      smooth_pairs: np.ndarray, tol: float, min_faces: int
                      ) -> tuple[list[tuple[str, float, np.ndarray, int, dict]], list[np.ndarray]]:
    """The cylindrical regions inside a patch no primitive fits, and the rest of it.

    A seed face's two-ring of faces (by shared vertices) is fitted as a
    cylinder, with the axis of any orientation (the normals' null direction,
    refined on the vertices). The region then grows over the faces whose
    three vertices lie on that cylinder within ``tol`` times its radius, and
    is fitted again, until it no longer changes. A region of at least
    ``min_faces`` faces that still fits within ``tol`` is a hole or a boss;
    the seeds then move on to faces no region or failed seed has covered. Only
    regions that close around their axis (:data:`MAX_BORE_GAP`) are taken out.

    Returns
    -------
    cylinders : list of (kind, area, ids, faces, params)
    rest : list of int arrays
        The face indices of each edge-connected part that is left, with at
        least ``min_faces`` faces.
    """
    nf = fids.size
    local = np.full(F.shape[0], -1, np.int64)
    local[fids] = np.arange(nf)
    pa = local[smooth_pairs]
    pa = pa[(pa >= 0).all(axis=1)]
    # face-face graphs of the patch: by shared edges (growth) and shared vertices (seed rings)
    Gedge = sp.coo_matrix((np.ones(pa.shape[0]), (pa[:, 0], pa[:, 1])), shape=(nf, nf)).tocsr()
    Gedge = Gedge + Gedge.T
    ids, Fl = np.unique(F[fids], return_inverse=True)
    Fl = Fl.reshape(-1, 3)
    A = sp.csr_matrix((np.ones(3 * nf), (np.repeat(np.arange(nf), 3), Fl.ravel())), shape=(nf, ids.size))
    R1 = (A @ A.T).tocsr()
    P = V[ids]
    Nf = N[fids]
    Cf = V[F[fids]].mean(axis=1)
    w = area[fids]
    taken = np.zeros(nf, bool)  # in a cylinder
    tried = np.zeros(nf, bool)  # covered by a seed that grew no cylinder
    cylinders = []
    for seed in range(nf):
        if taken[seed] or tried[seed]:
            continue
        ring = R1[R1[seed].indices].indices  # the seed's two-ring
        ring = np.unique(ring[~taken[ring]])
        region = _grow_cylinder(ring, seed, P, Fl, Nf, Cf, w, Gedge, taken, tol)
        if region is None or region.size < min_faces:
            tried[ring] = True
            continue
        rid = unique(Fl[region])
        kind, params = _cylinder_params(P[rid], Nf[region], w[region], Cf[region])
        if _largest_gap(P[rid], params["axis"], params["center"]) > MAX_BORE_GAP:
            tried[region] = True  # part of a cylinder (a fillet), not a bore: left to the rest
            continue
        taken[region] = True
        cylinders.append((kind, float(w[region].sum()), ids[rid], int(region.size), params))
    left = np.flatnonzero(~taken)
    if not cylinders:
        return [], []
    ncomp, lab = connected_components(Gedge[left][:, left], directed=False)
    rest = [fids[left[lab == c]] for c in range(ncomp) if np.count_nonzero(lab == c) >= min_faces]
    return cylinders, rest


def _circle_misfit(Q: np.ndarray, N: np.ndarray, w: np.ndarray) -> float:
    """Largest distance of ``Q`` from its algebraic circle about the normals' null direction, over the radius."""
    _, vec = np.linalg.eigh((w[:, None] * N).T @ N)
    e1, e2 = _plane_basis(vec[:, 0])
    X = Q - Q.mean(axis=0)
    x, y = X @ e1, X @ e2
    (a, b, c), *_ = np.linalg.lstsq(np.column_stack([2 * x, 2 * y, np.ones_like(x)]), x * x + y * y, rcond=None)
    r = float(np.sqrt(max(c + a * a + b * b, 0.0)))
    return float(np.abs(np.hypot(x - a, y - b) - r).max()) / r if r > 0 else np.inf


def _grow_cylinder(ring: np.ndarray, seed: int, P: np.ndarray, Fl: np.ndarray, Nf: np.ndarray, Cf: np.ndarray,
                   w: np.ndarray, Gedge: sp.csr_matrix, taken: np.ndarray, tol: float) -> np.ndarray | None:
    """The faces (local indices) of the cylinder grown from a seed's ring, or None.

    The faces are grown within ``tol`` times the radius until the region is
    stable, then once more within a band set by the vertices' own scatter
    (20 robust standard deviations of their distances to the cylinder, and at
    least ``tol / 100`` times the radius), so that the first rows of a tangent
    fillet, close to the cylinder but not on it, are left out.
    """
    region = ring
    band = None
    tight = False
    for _ in range(12):
        vid = unique(Fl[region])
        Q = P[vid]
        if not w[region].sum() > 0:
            return None  # degenerate faces only
        lam = np.linalg.eigvalsh((w[region, None] * Nf[region]).T @ Nf[region])
        if lam[1] < 1e-8 * lam[2]:
            return None  # flat: the normals give no axis
        if band is None and _circle_misfit(Q, Nf[region], w[region]) > SEED_MISFIT:
            return None  # far from any cylinder: not worth the geometric fit
        axis, center, r, rms, _, _ = _fit_cylinder(Q, Nf[region], w[region], Cf[region], 2 * tol)
        size = float(np.linalg.norm(Q.max(0) - Q.min(0)))
        if not (0 < r < 10 * size) or rms > tol * r:
            return None
        if band is None or not tight:
            band = tol * r
        on = _off_cylinder(P, axis, center, r) <= band
        ok = on[Fl].all(axis=1) & ~taken
        okid = np.flatnonzero(ok)
        if not okid.size:
            return None
        ncomp, lab = connected_components(Gedge[okid][:, okid], directed=False)
        if not tight:  # the seed's part
            if not ok[seed]:
                return None
            part = lab[np.searchsorted(okid, seed)]
        else:  # the part that overlaps the region most (the seed may be a fillet's first row)
            hits = np.bincount(lab[np.isin(okid, region)], minlength=ncomp)
            if not hits.any():
                return None
            part = int(np.argmax(hits))
        grown = okid[lab == part]
        if np.array_equal(grown, region):
            if tight:
                return region
            dev = _off_cylinder(Q, axis, center, r)
            scatter = 1.4826 * float(np.median(dev))
            tight = True
            band = min(tol * r, max(20 * scatter, 0.01 * tol * r))
            continue
        region = grown
    return region


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
    cos_sharp = float(np.cos(np.radians(angle_deg)))
    for p in range(npatch):
        fids = np.flatnonzero(lab == p)
        if fids.size < min_faces:
            continue
        fit = _fit_patch(V, F, N, area, fids, tol, cos_sharp)
        if fit is not None:
            found.append(fit)
            continue
        # no primitive fits the whole patch: a bore blended into its neighbours by a fillet
        # or a chamfer has no sharp edge around it; take the cylinders out, fit what is left
        cyl, rest = (_cylinders_inside(V, F, N, area, fids, pairs[smooth], tol, min_faces)
                     if _has_loops(V, F[fids]) else ([], []))
        if not cyl:
            found.append(_other(V, F, N, area, fids))
            continue
        found.extend(cyl)
        for part in rest:
            fit = _fit_patch(V, F, N, area, part, tol, cos_sharp)
            found.append(fit if fit is not None else _other(V, F, N, area, part))
    out: list[FeatureCandidate] = []
    for kind in ("hole", "boss", "plane", "other"):
        mine = sorted((f for f in found if f[0] == kind), key=lambda f: -f[1])
        for k, (_, a, ids, nfc, params) in enumerate(mine, start=1):
            out.append(FeatureCandidate(f"{kind}_{k}", kind, ids, nfc, a, params))
    return out
