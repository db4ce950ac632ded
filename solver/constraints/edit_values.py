"""The MOVE's parameters of the daily edits, parsed: one frozen value per named edit.

:func:`edit_values` reads them from a validated MOVE (:mod:`solver.documents.edit_moves`) and checks
the lengths against the mesh's extent (:class:`~solver.constraints.move.MoveBounds`): radii, radius
changes, offset distances and control-point displacements within
:data:`~solver.limits.EXTENT` bounding-box diagonals (code ``out_of_range``). :func:`scaled_value` is
a value scaled by a fraction (the inversion policy's clamp), :func:`combined_value` the sum of shape
values weighted by their parameters (:mod:`solver.workflows.shapes`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .edit_kinds import NOMINAL_KINDS
from .spec import expect

if TYPE_CHECKING:
    from ..documents.move import Move as MoveDoc
    from .move import MoveBounds

__all__ = ["RadiusValue", "TwistValue", "MapValue", "OffsetValue", "LatticeValue", "DistanceValue", "AngleValue",
           "EditValue", "edit_values", "scaled_value", "combined_value", "value_dict", "as_change",
           "NOMINAL_KINDS"]


@dataclass(frozen=True)
class RadiusValue:
    """A new radius (every node at it), or a change of every node's radius: exactly one is set."""

    radius: float | None = None
    delta: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        return {"radius": self.radius} if self.radius is not None else {"delta": self.delta}


@dataclass(frozen=True)
class TwistValue:
    """A twist law in degrees: ``rate`` per unit length, or a table ``(at, angle_deg)`` interpolated linearly."""

    rate: float | None = None
    at: tuple[float, ...] = ()
    angle_deg: tuple[float, ...] = ()

    def degrees(self, s: np.ndarray) -> np.ndarray:
        """Angles in degrees at axial coordinates ``s`` (the table's end values beyond its ends)."""
        if self.rate is not None:
            return self.rate * np.asarray(s, np.float64)
        return np.interp(s, np.asarray(self.at), np.asarray(self.angle_deg))

    def angles(self, s: np.ndarray) -> np.ndarray:
        """Angles in radians at axial coordinates ``s``."""
        return np.radians(self.degrees(s))

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        if self.rate is not None:
            return {"angle_deg_per_length": self.rate}
        return {"table": [{"at": a, "angle_deg": g} for a, g in zip(self.at, self.angle_deg, strict=True)]}


@dataclass(frozen=True)
class MapValue:
    """How far mapped nodes go: 0 rest, 1 on the geometry."""

    amount: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        return {"amount": self.amount}


@dataclass(frozen=True)
class OffsetValue:
    """The distance along the outward normal."""

    distance: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        return {"distance": self.distance}


@dataclass(frozen=True)
class LatticeValue:
    """Control-point displacements ``{(i, j, k): (3,) array}``."""

    displacements: dict[tuple[int, int, int], np.ndarray] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        return {"displacements": {f"{i},{j},{k}": v.tolist() for (i, j, k), v in self.displacements.items()}}


@dataclass(frozen=True)
class DistanceValue:
    """A distance between two features, or its change from the rest distance: exactly one is set."""

    distance: float | None = None
    delta: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        return {"distance": self.distance} if self.distance is not None else {"delta": self.delta}


@dataclass(frozen=True)
class AngleValue:
    """An angle between two features in degrees, or its change from the rest angle: exactly one is set."""

    angle_deg: float | None = None
    delta_deg: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """MOVE form."""
        return {"angle_deg": self.angle_deg} if self.angle_deg is not None else {"delta_deg": self.delta_deg}


EditValue = RadiusValue | TwistValue | MapValue | OffsetValue | LatticeValue | DistanceValue | AngleValue


def value_dict(values: dict[str, dict[str, EditValue]]) -> dict[str, Any]:
    """The MOVE form of parsed edit values (``{kind: {name: {...}}}``, kinds with no value left out)."""
    return {kind: {n: v.to_dict() for n, v in named.items()} for kind, named in values.items() if named}


