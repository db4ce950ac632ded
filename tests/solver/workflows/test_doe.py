"""DOE on the plate deck: each row's deck against morph of its MOVE composed by hand."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from solver import SpecError, read_mesh
from solver.cli import main as tetmorph
from solver.workflows.doe import SUMMARY_FIELDS, deck_writer, run_doe, write_summary
from solver.workflows.plan import parse_plan, read_plan
from solver.workflows.shapes import parse_shapes
from tests.solver.workflows.conftest import PLAN, PLATE, plate_shapes, plate_spec


def hand_move(bend: float, hole1_x: float, hole2_y: float, upper_x: float) -> dict:
    """The README shapes' variant, composed by hand from plate_shapes.json."""
    return {"handles": {
        "end": {"translation": [0, 0, 8 * bend], "rotation": {"axis": [0, 1, 0], "angle_deg": -6 * bend}},
        "hole1": {"translation": [4 * hole1_x, 0, 0]},
        "hole2": {"translation": [0, 4 * hole2_y, 0]},
        "hole3": {"translation": [-3 * upper_x, 0, 0]},
        "hole4": {"translation": [3 * upper_x, 0, 0]}}}


def node_lines_differ_only_in_coordinates(a: bytes, b: bytes, tol: float) -> int:
    """Compare two decks line by line: equal bytes, or node lines with one id and coordinates within ``tol``.

    Returns the number of node lines that differ.
    """
    la, lb = a.splitlines(keepends=True), b.splitlines(keepends=True)
    assert len(la) == len(lb)
    differing = 0
    for x, y in zip(la, lb, strict=True):
        if x == y:
            continue
        fx, fy = x.split(b","), y.split(b",")
        assert len(fx) == len(fy) == 4 and fx[0] == fy[0], (x, y)
        assert np.abs(np.array([float(v) for v in fx[1:]]) - np.array([float(v) for v in fy[1:]])).max() <= tol
        differing += 1
    return differing


@pytest.fixture(scope="module")
def shapes_exact(plate_exact):
    return parse_shapes(plate_shapes(), plate_exact)


def test_each_deck_is_morph_of_the_hand_composed_move(tmp_path, plate_exact, shapes_exact):
    d = plate_exact
    plan = read_plan(PLAN)
    res = run_doe(d, shapes_exact, plan, block=3, output=deck_writer(d.mesh, str(tmp_path / "out_{i}.inp")))
    assert [v.row for v in res.variants] == list(range(1, plan.rows + 1))
    assert all(v.status == "ok" for v in res.variants)
    original = PLATE.read_bytes()
    diag = d.data.constraints.diag
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(plate_spec(precision="exact")))
    for v in res.variants:
        row = plan.values[v.row - 1]
        hand = hand_move(*row)
        one = d.solve(hand)
        back = read_mesh(v.file)  # read the written deck back
        assert np.abs(back.V - one.V).max() <= 1e-10 * diag
        assert v.inverted == one.report["inverted_elements"] == 0
        assert v.max_displacement == pytest.approx(one.report["max_displacement"], rel=1e-9)
        assert v.min_scaled_jacobian == pytest.approx(one.report["min_scaled_jacobian"], rel=1e-9)
        written = open(v.file, "rb").read()
        moved = node_lines_differ_only_in_coordinates(original, written, tol=2 * diag)  # byte-faithful but nodes
        assert moved > 0 or not row.any()
        if v.row in (2, 7):  # the deck tetmorph morph writes for the hand-composed MOVE
            mv_path = tmp_path / f"move_{v.row}.json"
            mv_path.write_text(json.dumps(hand))
            out = tmp_path / f"morph_{v.row}.inp"
            assert tetmorph(["morph", str(PLATE), "--spec", str(spec_path), "--move", str(mv_path),
                             "--output", str(out)]) == 0
            node_lines_differ_only_in_coordinates(out.read_bytes(), written, tol=1e-10 * diag)


def test_block_size_does_not_change_results(plate_exact, shapes_exact):
    plan = read_plan(PLAN)
    keep: dict[int, list] = {}

    def grab(block):
        def out(row, r):
            keep.setdefault(block, []).append(r.V)
            return None
        return out

    for block in (1, 8):
        run_doe(plate_exact, shapes_exact, plan, block=block, output=grab(block))
    diff = max(np.abs(a - b).max() for a, b in zip(keep[1], keep[8], strict=True))
    assert diff <= 1e-10 * plate_exact.data.constraints.diag


def test_progress_cancel_and_summary(tmp_path, plate_deformer):
    shapes = parse_shapes(plate_shapes(), plate_deformer)
    plan = read_plan(PLAN)
    seen = []
    res = run_doe(plate_deformer, shapes, plan, block=3, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(3, 8), (6, 8), (8, 8)]
    asked = []

    def cancelled():
        asked.append(1)
        return len(asked) > 1  # stop before the second block

    part = run_doe(plate_deformer, shapes, plan, block=3, cancelled=cancelled)
    assert part.cancelled and [v.row for v in part.variants] == [1, 2, 3]
    path = tmp_path / "sub" / "summary.csv"
    write_summary(res, path)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["row", *shapes.names, *SUMMARY_FIELDS]
    for r, v in zip(rows, res.variants, strict=True):
        assert int(r["row"]) == v.row
        assert [float(r[n]) for n in shapes.names] == plan.values[v.row - 1].tolist()
        assert int(r["inverted"]) == v.inverted
        assert float(r["max_displacement"]) == v.max_displacement  # 17 digits read back exactly
        assert float(r["min_scaled_jacobian"]) == v.min_scaled_jacobian
        assert float(r["constraint_residual_max"]) == v.constraint_residual_max
        assert r["file"] == "" and r["status"] == "ok"


