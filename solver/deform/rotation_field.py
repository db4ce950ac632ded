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

from ..constraints.move import Move
from ..constraints.spec import Spec
from ..linalg import factorization as fz
from ..linalg.constrained import ConstrainedSolver, constrained_solver
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
        Harmonic basis over the boundary vertices (``ConstraintSet.bidx`` order).
    system : ConstrainedSolver or None
        The factored rotation system (None without handles).
    unit_residuals : (m, H) float array
        Residual of every rotation row per unit handle logarithm (dropped rows reveal conflicts).
    handle_names : tuple of str
    factorizations : int
        Factorizations this object made.
    """

    Phi: np.ndarray
    system: ConstrainedSolver | None
    unit_residuals: np.ndarray
    handle_names: tuple[str, ...]
    factorizations: int

    @property
    def nbytes(self) -> int:
        """Bytes held by the basis and the factor."""
        return int(self.Phi.nbytes) + (self.system.nbytes if self.system is not None else 0)

    def handle_logs(self, move: Move) -> tuple[np.ndarray, np.ndarray]:
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

    def solve(self, move: Move) -> tuple[np.ndarray, np.ndarray]:
        """Quaternion logarithms (n_B, 3) and log-scales (n_B,) of the boundary vertices."""
        C, s = self.handle_logs(move)
        return self.Phi @ C, self.Phi @ s


def rotation_field_precompute(mesh: Mesh, spec: Spec, cs: ConstraintSet, ops: Operators) -> RotationField:
    """Factor the rotation system and compute the harmonic basis ``Phi``.

    Parameters
    ----------
    mesh : Mesh
    spec : Spec
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
    D = np.zeros((asm.C.shape[0], H))
    for b_i, t in enumerate(cs.rbasis):
        rows = asm.block == b_i
        D[rows] = t[asm.local[rows]]
    system = constrained_solver(asm.C, H=Q, method=spec.method, beta=spec.penalty_weight, what="rotation system",
                                analysis=cs.rra)
    Phi = system.solve(np.zeros((bidx.size, H)), D, None, refine=REFINE_STEPS)
    unit_residuals = asm.C @ Phi - D
    factorizations = system.factorizations
    if bidx.size != nb:
        full = np.zeros((nb, H))
        full[np.searchsorted(cs.bidx, bidx)] = Phi
        void = cs.bidx[cs.free_shell[cs.bidx]]
        full[np.searchsorted(cs.bidx, void)] = _extend(mesh, bidx, Phi, void)
        factorizations += 1
        Phi = full
    return RotationField(Phi, system, unit_residuals, cs.handle_names, factorizations)


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
