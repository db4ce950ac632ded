"""The format names and extensions the schema offers, each one the validation accepts.

The validation is :func:`service.formats.resolve_format`.

A ``format`` field or query parameter of the API takes a format name, an alias or an extension,
in any case, with or without its dot; the schema lists each name, alias and extension once, in
lower case without the dot, so every value it offers is one the service reads or writes here.
A format written back in place only (``GET /v1/formats``: ``converts_to`` false) is among the
download values: it is the format of the meshes read from it.
"""

from __future__ import annotations

from ..formats import SURFACE_FORMATS, format_keys, offered, resolve_format

__all__ = ["format_values", "MESH_FORMAT_VALUES", "UPLOAD_FORMAT_VALUES", "SURFACE_FORMAT_VALUES"]


def format_values(allowed: dict[str, str]) -> list[str]:
    """Names, aliases and extensions (without the dot) of ``allowed`` (format name -> extension) that resolve.

    Examples
    --------
    >>> format_values({"stl": ".stl", "obj": ".obj"})
    ['obj', 'stl']
    """
    values = sorted(format_keys(allowed))
    return [v for v in values if resolve_format(v, None, allowed)[0] in allowed]


#: Formats meshes are downloaded and morphs written in (this installation's, measured).
MESH_FORMAT_VALUES = format_values(offered())
#: Formats of ``POST /v1/meshes``: the mesh formats and the triangle surfaces (SPEC targets).
UPLOAD_FORMAT_VALUES = format_values({**offered(), **SURFACE_FORMATS})
#: Closed triangle surfaces of ``POST /v1/tetrahedralize``.
SURFACE_FORMAT_VALUES = format_values(SURFACE_FORMATS)
