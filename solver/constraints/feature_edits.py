"""The edits that change a dimension between features: a fillet's radius, a distance, an angle.

Each is an :class:`~solver.constraints.edits.Edit`: its nodes get prescribed positions from their
rest positions and the MOVE's value, and are held like a handle's.

``fillet``
    Planes ``n_a . x = h_a`` and ``n_b . x = h_b`` fitted to the two faces, the fillet's axis along
    ``d = n_a x n_b``. The axis at radius ``r`` is ``c0 + r g``, ``g`` solving ``n_a . g = s_a``,
    ``n_b . g = s_b``, ``d . g = 0`` (``s`` the side of each plane the fillet lies on), so it stays at
    distance ``r`` from both planes. A node at axial coordinate ``t`` and unit radial direction
    ``u`` goes to ``p = c0 + t d + r' (g + u)``: its axial coordinate and its angle on the arc are
    kept, its distance from the new axis is ``r'``. The faces' other nodes get rows
    ``n . p = n . p0`` (they slide on their planes).
``distance``
    ``p = p0 + (D' - D) e`` for the moving feature's nodes, ``e`` the measuring direction (along
    the centroids, or given), ``D`` the rest distance; the reference's nodes stay.
``angle``
    ``p = c + R_k(psi) (p0 - c)`` for the moving feature's nodes, ``psi`` the turn about ``k`` that
    sets the angle between the two directions to the MOVE's; the reference's nodes stay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np

from ..errors import SpecError
from ..mesh import Mesh
from .edit_entries import AngleEntry, DistanceEntry, FilletEntry
from .edit_values import AngleValue, DistanceValue, RadiusValue
from .edits import Edit, _base, _faces_of, _ids_error

__all__ = ["FilletEdit", "DistanceEdit", "AngleEdit", "fillet_edit", "distance_edit", "angle_edit",
           "PLANE_FIT_TOL", "ARC_TOL"]

#: A face is planar when its corner nodes lie within this fraction of its extent from the fitted plane.
PLANE_FIT_TOL = 1e-3
#: A fillet node lies on the fitted arc when its distance from the axis is within this fraction of the
#: radius, and its angle on the arc within this fraction of the arc's beyond its ends.
ARC_TOL = 1e-2
#: Two planes (or two directions) are parallel when the sine of their angle is below this.
PARALLEL_SIN = 1e-6


def _unit(v: np.ndarray) -> np.ndarray:
    return v / float(np.linalg.norm(v))


@dataclass(frozen=True, eq=False)
class FilletEdit(Edit):
    """A fillet: its corner line, the axis's direction of travel, each node's axial part and arc direction.

    Attributes
    ----------
    direction : (3,) float array
        The axis's unit direction ``d``.
    g : (3,) float array
        The axis at radius ``r`` passes through ``c0 + r g``.
    base : (k, 3) float array
        ``c0 + t d`` of each node, ``t`` its axial coordinate.
    u : (k, 3) float array
        Each node's unit radial direction, its angle on the arc clamped to the arc.
    reach : (2, 3) float arrays
        Per face, ``g + e``, ``e`` the unit direction from the axis to the face's tangent line: the
        tangent line at radius ``r`` lies at ``c0 + r (g + e)``.
    room : (2,) float array
        Per face, how far its nodes reach from the corner line along ``g + e``.
    nominal : float
        The fitted rest radius.
    slide_ids : (m,) int array
        The faces' corner nodes held on their planes (not the fillet's).
    slide_normals : (m, 3) float array
    """

    direction: np.ndarray
    g: np.ndarray
    base: np.ndarray
    u: np.ndarray
    reach: np.ndarray
    room: np.ndarray
    nominal: float
    parameter: ClassVar[str | None] = "radius"
    slide_ids: np.ndarray
    slide_normals: np.ndarray

    def radius_of(self, value: RadiusValue) -> float:
        """The new radius a value sets."""
        return float(value.radius) if value.radius is not None else self.nominal + float(value.delta or 0.0)

    def change(self, value: RadiusValue) -> np.ndarray:
        """``c0 + t d + r' (g + u) - p0``: every node on the arc of radius ``r'``."""
        return self.base + self.radius_of(value) * (self.g + self.u) - self.rest

    def derivative(self, value: RadiusValue | None, step: RadiusValue) -> np.ndarray:
        """``dr (g + u)``, ``dr`` the step's change of radius."""
        dr = float(step.delta) if step.delta is not None else float(step.radius or 0.0) - self.nominal
        return dr * (self.g[None, :] + self.u)

    def check(self, value: RadiusValue, where: str) -> None:
        """A radius of zero or less, or one whose tangent lines leave a face, is refused (``fillet_too_large``)."""
        r = self.radius_of(value)
        key = "radius" if value.radius is not None else "delta"
        given = value.radius if value.radius is not None else value.delta
        if r <= 0.0:
            raise SpecError(f"{where}.{key}: {given:g} takes the radius of {self.where} to {r:.6g}; a radius must "
                            "stay positive", field=f"{where}.{key}", value=given)
        need = r * np.linalg.norm(self.reach, axis=1)
        over = np.flatnonzero(need >= self.room)
        if over.size:
            limit = float((self.room / np.linalg.norm(self.reach, axis=1)).min())
            raise SpecError(f"{where}.{key}: a radius of {r:.6g} puts the tangent line of {self.where} "
                            f"{float(need[over[0]]):.6g} from the corner line, beyond its face, which reaches "
                            f"{float(self.room[over[0]]):.6g}; the radius must stay below {limit:.6g}",
                            code="fillet_too_large", field=f"{where}.{key}", value=given, bound=limit)

    def with_free(self, free: np.ndarray) -> FilletEdit:
        """The edit with only the sliding nodes that no other constraint holds (``free`` (n,) bool)."""
        keep = free[self.slide_ids]
        return replace(self, slide_ids=self.slide_ids[keep], slide_normals=self.slide_normals[keep])

    @property
    def slides(self) -> tuple[np.ndarray, np.ndarray]:
        """The faces' nodes held on their planes and the planes' normals."""
        return self.slide_ids, self.slide_normals


