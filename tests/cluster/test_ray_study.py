"""``study --engine ray`` on a local Ray: the single-process files and table; a lost worker's run retried."""

from __future__ import annotations

import csv
import json

import pytest

from solver.workflows.ray_engine import connect
from tests.conftest import DATA

pytestmark = pytest.mark.ccx

DECK = DATA / "ccx_bracket.inp"
SPEC = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
        "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
SHAPES = {"shapes": {"shift": {"handles": {"bore": {"translation": [-1.0, 0, 0]}}}}}
#: Kills the Ray worker that runs it (its parent) the first time; runs CalculiX after that.
KILL_ONCE = """#!/bin/sh
mark="$1"; shift
if [ ! -e "$mark" ]; then echo attempt >> "$mark.log"; touch "$mark"; kill -9 $PPID; sleep 30; exit 1; fi
echo attempt >> "$mark.log"
exec ccx -i "$1"
"""
KILL_ALWAYS = """#!/bin/sh
echo attempt >> "$1.log"; kill -9 $PPID; sleep 30; exit 1
"""


@pytest.fixture(scope="module")
def ray_local():
    ray, started = connect(None, num_cpus=2)
    assert started, "a Ray was already connected in this process"
    yield ray
    ray.shutdown()


@pytest.fixture()
def files(tmp_path):
    (tmp_path / "spec.json").write_text(json.dumps(SPEC))
    (tmp_path / "shapes.json").write_text(json.dumps(SHAPES))
    (tmp_path / "plan.csv").write_text("shift\n0\n5\n80\n")  # row 3 inverts: recorded, not solved
    return tmp_path


def _study(f, out, solver, *extra):
    from service.cli import main

    return main(["study", str(DECK), "--spec", str(f / "spec.json"), "--shapes", str(f / "shapes.json"),
                 "--plan", str(f / "plan.csv"), "--output", str(out / "{i}" / "deck.inp"),
                 "--table", str(out / "study.csv"), "--solver", solver, "--timeout", "120", *extra])


def _table(path):
    """The table without what differs between runs: solver wall time and the folder of the decks."""
    rows = list(csv.DictReader(open(path)))
    for r in rows:
        r.pop("solver_s")
        r["deck"] = r["deck"].rsplit("/", 2)[-2:] if r["deck"] else ""
    return rows


def test_a_study_on_ray_writes_the_single_process_files_and_table(files, ray_local):
    f = files
    assert _study(f, f / "local", "ccx -i {stem}") == 1  # row 3 rejected
    assert _study(f, f / "ray", "ccx -i {stem}", "--engine", "ray", "--actors", "2") == 1
    assert _table(f / "ray" / "study.csv") == _table(f / "local" / "study.csv")
    assert [r["status"] for r in _table(f / "ray" / "study.csv")] == ["ok", "ok", "rejected"]
    for row in ("1", "2"):
        for name in ("deck.inp", "deck.dat"):
            assert (f / "ray" / row / name).read_bytes() == (f / "local" / row / name).read_bytes(), (row, name)
    assert not (f / "ray" / "3").exists()


def test_a_solver_run_whose_worker_dies_is_run_again(files, ray_local, tmp_path):
    f = files
    script = tmp_path / "kill_once.sh"
    script.write_text(KILL_ONCE)
    mark = tmp_path / "killed"
    assert _study(f, f / "local", "ccx -i {stem}") == 1
    assert _study(f, f / "ray", f"sh {script} {mark} {{stem}}", "--engine", "ray", "--actors", "1") == 1
    assert mark.exists()  # one worker was killed
    assert len((tmp_path / "killed.log").read_text().splitlines()) == 3  # 2 rows + 1 retried attempt
    assert _table(f / "ray" / "study.csv") == _table(f / "local" / "study.csv")
    for row in ("1", "2"):
        assert (f / "ray" / row / "deck.dat").read_bytes() == (f / "local" / row / "deck.dat").read_bytes()


def test_a_run_lost_on_every_attempt_is_recorded_not_fatal(files, ray_local, tmp_path):
    f = files
    script = tmp_path / "kill_always.sh"
    script.write_text(KILL_ALWAYS)
    mark = tmp_path / "always"
    assert _study(f, f / "ray", f"sh {script} {mark} {{stem}}", "--engine", "ray", "--actors", "1") == 1
    table = list(csv.DictReader(open(f / "ray" / "study.csv")))
    assert [r["status"] for r in table] == ["solver_lost", "solver_lost", "rejected"]
    assert len((tmp_path / "always.log").read_text().splitlines()) == 2 * 3  # every attempt, both rows
