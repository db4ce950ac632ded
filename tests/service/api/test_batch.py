"""Batches and bounds of shape variables on a session: the plate deck, against the library."""

from __future__ import annotations

import csv
import io
import time
import zipfile

import numpy as np
import pytest

from solver import read_mesh
from solver.deform.deformer import Deformer
from solver.workflows import deck_writer, parse_shapes, read_plan, run_doe, shape_bounds, write_summary
from tests.conftest import DATA, distance_to_triangles
from tests.solver.workflows.conftest import PLAN, plate_shapes, plate_spec

from ..conftest import err, running

PLATE = DATA / "plate.inp"


def plan_rows() -> dict:
    p = read_plan(PLAN)
    return {"columns": list(p.columns), "rows": p.values.tolist()}


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    """The single-process DOE of the plate plan (block 3): decks and summary."""
    out = tmp_path_factory.mktemp("doe")
    mesh = read_mesh(PLATE)
    d = Deformer(mesh, plate_spec())
    plan = read_plan(PLAN)
    r = run_doe(d, parse_shapes(plate_shapes(), d), plan, block=3,
                output=deck_writer(mesh, str(out / "plate_{i}.inp")))
    write_summary(r, out / "summary.csv")
    return d, r, out


def session(tc, spec=None) -> str:
    mid = tc.post("/v1/meshes", files=[("file", ("plate.inp", PLATE.read_bytes()))]).json()["id"]
    r = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": spec or plate_spec()})
    assert r.status_code in (201, 202), r.text
    return r.json()["id"]


def wait(tc, sid: str, jid: str, limit_s: float = 120.0) -> dict:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        doc = tc.get(f"/v1/sessions/{sid}/batch/{jid}").json()
        if doc["status"] not in ("queued", "running"):
            return doc
        time.sleep(0.1)
    raise AssertionError(f"batch {jid} still running after {limit_s} s")


def summary_without_files(text: str) -> list[dict]:
    return [{k: v for k, v in row.items() if k != "file"} for row in csv.DictReader(io.StringIO(text))]


def test_batch_decks_and_summary_are_the_single_process_doe(tmp_path, library):
    _, ref, out = library
    with running(tmp_path / "data") as tc:
        sid = session(tc)
        shapes = plate_shapes()["shapes"]
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": plan_rows(), "block": 3})
        assert r.status_code == 202, r.text
        job = r.json()
        assert job["kind"] == "batch" and job["rows_total"] == 8
        assert r.headers["location"] == f"/v1/sessions/{sid}/batch/{job['id']}"
        doc = wait(tc, sid, job["id"])
        assert doc["status"] == "done" and doc["rows_done"] == 8 and doc["progress"] == 1.0, doc
        assert doc["summary"]["ok"] == 8 and doc["result"].endswith("/result")
        z = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content))
        assert sorted(z.namelist()) == sorted([f"plate_{i}.inp" for i in range(1, 9)] + ["summary.csv"])
        for i in range(1, 9):  # bit for bit the deck tetmorph doe writes
            assert z.read(f"plate_{i}.inp") == (out / f"plate_{i}.inp").read_bytes(), i
        got = z.read("summary.csv").decode()
        assert summary_without_files(got) == summary_without_files((out / "summary.csv").read_text())
        assert [row["file"] for row in csv.DictReader(io.StringIO(got))] == [f"plate_{i}.inp" for i in range(1, 9)]
        # the same plan as CSV text, decks as VTU
        text = PLAN.read_text()
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": text, "format": "vtu"})
        doc = wait(tc, sid, r.json()["id"])
        names = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content)).namelist()
        assert "plate_8.vtu" in names and len(names) == 9
        # a MOVE in between batches still works, and the session document is unchanged by batches
        mv = tc.post(f"/v1/sessions/{sid}/deform?result=report", json={"handles": {"end": {"translation": [0, 0, 1]}}})
        assert mv.status_code == 200


