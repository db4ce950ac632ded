"""The MOVE document: where the handles go, and the targets of the other constraints.

These models are the MOVE's one definition. They state every type and every static range (from
:mod:`solver.limits`), the library's :func:`~solver.constraints.move.parse_move` validates a MOVE with
them, and the service's OpenAPI schema is generated from them. What depends on the SPEC and the mesh
(names the SPEC defines, translations and points within :data:`~solver.limits.EXTENT` diagonals of the
mesh, a non-zero axis) is checked by :func:`~solver.constraints.move.parse_move`.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic.json_schema import SkipJsonSchema

from ..limits import EXTENT, TARGET_AMOUNT_MAX
from .deferred import OnFirstUse
from .numbers import Angle, Quat, Scale, Vec3

if TYPE_CHECKING:
    from .edit_moves import AngleMove, DistanceMove, LatticeMove, MapMove, OffsetMove, RadiusMove, TwistAngle, TwistMove

__all__ = ["Move", "HandleMove", "Rotation", "RelativeMove", "FeatureMove", "MotionMove", "TargetMove",
           "TargetAmount", "RadiusMove", "TwistMove", "TwistAngle", "MapMove", "OffsetMove", "LatticeMove",
           "DistanceMove", "AngleMove"]

_STRICT = ConfigDict(extra="forbid", strict=True)
#: The config of a model that only a member built on first use holds (:class:`.deferred.OnFirstUse`).
_LATER = ConfigDict(extra="forbid", strict=True, defer_build=True)

#: The edits' MOVE models, which :mod:`.edit_moves` defines; this module gives them when asked.
_EDIT_MODELS = ("RadiusMove", "TwistMove", "TwistAngle", "MapMove", "OffsetMove", "LatticeMove", "DistanceMove",
                "AngleMove")


def __getattr__(name: str) -> Any:
    """The edits' models (:data:`_EDIT_MODELS`), imported from :mod:`.edit_moves` when first asked for."""
    if name in _EDIT_MODELS:
        return getattr(import_module(".edit_moves", __package__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _edit(model: str) -> Any:
    """A function giving :mod:`.edit_moves`' ``model``, which imports that module when first called."""
    return lambda: getattr(import_module(".edit_moves", __package__), model)


if TYPE_CHECKING:
    Radii = dict[str, RadiusMove]
    Fillets = dict[str, RadiusMove]
    Twists = dict[str, TwistMove]
    Mappings = dict[str, MapMove]
    Offsets = dict[str, OffsetMove]
    Lattices = dict[str, LatticeMove]
    Distances = dict[str, DistanceMove]
    Angles = dict[str, AngleMove]
else:  # a MOVE's values of one edit kind by name; their models are built when a MOVE first has one
    Radii, Fillets, Twists, Mappings, Offsets, Lattices, Distances, Angles = (
        Annotated[dict[str, Any], OnFirstUse(most, _edit(model))] for model, most in (
            ("RadiusMove", 10_000), ("RadiusMove", 10_000), ("TwistMove", 10_000), ("MapMove", 10_000),
            ("OffsetMove", 10_000), ("LatticeMove", 1000), ("DistanceMove", 10_000), ("AngleMove", 10_000)))


#: How far a target's nodes go: 0 at rest, 1 on the target surface.
TargetAmount = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-TARGET_AMOUNT_MAX,
                                      le=TARGET_AMOUNT_MAX)]


