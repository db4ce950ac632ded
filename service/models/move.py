"""The MOVE document and the WebSocket frame that carries one.

Types and static ranges are checked by the models; :func:`check_move_extent`
checks translations, pivots and targets against the mesh's size, and
:func:`reduced_move` reduces angles modulo 360 degrees.
"""

from __future__ import annotations

import copy
import math
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, model_validator

from solver.limits import TARGET_AMOUNT_MAX

from ..errors import ServiceError
from .numbers import EXTENT, Angle, Quat, Scale, Vec3

__all__ = ["Move", "HandleMove", "StreamFrame", "check_move_extent", "reduced_move"]

_STRICT = ConfigDict(extra="forbid", strict=True)


class Rotation(BaseModel):
    """``axis`` + ``angle_deg``, or a ``quaternion`` [w, x, y, z]."""

    model_config = _STRICT
    axis: Vec3 | None = None
    angle_deg: Angle | None = None
    quaternion: Quat | None = None


class HandleMove(BaseModel):
    """Where one handle goes: ``pivot + translation + scale R (p0 - pivot)``."""

    model_config = _STRICT
    translation: Vec3 | None = Field(None, description=f"within {EXTENT:g} bounding-box diagonals")
    rotation: Rotation | None = None
    pivot: Vec3 | None = Field(None, description="default: the handle's rest centroid; within "
                               f"{EXTENT:g} diagonals of the mesh's centre")
    scale: Scale | None = None


class RelativeMove(BaseModel):
    """A new offset or scale of a SPEC ``relative`` constraint."""

    model_config = _STRICT
    offset: Vec3 | None = None
    scale: Scale | None = None


class FeatureMove(BaseModel):
    """The scale of a SPEC feature."""

    model_config = _STRICT
    scale: Scale = 1.0


class MotionMove(BaseModel):
    """The point a SPEC ``motion`` plane or line passes through."""

    model_config = _STRICT
    point: Vec3


class TargetMove(BaseModel):
    """How far the nodes of a SPEC ``targets`` entry go: 0 rest, 1 on the target surface."""

    model_config = _STRICT
    amount: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-TARGET_AMOUNT_MAX,
                                   le=TARGET_AMOUNT_MAX)] = 1.0


class Move(BaseModel):
    """Where the handles go (docs/guide/documents.md).

    A handle the MOVE does not name is at its rest position (identity
    transform), not where an earlier MOVE put it: every MOVE is absolute.
    """

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [
        {"handles": {"tip": {"translation": [0, 0, 4], "rotation": {"axis": [1, 0, 0], "angle_deg": 15}}}}]})

    handles: dict[str, HandleMove] = Field(default_factory=dict, max_length=10_000)
    points: dict[str, Vec3] = Field(default_factory=dict, max_length=100_000)
    relative: dict[str, RelativeMove] = Field(default_factory=dict, max_length=100_000)
    features: dict[str, FeatureMove] = Field(default_factory=dict, max_length=10_000)
    motion: dict[str, MotionMove] = Field(default_factory=dict, max_length=10_000)
    targets: dict[str, TargetMove] = Field(default_factory=dict, max_length=1000)

    def dump(self) -> dict[str, Any]:
        """The document as given (fields not set are left out)."""
        return self.model_dump(exclude_unset=True, mode="python")


class StreamFrame(BaseModel):
    """A WebSocket text frame: ``{"seq": k, "move": MOVE}`` with optional overrides."""

    model_config = ConfigDict(extra="forbid", strict=True)
    seq: StrictInt | None = Field(None, ge=-(2**53), le=2**53, description="echoed in the answer")
    move: Move
    inversion: Literal["warn", "reject", "clamp"] | None = None
    repair: StrictBool | None = None

    @model_validator(mode="before")
    @classmethod
    def _needs_move(cls, data: Any) -> Any:
        if isinstance(data, dict) and "move" not in data:
            raise ValueError("a frame needs 'move' (send {\"seq\": k, \"move\": MOVE}); a frame without "
                             "a MOVE changes nothing")
        return data


def reduced_move(doc: dict[str, Any]) -> dict[str, Any]:
    """The MOVE with every ``angle_deg`` reduced into (-360, 360) (the same rotation).

    Examples
    --------
    >>> reduced_move({"handles": {"h": {"rotation": {"axis": [0, 0, 1], "angle_deg": 725.0}}}})
    {'handles': {'h': {'rotation': {'axis': [0, 0, 1], 'angle_deg': 5.0}}}}
    """
    out = doc
    for name, h in (doc.get("handles") or {}).items():
        rot = h.get("rotation") or {}
        a = rot.get("angle_deg")
        if a is not None and abs(a) >= 360:
            if out is doc:
                out = copy.deepcopy(doc)
            out["handles"][name]["rotation"]["angle_deg"] = math.fmod(a, 360.0)
    return out


def check_move_extent(doc: dict[str, Any], lo: list[float], hi: list[float]) -> None:
    """Refuse translations, offsets, pivots and targets far outside the mesh.

    Parameters
    ----------
    doc : dict
        A MOVE validated by :class:`Move`.
    lo, hi : list of float
        The mesh's bounding box.

    Raises
    ------
    ServiceError
        422 ``out_of_range`` naming the field, its value's size and the bound.
    """
    a, b = np.asarray(lo, float), np.asarray(hi, float)
    diag = float(np.linalg.norm(b - a)) or 1.0
    centre = (a + b) / 2
    bound = EXTENT * diag

    def check(v: list[float] | None, where: str, about: np.ndarray | None) -> None:
        if v is None:
            return
        x = np.asarray(v, float) - (about if about is not None else 0.0)
        size = float(np.linalg.norm(x))
        if not size <= bound:
            what = "distance from the mesh's centre" if about is not None else "length"
            raise ServiceError("out_of_range", f"{where}: {what} {size:.3g} exceeds {EXTENT:g} bounding-box "
                               f"diagonals of the mesh ({bound:.3g})", field=where, value=v, bound=bound)

    for name, h in (doc.get("handles") or {}).items():
        check(h.get("translation"), f"MOVE.handles.{name}.translation", None)
        check(h.get("pivot"), f"MOVE.handles.{name}.pivot", centre)
    for name, p in (doc.get("points") or {}).items():
        check(p, f"MOVE.points.{name}", centre)
    for name, r in (doc.get("relative") or {}).items():
        check(r.get("offset"), f"MOVE.relative.{name}.offset", None)
    for name, m in (doc.get("motion") or {}).items():
        check(m.get("point"), f"MOVE.motion.{name}.point", centre)
