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

import math
from importlib import import_module
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StrictStr,
    ValidationInfo,
    model_validator,
)
from pydantic.json_schema import SkipJsonSchema
from pydantic_core import PydanticCustomError

from ..limits import THREADS_MAX
from .choices import BACKENDS, PRECISIONS
from .deferred import OnFirstUse
from .geometry import Axis, Box, Direction3
from .numbers import INTEGRAL, Angle, Fraction, NonNegLength, PenaltyWeight, Vec3, VertexId, WallWeight, Weight

if TYPE_CHECKING:
    from .edits import AngleBetween, DistanceBetween, Fillet, Lattice, Mapping, Offset, Radius, Twist

__all__ = ["Spec", "SolveSettings", "Selection", "Target", "SELECTION_KINDS", "Box", "Sphere", "Plane",
           "Constraints", "Point", "Motion", "Relative", "RelativePoint", "Symmetry", "Cyclic", "Feature",
           "Sliding", "ThinWalls", "Ties", "StoredSurface", "InlineSurface", "Radius", "Twist", "Mapping", "Offset",
           "Lattice", "Fillet", "DistanceBetween", "AngleBetween", "Axis", "Direction3"]

_STRICT = ConfigDict(extra="forbid", strict=True)
#: The config of a model that only a member built on first use holds (:class:`.deferred.OnFirstUse`).
_LATER = ConfigDict(extra="forbid", strict=True, defer_build=True)

#: The edits' models, which :mod:`.edits` defines; this module gives them when asked (``spec.Radius``).
_EDIT_MODELS = ("Radius", "Twist", "Mapping", "Offset", "Lattice", "Fillet", "DistanceBetween", "AngleBetween")


