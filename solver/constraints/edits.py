"""The daily edits resolved on a mesh: each selection's nodes and their prescribed positions per MOVE.

An :class:`Edit` holds every node its SPEC entry moves (corner and mid-side nodes, sorted), their
rest positions, and what its kind needs to place them: :meth:`Edit.positions` is where a MOVE's value
puts them, :meth:`Edit.derivative` its derivative along a shape's value, :meth:`Edit.check` refuses
values that have no meaning on this mesh. The nodes are held like a handle's (corner nodes among the
constrained nodes, one hard row each; mid-side nodes pinned), so every prescribed position holds
exactly and the REPORT's ``constraint_residual_max`` covers them.

``radius``
    ``p = p0 + (r' - r) w/|w|``, ``w`` the node's radial vector about the axis, ``r = |w|``.
``twist``
    ``p = a + s d + R_d(phi(s)) w``: the node turned about the axis by the angle at its axial
    coordinate ``s``; mode ``bend``: ``p = a + int_0^s (cos phi d + sin phi t) + x n(s) + y b``,
    the axis bent toward ``t`` and each cross-section rigid, orthogonal to it.
``map``
    ``p = p0 + t (q - p0)``, ``q`` the node's point on the geometry (nearest, or along a direction).
``offset``
    ``p = p0 + delta n``: one normal for a planar face set, each node's own otherwise.
``lattice``
    ``p = p0 + sum B_i(u) B_j(v) B_k(w) d_ijk`` over the displaced control points.

The ``fillet``, ``distance`` and ``angle`` edits are :mod:`solver.constraints.feature_edits`'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import MAX_IDS, SpecError, format_ids
from ..limits import ANGLE_MAX
from ..mesh import Mesh
from ..ops.elements import midside_edges
from .edit_entries import EditEntry, LatticeEntry, MapEntry, OffsetEntry, RadiusEntry, TwistEntry
from .edit_values import EditValue, LatticeValue, MapValue, OffsetValue, RadiusValue, TwistValue
from .projections import ON_AXIS, nearest_points, points_along, radial
from .selection import node_masks

__all__ = ["Edit", "RadiusEdit", "TwistEdit", "BendEdit", "MapEdit", "OffsetEdit", "LatticeEdit", "resolve_edit",
           "CYLINDER_FIT_TOL"]

#: A fitted axis is refused when the selection's nodes lie farther than this fraction of the radius
#: (rms) from the fitted cylinder.
CYLINDER_FIT_TOL = 1e-3


@dataclass(frozen=True, eq=False)
class Edit:
    """One edit's nodes and rest positions.

    Attributes
    ----------
    kind : str
        Its SPEC key (``radius``, ``twist``, ``map``, ``offset``, ``lattice``, ``fillet``, ``distance``,
        ``angle``).
    index : int
        Its position in that SPEC list.
    name : str
    nodes : (k,) int array
        Every node it moves, sorted; corner and mid-side nodes.
    corner : (k,) bool array
        Which of them are corner nodes.
    rest : (k, 3) float array
    """

    kind: str
    index: int
    name: str
    nodes: np.ndarray
    corner: np.ndarray
    rest: np.ndarray

    @property
    def where(self) -> str:
        """The entry in messages: ``SPEC.radius[0] ('bore')``."""
        return f"SPEC.{self.kind}[{self.index}] ({self.name!r})"

    @property
    def ids(self) -> np.ndarray:
        """Corner nodes."""
        return self.nodes[self.corner]

    @property
    def mid_ids(self) -> np.ndarray:
        """Mid-side nodes."""
        return self.nodes[~self.corner]

    def positions(self, value: EditValue | None) -> np.ndarray:
        """Positions (k, 3) of :attr:`nodes` under a MOVE's value (None: the rest positions)."""
        if value is None:
            return self.rest
        return self.rest + self.change(value)

    def change(self, value: Any) -> np.ndarray:
        """Displacements (k, 3) of the nodes under ``value``."""
        raise NotImplementedError

    def derivative(self, value: Any, step: Any) -> np.ndarray:
        """Derivative (k, 3) of the positions at ``value`` when the value moves along ``step``.

        The edits whose positions are linear in their value: the displacement of ``step``.
        """
        return self.change(step)

    #: The MOVE parameter that sets the dimension this edit measures at rest (``radius``,
    #: ``distance``, ``angle_deg``); None for an edit without one (twist, map, offset, lattice).
    parameter: ClassVar[str | None] = None

    @property
    def dimension(self) -> float | None:
        """The dimension at rest that :attr:`parameter` sets: a radius, a distance, or an angle in degrees."""
        nominal = getattr(self, "nominal", None)
        return None if self.parameter is None or nominal is None else float(nominal)

    def check(self, value: Any, where: str) -> None:
        """Refuse a value without meaning on this mesh (``where`` names it, ``MOVE.radius.bore``)."""

    @property
    def slides(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodes (m,) held on planes through their rest positions, and the planes' unit normals (m, 3): none here."""
        return np.zeros(0, np.int64), np.zeros((0, 3))

    def with_free(self, free: np.ndarray) -> Edit:
        """The edit with only the sliding nodes that ``free`` (n,) bool marks (no other constraint holds them)."""
        return self


@dataclass(frozen=True, eq=False)
class RadiusEdit(Edit):
    """A cylindrical feature: each node's radial unit vector ``u`` and rest radius ``r`` about the axis.

    Attributes
    ----------
    point, direction : (3,) float arrays
        The axis (given, or fitted to the selection's boundary faces).
    u : (k, 3) float array
    r : (k,) float array
    nominal : float
        The mean rest radius: a new radius scaled by a fraction is ``nominal + f (radius - nominal)``.
    """

    point: np.ndarray
    direction: np.ndarray
    u: np.ndarray
    r: np.ndarray
    nominal: float
    parameter: ClassVar[str | None] = "radius"

    def change(self, value: RadiusValue) -> np.ndarray:
        """``(r' - r) u``: every node to the new radius, or its radius changed by ``delta``."""
        dr = (value.radius - self.r) if value.radius is not None else np.full(self.r.size, float(value.delta or 0.0))
        return dr[:, None] * self.u

    def derivative(self, value: RadiusValue | None, step: RadiusValue) -> np.ndarray:
        """``dr u``, ``dr`` the step's change (a new radius: its change from the nominal radius)."""
        dr = float(step.delta) if step.delta is not None else float(step.radius or 0.0) - self.nominal
        return dr * self.u

    def check(self, value: RadiusValue, where: str) -> None:
        """A change that leaves some node at a radius of zero or less is refused."""
        if value.delta is not None and float(self.r.min()) + value.delta <= 0.0:
            raise SpecError(f"{where}.delta: {value.delta:g} takes the radius of {self.where} to "
                            f"{float(self.r.min()) + value.delta:.6g} at its innermost node; a radius must "
                            "stay positive", field=f"{where}.delta", value=value.delta)


@dataclass(frozen=True, eq=False)
class TwistEdit(Edit):
    """Nodes turned about an axis: axial coordinates ``s``, radial vectors ``w`` and ``d x w``."""

    point: np.ndarray
    direction: np.ndarray
    s: np.ndarray
    w: np.ndarray
    dw: np.ndarray

    def change(self, value: TwistValue) -> np.ndarray:
        """``w (cos phi - 1) + (d x w) sin phi``, ``cos phi - 1`` as ``-2 sin^2(phi / 2)``."""
        phi = value.angles(self.s)
        return -2.0 * np.sin(0.5 * phi)[:, None] ** 2 * self.w + np.sin(phi)[:, None] * self.dw

    def derivative(self, value: TwistValue, step: TwistValue) -> np.ndarray:
        """``phi_step(s) d x (p - a)``: the turn's rate times the tangent of the circle the node is on."""
        p = self.positions(value)
        return step.angles(self.s)[:, None] * np.cross(self.direction, p - self.point)

    def check(self, value: TwistValue, where: str) -> None:
        """A linear law that turns some node by more than :data:`~solver.limits.ANGLE_MAX` degrees is refused."""
        _check_angles(self, value, self.s, where)


def _check_angles(e: Edit, value: TwistValue, s: np.ndarray, where: str) -> None:
    if value.rate is not None and s.size:
        worst = float(np.abs(value.rate * s).max())
        if worst > ANGLE_MAX:
            raise SpecError(f"{where}.angle_deg_per_length: {value.rate:g} turns a node of {e.where} by "
                            f"{worst:.6g} degrees, beyond {ANGLE_MAX:g}", field=f"{where}.angle_deg_per_length",
                            value=value.rate, bound=ANGLE_MAX)


def _knots(*values: TwistValue | None) -> np.ndarray:
    """Where the angle laws of ``values`` bend: their tables' rows, and 0 (where the arc length starts)."""
    return np.union1d(np.concatenate([np.asarray(v.at, np.float64) for v in values if v is not None] or
                                     [np.zeros(0)]), [0.0])


def _excess(knots: np.ndarray, th_knots: np.ndarray, s: np.ndarray, th_s: np.ndarray) -> tuple[np.ndarray, ...]:
    """``int_0^s (cos th - 1)`` and ``int_0^s sin th`` of an angle ``th`` linear between ``knots`` (held beyond).

    On a piece of length ``L`` where ``th`` goes from ``a`` to ``b``: ``int cos th = L cos m sinc h`` and
    ``int sin th = L sin m sinc h``, ``m = (a + b) / 2``, ``h = (b - a) / 2``, ``sinc h = sin h / h``; the
    ``- 1`` is taken out without cancellation (``cos m sinc h - 1 = -2 sin^2(m/2) - cos m (1 - sinc h)``),
    so a zero angle gives zeros exactly. Complex angles pass through (a complex step).
    """
    def piece(length: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m, sc = 0.5 * (a + b), np.sinc(0.5 * (b - a) / np.pi)
        return (length * (-2.0 * np.sin(0.5 * m) ** 2 - np.cos(m) * (1.0 - sc)), length * np.sin(m) * sc)

    ec, es = piece(np.diff(knots), th_knots[:-1], th_knots[1:])
    zero = int(np.searchsorted(knots, 0.0))
    hc, hs = np.concatenate([[0.0], np.cumsum(ec)]), np.concatenate([[0.0], np.cumsum(es)])
    j = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, knots.size - 1)
    pc, ps = piece(s - knots[j], th_knots[j], th_s)
    return hc[j] - hc[zero] + pc, hs[j] - hs[zero] + ps


@dataclass(frozen=True, eq=False)
class BendEdit(Edit):
    """Nodes bent along an axis: axial coordinates ``s`` and offsets ``x`` toward ``toward`` (unit, off the axis).

    The axis becomes the curve ``a + int_0^s (cos th d + sin th t)`` and a node at ``(s, x)`` goes to
    its point plus ``x`` times the curve's normal ``-sin th d + cos th t``; the third coordinate is kept.
    """

    point: np.ndarray
    direction: np.ndarray
    toward: np.ndarray
    s: np.ndarray
    x: np.ndarray

    def _bent(self, knots: np.ndarray, th_knots: np.ndarray, th_s: np.ndarray) -> np.ndarray:
        ec, es = _excess(knots, th_knots, self.s, th_s)
        along = ec - self.x * np.sin(th_s)
        side = es - self.x * 2.0 * np.sin(0.5 * th_s) ** 2
        return np.outer(along, self.direction) + np.outer(side, self.toward)

    def change(self, value: TwistValue) -> np.ndarray:
        """The bent positions less the rest ones."""
        knots = _knots(value)
        return self._bent(knots, value.angles(knots), value.angles(self.s))

    def derivative(self, value: TwistValue | None, step: TwistValue) -> np.ndarray:
        """By a complex step: ``Im change(th + i h th_step) / h``, exact to round-off (the map is analytic)."""
        h = 1e-30
        knots = _knots(value, step)

        def at(t: np.ndarray) -> np.ndarray:
            base = value.angles(t) if value is not None else np.zeros(t.shape)
            return base + 1j * h * step.angles(t)

        return self._bent(knots, at(knots), at(self.s)).imag / h

    def check(self, value: TwistValue, where: str) -> None:
        """As a twist's: angles within :data:`~solver.limits.ANGLE_MAX`."""
        _check_angles(self, value, self.s, where)


@dataclass(frozen=True, eq=False)
class MapEdit(Edit):
    """Nodes mapped onto a geometry: each node's point ``q`` on it."""

    q: np.ndarray

    def change(self, value: MapValue) -> np.ndarray:
        """``t (q - p0)``."""
        return value.amount * (self.q - self.rest)


@dataclass(frozen=True, eq=False)
class OffsetEdit(Edit):
    """Faces moved along their normal: each node's displacement per unit distance ``n``.

    ``planar`` states whether the selection's faces were planar (one normal for all).
    """

    n: np.ndarray
    planar: bool

    def change(self, value: OffsetValue) -> np.ndarray:
        """``delta n``."""
        return value.distance * self.n


@dataclass(frozen=True, eq=False)
class LatticeEdit(Edit):
    """A morph volume: the Bernstein polynomials of each axis at each node's box coordinates."""

    counts: tuple[int, int, int]
    bu: np.ndarray
    bv: np.ndarray
    bw: np.ndarray

    def change(self, value: LatticeValue) -> np.ndarray:
        """``sum B_i(u) B_j(v) B_k(w) d_ijk`` over the displaced control points."""
        self.check(value, f"MOVE.lattice.{self.name}")
        out = np.zeros(self.rest.shape)
        for (i, j, k), dv in value.displacements.items():
            out += np.outer(self.bu[:, i] * self.bv[:, j] * self.bw[:, k], dv)
        return out

    def check(self, value: LatticeValue, where: str) -> None:
        """A control point outside the lattice is refused."""
        for key in value.displacements:
            if any(c >= n for c, n in zip(key, self.counts, strict=True)):
                label = ",".join(str(c) for c in key)
                raise SpecError(f"{where}.displacements: control point {label!r} is outside the lattice of "
                                f"{self.where}, {'x'.join(str(n) for n in self.counts)} points (0-based indices)",
                                field=f"{where}.displacements", point=label, counts=list(self.counts))


def bernstein(t: np.ndarray, n: int) -> np.ndarray:
    """The ``n`` Bernstein polynomials of degree ``n - 1`` at ``t`` (k,): (k, n), rows summing to one."""
    deg = n - 1
    i = np.arange(n)
    comb = np.array([math.comb(deg, int(j)) for j in i], np.float64)
    t = np.asarray(t, np.float64)[:, None]
    return comb * t ** i * (1.0 - t) ** (deg - i)


def _ids_error(where: str, what: str, ids: np.ndarray, field: str, code: str) -> SpecError:
    return SpecError(f"{where}: {ids.size} nodes {what} ({format_ids(ids)})", code=code, field=field,
                     ids=ids[:MAX_IDS].tolist())


def _base(mesh: Mesh, e: EditEntry, nodes: np.ndarray) -> dict[str, Any]:
    nodes = np.asarray(nodes, np.int64)
    corner = mesh.referenced[nodes]
    where = f"SPEC.{e.kind}[{e.index}] ({e.name!r})"
    if not corner.any():
        raise SpecError(f"{where}: its selection holds no corner node ({nodes.size} mid-side nodes); an edit needs "
                        "at least one", code="empty_selection", field=f"{e.kind}[{e.index}]")
    return {"kind": e.kind, "index": e.index, "name": e.name, "nodes": nodes, "corner": corner,
            "rest": mesh.V[nodes].copy()}


def _faces_of(mesh: Mesh, nodes: np.ndarray) -> np.ndarray:
    """Boundary faces whose corners are all ``nodes``."""
    inside = np.zeros(mesh.n, bool)
    inside[nodes] = True
    F = mesh.F
    return F[inside[F].all(axis=1)]


def _fitted_axis(mesh: Mesh, e: RadiusEntry, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The axis of the cylinder fitted to the selection's boundary faces (``tetmorph features``'s fit)."""
    from .features import _face_normals, _fit_cylinder

    where = f"SPEC.radius[{e.index}] ({e.name!r})"
    F = _faces_of(mesh, nodes[mesh.referenced[nodes]])
    if len(F) < 4:
        raise SpecError(f"{where}: its selection holds {len(F)} boundary faces; fitting an axis needs a "
                        "cylindrical face set (or give the axis)", code="not_a_cylinder", field=f"radius[{e.index}]")
    N, area = _face_normals(mesh.V, F)
    ids = np.unique(F)
    axis, center, r, rms, _, _ = _fit_cylinder(mesh.V[ids], N, area, mesh.V[F].mean(axis=1))
    if not (r > 0 and rms <= CYLINDER_FIT_TOL * r):
        raise SpecError(f"{where}: its boundary faces are not a cylinder (fitted radius {r:.6g}, rms distance "
                        f"{rms:.3g}); give the axis", code="not_a_cylinder", field=f"radius[{e.index}]",
                        radius=float(r), rms=float(rms))
    return np.asarray(center, np.float64), np.asarray(axis, np.float64) / float(np.linalg.norm(axis))


def _radius(mesh: Mesh, e: RadiusEntry, nodes: np.ndarray) -> RadiusEdit:
    base = _base(mesh, e, nodes)
    if e.point is None or e.direction is None:
        point, d = _fitted_axis(mesh, e, nodes)
    else:
        point, d = np.asarray(e.point, np.float64), np.asarray(e.direction, np.float64)
    _, w, r = radial(base["rest"], point, d)
    scale = float(np.median(r)) if r.size else 0.0
    on = r <= ON_AXIS * max(scale, 1e-300) if scale > 0 else np.ones(r.size, bool)
    if on.any():
        raise _ids_error(f"SPEC.radius[{e.index}] ({e.name!r})", "lie on the axis, where no radial direction "
                         "exists; leave them out of the selection", base["nodes"][on], f"radius[{e.index}]",
                         code="node_on_axis")
    return RadiusEdit(**base, point=point, direction=d, u=w / r[:, None], r=r, nominal=float(r.mean()))


def _twist(mesh: Mesh, e: TwistEntry, nodes: np.ndarray) -> TwistEdit | BendEdit:
    base = _base(mesh, e, nodes)
    a, d = np.asarray(e.point, np.float64), np.asarray(e.direction, np.float64)
    s, w, _ = radial(base["rest"], a, d)
    if e.mode == "bend" and e.toward is not None:
        t = np.asarray(e.toward, np.float64)
        return BendEdit(**base, point=a, direction=d, toward=t, s=s, x=w @ t)
    return TwistEdit(**base, point=a, direction=d, s=s, w=w, dw=np.cross(d, w))


def _map(mesh: Mesh, e: MapEntry, nodes: np.ndarray) -> MapEdit:
    base = _base(mesh, e, nodes)
    P = base["rest"]
    where = f"SPEC.map[{e.index}] ({e.name!r})"
    if e.projection == "along" and e.along is not None:
        q, bad = points_along(e, P, np.asarray(e.along, np.float64))
        if bad.any():
            raise _ids_error(where, f"miss the {e.shape} along the direction {list(e.along)}", base["nodes"][bad],
                             f"map[{e.index}]", code="no_intersection")
    else:
        q, bad = nearest_points(e, P)
        if bad.any():
            what = "lie at the sphere's centre" if e.shape == "sphere" else f"lie on the {e.shape}'s axis"
            raise _ids_error(where, f"{what}, where no nearest point is unique", base["nodes"][bad],
                             f"map[{e.index}]", code="node_on_axis")
    return MapEdit(**base, q=q)


def _normals(mesh: Mesh, nodes: np.ndarray, planar_deg: float, where: str, field: str
             ) -> tuple[np.ndarray, bool]:
    """Unit outward normals (k, 3) of ``nodes`` from their selection's boundary faces, and whether those are planar."""
    corner = nodes[mesh.referenced[nodes]]
    F = _faces_of(mesh, corner)
    if not len(F):
        raise SpecError(f"{where}: its selection holds no boundary face; an offset moves a face set",
                        code="empty_selection", field=field)
    V = mesh.V
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])  # twice the area, outward
    mean = fn.sum(axis=0)
    size = float(np.linalg.norm(mean))
    unit = np.sqrt(np.einsum("ij,ij->i", fn, fn))
    cos = (fn @ mean) / np.maximum(unit * size, 1e-300)
    planar = size > 0 and bool((cos >= math.cos(math.radians(planar_deg))).all())
    if planar:
        return np.repeat((mean / size)[None, :], nodes.size, axis=0), True
    N = np.zeros((mesh.n, 3))
    for j in range(3):
        np.add.at(N, F[:, j], fn)
    if mesh.T10 is not None:
        mids, a, b = midside_edges(mesh.T10)
        N[mids] = N[a] + N[b]
    out = N[nodes]
    length = np.sqrt(np.einsum("ij,ij->i", out, out))
    stray = length <= 1e-300
    if stray.any():
        raise _ids_error(where, "lie on none of the selection's boundary faces; an offset moves a face set",
                         nodes[stray], field, code="bad_selection")
    return out / length[:, None], False


