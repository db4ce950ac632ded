"""Number types of the documents: strict (booleans and strings are not numbers), finite, bounded.

An integer field takes what JSON Schema calls an integer: ``3`` and ``3.0`` alike (a number
with no fraction), never ``3.5``, ``true`` or ``"3"``.

Bounds that depend on the mesh (vertex ids below its vertex count, translations and points within
:data:`EXTENT` bounding-box diagonals) are checked where the mesh is known: by
:func:`~solver.constraints.move.parse_move` against the deformer's mesh, and by the SPEC's parser.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BeforeValidator, Field

from ..limits import (
    ANGLE_MAX,
    COORD_MAX,
    EXTENT,
    ID_MAX,
    PENALTY_MAX,
    POINT_WEIGHT_MAX,
    SCALE_MAX,
    SCALE_MIN,
    WALL_WEIGHT_MAX,
)

__all__ = ["Int", "INTEGRAL", "Coord", "Vec3", "Quat", "Scale", "Angle", "Weight", "VertexId", "Fraction",
           "NonNegLength", "PenaltyWeight", "COORD_MAX", "SCALE_MIN", "SCALE_MAX", "EXTENT", "PENALTY_MAX", "ID_MAX",
           "ANGLE_MAX", "WALL_WEIGHT_MAX", "POINT_WEIGHT_MAX", "WallWeight"]

# Every bound is :mod:`solver.limits`'s: the library's parsers and this schema read the same numbers.

Coord = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-COORD_MAX, le=COORD_MAX)]

def _listed(v: Any) -> Any:
    """A tuple as the list it holds (a library caller's ``(1, 0, 0)``; JSON has lists only)."""
    return list(v) if isinstance(v, tuple) else v


Vec3 = Annotated[list[Coord], Field(min_length=3, max_length=3, description="[x, y, z]"), BeforeValidator(_listed)]
Quat = Annotated[list[Coord], Field(min_length=4, max_length=4, description="[w, x, y, z], non-zero"),
                 BeforeValidator(_listed)]
Scale = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=SCALE_MIN, le=SCALE_MAX,
                               description=f"uniform scale factor in [{SCALE_MIN:g}, {SCALE_MAX:g}]")]
Angle = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-ANGLE_MAX, le=ANGLE_MAX,
                               description=f"degrees within +-{ANGLE_MAX:g} (reduced modulo 360)")]
Weight = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-POINT_WEIGHT_MAX, le=POINT_WEIGHT_MAX)]
WallWeight = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=WALL_WEIGHT_MAX)]
Fraction = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=1)]
NonNegLength = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=COORD_MAX)]
PenaltyWeight = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0, le=PENALTY_MAX,
                                       description=f"penalty weight beta in (0, {PENALTY_MAX:g}]")]


def _integral(v: Any) -> Any:
    """A float with no fraction as the int it is (JSON Schema's ``integer``); anything else unchanged."""
    if type(v) is float and v.is_integer():
        return int(v)
    return v


#: Put after the ``Field`` of an ``int`` (``Annotated[int, Field(strict=True, ge=...), INTEGRAL]``): a
#: float without fraction is taken as its int. (Before the ``Field``, the schema would lose its bounds.)
INTEGRAL = BeforeValidator(_integral)
#: An integer: an int, or a float without fraction; booleans and strings are refused.
Int = Annotated[int, Field(strict=True), INTEGRAL]
VertexId = Annotated[int, Field(strict=True, ge=0, le=ID_MAX, description="0-based vertex index in file order"),
                     INTEGRAL]