class Rotation(BaseModel):
    """``axis`` + ``angle_deg``, or a ``quaternion`` [w, x, y, z]; the schema's ``oneOf`` says so."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "oneOf": [{"required": ["axis", "angle_deg"], "not": {"required": ["quaternion"]}},
                  {"required": ["quaternion"],
                   "not": {"anyOf": [{"required": ["axis"]}, {"required": ["angle_deg"]}]}}],
        "examples": [{"axis": [0.0, 0.0, 1.0], "angle_deg": 15.0}, {"quaternion": [1.0, 0.0, 0.0, 0.0]}]})
    axis: Vec3 | SkipJsonSchema[None] = None
    angle_deg: Angle | SkipJsonSchema[None] = None
    quaternion: Quat | SkipJsonSchema[None] = None

    @model_validator(mode="after")
    def _one_form(self) -> Rotation:
        if self.quaternion is not None:
            if self.axis is not None or self.angle_deg is not None:
                raise ValueError("give either axis+angle_deg or quaternion, not both")
        elif self.axis is None or self.angle_deg is None:
            raise ValueError("a rotation needs axis and angle_deg (or quaternion)")
        return self


class HandleMove(BaseModel):
    """Where one handle goes: ``pivot + translation + scale R (p0 - pivot)``."""

    model_config = _STRICT
    translation: Vec3 | None = Field(None, description=f"within {EXTENT:g} bounding-box diagonals")
    rotation: Rotation | None = None
    pivot: Vec3 | None = Field(None, description="default: the handle's rest centroid; within "
                               f"{EXTENT:g} diagonals of the mesh's centre")
    scale: Scale | None = None


class RelativeMove(BaseModel):
    """A new offset or scale of a SPEC ``relative`` constraint: exactly one of the two.

    The schema says so (``oneOf`` of the two, neither ``null``), so a body the
    OpenAPI schema admits is one the parser takes.
    """

    model_config = ConfigDict(extra="forbid", strict=True, defer_build=True, json_schema_extra={
        "oneOf": [{"required": ["offset"]}, {"required": ["scale"]}],
        "examples": [{"offset": [0.0, 0.0, 1.0]}, {"scale": 1.5}]})
    offset: Vec3 | SkipJsonSchema[None] = None
    scale: Scale | SkipJsonSchema[None] = None

    @model_validator(mode="after")
    def _exactly_one(self) -> RelativeMove:
        if (self.offset is None) == (self.scale is None):
            raise ValueError("needs exactly one of offset or scale")
        return self


class FeatureMove(BaseModel):
    """The scale of a SPEC feature."""

    model_config = _LATER
    scale: Scale = 1.0


class MotionMove(BaseModel):
    """The point a SPEC ``motion`` plane or line passes through."""

    model_config = _LATER
    point: Vec3


class TargetMove(BaseModel):
    """How far the nodes of a SPEC ``targets`` entry go: 0 rest, 1 on the target surface."""

    model_config = _LATER
    amount: TargetAmount = 1.0


class Move(BaseModel):
    """Where the handles go (docs/guide/documents.md).

    A handle the MOVE does not name is at its rest position (identity
    transform), not where an earlier MOVE put it: every MOVE is absolute.
    """

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [
        {"handles": {"tip": {"translation": [0, 0, 4], "rotation": {"axis": [1, 0, 0], "angle_deg": 15}}}}]})

    handles: dict[str, HandleMove] = Field(default_factory=dict, max_length=10_000)
    points: dict[str, Vec3] = Field(default_factory=dict, max_length=100_000)
    relative: Annotated[dict[str, RelativeMove], OnFirstUse(100_000)] = Field(default_factory=dict)
    features: Annotated[dict[str, FeatureMove], OnFirstUse(10_000)] = Field(default_factory=dict)
    motion: Annotated[dict[str, MotionMove], OnFirstUse(10_000)] = Field(default_factory=dict)
    targets: Annotated[dict[str, TargetMove], OnFirstUse(1000)] = Field(default_factory=dict)
    radius: Radii = Field(default_factory=dict)
    twist: Twists = Field(default_factory=dict)
    map: Mappings = Field(default_factory=dict)
    offset: Offsets = Field(default_factory=dict)
    lattice: Lattices = Field(default_factory=dict)
    fillet: Fillets = Field(default_factory=dict)
    distance: Distances = Field(default_factory=dict)
    angle: Angles = Field(default_factory=dict)

    def dump(self) -> dict[str, Any]:
        """The document as given (fields not set are left out)."""
        return self.model_dump(exclude_unset=True, mode="python")