def _offset(mesh: Mesh, e: OffsetEntry, sel_ids: dict[str, np.ndarray]) -> OffsetEdit:
    where = f"SPEC.offset[{e.index}] ({e.name!r})"
    field = f"offset[{e.index}]"
    first = sel_ids[e.selection]
    n1, planar = _normals(mesh, first, e.planar_deg, where, field)
    parts, dirs = [first], [n1 * (0.5 if e.symmetric else 1.0)]
    if e.opposite is not None:
        other = sel_ids[e.opposite]
        both = np.intersect1d(first, other)
        if both.size:
            raise _ids_error(where, f"are both in {e.selection!r} and its opposite {e.opposite!r}", both,
                             field, code="overlapping_constraints")
        n2 = _normals(mesh, other, e.planar_deg, where, field)[0] if e.symmetric else np.zeros((other.size, 3))
        parts.append(other)
        dirs.append(0.5 * n2)
    nodes = np.concatenate(parts)
    order = np.argsort(nodes, kind="stable")
    base = _base(mesh, e, nodes[order])
    return OffsetEdit(**base, n=np.concatenate(dirs)[order], planar=planar)


def _lattice(mesh: Mesh, e: LatticeEntry, sel_ids: dict[str, np.ndarray]) -> LatticeEdit:
    where = f"SPEC.lattice[{e.index}] ({e.name!r})"
    lo, hi = np.asarray(e.lo, np.float64), np.asarray(e.hi, np.float64)
    V = mesh.V
    if e.selection is not None:
        nodes = sel_ids[e.selection]
        out = nodes[~np.all((V[nodes] >= lo) & (V[nodes] <= hi), axis=1)]
        if out.size:
            raise _ids_error(where, "of its selection lie outside its box, where the lattice's polynomials do not "
                             "reach", out, f"lattice[{e.index}]", code="bad_selection")
    else:
        used, on_b = node_masks(mesh)
        nodes = np.flatnonzero(used & on_b & np.all((V >= lo) & (V <= hi), axis=1))
        if not nodes.size:
            raise SpecError(f"{where}: no boundary node lies inside its box", code="empty_selection",
                            field=f"lattice[{e.index}]")
    base = _base(mesh, e, nodes)
    uvw = np.clip((base["rest"] - lo) / (hi - lo), 0.0, 1.0)
    nx, ny, nz = e.counts
    return LatticeEdit(**base, counts=e.counts, bu=bernstein(uvw[:, 0], nx), bv=bernstein(uvw[:, 1], ny),
                       bw=bernstein(uvw[:, 2], nz))


