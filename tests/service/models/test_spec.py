"""SPEC documents with extreme numbers in every numeric field: a typed 4xx or a session, never a 5xx."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.demo import DEMO_MESH

from ..conftest import running
from .test_move import EXTREME, VEC

IDS = st.lists(st.one_of(st.integers(min_value=-(2**70), max_value=2**70), EXTREME), min_size=1, max_size=3)
SELECTION = st.one_of(
    st.fixed_dictionaries({"ids": IDS}),
    st.fixed_dictionaries({"box": st.fixed_dictionaries({"min": VEC, "max": VEC})}),
    st.fixed_dictionaries({"sphere": st.fixed_dictionaries({"center": VEC, "radius": EXTREME})}),
    st.fixed_dictionaries({"plane": st.fixed_dictionaries({"point": VEC, "normal": VEC, "tolerance": EXTREME})}),
)
SPEC = st.fixed_dictionaries(
    {"selections": st.fixed_dictionaries({"root": SELECTION, "tip": st.just({"ids": [1]})}),
     "fixed": st.just(["root"]), "handles": st.just({"tip": "tip"})},
    optional={"constraints": st.fixed_dictionaries({"method": st.just("penalty"), "penalty_weight": EXTREME}),
              "thin_walls": st.fixed_dictionaries({"weight": EXTREME}),
              "points": st.lists(st.fixed_dictionaries({"name": st.just("p"), "edge": IDS, "t": EXTREME}),
                                 max_size=1),
              "ties": st.lists(IDS, max_size=2)})


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    with running(tmp_path_factory.mktemp("demo"), demo=True, rate_limit_per_s=0, max_sessions=10_000) as tc:
        yield tc


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(spec=SPEC)
def test_extreme_specs_never_5xx(demo, spec):
    body = json.dumps({"mesh_id": DEMO_MESH, "spec": spec}, allow_nan=True)
    r = demo.post("/v1/sessions", content=body, headers={"content-type": "application/json"})
    assert r.status_code < 500, r.text
    if r.status_code in (201, 202):
        assert demo.delete(f"/v1/sessions/{r.json()['id']}").status_code == 204
    else:
        assert r.json()["error"]["status"] == r.status_code
