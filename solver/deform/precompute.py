"""Precompute: everything a MOVE needs, assembled and factored once (libigl's ``*_precompute``).

:func:`deform_precompute` returns a frozen :class:`DeformData`; the
functions of :mod:`solver.deform.solve` take it and a MOVE and return values.
Nothing in it is written after it is built, so one instance serves
concurrent solves (factor backends that keep work space in the factor
serialize their own back-substitutions, :mod:`solver.linalg.factorization`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..constraints.move import ResolvedMove
from ..constraints.spec import ResolvedSpec
from ..mesh import Mesh
from ..ops.unique import unique
from ..options import SolveOptions, current, using
from ..validity.check import ElementCheck, SurfaceCheck
from ..validity.midside import MidsideNodes
from .constraint_set import ConstraintSet, constraint_set
from .operators import operators
from .positions import Positions, interior_start, positions_precompute
from .rhs import RightHandSides, handle_targets, right_hand_sides
from .rotation_field import RotationField, rotation_field_precompute
from .thin_walls import WallRows, wall_rows

__all__ = ["DeformData", "deform_precompute"]

Progress = Callable[[str, float], None]


@dataclass(frozen=True, eq=False)
class DeformData:
    """The precomputed deformation of one mesh under one SPEC (immutable).

    Attributes
    ----------
    mesh : Mesh
    spec : ResolvedSpec
    constraints : ConstraintSet
    delta : (n, 3) float array
        Rest mean curvature normals (eq. 3.1).
    walls : WallRows or None
    rotation : RotationField
    positions : SplitPositions or JointPositions
    midside : MidsideNodes or None
        Quadratic meshes: the mid-side placement.
    pinned_mid : (p,) int array
        Mid-side nodes held by fixed and handle selections.
    check : ElementCheck or SurfaceCheck
        The element check (flipped triangles for triangle surfaces).
    setup_timings : dict
        ``assembly_ms``, ``rotation_factorization_ms``, ``position_factorization_ms``, ``total_ms``.
    factorizations : int
        Factorizations made by this precompute (its own count).
    options : SolveOptions
        The options it was made with (the caller's, with the SPEC's ``solve_options`` laid over
        them); its solves run under them too.
    """

    mesh: Mesh
    spec: ResolvedSpec
    constraints: ConstraintSet
    delta: np.ndarray
    walls: WallRows | None
    rotation: RotationField
    positions: Positions
    midside: MidsideNodes | None
    pinned_mid: np.ndarray
    check: ElementCheck | SurfaceCheck | None
    setup_timings: dict[str, float]
    factorizations: int
    options: SolveOptions = SolveOptions()

    def rhs(self, move: ResolvedMove) -> RightHandSides:
        """Right-hand sides of a parsed MOVE."""
        p = self.positions
        return right_hand_sides(self.mesh, self.constraints, self.rotation, self.delta, self.walls, p.rows,
                                p.system is not None, move)

    def pinned_targets(self, move: ResolvedMove) -> np.ndarray:
        """Targets (p, 3) of the fixed, handle and target-surface mid-side nodes (``pinned_mid`` order)."""
        U = handle_targets(self.mesh, self.constraints, move, self.pinned_mid)
        for t in self.constraints.corr.targets:
            if t.mid_ids.size:
                a = move.targets.get(t.name, 0.0)
                rows = np.searchsorted(self.pinned_mid, t.mid_ids)
                U[rows] = self.mesh.V[t.mid_ids] + a * (t.mid_q - self.mesh.V[t.mid_ids])
        return U

    @property
    def nbytes(self) -> int:
        """Memory held by the factors, operators and rotation basis, in bytes."""
        return int(self.rotation.nbytes + self.delta.nbytes + self.positions.nbytes)


def _touch_topology(mesh: Mesh) -> None:
    """Fill the mesh's cached topology now, so that no solve writes it."""
    for name in ("F", "referenced", "boundary", "interior", "body_labels", "shell_labels"):
        getattr(mesh, name)
    if mesh.cells or not mesh.is_surface:
        _ = mesh.edges


