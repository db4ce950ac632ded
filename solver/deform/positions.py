"""Position solves of eq. (4.2)/(4.3): the split and the joint precompute.

``joint``
    The least-squares problem (4.2)/(4.3) over all vertices at once, hard
    constraints eliminated (the null-space method with a selection matrix).
``split``
    When no interior row is tied to a known vertex by the constraints, the
    interior rows of (4.2) can be met exactly for any boundary, so the joint
    optimum is: boundary vertices from the boundary rows alone, then interior
    vertices from the square mean-value system. Interior vertices that are
    constrained (fixed volumes) keep their known positions and their rows are
    dropped -- see docs/benchmarks.md for the measured difference to ``joint``.

Each is one immutable object holding its factorizations (:class:`SplitPositions`:
the boundary system and the interior LU; :class:`JointPositions`: one
system), built by :func:`positions_precompute`. ``solve`` only
back-substitutes, in residual form: every system is solved for the
displacement of the free vertices from their rest positions, so round-off
scales with the change, not with the coordinates (a zero move gives exactly
the rest shape).
"""

from __future__ import annotations

import contextvars
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..constraints.move import HandleMove, ResolvedMove
from ..constraints.spec import ResolvedSpec
from ..linalg import factorization as fz
from ..linalg.column_basis import column_basis
from ..linalg.constrained import ConstrainedSolver, constrained_solver
from ..linalg.pardiso import PardisoFactor
from ..linalg.products import combination, offset_product, product, shifted_product, stacked_differences
from ..linalg.residual import block_residual, corrected, coupled_residual_norms
from ..linalg.threads import one_blas_thread
from ..mesh import Mesh
from ..options import SolveOptions
from ..options import current as current_options
from .constraint_set import ConstraintSet
from .operators import Operators, csr
from .rhs import RightHandSides
from .rotation_field import REFINE_STEPS
from .thin_walls import WallRows

__all__ = ["Positions", "SplitPositions", "JointPositions", "PositionSolve", "positions_precompute", "interior_start",
           "InteriorStart", "InteriorBasis", "REFINE_TOL",
           "MIXED_TOL"]


@dataclass(frozen=True, eq=False)
class PositionSolve:
    """Positions of one solve and the accuracy of its interior part.

    Attributes
    ----------
    P : (n, 3) float array
        Corner positions (mid-side nodes at rest).
    interior_residual : float or None
        Mixed precision: the largest mean-value row residual ``|p_i - sum w_ij p_j|``
        over the largest interior displacement (None for double precision).
    refined : bool
        Whether the interior solve took a refinement step.
    """

    P: np.ndarray
    interior_residual: float | None = None
    refined: bool = False

@dataclass(frozen=True, eq=False)
class InteriorBasis:
    """Boundary-displacement directions whose interior solutions are known (a DOE plan's first block).

    Built by :meth:`SplitPositions.interior_basis`; stacked solves given it
    (:meth:`SplitPositions.interior_solve_many`) project their displacements on
    ``Q`` and back-substitute only what is left beyond :data:`BASIS_TOL` of each
    column, often nothing. A block's result depends only on the block and the
    basis, so every process that builds the basis from the same first block
    (a Ray actor, a service batch) solves each block bit for bit alike.

    Attributes
    ----------
    Q : (c, r) float64 array
        Orthonormal directions over the coupled vertices (``SplitPositions.coupled``).
    W : (f, r + 3) float array
        ``M_ff^{-1} [M_fb Q, r0]`` as the interior factor returns it (float32 from
        a single-precision PARDISO factor).
    owner : int
        ``id`` of the :class:`SplitPositions` that built it: a basis is only
        used by the precompute it belongs to.
    """

    Q: np.ndarray
    W: np.ndarray
    owner: int = 0

    @property
    def rank(self) -> int:
        """Directions held."""
        return int(self.Q.shape[1])


#: Mixed precision: the interior solve is refined once when the relative mean-value residual
#: (largest row residual over the largest interior displacement) exceeds this.
MIXED_TOL = 1e-5
#: The refinement step is skipped when, for a probe move at set-up, it moves no
#: vertex by more than this fraction of the diagonal (:func:`refinement_probe`).
REFINE_TOL = 1e-11
#: The rest positions solve the position system when its solution for a zero MOVE
#: lies within this fraction of the diagonal of them (:func:`rest_right_hand_sides`).
REST_TOL = 1e-11