def _plane(mesh: Mesh, ids: np.ndarray, where: str, field: str, face: str) -> tuple[np.ndarray, np.ndarray]:
    """The plane (point, unit normal) fitted to the corner nodes ``ids``; ``not_planar`` unless they lie on one."""
    P = mesh.V[ids[mesh.referenced[ids]]]
    if len(P) < 3:
        raise SpecError(f"{where}: face {face!r} holds {len(P)} corner nodes; a plane needs three",
                        code="not_planar", field=field, face=face)
    c = P.mean(axis=0)
    _, sv, vt = np.linalg.svd(P - c, full_matrices=False)
    n = vt[2]
    extent = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    off = float(np.abs((P - c) @ n).max())
    if sv[1] <= 1e-9 * max(sv[0], 1e-300) or off > PLANE_FIT_TOL * extent:
        raise SpecError(f"{where}: face {face!r} is not planar (its nodes lie up to {off:.3g} from the fitted "
                        f"plane, {off / max(extent, 1e-300):.3g} of its extent; at most {PLANE_FIT_TOL:g})",
                        code="not_planar", field=field, face=face, distance=off)
    return c, n


def _fit_radius(Q: np.ndarray, g: np.ndarray) -> float:
    """The radius ``r`` minimizing ``sum (|q - r g| - r)^2`` over the points ``Q`` (k, 3), orthogonal to the axis."""
    size = float(np.sqrt(np.einsum("ij,ij->i", Q, Q)).max())

    def cost(r: np.ndarray) -> np.ndarray:
        W = Q[None, :, :] - r[:, None, None] * g
        return ((np.sqrt(np.einsum("rij,rij->ri", W, W)) - r[:, None]) ** 2).sum(axis=1)

    grid = np.geomspace(1e-4 * size, 1e2 * size, 400)
    r = float(grid[int(np.argmin(cost(grid)))])
    for _ in range(50):  # Gauss-Newton on the residuals |q - r g| - r
        W = Q - r * g
        rho = np.sqrt(np.einsum("ij,ij->i", W, W))
        res = rho - r
        jac = -(W @ g) / rho - 1.0
        step = -float(jac @ res) / float(jac @ jac)
        r += step
        if abs(step) <= 1e-15 * r:
            break
    return r


