"""A workspace: what a client shows beside a mesh or a session, kept with it on the service.

The editor keeps here what has no place in the morph state: the regions it draws (a SPEC
draft, which may be ahead of the SPEC a session was created from), the labels of its undo
history, the DOE plan and the shape sliders' values, and, for a mesh, the session last opened
on it. The service checks sizes and types only: the regions are the client's draft, checked as
a SPEC when a session is created from them.
"""

from __future__ import annotations

import json
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, StrictStr, StringConstraints, model_validator

from .history import HISTORY_MAX
from .session import PRESET_NAME_MAX, PRESETS_MAX

__all__ = ["Workspace", "WorkspaceDoc", "RegionsDraft", "WORKSPACE_MAX_BYTES",
           "WORKSPACE_REGIONS_MAX", "WORKSPACE_LABEL_MAX", "WORKSPACE_PLAN_MAX"]

#: Largest size of a workspace as compact JSON (the regions' id lists take most of it).
WORKSPACE_MAX_BYTES = 8 << 20
#: Most named selections (regions and the SPEC's other selections) a draft holds.
WORKSPACE_REGIONS_MAX = 1000
#: Longest history label (characters).
WORKSPACE_LABEL_MAX = 200
#: Longest DOE plan (characters of CSV).
WORKSPACE_PLAN_MAX = 1 << 18

_Label = Annotated[StrictStr, StringConstraints(max_length=WORKSPACE_LABEL_MAX)]
_ShapeName = Annotated[StrictStr, StringConstraints(min_length=1, max_length=PRESET_NAME_MAX)]
_SelectionName = Annotated[StrictStr, StringConstraints(min_length=1, max_length=64)]
_ShapeValue = Annotated[float, Field(ge=-1e6, le=1e6, allow_inf_nan=False)]
_SessionId = Annotated[StrictStr, StringConstraints(pattern=r"^[A-Za-z0-9_-]{1,64}$")]


class RegionsDraft(BaseModel):
    """The regions as a SPEC draft: named selections, which are fixed, which are handles, and the rest.

    Other SPEC keys (``domain``, ``symmetry``, ...) are kept as given; nothing is resolved on
    the mesh until a session is created from them.
    """

    model_config = ConfigDict(extra="allow", strict=True)
    selections: dict[_SelectionName, dict[str, Any]] = Field(
        default_factory=dict, max_length=WORKSPACE_REGIONS_MAX,
        description=f"named selections as a SPEC has them (ids, set, box, ...); at most {WORKSPACE_REGIONS_MAX}")
    fixed: list[_SelectionName] = Field(default_factory=list, max_length=WORKSPACE_REGIONS_MAX,
                                        description="the fixed selections")
    handles: dict[_SelectionName, Any] = Field(default_factory=dict, max_length=WORKSPACE_REGIONS_MAX,
                                               description="handle name -> its selection")


class Workspace(BaseModel):
    """``PUT /v1/sessions/{id}/workspace`` and ``PUT /v1/meshes/{id}/workspace``: replaces the workspace.

    Every field may be left out (its empty value is stored). It is not the morph state: saving it
    changes neither a session's version nor its positions.
    """

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{
        "regions": {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"ids": [3, 4, 5]}},
                    "fixed": ["FIXED"], "handles": {"LOAD": "LOAD"}},
        "labels": ["move", "preset lift 4"], "doe_plan": "lift 4\n0.5\n", "shape_values": {"lift 4": 0.5}}]})

    regions: RegionsDraft | None = Field(None, description="the regions drawn, as a SPEC draft (null: none)")
    labels: list[_Label] = Field(default_factory=list, max_length=2 * HISTORY_MAX,
                                 description="the undo history's labels, one per MOVE of the history "
                                             f"(applied, then undone); at most {2 * HISTORY_MAX}, "
                                             f"{WORKSPACE_LABEL_MAX} characters each")
    doe_plan: StrictStr = Field("", max_length=WORKSPACE_PLAN_MAX,
                                description=f"the DOE plan as typed (CSV); at most {WORKSPACE_PLAN_MAX} characters")
    shape_values: dict[_ShapeName, _ShapeValue] = Field(
        default_factory=dict, max_length=PRESETS_MAX,
        description=f"shape name -> the slider's value (|value| <= 1e6); at most {PRESETS_MAX}")
    session: _SessionId | None = Field(None, description="a mesh's workspace: the session last opened on it")

    @model_validator(mode="after")
    def _small(self) -> Workspace:
        size = len(json.dumps(self.dump(), separators=(",", ":")))
        if size > WORKSPACE_MAX_BYTES:
            raise ValueError(f"the workspace takes {size} bytes of JSON; at most {WORKSPACE_MAX_BYTES}")
        return self

    def dump(self) -> dict[str, Any]:
        """The workspace as stored, every field present."""
        return {"regions": None if self.regions is None else self.regions.model_dump(),
                "labels": list(self.labels), "doe_plan": self.doe_plan,
                "shape_values": {k: float(v) for k, v in self.shape_values.items()}, "session": self.session}


class WorkspaceDoc(BaseModel):
    """A workspace as the service answers it (every field present)."""

    regions: dict[str, Any] | None = Field(description="the regions drawn, as a SPEC draft (null: none)")
    labels: list[str] = Field(description="the undo history's labels, applied then undone")
    doe_plan: str = Field(description="the DOE plan as typed")
    shape_values: dict[str, float] = Field(description="shape name -> the slider's value")
    session: str | None = Field(description="a mesh's workspace: the session last opened on it")
