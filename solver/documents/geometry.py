"""Geometry the documents name: directions, boxes, axes, and the analytic curves and surfaces of a SPEC ``map``.

Every model is strict (unknown fields refused, numbers that are JSON numbers, finite and within
:data:`~solver.limits.COORD_MAX`). A direction or a normal is three numbers, not all zero; the
parsers use it as a unit vector.
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator
from pydantic.json_schema import SkipJsonSchema

from ..limits import COORD_MAX
from .numbers import Vec3

__all__ = ["Direction3", "Box", "Axis", "Line", "Circle", "PlaneSurface", "Cylinder", "Ball", "Geometry",
           "GEOMETRY_KINDS", "PositiveLength"]

_STRICT = ConfigDict(extra="forbid", strict=True)
#: The config of the analytic geometry (line, circle, plane, cylinder, sphere): only a SPEC's ``map`` edits
#: name one, so their models are built when a SPEC first does (:mod:`.deferred`), not with their classes.
_LATER = ConfigDict(extra="forbid", strict=True, defer_build=True)


def _nonzero(v: list[float]) -> list[float]:
    n = math.hypot(*v)
    if not (math.isfinite(n) and n > 1e-150):
        raise ValueError(f"must be non-zero, got {v}")
    return v


#: A direction or a normal: three numbers, not all zero (the parser uses it as a unit vector).
Direction3 = Annotated[Vec3, AfterValidator(_nonzero)]
#: A radius: a positive length.
PositiveLength = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0, le=COORD_MAX)]


class Box(BaseModel):
    """A closed axis-aligned box."""

    model_config = _STRICT
    min: Vec3
    max: Vec3

    @model_validator(mode="after")
    def _ordered(self) -> Box:
        if any(a > b for a, b in zip(self.min, self.max, strict=True)):
            raise ValueError(f"min {self.min} exceeds max {self.max}")
        return self


class Axis(BaseModel):
    """An axis: a point on it and its direction."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "examples": [{"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]}]})
    point: Vec3
    direction: Direction3


class Line(BaseModel):
    """A straight line through ``point`` along ``direction``."""

    model_config = _LATER
    point: Vec3
    direction: Direction3


class Circle(BaseModel):
    """A circle (a full turn): its centre, the normal of its plane, its radius."""

    model_config = _LATER
    center: Vec3
    normal: Direction3
    radius: PositiveLength


class PlaneSurface(BaseModel):
    """An unbounded plane through ``point`` orthogonal to ``normal``."""

    model_config = _LATER
    point: Vec3
    normal: Direction3


class Cylinder(BaseModel):
    """An unbounded circular cylinder: a point on its axis, the axis's direction, its radius."""

    model_config = _LATER
    point: Vec3
    axis: Direction3
    radius: PositiveLength


class Ball(BaseModel):
    """A sphere: its centre and its radius."""

    model_config = _LATER
    center: Vec3
    radius: PositiveLength


#: The fields of a GEOMETRY of which it has exactly one.
GEOMETRY_KINDS = ("line", "circle", "plane", "cylinder", "sphere")


class Geometry(BaseModel):
    """Exactly one of ``line``, ``circle``, ``plane``, ``cylinder``, ``sphere``.

    The schema says so (``oneOf`` of the five), and so does the model's own check.
    """

    model_config = ConfigDict(extra="forbid", strict=True, defer_build=True, json_schema_extra={
        "oneOf": [{"required": [k]} for k in GEOMETRY_KINDS],
        "examples": [{"cylinder": {"point": [0, 0, 0], "axis": [0, 0, 1], "radius": 5.0}},
                     {"plane": {"point": [0, 0, 10], "normal": [0, 0, 1]}}]})
    line: Line | SkipJsonSchema[None] = None
    circle: Circle | SkipJsonSchema[None] = None
    plane: PlaneSurface | SkipJsonSchema[None] = None
    cylinder: Cylinder | SkipJsonSchema[None] = None
    sphere: Ball | SkipJsonSchema[None] = None

    @model_validator(mode="after")
    def _exactly_one_kind(self) -> Geometry:
        given = [k for k in GEOMETRY_KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"a geometry has exactly one of {', '.join(GEOMETRY_KINDS)}; got "
                             f"{' and '.join(given) if given else 'none'}")
        return self

    @property
    def kind(self) -> str:
        """The one kind given."""
        return next(k for k in GEOMETRY_KINDS if getattr(self, k) is not None)
