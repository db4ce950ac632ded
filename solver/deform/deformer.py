"""Volumetric deformation of a tet mesh: precompute once, solve per handle move.

The method of Masuda & Ogawa, "Interactive deformation of 3D mesh models"
(eq. 4.1): boundary vertices keep their rotated mean curvature normals
``L(p_i) = R_i delta_i`` (eq. 3.1-3.2), interior vertices keep their mean value
coordinates in their one-ring local volume, weighted by ``1/S_i`` (eq. 2.5), and
fixed and handle vertices are hard positional constraints (eq. 2.6, 3.3).
The rotations ``R_i`` come from quaternion logarithms propagated over the
boundary (eq. 3.5-3.9; ECLS paper eq. 22-27).

Two position solves are offered:

``joint``
    The least-squares problem (4.2)/(4.3) over all vertices at once, hard
    constraints eliminated (the null-space method with a selection matrix).
``split``
    When no interior row is tied to a known vertex by the constraints, the
    interior rows of (4.2) can be met exactly for any boundary, so the joint
    optimum is: boundary vertices from the boundary rows alone, then interior
    vertices from the square mean-value system. Interior vertices that are
    constrained (fixed volumes) keep their known positions and their rows are
    dropped -- see the README for the measured difference to ``joint``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..constraints.rows import (
    assemble,
    block_targets,
    describe,
    position_blocks,
    rotation_blocks,
    tie_pairs,
)
from ..constraints.selection import select
from ..constraints.spec import INVERSION_POLICIES, HandleMove, Move, Spec, parse_move, parse_spec
from ..errors import ConstraintError, InversionError, SpecError, format_ids
from ..linalg import factorization as fz
from ..linalg.constrained import ConstrainedSolver, rank_analysis
from ..mesh import Mesh
from ..ops.boundary_facets import simplex_edges
from ..ops.cotmatrix import cotmatrix, uniform_matrix, voronoi_areas
from ..ops.elements import check_tets, element_edges
from ..ops.mvc_matrix import mvc_matrix
from ..ops.rotation import rotate_by_log
from ..validity.midside import MidsideNodes, node_jacobians
from ..validity.quality import DEGENERATE_TOL, element_jacobians, element_quality, summarize_quality
from ..validity.repair import repair_inverted

__all__ = ["Deformer", "DeformResult", "precompute"]

#: How many inverted element ids a REPORT lists.
REPORT_IDS = 100
#: Iterative-refinement steps of the least-squares (normal-equation) solves:
#: each recomputes the residual with the new positions and back-substitutes
#: once more. Normal equations square the condition number, which slivers make
#: large (screw.msh: rigid-motion error 6e-8 of the diagonal without, <1e-10 with).
REFINE_STEPS = 1
#: The refinement step is skipped when, for a probe move at set-up, it moves no
#: vertex by more than this fraction of the diagonal (Deformer.refine_probe).
REFINE_TOL = 1e-11
#: Bracket width of the safe-fraction bisection (10 halvings).
SAFE_TOL = 1.0 / 1024
#: A dropped constraint row whose residual exceeds this fraction of the mesh
#: diagonal (positions) or this many radians/2 (rotation logarithms) conflicts.
CONFLICT_TOL = 1e-9


@dataclass
class DeformResult:
    """Result of one update.

    Attributes
    ----------
    V : (n, 3) float64 array
        Deformed positions in file order (unreferenced vertices unchanged).
    report : dict
        The REPORT document.
    move : Move
        The MOVE that was applied (the scaled one when the policy clamped it).
    cell_quality : dict of str to (m,) array, optional
        Per-element metrics (``quality="full"``), see :func:`solver.validity.quality.element_quality`.
    """

    V: np.ndarray
    report: dict[str, Any]
    move: Move | None = None
    cell_quality: dict[str, np.ndarray] | None = None


def _csr(M: sp.spmatrix) -> sp.csr_matrix:
    M = sp.csr_matrix(M)
    M.sort_indices()
    return M


class Deformer:
    """Precomputed deformation of one mesh under one SPEC.

    Assembly and factorization happen in the constructor; :meth:`solve` only
    back-substitutes. The object is never mutated after construction, so one
    instance may serve concurrent updates.

    Parameters
    ----------
    mesh : Mesh
    spec : Spec or dict
        A parsed :class:`~solver.spec.Spec` or a SPEC document.
    progress : callable, optional
        ``progress(stage, fraction)`` is called as set-up advances, with
        ``stage`` in ``"constraints"`` (selections resolved and checked: every
        SPEC error has been raised by then), ``"assembly"``, ``"rotation"``,
        ``"positions"``, ``"done"`` and ``fraction`` in [0, 1].

    Raises
    ------
    SpecError
        Malformed SPEC, unknown or empty selections, overlapping handles, a
        vertex both fixed and in a handle.
    ConstraintError
        A body or a boundary shell (e.g. an internal void) has no constrained
        vertex, so its position would be undetermined.
    FactorizationError
        A system could not be factored.

    Examples
    --------
    >>> from solver.mesh import mesh_from_arrays
    >>> from solver.testing import cube_mesh
    >>> mesh = mesh_from_arrays(*cube_mesh(3))
    >>> d = Deformer(mesh, {"selections": {"bottom": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
    ...                                    "top": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
    ...                     "fixed": ["bottom"], "handles": {"top": "top"}})
    >>> r = d.solve({"handles": {"top": {"translation": [0.1, 0, 0]}}})
    >>> r.report["inverted_elements"], round(float(r.V[:, 0].max()), 6)
    (0, 1.1)
    """

    def __init__(self, mesh: Mesh, spec: Spec | dict[str, Any],
                 progress: Callable[[str, float], None] | None = None) -> None:
        t0 = time.perf_counter()
        report = progress or (lambda stage, fraction: None)
        self.mesh = mesh
        self.spec = spec if isinstance(spec, Spec) else parse_spec(spec)
        n = mesh.n
        V0 = mesh.V
        self._n_factor0 = fz.STATS["factorizations"]

        # --- constraints -------------------------------------------------------
        sel_ids = {name: select(mesh, sel, name) for name, sel in self.spec.selections.items()}
        fixed = np.unique(np.concatenate([sel_ids[f] for f in self.spec.fixed])) \
            if self.spec.fixed else np.zeros(0, np.int64)
        owner = np.full(n, -1, np.int64)  # -2 fixed, h >= 0 handle index
        owner[fixed] = -2
        self.handle_names = tuple(self.spec.handles)
        self.handle_ids: dict[str, np.ndarray] = {}
        self.handle_centroids: dict[str, np.ndarray] = {}
        for h, name in enumerate(self.handle_names):
            ids = sel_ids[self.spec.handles[name]]
            clash_fixed = ids[owner[ids] == -2]
            if clash_fixed.size:
                raise SpecError(f"handle {name!r} shares vertices {format_ids(clash_fixed)} with the "
                                "fixed selections", code="overlapping_constraints", handle=name,
                                ids=clash_fixed[:100].tolist())
            clash = ids[owner[ids] >= 0]
            if clash.size:
                other = self.handle_names[int(owner[clash[0]])]
                raise SpecError(f"handles {other!r} and {name!r} overlap at vertices "
                                f"{format_ids(clash)}", code="overlapping_constraints",
                                handles=[other, name], ids=clash[:100].tolist())
            owner[ids] = h
            self.handle_ids[name] = ids
            self.handle_centroids[name] = V0[ids].mean(axis=0)
        constrained = owner != -1
        self._owner = owner
        self.ties = tie_pairs(mesh, self.spec.ties)
        self._check_determined(constrained)
        self._blocks = position_blocks(mesh, self.spec, sel_ids, fixed, self.handle_ids,
                                       self.handle_centroids, self.ties)
        self._rblocks, self._rbasis = rotation_blocks(mesh, self.spec, sel_ids, fixed, self.handle_ids,
                                                      self.ties)
        self._vector = any(b.vector for b in self._blocks)
        general = [b for b in self._blocks if b.kind not in ("fixed", "handle")]
        touches_interior = any(mesh.interior[b.vert].any() for b in general)
        if self._free_shell.any():
            on_void = [b for b in self._blocks if self._free_shell[b.vert].any()]
            if on_void:
                raise SpecError(f"{on_void[0].kind} {on_void[0].name!r} uses vertices of an internal void that "
                                "has no fixed or handle vertex; fix or select a vertex of that void, or "
                                "drop the constraint", code="constraint_on_free_void")
            if self.spec.solve == "split":
                raise SpecError("SPEC.solve 'split' cannot position an internal void with no fixed or handle "
                                "vertex (its translation comes from the interior's mean-value rows); use "
                                "'joint' or 'auto'", field="solve")
            touches_interior = True  # auto: the joint solve
        mode = self.spec.solve
        if mode == "split" and touches_interior:
            b = next(b for b in general if mesh.interior[b.vert].any())
            raise SpecError(f"SPEC.solve 'split' needs every constraint other than fixed and handle "
                            f"vertices on the boundary; {b.kind} {b.name!r} uses interior vertices "
                            f"{format_ids(b.vert[mesh.interior[b.vert]])}. Use 'joint' or 'auto'.",
                            field="solve", kind=b.kind, name=b.name)
        if self.spec.method == "penalty" or (mode == "auto" and touches_interior):
            mode = "joint"
        elif mode == "auto":
            mode = "split"
        self.solve_mode = mode
        self._analyse_constraints()
        report("constraints", 0.05)

        # --- operators -----------------------------------------------------------
        B = mesh.boundary
        I = mesh.interior
        F = mesh.F
        if self.spec.laplacian == "cotangent":
            K = cotmatrix(V0, F, n)
            A = voronoi_areas(V0, F, n)
            wb = np.zeros(n)
            wb[B] = 1.0 / (2.0 * A[B])  # L(p_i) = (K p)_i / (2 A_i), eq. (3.1)
        else:
            K = uniform_matrix(F, n)
            val = K.diagonal()
            wb = np.zeros(n)
            wb[B] = 1.0 / val[B]  # L(p_i) = p_i - mean of neighbours
        Lb = _csr(sp.diags(wb) @ K)  # boundary rows; zero rows elsewhere
        self._delta = Lb @ V0  # original mean curvature normals delta_i
        self._wall_rows(Lb)
        if I.any():
            W, S = mvc_matrix(V0, mesh.T, I, mesh.cells)
            wi = np.zeros(n)
            wi[I] = 1.0 / S[I]  # eq. (2.5)
            Mi = _csr(sp.diags(I.astype(float)) - W)  # p_i - sum w_ij p_j on interior rows
        else:
            wi = np.zeros(n)
            Mi = sp.csr_matrix((n, n))
        t_assembly = time.perf_counter() - t0
        report("assembly", 0.35)

        # --- rotation field ------------------------------------------------------
        t1 = time.perf_counter()
        self._Phi = self._rotation_basis(K, Lb, B, owner)
        t_rot = time.perf_counter() - t1
        report("rotation", 0.5)

        # --- positions -------------------------------------------------------------
        t2 = time.perf_counter()
        self._constrained = np.flatnonzero(constrained)
        if mode == "joint":
            self._setup_joint(Lb, Mi, wi)
        else:
            self._setup_split(Lb, Mi, constrained)
        self._bpos = np.full(n, -1, np.int64)
        self._bpos[self._bidx] = np.arange(self._bidx.size)
        self.refine_steps = REFINE_STEPS
        self.refine_probe = self._probe_refinement()
        if self.refine_probe <= REFINE_TOL * self._diag:
            self.refine_steps = 0
        t_pos = time.perf_counter() - t2
        report("positions", 0.95)

        self._T = np.ascontiguousarray(mesh.T)
        self._mid = MidsideNodes(V0, mesh.T10) if mesh.T10 is not None else None
        # quadratic elements already folded in the input (node Jacobian <= 0) are reported, not counted
        self._valid_rest = node_jacobians(V0, mesh.T10).min(axis=1) > 0 if mesh.T10 is not None else None
        sj = self._bad_elements(V0)[1] if not mesh.is_surface else np.zeros(0)
        self._sj_before = (float(sj.min()) if sj.size else None,
                           float(np.partition(sj, sj.size // 100)[sj.size // 100]) if sj.size else None)
        self.setup_timings = {
            "assembly_ms": 1e3 * t_assembly,
            "rotation_factorization_ms": 1e3 * t_rot,
            "position_factorization_ms": 1e3 * t_pos,
            "total_ms": 1e3 * (time.perf_counter() - t0),
        }
        self.factorizations = fz.STATS["factorizations"] - self._n_factor0
        report("done", 1.0)

    @property
    def nbytes(self) -> int:
        """Memory held by the factors, operators and rotation basis, in bytes."""
        total = int(self._Phi.nbytes + self._delta.nbytes)
        for name in ("_psys", "_finter"):
            f = getattr(self, name, None)
            if f is not None:
                total += int(f.nbytes)
        for name in ("_Mfi",):
            M = getattr(self, name, None)
            if M is not None:
                total += int(M.data.nbytes + M.indices.nbytes + M.indptr.nbytes)
        if self._psys is not None and self._psys.A is not None:
            for M in (self._psys.A, self._psys.At):
                total += int(M.data.nbytes + M.indices.nbytes + M.indptr.nbytes)
        return total

    def parse_move(self, move: Move | dict[str, Any]) -> Move:
        """Parse a MOVE document against this SPEC's handle and constraint names."""
        if isinstance(move, Move):
            return move
        sp_ = self.spec
        names = {"points": [e["name"] for e in sp_.points], "relative": [e["name"] for e in sp_.relative],
                 "features": [e["name"] for e in sp_.features], "motion": [e["name"] for e in sp_.motion]}
        return parse_move(move, self.handle_names, names)

    def _analyse_constraints(self) -> None:
        """Assemble the hard constraint rows, find dependent ones, and check them at rest.

        Runs before any factorization, so a SPEC whose constraints conflict
        with ``"conflicts": "reject"`` is refused at the "constraints" stage.
        Sets ``self.rest_constraints`` (redundant and conflicting entries with
        every handle at rest).
        """
        mesh = self.mesh
        V0 = mesh.V
        self._diag = float(np.linalg.norm(V0[mesh.referenced].max(0) - V0[mesh.referenced].min(0)))
        self._conflict_tol = CONFLICT_TOL * max(self._diag, 1e-300)
        self._bidx = np.flatnonzero(mesh.boundary)
        unknowns = self._bidx if self.solve_mode == "split" else np.flatnonzero(mesh.referenced)
        self._unknowns = unknowns
        self._pasm = self._pra = None
        if unknowns.size:
            umap = np.full(mesh.n, -1, np.int64)
            umap[unknowns] = np.arange(unknowns.size)
            self._pasm = assemble(self._blocks, umap, unknowns.size, self._vector)
            self._pra = rank_analysis(self._pasm.C)
        self._rasm = self._rra = None
        self._rbidx = self._bidx[~self._free_shell[self._bidx]]  # rotation unknowns
        if self.handle_names and self._rbidx.size:
            umap = np.full(mesh.n, -1, np.int64)
            umap[self._rbidx] = np.arange(self._rbidx.size)
            self._rasm = assemble(self._rblocks, umap, self._rbidx.size, vector=False)
            self._rra = rank_analysis(self._rasm.C)
        redundant, conflicting = [], []
        if self._pra is not None and not self._pra.kept.all():
            d = block_targets(self._blocks, self._pasm, Move({}), lambda ids: np.zeros((len(ids), 3)))
            res = self._pra.dropped_residuals(self._pasm.C, d)
            drop = np.flatnonzero(~self._pra.kept)
            bad = res > self._conflict_tol
            redundant += describe(self._blocks, self._pasm, drop[~bad], "positions")
            conflicting += describe(self._blocks, self._pasm, drop[bad], "positions", res[bad])
        if self._rra is not None:  # at rest every rotation target is 0: dropped rows are redundant
            redundant += describe(self._rblocks, self._rasm, np.flatnonzero(~self._rra.kept), "rotations")
        self.rest_constraints = {"redundant_constraints": redundant, "conflicting_constraints": conflicting}
        if conflicting and self.spec.conflicts == "reject":
            raise ConstraintError(
                f"{len(conflicting)} hard constraints conflict with the ones before them (first: "
                f"{_entry_text(conflicting[0])}); SPEC.conflicts is 'reject'",
                code="conflicting_constraints", conflicting_constraints=conflicting,
                redundant_constraints=redundant)

    # ------------------------------------------------------------------ checks
    def _check_determined(self, constrained: np.ndarray) -> None:
        mesh = self.mesh
        bodies = mesh.body_labels
        nb = int(bodies.max()) + 1
        has = np.zeros(nb, bool)
        has[bodies[constrained & mesh.referenced]] = True
        has = _spread(has, bodies, self.ties)  # a body tied to a held one is held
        if not has.all():
            b = int(np.flatnonzero(~has)[0])
            verts = np.flatnonzero(bodies == b)
            raise ConstraintError(
                f"body {b} of {nb} ({verts.size} vertices, first {format_ids(verts, 5)}) has no fixed "
                "or handle vertex: its position is undetermined. Add a selection that touches it.",
                code="unconstrained_component", component=b, vertices=int(verts.size))
        shells = mesh.shell_labels
        ns = int(shells.max()) + 1 if mesh.boundary.any() else 0
        has_s = np.zeros(ns, bool)
        has_s[shells[constrained & mesh.boundary]] = True
        if ns:
            tb = self.ties[mesh.boundary[self.ties].all(axis=1)] if len(self.ties) else self.ties
            has_s = _spread(has_s, shells, tb)
        self._free_shell = np.zeros(mesh.n, bool)
        if ns and not has_s.all() and self.spec.voids == "volume":
            # internal voids: positioned by the surrounding volume (rotation extended through the
            # tets, translation by the interior's mean-value rows in the joint solve)
            self._free_shell = mesh.boundary & ~has_s[np.maximum(shells, 0)]
            has_s[:] = True
        if ns and not has_s.all():
            s = int(np.flatnonzero(~has_s)[0])
            verts = np.flatnonzero(shells == s)
            raise ConstraintError(
                f"boundary shell {s} of {ns} ({verts.size} vertices, first {format_ids(verts, 5)}) has "
                "no fixed or handle vertex. It is an internal void or an unconstrained surface: the "
                "method's rotation and boundary systems leave its rigid motion undetermined. Add a "
                "selection on it (e.g. fix it, or select it with a sphere/box).",
                code="unconstrained_shell", shell=s, vertices=int(verts.size))

    # --------------------------------------------------------------- rotations
    def _rotation_basis(self, K: sp.csr_matrix, Lb: sp.csr_matrix, B: np.ndarray,
                        owner: np.ndarray) -> np.ndarray:
        """Harmonic basis ``Phi`` (n_B, H): rotation field = ``Phi @ log_rotations``.

        With rotations prescribed per handle (``c_h`` on handle ``h``, 0 on
        fixed vertices; eq. 3.6, ECLS eq. 26-27), tied together on rigid
        features and held at 0 on ``keep_direction`` features (ECLS eq. 29,
        Form features §3.1), the solution of (3.5)/(25) is linear in the
        ``c_h``: ``r = sum_h phi_h c_h``. One factorization (by the SPEC's
        constraint method), one back-substitution per handle.
        """
        H = len(self.handle_names)
        self._rsys = None
        if H == 0 or self._rbidx.size == 0:
            return np.zeros((self._bidx.size, H))
        bidx = self._rbidx
        Kb = K[bidx][:, bidx]
        if self.spec.rotation == "harmonic":
            Q = Kb
        else:
            Lbb = Lb[bidx][:, bidx]
            Q = (Lbb.T @ Lbb).tocsr()
        D = np.zeros((self._rasm.C.shape[0], H))
        for b_i, t in enumerate(self._rbasis):
            rows = self._rasm.block == b_i
            D[rows] = t[self._rasm.local[rows]]
        self._rD = D
        self._rsys = ConstrainedSolver(self._rasm.C, H=Q, method=self.spec.method,
                                       beta=self.spec.penalty_weight, what="rotation system",
                                       analysis=self._rra)
        Phi = self._rsys.solve(np.zeros((bidx.size, H)), D, None, refine=REFINE_STEPS)
        # residual of every row per unit handle rotation: dropped rows reveal conflicts
        self._rres = self._rasm.C @ Phi - D
        if bidx.size == self._bidx.size:
            return Phi
        full = np.zeros((self._bidx.size, H))
        full[np.searchsorted(self._bidx, bidx)] = Phi
        void = self._bidx[self._free_shell[self._bidx]]
        full[np.searchsorted(self._bidx, void)] = self._extend_rotations(bidx, Phi, void)
        return full

    def _extend_rotations(self, known: np.ndarray, Phi: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """Rotation basis at internal-void vertices: the harmonic extension of the outer
        shells' field through the tets (graph Laplacian of the tet edges, Dirichlet on
        ``known``), so a void turns with the volume around it."""
        mesh = self.mesh
        n = mesh.n
        Lv = uniform_matrix(mesh.edges if mesh.cells else mesh.T, n)
        isknown = np.zeros(n, bool)
        isknown[known] = True
        u = np.flatnonzero(mesh.referenced & ~isknown)
        f = fz.cholesky(Lv[u][:, u].tocsc(), "void rotation extension")
        X = f.solve(-(Lv[u][:, known] @ Phi))
        return X[np.searchsorted(u, targets)]

    # --------------------------------------------------------------- positions
    def _layout(self, X: np.ndarray) -> np.ndarray:
        """(k, 3) per-vertex array -> the position system's layout."""
        return X.reshape(-1, 1) if self._vector else X

    def _unlayout(self, x: np.ndarray) -> np.ndarray:
        return x.reshape(-1, 3) if self._vector else x

    def _position_system(self, A: sp.csr_matrix, what: str) -> None:
        if self._vector:
            A = sp.kron(A, sp.identity(3), format="csr")
        self._psys = ConstrainedSolver(self._pasm.C, A=A, method=self.spec.method,
                                       beta=self.spec.penalty_weight, what=what, analysis=self._pra)

    def _wall_rows(self, Lb: sp.csr_matrix) -> None:
        """Rows tying the two faces of walls one tet thick (``SPEC.thin_walls``).

        A tet whose four vertices are all on the boundary gets no mean-value
        row: nothing in the paper's system holds the wall's thickness, and
        such walls invert first (measured on kiefer_fea_bracket.vtu). For
        every edge of such a tet that is not an edge of the boundary surface
        (it crosses the wall), a soft row ``w_ij (p_i - p_j) = w_ij s R_ij
        (p0_i - p0_j)`` keeps the edge's rest vector, turned and scaled by
        the rotation field averaged over its two ends. ``w_ij = thin_walls *
        sqrt(|L_ii| |L_jj|)`` matches the boundary rows' magnitude. Meshes
        without all-boundary tets are unchanged.
        """
        mesh = self.mesh
        self._wall = None
        if self.spec.thin_walls <= 0 or mesh.is_surface:
            return
        parts = []
        for kind, B in mesh.blocks:  # elements with every node on the boundary
            B = B[mesh.boundary[B].all(axis=1)]
            if len(B):
                parts.append(simplex_edges(B) if kind == "tetra" else element_edges(B, kind))
        if not parts:
            return
        E = np.unique(np.sort(np.concatenate(parts), axis=1), axis=0)
        FE = simplex_edges(mesh.F)
        n = mesh.n
        key = E[:, 0] * n + E[:, 1]
        E = E[~np.isin(key, FE[:, 0] * n + FE[:, 1])]
        if not E.size:
            return
        d = np.abs(Lb.diagonal())
        w = self.spec.thin_walls * np.sqrt(d[E[:, 0]] * d[E[:, 1]])
        self._wall = (E, w, mesh.V[E[:, 0]] - mesh.V[E[:, 1]])

    def _wall_matrix(self, unknowns: np.ndarray) -> sp.csr_matrix | None:
        if self._wall is None:
            return None
        E, w, _ = self._wall
        umap = np.full(self.mesh.n, -1, np.int64)
        umap[unknowns] = np.arange(unknowns.size)
        k = np.arange(E.shape[0])
        return sp.csr_matrix((np.r_[w, -w], (np.r_[k, k], np.r_[umap[E[:, 0]], umap[E[:, 1]]])),
                             shape=(E.shape[0], unknowns.size))

    def _soft_rhs(self, b: np.ndarray, r: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """Right-hand side of the position system's soft rows: vertex rows, then wall rows."""
        c = b[self._rows]
        if self._wall is None:
            return c
        E, w, D0 = self._wall
        bp = self._bpos
        rr = 0.5 * (r[bp[E[:, 0]]] + r[bp[E[:, 1]]])
        s = np.exp(0.5 * (sigma[bp[E[:, 0]]] + sigma[bp[E[:, 1]]]))
        return np.vstack([c, (w * s)[:, None] * rotate_by_log(D0, rr)])

    def _setup_joint(self, Lb: sp.csr_matrix, Mi: sp.csr_matrix, wi: np.ndarray) -> None:
        ref = np.flatnonzero(self.mesh.referenced)
        A = _csr(Lb + sp.diags(wi) @ Mi)  # every row of eq. (4.2), weighted
        self._rows = ref  # row r of the system is vertex ref[r]
        self._fi = np.zeros(0, np.int64)
        A = _csr(A[ref][:, ref])
        Wm = self._wall_matrix(ref)
        if Wm is not None:
            A = _csr(sp.vstack([A, Wm]))
        self._position_system(A, "position system (joint)")

    def _setup_split(self, Lb: sp.csr_matrix, Mi: sp.csr_matrix, constrained: np.ndarray) -> None:
        mesh = self.mesh
        bidx = self._bidx
        self._rows = bidx
        self._psys = None
        if bidx.size:
            A = _csr(Lb[bidx][:, bidx])
            Wm = self._wall_matrix(bidx)
            if Wm is not None:
                A = _csr(sp.vstack([A, Wm]))
            self._position_system(A, "boundary position system")
        # interior: square MVC system of the free interior vertices
        self._fi = np.flatnonzero(mesh.interior & ~constrained & mesh.referenced)
        if self._fi.size:
            Mfi = Mi[self._fi]
            self._Mfi = _csr(Mfi)
            self._finter = fz.lu(Mfi[:, self._fi].tocsc(), "interior mean-value system")

    # ------------------------------------------------------------------ update
    def targets(self, move: Move) -> np.ndarray:
        """Target positions (k, 3) of the fixed and handle vertices, in ``self._constrained`` order."""
        V0 = self.mesh.V
        U = V0[self._constrained].copy()
        own = self._owner[self._constrained]
        for h, name in enumerate(self.handle_names):
            hm = move.handles.get(name)
            if hm is None:
                continue
            rows = np.flatnonzero(own == h)
            U[rows] = hm.apply(V0[self._constrained[rows]], self.handle_centroids[name])
        return U

    def rotation_field(self, move: Move) -> tuple[np.ndarray, np.ndarray]:
        """Quaternion logarithms (n_B, 3) and log-scales (n_B,) of the boundary vertices."""
        C, s = self._handle_logs(move)
        return self._Phi @ C, self._Phi @ s

    def _handle_logs(self, move: Move) -> tuple[np.ndarray, np.ndarray]:
        H = len(self.handle_names)
        C = np.zeros((H, 3))
        s = np.zeros(H)
        for h, name in enumerate(self.handle_names):
            hm = move.handles.get(name)
            if hm is not None:
                C[h] = hm.log_rotation
                s[h] = np.log(hm.scale)
        return C, s

    def _right_hand_sides(self, mv: Move) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Fixed/handle targets U (k, 3), the soft rows' right-hand side c (rotated normals,
        eq. 3.2, then thin-wall rows) and the hard rows' targets d."""
        U = self.targets(mv)
        r, sigma = self.rotation_field(mv)
        bpos = self._bpos

        def rot_at(ids: np.ndarray) -> np.ndarray:
            return r[bpos[ids]]

        b = np.zeros((self.mesh.n, 3))
        if self._bidx.size:
            b[self._bidx] = np.exp(sigma)[:, None] * rotate_by_log(self._delta[self._bidx], r)
        d = block_targets(self._blocks, self._pasm, mv, rot_at) if self._psys is not None else None
        return U, self._soft_rhs(b, r, sigma), d

    def _probe_refinement(self) -> float:
        """Size of the refinement step for a probe move (every handle turned 10° and moved 1%).

        Residual form makes one back-substitution exact to round-off on
        well-conditioned systems; slivers (large condition numbers) need the
        refinement step. Returns the step's largest vertex correction.
        """
        if self._psys is None or not self.handle_names:
            return 0.0
        axis = np.array([0.36, 0.48, 0.8])
        mv = Move({h: HandleMove(0.01 * self._diag * axis, np.radians(10.0) / 2 * axis)
                   for h in self.handle_names})
        _, b, d = self._right_hand_sides(mv)
        sysp = self._psys
        x = sysp.start(self._layout(self.mesh.V[self._unknowns]), d)
        c = self._layout(b)
        x = x + sysp.step(sysp.gradient(x, c), x, d)
        dx = sysp.step(sysp.gradient(x, c), x, d)
        return float(np.abs(dx).max())

    def solve_positions(self, mv: Move) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Positions for a parsed MOVE: ``(P, U, d)`` -- positions (n, 3), fixed/handle
        targets (k, 3) and the position system's row targets (or None)."""
        U, b, d = self._right_hand_sides(mv)
        # Residual form: every system is solved for the displacement of the free
        # vertices from their rest positions, so round-off scales with the change,
        # not with the coordinates (a zero move gives exactly the rest shape).
        V0 = self.mesh.V
        P = V0.copy()
        P[self._constrained] = U
        if self._psys is not None:
            u = self._unknowns
            x = self._psys.solve(self._layout(V0[u]), d, self._layout(b),
                                 refine=self.refine_steps)
            P[u] = self._unlayout(x)
        if self._fi.size:
            P[self._fi] -= self._finter.solve(self._Mfi @ P)
        if getattr(self, "_mid", None) is not None:
            P = self._mid.place(P, self._valid_rest)  # quadratic: mid-side nodes follow their edges
        return P, U, d

    def constraint_report(self, solved: tuple[np.ndarray, np.ndarray, np.ndarray | None],
                          mv: Move) -> dict[str, Any]:
        """Residuals, redundant and conflicting constraints of a solve (ECLS §5)."""
        P, U, d = solved
        res_max = float(np.abs(P[self._constrained] - U).max()) if U.size else 0.0
        redundant: list[dict[str, Any]] = []
        conflicting: list[dict[str, Any]] = []
        rows = {"rows": 0, "dropped": 0}
        tol = self._conflict_tol
        if self._psys is not None and d is not None:
            x = self._layout(P[self._unknowns])
            res = self._psys.residuals(x, d)
            kept = self._psys.kept
            rows["rows"] += int(kept.size)
            if kept.any():
                res_max = max(res_max, float(res[kept].max()))
            drop = np.flatnonzero(~kept)
            rows["dropped"] += int(drop.size)
            bad = res[drop] > tol
            redundant += describe(self._blocks, self._pasm, drop[~bad], "positions")
            conflicting += describe(self._blocks, self._pasm, drop[bad], "positions", res[drop[bad]])
        if self._rsys is not None:
            C, s = self._handle_logs(mv)
            rres = np.abs(self._rres @ np.column_stack([C, s])).max(axis=1) \
                if self._rres.shape[0] else np.zeros(0)
            kept = self._rsys.kept
            rows["rows"] += int(kept.size)
            drop = np.flatnonzero(~kept)
            rows["dropped"] += int(drop.size)
            bad = rres[drop] > CONFLICT_TOL
            redundant += describe(self._rblocks, self._rasm, drop[~bad], "rotations")
            conflicting += describe(self._rblocks, self._rasm, drop[bad], "rotations", rres[drop[bad]])
        return {"constraint_residual_max": res_max, "constraint_rows": rows,
                "redundant_constraints": redundant, "conflicting_constraints": conflicting}

    # --------------------------------------------------------------- safe step
    def scaled_move(self, mv: Move, f: float) -> Move:
        """The MOVE scaled by ``f`` in [0, 1]: ``f = 0`` is the rest shape, ``f = 1`` the MOVE.

        Handles: translation ``f t``, rotation angle ``f θ``, scale ``s^f``.
        Point and motion targets and relative offsets: ``rest + f (target - rest)``.
        Feature and relative scales: ``s^f``.
        """
        V0 = self.mesh.V
        handles = {k: h.interpolate(f) for k, h in mv.handles.items()}
        rest: dict[tuple[str, str], np.ndarray] = {}
        for b in self._blocks:
            if b.kind in ("point", "motion"):
                rest[(b.kind, b.name)] = b.coeff[b.row == 0] @ V0[b.vert[b.row == 0]]
        points = {}
        for e in self.spec.points:
            target = mv.points.get(e["name"], np.asarray(e["target"]) if "target" in e else None)
            if target is not None:
                r0 = rest[("point", e["name"])]
                points[e["name"]] = r0 + f * (np.asarray(target) - r0)
        motion = {k: rest[("motion", k)] + f * (v - rest[("motion", k)]) for k, v in mv.motion.items()}
        relative = {}
        for k, v in mv.relative.items():
            if "offset" in v:
                i, j = next(e["vertices"] for e in self.spec.relative if e["name"] == k)
                r0 = V0[i] - V0[j]
                relative[k] = {"offset": r0 + f * (v["offset"] - r0)}
            else:
                relative[k] = {"scale": v["scale"] ** f}
        features = {k: v ** f for k, v in mv.features.items()}
        return Move(handles, points, relative, features, motion)

    def _bad_elements(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """(bad mask, scaled Jacobian of every element (:func:`element_jacobians`), degenerate
        mask, node Jacobians (m, 10) of quadratic elements or None); quadratic elements are
        also bad when their Jacobian is <= 0 at any of their ten nodes."""
        vol6, sj = element_jacobians(P, self._T, self.mesh.cells)
        degenerate = np.abs(sj) <= DEGENERATE_TOL
        bad = (vol6 <= 0) | degenerate
        dj = None
        if self.mesh.T10 is not None:
            known = self._mid.jacobians if getattr(self, "_mid", None) is not None else None
            dj = known[1] if known is not None and known[0] is P else node_jacobians(P, self.mesh.T10)
            bad |= (dj.min(axis=1) <= 0) & self._valid_rest
        return bad, sj, degenerate, dj

    def _inverted(self, P: np.ndarray) -> int:
        return int(np.count_nonzero(self._bad_elements(P)[0]))

    def safe_fraction(self, move: Move | dict[str, Any], tol: float = SAFE_TOL,
                      inverts: bool | None = None) -> tuple[float, int]:
        """Largest fraction of a MOVE that inverts no element, by bisection.

        Each step is one back-substitution and one volume check (no
        refactorization). ``f = 0`` (the rest shape) is valid because inputs
        with inverted elements are refused.

        Parameters
        ----------
        move : Move or dict
        tol : float
            Width of the final bracket in ``f``.
        inverts : bool, optional
            Whether the whole MOVE is known to invert (saves one solve).

        Returns
        -------
        f : float
            1.0 when the whole MOVE is valid; else the valid end of the final
            bracket (``[f, f + tol]`` contains the first inverting fraction
            that bisection meets).
        steps : int
            Solves used.
        """
        mv = self.parse_move(move)
        if self.mesh.is_surface:
            return 1.0, 0
        steps = 0
        if inverts is None:
            steps = 1
            inverts = self._inverted(self.solve_positions(mv)[0]) > 0
        if not inverts:
            return 1.0, steps
        lo, hi = 0.0, 1.0
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            steps += 1
            if self._inverted(self.solve_positions(self.scaled_move(mv, mid))[0]) == 0:
                lo = mid
            else:
                hi = mid
        return lo, steps

    @property
    def quality_before(self) -> dict[str, Any]:
        """Summary of every quality metric of the rest mesh (computed once)."""
        if getattr(self, "_quality_before", None) is None:
            self._quality_before = summarize_quality(element_quality(self.mesh.V, self.mesh.T, self.mesh.cells))
        return self._quality_before

    @property
    def movable(self) -> np.ndarray:
        """(n,) bool: free interior vertices (in no hard constraint), which repair may move."""
        if getattr(self, "_movable", None) is None:
            mv = self.mesh.interior & self.mesh.referenced
            mv[self._constrained] = False
            for b in self._blocks:
                mv[b.vert] = False
            self._movable = mv
        return self._movable

    def solve(self, move: Move | dict[str, Any], inversion: str | None = None,
              quality: str = "basic", repair: bool | None = None) -> DeformResult:
        """Deform for one MOVE by back-substitution only.

        Parameters
        ----------
        move : Move or dict
            A parsed :class:`~solver.spec.Move` or a MOVE document.
        inversion : {"warn", "reject", "clamp"}, optional
            Overrides the SPEC's policy. With ``"clamp"`` an inverting MOVE is
            scaled by its safe fraction (:meth:`safe_fraction`) and the REPORT
            says so (``clamped``, ``applied_fraction``,
            ``inverted_elements_unclamped``).
        repair : bool, optional
            Overrides ``SPEC.repair``: untangle inverted elements by moving
            free interior vertices near them (:func:`solver.validity.repair.repair_inverted`);
            ``report["repair"]`` says what happened. Never worse: a repair that
            does not reduce the inverted count is discarded.
        quality : {"basic", "full"}
            ``"full"`` adds ``report["quality"] = {"before", "after"}`` (min,
            percentiles, max and histograms of volume, scaled Jacobian, min/max
            dihedral angle and aspect ratio) and the per-element arrays in
            ``DeformResult.cell_quality``.

        Returns
        -------
        DeformResult
            The REPORT has ``safe_fraction`` when the MOVE inverted elements
            (1.0 otherwise).

        Raises
        ------
        SpecError
            Malformed MOVE or unknown handle or constraint names.
        ConstraintError
            The MOVE makes hard constraints conflict and ``SPEC.conflicts`` is
            ``"reject"`` (``code="conflicting_constraints"``, the entries in
            ``details``).
        InversionError
            Elements were inverted and the policy is ``"reject"``.
        """
        t0 = time.perf_counter()
        mv = self.parse_move(move)
        policy = inversion or self.spec.inversion
        if policy not in INVERSION_POLICIES:
            raise SpecError(f"inversion policy must be one of {list(INVERSION_POLICIES)}, got {policy!r}")
        if quality not in ("basic", "full"):
            raise SpecError(f"quality must be 'basic' or 'full', got {quality!r}", field="quality")
        n0 = fz.STATS["factorizations"]
        t1 = time.perf_counter()
        solved = self.solve_positions(mv)
        P = solved[0]
        t2 = time.perf_counter()
        report = self._report(P, solved, mv)
        t3 = time.perf_counter()
        do_repair = self.spec.repair if repair is None else repair
        repair_rep = None
        if do_repair and report["inverted_elements"] > 0 and not self.mesh.is_surface:
            rr = repair_inverted(self.mesh.V, P, check_tets(self.mesh.T, self.mesh.cells), self.movable)
            repair_rep = rr.report
            if rr.report["accepted"]:
                P = rr.V
                solved = (P, *solved[1:])
                report = self._report(P, solved, mv)
            t3 = time.perf_counter()
        safe_ms = 0.0
        report["safe_fraction"] = 1.0
        report["clamped"] = False
        if report["inverted_elements"] > 0:
            f, steps = self.safe_fraction(mv, inverts=True)
            report["safe_fraction"] = f
            report["safe_fraction_solves"] = steps
            if policy == "clamp":
                unclamped = report["inverted_elements"]
                mv = self.scaled_move(mv, f)
                solved = self.solve_positions(mv)
                P = solved[0]
                report = {**self._report(P, solved, mv), "safe_fraction": f, "safe_fraction_solves": steps,
                          "clamped": True, "applied_fraction": f,
                          "inverted_elements_unclamped": unclamped}
            safe_ms = 1e3 * (time.perf_counter() - t3)
        if repair_rep is not None:
            report["repair"] = repair_rep
        cell_q = None
        if quality == "full" and not self.mesh.is_surface:
            cell_q = element_quality(P, self.mesh.T, self.mesh.cells)
            report["quality"] = {"before": self.quality_before, "after": summarize_quality(cell_q)}
        t4 = time.perf_counter()
        report["timings"] = {
            "setup": self.setup_timings,
            "update": {"rhs_ms": 1e3 * (t1 - t0), "solve_ms": 1e3 * (t2 - t1), "check_ms": 1e3 * (t3 - t2),
                       "safe_fraction_ms": safe_ms, "total_ms": 1e3 * (t4 - t0)},
        }
        report["refactorized"] = fz.STATS["factorizations"] != n0
        if self.spec.conflicts == "reject" and report["conflicting_constraints"]:
            first = report["conflicting_constraints"][0]
            raise ConstraintError(
                f"the move makes {len(report['conflicting_constraints'])} hard constraints conflict "
                f"(first: {_entry_text(first)}); SPEC.conflicts is 'reject'",
                code="conflicting_constraints", report=report)
        if policy == "reject" and report["inverted_elements"] > 0:
            raise InversionError(
                f"the move inverts {report['inverted_elements']} elements (first "
                f"{format_ids(report['inverted_ids'])}); policy 'reject' returns no result",
                report)
        return DeformResult(P, report, mv, cell_q)

    def _report(self, P: np.ndarray, solved: tuple, mv: Move) -> dict[str, Any]:
        mesh = self.mesh
        cons = self.constraint_report(solved, mv)
        res = cons["constraint_residual_max"]
        rep: dict[str, Any] = {
            "inverted_elements": 0, "inverted_ids": [], "degenerate_elements": 0,
            "min_scaled_jacobian": None, "p01_scaled_jacobian": None,
            "min_scaled_jacobian_before": self._sj_before[0],
            "p01_scaled_jacobian_before": self._sj_before[1],
            "constraint_residual_max": res,
            "constraint_residual_relative": res / self._diag if self._diag else 0.0,
            "constraint_rows": cons["constraint_rows"],
            "redundant_constraints": cons["redundant_constraints"],
            "conflicting_constraints": cons["conflicting_constraints"],
            "max_displacement": float(np.linalg.norm(P - mesh.V, axis=1).max()),
            "solve_method": self.spec.method, "solve_mode": self.solve_mode,
            "refine_steps": self.refine_steps,
            "backend": fz.backend(),
            "lu_backend": self._finter.name if getattr(self, "_finter", None) is not None else None,
            "finite": bool(np.isfinite(P).all()),
        }
        if not mesh.is_surface:
            # scaled Jacobian = sqrt(2) vol6 / (edge-length products), so a tiny |sj| flags degeneracy
            badm, sj, degenerate, dj = self._bad_elements(P)
            bad = np.flatnonzero(badm)
            k = sj.size // 100
            if dj is not None:
                ratio = dj.min(axis=1) / np.maximum(np.abs(dj).max(axis=1), 1e-300)
                rep["element_order"] = 2
                rep["min_jacobian_ratio"] = float(ratio[self._valid_rest].min()) if self._valid_rest.any() \
                    else float(ratio.min())
                rep["invalid_at_rest_elements"] = int((~self._valid_rest).sum())
                placed = self._mid.jacobians is not None and self._mid.jacobians[0] is P
                rep["midside_relaxed"] = self._mid.relaxed if placed else None
            rep.update({
                "inverted_elements": int(bad.size),
                "inverted_ids": bad[:REPORT_IDS].tolist(),
                "degenerate_elements": int(degenerate.sum()),
                "min_scaled_jacobian": float(sj.min()),
                "p01_scaled_jacobian": float(np.partition(sj, k)[k]),
            })
        return rep


def _spread(has: np.ndarray, labels: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Mark every component tied (by vertex ``pairs``) to a marked one."""
    if not len(pairs) or has.all():
        return has
    from scipy.sparse.csgraph import connected_components

    la, lb = labels[pairs[:, 0]], labels[pairs[:, 1]]
    k = has.size
    G = sp.coo_matrix((np.ones(la.size), (la, lb)), shape=(k, k))
    _, grp = connected_components(G, directed=False)
    held = np.zeros(grp.max() + 1, bool)
    held[grp[has]] = True
    return held[grp]


def _entry_text(e: dict[str, Any]) -> str:
    txt = f"{e['kind']} {e['name']!r} (#{e['index']}) on vertices {e['vertices']}"
    if "residual" in e:
        txt += f", residual {e['residual']:.3g}"
    return txt


def precompute(mesh: Mesh, spec: Spec | dict[str, Any]) -> Deformer:
    """Assemble and factor the deformation of ``mesh`` under ``spec``.

    Parameters
    ----------
    mesh : Mesh
    spec : Spec or dict

    Returns
    -------
    Deformer
        Call ``.solve(move)`` for each handle update.

    See Also
    --------
    Deformer
    """
    return Deformer(mesh, spec)

