"""The rotation field: handle rotations propagated over the boundary (ECLS §3.3, Masuda & Ogawa eq. 3.5-3.9).

With rotations prescribed per handle (``c_h`` on handle ``h``, 0 on fixed
vertices; eq. 3.6, ECLS eq. 26-27), tied together on rigid features and held
at 0 on ``keep_direction`` features (ECLS eq. 29, Form features §3.1), the
solution of (3.5)/(25) is linear in the ``c_h``: ``r = sum_h phi_h c_h``.
:func:`rotation_field_precompute` factors the system once (by the SPEC's
constraint method) and back-substitutes once per handle for the harmonic
basis ``Phi``; :meth:`RotationField.solve` is then a small dense product.
Log-scales (uniform handle scales) use the same basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..constraints.assembly import Assembly
from ..constraints.move import ResolvedMove
from ..constraints.spec import ResolvedSpec
from ..linalg import factorization as fz
from ..linalg.constrained import ConstrainedSolver, constrained_solver
from ..linalg.rank import RankAnalysis
from ..mesh import Mesh
from ..ops.cotmatrix import uniform_matrix
from .constraint_set import ConstraintSet
from .operators import Operators

__all__ = ["RotationField", "rotation_field_precompute", "REFINE_STEPS"]

#: Iterative-refinement steps of the least-squares (normal-equation) solves:
#: each recomputes the residual with the new positions and back-substitutes
#: once more. Normal equations square the condition number, which slivers make
#: large (screw.msh: rigid-motion error 6e-8 of the diagonal without, <1e-10 with).
REFINE_STEPS = 1


@dataclass(frozen=True, eq=False)
class RotationField:
    """The precomputed rotation field of one SPEC (immutable).

    Attributes
    ----------
    Phi : (n_B, H) float array
        Harmonic basis over the boundary vertices (``ConstraintSet.bidx`` order): of
        the rotations and log-scales, or of the log-scales only when ``Phi3`` is set.
    system : ConstrainedSolver or None
        The factored rotation system (None without handles).
    unit_residuals : (m, H) or (m, 3H) float array
        Residual of every rotation row per unit handle logarithm (dropped rows reveal conflicts).
    handle_names : tuple of str
    factorizations : int
        Factorizations this object made.
    Phi3 : (3 n_B, 3 H) float array or None
        Mirror and cyclic symmetry couple the coordinates of the logarithms:
        ``vec(r) = Phi3 @ vec(C)`` (vertex-major, coordinate-minor; handle-major).
    scale_system : ConstrainedSolver or None
        The log-scales' own system when ``Phi3`` is set.
    """

    Phi: np.ndarray
    system: ConstrainedSolver | None
    unit_residuals: np.ndarray
    handle_names: tuple[str, ...]
    factorizations: int
    Phi3: np.ndarray | None = None
    scale_system: ConstrainedSolver | None = None

    @property
    def nbytes(self) -> int:
        """Bytes held by the basis and the factor."""
        total = int(self.Phi.nbytes) + (self.system.nbytes if self.system is not None else 0)
        if self.Phi3 is not None:
            total += int(self.Phi3.nbytes) + (self.scale_system.nbytes if self.scale_system is not None else 0)
        return total

    def unit_vector(self, move: ResolvedMove) -> np.ndarray:
        """What ``unit_residuals`` multiplies: ``[C, s]`` (H, 4), or ``vec(C)`` (3H, 1) when coupled."""
        C, s = self.handle_logs(move)
        return C.reshape(-1, 1) if self.Phi3 is not None else np.column_stack([C, s])

    def handle_logs(self, move: ResolvedMove) -> tuple[np.ndarray, np.ndarray]:
        """Quaternion logarithms (H, 3) and log-scales (H,) of the handles in ``move``."""
        H = len(self.handle_names)
        C = np.zeros((H, 3))
        s = np.zeros(H)
        for h, name in enumerate(self.handle_names):
            hm = move.handles.get(name)
            if hm is not None:
                C[h] = hm.log_rotation
                s[h] = np.log(hm.scale)
        return C, s

    def solve(self, move: ResolvedMove) -> tuple[np.ndarray, np.ndarray]:
        """Quaternion logarithms (n_B, 3) and log-scales (n_B,) of the boundary vertices."""
        C, s = self.handle_logs(move)
        if self.Phi3 is not None:
            return (self.Phi3 @ C.ravel()).reshape(-1, 3), self.Phi @ s
        return self.Phi @ C, self.Phi @ s


def rotation_field_precompute(mesh: Mesh, spec: ResolvedSpec, cs: ConstraintSet, ops: Operators) -> RotationField:
    """Factor the rotation system and compute the harmonic basis ``Phi``.

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec
        ``spec.rotation``: ``harmonic`` (the cotangent Laplacian, ECLS eq. 25)
        or ``least_squares`` (``Lb^T Lb``, eq. 3.8/3.9).
    cs : ConstraintSet
    ops : Operators

    Returns
    -------
    RotationField

    Raises
    ------
    FactorizationError
    """
    H = len(cs.handle_names)
    nb = cs.bidx.size
    if H == 0 or cs.rbidx.size == 0 or cs.rasm is None:
        return RotationField(np.zeros((nb, H)), None, np.zeros((0, H)), cs.handle_names, 0)
    bidx = cs.rbidx
    if spec.rotation == "harmonic":
        Q = ops.K[bidx][:, bidx]
    else:
        Lbb = ops.Lb[bidx][:, bidx]
        Q = (Lbb.T @ Lbb).tocsr()
    asm = cs.rasm
    if not cs.rvector:
        system, Phi, unit_residuals = _basis(spec, Q, asm, cs.rra, cs.rbasis, H, "rotation system")
        factorizations = system.factorizations
        Phi3 = scale_system = None
    else:
        # coupled logarithms: 3 unknowns per vertex, one column per handle and coordinate
        Q3 = sp.kron(Q, sp.identity(3), format="csr")
        D = np.zeros((asm.C.shape[0], 3 * H))
        for b_i, t in enumerate(cs.rbasis):
            rows = np.flatnonzero((asm.block == b_i) & (asm.coord >= 0))
            for h in range(H):
                D[rows, 3 * h + asm.coord[rows]] = t[asm.local[rows], h]
        system = constrained_solver(asm.C, H=Q3, method=spec.method, beta=spec.penalty_weight,
                                    what="rotation system", analysis=cs.rra)
        Phi3 = system.solve(np.zeros((3 * bidx.size, 3 * H)), D, None, refine=REFINE_STEPS)
        unit_residuals = asm.C @ Phi3 - D
        assert cs.sasm is not None
        scale_system, Phi, _ = _basis(spec, Q, cs.sasm, cs.sra, cs.sbasis, H, "log-scale system")
        factorizations = system.factorizations + scale_system.factorizations
    if bidx.size != nb:
        void = cs.bidx[cs.free_shell[cs.bidx]]
        Phi = _embed(mesh, cs, bidx, Phi, void)
        if Phi3 is not None:
            Phi3 = _embed(mesh, cs, bidx, Phi3.reshape(bidx.size, -1), void).reshape(3 * nb, 3 * H)
        factorizations += 1
    return RotationField(Phi, system, unit_residuals, cs.handle_names, factorizations, Phi3, scale_system)


def _basis(spec: ResolvedSpec, Q: sp.csr_matrix, asm: Assembly, ra: RankAnalysis | None, basis: list[np.ndarray],
           H: int, what: str) -> tuple[ConstrainedSolver, np.ndarray, np.ndarray]:
    """Factor one scalar system and solve its harmonic basis (one column per handle)."""
    D = np.zeros((asm.C.shape[0], H))
    for b_i, t in enumerate(basis):
        rows = asm.block == b_i
        D[rows] = t[asm.local[rows]]
    system = constrained_solver(asm.C, H=Q, method=spec.method, beta=spec.penalty_weight, what=what, analysis=ra)
    Phi = system.solve(np.zeros((Q.shape[0], H)), D, None, refine=REFINE_STEPS)
    return system, Phi, asm.C @ Phi - D


def _embed(mesh: Mesh, cs: ConstraintSet, bidx: np.ndarray, Phi: np.ndarray, void: np.ndarray) -> np.ndarray:
    """A basis over ``bidx`` spread to every boundary vertex, internal voids by harmonic extension."""
    full = np.zeros((cs.bidx.size, Phi.shape[1]))
    full[np.searchsorted(cs.bidx, bidx)] = Phi
    full[np.searchsorted(cs.bidx, void)] = _extend(mesh, bidx, Phi, void)
    return full


def _extend(mesh: Mesh, known: np.ndarray, Phi: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Rotation basis at internal-void vertices: the outer shells' field extended harmonically.

    The graph Laplacian of the element edges, Dirichlet on ``known``: a void turns
    with the volume around it.
    """
    n = mesh.n
    Lv = uniform_matrix(mesh.edges if mesh.cells else mesh.T, n)
    isknown = np.zeros(n, bool)
    isknown[known] = True
    u = np.flatnonzero(mesh.referenced & ~isknown)
    f = fz.cholesky(Lv[u][:, u].tocsc(), "void rotation extension")
    X = f.solve(-(Lv[u][:, known] @ Phi))
    return X[np.searchsorted(u, targets)]