def test_bad_plans_name_the_row_and_column_and_store_nothing(tmp_path):
    with running(tmp_path / "data", batch_max_rows=20) as tc:
        sid = session(tc)
        shapes = plate_shapes()["shapes"]
        bad = "bend,hole1_x\n0,0\n1,x\n"
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": bad}))
        assert e["status"] == 422 and e["code"] == "invalid_plan" and "row 2 (line 3)" in e["message"]
        assert e["details"]["column"] == "hole1_x"
        # a bare carriage return inside a field: CSV the reader cannot split, a 422 naming the line (was a 500)
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": "bend,hole1_x\n0\r1,0\n"}))
        assert e["status"] == 422 and e["code"] == "invalid_plan" and "line 2" in e["message"]
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": {"columns": ["bend"],
                                                                                       "rows": [[0], [1, 2]]}}))
        assert e["code"] == "invalid_plan" and "row 2" in e["message"]
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": {"columns": ["twist"],
                                                                                       "rows": [[1]]}}))
        assert e["code"] == "unknown_shape" and e["details"]["columns"] == ["twist"]
        rows = {"columns": ["bend"], "rows": [[0.1]] * 21}
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": rows}))
        assert e["code"] == "too_many_rows" and e["details"] == {"field": "plan", "rows": 21, "limit": 20}
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": plan_rows(), "engine": "ray"}))
        assert e["code"] == "engine_unavailable" and e["details"]["field"] == "engine"
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": plan_rows(), "format": "xyz"}))
        assert e["code"] == "unknown_format"
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": {"s": {"handles": {"nope": {}}}},
                                                           "plan": {"columns": ["s"], "rows": [[1]]}}))
        assert e["status"] == 422 and "nope" in e["message"]
        e = err(tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": "bend\n"}))
        assert e["code"] == "empty_plan"
        assert tc.app.state.jobs.jobs == {}  # nothing was started
        assert not list((tmp_path / "data" / "jobs").rglob("*.zip"))


def test_result_cap_and_cancel_leave_nothing(tmp_path):
    with running(tmp_path / "data", batch_max_result_mb=0.05) as tc:
        sid = session(tc)
        shapes = plate_shapes()["shapes"]
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": plan_rows()})
        doc = wait(tc, sid, r.json()["id"])
        assert doc["status"] == "failed" and doc["error"]["code"] == "result_too_large", doc
        e = err(tc.get(f"/v1/sessions/{sid}/batch/{doc['id']}/result"))
        assert e["status"] == 409 and e["code"] == "job_not_finished"
        many = {"columns": ["bend"], "rows": [[k / 400] for k in range(400)]}
    with running(tmp_path / "data2") as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes, "plan": many, "block": 1})
        jid = r.json()["id"]
        c = tc.delete(f"/v1/sessions/{sid}/batch/{jid}")
        assert c.status_code == 200 and c.json()["status"] == "cancelled"
        assert err(tc.delete(f"/v1/sessions/{sid}/batch/{jid}"))["code"] == "job_finished"
        left = [1]
        deadline = time.monotonic() + 20  # the block in flight ends, then nothing of the batch stays
        while left and time.monotonic() < deadline:
            time.sleep(0.1)
            left = [p for p in (tmp_path / "data2" / "jobs").rglob("*") if p.is_file()]
        assert not left
        assert err(tc.get(f"/v1/sessions/{sid}/batch/j_0000/result"))["code"] == "job_not_found"


def test_deleting_a_session_stops_its_batch_and_leaves_no_file(tmp_path):
    with running(tmp_path / "data") as tc:
        sid = session(tc)
        many = {"columns": ["bend"], "rows": [[k / 2000] for k in range(2000)]}
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": plate_shapes()["shapes"], "plan": many,
                                                      "block": 1})
        jid = r.json()["id"]
        deadline = time.monotonic() + 30
        while tc.get(f"/v1/sessions/{sid}/batch/{jid}").json()["rows_done"] == 0 and time.monotonic() < deadline:
            time.sleep(0.05)  # the batch is writing decks
        jobs = tc.app.state.jobs
        job = jobs.jobs[jid]
        assert tc.delete(f"/v1/sessions/{sid}").status_code == 204
        assert job.status == "cancelled" and job.error["code"] == "session_deleted"
        assert jid not in jobs.jobs  # owned by the session: gone with it
        left, deadline = [1], time.monotonic() + 60
        while left and time.monotonic() < deadline:  # the block in flight ends, then its zip is discarded
            time.sleep(0.1)
            left = [p for p in (tmp_path / "data" / "jobs").rglob("*") if p.is_file()]
        assert not left and job.done < 2000


