"""A SPEC's stored target surfaces, resolved to the vertices and triangles the solver reads."""

from __future__ import annotations

import copy
from typing import Any

from ..errors import ServiceError
from ..models.spec import stored_surfaces
from .catalogue import Catalogue

__all__ = ["resolve_spec"]


async def resolve_spec(catalogue: Catalogue, owner: str, spec: dict[str, Any]) -> dict[str, Any]:
    """The SPEC with each stored target surface (``{"mesh_id": ID}``) as its vertices and triangles.

    Parameters
    ----------
    catalogue : Catalogue
        Where the surfaces are stored.
    owner : str
        Only this key's meshes are found.
    spec : dict
        A SPEC document; returned as it is when it names no stored surface.

    Raises
    ------
    ServiceError
        422 ``surface_not_found`` (no such mesh of the owner) or
        ``not_a_surface`` (a volume mesh), naming the SPEC field.
    """
    refs = stored_surfaces(spec)
    if not refs:
        return spec
    out = copy.copy(spec)
    out["targets"] = list(spec["targets"])
    for k, mid in refs:
        where = f"SPEC.targets[{k}].surface.mesh_id"
        meta = catalogue.store.mesh_meta(mid)
        if meta is None or meta.get("owner") != owner:
            raise ServiceError("surface_not_found", f"{where}: no stored mesh {mid!r} (upload the surface "
                               "with POST /v1/meshes)", field=where, mesh_id=mid)
        m = await catalogue.mesh(meta)
        if not m.is_surface:
            raise ServiceError("not_a_surface", f"{where}: mesh {mid} is a volume mesh ({m.elements} "
                               "elements); a target is a triangle surface (STL, OBJ, PLY, OFF)",
                               field=where, mesh_id=mid)
        surface = await catalogue.builder.run(lambda m=m: {"vertices": m.V.tolist(), "triangles": m.surface.tolist()})
        out["targets"][k] = {**spec["targets"][k], "surface": surface}
    return out
