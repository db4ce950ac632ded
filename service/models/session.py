"""Session documents."""

from __future__ import annotations

import enum
import json
import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictStr, field_validator

from solver.documents.report import Report
from solver.documents.text import HAS_TEXT

from .move import Move

__all__ = ["SessionStatus", "SessionDoc", "SessionPatch", "Preset", "PresetDoc", "PRESETS_MAX", "PRESET_NAME_MAX",
           "PRESETS_MAX_BYTES"]

#: Most presets a session keeps.
PRESETS_MAX = 100
#: Longest preset name (characters).
PRESET_NAME_MAX = 64
#: Largest size of a session's presets as compact JSON (they are answered with every session document).
PRESETS_MAX_BYTES = 1 << 20



class SessionStatus(enum.StrEnum):
    """Where a session is in its life.

    ``stored``: known from the data directory, not built in this process yet;
    ``building``: assembling and factoring; ``ready``: factorizations cached;
    ``evicted``: dropped from the factorization cache, rebuilt on next use;
    ``failed``: the build failed (``error`` says why).
    """

    stored = "stored"
    building = "building"
    ready = "ready"
    evicted = "evicted"
    failed = "failed"


class Preset(BaseModel):
    """A named MOVE kept with the session (the editor's presets)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    name: StrictStr = Field(min_length=1, max_length=PRESET_NAME_MAX, json_schema_extra={"pattern": HAS_TEXT},
                            description="unique within the session; not only white space")
    move: Move = Field(description="the MOVE document, validated as POST .../deform validates it")

    @field_validator("name")
    @classmethod
    def _not_blank(cls, v: str) -> str:
        if not re.search(HAS_TEXT, v):  # the schema's pattern
            raise ValueError("a preset name needs a character other than white space")
        return v

    def dump(self) -> dict[str, Any]:
        """The preset as stored: its name and the MOVE as given."""
        return {"name": self.name, "move": self.move.dump()}


class SessionPatch(BaseModel):
    """``PATCH /v1/sessions/{id}``: what a client keeps with a session (the morph state is not touched)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{"presets": [
        {"name": "lift 4", "move": {"handles": {"tip": {"translation": [0, 0, 4]}}}}]}]})
    presets: list[Preset] = Field(max_length=PRESETS_MAX, description=f"replaces the session's presets; at "
                                  f"most {PRESETS_MAX}, names unique, {PRESETS_MAX_BYTES // 1024} KiB of JSON "
                                  "in all")

    @field_validator("presets")
    @classmethod
    def _unique_and_small(cls, v: list[Preset]) -> list[Preset]:
        first: dict[str, int] = {}
        for k, p in enumerate(v):
            j = first.setdefault(p.name, k)
            if j != k:
                raise ValueError(f"presets[{k}].name {p.name!r} is already the name of presets[{j}]; "
                                 "names are unique")
        size = len(json.dumps([p.dump() for p in v], separators=(",", ":")))
        if size > PRESETS_MAX_BYTES:
            raise ValueError(f"the presets take {size} bytes of JSON; at most {PRESETS_MAX_BYTES}")
        return v

    def dump(self) -> list[dict[str, Any]]:
        """The presets as stored."""
        return [p.dump() for p in self.presets]


class PresetDoc(BaseModel):
    """A preset as the session document answers it."""

    name: str
    move: dict[str, Any] = Field(description="the MOVE, as given")


class EditDimension(BaseModel):
    """An edit's dimension at rest: what its MOVE parameter changes from."""

    kind: Literal["radius", "fillet", "distance", "angle"] = Field(description="the SPEC key of the edit")
    name: str
    parameter: Literal["radius", "distance", "angle_deg"] = Field(
        description="the MOVE parameter that sets it (MOVE.<kind>.<name>.<parameter>)")
    rest: float = Field(description="a radius or a distance in the mesh's units, or an angle in degrees")


class SessionDoc(BaseModel):
    """A session: its status, progress, set-up figures and the last MOVE and REPORT."""

    model_config = ConfigDict(json_schema_extra={"examples": [{
        "id": "s_0a1b2c3d4e5f6071", "mesh_id": "m_3f9c0a1b2d4e6f70", "status": "ready", "stage": "done",
        "progress": 1.0, "error": None, "created": 1764579600.0, "last_used": 1764579660.0,
        "expires_at": 1764666060.0, "updates": 1, "builds": 1, "handles": ["tip"],
        "last_move": {"handles": {"tip": {"translation": [0, 0, 4]}}}, "spec": {}, "setup_timings": None,
        "factor_bytes": 1048576, "constraints_at_rest": None, "edits_at_rest": [], "last_report": None,
        "presets": [{"name": "lift 4", "move": {"handles": {"tip": {"translation": [0, 0, 4]}}}}]}]})

    id: str
    mesh_id: str
    status: SessionStatus
    stage: str = Field(description="build stage while building")
    progress: float = Field(description="build progress, 0 to 1")
    error: dict[str, Any] | None = Field(description="why the build failed (status 'failed')")
    created: float
    last_used: float = Field(description="Unix time of the last authenticated use")
    expires_at: float | None = Field(description="when the session is removed if unused until then")
    updates: int
    builds: int
    handles: list[str]
    last_move: dict[str, Any] | None = Field(description="the committed MOVE (as applied, when clamped)")
    version: int = Field(0, description="committed MOVEs (and resets) of the session so far")
    spec: dict[str, Any]
    setup_timings: dict[str, Any] | None
    factor_bytes: int | None
    constraints_at_rest: dict[str, Any] | None
    edits_at_rest: list[EditDimension] | None = Field(
        None, description="each radius, fillet, distance and angle edit's dimension at rest, as the set-up "
                          "measured it (None while building)")
    last_report: Report | None
    presets: list[PresetDoc] = Field(default_factory=list, description="named MOVEs kept with the session "
                                     "(PATCH /v1/sessions/{id}); not part of its morph state or version")
