"""Schemathesis's DELETE cases on real resources, each created for its case, then checked gone.

tests/service/test_app.py never points DELETE at real ids, for the demo must survive its run.
Here every DELETE case gets a fresh resource made through the API just before it: a mesh (JSON
arrays, one tetrahedron), a session (the demo's mesh and SPEC), a batch of that session, a
tetrahedralization job (fTetWild on a 80-triangle sphere with the coarsest options), and a study
of a session on the CalculiX bracket whose ccx is in a long eigen-solve. The answer must be no
5xx, a documented status and a body matching its schema; a 204 must leave the resource gone (GET
404 or 410); a cancelled job must read as cancelled, its worker process or solver run ended, its
scratch or rows folder removed, and nothing of it stored (no mesh listed, no zip).

The study's cases run ccx (marker ``ccx``).
"""

from __future__ import annotations

import functools
import shutil
import tempfile
from pathlib import Path
from typing import Any

import meshio
import psutil
import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import response_schema_conformance, status_code_conformance

from service.app import create_app
from service.demo import DEMO_MESH, DEMO_SESSION
from solver.testing import sphere_surface

from .api.test_study import SHAPES, SPEC, long_deck, solver_runs, until
from .st_transport import send

pytestmark = pytest.mark.fuzz  # generated requests: make test, not make check
_DATA = tempfile.mkdtemp(prefix="tetmorph-delete-")
#: job_wait_s 0: POST /v1/tetrahedralize answers 202 with the running job at once.
app = create_app(data_dir=_DATA, demo=True, rate_limit_per_s=0, max_sessions=100_000, job_wait_s=0,
                 study_solvers={"ccx": "ccx -i {stem}"})
client = TestClient(app)
client.__enter__()  # the demo mesh and session exist; the one lifespan of the run
schema = schemathesis.openapi.from_dict(app.openapi())  # cases go through the client (st_transport)
DEMO_SPEC = client.get(f"/v1/sessions/{DEMO_SESSION}").json()["spec"]
#: A batch long enough to be running when it is cancelled.
BATCH = {"shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}},
         "plan": {"columns": ["bend"], "rows": [[k / 400] for k in range(400)]}, "block": 1}
#: The coarsest tetrahedralization the route accepts (about 3 s in all on this sphere).
TETRA_OPTIONS = {"edge_length_fac": "1", "epsilon": "0.1", "optimize": "false"}


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


@functools.cache
def sphere_stl() -> bytes:
    V, F = sphere_surface(1, 1.0)
    path = Path(_DATA) / "sphere.stl"
    meshio.write(path, meshio.Mesh(V, [("triangle", F)]))
    return path.read_bytes()


def mesh_ids() -> set[str]:
    return {m["id"] for m in client.get("/v1/meshes?limit=1000").json()}


def fresh_tetrahedralization() -> str:
    r = client.post("/v1/tetrahedralize", files=[("file", ("sphere.stl", sphere_stl()))], data=TETRA_OPTIONS)
    assert r.status_code == 202, r.text
    return r.json()["id"]


@functools.cache
def study_mesh() -> str:
    """The bracket deck whose ccx run is a long eigen-solve, uploaded once."""
    deck = long_deck(Path(tempfile.mkdtemp(dir=_DATA)))
    r = client.post("/v1/meshes", files=[("file", (deck.name, deck.read_bytes()))])
    assert r.status_code == 201, r.text
    return r.json()["id"]


def fresh_study_session() -> str:
    r = client.post("/v1/sessions", json={"mesh_id": study_mesh(), "spec": SPEC})
    assert r.status_code in (201, 202), r.text
    return r.json()["id"]


def fresh_study(sid: str) -> str:
    """A study of ``sid`` whose row 1 has ccx in its eigen-solve (running, past reading the deck)."""
    r = client.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "solver": "ccx", "timeout_s": 30,
                                                       "plan": {"columns": ["shift"], "rows": [[0.0], [1.0]]}})
    assert r.status_code == 202, r.text
    runs = until(solver_runs)
    until(lambda: sum(runs[0].cpu_times()[:2]) > 1.0)  # past reading the deck (0.3 s)
    return r.json()["id"]


def tetra_workers() -> list[psutil.Process]:
    """The job runner's worker processes (not multiprocessing's resource tracker)."""
    from service.state.parse_pool import reader_pids

    out, readers = [], reader_pids()  # the processes that read uploads are not the job runner's
    for p in psutil.Process().children(recursive=True):
        try:
            if p.pid in readers:
                continue
            if "spawn_main" in " ".join(p.cmdline()) and p.status() != psutil.STATUS_ZOMBIE:
                out.append(p)
        except psutil.Error:
            continue
    return out


