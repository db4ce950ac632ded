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
from dataclasses import dataclass
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp

from . import factorization as fz
from .cotmatrix import cotmatrix, uniform_matrix, voronoi_areas
from .errors import ConstraintError, InversionError, SpecError, format_ids
from .mesh import Mesh
from .mvc_matrix import mvc_matrix
from .quality import DEGENERATE_TOL, tet_quality
from .rotation import rotate_by_log
from .selection import select
from .spec import Move, Spec, parse_move, parse_spec

__all__ = ["Deformer", "DeformResult", "precompute"]

#: How many inverted element ids a REPORT lists.
REPORT_IDS = 100
#: Iterative-refinement steps of the least-squares (normal-equation) solves:
#: each recomputes the residual with the new positions and back-substitutes
#: once more. Normal equations square the condition number, which slivers make
#: large (screw.msh: rigid-motion error 6e-8 of the diagonal without, <1e-10 with).
REFINE_STEPS = 1


@dataclass
class DeformResult:
    """Result of one update.

    Attributes
    ----------
    V : (n, 3) float64 array
        Deformed positions in file order (unreferenced vertices unchanged).
    report : dict
        The REPORT document.
    """

    V: np.ndarray
    report: dict[str, Any]


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
        self._check_determined(constrained)
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
        if I.any():
            W, S = mvc_matrix(V0, mesh.T, I)
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
        self._bidx = np.flatnonzero(B)
        self._Phi = self._rotation_basis(K, Lb, B, owner)
        t_rot = time.perf_counter() - t1
        report("rotation", 0.5)

        # --- positions -------------------------------------------------------------
        t2 = time.perf_counter()
        known = constrained | ~mesh.referenced
        self._known = np.flatnonzero(known)
        self._free = np.flatnonzero(~known)
        self._constrained = np.flatnonzero(constrained)
        mode = self.spec.solve
        if self.spec.method == "penalty":
            mode = "joint"
        elif mode == "auto":
            mode = "split"
        self.solve_mode = mode
        if self.spec.method == "penalty":
            self._setup_penalty(Lb, Mi, wi)
        elif mode == "joint":
            self._setup_joint(Lb, Mi, wi)
        else:
            self._setup_split(Lb, Mi)
        t_pos = time.perf_counter() - t2
        report("positions", 0.95)

        self._Tt = np.ascontiguousarray(mesh.T.T)
        sj = tet_quality(V0, self._Tt)[1] if not mesh.is_surface else np.zeros(0)
        self._sj_before = (float(sj.min()) if sj.size else None,
                           float(np.partition(sj, sj.size // 100)[sj.size // 100]) if sj.size else None)
        self._diag = float(np.linalg.norm(V0[mesh.referenced].max(0) - V0[mesh.referenced].min(0)))
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
        for name in ("_fpos", "_fbound", "_finter"):
            f = getattr(self, name, None)
            if f is not None:
                total += int(f.nbytes)
        for name in ("_A", "_AFt", "_Art", "_Bft", "_Lbb", "_Mfi"):
            M = getattr(self, name, None)
            if M is not None:
                total += int(M.data.nbytes + M.indices.nbytes + M.indptr.nbytes)
        return total

    # ------------------------------------------------------------------ checks
    def _check_determined(self, constrained: np.ndarray) -> None:
        mesh = self.mesh
        bodies = mesh.body_labels
        nb = int(bodies.max()) + 1
        has = np.zeros(nb, bool)
        has[bodies[constrained & mesh.referenced]] = True
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
        fixed vertices; eq. 3.6, 26-27), the solution of (3.5)/(25) is linear
        in the ``c_h``: ``r = sum_h phi_h c_h``, with ``phi_h`` the solution for
        ``c_h = 1``. One factorization, one back-substitution per handle.
        """
        bidx = self._bidx
        H = len(self.handle_names)
        if H == 0 or bidx.size == 0:
            return np.zeros((bidx.size, H))
        Kb = K[bidx][:, bidx]
        if self.spec.rotation == "harmonic":
            Q = Kb
        else:
            Lbb = Lb[bidx][:, bidx]
            Q = (Lbb.T @ Lbb).tocsr()
        ob = owner[bidx]
        E = np.zeros((bidx.size, H))
        for h in range(H):
            E[ob == h, h] = 1.0
        cons = ob != -1
        if self.spec.method == "penalty":
            beta2 = self.spec.penalty_weight ** 2
            P = sp.diags(cons.astype(float) * beta2)
            f = fz.cholesky(Q + P, "rotation system (penalty)")
            return f.solve(beta2 * E)
        free = np.flatnonzero(~cons)
        Phi = E.copy()
        if free.size:
            c = np.flatnonzero(cons)
            f = fz.cholesky(Q[free][:, free], "rotation system")
            Phi[free] = f.solve(-(Q[free][:, c] @ E[c]))
        return Phi

    # --------------------------------------------------------------- positions
    def _setup_joint(self, Lb: sp.csr_matrix, Mi: sp.csr_matrix, wi: np.ndarray) -> None:
        A = _csr(Lb + sp.diags(wi) @ Mi)  # every row of eq. (4.2), weighted
        A = A[self.mesh.referenced]
        self._rows_b = np.flatnonzero(self.mesh.referenced)  # row r of A is vertex rows_b[r]
        AF = A[:, self._free].tocsc()
        self._AFt = _csr(AF.T)
        self._A = A
        self._fpos = fz.cholesky((AF.T @ AF).tocsc(), "position system (joint)") if self._free.size else None

    def _setup_penalty(self, Lb: sp.csr_matrix, Mi: sp.csr_matrix, wi: np.ndarray) -> None:
        A = _csr(Lb + sp.diags(wi) @ Mi)[self.mesh.referenced]
        self._rows_b = np.flatnonzero(self.mesh.referenced)
        ref = np.flatnonzero(self.mesh.referenced)
        self._pen_idx = ref
        Ar = A[:, ref].tocsc()
        self._A = A
        beta2 = self.spec.penalty_weight ** 2
        c = np.zeros(self.mesh.n)
        c[self._constrained] = beta2
        self._pen_diag = c[ref]
        self._Art = _csr(Ar.T)
        self._fpos = fz.cholesky((Ar.T @ Ar + sp.diags(self._pen_diag)).tocsc(),
                                 "position system (penalty)")

    def _setup_split(self, Lb: sp.csr_matrix, Mi: sp.csr_matrix) -> None:
        mesh = self.mesh
        B = mesh.boundary
        known = np.zeros(mesh.n, bool)
        known[self._known] = True
        bidx = self._bidx
        self._fb = np.flatnonzero(B & ~known)  # free boundary vertices
        Lbb = _csr(Lb[bidx][:, bidx])
        fb_local = np.searchsorted(bidx, self._fb)
        Af = Lbb[:, fb_local].tocsc()
        self._Bft = _csr(Af.T)
        self._Lbb = Lbb
        self._fbound = fz.cholesky((Af.T @ Af).tocsc(), "boundary position system") \
            if self._fb.size else None
        # interior: square MVC system of the free interior vertices
        self._fi = np.flatnonzero(mesh.interior & ~known)
        if self._fi.size:
            Mfi = Mi[self._fi]
            self._Mfi = _csr(Mfi)
            self._finter = fz.lu(Mfi[:, self._fi].tocsc(), "interior mean-value system")

    # ------------------------------------------------------------------ update
    def targets(self, move: Move) -> np.ndarray:
        """Target positions (k, 3) of the constrained vertices, in ``self._constrained`` order."""
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
        H = len(self.handle_names)
        C = np.zeros((H, 3))
        s = np.zeros(H)
        for h, name in enumerate(self.handle_names):
            hm = move.handles.get(name)
            if hm is not None:
                C[h] = hm.log_rotation
                s[h] = np.log(hm.scale)
        return self._Phi @ C, self._Phi @ s

    def solve(self, move: Move | dict[str, Any], inversion: str | None = None) -> DeformResult:
        """Deform for one MOVE by back-substitution only.

        Parameters
        ----------
        move : Move or dict
            A parsed :class:`~solver.spec.Move` or a MOVE document.
        inversion : {"warn", "reject"}, optional
            Overrides the SPEC's policy.

        Returns
        -------
        DeformResult

        Raises
        ------
        SpecError
            Malformed MOVE or unknown handle names.
        InversionError
            Elements were inverted and the policy is ``"reject"``.
        """
        t0 = time.perf_counter()
        mv = move if isinstance(move, Move) else parse_move(move, self.handle_names)
        policy = inversion or self.spec.inversion
        if policy not in ("warn", "reject"):
            raise SpecError(f"inversion policy must be 'warn' or 'reject', got {policy!r}")
        n0 = fz.STATS["factorizations"]
        U = self.targets(mv)
        r, sigma = self.rotation_field(mv)
        b = np.zeros((self.mesh.n, 3))
        if self._bidx.size:
            b[self._bidx] = np.exp(sigma)[:, None] * rotate_by_log(self._delta[self._bidx], r)
        t1 = time.perf_counter()
        # Residual form: every system is solved for the displacement of the free
        # vertices from their rest positions, so round-off scales with the change,
        # not with the coordinates (a zero move gives exactly the rest shape).
        V0 = self.mesh.V
        P = V0.copy()
        if self.spec.method == "penalty":
            ref = self._pen_idx
            du = np.zeros((self.mesh.n, 3))
            du[self._constrained] = U - V0[self._constrained]
            rhs = self._Art @ (b[self._rows_b] - self._A @ V0) + self._pen_diag[:, None] * du[ref]
            P[ref] += self._fpos.solve(rhs)
        elif self.solve_mode == "joint":
            P[self._constrained] = U
            if self._free.size:
                for _ in range(1 + REFINE_STEPS):
                    rhs = self._AFt @ (b[self._rows_b] - self._A @ P)
                    P[self._free] += self._fpos.solve(rhs)
        else:
            P[self._constrained] = U
            if self._fb.size:
                for _ in range(1 + REFINE_STEPS):
                    rhs = self._Bft @ (b[self._bidx] - self._Lbb @ P[self._bidx])
                    P[self._fb] += self._fbound.solve(rhs)
            if self._fi.size:
                P[self._fi] -= self._finter.solve(self._Mfi @ P)
        t2 = time.perf_counter()
        report = self._report(P, U, mv)
        t3 = time.perf_counter()
        report["timings"] = {
            "setup": self.setup_timings,
            "update": {"rhs_ms": 1e3 * (t1 - t0), "solve_ms": 1e3 * (t2 - t1), "check_ms": 1e3 * (t3 - t2),
                       "total_ms": 1e3 * (t3 - t0)},
        }
        report["refactorized"] = fz.STATS["factorizations"] != n0
        if policy == "reject" and report["inverted_elements"] > 0:
            raise InversionError(
                f"the move inverts {report['inverted_elements']} elements (first "
                f"{format_ids(report['inverted_ids'])}); policy 'reject' returns no result",
                report)
        return DeformResult(P, report)

    def _report(self, P: np.ndarray, U: np.ndarray, mv: Move) -> dict[str, Any]:
        mesh = self.mesh
        res = float(np.abs(P[self._constrained] - U).max()) if U.size else 0.0
        rep: dict[str, Any] = {
            "inverted_elements": 0, "inverted_ids": [], "degenerate_elements": 0,
            "min_scaled_jacobian": None, "p01_scaled_jacobian": None,
            "min_scaled_jacobian_before": self._sj_before[0],
            "p01_scaled_jacobian_before": self._sj_before[1],
            "constraint_residual_max": res,
            "constraint_residual_relative": res / self._diag if self._diag else 0.0,
            "max_displacement": float(np.linalg.norm(P - mesh.V, axis=1).max()),
            "solve_method": self.spec.method, "solve_mode": self.solve_mode,
            "backend": fz.backend(), "lu_backend": fz.lu_backend(),
            "finite": bool(np.isfinite(P).all()),
        }
        if not mesh.is_surface:
            vol6, sj = tet_quality(P, self._Tt)
            # scaled Jacobian = sqrt(2) vol6 / (edge-length products), so a tiny |sj| flags degeneracy
            degenerate = np.abs(sj) <= DEGENERATE_TOL
            bad = np.flatnonzero((vol6 <= 0) | degenerate)
            k = sj.size // 100
            rep.update({
                "inverted_elements": int(bad.size),
                "inverted_ids": bad[:REPORT_IDS].tolist(),
                "degenerate_elements": int(degenerate.sum()),
                "min_scaled_jacobian": float(sj.min()),
                "p01_scaled_jacobian": float(np.partition(sj, k)[k]),
            })
        return rep


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

