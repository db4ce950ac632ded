"""The SPEC document (docs/guide/documents.md): strict types, unknown fields refused.

These models are the SPEC's one definition: the library's :func:`~solver.constraints.spec.parse_spec`
validates a SPEC with them before it resolves its names, and the service's OpenAPI schema is generated
from them. What needs the names and the mesh (selections that exist, handles that do not overlap,
vertex ids below the mesh's count) is checked by the parser.

One difference between the library and the service is stated by the validation context: a target's
``surface`` may be a file path only when validated with ``context={"files": True}`` (the library's
callers and the command line); the service never reads a path a client names.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, ValidationInfo, model_validator
from pydantic.json_schema import SkipJsonSchema

from .numbers import Angle, Fraction, NonNegLength, PenaltyWeight, Vec3, VertexId, WallWeight, Weight

__all__ = ["Spec", "Selection", "Target", "SELECTION_KINDS", "Box", "Sphere", "Plane", "Constraints", "Point",
           "Motion", "Relative", "RelativePoint", "Symmetry", "Cyclic", "Feature", "Sliding", "ThinWalls", "Ties",
           "StoredSurface", "InlineSurface"]

_STRICT = ConfigDict(extra="forbid", strict=True)


class Box(BaseModel):
    """A closed axis-aligned box."""

    model_config = _STRICT
    min: Vec3
    max: Vec3


class Sphere(BaseModel):
    """A closed ball."""

    model_config = _STRICT
    center: Vec3
    radius: NonNegLength


class Plane(BaseModel):
    """Vertices within ``tolerance`` of a plane."""

    model_config = _STRICT
    point: Vec3
    normal: Vec3
    tolerance: NonNegLength = 0.0


#: The fields of a SELECTION of which it has exactly one.
SELECTION_KINDS = ("ids", "set", "box", "sphere", "plane")


class Selection(BaseModel):
    """Exactly one of ``ids``, ``set``, ``box``, ``sphere``, ``plane``; optionally ``boundary_only``.

    The schema says so (``oneOf`` of the five, none of them ``null``); the SPEC parser refuses the rest
    (422 ``invalid_spec`` naming the selection).
    """

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={
        "oneOf": [{"required": [k]} for k in SELECTION_KINDS],
        "examples": [{"set": "FIXED"}, {"box": {"min": [0, 0, 0], "max": [1, 1, 1]}, "boundary_only": True}]})
    ids: Annotated[list[VertexId], Field(max_length=10_000_000)] | SkipJsonSchema[None] = None
    set: Annotated[StrictStr, Field(max_length=200)] | SkipJsonSchema[None] = Field(
        None, description="node set, element set, physical group, material region ('medit:ref=2')")
    box: Box | SkipJsonSchema[None] = None
    sphere: Sphere | SkipJsonSchema[None] = None
    plane: Plane | SkipJsonSchema[None] = None
    boundary_only: StrictBool = False

    @model_validator(mode="after")
    def _exactly_one_kind(self) -> Selection:
        given = [k for k in SELECTION_KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"a selection has exactly one of {', '.join(SELECTION_KINDS)}; got "
                             f"{' and '.join(given) if given else 'none'}")
        return self


class Constraints(BaseModel):
    """How hard constraints are imposed."""

    model_config = _STRICT
    method: Literal["null_space", "kkt", "penalty"] = "null_space"
    penalty_weight: PenaltyWeight = 1.0e4


class RelativePoint(BaseModel):
    """A point as a combination of vertices: vertices+weights, edge+t, face+barycentric, or a selection.

    One of the two POINTs of a relative constraint has no name; the other points have one.
    """

    model_config = _STRICT
    vertices: list[VertexId] | None = Field(None, min_length=1, max_length=100_000)
    weights: list[Weight] | None = Field(None, max_length=100_000)
    edge: list[VertexId] | None = Field(None, min_length=2, max_length=2)
    t: Fraction | None = None
    face: list[VertexId] | None = Field(None, min_length=3, max_length=3)
    barycentric: list[Fraction] | None = Field(None, min_length=3, max_length=3)
    selection: StrictStr | None = Field(None, max_length=200)


class PointBase(RelativePoint):
    """A named point as a combination of vertices: vertices+weights, edge+t, face+barycentric, or a selection."""

    name: StrictStr = Field(max_length=200)


class Point(PointBase):
    """A point held at a target (default: its rest position; a MOVE may set it)."""

    target: Vec3 | None = None


class Normal(BaseModel):
    """A plane through the MOVE's point."""

    model_config = _STRICT
    normal: Vec3


class Direction(BaseModel):
    """A line through the MOVE's point."""

    model_config = _STRICT
    direction: Vec3


class Motion(PointBase):
    """A point that moves on a plane or along a line."""

    plane: Normal | None = None
    line: Direction | None = None


class Relative(BaseModel):
    """The offset of two vertices or two POINTs (a hole's centre to another's), turned or not."""

    model_config = _STRICT
    name: StrictStr = Field(max_length=200)
    vertices: list[VertexId] | None = Field(None, min_length=2, max_length=2)
    points: list[RelativePoint] | None = Field(None, min_length=2, max_length=2)
    mode: Literal["rotate", "translate"] = "rotate"


class MirrorPlane(BaseModel):
    """A plane of symmetry."""

    model_config = _STRICT
    point: Vec3
    normal: Vec3


