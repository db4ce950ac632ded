"""The daily edits as shape variables: variants, and sensitivities against central differences of full solves."""

from __future__ import annotations

import numpy as np
import pytest

from solver import SpecError, precompute
from solver.workflows.sensitivities import shape_sensitivities
from solver.workflows.shapes import combine, parse_shapes, variant_move
from tests.solver.workflows.test_sensitivities import TURNS, assert_matches, central_differences

BORE = [160.0 / 3.0, 80.0 / 3.0, 0.0]


def edit_spec(**extra) -> dict:
    """The plate clamped, its end a handle, its first bore's radius, its end face twisted, its top offset, and a
    morph volume over its second bore (double-precision interior)."""
    return {"selections": {"clamp": {"set": "FIXED"}, "end": {"set": "LOAD"}, "hole1": {"set": "HOLE1"},
                           "hole2": {"set": "HOLE2"}},
            "fixed": ["clamp"], "handles": {"end": "end"}, "precision": "exact",
            "radius": [{"name": "bore", "selection": "hole1", "axis": {"point": BORE, "direction": [0, 0, 1]}}],
            "map": [{"name": "flat", "selection": "hole2",
                     "geometry": {"cylinder": {"point": [320 / 3, 80 / 3, 0], "axis": [0, 0, 1], "radius": 6.5}}}],
            "lattice": [{"name": "box", "box": {"min": [10, 50, -1], "max": [60, 81, 5]}, "counts": [3, 3, 2]}],
            **extra}


@pytest.fixture(scope="module")
def edited(plate):
    return precompute(plate, edit_spec())


def test_radius_sensitivities_agree_with_central_differences(edited):
    d = edited
    shapes = parse_shapes({"shapes": {"bend": TURNS["shapes"]["bend"],
                                      "grow": {"radius": {"bore": {"radius": 6.8}}},
                                      "shift": {"radius": {"bore": {"delta": -0.3}}}}}, d)
    nominal = d.data.constraints.edits[0].nominal
    steps = shapes.edits["radius"]["bore"]
    assert steps[0] is None and steps[1].delta == pytest.approx(6.8 - nominal) and steps[2].delta == -0.3
    theta = np.array([0.8, 0.6, 0.5])
    assert combine(shapes, theta)["radius"] == {"bore": {"delta": pytest.approx(0.6 * (6.8 - nominal) - 0.15)}}
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))
    ids = d.data.constraints.sel_ids["hole1"]
    grow = S.derivatives[1][ids]  # a radius change moves each bore node along its radial direction
    radial = d.mesh.V[ids] - BORE
    radial[:, 2] = 0.0
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    assert np.abs(grow - (6.8 - nominal) * radial).max() <= 1e-9


def test_twist_map_and_lattice_sensitivities_agree_with_central_differences(plate, edited):
    d = precompute(plate, edit_spec(handles={}, fixed=["clamp"], twist=[
        {"name": "tip", "selection": "end", "axis": {"point": [0, 40, 2], "direction": [1, 0, 0]}}]))
    shapes = parse_shapes({"shapes": {
        "twist": {"twist": {"tip": {"angle_deg_per_length": 0.1}}},
        "twist2": {"twist": {"tip": {"angle_deg_per_length": -0.04}}},
        "map": {"map": {"flat": {"amount": 1.0}}},
        "box": {"lattice": {"box": {"displacements": {"1,2,1": [0, 3, 2], "0,0,0": [1, 0, 0]}}}}}}, d)
    theta = np.array([0.7, 1.2, 0.8, -0.6])
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))
    doc = combine(shapes, theta)
    assert doc["twist"]["tip"]["angle_deg_per_length"] == pytest.approx(0.7 * 0.1 - 1.2 * 0.04)
    assert doc["lattice"]["box"]["displacements"]["1,2,1"] == pytest.approx([0, -1.8, -1.2])
    tables = parse_shapes({"shapes": {
        "a": {"twist": {"tip": {"table": [{"at": 0, "angle_deg": 0}, {"at": 160, "angle_deg": 10}]}}},
        "b": {"twist": {"tip": {"table": [{"at": 80, "angle_deg": 4}]}}}}}, d)
    rows = combine(tables, [1.0, 0.5])["twist"]["tip"]["table"]
    assert [(r["at"], r["angle_deg"]) for r in rows] == [(0, 2.0), (80, 7.0), (160, 12.0)]
    St = shape_sensitivities(d, tables, [1.0, 0.5])
    assert_matches(St, central_differences(d, tables, [1.0, 0.5]))
    with pytest.raises(SpecError) as e:
        parse_shapes({"shapes": {"a": {"twist": {"tip": {"angle_deg_per_length": 0.1}}},
                                 "b": {"twist": {"tip": {"table": [{"at": 0, "angle_deg": 1}]}}}}}, d)
    assert e.value.code == "twist_conflict"


