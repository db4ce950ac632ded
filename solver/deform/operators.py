"""The method's operators on the rest mesh: boundary Laplacian rows and interior mean-value rows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..constraints.spec import ResolvedSpec
from ..mesh import Mesh
from ..ops.cotmatrix import cotmatrix, uniform_matrix, voronoi_areas
from ..ops.mvc_matrix import mvc_matrix

__all__ = ["Operators", "operators", "csr"]


def csr(M: sp.spmatrix) -> sp.csr_matrix:
    """``M`` as CSR with sorted indices."""
    M = sp.csr_matrix(M)
    M.sort_indices()
    return M


@dataclass(frozen=True, eq=False)
class Operators:
    """Operators of eq. (4.1), built once.

    Attributes
    ----------
    K : (n, n) csr matrix
        Cotangent (or uniform) Laplacian of the boundary surface.
    Lb : (n, n) csr matrix
        Boundary rows ``L(p_i) = (K p)_i / (2 A_i)`` (eq. 3.1); zero rows elsewhere.
    delta : (n, 3) float array
        Rest mean curvature normals ``Lb @ V0``.
    Mi : (n, n) csr matrix
        Interior rows ``p_i - sum_j w_ij p_j`` (mean value coordinates, eq. 2.4); zero rows elsewhere.
    wi : (n,) float array
        Interior row weights ``1 / S_i`` (eq. 2.5); zero elsewhere.
    """

    K: sp.csr_matrix
    Lb: sp.csr_matrix
    delta: np.ndarray
    Mi: sp.csr_matrix
    wi: np.ndarray


def operators(mesh: Mesh, spec: ResolvedSpec) -> Operators:
    """Assemble the boundary and interior operators of ``mesh`` (eq. 2.4-2.5, 3.1).

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec
        ``spec.laplacian`` picks cotangent (eq. 3.1) or uniform weights.

    Returns
    -------
    Operators
    """
    n = mesh.n
    V0 = mesh.V
    B = mesh.boundary
    I = mesh.interior  # noqa: E741 - the papers' notation
    F = mesh.F
    wb = np.zeros(n)
    if spec.laplacian == "cotangent":
        K = cotmatrix(V0, F, n)
        A = voronoi_areas(V0, F, n)
        wb[B] = 1.0 / (2.0 * A[B])  # L(p_i) = (K p)_i / (2 A_i), eq. (3.1)
    else:
        K = uniform_matrix(F, n)
        wb[B] = 1.0 / K.diagonal()[B]  # L(p_i) = p_i - mean of neighbours
    Lb = csr(sp.diags(wb) @ K)
    wi = np.zeros(n)
    if I.any():
        W, S = mvc_matrix(V0, mesh.T, I, mesh.cells)
        wi[I] = 1.0 / S[I]  # eq. (2.5)
        Mi = csr(sp.diags(I.astype(float)) - W)
    else:
        Mi = sp.csr_matrix((n, n))
    return Operators(K, Lb, Lb @ V0, Mi, wi)