def test_job_files_of_dead_processes_are_swept_by_age_whatever_replica_wrote_them(tmp_path):
    import os

    jobs = tmp_path / "data" / "jobs"
    old_zip = jobs / "host-1234" / "j_old.zip"  # a replica id of a process long gone (hostname-pid)
    old_dir = jobs / "host-99" / "j_old2-decks"
    fresh = jobs / "host-5678" / "j_new.zip"  # another live replica's batch, being written
    for f in (old_zip, old_dir / "plate_1.inp", fresh):
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_bytes(b"x")
    long_ago = time.time() - 3 * 3600
    for f in (old_zip, old_dir / "plate_1.inp", old_dir):
        os.utime(f, (long_ago, long_ago))
    with running(tmp_path / "data") as tc:
        assert not old_zip.exists() and not old_dir.exists() and not old_zip.parent.exists()
        assert fresh.exists()  # a file a live job may own stays
        later = time.time() + 3 * 3600  # the periodic sweep: once untouched long enough, it goes too
        tc.app.state.sweeper.sweep(later)
        assert not fresh.exists()


def test_a_single_server_removes_at_start_the_job_folders_of_its_dead_processes(tmp_path):
    """A killed server's folder (``jobs/<host>-<pid>``) goes at the next start, not an hour later; a folder
    whose PID is alive stays, unless that process started after the folder was last written (a reused PID)."""
    import os
    import socket
    import subprocess
    import sys

    host = "".join(c if c.isalnum() or c in "._-" else "_" for c in socket.gethostname())
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    sleepers = [subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"]) for _ in range(2)]
    try:
        jobs = tmp_path / "data" / "jobs"
        dead = jobs / f"{host}-{gone.pid}" / "j_0001.zip"  # written a moment ago: the age sweep keeps it
        live = jobs / f"{host}-{sleepers[0].pid}" / "j_0001.zip"
        reused = jobs / f"{host}-{sleepers[1].pid}" / "j_0002-decks" / "plate_1.inp"
        elsewhere = jobs / f"otherhost-{gone.pid}" / "j_0003.zip"  # another machine's PID: not ours to judge
        for f in (dead, live, reused, elsewhere):
            f.parent.mkdir(parents=True, exist_ok=True)
            f.write_bytes(b"x")
        before_start = time.time() - 600  # within the jobs' keep time: the age sweep keeps it
        for f in (reused, reused.parent, reused.parent.parent):
            os.utime(f, (before_start, before_start))
        with running(tmp_path / "data"):
            assert not dead.parent.exists()
            assert live.exists() and elsewhere.exists()
            assert not reused.parent.parent.exists()
    finally:
        for p in sleepers:
            p.kill()
            p.wait()


def test_bounds_are_the_library_bounds(tmp_path, library):
    d, _, _ = library
    shapes = plate_shapes()["shapes"]
    want = shape_bounds(d, parse_shapes(plate_shapes(), d), lo=-4.0, hi=4.0, tol=0.01).to_dict()
    with running(tmp_path / "data") as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/bounds", json={"shapes": shapes, "range": [-4.0, 4.0], "tol": 0.01})
        assert r.status_code == 200, r.text
        got = r.json()
        assert got["bounds"] == want["bounds"] and got["range"] == [-4.0, 4.0]
        e = err(tc.post(f"/v1/sessions/{sid}/bounds", json={"shapes": shapes, "range": [1.0, 4.0]}))
        assert e["code"] == "invalid_range"
    with running(tmp_path / "data", bounds_time_limit_s=1e-9) as tc:
        sid = tc.get("/v1/sessions").json()[0]["id"]
        e = err(tc.post(f"/v1/sessions/{sid}/bounds", json={"shapes": shapes}))
        assert e["status"] == 422 and e["code"] == "bounds_time_limit" and e["details"]["finished"] == []


def top_surface_stl(mesh, path, bump: float) -> np.ndarray:
    """The plate's top face with a bump, as ASCII STL; returns its vertices and triangles."""
    on = np.zeros(mesh.n, bool)
    on[mesh.sets["TOP"]] = True
    F = mesh.F[on[mesh.F].all(axis=1)]
    V = mesh.V.copy()
    x, y = V[:, 0], V[:, 1]
    V[:, 2] += bump * np.exp(-((x - 80) ** 2 + (y - 40) ** 2) / 30.0**2)
    lines = ["solid top"]
    for tri in F:
        a, b, c = V[tri]
        nrm = np.cross(b - a, c - a)
        nrm /= np.linalg.norm(nrm)
        lines += [f"facet normal {nrm[0]:.17g} {nrm[1]:.17g} {nrm[2]:.17g}", "outer loop",
                  *[f"vertex {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}" for p in (a, b, c)], "endloop", "endfacet"]
    path.write_text("\n".join([*lines, "endsolid top"]) + "\n")
    return V[F]


def test_a_stored_target_surface_is_resolved_and_the_nodes_land_on_it(tmp_path):
    mesh = read_mesh(PLATE)
    stl = tmp_path / "top_bumped.stl"
    tris = top_surface_stl(mesh, stl, bump=3.0)
    nodes = np.setdiff1d(mesh.sets["TOP"], mesh.sets["FIXED"])
    with running(tmp_path / "data") as tc:
        plate = tc.post("/v1/meshes", files=[("file", ("plate.inp", PLATE.read_bytes()))]).json()["id"]
        surf = tc.post("/v1/meshes", files=[("file", ("top_bumped.stl", stl.read_bytes()))])
        assert surf.status_code == 201, surf.text
        sid_spec = {"selections": {"top": {"ids": nodes.tolist()}, "fix": {"set": "FIXED"}},
                    "fixed": ["fix"], "handles": {},
                    "targets": [{"name": "skin", "selection": "top", "surface": {"mesh_id": surf.json()["id"]}}]}
        r = tc.post("/v1/sessions", json={"mesh_id": plate, "spec": sid_spec})
        assert r.status_code in (201, 202), r.text
        sid = r.json()["id"]
        assert r.json()["spec"]["targets"][0]["surface"] == {"mesh_id": surf.json()["id"]}  # stored as given
        r = tc.post(f"/v1/sessions/{sid}/deform", json={"targets": {"skin": {"amount": 1}}})
        assert r.status_code == 200, r.text
        V = np.asarray(r.json()["positions"])
        diag = float(np.linalg.norm(mesh.V.max(0) - mesh.V.min(0)))
        far = max(distance_to_triangles(V[i], tris[:, 0], tris[:, 1], tris[:, 2]) for i in nodes[::5])
        assert far <= 1e-6 * diag
        assert V[nodes, 2].max() > 4.0 + 2.5  # the bump's top is reached
        assert r.json()["report"]["inverted_elements"] == 0
        e = err(tc.delete(f"/v1/meshes/{surf.json()['id']}"))
        assert e["code"] == "mesh_in_use" and e["details"]["sessions"] == [sid]
        # a surface that is no stored mesh, a volume mesh as a target, a raw path: typed 422s
        for surface, code in (({"mesh_id": "m_0000000000000000"}, "surface_not_found"),
                              ({"mesh_id": plate}, "not_a_surface"), ("/etc/passwd", "invalid_spec")):
            spec = {**sid_spec, "targets": [{"name": "skin", "selection": "top", "surface": surface}]}
            e = err(tc.post("/v1/sessions", json={"mesh_id": plate, "spec": spec}))
            assert e["status"] == 422 and e["code"] == code, e
        assert [s["id"] for s in tc.get("/v1/sessions").json()] == [sid]
    with running(tmp_path / "data") as tc:  # after a restart the session rebuilds from its stored SPEC
        r = tc.get(f"/v1/sessions/{sid}/positions")
        assert np.allclose(np.asarray(r.json()["positions"]), V, atol=1e-9 * diag)
