"""Mesh documents: the summary of a stored mesh, and JSON uploads."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["MeshInfo", "MeshDoc"]


class MeshInfo(BaseModel):
    """Counts, element types, named sets and a quality summary of a mesh."""

    model_config = ConfigDict(extra="allow")

    vertices: int
    tetrahedra: int
    elements: int = Field(description="volume elements of every type")
    boundary_faces: int | None = None
    boundary_vertices: int | None = None
    interior_vertices: int | None = None
    unreferenced_vertices: int | None = None
    bodies: int | None = None
    boundary_shells: int | None = None
    cell_types: dict[str, int] = Field(default_factory=dict, description="cells of the file by meshio type")
    element_order: int | None = None
    sets: dict[str, int] = Field(default_factory=dict, description="named vertex sets and their sizes")
    quality: dict[str, float | None] = Field(default_factory=dict,
                                             description="min/p01/median scaled Jacobian, min and total volume")
    bounding_box: dict[str, list[float]] | None = None


class MeshDoc(BaseModel):
    """A stored mesh."""

    model_config = ConfigDict(json_schema_extra={"examples": [{
        "id": "m_3f9c0a1b2d4e6f70", "name": "bracket.inp", "format": "abaqus", "files": ["bracket.inp"],
        "created": 1764579600.0, "info": {"vertices": 1213, "tetrahedra": 4228, "elements": 4228}}]})

    id: str
    name: str
    format: str = Field(description="meshio format name of the upload, or 'arrays'")
    files: list[str] = Field(description="the stored files (the upload, byte for byte)")
    created: float = Field(description="Unix time")
    info: MeshInfo
    tetrahedralization: dict[str, Any] | None = Field(
        None, description="fTetWild options and counts, for meshes made by POST /v1/tetrahedralize")
