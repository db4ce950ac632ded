"""``SolveOptions``: the speed layer passed in, the plain reference path selectable, and the same answers."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import tetmorph_core

from solver import SolveOptions, SpecError, parse_spec, precompute, read_mesh
from solver.deform.positions import MIXED_TOL
from solver.options import current, using
from tests.conftest import DATA, load
from tests.solver.deform.test_precision import bend_move, bend_spec

ROOT = Path(__file__).resolve().parents[2]


def test_the_environment_is_read_into_options_once():
    assert SolveOptions.from_environment({}) == SolveOptions()
    env = {"TETMORPH_SOLVER": " PARDISO ", "TETMORPH_SUPERNODAL": "0", "TETMORPH_COLUMN_BASIS": "0"}
    assert SolveOptions.from_environment(env) == SolveOptions("pardiso", sweeps=False, basis=False)
    code = ("import os, solver.options as o; os.environ['TETMORPH_SUPERNODAL'] = '0'; "
            "print(o.current().sweeps, o.SolveOptions.from_environment().sweeps)")
    clean = {k: v for k, v in os.environ.items() if not k.startswith("TETMORPH_")}
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True,
                         env=clean)
    assert out.stdout.split() == ["True", "True"]  # set after start-up: read by nothing
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True,
                         env={**clean, "TETMORPH_SUPERNODAL": "0"})
    assert out.stdout.split() == ["False", "False"]  # set before: the options in effect


@pytest.mark.parametrize("doc, field", [({"backend": "mumps"}, "solve_options.backend"),
                                        ({"sweeps": "no"}, "solve_options.sweeps"),
                                        ({"speed": 1}, "solve_options"), ([1], "solve_options")])
def test_bad_option_documents_name_the_field(doc, field):
    with pytest.raises(SpecError) as e:
        SolveOptions.parse(doc)
    assert e.value.code == "invalid_options" and e.value.details["field"] == field


def test_options_are_scoped_to_their_block_and_thread():
    ref = SolveOptions.reference()
    seen = {}

    def other():
        seen["thread"] = current()

    with using(ref):
        assert current() == ref
        t = threading.Thread(target=other)
        t.start()
        t.join()
    assert seen["thread"] != ref and current() != ref


@pytest.mark.parametrize("precision, tol", [("exact", 1e-9), ("mixed", 10 * MIXED_TOL)])
def test_the_fast_path_agrees_with_the_reference_path(precision, tol):
    """cube_big_tetra (25k interior unknowns): sweeps, multifrontal LU and column basis against the
    backends' own solves, for single moves and a stacked block."""
    mesh = load("tet/cube_big_tetra.mesh")
    spec = {**bend_spec(mesh), "precision": precision}
    fast = precompute(mesh, spec)
    ref = precompute(mesh, spec, options=SolveOptions.reference())
    assert fast.data.positions.lu_backend == "supernodal"
    assert ref.data.positions.lu_backend == "pardiso"
    moves = [bend_move(mesh, angle=a, frac=f) for a, f in [(15, 0.02), (-8, 0.01), (4, -0.02)]]
    for a, b in zip(fast.solve_many(moves), ref.solve_many(moves), strict=True):
        disp = np.abs(b.V - mesh.V).max()
        assert disp > 0
        assert np.abs(a.V - b.V).max() <= tol * disp
        assert a.report["inverted_elements"] == b.report["inverted_elements"]


def test_concurrent_set_ups_keep_their_own_options():
    mesh = read_mesh(DATA / "bracket.inp")
    spec = {"selections": {"a": {"set": "FIXED"}, "b": {"set": "LOAD"}}, "fixed": ["a"], "handles": {"b": "b"}}
    out: dict[str, object] = {}

    def build(name, options):
        out[name] = precompute(mesh, spec, options=options).data.positions.options

    ts = [threading.Thread(target=build, args=(k, o)) for k, o in
          (("ref", SolveOptions.reference()), ("fast", SolveOptions()))]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert out == {"ref": SolveOptions.reference(), "fast": SolveOptions()}


