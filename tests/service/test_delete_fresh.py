"""Schemathesis's DELETE cases on real resources, each created for its case, then checked gone.

tests/service/test_app.py never points DELETE at real ids, for the demo must survive its run.
Here every DELETE case gets a fresh resource made through the API just before it: a mesh (JSON
arrays, one tetrahedron), a session (the demo's mesh and SPEC), a batch of that session. The
answer must be no 5xx, a documented status and a body matching its schema; a 204 must leave the
resource gone (GET 404 or 410), a cancelled batch must read as cancelled.

Not given real ids: ``/v1/jobs/{job_id}`` (a tetrahedralization, fTetWild per case is too slow
for a bounded run) and the study's job (no FE solver is configured in tests); their cases run
with the generated ids (404).
"""

from __future__ import annotations

import tempfile
from typing import Any

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import response_schema_conformance, status_code_conformance

from service.app import create_app
from service.demo import DEMO_MESH, DEMO_SESSION

from .st_transport import send

pytestmark = pytest.mark.fuzz  # generated requests: make test, not make check
_DATA = tempfile.mkdtemp(prefix="tetmorph-delete-")
app = create_app(data_dir=_DATA, demo=True, rate_limit_per_s=0, max_sessions=100_000, job_wait_s=30)
client = TestClient(app)
client.__enter__()  # the demo mesh and session exist; the one lifespan of the run
schema = schemathesis.openapi.from_dict(app.openapi())  # cases go through the client (st_transport)
DEMO_SPEC = client.get(f"/v1/sessions/{DEMO_SESSION}").json()["spec"]
#: A batch long enough to be running when it is cancelled.
BATCH = {"shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}},
         "plan": {"columns": ["bend"], "rows": [[k / 400] for k in range(400)]}, "block": 1}


def fresh_mesh() -> str:
    r = client.post("/v1/meshes/arrays", json={"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                               "tetrahedra": [[0, 1, 2, 3]], "name": "fresh"})
    assert r.status_code == 201, r.text
    return r.json()["id"]


def fresh_session() -> str:
    r = client.post("/v1/sessions", json={"mesh_id": DEMO_MESH, "spec": DEMO_SPEC})
    assert r.status_code in (201, 202), r.text
    return r.json()["id"]


def fresh_batch(sid: str) -> str:
    r = client.post(f"/v1/sessions/{sid}/batch", json=BATCH)
    assert r.status_code == 202, r.text
    return r.json()["id"]


def give_fresh_ids(case: Any) -> dict[str, str]:
    """Point the case's path at resources made for it; answer what was made."""
    params = case.path_parameters
    made: dict[str, str] = {}
    if case.path == "/v1/meshes/{mesh_id}":
        made["mesh"] = params["mesh_id"] = fresh_mesh()
    elif case.path.startswith("/v1/sessions/{session_id}"):
        made["session"] = params["session_id"] = fresh_session()
        if case.path.endswith("/batch/{job_id}"):
            made["batch"] = params["job_id"] = fresh_batch(made["session"])
    return made


@schema.include(method="DELETE").parametrize()
@settings(max_examples=6, deadline=None, suppress_health_check=list(HealthCheck))
def test_delete_of_a_fresh_resource_removes_it_and_answers_as_documented(case):
    made = give_fresh_ids(case)
    try:
        response = send(client, case)
        case.validate_response(response, checks=[not_a_server_error, status_code_conformance,
                                                 response_schema_conformance])
        if case.method == "DELETE":  # schemathesis also probes other methods on the path (405)
            check_gone(case, made, response)
    finally:
        if "session" in made and case.path != "/v1/sessions/{session_id}":
            client.delete(f"/v1/sessions/{made['session']}")  # the session of a batch or study, not under test


def check_gone(case: Any, made: dict[str, str], response: Any) -> None:
    """A 204 left the resource gone; a cancelled batch reads as cancelled; a fresh mesh or session is deleted."""
    if case.path in ("/v1/meshes/{mesh_id}", "/v1/sessions/{session_id}") and response.status_code != 204:
        pytest.fail(f"DELETE {case.path} of a fresh resource answered {response.status_code}: {response.text}")
    if response.status_code == 204 and "mesh" in made:
        assert client.get(f"/v1/meshes/{made['mesh']}").status_code == 404
        assert made["mesh"] not in {m["id"] for m in client.get("/v1/meshes?limit=1000").json()}
    if response.status_code == 204 and "session" in made:
        assert client.get(f"/v1/sessions/{made['session']}").status_code in (404, 410)
        assert client.post(f"/v1/sessions/{made['session']}/deform", json={}).status_code in (404, 410)
    if "batch" in made and response.status_code == 200:
        assert response.json()["status"] == "cancelled"
        got = client.get(f"/v1/sessions/{made['session']}/batch/{made['batch']}")
        assert got.status_code == 200 and got.json()["status"] == "cancelled", got.text


def test_every_delete_route_is_exercised():
    deletes = {path for path, item in app.openapi()["paths"].items() if "delete" in item}
    covered = {"/v1/meshes/{mesh_id}", "/v1/sessions/{session_id}", "/v1/sessions/{session_id}/batch/{job_id}",
               "/v1/sessions/{session_id}/study/{job_id}", "/v1/jobs/{job_id}"}
    assert deletes == covered, deletes ^ covered  # a new DELETE route needs its fresh resource here
