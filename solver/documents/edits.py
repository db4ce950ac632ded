"""The SPEC's daily edits: ``radius``, ``twist``, ``map``, ``offset``, ``lattice``, ``fillet``, ``distance``, ``angle``.

Each entry names a selection whose nodes (corner and mid-side) get prescribed positions, computed
from their rest positions and the MOVE's parameters (:mod:`solver.documents.edit_moves`); the rest
of the part follows through the method, as it does a handle. What needs the mesh (the selection's
nodes, a node on an axis, a fit) is checked by :func:`solver.constraints.resolve_edits.resolve_edits`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, model_validator

from ..limits import ANGLE_MAX, LATTICE_COUNT_MAX
from .geometry import Axis, Box, Direction3, Geometry
from .numbers import INTEGRAL, Vec3

__all__ = ["Radius", "Twist", "Mapping", "Offset", "Lattice", "Fillet", "DistanceBetween", "AngleBetween", "EDIT_KINDS",
           "LatticeCount"]

#: The SPEC (and MOVE) keys of the edits, in the order their rows are ranked.
EDIT_KINDS = ("radius", "twist", "map", "offset", "lattice", "fillet", "distance", "angle")

Name = Annotated[StrictStr, Field(max_length=200)]
#: Control points along one axis of a lattice.
LatticeCount = Annotated[int, Field(strict=True, ge=1, le=LATTICE_COUNT_MAX), INTEGRAL]
#: An angle tolerance in degrees.
AngleTolerance = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=ANGLE_MAX)]


def _config(example: dict[str, Any]) -> ConfigDict:
    return ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [example]})


class Radius(BaseModel):
    """A cylindrical feature, a bore's wall or a boss, whose radius a MOVE sets (MOVE ``radius.NAME``).

    Every node of ``selection`` (mid-side nodes of quadratic elements too) goes to the MOVE's radius
    about ``axis``, its axial coordinate and its angle about the axis kept. Without ``axis``, the axis
    is the cylinder fitted to the selection's boundary faces (as ``tetmorph features`` fits its
    ``hole`` and ``boss`` candidates). A node on the axis has no radial direction and is refused.
    """

    model_config = _config({"name": "bore", "selection": "hole1",
                            "axis": {"point": [53.33, 26.67, 0.0], "direction": [0.0, 0.0, 1.0]}})
    name: Name
    selection: Name
    axis: Axis | None = Field(None, description="default: fitted to the selection's boundary faces")


class Twist(BaseModel):
    """Nodes turned or bent along an axis by an angle that depends on their axial coordinate (MOVE ``twist.NAME``).

    The angle at axial coordinate ``s`` (measured along ``axis.direction`` from ``axis.point``) is the
    MOVE's: a linear law (degrees per unit length, zero at ``axis.point``) or a table interpolated
    linearly. ``mode`` ``twist``: a node at ``s`` turns by that angle about the axis, right-handed.
    ``bend``: the axis becomes a curve whose tangent has turned by that angle toward ``toward`` at arc
    length ``s`` (a constant rate bends it into a circular arc), and each cross-section stays
    orthogonal to it, rigid.
    """

    model_config = _config({"name": "shaft", "selection": "skin",
                            "axis": {"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]}})
    name: Name
    selection: Name
    axis: Axis
    mode: Literal["twist", "bend"] = "twist"
    toward: Direction3 | None = Field(None, description="bend: the side the axis curves to, not along the axis")

    @model_validator(mode="after")
    def _toward_with_bend(self) -> Twist:
        if self.mode == "bend":
            if self.toward is None:
                raise ValueError("mode 'bend' needs toward, the direction the axis curves to")
            d, t = self.axis.direction, self.toward
            cross = math.hypot(d[1] * t[2] - d[2] * t[1], d[2] * t[0] - d[0] * t[2], d[0] * t[1] - d[1] * t[0])
            if cross <= 1e-9 * math.hypot(*d) * math.hypot(*t):
                raise ValueError(f"toward {t} runs along the axis {d}; it must point off it")
        elif self.toward is not None:
            raise ValueError("toward goes with mode 'bend'")
        return self


class Mapping(BaseModel):
    """Nodes mapped onto an analytic line, circle, plane, cylinder or sphere (MOVE ``map.NAME.amount``).

    ``projection`` ``nearest``: each node to its nearest point of the geometry; ``along``: along
    ``direction`` (either sense, the nearer hit), for the plane, the cylinder and the sphere.
    """

    model_config = _config({"name": "flat", "selection": "top",
                            "geometry": {"plane": {"point": [0.0, 0.0, 5.0], "normal": [0.0, 0.0, 1.0]}}})
    name: Name
    selection: Name
    geometry: Geometry
    projection: Literal["nearest", "along"] = "nearest"
    direction: Direction3 | None = Field(None, description="the projection's direction (projection 'along')")

    @model_validator(mode="after")
    def _direction_with_along(self) -> Mapping:
        if self.projection == "along":
            if self.direction is None:
                raise ValueError("projection 'along' needs a direction")
            if self.geometry.kind in ("line", "circle"):
                raise ValueError(f"projection 'along' maps onto a surface (plane, cylinder, sphere); a "
                                 f"{self.geometry.kind} is reached by 'nearest'")
        elif self.direction is not None:
            raise ValueError("direction goes with projection 'along'")
        return self


class Offset(BaseModel):
    """A face set moved along its outward normal by the MOVE's distance (MOVE ``offset.NAME.distance``).

    Faces whose normals all lie within ``planar_deg`` of their area-weighted mean are planar and move
    by exactly the distance along that one normal; otherwise each node moves along its own
    area-weighted normal. ``opposite`` (the wall's other face) stays where it is, or, with
    ``symmetric``, moves half the distance the other way (the first then moves half of it).
    """

    model_config = _config({"name": "wall", "selection": "outer", "opposite": "inner", "symmetric": True})
    name: Name
    selection: Name
    opposite: Name | None = None
    symmetric: StrictBool = False
    planar_deg: AngleTolerance = Field(1.0, description="faces within this angle of their mean normal are "
                                                        "planar")

    @model_validator(mode="after")
    def _symmetric_needs_opposite(self) -> Offset:
        if self.symmetric and self.opposite is None:
            raise ValueError("symmetric needs an opposite selection")
        if self.opposite is not None and self.opposite == self.selection:
            raise ValueError("opposite must be another selection than selection")
        return self


class Lattice(BaseModel):
    """A morph volume: a box with a lattice of control points whose displacements a MOVE sets.

    ``counts`` control points along x, y and z (trivariate Bernstein polynomials of degrees
    ``counts - 1``); a node at ``u`` in the box moves by ``sum B_i(u) B_j(v) B_k(w) d_ijk``. The nodes
    moved are ``selection``'s (default: the boundary nodes inside the box); the interior and the rest
    follow through the method.
    """

    model_config = _config({"name": "box", "box": {"min": [0, 0, 0], "max": [40, 20, 10]}, "counts": [3, 2, 2]})
    name: Name
    box: Box
    counts: list[LatticeCount] = Field(min_length=3, max_length=3)
    selection: Name | None = Field(None, description="default: the boundary nodes inside the box")

    @model_validator(mode="after")
    def _a_volume(self) -> Lattice:
        flat = [c for c, a, b in zip("xyz", self.box.min, self.box.max, strict=True) if not b > a]
        if flat:
            raise ValueError(f"the box must have a positive extent along each axis; it has none along {flat}")
        return self


class Fillet(BaseModel):
    """A fillet between two planar faces whose radius a MOVE sets (MOVE ``fillet.NAME``).

    The fillet is the circular cylinder tangent to the planes fitted to ``faces`` (two selections),
    its axis parallel to their intersection line; its radius is fitted to ``selection``'s corner
    nodes. For a new radius the axis moves to the line at that distance from both planes, on the
    same side, and every node of ``selection`` (mid-side nodes too) keeps its axial coordinate and
    its angle on the arc, and lands on the new arc. The faces' other nodes slide on their planes, so
    the part stays tangent to the fillet.
    """

    model_config = _config({"name": "corner", "selection": "fillet", "faces": ["flange", "web"]})
    name: Name
    selection: Name
    faces: list[Name] = Field(min_length=2, max_length=2, description="the two planar faces the fillet joins")

    @model_validator(mode="after")
    def _distinct_faces(self) -> Fillet:
        a, b = self.faces
        if a == b or self.selection in self.faces:
            raise ValueError(f"faces {self.faces} must be two selections, each another selection than selection "
                             f"{self.selection!r}")
        return self


class DistanceBetween(BaseModel):
    """The distance between two features, set by a MOVE (MOVE ``distance.NAME``).

    Measured between the centroids of ``selection`` (the moving feature) and ``reference`` (every
    node, mid-side nodes too), or, with ``direction``, along it (signed). ``selection`` translates
    rigidly along the measuring direction to the MOVE's distance; ``reference`` is held at rest.
    """

    model_config = _config({"name": "pitch", "selection": "hole2", "reference": "hole1"})
    name: Name
    selection: Name
    reference: Name
    direction: Direction3 | None = Field(None, description="measure along it (signed); default: between the "
                                                           "centroids")

    @model_validator(mode="after")
    def _two_features(self) -> DistanceBetween:
        if self.reference == self.selection:
            raise ValueError("reference must be another selection than selection")
        return self


class AngleBetween(BaseModel):
    """The angle between two features' directions, set by a MOVE (MOVE ``angle.NAME``).

    Each feature's direction is given, or fitted to its selection's boundary faces: a planar face
    set's outward normal, else a cylinder's axis (oriented so that the angle at rest is at most
    90°). ``selection`` (the moving feature) turns rigidly about ``axis`` (default: the cross
    product of the two directions) through ``pivot`` (default: its centroid) until the angle is the
    MOVE's; ``reference`` is held at rest.
    """

    model_config = _config({"name": "tilt", "selection": "flange", "reference": "base"})
    name: Name
    selection: Name
    reference: Name
    direction: Direction3 | None = Field(None, description="the moving feature's direction; default: fitted")
    reference_direction: Direction3 | None = Field(None, description="the reference's direction; default: fitted")
    axis: Direction3 | None = Field(None, description="the rotation axis; default: direction x reference_direction")
    pivot: Vec3 | None = Field(None, description="a point of the rotation axis; default: the moving feature's "
                                                 "centroid")
    planar_deg: AngleTolerance = Field(1.0, description="faces within this angle of their mean normal are planar")

    @model_validator(mode="after")
    def _two_features(self) -> AngleBetween:
        if self.reference == self.selection:
            raise ValueError("reference must be another selection than selection")
        return self
