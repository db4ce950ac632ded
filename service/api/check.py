"""``GET /v1/meshes/{id}/check`` and ``GET /v1/sessions/{id}/check``: the quality check of ``tetmorph check``.

Both answer the numbers of :func:`solver.validity.criteria.quality_check`: the
stored mesh at rest, or a session's mesh at its current positions (with the
volume ratio against rest). ``result=csv`` and ``result=elset`` answer the
failing elements as the CLI's ``--csv`` and ``--elset`` files.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, Depends, Query, Response

from solver.io.abaqus_deck import is_assembly
from solver.io.element_sets import deck_element_ids, element_set
from solver.limits import QUALITY_THRESHOLD_MAX
from solver.mesh import Mesh
from solver.validity.criteria import Criteria, preset, quality_check

from ..errors import ServiceError
from ..models.check import CHECK_IDS_DEFAULT, CHECK_IDS_MAX, CriterionName, PresetName, QualityCheckDoc
from ..models.error import error_responses
from ..state.registry import Registry
from .deps import MeshDep, RegistryDep, SessionDep, safe_name

router = APIRouter(tags=["quality"])
_AUTH = (401, 429)

_Threshold = Annotated[float | None, Query(ge=-QUALITY_THRESHOLD_MAX, le=QUALITY_THRESHOLD_MAX,
                                            description="overrides the preset's threshold")]


class CheckQuery:
    """The query of both routes: the preset, threshold overrides, what to answer."""

    def __init__(
        self,
        preset: Annotated[PresetName, Query(description="thresholds to start from (docs/guide/validity.md)")]
        = "tetmorph",
        min_scaled_jacobian: _Threshold = None, min_scaled_jacobian_ip: _Threshold = None,
        max_aspect_ratio: _Threshold = None, min_dihedral: _Threshold = None, max_dihedral: _Threshold = None,
        min_volume_ratio: _Threshold = None, max_volume_ratio: _Threshold = None,
        off: Annotated[list[CriterionName] | None, Query(description="criteria not to check (repeat the "
                                                         "parameter for several)")] = None,
        ids: Annotated[int, Query(ge=0, le=CHECK_IDS_MAX, description="failing deck ids answered per "
                                  "criterion (the first, ascending)")] = CHECK_IDS_DEFAULT,
        result: Annotated[Literal["json", "csv", "elset"], Query(
            description="json; csv: the failing elements (element,criterion,value,threshold); elset: an "
                        "element set in the deck's syntax (Abaqus, Nastran, Ansys CDB, LS-DYNA decks)")] = "json",
        set_name: Annotated[str, Query(pattern=r"^[A-Za-z][A-Za-z0-9_\-]{0,63}$",
                                       description="name of the result=elset set")] = "FAILED_QUALITY",
    ) -> None:
        given = {"min_scaled_jacobian": min_scaled_jacobian, "min_scaled_jacobian_ip": min_scaled_jacobian_ip,
                 "max_aspect_ratio": max_aspect_ratio, "min_dihedral": min_dihedral,
                 "max_dihedral": max_dihedral, "min_volume_ratio": min_volume_ratio,
                 "max_volume_ratio": max_volume_ratio}
        changed: dict[str, float | None] = {k: v for k, v in given.items() if v is not None}
        changed.update({k: None for k in (off or [])})
        self.preset: str = preset
        self.criteria: Criteria = _PRESET(preset).replace(**changed)
        self.ids, self.result, self.set_name = ids, result, set_name


#: The library's presets (the query's ``preset`` parameter shadows the function's name in ``__init__``).
_PRESET = preset

CheckDep = Annotated[CheckQuery, Depends()]

_200 = {"model": QualityCheckDoc, "content": {"text/csv": {"schema": {"type": "string"}},
                                               "text/plain": {"schema": {"type": "string"}}},
        "description": "the check (JSON), or the failing elements as CSV or as an element set"}
_422 = ("invalid query (invalid_request); result=elset on a mesh whose format has no element sets, or an "
        "Abaqus/CAE assembly deck (element_sets_unsupported)")


def _answer(mesh: Mesh, V: np.ndarray, V0: np.ndarray | None, q: CheckQuery) -> tuple[str, Any]:
    """The check's answer: ``("json", doc)`` or ``(media type, text)`` (in a worker thread)."""
    ids = deck_element_ids(mesh)
    check = quality_check(V, mesh.T, q.criteria, cells=mesh.cells, T10=mesh.T10, V0=V0, ids=ids)
    if q.result == "elset":
        return "text/plain", element_set(mesh.file_format, q.set_name, ids[check.failing],
                                         assembly=is_assembly(mesh))
    if q.result == "csv":
        return "text/csv", check.csv()
    return "json", {"preset": q.preset, "deformed": V0 is not None, **check.to_dict(max_ids=q.ids)}


async def _respond(reg: Registry, mesh: Mesh, V: np.ndarray, V0: np.ndarray | None, q: CheckQuery,
                   stem: str) -> Any:
    if mesh.is_surface:
        raise ServiceError("not_a_volume_mesh", "the mesh is a triangle surface; the quality check measures "
                           "volume elements", field="mesh")
    media, body = await reg.run(_answer, mesh, V, V0, q)
    if media == "json":
        return body
    ext = "csv" if media == "text/csv" else "inc"
    name = safe_name(f"{stem}_failed.{ext}", f"failed.{ext}")
    return Response(body, media_type=media, headers={"Content-Disposition": f'attachment; filename="{name}"'})


@router.get("/meshes/{mesh_id}/check", summary="Quality check of a mesh against thresholds",
            response_model=QualityCheckDoc, responses={200: _200, **error_responses(*_AUTH, 404, 422, s422=_422)})
async def check_mesh(meta: MeshDep, reg: RegistryDep, q: CheckDep) -> Any:
    """Per criterion: threshold, failing count, worst value and its element, the failing deck ids.

    The stored mesh as uploaded (the volume ratio is not measured: no deformation).
    """
    mesh = await reg.catalogue.mesh(meta)
    return await _respond(reg, mesh, mesh.V, None, q, str(meta.get("name", "mesh")).rsplit(".", 1)[0])


@router.get("/sessions/{session_id}/check", summary="Quality check of a session's current mesh",
            response_model=QualityCheckDoc,
            responses={200: _200, **error_responses(*_AUTH, 404, 410, 422, s422=_422)})
async def check_session(s: SessionDep, reg: RegistryDep, q: CheckDep) -> Any:
    """The check at the session's last MOVE (rest shape before any), with the volume ratio against rest."""
    V = await reg.moves.positions(s)
    mesh = await reg.sessions.mesh(s)
    meta = reg.store.mesh_meta(s.mesh_id) or {}
    return await _respond(reg, mesh, V, mesh.V, q, str(meta.get("name", "mesh")).rsplit(".", 1)[0] + "_deformed")


__all__ = ["router", "CheckQuery"]
