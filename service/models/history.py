"""A session's undo history: the MOVEs a client applied, and those it undid."""

from __future__ import annotations

import json
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from .move import Move

__all__ = ["History", "HistoryDoc", "HISTORY_MAX", "HISTORY_MAX_BYTES"]

#: Most MOVEs each list of a history keeps (a client drops the oldest beyond it).
HISTORY_MAX = 500
#: Largest size of a history as compact JSON.
HISTORY_MAX_BYTES = 4 << 20


class History(BaseModel):
    """``PUT /v1/sessions/{id}/history``: the editor's undo and redo stacks, kept with the session.

    ``applied`` are the MOVEs applied in order, the last one the session's
    current MOVE (undo walks back through them); ``undone`` are the MOVEs
    undone since, the last one undone first (redo applies it again). It is a
    client's record, not the morph state: the session's version and last
    MOVE do not change when it is saved.
    """

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{
        "applied": [{"handles": {"tip": {"translation": [0, 0, 4]}}}],
        "undone": [{"handles": {"tip": {"translation": [0, 0, 6]}}}]}]})

    applied: list[Move] = Field(default_factory=list, max_length=HISTORY_MAX,
                                description=f"the MOVEs applied, oldest first; each validated as POST .../deform "
                                            f"validates it; at most {HISTORY_MAX}")
    undone: list[Move] = Field(default_factory=list, max_length=HISTORY_MAX,
                               description=f"the MOVEs undone since, the last one undone first; at most "
                                           f"{HISTORY_MAX} (both lists {HISTORY_MAX_BYTES // (1 << 20)} MiB of "
                                           f"JSON in all)")

    @model_validator(mode="after")
    def _small(self) -> History:
        size = len(json.dumps(self.dump(), separators=(",", ":")))
        if size > HISTORY_MAX_BYTES:
            raise ValueError(f"the history takes {size} bytes of JSON; at most {HISTORY_MAX_BYTES}")
        return self

    def dump(self) -> dict[str, Any]:
        """The history as stored: both lists of MOVEs as given."""
        return {"applied": [m.dump() for m in self.applied], "undone": [m.dump() for m in self.undone]}


class HistoryDoc(BaseModel):
    """A session's undo history as the service answers it: the MOVEs as they were given."""

    applied: list[dict[str, Any]] = Field(description="the MOVEs applied, oldest first")
    undone: list[dict[str, Any]] = Field(description="the MOVEs undone since, the last one undone first")
