"""The same MOVEs and DOE rows give the same bytes in this process, in another with other threads, and on Ray.

The decks are computed three ways: here with two threads for every solve
and every compiled kernel; in a separate ``tetmorph`` process with one
thread everywhere (``--threads 1``, OpenMP, MKL and OpenBLAS on one
thread); and by Ray actors (``tetmorph doe --engine ray``, a local Ray that
the command starts). Every written deck must be byte-for-byte the same.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from solver.linalg import threads
from tests.conftest import DATA

DECK = DATA / "plate.inp"
WORKFLOWS = Path(__file__).resolve().parents[1] / "solver" / "workflows" / "data"
TETMORPH = str(Path(sys.executable).parent / "tetmorph")
ONE_THREAD = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def _doe(out: Path) -> list[str]:
    return ["doe", str(DECK), "--spec", str(WORKFLOWS / "plate_spec.json"), "--shapes",
            str(WORKFLOWS / "plate_shapes.json"), "--plan", str(WORKFLOWS / "plate_plan.csv"),
            "--output", str(out / "plate_{i}.inp"), "--summary", str(out / "summary.csv")]


def _morph(out: Path, moves: Path) -> list[str]:
    return ["morph", str(DECK), "--spec", str(WORKFLOWS / "plate_spec.json"), "--moves", str(moves),
            "--output", str(out / "move_{i}.inp")]


def _tetmorph(args: list[str], env: dict[str, str] | None = None) -> None:
    r = subprocess.run([TETMORPH, *args], capture_output=True, text=True, timeout=600,
                       env={**os.environ, **(env or {})})
    assert r.returncode == 0, r.stderr[-3000:]


@pytest.fixture()
def moves(tmp_path) -> Path:
    """The plate's shapes as MOVEs of their own, one at a time and summed."""
    shapes = json.loads((WORKFLOWS / "plate_shapes.json").read_text())["shapes"]
    path = tmp_path / "moves.json"
    path.write_text(json.dumps(list(shapes.values())))
    return path


def test_moves_and_doe_rows_are_the_same_bytes_here_in_another_process_and_on_ray(tmp_path, monkeypatch, moves):
    from service.cli import main

    here, other, ray = tmp_path / "here", tmp_path / "other", tmp_path / "ray"
    monkeypatch.setattr(threads, "free_threads", lambda solves=1: 2)  # two threads whatever the machine's load
    assert main(_doe(here)) == 0
    assert main(_morph(here, moves)) == 0
    _tetmorph([*_doe(other), "--threads", "1"], ONE_THREAD)
    _tetmorph([*_morph(other, moves), "--threads", "1"], ONE_THREAD)
    _tetmorph([*_doe(ray), "--engine", "ray", "--actors", "2"])
    decks = sorted(p.name for p in here.glob("*.inp"))
    assert len([d for d in decks if d.startswith("plate_")]) == 8 and len(decks) == 12, decks
    for name in decks:
        mine = (here / name).read_bytes()
        assert (other / name).read_bytes() == mine, f"{name}: another process with one thread differs"
        if name.startswith("plate_"):
            assert (ray / name).read_bytes() == mine, f"{name}: the Ray actors' deck differs"
    assert (here / "plate_2.inp").read_bytes() != (here / "plate_1.inp").read_bytes()  # the rows differ