@dataclass(frozen=True, eq=False)
class Positions:
    """What both position solves share.

    Attributes
    ----------
    system : ConstrainedSolver or None
        The least-squares system with its hard constraints (boundary rows for
        split, every row for joint).
    unknowns : (u,) int array
        Its unknown vertices.
    rows : (l,) int array
        Vertices of its soft rows, in row order (thin-wall rows follow).
    vector : bool
        Whether the unknowns are interleaved coordinates (3 per vertex).
    refine_steps : int
        Refinement steps per solve (0 or :data:`~solver.deform.rotation_field.REFINE_STEPS`).
    refine_probe : float
        Size of the refinement step for the probe move at set-up.
    factorizations : int
    rest_c, rest_d : arrays or None
        The system's right-hand sides for a zero MOVE (``c`` laid out as the
        system reads it) when the rest positions solve the system; then each
        MOVE is solved for its change from them (:meth:`boundary_many`). None:
        the rest does not solve it (a tie the rest misses, for instance), and
        the positions are solved for directly.
    options : SolveOptions
        The options the factors were made with (those in effect at set-up).
    """

    system: ConstrainedSolver | None
    unknowns: np.ndarray
    rows: np.ndarray
    vector: bool
    refine_steps: int
    refine_probe: float
    factorizations: int
    rest_c: np.ndarray | None = None
    rest_d: np.ndarray | None = None
    options: SolveOptions = field(default_factory=current_options)

    mode = "joint"

    @property
    def nbytes(self) -> int:
        """Bytes held by the factors."""
        return self.system.nbytes if self.system is not None else 0

    @property
    def lu_backend(self) -> str | None:
        """Backend of the interior LU (split only)."""
        return None

    def _layout(self, X: np.ndarray) -> np.ndarray:
        return X.reshape(-1, 1) if self.vector else X

    def _unlayout(self, x: np.ndarray) -> np.ndarray:
        return x.reshape(-1, 3) if self.vector else x

    @property
    def interior_precision(self) -> str | None:
        """``"single"`` or ``"double"`` for the split solve's interior factor, else None."""
        return None

    def solve(self, V0: np.ndarray, constrained: np.ndarray, rhs: RightHandSides) -> PositionSolve:
        """Corner positions (n, 3) for one MOVE's right-hand sides (mid-side nodes at rest)."""
        return self.interior_solve_many([self.boundary(V0, constrained, rhs)], overwrite=True)[0]

    def solve_many(self, V0: np.ndarray, constrained: np.ndarray, rhss: list[RightHandSides],
                   basis: InteriorBasis | None = None) -> list[PositionSolve]:
        """:meth:`solve` for several MOVEs, their right-hand sides stacked into one back-substitution per factor."""
        return self.interior_solve_many(self.boundary_many(V0, constrained, rhss), overwrite=True, basis=basis)

    def boundary(self, V0: np.ndarray, constrained: np.ndarray, rhs: RightHandSides) -> np.ndarray:
        """Positions with the fixed and handle nodes and the system's unknowns solved (interior at rest)."""
        return self.boundary_many(V0, constrained, [rhs])[0]

    def boundary_many(self, V0: np.ndarray, constrained: np.ndarray, rhss: list[RightHandSides]) -> list[np.ndarray]:
        """:meth:`boundary` for several MOVEs: one stacked solve of the system.

        Where the rest solves the system (:attr:`rest_c`), the unknowns are
        ``V0 + x`` with ``x`` solved from the change of the right-hand sides: a
        zero MOVE changes nothing, solves zeros, and returns the rest positions
        bit for bit (a direct solve would return them to round-off).
        """
        k = len(rhss)
        Ps = [V0.copy() for _ in range(k)]
        for P, rhs in zip(Ps, rhss, strict=True):
            P[constrained] = rhs.U
        if self.system is None or not k:
            return Ps
        u = self.unknowns
        change = self.rest_c is not None and self.rest_d is not None
        rest = self._layout(V0[u])
        if k == 1:
            d = rhss[0].d
            assert d is not None
            c = self._layout(rhss[0].c)
            if change:
                c, d = c - self.rest_c, d - self.rest_d
            x0 = np.zeros_like(rest) if change else rest
        else:
            d = np.hstack([r.d - self.rest_d if change else r.d for r in rhss if r.d is not None])
            # (k, l, w): one contiguous copy; the gradient reads the blocks in place (an (l, w k) hstack
            # of narrow blocks copies every one of them twice)
            c = np.stack([self._layout(r.c) for r in rhss])
            if change:
                c -= self.rest_c
            # a block per MOVE; faster than hstack (measure_choices)
            x0 = np.zeros((rest.shape[0], rest.shape[1] * k)) if change else np.tile(rest, (1, k))
        x = self.system.solve(x0, d, c, refine=self.refine_steps)
        w = x.shape[1] // k
        for j, P in enumerate(Ps):
            xj = x[:, j * w:(j + 1) * w]
            P[u] = self._unlayout(rest + xj if change else xj)
        return Ps

    def interior_solve(self, P: np.ndarray) -> PositionSolve:
        """Interior positions for boundary positions ``P`` (joint: nothing left to solve)."""
        return self.interior_solve_many([P])[0]

    def interior_solve_many(self, Ps: list[np.ndarray], overwrite: bool = False,
                            basis: InteriorBasis | None = None) -> list[PositionSolve]:
        """:meth:`interior_solve` for several position arrays (``overwrite``: the caller gives them up)."""
        return [PositionSolve(P) for P in Ps]

    def interior_basis(self, Ps: list[np.ndarray]) -> InteriorBasis | None:
        """The column basis of boundary positions ``Ps`` (None: no interior system, or it would not pay)."""
        return None

    def uses_basis(self, k: int) -> bool:
        """Whether a stacked solve of ``k`` arrays goes through a column basis (no interior system: never)."""
        return False


