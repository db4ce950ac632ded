"""Request bodies other than SPEC and MOVE: JSON mesh arrays, feature bands, session creation."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, StrictStr

from solver.documents.numbers import Coord, VertexId
from solver.limits import MAX_POINTS

from .spec import Selection, Spec

__all__ = ["MeshArrays", "Band", "SessionCreate"]


class MeshArrays(BaseModel):
    """A tet mesh (or a triangle surface) as JSON arrays, 0-based indices."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"anyOf": [
        {"required": [k], "properties": {k: {"type": "array", "minItems": 1}}} for k in ("tetrahedra", "triangles")]})

    vertices: list[Annotated[list[Coord], Field(min_length=3, max_length=3)]] = Field(
        ..., min_length=4, max_length=MAX_POINTS, description="(n, 3) vertex positions, n >= 4")
    tetrahedra: list[Annotated[list[VertexId], Field(min_length=4, max_length=4)]] | None = Field(
        None, description="(m, 4) vertex indices")
    triangles: list[Annotated[list[VertexId], Field(min_length=3, max_length=3)]] | None = Field(
        None, description="(k, 3) vertex indices of a surface-only mesh")
    sets: dict[str, list[VertexId]] = Field(default_factory=dict, description="named vertex sets")
    name: StrictStr | None = Field(None, max_length=200)


class Band(BaseModel):
    """Selections whose union is a band around a feature's border."""

    model_config = ConfigDict(extra="forbid", strict=True)
    band: list[Selection] = Field(min_length=1, max_length=1000, description="SELECTION documents (as in a SPEC)")

    def dump(self) -> list[dict[str, Any]]:
        """The selections as given (a ``null`` field is absent)."""
        return [s.model_dump(exclude_unset=True, exclude_none=True) for s in self.band]


class SessionCreate(BaseModel):
    """Create a session: which mesh, and the SPEC (selections, fixed, handles, options)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    mesh_id: StrictStr = Field(..., max_length=64, description="id from POST /v1/meshes")
    spec: Spec = Field(..., description="the SPEC document (docs/guide/documents.md)")
