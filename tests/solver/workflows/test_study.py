"""``tetmorph study``: plan rows morphed, solved by CalculiX, responses tabled; failures recorded, not fatal."""

from __future__ import annotations

import csv
import json
import re
import shutil

import numpy as np
import pytest

from solver.cli import main
from tests.conftest import DATA

DECK = DATA / "ccx_bracket.inp"


@pytest.fixture()
def study_files(tmp_path):
    spec = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
            "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
    shapes = {"shapes": {"shift": {"handles": {"bore": {"translation": [-1.0, 0, 0]}}}}}
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    (tmp_path / "shapes.json").write_text(json.dumps(shapes))
    # rows 1-3 move the hole 0, 4 and 8 mm toward the clamp; row 4 moves it through the clamp (inverts)
    (tmp_path / "plan.csv").write_text("shift\n0\n4\n8\n80\n")
    return tmp_path


def _max_u(dat):
    """Largest |u| of the .dat's displacement block, parsed here."""
    return max_u_of(dat.read_text())


def max_u_of(dat_text: str) -> float:
    """Largest |u| of the displacement block of a CalculiX .dat file's text."""
    lines = dat_text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.strip().startswith("displacements"))
    rows = []
    for ln in lines[k + 1:]:
        if not ln.strip():
            if rows:
                break
            continue
        rows.append([float(v) for v in ln.split()])
    return float(np.linalg.norm(np.array(rows)[:, 1:4], axis=1).max())


def _study(f, *extra):
    return main(["study", str(DECK), "--spec", str(f / "spec.json"), "--shapes", str(f / "shapes.json"),
                 "--plan", str(f / "plan.csv"), "--output", str(f / "out" / "{i}" / "deck.inp"),
                 "--table", str(f / "study.csv"), *extra])


@pytest.mark.ccx
def test_each_row_is_solved_and_its_responses_tabled(study_files, capsys):
    f = study_files
    assert _study(f, "--solver", "ccx -i {stem}", "--response", "ccx", "--timeout", "120") == 1  # row 4 not ok
    assert capsys.readouterr().out == ""  # stdout carries no chatter
    table = list(csv.DictReader(open(f / "study.csv")))
    assert [r["row"] for r in table] == ["1", "2", "3", "4"]
    assert [r["status"] for r in table] == ["ok", "ok", "ok", "rejected"]
    assert table[3]["solver_s"] == "" and int(table[3]["inverted"]) > 0  # recorded, never solved
    assert not (f / "out" / "4" / "deck.dat").exists()
    for r in table[:3]:
        dat = f / "out" / r["row"] / "deck.dat"
        assert float(r["max_displacement"]) == pytest.approx(_max_u(dat), rel=1e-12)
        assert float(r["solver_s"]) > 0 and r["inverted"] == "0"
    tip = [float(r["max_displacement"]) for r in table[:3]]
    assert tip[0] < tip[1] < tip[2]  # the hole nearer the clamp: a more flexible bar
    assert float(table[0]["max_mises"]) > 0 and float(table[0]["mass"]) > 0
    # row 1 is the rest shape: within round-off of the input deck, which differs only in node lines
    rest = DECK.read_text().splitlines()
    row1 = (f / "out" / "1" / "deck.inp").read_text().splitlines()
    assert len(rest) == len(row1)
    changed = [a for a, b in zip(rest, row1, strict=True) if a != b]
    assert all(re.match(r"^\d+, ", a) and a.count(",") == 3 for a in changed)


def test_a_failing_solver_a_timeout_and_a_raising_reader_are_recorded(study_files, tmp_path):
    f = study_files
    (f / "plan.csv").write_text("shift\n0\n4\n")
    assert _study(f, "--solver", "false") == 1
    assert {r["status"] for r in csv.DictReader(open(f / "study.csv"))} == {"solver_failed"}
    sleeper = shutil.which("sleep")
    assert sleeper
    assert _study(f, "--solver", "sleep 30", "--timeout", "0.5") == 1
    table = list(csv.DictReader(open(f / "study.csv")))
    assert {r["status"] for r in table} == {"timeout"} and all(float(r["solver_s"]) < 10 for r in table)
    bad = tmp_path / "resp.py"
    bad.write_text("def response(deck):\n    raise RuntimeError('no such result')\n")
    assert _study(f, "--solver", "true", "--response", str(bad)) == 1
    table = list(csv.DictReader(open(f / "study.csv")))
    assert {r["status"] for r in table} == {"response_failed"}
    assert all("no such result" in r["message"] for r in table)
    good = tmp_path / "good.py"
    good.write_text("def response(deck):\n    return {'lines': float(len(deck.read_text().splitlines()))}\n")
    assert _study(f, "--solver", "true", "--response", str(good)) == 0
    table = list(csv.DictReader(open(f / "study.csv")))
    assert [float(r["lines"]) for r in table] == [float(len(DECK.read_text().splitlines()))] * 2


def test_a_solver_that_is_not_installed_is_a_typed_error_before_anything_runs(study_files, capsys):
    f = study_files
    assert _study(f, "--solver", "no-such-fe-solver -i {stem}") == 1
    err = capsys.readouterr().err
    assert re.search(r"error \[solver_not_found\].*no-such-fe-solver", err)
    assert not (f / "out").exists() and not (f / "study.csv").exists()
    assert _study(f, "--solver", "ccx -i {stem}", "--response", str(f / "missing.py")) == 1
    assert "invalid_response" in capsys.readouterr().err


@pytest.mark.ccx
def test_the_ccx_reader_takes_what_the_dat_file_lacks_from_the_frd_file(tmp_path):
    """A deck that writes results to the .frd only (*NODE FILE, *EL FILE) still has responses: the largest
    displacement, within the .frd's 6 digits of the .dat's of the same run, and the nodal von Mises."""
    import subprocess

    from solver.workflows.study import ccx_responses

    lines = DECK.read_text().splitlines()
    both, frd_only = tmp_path / "both", tmp_path / "frd"
    both.mkdir()
    frd_only.mkdir()
    (both / "deck.inp").write_text("\n".join(lines) + "\n")
    keep, skip = [], False
    for ln in lines:  # drop the *NODE PRINT and *EL PRINT cards and their data lines
        if ln.startswith("*"):
            skip = ln.upper().startswith(("*NODE PRINT", "*EL PRINT"))
        if not skip:
            keep.append(ln)
    (frd_only / "deck.inp").write_text("\n".join(keep) + "\n")
    for d in (both, frd_only):
        subprocess.run(["ccx", "-i", "deck"], cwd=d, capture_output=True, check=True, timeout=120)
    full, frd = ccx_responses(both / "deck.inp"), ccx_responses(frd_only / "deck.inp")
    assert "mass" not in frd and "max_mises" not in frd  # nothing printed to the .dat
    assert frd["max_displacement"] == pytest.approx(full["max_displacement"], rel=1e-5)
    assert frd["max_displacement"] == pytest.approx(_max_u(both / "deck.dat"), rel=1e-5)
    assert 0.5 * full["max_mises"] < frd["max_mises_nodal"] < 1.5 * full["max_mises"]  # nodal vs Gauss points