def fillet_edit(mesh: Mesh, e: FilletEntry, sets: dict[str, np.ndarray]) -> FilletEdit:
    """Resolve a ``fillet`` entry: the planes, the fitted axis and radius, each node's place on the arc.

    Raises
    ------
    SpecError
        A face that is not planar (``not_planar``), parallel faces (``parallel_faces``), a fillet on
        neither side of a plane or nodes off the fitted arc (``off_arc``).
    """
    where, field = f"SPEC.fillet[{e.index}] ({e.name!r})", f"fillet[{e.index}]"
    base = _base(mesh, e, sets[e.selection])
    X = base["rest"]
    (pa, na), (pb, nb) = (_plane(mesh, sets[f], where, field, f) for f in e.faces)
    cross = np.cross(na, nb)
    if float(np.linalg.norm(cross)) <= PARALLEL_SIN:
        raise SpecError(f"{where}: faces {list(e.faces)} are parallel; a fillet joins two faces at an angle",
                        code="parallel_faces", field=field)
    d = _unit(cross)
    corner = X[base["corner"]]
    side = np.array([np.sign(((corner - pa) @ na).mean()), np.sign(((corner - pb) @ nb).mean())])
    M = np.stack([na, nb, d])
    c0 = np.linalg.solve(M, [pa @ na, pb @ nb, float((corner @ d).mean())])
    g = np.linalg.solve(M, [side[0], side[1], 0.0])
    T = X - c0
    t = T @ d
    Q = T - np.outer(t, d)
    r = _fit_radius(Q[base["corner"]], g)
    W = Q - r * g
    rho = np.sqrt(np.einsum("ij,ij->i", W, W))
    ea, eb = -side[0] * na, -side[1] * nb  # from the axis toward each tangent line
    beta = math.atan2(float(np.linalg.norm(np.cross(ea, eb))), float(ea @ eb))
    f = _unit(eb - (eb @ ea) * ea)
    frac = np.arctan2(W @ f, W @ ea) / beta
    off = (np.abs(rho - r) > ARC_TOL * r) | (frac < -ARC_TOL) | (frac > 1.0 + ARC_TOL)
    if not (r > 0 and side.all()) or off.any():
        bad = base["nodes"][off] if off.any() else base["nodes"]
        raise _ids_error(where, f"lie off the arc fitted to the fillet (radius {r:.6g}, tangent to both faces; "
                         f"allowed: {ARC_TOL:g} of the radius, or of the arc beyond its ends)", bad, field,
                         code="off_arc")
    a = np.clip(frac, 0.0, 1.0)[:, None] * beta
    u = np.cos(a) * ea + np.sin(a) * f
    reach = np.stack([g + ea, g + eb])
    slide, normals, room = [], [], []
    for fname, n, h in zip(e.faces, (na, nb), reach, strict=True):
        ids = sets[fname]
        ids = ids[mesh.referenced[ids] & mesh.boundary[ids]]
        room.append(float(((mesh.V[ids] - c0) @ _unit(h)).max()))
        ids = np.setdiff1d(ids, base["nodes"])
        slide.append(ids)
        normals.append(np.repeat(n[None, :], ids.size, axis=0))
    return FilletEdit(**base, direction=d, g=g, base=c0 + np.outer(t, d), u=u, reach=reach, room=np.asarray(room),
                      nominal=r, slide_ids=np.concatenate(slide), slide_normals=np.concatenate(normals))


