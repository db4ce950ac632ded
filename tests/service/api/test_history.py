"""The undo history kept with a session: GET and PUT /v1/sessions/{id}/history.

It is a client's record, not the morph state: saving it leaves the version, the last MOVE and the
positions alone; it survives restarts and is deleted with its session. Files are read in the test
from the data directory.
"""

from __future__ import annotations

import json

import pytest

from service.client import Client
from service.models.history import HISTORY_MAX, HISTORY_MAX_BYTES

from ..conftest import BRACKET_SPEC, MOVES, err, running, upload_bracket


def stored(data_dir, sid):
    p = data_dir / "sessions" / "history" / f"{sid}.json"
    return json.loads(p.read_text()) if p.exists() else None


def test_the_history_survives_a_restart_and_leaves_the_morph_state_alone(tmp_path):
    data = tmp_path / "data"
    with running(data) as tc:
        c = Client(http=tc)
        sid = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)["id"]
        assert c.history(sid) == {"applied": [], "undone": []}  # none saved yet
        c.deform(sid, MOVES[1])
        before = c.session(sid)
        kept = c.save_history(sid, MOVES[:2], MOVES[2:])  # two applied, the third undone
        assert kept == {"applied": MOVES[:2], "undone": MOVES[2:]}
        after = c.session(sid)
        for k in ("version", "last_move", "updates"):
            assert after[k] == before[k], k
    assert stored(data, sid) == {"applied": MOVES[:2], "undone": MOVES[2:]}
    record = json.loads((data / "sessions" / f"{sid}.json").read_text())
    assert "history" not in record and "applied" not in record  # kept apart from the versioned record
    with running(data) as tc:
        c = Client(http=tc)
        assert c.history(sid) == {"applied": MOVES[:2], "undone": MOVES[2:]}
        c.delete_session(sid)
        assert stored(data, sid) is None  # deleted with the session
        r = tc.get(f"/v1/sessions/{sid}/history")
        assert r.status_code == 404 and err(r)["code"] == "session_not_found"


BIG = {"points": {f"p{k}": [0.5, 0.5, 0.5] for k in range(12_000)}}  # about 290 KB of JSON per MOVE


@pytest.mark.parametrize("body, field", [
    ({"applied": [{"handles": {"tip": {"translation": [1, 2]}}}]}, "applied.0.handles.tip.translation"),
    ({"undone": [MOVES[0], {"rotate": 1}]}, "undone.1.rotate"),
    ({"applied": MOVES, "redo": []}, "redo"),
    ({"applied": [MOVES[0]] * (HISTORY_MAX + 1)}, "applied"),
    ({"applied": "all"}, "applied"),
    ({"applied": [BIG] * 8, "undone": [BIG] * 8}, f"at most {HISTORY_MAX_BYTES}"),
    ({"applied": [BIG] * 16}, f"at most {HISTORY_MAX_BYTES}"),
])
def test_a_bad_history_is_422_naming_the_field_and_keeps_the_stored_one(tmp_path, body, field):
    data = tmp_path / "data"
    with running(data) as tc:
        c = Client(http=tc)
        sid = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)["id"]
        c.save_history(sid, MOVES[:2])
        r = tc.put(f"/v1/sessions/{sid}/history", json=body)
        assert r.status_code == 422, r.text[:300]
        assert field in json.dumps(err(r)), err(r)
        assert stored(data, sid) == {"applied": MOVES[:2], "undone": []}


def test_another_keys_session_has_no_history_to_read_or_write(tmp_path):
    with running(tmp_path / "data", api_keys="alpha,beta") as tc:
        alpha, beta = Client(http=tc, api_key="alpha"), Client(http=tc, api_key="beta")
        sid = alpha.create_session(upload_bracket(alpha)["id"], BRACKET_SPEC)["id"]
        alpha.save_history(sid, MOVES)
        for call in (lambda: beta.history(sid), lambda: beta.save_history(sid, [])):
            with pytest.raises(Exception) as e:
                call()
            assert e.value.code == "session_not_found"
        assert alpha.history(sid) == {"applied": MOVES, "undone": []}