def resolve_edit(mesh: Mesh, e: EditEntry, sets: dict[str, np.ndarray]) -> Edit:
    """Resolve one ``radius``, ``twist``, ``map``, ``offset`` or ``lattice`` entry on ``mesh``.

    ``sets``: every selection's nodes, sorted and unique.

    Raises
    ------
    SpecError
        A selection without corner nodes (``empty_selection``), nodes on a radius's or a mapped
        circle's or cylinder's axis or at a sphere's centre (``node_on_axis``), lines that miss a
        mapped surface (``no_intersection``), an axis that cannot be fitted (``not_a_cylinder``), an
        offset whose selection has no boundary face or nodes on none (``empty_selection``,
        ``bad_selection``), a lattice selection outside its box (``bad_selection``).
    """
    if isinstance(e, RadiusEntry):
        return _radius(mesh, e, sets[e.selection])
    if isinstance(e, TwistEntry):
        return _twist(mesh, e, sets[e.selection])
    if isinstance(e, MapEntry):
        return _map(mesh, e, sets[e.selection])
    if isinstance(e, OffsetEntry):
        return _offset(mesh, e, sets)
    if isinstance(e, LatticeEntry):
        return _lattice(mesh, e, sets)
    raise TypeError(f"{type(e).__name__} is resolved by solver.constraints.feature_edits")