def _two_features(mesh: Mesh, e: DistanceEntry | AngleEntry, sets: dict[str, np.ndarray]
                  ) -> tuple[dict[str, Any], np.ndarray]:
    """The base of an edit over the moving and the reference feature's nodes, and which are moving."""
    moving, ref = sets[e.selection], sets[e.reference]
    both = np.intersect1d(moving, ref)
    if both.size:
        raise _ids_error(f"SPEC.{e.kind}[{e.index}] ({e.name!r})", f"are both in {e.selection!r} and its "
                         f"reference {e.reference!r}", both, f"{e.kind}[{e.index}]", code="overlapping_constraints")
    nodes = np.concatenate([moving, ref])
    order = np.argsort(nodes, kind="stable")
    base = _base(mesh, e, nodes[order])
    return base, np.isin(base["nodes"], moving)


@dataclass(frozen=True, eq=False)
class DistanceEdit(Edit):
    """Two features: the moving one's nodes translate along ``e`` (``n``: ``e`` on them, zero on the reference's).

    ``signed``: measured along a given direction (any sign), else between the centroids (positive).
    """

    n: np.ndarray
    nominal: float
    parameter: ClassVar[str | None] = "distance"
    signed: bool

    def distance_of(self, value: DistanceValue) -> float:
        """The distance a value sets."""
        return float(value.distance) if value.distance is not None else self.nominal + float(value.delta or 0.0)

    def change(self, value: DistanceValue) -> np.ndarray:
        """``(D' - D) e`` on the moving feature's nodes."""
        return (self.distance_of(value) - self.nominal) * self.n

    def derivative(self, value: DistanceValue | None, step: DistanceValue) -> np.ndarray:
        """``dD e`` on the moving feature's nodes."""
        dd = float(step.delta) if step.delta is not None else float(step.distance or 0.0) - self.nominal
        return dd * self.n

    def check(self, value: DistanceValue, where: str) -> None:
        """A distance between centroids of zero or less is refused."""
        dist = self.distance_of(value)
        if not self.signed and dist <= 0.0:
            key = "distance" if value.distance is not None else "delta"
            given = value.distance if value.distance is not None else value.delta
            raise SpecError(f"{where}.{key}: {given:g} takes the distance between the centroids of {self.where} to "
                            f"{dist:.6g}; it must stay positive (give a direction to measure a signed distance)",
                            field=f"{where}.{key}", value=given)


def distance_edit(mesh: Mesh, e: DistanceEntry, sets: dict[str, np.ndarray]) -> DistanceEdit:
    """Resolve a ``distance`` entry: the measuring direction and the rest distance.

    Raises
    ------
    SpecError
        The features share nodes (``overlapping_constraints``); their centroids coincide and no
        direction is given (``coincident_features``).
    """
    base, moving = _two_features(mesh, e, sets)
    X = base["rest"]
    v = X[moving].mean(axis=0) - X[~moving].mean(axis=0)
    if e.direction is not None:
        unit, dist = np.asarray(e.direction, np.float64), float(v @ np.asarray(e.direction))
    else:
        dist = float(np.linalg.norm(v))
        scale = float(np.linalg.norm(X.max(axis=0) - X.min(axis=0)))
        if dist <= 1e-12 * scale:
            raise SpecError(f"SPEC.distance[{e.index}] ({e.name!r}): the centroids of {e.selection!r} and "
                            f"{e.reference!r} coincide; give a direction to measure along",
                            code="coincident_features", field=f"distance[{e.index}]")
        unit = v / dist
    return DistanceEdit(**base, n=np.where(moving[:, None], unit, 0.0), nominal=dist, signed=e.direction is not None)