def give_fresh_ids(case: Any) -> dict[str, Any]:
    """Point the case's path at resources made for it; answer what was made."""
    params = case.path_parameters
    made: dict[str, Any] = {}
    if case.path == "/v1/meshes/{mesh_id}":
        made["mesh"] = params["mesh_id"] = fresh_mesh()
    elif case.method != "DELETE" and (case.path == "/v1/jobs/{job_id}" or "/study/" in case.path):
        pass  # a 405 probe: no job (it takes seconds) for it
    elif case.path == "/v1/jobs/{job_id}":
        made["meshes"] = mesh_ids()
        made["tetra"] = params["job_id"] = fresh_tetrahedralization()
    elif case.path.startswith("/v1/sessions/{session_id}/study"):
        made["session"] = params["session_id"] = fresh_study_session()
        made["meshes"] = mesh_ids()
        made["study"] = params["job_id"] = fresh_study(made["session"])
    elif case.path.startswith("/v1/sessions/{session_id}"):
        made["session"] = params["session_id"] = fresh_session()
        if case.path.endswith("/batch/{job_id}"):
            made["batch"] = params["job_id"] = fresh_batch(made["session"])
    return made


def delete_case(case: Any) -> None:
    made = give_fresh_ids(case)
    try:
        response = send(client, case)
        case.validate_response(response, checks=[not_a_server_error, status_code_conformance,
                                                 response_schema_conformance])
        if case.method == "DELETE":  # schemathesis also probes other methods on the path (405)
            check_gone(case, made, response)
    finally:
        if "tetra" in made:
            client.delete(f"/v1/jobs/{made['tetra']}")  # 409 when it is over already
        if "session" in made and case.path != "/v1/sessions/{session_id}":
            client.delete(f"/v1/sessions/{made['session']}")  # the session of a batch or study, not under test


@schema.include(method="DELETE").exclude(path_regex="/study/").parametrize()
@settings(max_examples=6, deadline=None, suppress_health_check=list(HealthCheck))
def test_delete_of_a_fresh_resource_removes_it_and_answers_as_documented(case):
    delete_case(case)


@pytest.mark.ccx
@schema.include(method="DELETE", path_regex="/study/").parametrize()
@settings(max_examples=2, deadline=None, suppress_health_check=list(HealthCheck))  # about 5 s per study
def test_delete_of_a_fresh_running_study_stops_its_solver_and_answers_as_documented(case):
    delete_case(case)


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
    if "tetra" in made:
        check_tetrahedralization_gone(made["tetra"], made["meshes"], response)
    if "study" in made:
        check_study_gone(made["session"], made["study"], made["meshes"], response)


def check_tetrahedralization_gone(jid: str, before: set[str], response: Any) -> None:
    """A cancelled tetrahedralization: its worker ended, its scratch folder removed, no mesh stored."""
    got = client.get(f"/v1/jobs/{jid}").json()
    if response.status_code == 409:  # it ended first: a finished job keeps its mesh (the client deletes it)
        assert got["status"] in ("done", "failed", "cancelled"), got
        if got["status"] == "done":
            assert got["mesh"]["id"] in mesh_ids() - before
            assert client.delete(f"/v1/meshes/{got['mesh']['id']}").status_code == 204
        return
    assert response.status_code == 200 and response.json()["status"] == "cancelled", response.text
    assert got["status"] == "cancelled" and got["mesh"] is None, got
    _, alive = psutil.wait_procs(tetra_workers(), timeout=10)
    assert not alive, "the cancelled job's worker process still runs"
    until(lambda: not list(Path(tempfile.gettempdir()).glob(f"tetmorph-job-{jid}-*")), 10)
    assert mesh_ids() <= before, mesh_ids() - before


def check_study_gone(sid: str, jid: str, before: set[str], response: Any) -> None:
    """A cancelled study: its ccx run killed, no other row started, its rows folder and zip removed."""
    assert response.status_code == 200 and response.json()["status"] == "cancelled", response.text
    got = client.get(f"/v1/sessions/{sid}/study/{jid}")
    assert got.status_code == 200 and got.json()["status"] == "cancelled", got.text
    assert client.get(f"/v1/sessions/{sid}/study/{jid}/result").status_code == 409
    _, alive = psutil.wait_procs(solver_runs(), timeout=10)
    assert not alive, "ccx still runs for the cancelled study"
    until(lambda: not list(Path(_DATA).glob(f"jobs/*/{jid}*")), 10)  # rows folder and zip
    assert not solver_runs() and mesh_ids() <= before


def test_every_delete_route_is_exercised():
    deletes = {path for path, item in app.openapi()["paths"].items() if "delete" in item}
    covered = {"/v1/meshes/{mesh_id}", "/v1/sessions/{session_id}", "/v1/sessions/{session_id}/batch/{job_id}",
               "/v1/sessions/{session_id}/study/{job_id}", "/v1/jobs/{job_id}"}
    assert deletes == covered, deletes ^ covered  # a new DELETE route needs its fresh resource here


def teardown_module():
    """End the module's one lifespan (its workers and stores) and remove its data folder."""
    client.__exit__(None, None, None)
    shutil.rmtree(_DATA, ignore_errors=True)
