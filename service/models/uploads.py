"""Request bodies other than SPEC and MOVE: JSON mesh arrays, feature bands, session creation."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, StrictStr, model_validator

from .numbers import Coord, VertexId
from .spec import Selection, Spec

__all__ = ["MeshArrays", "Band", "SessionCreate"]


class MeshArrays(BaseModel):
    """A tet mesh (or a triangle surface) as JSON arrays, 0-based indices."""

    model_config = ConfigDict(extra="forbid", strict=True)

    vertices: list[list[Coord]] = Field(..., max_length=50_000_000, description="(n, 3) vertex positions")
    tetrahedra: list[list[VertexId]] | None = Field(None, description="(m, 4) vertex indices")
    triangles: list[list[VertexId]] | None = Field(None, description="(k, 3) vertex indices of a "
                                                   "surface-only mesh")
    sets: dict[str, list[VertexId]] = Field(default_factory=dict, description="named vertex sets")
    name: StrictStr | None = Field(None, max_length=200)

    @model_validator(mode="after")
    def _rows(self) -> MeshArrays:
        """Check the row lengths (3 per vertex, 4 per tet, 3 per triangle), naming the first bad row."""
        table: tuple[tuple[str, Sequence[Sequence[float]] | None, int], ...] = (
            ("vertices", self.vertices, 3), ("tetrahedra", self.tetrahedra, 4), ("triangles", self.triangles, 3))
        for what, rows, k in table:
            bad = next((i for i, r in enumerate(rows or []) if len(r) != k), None)
            if bad is not None and rows is not None:
                raise ValueError(f"{what}[{bad}] has {len(rows[bad])} numbers; need {k}")
        return self


class Band(BaseModel):
    """Selections whose union is a band around a feature's border."""

    model_config = ConfigDict(extra="forbid", strict=True)
    band: list[Selection] = Field(min_length=1, max_length=1000, description="SELECTION documents (as in a SPEC)")

    def dump(self) -> list[dict[str, Any]]:
        """The selections as given."""
        return [s.model_dump(exclude_unset=True) for s in self.band]


class SessionCreate(BaseModel):
    """Create a session: which mesh, and the SPEC (selections, fixed, handles, options)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    mesh_id: StrictStr = Field(..., max_length=64, description="id from POST /v1/meshes")
    spec: Spec = Field(..., description="the SPEC document (docs/guide/documents.md)")