def __getattr__(name: str) -> Any:
    """The edits' models (:data:`_EDIT_MODELS`), imported from :mod:`.edits` when first asked for."""
    if name in _EDIT_MODELS:
        return getattr(import_module(".edits", __package__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _edit(model: str) -> Any:
    """A function giving :mod:`.edits`' ``model``, which imports that module when first called."""
    return lambda: getattr(import_module(".edits", __package__), model)


if TYPE_CHECKING:
    Radii = list[Radius]
    Twists = list[Twist]
    Mappings = list[Mapping]
    Offsets = list[Offset]
    Lattices = list[Lattice]
    Fillets = list[Fillet]
    Distances = list[DistanceBetween]
    Angles = list[AngleBetween]
else:  # a SPEC's edits of one kind; their models are built when a SPEC first has such an edit (most have none)
    Radii, Twists, Mappings, Offsets, Lattices, Fillets, Distances, Angles = (
        Annotated[list[Any], OnFirstUse(most, _edit(model))] for model, most in (
            ("Radius", 10_000), ("Twist", 10_000), ("Mapping", 10_000), ("Offset", 10_000), ("Lattice", 1000),
            ("Fillet", 10_000), ("DistanceBetween", 10_000), ("AngleBetween", 10_000)))


def _distinct(ids: list[int]) -> list[int]:
    if len(set(ids)) != len(ids):
        raise ValueError(f"repeats a vertex: {ids}")
    return ids


#: Vertex ids of one POINT or pair, each once.
DistinctIds = Annotated[list[VertexId], Field(json_schema_extra={"uniqueItems": True}), AfterValidator(_distinct)]
#: The forms of a POINT, of which it has exactly one, and the fields each form may add.
POINT_FORMS = {"vertices": ("weights",), "edge": ("t",), "face": ("barycentric",), "selection": ()}


def _point_schema(schema: dict[str, Any]) -> None:
    """State a POINT's forms in its JSON Schema: exactly one of them, each with its own further field."""
    schema["oneOf"] = [{"required": [k]} for k in POINT_FORMS]
    schema["dependentRequired"] = {"t": ["edge"], "barycentric": ["face"], "weights": ["vertices"]}
    schema.setdefault("allOf", []).extend([{"if": {"required": ["edge"]}, "then": {"required": ["t"]}},
                                           {"if": {"required": ["face"]}, "then": {"required": ["barycentric"]}}])


class Sphere(BaseModel):
    """A closed ball."""

    model_config = _STRICT
    center: Vec3
    radius: NonNegLength


class Plane(BaseModel):
    """Vertices within ``tolerance`` of a plane."""

    model_config = _STRICT
    point: Vec3
    normal: Direction3
    tolerance: NonNegLength = 0.0


#: The fields of a SELECTION of which it has exactly one.
SELECTION_KINDS = ("ids", "set", "box", "sphere", "plane")


class Selection(BaseModel):
    """Exactly one of ``ids``, ``set``, ``box``, ``sphere``, ``plane``; optionally ``boundary_only``.

    The schema says so (``oneOf`` of the five, none of them ``null``), and so does the model's own check
    (a ``null`` kind counts as absent).
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

    model_config = ConfigDict(extra="forbid", strict=True, defer_build=True, json_schema_extra=_point_schema)
    vertices: Annotated[DistinctIds, Field(min_length=1, max_length=100_000)] | SkipJsonSchema[None] = None
    weights: Annotated[list[Weight], Field(max_length=100_000)] | SkipJsonSchema[None] = None
    edge: Annotated[DistinctIds, Field(min_length=2, max_length=2)] | SkipJsonSchema[None] = None
    t: Fraction | SkipJsonSchema[None] = None
    face: Annotated[DistinctIds, Field(min_length=3, max_length=3)] | SkipJsonSchema[None] = None
    barycentric: Annotated[list[Fraction], Field(min_length=3, max_length=3)] | SkipJsonSchema[None] = None
    selection: Annotated[StrictStr, Field(max_length=200)] | SkipJsonSchema[None] = None

    @model_validator(mode="after")
    def _one_form(self) -> RelativePoint:
        forms = [k for k in ("vertices", "edge", "face", "selection") if getattr(self, k) is not None]
        if len(forms) != 1:
            raise ValueError("must give exactly one of vertices+weights, edge+t, face+barycentric or selection")
        form = forms[0]
        stray = [k for k, owner in (("weights", "vertices"), ("t", "edge"), ("barycentric", "face"))
                 if getattr(self, k) is not None and owner != form]
        if stray:
            raise ValueError(f"{stray[0]} goes with {dict(weights='vertices', t='edge', barycentric='face')[stray[0]]}"
                             f", not with {form}" + ("; a selection point is its centroid" if form == "selection"
                                                     else ""))
        if form == "edge" and self.t is None:
            raise ValueError("an edge point needs t, its position along the edge in [0, 1]")
        if form == "face" and self.barycentric is None:
            raise ValueError("a face point needs barycentric, 3 numbers summing to 1")
        if self.barycentric is not None and abs(sum(self.barycentric) - 1.0) > 1e-9:
            raise ValueError(f"barycentric must sum to 1, got {self.barycentric}")
        if self.weights is not None:
            n = len(self.vertices or ())
            if len(self.weights) != n:
                raise ValueError(f"weights must be {n} numbers (one per vertex), got {len(self.weights)}")
            if abs(sum(self.weights)) <= 1e-12:
                raise ValueError("weights must not sum to zero")
        return self


class PointBase(RelativePoint):
    """A named point as a combination of vertices: vertices+weights, edge+t, face+barycentric, or a selection."""

    name: StrictStr = Field(max_length=200)


class Point(PointBase):
    """A point held at a target (default: its rest position; a MOVE may set it)."""

    target: Vec3 | None = None


class Normal(BaseModel):
    """A plane through the MOVE's point."""

    model_config = _LATER
    normal: Direction3


class Direction(BaseModel):
    """A line through the MOVE's point."""

    model_config = _LATER
    direction: Direction3


def _motion_schema(schema: dict[str, Any]) -> None:
    """A motion's point forms, and exactly one of plane or line."""
    _point_schema(schema)
    schema["allOf"].append({"oneOf": [{"required": ["plane"]}, {"required": ["line"]}]})


class Motion(PointBase):
    """A point that moves on a plane or along a line."""

    model_config = ConfigDict(extra="forbid", strict=True, defer_build=True, json_schema_extra=_motion_schema)
    plane: Normal | SkipJsonSchema[None] = None
    line: Direction | SkipJsonSchema[None] = None

    @model_validator(mode="after")
    def _plane_or_line(self) -> Motion:
        if (self.plane is None) == (self.line is None):
            raise ValueError("needs exactly one of plane or line")
        return self


class Relative(BaseModel):
    """The offset of two vertices or two POINTs (a hole's centre to another's), turned or not."""

    model_config = ConfigDict(extra="forbid", strict=True, defer_build=True,
                              json_schema_extra={"oneOf": [{"required": ["vertices"]}, {"required": ["points"]}]})
    name: StrictStr = Field(max_length=200)
    vertices: Annotated[DistinctIds, Field(min_length=2, max_length=2)] | SkipJsonSchema[None] = None
    points: Annotated[list[RelativePoint], Field(min_length=2, max_length=2)] | SkipJsonSchema[None] = None
    mode: Literal["rotate", "translate"] = "rotate"

    @model_validator(mode="after")
    def _vertices_or_points(self) -> Relative:
        if (self.vertices is None) == (self.points is None):
            raise ValueError("needs exactly one of vertices [i, j] or points [POINT, POINT]")
        return self


class MirrorPlane(BaseModel):
    """A plane of symmetry."""

    model_config = _LATER
    point: Vec3
    normal: Direction3


class Symmetry(BaseModel):
    """Mirror symmetry: boundary nodes on one side are the mirror images of the other side's."""

    model_config = _LATER
    name: StrictStr = Field(max_length=200)
    plane: MirrorPlane
    tolerance: NonNegLength | None = None


class Cyclic(BaseModel):
    """Cyclic symmetry of a sector: face B is face A turned by ``angle_deg`` about the axis."""

    model_config = _LATER
    name: StrictStr = Field(max_length=200)
    axis: Axis
    angle_deg: Angle
    faces: list[StrictStr] = Field(min_length=2, max_length=2)
    tolerance: NonNegLength | None = None

    @model_validator(mode="after")
    def _a_turn(self) -> Cyclic:
        if math.fmod(self.angle_deg, 360.0) == 0.0:
            raise ValueError(f"angle_deg must not be a multiple of 360, got {self.angle_deg:g}")
        return self


class Feature(BaseModel):
    """A form feature kept rigid or at its direction."""

    model_config = _LATER
    selection: StrictStr = Field(max_length=200)
    mode: Literal["rigid", "keep_direction"] = "rigid"
    name: StrictStr | None = Field(None, max_length=200)


class Sliding(BaseModel):
    """Vertices of a selection that keep their coordinate along ``normal``."""

    model_config = _LATER
    selection: StrictStr = Field(max_length=200)
    normal: Direction3


class ThinWalls(BaseModel):
    """Weight of the thin-wall rows."""

    model_config = _STRICT
    weight: WallWeight = 1.0


class Ties(BaseModel):
    """Tie coincident nodes of different bodies within ``tolerance``.

    ``surface`` pairs of selections tie each boundary node of A to its closest
    point on B's boundary faces (non-matching interfaces).
    """

    model_config = ConfigDict(extra="forbid", strict=True,
                              json_schema_extra={"anyOf": [{"required": ["tolerance"]}, {"required": ["surface"]}]})
    tolerance: NonNegLength | SkipJsonSchema[None] = None
    surface: Annotated[list[Annotated[list[StrictStr], Field(min_length=2, max_length=2)]],
                       Field(max_length=1000)] | SkipJsonSchema[None] = None
    surface_tolerance: NonNegLength | None = None

    @model_validator(mode="after")
    def _something_to_tie(self) -> Ties:
        if self.tolerance is None and self.surface is None:
            raise ValueError("needs a tolerance or surface pairs")
        return self


class StoredSurface(BaseModel):
    """A triangle surface uploaded through ``POST /v1/meshes`` (STL, OBJ, PLY, OFF), by its id."""

    model_config = _LATER
    mesh_id: StrictStr = Field(max_length=64, description="id of an uploaded triangle surface")


class InlineSurface(BaseModel):
    """A triangle surface given in the SPEC."""

    model_config = _LATER
    vertices: list[Vec3] = Field(min_length=3, max_length=10_000_000)
    triangles: list[Annotated[list[VertexId], Field(min_length=3, max_length=3)]] = Field(
        min_length=1, max_length=20_000_000)


class Target(BaseModel):
    """A selection whose boundary nodes land on a target surface (MOVE ``targets.NAME.amount``)."""

    model_config = _LATER
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


class SolveSettings(BaseModel):
    """How a SPEC's set-up is factored and solved (:class:`solver.options.SolveOptions` as a document).

    A field given here replaces what the caller (the command line, the service's settings) or the
    environment chose for this SPEC, so that a SPEC solves the same way wherever it runs; ``threads``
    only lowers the caller's cap.
    """

    model_config = _STRICT
    backend: Literal[BACKENDS] | None = Field(  # type: ignore[valid-type]
        None, description="symmetric backend; auto: CHOLMOD, then PARDISO, then SciPy")
    precision: Literal[PRECISIONS] | None = Field(  # type: ignore[valid-type]
        None, description="the interior solve: mixed (single-precision factor, double-precision residual "
                          "check and refinement) or exact (double-precision factor)")
    threads: Annotated[int, Field(strict=True, ge=0, le=THREADS_MAX), INTEGRAL] | None = Field(
        None, description="most threads one solve uses (0: every free core)")
    sweeps: StrictBool | None = Field(None, description="tetmorph's supernodal back-substitutions where they "
                                      "apply; false: the backends' own solves")
    basis: StrictBool | None = Field(None, description="stacked solves through the interior column basis")

    def given(self) -> dict[str, Any]:
        """The fields set, as a dict."""
        return {k: v for k, v in self.model_dump().items() if v is not None}


class Spec(BaseModel):
    """What is fixed, what moves, and how to solve (docs/guide/documents.md)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{
        "selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}},
        "fixed": ["root"], "handles": {"tip": "tip"}}], "allOf": [  # the two precisions, when both given, agree
            {"not": {"required": ["precision", "solve_options"],
                     "properties": {"precision": {"const": p},
                                    "solve_options": {"type": "object", "required": ["precision"],
                                                      "properties": {"precision": {"const": q}}}}}}
            for p in PRECISIONS for q in PRECISIONS if p != q]})

    selections: dict[str, Selection] = Field(min_length=1, max_length=10_000)
    fixed: list[StrictStr] = Field(default_factory=list, max_length=10_000)
    handles: dict[str, StrictStr] = Field(default_factory=dict, max_length=10_000)
    domain: StrictStr | None = None
    laplacian: Literal["cotangent", "uniform"] = "cotangent"
    constraints: Constraints | None = None
    solve: Literal["auto", "split", "joint"] = "auto"
    rotation: Literal["harmonic", "least_squares"] = "harmonic"
    inversion: Literal["warn", "reject", "clamp"] = "warn"
    points: Annotated[list[Point], OnFirstUse(100_000)] = Field(default_factory=list)
    relative: Annotated[list[Relative], OnFirstUse(100_000)] = Field(default_factory=list)
    features: Annotated[list[Feature], OnFirstUse(10_000)] = Field(default_factory=list)
    motion: Annotated[list[Motion], OnFirstUse(10_000)] = Field(default_factory=list)
    sliding: Annotated[list[Sliding], OnFirstUse(10_000)] = Field(default_factory=list)
    conflicts: Literal["report", "reject"] = "report"
    repair: StrictBool = False
    thin_walls: StrictBool | ThinWalls = True
    ties: Literal["auto", False] | Ties | list[Annotated[DistinctIds, Field(min_length=2, max_length=2)]] = "auto"
    voids: Literal["volume", "refuse"] = "volume"
    targets: Annotated[list[Target], OnFirstUse(1000)] = Field(default_factory=list)
    symmetry: Annotated[list[Symmetry], OnFirstUse(100)] = Field(default_factory=list)
    cyclic: Annotated[list[Cyclic], OnFirstUse(100)] = Field(default_factory=list)
    radius: Radii = Field(default_factory=list)
    twist: Twists = Field(default_factory=list)
    map: Mappings = Field(default_factory=list)
    offset: Offsets = Field(default_factory=list)
    lattice: Lattices = Field(default_factory=list)
    fillet: Fillets = Field(default_factory=list)
    distance: Distances = Field(default_factory=list)
    angle: Angles = Field(default_factory=list)
    precision: Literal[PRECISIONS] = Field(  # type: ignore[valid-type]
        "mixed", description="shorthand for solve_options.precision")
    solve_options: SolveSettings | None = None

    @model_validator(mode="after")
    def _one_precision(self) -> Spec:
        inner = self.solve_options.precision if self.solve_options is not None else None
        if "precision" in self.model_fields_set and inner is not None and inner != self.precision:
            raise PydanticCustomError(
                "disagreeing_fields", "precision '{outer}' and solve_options.precision '{inner}' disagree; give one",
                {"outer": self.precision, "inner": inner, "at": ("solve_options", "precision")})
        return self

    def dump(self) -> dict[str, Any]:
        """The document as given; fields not set, and fields given as ``null`` (absent in JSON's sense), left out."""
        return self.model_dump(exclude_unset=True, exclude_none=True, mode="python")