def edit_values(m: MoveDoc, bounds: MoveBounds | None = None) -> dict[str, dict[str, EditValue]]:
    """The edit values of a validated MOVE, per kind and name, their lengths checked against ``bounds``.

    Raises
    ------
    SpecError
        ``out_of_range``: a radius, radius change, distance or displacement beyond
        :data:`~solver.limits.EXTENT` bounding-box diagonals of the mesh.
    """
    def length(x: float, where: str) -> float:
        if bounds is not None:
            expect(abs(x) <= bounds.translation, f"{where}: {abs(x):.3g} exceeds the bound of lengths, "
                   f"{bounds.translation:.3g} (100 bounding-box diagonals of the mesh)", code="out_of_range",
                   field=where, value=x, bound=bounds.translation)
        return float(x)

    out: dict[str, dict[str, EditValue]] = {"radius": {}, "twist": {}, "map": {}, "offset": {}, "lattice": {},
                                            "fillet": {}, "distance": {}, "angle": {}}
    for kind, named in (("radius", m.radius), ("fillet", m.fillet)):
        for name, r in named.items():
            where = f"MOVE.{kind}.{name}"
            out[kind][name] = (RadiusValue(radius=length(r.radius, f"{where}.radius")) if r.radius is not None
                               else RadiusValue(delta=length(r.delta, f"{where}.delta")))  # type: ignore[arg-type]
    for name, dm in m.distance.items():
        where = f"MOVE.distance.{name}"
        out["distance"][name] = (DistanceValue(distance=length(dm.distance, f"{where}.distance"))
                                 if dm.distance is not None
                                 else DistanceValue(delta=length(dm.delta, f"{where}.delta")))  # type: ignore[arg-type]
    for name, am in m.angle.items():
        out["angle"][name] = (AngleValue(angle_deg=float(am.angle_deg)) if am.angle_deg is not None
                              else AngleValue(delta_deg=float(am.delta_deg)))  # type: ignore[arg-type]
    for name, t in m.twist.items():
        if t.table is not None:
            out["twist"][name] = TwistValue(None, tuple(float(r.at) for r in t.table),
                                            tuple(float(r.angle_deg) for r in t.table))
        else:
            out["twist"][name] = TwistValue(float(t.angle_deg_per_length))  # type: ignore[arg-type]
    out["map"] = {name: MapValue(float(v.amount)) for name, v in m.map.items()}
    for name, o in m.offset.items():
        out["offset"][name] = OffsetValue(length(o.distance, f"MOVE.offset.{name}.distance"))
    for name, lat in m.lattice.items():
        disp = {}
        for key, v in lat.displacements.items():
            i, j, k = (int(x) for x in key.split(","))
            where = f"MOVE.lattice.{name}.displacements.{key}"
            a = np.asarray(v, np.float64)
            length(float(np.linalg.norm(a)), where)
            disp[(i, j, k)] = a
        out["lattice"][name] = LatticeValue(disp)
    return out


def as_change(v: EditValue, nominal: float | None) -> EditValue:
    """A radius, distance or angle given as a value, as its change from the edit's ``nominal`` rest value."""
    if nominal is None:
        return v
    if isinstance(v, RadiusValue) and v.radius is not None:
        return RadiusValue(delta=v.radius - nominal)
    if isinstance(v, DistanceValue) and v.distance is not None:
        return DistanceValue(delta=v.distance - nominal)
    if isinstance(v, AngleValue) and v.angle_deg is not None:
        return AngleValue(delta_deg=v.angle_deg - nominal)
    return v


