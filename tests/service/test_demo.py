"""The demo loaded at start-up."""

from __future__ import annotations

from .conftest import BEAM_SPEC, running


def test_demo_loads_at_startup(tmp_path):
    with running(tmp_path, demo=True) as tc:
        doc = tc.get("/v1/sessions/s_demo").json()
        assert doc["status"] == "ready" and doc["last_move"] is not None
        r = tc.post("/v1/sessions/s_demo/deform", json={"handles": {"tip": {"translation":
                                                                            [0, 0, 0.2]}}})
        assert r.status_code == 200 and r.json()["report"]["inverted_elements"] == 0
    with running(tmp_path, demo=True) as tc:  # idempotent across restarts
        assert len(tc.get("/v1/sessions").json()) == 1
    assert BEAM_SPEC["handles"] == {"tip": "tip"}
