"""MOVE documents with extreme numbers in every numeric field: never a 5xx, never a changed session."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.binary import decode_frame
from service.demo import DEMO_SESSION

from ..conftest import running

#: Numbers (and things that are not numbers) at the edges of what JSON and floats hold.
EXTREME = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-320, 5e-324, 1e-3, 1e3, 1e15, 1e16, 1e300, -1e300, 1.7976931348623157e308,
                     float("inf"), float("nan"), 360.0, 720.5, -1e9]),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([2**63, 2**64, -(2**63), 2**53 + 1]),
    st.booleans(), st.just("1"), st.none(),
)
VEC = st.lists(EXTREME, min_size=3, max_size=3) | st.lists(EXTREME, min_size=0, max_size=5)
HANDLE = st.fixed_dictionaries({}, optional={
    "translation": VEC, "pivot": VEC, "scale": EXTREME,
    "rotation": st.one_of(st.fixed_dictionaries({"axis": VEC, "angle_deg": EXTREME}),
                          st.fixed_dictionaries({"quaternion": st.lists(EXTREME, min_size=4, max_size=4)}))})
MOVE = st.fixed_dictionaries({"handles": st.fixed_dictionaries({"tip": HANDLE})})


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    with running(tmp_path_factory.mktemp("demo"), demo=True, rate_limit_per_s=0) as tc:
        yield tc


def _dumps(doc):
    return json.dumps(doc, allow_nan=True)  # NaN / Infinity literals too: Python's json reads them


@settings(max_examples=120, deadline=None, suppress_health_check=list(HealthCheck))
@given(move=MOVE)
def test_extreme_moves_never_5xx_and_never_commit_a_failure(demo, move):
    url = f"/v1/sessions/{DEMO_SESSION}"
    before = demo.get(f"{url}/positions?result=binary").content
    last = demo.get(url).json()["last_move"]
    r = demo.post(f"{url}/deform?result=binary", content=_dumps(move), headers={"content-type": "application/json"})
    assert r.status_code < 500, r.text
    if r.status_code == 200:
        X, head = decode_frame(r.content)
        assert np.isfinite(X).all() and head["report"]["finite"] is True
        assert demo.get(url).json()["last_move"] == move or head["report"]["clamped"]
    else:
        body = r.json()["error"]
        assert body["status"] == r.status_code and body["message"]
        assert demo.get(f"{url}/positions?result=binary").content == before
        assert demo.get(url).json()["last_move"] == last


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(move=MOVE, seq=EXTREME)
def test_extreme_frames_are_answered_on_an_open_stream(demo, move, seq):
    with demo.websocket_connect(f"/v1/sessions/{DEMO_SESSION}/stream") as ws:
        ws.send_text(_dumps({"seq": seq, "move": move}))
        msg = ws.receive()
        assert msg["type"] == "websocket.send", msg  # an answer, not a dropped socket
        if msg.get("text") is not None:
            assert json.loads(msg["text"])["error"]["status"] < 500
        else:
            X, head = decode_frame(msg["bytes"])
            assert np.isfinite(X).all() and head["report"]["finite"] is True