def scaled_value(v: EditValue, f: float, nominal: float | None = None) -> EditValue:
    """``v`` scaled by ``f`` in [0, 1]: 0 the rest shape, 1 ``v``.

    A new radius ``r`` (a fillet's too) becomes ``r0 + f (r - r0)``, ``r0`` the edit's ``nominal``
    rest radius (every node stays on one cylinder), and a distance or an angle likewise about its
    rest value; every other parameter is multiplied by ``f`` (angles, amounts, distances,
    displacements, changes).
    """
    if isinstance(v, DistanceValue):
        if v.distance is not None:
            d0 = float(nominal if nominal is not None else v.distance)
            return DistanceValue(distance=v.distance if f == 1.0 else d0 + f * (v.distance - d0))
        return DistanceValue(delta=f * float(v.delta or 0.0))
    if isinstance(v, AngleValue):
        if v.angle_deg is not None:
            a0 = float(nominal if nominal is not None else v.angle_deg)
            return AngleValue(angle_deg=v.angle_deg if f == 1.0 else a0 + f * (v.angle_deg - a0))
        return AngleValue(delta_deg=f * float(v.delta_deg or 0.0))
    if isinstance(v, RadiusValue):
        if v.radius is not None:
            r0 = float(nominal if nominal is not None else v.radius)
            return RadiusValue(radius=v.radius if f == 1.0 else r0 + f * (v.radius - r0))
        return RadiusValue(delta=f * float(v.delta or 0.0))
    if isinstance(v, TwistValue):
        if v.rate is not None:
            return TwistValue(f * v.rate)
        return TwistValue(None, v.at, tuple(f * a for a in v.angle_deg))
    if isinstance(v, MapValue):
        return MapValue(f * v.amount)
    if isinstance(v, OffsetValue):
        return OffsetValue(f * v.distance)
    return LatticeValue({k: f * d for k, d in v.displacements.items()})


def combined_value(kind: str, steps: list[EditValue | None], theta: np.ndarray) -> EditValue:
    """The value ``sum_k theta_k steps[k]`` of one edit (``None``: the shape leaves it at rest).

    Radius, fillet, distance and angle steps are changes (``delta``, ``delta_deg``;
    :func:`solver.workflows.shapes.parse_shapes` turns a value into its change from the nominal one);
    twist steps are all rates or all tables (the sum of tables is the table over every row's position).
    """
    given = [(float(t), s) for t, s in zip(theta, steps, strict=True) if s is not None]
    if kind in ("radius", "fillet"):
        return RadiusValue(delta=math.fsum(t * float(s.delta or 0.0) for t, s in given))  # type: ignore[union-attr]
    if kind == "distance":
        return DistanceValue(delta=math.fsum(t * float(s.delta or 0.0) for t, s in given))  # type: ignore[union-attr]
    if kind == "angle":
        return AngleValue(delta_deg=math.fsum(
            t * float(s.delta_deg or 0.0) for t, s in given))  # type: ignore[union-attr]
    if kind == "twist":
        tw = [(t, s) for t, s in given if isinstance(s, TwistValue)]
        if all(s.rate is not None for _, s in tw):
            return TwistValue(math.fsum(t * float(s.rate or 0.0) for t, s in tw))
        at = np.unique(np.concatenate([np.asarray(s.at, np.float64) for _, s in tw]))
        ang = sum((t * s.degrees(at) for t, s in tw), np.zeros(at.size))
        return TwistValue(None, tuple(at.tolist()), tuple(np.asarray(ang).tolist()))
    if kind == "map":
        return MapValue(math.fsum(t * s.amount for t, s in given))  # type: ignore[union-attr]
    if kind == "offset":
        return OffsetValue(math.fsum(t * float(s.distance or 0.0) for t, s in given))  # type: ignore[union-attr]
    disp: dict[tuple[int, int, int], np.ndarray] = {}
    for t, s in given:
        for key, d in s.displacements.items():  # type: ignore[union-attr]
            disp[key] = disp.get(key, np.zeros(3)) + t * d
    return LatticeValue(disp)
