"""The MOVE document (defined once, in :mod:`solver.documents.move`) and the WebSocket frame that carries one.

The service validates a request's MOVE with the library's model when the request is read, and hands the
validated model to the library, which checks it against the session's SPEC and mesh without validating
it again.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, model_validator

from solver.documents.move import FeatureMove, HandleMove, MotionMove, Move, RelativeMove, Rotation, TargetMove

__all__ = ["Move", "HandleMove", "Rotation", "RelativeMove", "FeatureMove", "MotionMove", "TargetMove",
           "StreamFrame"]


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