def test_an_edit_variant_is_the_move_of_its_parameters(edited):
    d = edited
    shapes = parse_shapes({"shapes": {"grow": {"radius": {"bore": {"radius": 7.0}}}}}, d)
    ids = d.data.constraints.sel_ids["hole1"]
    V = d.solve(variant_move(d, shapes, [1.0])).V[ids] - BORE
    assert np.abs(np.hypot(V[:, 0], V[:, 1]) - 7.0).max() <= 1e-12 * 7.0
    np.testing.assert_array_equal(d.solve(variant_move(d, shapes, [0.0])).V, d.mesh.V)


def test_plans_and_bounds_take_edit_shapes(plate, edited):
    from solver.workflows import parse_plan, run_doe, shape_bounds

    shapes = parse_shapes({"shapes": {"grow": {"radius": {"bore": {"delta": 1.0}}},
                                      "flat": {"map": {"flat": {"amount": 1.0}}}}}, edited)
    res = run_doe(edited, shapes, parse_plan([{"grow": g, "flat": f} for g in (-1.0, 0.0, 1.5) for f in (0.0, 1.0)]))
    assert [v.status for v in res.variants] == ["ok"] * 6 and all(v.inverted == 0 for v in res.variants)
    assert max(v.constraint_residual_max for v in res.variants) <= 1e-12 * 180
    wall = precompute(plate, {"selections": {"top": {"set": "TOP"}, "bottom": {"set": "BOTTOM"}},
                              "offset": [{"name": "wall", "selection": "top", "opposite": "bottom"}]})
    thick = parse_shapes({"shapes": {"thick": {"offset": {"wall": {"distance": 1.0}}}}}, wall)
    b = shape_bounds(wall, thick, lo=-10.0, hi=2.0, tol=0.05).shapes[0]
    assert b.positive.limit == "range" and b.positive.value == 2.0
    assert b.negative.limit == "inversion" and -4.0 < b.negative.value < -2.0


def test_bend_sensitivities_agree_with_central_differences(plate):
    d = precompute(plate, edit_spec(handles={}, twist=[
        {"name": "arc", "selection": "end", "mode": "bend", "toward": [0, 0, 1],
         "axis": {"point": [0, 40, 2], "direction": [1, 0, 0]}}]))
    rate = parse_shapes({"shapes": {"up": {"twist": {"arc": {"angle_deg_per_length": 0.05}}},
                                    "grow": {"radius": {"bore": {"delta": 0.5}}}}}, d)
    S = shape_sensitivities(d, rate, [0.8, 0.4])
    assert_matches(S, central_differences(d, rate, [0.8, 0.4]))
    table = parse_shapes({"shapes": {
        "root": {"twist": {"arc": {"table": [{"at": 0, "angle_deg": 0}, {"at": 60, "angle_deg": 4}]}}},
        "tip": {"twist": {"arc": {"table": [{"at": 100, "angle_deg": 0}, {"at": 150, "angle_deg": -3}]}}}}}, d)
    St = shape_sensitivities(d, table, [1.0, 0.7])
    assert_matches(St, central_differences(d, table, [1.0, 0.7]))
