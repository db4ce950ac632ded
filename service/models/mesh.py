"""Mesh documents: the summary of a stored mesh, the symmetry it has, and JSON uploads."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from solver.documents.spec import Cyclic, Symmetry

__all__ = ["MeshInfo", "MeshDoc", "PlaneOffer", "MeshSymmetry"]


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


class PlaneOffer(Symmetry):
    """A mirror plane the mesh's boundary has: a ``SPEC.symmetry`` entry, with how well it matched.

    ``name``, ``plane`` and ``tolerance`` are the entry (the tolerance a little above the largest
    gap found); ``matched`` and ``exact_pairs`` say how it was found and are not part of a SPEC.
    """

    matched: float = Field(ge=0, le=1, description="share of boundary nodes whose mirror image lies on "
                           "the boundary within the tolerance")
    exact_pairs: float = Field(ge=0, le=1, description="share of boundary nodes whose mirror image is a node")


class MeshSymmetry(BaseModel):
    """Symmetry a mesh already has, as ``tetmorph info`` lists it: entries ready for a SPEC."""

    model_config = ConfigDict(json_schema_extra={"examples": [{
        "planes": [{"name": "mirror1", "plane": {"point": [50.0, 10.0, 5.0], "normal": [0.0, 1.0, 0.0]},
                    "tolerance": 0.13, "matched": 1.0, "exact_pairs": 0.31}],
        "cyclic": [{"name": "T1", "axis": {"point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0]},
                    "angle_deg": -30.0, "faces": ["Nright", "Nleft"], "tolerance": 0.001}]}]})

    planes: list[PlaneOffer] = Field(description="mirror planes of the boundary, best match first "
                                     "(SPEC.symmetry entries once matched and exact_pairs are dropped)")
    cyclic: list[Cyclic] = Field(description="the deck's cyclic-symmetry definitions (Abaqus *TIE, CYCLIC "
                                 "SYMMETRY with *CYCLIC SYMMETRY MODEL), the angle's sign turning face A "
                                 "onto face B; SPEC.cyclic entries whose faces are named sets of the mesh")
