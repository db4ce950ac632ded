"""Safe bounds: each bound re-solved through the full update, and the limits known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver import SpecError, precompute
from solver.workflows.bounds import shape_bounds
from solver.workflows.shapes import parse_shapes, variant_move

HOLES = {"shapes": {
    "hole2_y": {"handles": {"hole2": {"translation": [0, 4, 0]}}},
    "upper_x": {"handles": {"hole3": {"translation": [-3, 0, 0]}, "hole4": {"translation": [3, 0, 0]}}},
}}


def test_bounds_are_valid_and_invert_just_beyond(plate_deformer):
    d = plate_deformer
    shapes = parse_shapes(HOLES, d)
    tol = 0.02
    res = shape_bounds(d, shapes, lo=-8, hi=8, tol=tol)
    assert [b.shape for b in res.shapes] == ["hole2_y", "upper_x"]
    assert res.timings["solves"] < res.timings["probes"]  # probes stacked per back-substitution
    inverting = []
    for k, b in enumerate(res.shapes):
        for side in (b.positive, b.negative):
            th = np.zeros(2)
            th[k] = side.value
            ok = d.solve(variant_move(d, shapes, th))  # the full update, its own REPORT
            assert ok.report["inverted_elements"] == 0
            if side.limit == "range":
                assert abs(side.value) == 8 and side.beyond is None
                continue
            assert side.limit == "inversion"
            assert 0 < abs(side.beyond) - abs(side.value) <= tol and np.sign(side.beyond) == np.sign(side.value)
            th[k] = side.beyond
            bad = d.solve(variant_move(d, shapes, th))
            assert bad.report["inverted_elements"] == side.inverted_beyond > 0
            inverting.append((b.shape, side.value > 0))
    # hole 2 moved up closes the ligament to hole 4; holes 3 and 4 moved together close the one between them
    assert inverting == [("hole2_y", True), ("upper_x", False)]
    doc = res.to_dict()
    assert set(doc["bounds"]) == {"hole2_y", "upper_x"} and doc["range"] == [-8, 8]


def test_the_move_limits_a_rigid_body(plate):
    """The whole plate one handle: nothing can invert, so a 100 degree turn per unit stops at 360 degrees
    (3.6 units, where a MOVE ends) and a doubling scale at 1000 (log2 1000 units)."""
    d = precompute(plate, {"selections": {"all": {"set": "SOLID"}}, "handles": {"all": "all"}})
    shapes = parse_shapes({"shapes": {
        "spin": {"handles": {"all": {"rotation": {"axis": [0, 0, 1], "angle_deg": 100}}}},
        "grow": {"handles": {"all": {"scale": 2}}}}}, d)
    tol = 1e-3
    res = shape_bounds(d, shapes, lo=-12, hi=12, tol=tol)
    spin, grow = res.shapes
    for side, limit in ((spin.positive, 3.6), (spin.negative, -3.6), (grow.positive, math.log2(1000)),
                        (grow.negative, -math.log2(1000))):
        assert side.limit == "move" and side.inverted_beyond is None
        assert abs(side.value) <= abs(limit) <= abs(side.beyond) and abs(side.beyond - side.value) <= tol
    free = shape_bounds(d, shapes, lo=-1, hi=0.5)
    assert [(b.positive.value, b.positive.limit, b.negative.value) for b in free.shapes] == [
        (0.5, "range", -1.0), (0.5, "range", -1.0)]


def test_default_search_doubles_and_callbacks(plate_deformer):
    shapes = parse_shapes({"shapes": {"hole2_y": HOLES["shapes"]["hole2_y"]}}, plate_deformer)
    seen = []
    res = shape_bounds(plate_deformer, shapes, tol=0.25, progress=lambda done, total: seen.append((done, total)))
    b = res.shapes[0]
    assert b.positive.limit == "inversion" and 2 <= b.positive.beyond <= 4  # found between probes 2 and 4
    assert seen[-1] == (2, 2) and all(t == 2 for _, t in seen) and len(seen) == len(set(seen))
    stopped = shape_bounds(plate_deformer, shapes, cancelled=lambda: True)
    assert stopped.cancelled and stopped.shapes == []


@pytest.mark.parametrize("kw, match", [
    ({"lo": 1, "hi": 2}, "must contain 0"),
    ({"hi": -1}, "must contain 0"),
    ({"tol": 0}, "tol must be a number in"),
    ({"block": 0}, "block must be an integer in"),
    ({"hi": math.inf}, "must be finite"),
])
def test_bad_ranges(plate_deformer, kw, match):
    shapes = parse_shapes(HOLES, plate_deformer)
    with pytest.raises(SpecError, match=match):
        shape_bounds(plate_deformer, shapes, **kw)


def test_an_inverting_base_is_refused(plate_deformer):
    shapes = parse_shapes(HOLES, plate_deformer)
    with pytest.raises(SpecError, match="base parameters .* invert"):
        shape_bounds(plate_deformer, shapes, base=[6.0, 0.0], lo=-1, hi=1)