def _surface_check(mesh: Mesh) -> SurfaceCheck:
    """The surface check with each shell's closedness (no edge in only one triangle)."""
    F = mesh.surface
    shell = mesh.shell_labels[F[:, 0]]
    ns = int(shell.max(initial=-1)) + 1
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, inv, cnt = np.unique(E[:, 0] * mesh.n + E[:, 1], return_inverse=True, return_counts=True)
    open_face = (cnt[inv] == 1).reshape(3, -1).any(axis=0)
    closed = np.ones(ns, bool)
    closed[unique(shell[open_face])] = False
    return SurfaceCheck(mesh.V, F, shell, closed)


def deform_precompute(mesh: Mesh, spec: ResolvedSpec, progress: Progress | None = None,
                      options: SolveOptions | None = None) -> DeformData:
    """Assemble and factor the deformation of ``mesh`` under a parsed ``spec``.

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec
    progress : callable, optional
        ``progress(stage, fraction)`` as set-up advances, with ``stage`` in
        ``"constraints"`` (selections resolved and checked: every SPEC error
        has been raised by then), ``"assembly"``, ``"rotation"``,
        ``"positions"``, ``"done"``.
    options : SolveOptions, optional
        Backend, precision, threads, sweeps and column basis (default: those in
        effect, :func:`solver.options.current`); the SPEC's ``solve_options``
        replace what they name (:meth:`~solver.options.SolveOptions.updated`).

    Returns
    -------
    DeformData

    Raises
    ------
    SpecError, ConstraintError, FactorizationError
    """
    with using((options or current()).updated(spec.solve_options)) as effective:
        return _precompute(mesh, spec, progress, effective)


def _precompute(mesh: Mesh, spec: ResolvedSpec, progress: Progress | None, options: SolveOptions) -> DeformData:
    t0 = time.perf_counter()
    report: Progress = progress or (lambda stage, fraction: None)
    _touch_topology(mesh)
    cs = constraint_set(mesh, spec)
    report("constraints", 0.05)
    ops = operators(mesh, spec)
    start = interior_start(mesh, spec, cs, ops)  # the interior LU runs on a second thread from here
    try:
        walls = wall_rows(mesh, spec.thin_walls, ops.Lb)
        t_assembly = time.perf_counter() - t0
        report("assembly", 0.35)
        t1 = time.perf_counter()
        rotation = rotation_field_precompute(mesh, spec, cs, ops)
        t_rot = time.perf_counter() - t1
        report("rotation", 0.5)
        midside = MidsideNodes(mesh.V, mesh.T10) if mesh.T10 is not None else None
        check = _surface_check(mesh) if mesh.is_surface else ElementCheck(mesh.V, mesh.T, mesh.cells, mesh.T10,
                                                                          mesh.degenerate_at_rest)
        t2 = time.perf_counter()

        def rhs_for(move: ResolvedMove, rows: np.ndarray) -> RightHandSides:
            return right_hand_sides(mesh, cs, rotation, ops.delta, walls, rows, True, move)

        positions = positions_precompute(mesh, spec, cs, ops, walls, rhs_for, start)
    except BaseException:
        if start is not None:
            start.settle()
        raise
    t_pos = time.perf_counter() - t2
    report("positions", 0.95)
    timings = {"assembly_ms": 1e3 * t_assembly, "rotation_factorization_ms": 1e3 * t_rot,
               "position_factorization_ms": 1e3 * t_pos, "total_ms": 1e3 * (time.perf_counter() - t0)}
    data = DeformData(mesh=mesh, spec=spec, constraints=cs, delta=ops.delta, walls=walls, rotation=rotation,
                      positions=positions, midside=midside, pinned_mid=cs.pinned_mid, check=check,
                      setup_timings=timings, factorizations=rotation.factorizations + positions.factorizations,
                      options=options)
    report("done", 1.0)
    return data


def describe_setup(data: DeformData) -> dict[str, Any]:
    """Set-up facts for a session document: timings, factorizations, bytes, solve mode."""
    return {"timings": data.setup_timings, "factorizations": data.factorizations, "nbytes": data.nbytes,
            "solve_mode": data.constraints.mode}
