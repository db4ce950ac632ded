"""A mesh's and a session's workspace: GET and PUT /v1/meshes/{id}/workspace and /v1/sessions/{id}/workspace.

What a client shows beside a mesh or a session (regions drawn, history labels, DOE plan, shape
values). It is not the morph state; it survives a restart of the app on the same data directory,
is deleted with its mesh or session, and a refused request stores nothing. Files are read in the
test from the data directory.
"""

from __future__ import annotations

import json

import pytest

from service.client import Client
from service.models.history import HISTORY_MAX
from service.models.workspace import WORKSPACE_LABEL_MAX, WORKSPACE_MAX_BYTES, WORKSPACE_PLAN_MAX

from ..conftest import BRACKET_SPEC, MOVES, err, running, upload_bracket

EMPTY = {"regions": None, "labels": [], "doe_plan": "", "shape_values": {}, "session": None}
DRAFT = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"ids": [1, 2, 3]}, "domain": {"set": "TET"}},
         "fixed": ["FIXED"], "handles": {"LOAD": "LOAD"}, "domain": "domain"}
DOC = {"regions": DRAFT, "labels": ["move", "preset lift 4", "shapes lift 1 + twist 0.5"],
       "doe_plan": "lift,twist\n1,0.5\n", "shape_values": {"lift": 1.0, "twist": 0.5}, "session": None}


def stored(data_dir, of: str, ident: str):
    """A workspace file of the data directory (None when there is none)."""
    p = (data_dir / "sessions" / "workspace" / f"{ident}.json" if of == "sessions"
         else data_dir / "meshes" / f"{ident}.workspace.json")
    return json.loads(p.read_text()) if p.exists() else None


def test_workspaces_survive_a_restart_and_leave_the_session_alone(tmp_path):
    data = tmp_path / "data"
    with running(data) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        sid = c.create_session(mid, BRACKET_SPEC)["id"]
        assert c.workspace("meshes", mid) == EMPTY and c.workspace("sessions", sid) == EMPTY  # none saved yet
        c.deform(sid, MOVES[1])
        before = c.session(sid)
        assert c.save_workspace("sessions", sid, DOC) == DOC
        assert c.save_workspace("meshes", mid, {"regions": DRAFT, "session": sid}) == {**EMPTY, "regions": DRAFT,
                                                                                       "session": sid}
        after = c.session(sid)
        for k in ("version", "last_move", "updates", "presets"):
            assert after[k] == before[k], k
    assert stored(data, "sessions", sid) == DOC
    assert stored(data, "meshes", mid)["session"] == sid
    record = json.loads((data / "sessions" / f"{sid}.json").read_text())
    assert "workspace" not in record and "labels" not in record  # kept apart from the versioned record
    with running(data) as tc:
        c = Client(http=tc)
        assert c.workspace("sessions", sid) == DOC
        assert c.workspace("meshes", mid) == {**EMPTY, "regions": DRAFT, "session": sid}
        # the whole document is replaced: a field left out is emptied
        assert c.save_workspace("sessions", sid, {"labels": ["move"]}) == {**EMPTY, "labels": ["move"]}
        c.delete_session(sid)
        assert stored(data, "sessions", sid) is None  # deleted with the session
        r = tc.get(f"/v1/sessions/{sid}/workspace")
        assert r.status_code == 404 and err(r)["code"] == "session_not_found"
        assert c.workspace("meshes", mid)["session"] == sid  # the mesh's stays until the mesh goes
        assert tc.delete(f"/v1/meshes/{mid}").status_code == 204
        assert stored(data, "meshes", mid) is None
        r = tc.put(f"/v1/meshes/{mid}/workspace", json=DOC)
        assert r.status_code == 404 and err(r)["code"] == "mesh_not_found"


BIG_IDS = {"selections": {"LOAD": {"ids": list(range(1_000_000, 3_000_000))}}}  # about 16 MB of JSON


@pytest.mark.parametrize("body, field", [
    ({"labels": ["x" * (WORKSPACE_LABEL_MAX + 1)]}, "labels.0"),
    ({"labels": ["move"] * (2 * HISTORY_MAX + 1)}, "labels"),
    ({"labels": [1]}, "labels.0"),
    ({"doe_plan": "1," * WORKSPACE_PLAN_MAX}, "doe_plan"),
    ({"doe_plan": ["a", "b"]}, "doe_plan"),
    ({"shape_values": {"lift": "1"}}, "shape_values.lift"),
    ({"shape_values": {"lift": 1e7}}, "shape_values.lift"),
    ({"shape_values": {"": 1}}, "shape_values"),
    ({"shape_values": {f"s{k}": 0 for k in range(101)}}, "shape_values"),
    ({"regions": {"selections": {"A": 5}}}, "regions.selections.A"),
    ({"regions": {"fixed": "FIXED"}}, "regions.fixed"),
    ({"regions": "all"}, "regions"),
    ({"session": "../etc"}, "session"),
    ({"redo": []}, "redo"),
    ({"regions": {"selections": {f"r{k}": {"ids": list(range(3000))} for k in range(700)}}},
     f"at most {WORKSPACE_MAX_BYTES}"),
])
@pytest.mark.parametrize("of", ["sessions", "meshes"])
def test_a_bad_workspace_is_422_naming_the_field_and_keeps_the_stored_one(tmp_path, body, field, of):
    data = tmp_path / "data"
    with running(data) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        ident = c.create_session(mid, BRACKET_SPEC)["id"] if of == "sessions" else mid
        c.save_workspace(of, ident, DOC)
        r = tc.put(f"/v1/{of}/{ident}/workspace", json=body)
        assert r.status_code == 422, r.text[:300]
        assert field in json.dumps(err(r)), err(r)
        assert stored(data, of, ident) == DOC
        assert c.workspace(of, ident) == DOC


def test_a_body_over_the_upload_limit_is_413_and_stores_nothing(tmp_path):
    data = tmp_path / "data"
    with running(data, max_upload_mb=1) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        c.save_workspace("meshes", mid, DOC)
        r = tc.put(f"/v1/meshes/{mid}/workspace", json={"regions": BIG_IDS})
        assert r.status_code == 413 and err(r)["code"] == "payload_too_large"
        assert stored(data, "meshes", mid) == DOC


def test_another_keys_workspaces_are_not_found(tmp_path):
    with running(tmp_path / "data", api_keys="alpha,beta") as tc:
        alpha, beta = Client(http=tc, api_key="alpha"), Client(http=tc, api_key="beta")
        mid = upload_bracket(alpha)["id"]
        sid = alpha.create_session(mid, BRACKET_SPEC)["id"]
        alpha.save_workspace("sessions", sid, DOC)
        alpha.save_workspace("meshes", mid, DOC)
        for of, ident, code in (("sessions", sid, "session_not_found"), ("meshes", mid, "mesh_not_found")):
            with pytest.raises(Exception) as e:
                beta.workspace(of, ident)
            assert e.value.code == code
            with pytest.raises(Exception) as e:
                beta.save_workspace(of, ident, EMPTY)
            assert e.value.code == code
            assert alpha.workspace(of, ident) == DOC
