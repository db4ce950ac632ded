"""Studies through the service: plan rows morphed, solved by the operator's FE solver, tabled in a zip."""

from __future__ import annotations

import csv
import io
import time
import zipfile

import pytest

from tests.conftest import DATA
from tests.solver.workflows.test_study import max_u_of

from ..conftest import err, running

DECK = DATA / "ccx_bracket.inp"
SPEC = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
        "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
SHAPES = {"shift": {"handles": {"bore": {"translation": [-1.0, 0, 0]}}}}
#: rows 1-2 move the bore 0 and 6 mm toward the clamp; row 3 moves it through the clamp (inverts)
PLAN = {"columns": ["shift"], "rows": [[0.0], [6.0], [80.0]]}


def session(tc) -> str:
    mid = tc.post("/v1/meshes", files=[("file", ("ccx_bracket.inp", DECK.read_bytes()))]).json()["id"]
    r = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": SPEC})
    assert r.status_code in (201, 202), r.text
    return r.json()["id"]


def wait(tc, sid: str, jid: str, limit_s: float = 240.0) -> dict:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        doc = tc.get(f"/v1/sessions/{sid}/study/{jid}").json()
        if doc["status"] not in ("queued", "running"):
            return doc
        time.sleep(0.2)
    raise AssertionError(f"study {jid} still running after {limit_s} s")


@pytest.mark.ccx
def test_a_study_solves_each_row_with_calculix_and_tables_it(tmp_path):
    with running(tmp_path, study_solvers={"ccx": "ccx -i {stem}"}) as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "plan": PLAN, "solver": "ccx",
                                                       "timeout_s": 120})
        assert r.status_code == 202, r.text
        assert r.headers["location"] == f"/v1/sessions/{sid}/study/{r.json()['id']}"
        doc = wait(tc, sid, r.json()["id"])
        assert doc["status"] == "done", doc
        assert doc["kind"] == "study" and doc["rows_done"] == 3
        assert doc["summary"]["rows"] == {"ok": 2, "rejected": 1}
        z = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content))
        table = list(csv.DictReader(io.StringIO(z.read("study.csv").decode())))
        assert [t["status"] for t in table] == ["ok", "ok", "rejected"]
        names = set(z.namelist())
        for t in table[:2]:
            assert t["deck"] == f"{t['row']}/ccx_bracket.inp" and t["deck"] in names
            dat = z.read(f"{t['row']}/ccx_bracket.dat").decode()
            assert float(t["max_displacement"]) == pytest.approx(max_u_of(dat), rel=1e-12)
        assert float(table[1]["max_displacement"]) > float(table[0]["max_displacement"])  # bore nearer the clamp
        assert not any(n.startswith("3/") for n in names)  # the inverting row is recorded, never solved
        # the rest row's deck differs from the upload only in node lines
        rest = DECK.read_text().splitlines()
        row1 = z.read("1/ccx_bracket.inp").decode().splitlines()
        assert len(rest) == len(row1) and rest[0] == row1[0]


def test_a_solver_the_operator_has_not_configured_is_refused_and_nothing_runs(tmp_path):
    with running(tmp_path) as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "plan": PLAN, "solver": "ccx"})
        assert r.status_code == 422 and err(r)["code"] == "solver_unavailable"
        assert err(r)["details"]["configured"] == []
    with running(tmp_path, study_solvers={"abq": "no-such-program-here -job {stem}"}) as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "plan": PLAN, "solver": "abq"})
        assert r.status_code == 422 and err(r)["code"] == "solver_unavailable"
        assert err(r)["details"]["program"] == "no-such-program-here"
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "plan": PLAN, "solver": "abq",
                                                       "command": "rm -rf /"})
        assert r.status_code == 422  # a client cannot send a command
    assert not [p for p in tmp_path.rglob("*") if p.suffix in (".inp", ".zip") and "jobs" in p.parts]


def test_a_run_without_responses_is_recorded_row_by_row(tmp_path):
    # 'true' exits 0 and writes no .dat: every solved row is response_failed, the study still finishes
    with running(tmp_path, study_solvers={"noop": "true"}) as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "plan": PLAN, "solver": "noop"})
        assert r.status_code == 202, r.text
        doc = wait(tc, sid, r.json()["id"])
        assert doc["status"] == "done" and doc["summary"]["rows"] == {"response_failed": 2, "rejected": 1}
        z = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content))
        table = list(csv.DictReader(io.StringIO(z.read("study.csv").decode())))
        assert "no ccx_bracket.dat" in table[0]["message"]
        assert tc.get(f"/v1/sessions/{sid}/study/j_nosuch").status_code == 404
        assert tc.get(f"/v1/sessions/{sid}/batch/{r.json()['id']}").status_code == 200  # a job, either path


def test_a_bad_plan_is_refused_before_the_job(tmp_path):
    with running(tmp_path, study_solvers={"noop": "true"}) as tc:
        sid = session(tc)
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "solver": "noop",
                                                       "plan": {"columns": ["nosuch"], "rows": [[1.0]]}})
        assert r.status_code == 422 and "nosuch" in err(r)["message"]
    assert not [p for p in tmp_path.rglob("*") if p.suffix in (".inp", ".zip") and "jobs" in p.parts]
