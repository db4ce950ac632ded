"""The MOVE's parameters of the daily edits, from ``radius`` to ``angle``.

A ``fillet`` takes a :class:`RadiusMove` (its new radius, or the change of it).

One model per SPEC edit (:mod:`solver.documents.edits`). Static ranges are :mod:`solver.limits`'s;
what depends on the mesh (a length within :data:`~solver.limits.EXTENT` diagonals, a radius that
stays positive at every node, a twist angle within :data:`~solver.limits.ANGLE_MAX` at every node, a
control point of the lattice) is checked against the resolved edit
(:meth:`solver.constraints.edits.Edit.check`).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic.json_schema import SkipJsonSchema

from ..limits import ANGLE_BETWEEN_MAX, LATTICE_COUNT_MAX, TARGET_AMOUNT_MAX
from .geometry import PositiveLength
from .numbers import Angle, Coord, Vec3

__all__ = ["RadiusMove", "TwistMove", "TwistAngle", "MapMove", "OffsetMove", "LatticeMove", "DistanceMove",
           "AngleMove", "LATTICE_KEY"]

#: How far mapped nodes go: 0 at rest, 1 on the geometry.
Amount = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-TARGET_AMOUNT_MAX, le=TARGET_AMOUNT_MAX)]
#: A control point of a lattice: ``"i,j,k"``, 0-based indices along x, y and z.
LATTICE_KEY = r"^(0|[1-9][0-9]?),(0|[1-9][0-9]?),(0|[1-9][0-9]?)$"


class RadiusMove(BaseModel):
    """The new radius of a SPEC ``radius`` entry, or the change of each node's radius: exactly one."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "oneOf": [{"required": ["radius"]}, {"required": ["delta"]}],
        "examples": [{"radius": 7.5}, {"delta": -0.5}]})
    radius: PositiveLength | SkipJsonSchema[None] = Field(None, description="every node at this distance from "
                                                                            "the axis")
    delta: Coord | SkipJsonSchema[None] = Field(None, description="every node's distance from the axis changed "
                                                                  "by this")

    @model_validator(mode="after")
    def _exactly_one(self) -> RadiusMove:
        if (self.radius is None) == (self.delta is None):
            raise ValueError("needs exactly one of radius or delta")
        return self


class TwistAngle(BaseModel):
    """One row of a twist table: the angle at an axial position."""

    model_config = ConfigDict(extra="forbid", strict=True)
    at: Coord = Field(description="axial coordinate from the SPEC axis's point")
    angle_deg: Angle


class TwistMove(BaseModel):
    """The twist law of a SPEC ``twist`` entry: linear, or a table interpolated linearly; exactly one.

    ``angle_deg_per_length``: a node at axial coordinate ``s`` turns by ``s`` times it (degrees).
    ``table``: rows in increasing ``at``; between two rows the angle is interpolated linearly, before
    the first and after the last it is the end row's.
    """

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "oneOf": [{"required": ["angle_deg_per_length"]}, {"required": ["table"]}],
        "examples": [{"angle_deg_per_length": 0.5},
                     {"table": [{"at": 0.0, "angle_deg": 0.0}, {"at": 100.0, "angle_deg": 30.0}]}]})
    angle_deg_per_length: Coord | SkipJsonSchema[None] = None
    table: Annotated[list[TwistAngle], Field(min_length=1, max_length=10_000)] | SkipJsonSchema[None] = None

    @model_validator(mode="after")
    def _one_law(self) -> TwistMove:
        if (self.angle_deg_per_length is None) == (self.table is None):
            raise ValueError("needs exactly one of angle_deg_per_length or table")
        if self.table is not None:
            at = [r.at for r in self.table]
            if any(b <= a for a, b in zip(at, at[1:], strict=False)):
                raise ValueError(f"table rows must be in strictly increasing 'at', got {at[:20]}")
        return self


class MapMove(BaseModel):
    """How far the nodes of a SPEC ``map`` entry go: 0 rest, 1 on the geometry."""

    model_config = ConfigDict(extra="forbid", strict=True)
    amount: Amount = 1.0


class OffsetMove(BaseModel):
    """The distance a SPEC ``offset`` entry's faces move along their outward normal (negative: inward)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{"distance": 0.5}]})
    distance: Coord


class LatticeMove(BaseModel):
    """Displacements of control points of a SPEC ``lattice`` entry; those not named stay."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "examples": [{"displacements": {"2,0,1": [0.0, 0.0, 3.0]}}]})
    displacements: Annotated[dict[Annotated[str, Field(pattern=LATTICE_KEY)], Vec3],
                             Field(max_length=LATTICE_COUNT_MAX ** 3)] = Field(
        default_factory=dict, description="'i,j,k' (0-based along x, y, z) -> [dx, dy, dz]")


class DistanceMove(BaseModel):
    """The distance of a SPEC ``distance`` entry, or its change from the rest distance: exactly one."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "oneOf": [{"required": ["distance"]}, {"required": ["delta"]}],
        "examples": [{"distance": 40.0}, {"delta": 2.5}]})
    distance: Coord | SkipJsonSchema[None] = Field(None, description="the measured distance after the morph")
    delta: Coord | SkipJsonSchema[None] = Field(None, description="the rest distance changed by this")

    @model_validator(mode="after")
    def _exactly_one(self) -> DistanceMove:
        if (self.distance is None) == (self.delta is None):
            raise ValueError("needs exactly one of distance or delta")
        return self


#: An angle between two features' directions, in degrees.
BetweenAngle = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=ANGLE_BETWEEN_MAX)]


class AngleMove(BaseModel):
    """The angle in degrees of a SPEC ``angle`` entry, or its change from the rest angle: exactly one."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "oneOf": [{"required": ["angle_deg"]}, {"required": ["delta_deg"]}],
        "examples": [{"angle_deg": 95.0}, {"delta_deg": -2.0}]})
    angle_deg: BetweenAngle | SkipJsonSchema[None] = Field(None, description="the measured angle after the morph, "
                                                                             "0 to 180")
    delta_deg: Angle | SkipJsonSchema[None] = Field(None, description="the rest angle changed by this")

    @model_validator(mode="after")
    def _exactly_one(self) -> AngleMove:
        if (self.angle_deg is None) == (self.delta_deg is None):
            raise ValueError("needs exactly one of angle_deg or delta_deg")
        return self