@dataclass(frozen=True, eq=False)
class AngleEdit(Edit):
    """Two features' directions ``a`` (moving) and ``b``; the turn about ``k`` through ``pivot`` that sets their angle.

    Turning ``a`` by ``psi`` about ``k``: ``cos angle = A + B cos psi + C sin psi``
    (``A = (a.k)(b.k)``, ``B = (a - (a.k) k).b``, ``C = (k x a).b``), so ``psi = phi0 + sigma
    acos((cos angle - A) / M)``, ``M = hypot(B, C)``, ``phi0 = atan2(C, B)``, the branch ``sigma``
    through ``psi = 0`` at the rest angle. With ``k`` orthogonal to both (``flat``),
    ``psi = kappa (angle0 - angle)``, ``kappa`` the sign of ``C``.
    """

    moving: np.ndarray
    axis: np.ndarray
    pivot: np.ndarray
    coef: tuple[float, float, float]
    flat: bool
    nominal: float
    parameter: ClassVar[str | None] = "angle_deg"

    def angle_of(self, value: AngleValue | None) -> float:
        """The angle in degrees a value sets (None: the rest angle)."""
        if value is None:
            return self.nominal
        return float(value.angle_deg) if value.angle_deg is not None else self.nominal + float(value.delta_deg or 0.0)

    def _turn(self, deg: float) -> float:
        A, B, C = self.coef
        if self.flat:
            return math.copysign(1.0, C) * math.radians(self.nominal - deg)
        phi0 = math.atan2(C, B)
        x = (math.cos(math.radians(deg)) - A) / math.hypot(B, C)
        return phi0 + (-1.0 if phi0 >= 0 else 1.0) * math.acos(min(1.0, max(-1.0, x)))

    def _rate(self, deg: float) -> float:
        """``d psi / d angle`` (radians per radian)."""
        A, B, C = self.coef
        if self.flat:
            return -math.copysign(1.0, C)
        phi0 = math.atan2(C, B)
        rest = self._turn(deg) - phi0
        return math.sin(math.radians(deg)) / (math.hypot(B, C) * math.sin(rest))

    def change(self, value: AngleValue) -> np.ndarray:
        """``R_k(psi) w - w`` on the moving nodes, ``w = p0 - pivot``: ``sin psi k x w - 2 sin^2(psi/2) w_perp``."""
        psi = self._turn(self.angle_of(value))
        W = self.rest - self.pivot
        perp = W - np.outer(W @ self.axis, self.axis)
        out = math.sin(psi) * np.cross(self.axis, W) - 2.0 * math.sin(0.5 * psi) ** 2 * perp
        return np.where(self.moving[:, None], out, 0.0)

    def derivative(self, value: AngleValue | None, step: AngleValue) -> np.ndarray:
        """``d psi k x (p - pivot)`` on the moving nodes, ``d psi`` the turn of the step's change of angle."""
        dd = float(step.delta_deg) if step.delta_deg is not None else float(step.angle_deg or 0.0) - self.nominal
        dpsi = self._rate(self.angle_of(value)) * math.radians(dd)
        out = dpsi * np.cross(self.axis, self.positions(value) - self.pivot)
        return np.where(self.moving[:, None], out, 0.0)

    def check(self, value: AngleValue, where: str) -> None:
        """An angle no turn about the axis reaches (within [0, 180] degrees) is refused (``angle_out_of_reach``)."""
        deg = self.angle_of(value)
        key = "angle_deg" if value.angle_deg is not None else "delta_deg"
        given = value.angle_deg if value.angle_deg is not None else value.delta_deg
        A, B, C = self.coef
        M = math.hypot(B, C)
        lo = math.degrees(math.acos(min(1.0, A + M)))
        hi = math.degrees(math.acos(max(-1.0, A - M)))
        if not (lo - 1e-9 <= deg <= hi + 1e-9):
            raise SpecError(f"{where}.{key}: {given:g} asks {self.where} for an angle of {deg:.6g} degrees; turning "
                            f"about its axis reaches {lo:.6g} to {hi:.6g}", code="angle_out_of_reach",
                            field=f"{where}.{key}", value=given, bound=[lo, hi])