@dataclass(frozen=True, eq=False)
class JointPositions(Positions):
    """Every row of eq. (4.2) in one constrained least-squares system."""

    mode = "joint"


@dataclass(frozen=True, eq=False)
class SplitPositions(Positions):
    """The boundary system, then the square mean-value system of the free interior vertices.

    Attributes
    ----------
    free_interior : (f,) int array
        Interior vertices in no fixed or handle selection.
    Mfi : (f, n) csr matrix
        Their mean-value rows ``p_i - sum_j w_ij p_j``.
    interior : Factor or None
        LU of ``Mff = Mfi[:, free_interior]``.
    Mff : (f, f) csr matrix
        The rows on the free interior vertices.
    Mfb : (f, c) csr matrix
        The rows on the other vertices they touch (``coupled``): a MOVE changes the
        interior's right-hand side only through them, ``M_f P = r0 + Mfb (P_c - P0_c)``.
    coupled : (c,) int array
    r0 : (f, 3) float array
        The mean-value rows at rest: zero (mean-value coordinates reproduce the rest
        positions; ``Mfi @ V0`` is their round-off, not solved for).
    """

    free_interior: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    Mfi: sp.csr_matrix | None = None
    interior: fz.Factor | None = None
    Mff: sp.csr_matrix | None = None
    Mfb: sp.csr_matrix | None = None
    coupled: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    r0: np.ndarray | None = None
    rest_coupled: np.ndarray | None = None

    mode = "split"

    @property
    def nbytes(self) -> int:
        """Bytes held by the factors and the interior rows."""
        total = super().nbytes
        if self.interior is not None:
            total += int(self.interior.nbytes)
        if self.Mfi is not None:
            total += int(self.Mfi.data.nbytes + self.Mfi.indices.nbytes + self.Mfi.indptr.nbytes)
        return total

    @property
    def lu_backend(self) -> str | None:
        """Backend of the interior LU."""
        return self.interior.name if self.interior is not None else None

    @property
    def interior_precision(self) -> str | None:
        """Precision of the interior factor."""
        if self.interior is None:
            return None
        return "single" if getattr(self.interior, "single", False) else "double"

    def interior_solve_many(self, Ps: list[np.ndarray], overwrite: bool = False,
                            basis: InteriorBasis | None = None) -> list[PositionSolve]:
        """Interior positions for boundary positions ``Ps`` (new arrays unless ``overwrite``), in one solve.

        Residual form ``P_f -= M_ff^{-1} (M_f P)``, every position array a block of
        columns; the right-hand side comes from the change of the coupled vertices only
        (``r0 + Mfb (P_c - P0_c)``, :attr:`Mfb`). In single precision the
        double-precision residual of the mean-value rows is measured per array, and one
        refinement step is taken when it exceeds :data:`MIXED_TOL` of the interior
        displacement. A stacked solve of a single-precision factor on at least
        :data:`BASIS_MIN` vertices back-substitutes only the directions its columns span
        (:meth:`_through_basis`): those of ``basis`` when given (built by
        :meth:`interior_basis` from other arrays), else of its own columns; the
        residual check is the same.
        """
        if self.interior is None or self.Mfb is None or self.Mff is None or self.r0 is None or not Ps:
            return [PositionSolve(P.copy()) for P in Ps]
        fi, cols, k = self.free_interior, self.coupled, len(Ps)
        single = self.interior_precision == "single"
        D: np.ndarray | None = None
        R: np.ndarray | None = None
        if k == 1:  # one update: the product, the shift and r0 in one threaded pass
            R = shifted_product(self.Mfb, cols, Ps[0], self._rest_coupled, self.r0)
            dx = self.interior.solve(R)  # float32 from a single-precision PARDISO factor: kept, it widens exactly
        else:
            D = stacked_differences(Ps, cols, self._rest_coupled)
            if basis is not None and basis.owner != id(self):
                raise ValueError("interior_solve_many: the interior basis was built by another precompute")
            via = None
            if self.uses_basis(k):
                with one_blas_thread():  # small products: no spinning helper against the kernels after them
                    via = self._through_basis(Ps, basis)
            if via is not None:
                dx = via  # its right-hand side never formed: the check below reads r0 + Mfb D directly
            else:
                R = offset_product(self.Mfb, D, self.r0)  # one threaded product for every array, r0 in each block
                dx = self.interior.solve(R)
        rels: list[float | None] = [None] * k
        refined = [False] * k
        if single:  # the mean-value rows at the new positions, in double precision, per array
            rn, dn = self._residual_norms(R, D, dx)  # norms only: refining is rare
            rel = rn / np.maximum(dn, 1e-300)  # per array: largest row residual over largest displacement
            refined = (rel > MIXED_TOL).tolist()
            if any(refined):
                c = np.concatenate([np.arange(3 * j, 3 * j + 3) for j in range(k) if refined[j]])
                Rc = R[:, c] if R is not None else offset_product(self.Mfb, np.asarray(D)[:, c], self.r0)
                res, _, _ = block_residual(self.Mff, Rc, dx[:, c], 3)
                assert res is not None
                dx = np.array(dx, dtype=np.float64)  # the correction leaves float32
                dx[:, c] += self.interior.solve(res)
                rn, dn = self._residual_norms(R, D, dx)
                rel = np.where(refined, rn / np.maximum(dn, 1e-300), rel)
            rels = rel.tolist()
        out = []
        for j, P in enumerate(Ps):
            Q = corrected(P, fi, dx, 3 * j, overwrite)
            out.append(PositionSolve(Q, rels[j], refined[j]) if single else PositionSolve(Q))
        return out

    def _residual_norms(self, R: np.ndarray | None, D: np.ndarray | None,
                        dx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Largest mean-value row residual and displacement per array: from ``R``, or from ``r0 + Mfb D``."""
        assert self.Mff is not None and self.Mfb is not None and self.r0 is not None
        if R is not None:
            _, rn, dn = block_residual(self.Mff, R, dx, 3, store=False)
            return rn, dn
        assert D is not None
        return coupled_residual_norms(self.Mff, self.Mfb, self.r0, D, dx, 3)

    def interior_basis(self, Ps: list[np.ndarray]) -> InteriorBasis | None:
        """The column basis of the boundary displacements of ``Ps`` with its interior solutions.

        None unless stacked solves use one (a single-precision factor on at least
        :data:`BASIS_MIN` vertices, three or more arrays) and it holds fewer than
        :data:`BASIS_GAIN` of the columns.
        """
        if not self.uses_basis(len(Ps)):
            return None
        with one_blas_thread():
            return self._basis_of(stacked_differences(Ps, self.coupled, self._rest_coupled, order="F"))

    def uses_basis(self, k: int) -> bool:
        """Whether a stacked solve of ``k`` arrays goes through a column basis (:func:`_use_basis`)."""
        return (self.interior is not None and self.interior_precision == "single"
                and _use_basis(self.free_interior.size, k, self.options.basis))

    def _scales(self, D: np.ndarray) -> np.ndarray | None:
        """Per-column norms of ``D`` floored at round-off of the coordinates; None when ``D`` is not finite.

        A plan row at or next to rest (a DOE's centre point) has columns of
        round-off; measured against their own size they would count as new
        directions. Below ``1e-6 |extent| sqrt(c)`` the accuracy asked is the
        coordinates' round-off instead.
        """
        norms = np.sqrt(np.einsum("ij,ij->j", D, D))
        if not np.isfinite(norms).all():
            return None  # the direct solve carries the NaN to the REPORT, as before
        rest = self._rest_coupled
        extent = float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))) if rest.size else 0.0
        return np.maximum(norms, 1e-6 * extent * np.sqrt(D.shape[0]))

    def _basis_of(self, D: np.ndarray) -> InteriorBasis | None:
        assert self.interior is not None and self.Mfb is not None and self.r0 is not None
        scale = self._scales(D)
        if scale is None:
            return None
        cb = column_basis(D, BASIS_TOL, scale=scale)
        if cb.rank + 3 >= BASIS_GAIN * D.shape[1]:
            return None
        Q = np.linalg.qr(cb.basis)[0] if cb.rank else np.zeros((D.shape[0], 0))  # orthonormal, the same span
        W = self._stacked_solve(np.hstack([product(self.Mfb, Q), self.r0]))
        return InteriorBasis(np.ascontiguousarray(Q), W, id(self))

    def _stacked_solve(self, B: np.ndarray) -> np.ndarray:
        """A back-substitution scheduled as stacked whatever its width (PARDISO's thread count, threads.py)."""
        assert self.interior is not None
        if isinstance(self.interior, PardisoFactor):
            return self.interior.solve(B, stacked=True)
        return self.interior.solve(B)

    def _through_basis(self, Ps: list[np.ndarray], basis: InteriorBasis | None) -> np.ndarray | None:
        """The stacked solve ``M_ff^{-1} (r0 + M_fb D)`` through a column basis, or None when it does not pay.

        ``D = Q C + E`` (projected twice on ``basis.Q``, built from ``D`` itself
        when no basis is given); what is left beyond :data:`BASIS_TOL` of each
        column's norm (:func:`~solver.linalg.column_basis.column_basis` of ``E``)
        is back-substituted as a few more columns ``N``. Then ``dx = [W, W_N]
        [C; I I ... I; C_N]``, summed in double precision and stored in the
        factor's single precision. The caller's double-precision residual of every
        array against the true right-hand side decides refinement as for a direct solve.
        """
        assert self.interior is not None and self.Mfb is not None
        D = stacked_differences(Ps, self.coupled, self._rest_coupled, order="F")  # column-major for the QR
        m = D.shape[1]
        if basis is None:
            basis = self._basis_of(D)
            if basis is None:
                return None
        Q = basis.Q
        C = Q.T @ D
        E = D - (C.T @ Q.T).T  # column-major like D, for the QR below
        C2 = Q.T @ E  # twice is enough: the remainder orthogonal to Q to round-off
        E -= (C2.T @ Q.T).T
        C += C2
        norms = self._scales(D)
        if norms is None:
            return None
        parts = [basis.W]
        coef = [C, np.tile(np.eye(3), (1, m // 3))]
        # every column within BASIS_TOL of its norm already: nothing left to solve (no QR of the remainder)
        within = bool((np.sqrt(np.einsum("ij,ij->j", E, E)) <= BASIS_TOL * norms).all())
        left = column_basis(E, BASIS_TOL, scale=norms) if not within else None
        if left is not None and left.rank:
            if left.rank >= BASIS_GAIN * m:  # the basis does not fit this block: solve it directly
                return None
            parts.append(self._stacked_solve(product(self.Mfb, left.basis)))
            coef.append(left.coefficients)
        W = parts[0] if len(parts) == 1 else np.hstack(parts)
        return combination(W, np.vstack(coef), np.float32)

    @property
    def _rest_coupled(self) -> np.ndarray:
        assert self.rest_coupled is not None
        return self.rest_coupled


#: Stacked interior solves on at least this many free interior vertices go through the block's
#: column basis (:meth:`SplitPositions._through_basis`) when the factor is single precision:
#: there each solved column costs most (PARDISO's solve, above the supernodal sweeps' range).
BASIS_MIN = 40_000
#: Relative accuracy per column of that basis: far below float32's 6e-8, so the dropped
#: directions are invisible next to the single-precision solve itself.
BASIS_TOL = 1e-10
#: The basis is used when its ``r + 3`` solved columns are fewer than this fraction of the block's.
BASIS_GAIN = 0.75


def _use_basis(free: int, k: int, allowed: bool = True) -> bool:
    """Whether a stacked solve of ``k`` arrays on ``free`` interior vertices tries the column basis.

    ``allowed`` is the precompute's :attr:`~solver.options.SolveOptions.basis`
    (False keeps the direct stacked solve).
    """
    return allowed and k >= 3 and free >= BASIS_MIN


RhsFor = Callable[[ResolvedMove, np.ndarray], RightHandSides]


def refinement_probe(system: ConstrainedSolver, vector: bool, x0: np.ndarray, rhs: RightHandSides) -> float:
    """Size of the refinement step for a probe move (largest vertex correction).

    Residual form makes one back-substitution exact to round-off on
    well-conditioned systems; slivers (large condition numbers) need the
    refinement step.
    """
    d = rhs.d
    assert d is not None

    def lay(X: np.ndarray) -> np.ndarray:
        return X.reshape(-1, 1) if vector else X

    x = system.start(lay(x0), d)
    c = lay(rhs.c)
    x = x + system.step(system.gradient(x, c), x, d)
    dx = system.step(system.gradient(x, c), x, d)
    return float(np.abs(dx).max())


def probe_move(cs: ConstraintSet) -> ResolvedMove:
    """Every handle turned 10 degrees and moved 1% of the diagonal."""
    axis = np.array([0.36, 0.48, 0.8])
    return ResolvedMove({h: HandleMove(0.01 * cs.diag * axis, np.radians(10.0) / 2 * axis) for h in cs.handle_names})


@dataclass(frozen=True, eq=False)
class InteriorStart:
    """A split solve's interior mean-value system, its LU under way on a second thread.

    Started by :func:`interior_start` as soon as the operators exist, so the
    factorization (which mostly runs without the GIL) overlaps the rest of the
    set-up; :func:`positions_precompute` takes the factor.

    Attributes
    ----------
    fi : (f,) int array
        Free interior vertices.
    Mfi : (f, n) csr matrix
    Mff : (f, f) csr matrix
    lu : Future of Factor
    """

    fi: np.ndarray
    Mfi: sp.csr_matrix
    Mff: sp.csr_matrix
    lu: Future

    def settle(self) -> None:
        """Wait for the factorization to end, whatever its outcome (a set-up that failed leaves nothing running)."""
        wait([self.lu])


def interior_start(mesh: Mesh, spec: ResolvedSpec, cs: ConstraintSet, ops: Operators) -> InteriorStart | None:
    """Start factoring the interior mean-value system of a split solve (None for joint or no free interior)."""
    if cs.mode == "joint":
        return None
    fi = np.flatnonzero(mesh.interior & ~np.isin(np.arange(mesh.n), cs.constrained) & mesh.referenced)
    if not fi.size:
        return None
    Mfi = csr(ops.Mi[fi])
    Mff = csr(Mfi[:, fi])
    pool = ThreadPoolExecutor(1, thread_name_prefix="tetmorph-interior-lu")
    # in the set-up's context: the factor follows the SolveOptions in effect here, not the thread's default
    lu = pool.submit(contextvars.copy_context().run, fz.lu, Mff.tocsc(), "interior mean-value system",
                     single=current_options().precision == "mixed")
    pool.shutdown(wait=False)  # the thread ends with its one task
    return InteriorStart(fi, Mfi, Mff, lu)


def positions_precompute(mesh: Mesh, spec: ResolvedSpec, cs: ConstraintSet, ops: Operators, walls: WallRows | None,
                         rhs_for: RhsFor, start: InteriorStart | None = None) -> Positions:
    """Assemble and factor the position solve that ``cs.mode`` names.

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec
    cs : ConstraintSet
    ops : Operators
    walls : WallRows or None
    rhs_for : callable
        ``rhs_for(move, rows) -> RightHandSides`` for the refinement probe.
    start : InteriorStart, optional
        The interior factorization already under way (:func:`interior_start`); started here when
        not given.

    Returns
    -------
    SplitPositions or JointPositions

    Raises
    ------
    FactorizationError
    """
    if start is None:
        start = interior_start(mesh, spec, cs, ops)
    try:
        system, probe = _boundary_system(mesh, spec, cs, ops, walls, rhs_for)
    except BaseException:
        if start is not None:
            start.settle()
        raise
    steps = 0 if probe <= REFINE_TOL * cs.diag else REFINE_STEPS
    nf = system.factorizations if system is not None else 0
    rows = np.flatnonzero(mesh.referenced) if cs.mode == "joint" else cs.bidx
    rest_c, rest_d = rest_right_hand_sides(system, cs.vector, mesh.V[cs.unknowns], rhs_for(ResolvedMove({}), rows),
                                           cs.diag, steps)
    common: dict[str, Any] = dict(system=system, unknowns=cs.unknowns, rows=rows, vector=cs.vector,
                                  refine_steps=steps, refine_probe=probe, rest_c=rest_c, rest_d=rest_d)
    if cs.mode == "joint":
        return JointPositions(factorizations=nf, **common)
    fi = np.zeros(0, np.int64)
    Mfi = interior = Mff = Mfb = r0 = rest_coupled = None
    coupled = np.zeros(0, np.int64)
    if start is not None:
        fi, Mfi, Mff = start.fi, start.Mfi, start.Mff
        interior = start.lu.result()
        nf += 1
        is_free = np.zeros(mesh.n, bool)
        is_free[fi] = True
        used = np.zeros(mesh.n, bool)
        used[Mfi.indices] = True
        coupled = np.flatnonzero(used & ~is_free)
        Mfb = csr(Mfi[:, coupled])
        # Mean-value coordinates reproduce linear functions, so the rest solves the interior rows and
        # Mfi @ V0 is round-off: taken as zero, a boundary at rest leaves every interior node at rest exactly.
        r0 = np.zeros((fi.size, 3))
        rest_coupled = np.ascontiguousarray(mesh.V[coupled])
    return SplitPositions(factorizations=nf, free_interior=fi, Mfi=Mfi, interior=interior, Mff=Mff, Mfb=Mfb,
                          coupled=coupled, r0=r0, rest_coupled=rest_coupled, **common)


def _boundary_system(mesh: Mesh, spec: ResolvedSpec, cs: ConstraintSet, ops: Operators, walls: WallRows | None,
                     rhs_for: RhsFor) -> tuple[ConstrainedSolver | None, float]:
    """The least-squares position system (boundary rows for split, every row for joint) and its probe step."""
    if cs.mode == "joint":
        rows = np.flatnonzero(mesh.referenced)
        A = csr(ops.Lb + sp.diags(ops.wi) @ ops.Mi)  # every row of eq. (4.2), weighted
        A = csr(A[rows][:, rows])
        what = "position system (joint)"
    else:
        rows = cs.bidx
        A = csr(ops.Lb[rows][:, rows]) if rows.size else None
        what = "boundary position system"
    system = None
    if A is not None and cs.pasm is not None:
        if walls is not None:
            A = csr(sp.vstack([A, walls.matrix(rows, mesh.n)]))
        if cs.vector:
            A = sp.kron(A, sp.identity(3), format="csr")
        system = constrained_solver(cs.pasm.C, A=A, method=spec.method, beta=spec.penalty_weight, what=what,
                                    analysis=cs.pra, per_update=True)
    probe = 0.0
    if system is not None and cs.handle_names:
        probe = refinement_probe(system, cs.vector, mesh.V[cs.unknowns], rhs_for(probe_move(cs), rows))
    return system, probe


def rest_right_hand_sides(system: ConstrainedSolver | None, vector: bool, x0: np.ndarray, rhs: RightHandSides,
                          diag: float, refine: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The system's right-hand sides of a zero MOVE ``rhs``, when the rest positions ``x0`` solve it.

    The rest solves the system in exact arithmetic when its hard rows hold at
    rest (the cotangent rows reproduce the rest normals). Solved here, it is
    ``x0`` to round-off; a row the rest misses (a tie within its tolerance
    only) moves it further, by more than :data:`REST_TOL` of the diagonal, and
    then None: those MOVEs are solved for positions, not for changes.
    """
    if system is None or rhs.d is None:
        return None, None
    c = rhs.c.reshape(-1, 1) if vector else rhs.c
    x0 = x0.reshape(-1, 1) if vector else x0
    x = system.solve(x0, rhs.d, c, refine=refine)
    if not np.isfinite(x).all() or float(np.abs(x - x0).max(initial=0.0)) > REST_TOL * diag:
        return None, None
    return np.array(c), np.array(rhs.d)