class Symmetry(BaseModel):
    """Mirror symmetry: boundary nodes on one side are the mirror images of the other side's."""

    model_config = _STRICT
    name: StrictStr = Field(max_length=200)
    plane: MirrorPlane
    tolerance: NonNegLength | None = None


class Axis(BaseModel):
    """An axis of rotation."""

    model_config = _STRICT
    point: Vec3
    direction: Vec3


class Cyclic(BaseModel):
    """Cyclic symmetry of a sector: face B is face A turned by ``angle_deg`` about the axis."""

    model_config = _STRICT
    name: StrictStr = Field(max_length=200)
    axis: Axis
    angle_deg: Angle
    faces: list[StrictStr] = Field(min_length=2, max_length=2)
    tolerance: NonNegLength | None = None


class Feature(BaseModel):
    """A form feature kept rigid or at its direction."""

    model_config = _STRICT
    selection: StrictStr = Field(max_length=200)
    mode: Literal["rigid", "keep_direction"] = "rigid"
    name: StrictStr | None = Field(None, max_length=200)


class Sliding(BaseModel):
    """Vertices of a selection that keep their coordinate along ``normal``."""

    model_config = _STRICT
    selection: StrictStr = Field(max_length=200)
    normal: Vec3


class ThinWalls(BaseModel):
    """Weight of the thin-wall rows."""

    model_config = _STRICT
    weight: WallWeight = 1.0


class Ties(BaseModel):
    """Tie coincident nodes of different bodies within ``tolerance``.

    ``surface`` pairs of selections tie each boundary node of A to its closest
    point on B's boundary faces (non-matching interfaces).
    """

    model_config = _STRICT
    tolerance: NonNegLength | None = None
    surface: list[Annotated[list[StrictStr], Field(min_length=2, max_length=2)]] | None = Field(None, max_length=1000)
    surface_tolerance: NonNegLength | None = None


class StoredSurface(BaseModel):
    """A triangle surface uploaded through ``POST /v1/meshes`` (STL, OBJ, PLY, OFF), by its id."""

    model_config = _STRICT
    mesh_id: StrictStr = Field(max_length=64, description="id of an uploaded triangle surface")


class InlineSurface(BaseModel):
    """A triangle surface given in the SPEC."""

    model_config = _STRICT
    vertices: list[Vec3] = Field(min_length=3, max_length=10_000_000)
    triangles: list[Annotated[list[VertexId], Field(min_length=3, max_length=3)]] = Field(
        min_length=1, max_length=20_000_000)


class Target(BaseModel):
    """A selection whose boundary nodes land on a target surface (MOVE ``targets.NAME.amount``)."""

    model_config = _STRICT
    name: StrictStr = Field(max_length=200)
    selection: StrictStr = Field(max_length=200)
    surface: StoredSurface | InlineSurface | SkipJsonSchema[StrictStr] = Field(
        description="a stored surface {mesh_id} (resolved by the service) or {vertices, triangles}; never a "
                    "file path (the library reads one, given ``files=True``)")
    method: Literal["closest", "normal"] = "closest"
    tolerance: NonNegLength | None = None

    @model_validator(mode="after")
    def _path_in_the_library_only(self, info: ValidationInfo) -> Target:
        if isinstance(self.surface, str) and not (info.context or {}).get("files"):
            raise ValueError("the surface is a stored surface {mesh_id} or {vertices, triangles}; a file path "
                             "is read by the library, never by the service")
        return self


class Spec(BaseModel):
    """What is fixed, what moves, and how to solve (docs/guide/documents.md)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{
        "selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}},
        "fixed": ["root"], "handles": {"tip": "tip"}}]})

    selections: dict[str, Selection] = Field(min_length=1, max_length=10_000)
    fixed: list[StrictStr] = Field(default_factory=list, max_length=10_000)
    handles: dict[str, StrictStr] = Field(default_factory=dict, max_length=10_000)
    domain: StrictStr | None = None
    laplacian: Literal["cotangent", "uniform"] = "cotangent"
    constraints: Constraints | None = None
    solve: Literal["auto", "split", "joint"] = "auto"
    rotation: Literal["harmonic", "least_squares"] = "harmonic"
    inversion: Literal["warn", "reject", "clamp"] = "warn"
    points: list[Point] = Field(default_factory=list, max_length=100_000)
    relative: list[Relative] = Field(default_factory=list, max_length=100_000)
    features: list[Feature] = Field(default_factory=list, max_length=10_000)
    motion: list[Motion] = Field(default_factory=list, max_length=10_000)
    sliding: list[Sliding] = Field(default_factory=list, max_length=10_000)
    conflicts: Literal["report", "reject"] = "report"
    repair: StrictBool = False
    thin_walls: StrictBool | ThinWalls = True
    ties: Literal["auto", False] | Ties | list[list[VertexId]] = "auto"
    voids: Literal["volume", "refuse"] = "volume"
    targets: list[Target] = Field(default_factory=list, max_length=1000)
    symmetry: list[Symmetry] = Field(default_factory=list, max_length=100)
    cyclic: list[Cyclic] = Field(default_factory=list, max_length=100)
    precision: Literal["mixed", "exact"] = "mixed"

    def dump(self) -> dict[str, Any]:
        """The document as given (fields not set are left out)."""
        return self.model_dump(exclude_unset=True, mode="python")
