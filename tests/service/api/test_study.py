"""Studies through the service: plan rows morphed, solved by the operator's FE solver, tabled in a zip."""

from __future__ import annotations

import csv
import io
import time
import zipfile
from pathlib import Path

import psutil
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


def session(tc, deck: Path = DECK) -> str:
    mid = tc.post("/v1/meshes", files=[("file", ("ccx_bracket.inp", deck.read_bytes()))]).json()["id"]
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


def long_deck(tmp_path) -> Path:
    """The bracket deck with a first step of 1,500 eigenmodes: ccx runs for minutes and writes no file meanwhile.

    (ccx ends by itself when a file it reopens between increments is gone; in one long
    eigen-solve it opens none, as a large model's factorization.)
    """
    text = DECK.read_text()
    at = text.index("*STEP")
    long = "*STEP\n*FREQUENCY\n1500\n*BOUNDARY\nFIXED, 1, 3\n*END STEP\n"
    path = tmp_path / "ccx_bracket.inp"
    path.write_text(text[:at] + long + text[at:])
    return path


def solver_runs() -> list[psutil.Process]:
    """The ccx processes this test process started."""
    out = []
    for p in psutil.Process().children(recursive=True):
        try:
            if p.name() == "ccx":
                out.append(p)
        except psutil.Error:
            continue
    return out


def until(what, limit_s: float = 60.0):
    """Poll ``what()`` until it answers something true; fail after ``limit_s``."""
    deadline = time.monotonic() + limit_s
    while not (got := what()):
        assert time.monotonic() < deadline, f"{what.__name__} still false after {limit_s} s"
        time.sleep(0.05)
    return got


@pytest.mark.ccx
@pytest.mark.parametrize("delete", ["study", "session"])
def test_deleting_a_study_or_its_session_kills_the_running_solver_and_keeps_nothing(tmp_path, delete):
    data = tmp_path / "d"
    with running(data, study_solvers={"ccx": "ccx -i {stem}"}) as tc:
        sid = session(tc, long_deck(tmp_path))
        plan = {"columns": ["shift"], "rows": [[0.0], [1.0]]}
        r = tc.post(f"/v1/sessions/{sid}/study", json={"shapes": SHAPES, "plan": plan, "solver": "ccx",
                                                       "timeout_s": 30})
        assert r.status_code == 202, r.text
        jid = r.json()["id"]
        runs = until(solver_runs)  # row 1's ccx, in the job's rows folder
        rows = next(data.glob(f"jobs/*/{jid}-rows"))
        assert Path(runs[0].cwd()).is_relative_to(rows)
        until(lambda: sum(runs[0].cpu_times()[:2]) > 1.5)  # past reading the deck (0.3 s): in the eigen-solve
        if delete == "study":
            c = tc.delete(f"/v1/sessions/{sid}/study/{jid}")
            assert c.status_code == 200 and c.json()["status"] == "cancelled", c.text
            assert tc.get(f"/v1/sessions/{sid}/study/{jid}").json()["status"] == "cancelled"
            assert err(tc.get(f"/v1/sessions/{sid}/study/{jid}/result"))["code"] == "job_not_finished"
        else:
            assert tc.delete(f"/v1/sessions/{sid}").status_code == 204
            assert tc.get(f"/v1/sessions/{sid}/study/{jid}").status_code in (404, 410)
        _, alive = psutil.wait_procs(runs, timeout=10)
        assert not alive, f"ccx still runs {len(alive)} process(es) of the deleted study"
        until(lambda: not rows.exists(), 10)  # the rows' decks and solver files are removed
        assert not solver_runs()  # row 2 never started
        assert not list(data.glob(f"jobs/*/{jid}*"))  # no zip either
