"""The plate DOE the Ray tests run, and its single-process reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from solver import read_mesh
from solver.deform.deformer import Deformer
from solver.workflows import DoeResult, deck_writer, parse_plan, parse_shapes, run_doe, write_summary
from solver.workflows.plan import Plan
from tests.conftest import DATA
from tests.solver.workflows.conftest import plate_shapes, plate_spec

PLATE = DATA / "plate.inp"


def plan(rows: int) -> Plan:
    t = np.linspace(-1.0, 1.0, rows)
    return parse_plan([[a, a / 2, -a, a / 3] for a in t], ["bend", "hole1_x", "hole2_y", "upper_x"])


def reference(folder: Path, p: Plan, block: int) -> DoeResult:
    """``tetmorph doe``'s run: one process, decks plate_{i}.inp and summary.csv in ``folder``."""
    mesh = read_mesh(PLATE)
    d = Deformer(mesh, plate_spec())
    out = deck_writer(mesh, str(folder / "plate_{i}.inp"))
    r = run_doe(d, parse_shapes(plate_shapes(), d), p, block=block, output=out)
    write_summary(r, folder / "summary.csv")
    return r


def same_decks(a: Path, b: Path, rows: int) -> None:
    """Every row's deck exists once in each folder, byte for byte equal; nothing else is there."""
    names = sorted(f"plate_{i}.inp" for i in range(1, rows + 1))
    assert sorted(p.name for p in b.iterdir() if p.name != "summary.csv") == names
    for n in names:
        x, y = (a / n).read_bytes(), (b / n).read_bytes()
        assert x == y, f"{n}: {_difference(x, y)}"


def _difference(x: bytes, y: bytes) -> str:
    """Where two decks differ: the count of differing lines, the first, and the largest difference of a number."""
    lx, ly = x.decode().splitlines(), y.decode().splitlines()
    if len(lx) != len(ly):
        return f"{len(lx)} lines against {len(ly)}"
    rows = [k for k, (p, q) in enumerate(zip(lx, ly, strict=True)) if p != q]
    worst = 0.0
    for k in rows:
        try:
            worst = max(worst, max(abs(float(u) - float(v)) for u, v in
                                   zip(lx[k].split(",")[1:], ly[k].split(",")[1:], strict=True)))
        except ValueError:
            worst = float("nan")
    return (f"{len(rows)} lines differ, the first {rows[0] + 1}: {lx[rows[0]]!r} against {ly[rows[0]]!r}; "
            f"largest {worst:.3g}")