def test_reject_writes_no_deck_and_clamp_writes_the_safe_fraction(plate_deformer):
    shapes = parse_shapes(plate_shapes(), plate_deformer)
    plan = parse_plan([{"hole2_y": 0.5}, {"hole2_y": 4.0}, {"bend": 1}])  # hole 2 moved 16 mm folds its ligament
    written = []
    res = run_doe(plate_deformer, shapes, plan, inversion="reject", output=lambda i, r: written.append(i) or "f")
    assert [v.status for v in res.variants] == ["ok", "rejected", "ok"]
    assert written == [1, 3] and res.variants[1].file is None and res.variants[1].inverted > 0
    clamp = run_doe(plate_deformer, shapes, plan, inversion="clamp")
    rep = clamp.variants[1].report
    assert clamp.variants[1].status == "ok" and clamp.variants[1].inverted == 0
    assert rep["clamped"] and 0 < rep["applied_fraction"] < 1 and rep["inverted_elements_unclamped"] > 0


def test_invalid_rows_stop_the_run_before_any_solve(plate_deformer):
    doc = plate_shapes()
    doc["shapes"]["spin"] = {"handles": {"end": {"rotation": {"axis": [1, 0, 0], "angle_deg": 120}}}}
    shapes = parse_shapes(doc, plate_deformer)
    calls = []
    plan = parse_plan([{"bend": 1}, {"spin": 1}, {"spin": 3.5}])
    with pytest.raises(SpecError, match="plan row 3: handle 'end' turns by 420 degrees"):
        run_doe(plate_deformer, shapes, plan, output=lambda i, r: calls.append(i))
    assert calls == []
    with pytest.raises(SpecError, match="name no shape"):
        run_doe(plate_deformer, shapes, parse_plan([{"bent": 1}]))
    with pytest.raises(SpecError, match="block must be an integer in"):
        run_doe(plate_deformer, shapes, plan, block=0)


def test_blocks_solved_through_the_first_blocks_basis_are_the_same_wherever_they_run(monkeypatch):
    """A large interior (BASIS_MIN lowered to reach it): every block projects on the first block's basis.

    A block run alone with that basis (as a Ray actor or a service batch runs it)
    gives the whole run's positions bit for bit; each row equals its own
    separate solve within the mixed precision's stated accuracy, with no
    refinement step, and the residual is recomputed here from the positions.
    """
    from solver import precompute
    from solver.deform import positions
    from solver.deform.positions import MIXED_TOL
    from solver.ops.mvc_matrix import mvc_matrix
    from solver.workflows.doe import doe_basis
    from solver.workflows.plan import Plan
    from solver.workflows.shapes import variant_move
    from tests.conftest import bend_spec, load, longest_axis

    monkeypatch.setattr(positions, "BASIS_MIN", 0)
    mesh = load("tet/cube_big_tetra.mesh")
    d = precompute(mesh, bend_spec(mesh))
    ax, diag = longest_axis(mesh)
    axis = [0.0, 0.0, 0.0]
    axis[(ax + 1) % 3] = 1.0
    shapes = parse_shapes({"shapes": {
        "turn": {"handles": {"h": {"rotation": {"axis": axis, "angle_deg": 12}}}},
        "lift": {"handles": {"h": {"translation": (0.02 * diag * np.eye(3)[(ax + 2) % 3]).tolist()}}},
        "pull": {"handles": {"h": {"translation": (0.01 * diag * np.eye(3)[ax]).tolist()}}}}}, d)
    values = np.random.default_rng(5).uniform(-1, 1, (24, 3))
    plan = parse_plan([dict(zip(shapes.names, r, strict=True)) for r in values.tolist()])
    got: dict[int, np.ndarray] = {}
    reports: dict[int, dict] = {}

    def keep(row, r):
        got[row] = r.V
        reports[row] = r.report

    whole = run_doe(d, shapes, plan, block=8, output=keep)
    assert whole.timings["interior_basis_columns"] > 0
    basis = doe_basis(d, shapes, plan, 8)
    assert basis is not None and basis.rank == whole.timings["interior_basis_columns"]
    for start in (8, 16):  # the later blocks alone, as another process runs them
        part = Plan(plan.columns, plan.values[start:start + 8], None)
        alone: dict[int, np.ndarray] = {}
        run_doe(d, shapes, part, block=8, basis=basis, output=lambda row, r, alone=alone: alone.setdefault(row, r.V))
        assert len(alone) == 8
        for row, V in alone.items():
            assert np.array_equal(V, got[row + start])
    W, _ = mvc_matrix(mesh.V, mesh.T, mesh.interior)
    fi = d.data.positions.free_interior
    for i in range(plan.rows):
        one = d.solve(variant_move(d, shapes, values[i]))
        disp = np.linalg.norm(one.V[fi] - mesh.V[fi], axis=1).max()
        assert np.linalg.norm(got[i + 1] - one.V, axis=1).max() <= 10 * MIXED_TOL * disp
        res = np.linalg.norm(got[i + 1][fi] - (W @ got[i + 1])[fi], axis=1).max() / disp
        assert res <= MIXED_TOL and reports[i + 1]["interior_refined"] is False