def test_the_command_line_selects_the_reference_path(tmp_path):
    from solver.cli import main

    spec = tmp_path / "spec.json"
    spec.write_text('{"selections": {"a": {"set": "FIXED"}, "b": {"set": "LOAD"}}, "fixed": ["a"], '
                    '"handles": {"b": "b"}}')
    move = tmp_path / "move.json"
    move.write_text('{"handles": {"b": {"translation": [0, 0, 3]}}}')
    outs = []
    for extra in ([], ["--reference"], ["--backend", "scipy"]):
        out = tmp_path / f"out{len(outs)}.vtu"
        assert main(["morph", str(DATA / "bracket.inp"), "--spec", str(spec), "--move", str(move),
                     "--output", str(out), *extra]) == 0
        outs.append(read_mesh(out).V)
    assert np.abs(outs[0] - outs[1]).max() <= 1e-9 * 100 and np.abs(outs[0] - outs[2]).max() <= 1e-6 * 100


def test_a_specs_solve_options_replace_what_they_name():
    mesh = load("tet/cube_big_tetra.mesh")
    moves = [bend_move(mesh, angle=12, frac=0.01)]
    fast = precompute(mesh, bend_spec(mesh))
    plain = precompute(mesh, {**bend_spec(mesh), "solve_options": {"sweeps": False, "basis": False,
                                                                   "precision": "exact"}})
    assert plain.data.options == replace(SolveOptions(), sweeps=False, basis=False, precision="exact")
    assert fast.data.positions.lu_backend == "supernodal" and plain.data.positions.lu_backend != "supernodal"
    assert plain.solve(moves[0]).report["interior_precision"] == "double"
    assert fast.solve(moves[0]).report["interior_precision"] == "single"
    # the caller's options hold where the SPEC says nothing, and the SPEC's win where it does
    ref = precompute(mesh, {**bend_spec(mesh), "precision": "exact"}, options=SolveOptions.reference())
    assert ref.data.options == SolveOptions.reference(precision="exact")
    a, b = plain.solve(moves[0]).V, ref.solve(moves[0]).V
    assert np.abs(a - b).max() <= 1e-9 * np.abs(b - mesh.V).max()


def test_precision_and_solve_options_precision_must_agree():
    base = {"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}}, "fixed": ["a"], "handles": {"h": "b"}}
    assert parse_spec({**base, "precision": "exact", "solve_options": {"precision": "exact"}}).solve_options == \
        {"precision": "exact"}
    assert parse_spec({**base, "precision": "exact"}).solve_options == {"precision": "exact"}
    assert parse_spec(base).solve_options == {}
    with pytest.raises(SpecError) as e:
        parse_spec({**base, "precision": "exact", "solve_options": {"precision": "mixed"}})
    assert "disagree" in str(e.value) and e.value.details["field"] == "SPEC.solve_options.precision"
    with pytest.raises(SpecError) as e:
        parse_spec({**base, "solve_options": {"threads": -1}})
    assert e.value.details["field"] == "SPEC.solve_options.threads"


@pytest.mark.parametrize("caller, spec, want", [(0, None, 0), (0, 1, 1), (4, 1, 1), (1, 4, 1), (3, 0, 3)])
def test_threads_are_the_smaller_cap(caller, spec, want):
    doc = None if spec is None else {"threads": spec}
    assert SolveOptions(threads=caller).overlay(doc).threads == want


def test_a_solve_keeps_to_its_precomputes_thread_cap(monkeypatch):
    import solver.deform.deformer as deformer_module
    from solver.linalg import threads

    mesh = read_mesh(DATA / "bracket.inp")
    spec = {"selections": {"a": {"set": "FIXED"}, "b": {"set": "LOAD"}}, "fixed": ["a"], "handles": {"b": "b"}}
    one = precompute(mesh, {**spec, "solve_options": {"threads": 1}})
    free = precompute(mesh, spec)
    monkeypatch.setattr(threads, "free_threads", lambda solves=1: 2)  # as if two cores were free
    seen = []
    real = deformer_module.solve_positions

    def spy(data, move):
        seen.append(threads.current_threads())
        return real(data, move)

    monkeypatch.setattr(deformer_module, "solve_positions", spy)
    move = {"handles": {"b": {"translation": [0, 0, 1]}}}
    one.solve(move)
    free.solve(move)
    assert seen == [1, min(2, tetmorph_core.max_threads())]


def test_the_command_line_caps_the_threads(tmp_path):
    import argparse

    from solver.options import add_solve_arguments, from_arguments

    p = argparse.ArgumentParser()
    add_solve_arguments(p)
    assert from_arguments(p.parse_args([])) is None
    assert from_arguments(p.parse_args(["--threads", "1"])) == replace(current(), threads=1)
    assert from_arguments(p.parse_args(["--reference", "--threads", "2"])).threads == 2
    with pytest.raises(SystemExit):
        p.parse_args(["--threads", "-1"])