def _direction(mesh: Mesh, ids: np.ndarray, planar_deg: float, where: str, field: str, name: str
               ) -> tuple[np.ndarray, bool]:
    """A feature's fitted direction: its planar faces' outward normal (False), else its cylinder's axis (True)."""
    from .features import _face_normals, _fit_cylinder

    F = _faces_of(mesh, ids[mesh.referenced[ids]])
    if len(F):
        fn = np.cross(mesh.V[F[:, 1]] - mesh.V[F[:, 0]], mesh.V[F[:, 2]] - mesh.V[F[:, 0]])
        mean = fn.sum(axis=0)
        size = float(np.linalg.norm(mean))
        cos = (fn @ mean) / np.maximum(np.linalg.norm(fn, axis=1) * size, 1e-300)
        if size > 0 and bool((cos >= math.cos(math.radians(planar_deg))).all()):
            return mean / size, False
    if len(F) >= 4:
        N, area = _face_normals(mesh.V, F)
        axis, _, r, rms, _, _ = _fit_cylinder(mesh.V[np.unique(F)], N, area, mesh.V[F].mean(axis=1))
        if r > 0 and rms <= 1e-3 * r:
            return _unit(np.asarray(axis, np.float64)), True
    raise SpecError(f"{where}: the boundary faces of {name!r} are neither planar (within the planar_deg) nor a "
                    "cylinder; give its direction", code="no_feature_direction", field=field, selection=name)


def angle_edit(mesh: Mesh, e: AngleEntry, sets: dict[str, np.ndarray]) -> AngleEdit:
    """Resolve an ``angle`` entry: both directions, the rotation axis and pivot, the rest angle.

    Raises
    ------
    SpecError
        The features share nodes (``overlapping_constraints``); a direction that cannot be fitted
        (``no_feature_direction``); parallel directions without an axis (``parallel_features``); an
        axis about which turning does not change the angle (``axis_does_not_turn``).
    """
    where, field = f"SPEC.angle[{e.index}] ({e.name!r})", f"angle[{e.index}]"
    base, moving = _two_features(mesh, e, sets)
    fitted = []
    for given, name in ((e.direction, e.selection), (e.reference_direction, e.reference)):
        if given is not None:
            fitted.append((np.asarray(given, np.float64), False))
        else:
            fitted.append(_direction(mesh, sets[name], e.planar_deg, where, field, name))
    (a, a_axis), (b, b_axis) = fitted
    if (a_axis or b_axis) and a @ b < 0:  # an axis has no sense: the one that makes the rest angle acute
        a, b = (-a, b) if a_axis else (a, -b)
    cross = np.cross(a, b)
    if e.axis is not None:
        k = np.asarray(e.axis, np.float64)
    elif float(np.linalg.norm(cross)) <= PARALLEL_SIN:
        raise SpecError(f"{where}: the directions of {e.selection!r} and {e.reference!r} are parallel, so their "
                        "cross product gives no rotation axis; give the axis", code="parallel_features",
                        field=field)
    else:
        k = _unit(cross)
    ak, bk = float(a @ k), float(b @ k)
    A, B, C = ak * bk, float((a - ak * k) @ b), float(np.cross(k, a) @ b)
    if math.hypot(B, C) <= PARALLEL_SIN:
        raise SpecError(f"{where}: turning {e.selection!r} about the axis {k.tolist()} does not change its angle to "
                        f"{e.reference!r}; give another axis", code="axis_does_not_turn", field=field)
    X = base["rest"]
    pivot = np.asarray(e.pivot, np.float64) if e.pivot is not None else X[moving].mean(axis=0)
    flat = abs(ak) <= 1e-12 and abs(bk) <= 1e-12
    nominal = math.degrees(math.atan2(float(np.linalg.norm(cross)), float(a @ b)))
    return AngleEdit(**base, moving=moving, axis=k, pivot=pivot, coef=(A, B, C), flat=flat, nominal=nominal)
