"""A fillet's radius, a distance and an angle as shape variables: sensitivities against central differences.

The part is the filleted L bracket of tests/gmsh_parts.py, meshed here (tests/solver/constraints/
test_feature_edits.py measures the edits themselves).
"""

from __future__ import annotations

import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.workflows.sensitivities import shape_sensitivities
from solver.workflows.shapes import combine, parse_shapes
from tests.gmsh_parts import filleted_bracket
from tests.solver.workflows.test_sensitivities import assert_matches, central_differences


@pytest.fixture(scope="module")
def bracket(tmp_path_factory):
    path = tmp_path_factory.mktemp("bracket") / "bracket.msh"
    filleted_bracket(path, size=3.0)
    return read_mesh(path)


def test_fillet_and_distance_sensitivities_agree_with_central_differences(bracket):
    d = precompute(bracket, {
        "selections": {k.lower(): {"set": k} for k in ("FIXED", "FILLET", "INNER_H", "INNER_V", "BORE", "LOAD")},
        "fixed": ["fixed"], "precision": "exact",
        "fillet": [{"name": "corner", "selection": "fillet", "faces": ["inner_h", "inner_v"]}],
        "distance": [{"name": "pitch", "selection": "bore", "reference": "load"}]})
    fillet, pitch = d.data.constraints.edits
    shapes = parse_shapes({"shapes": {"grow": {"fillet": {"corner": {"radius": 6.0}}},
                                      "shift": {"fillet": {"corner": {"delta": -0.5}}},
                                      "pitch": {"distance": {"pitch": {"distance": pitch.nominal - 2.0}}}}}, d)
    theta = np.array([0.5, 0.4, 0.7])
    doc = combine(shapes, theta)
    assert doc["fillet"]["corner"]["delta"] == pytest.approx(0.5 * (6.0 - fillet.nominal) - 0.2)
    assert doc["distance"]["pitch"]["delta"] == pytest.approx(-1.4)
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))


@pytest.mark.parametrize("axis", [None, [0.3, 0.0, 1.0]], ids=["cross", "given"])
def test_angle_sensitivities_agree_with_central_differences(bracket, axis):
    entry = {"name": "tilt", "selection": "load", "reference": "fixed"}
    if axis is not None:
        entry["axis"] = axis
    d = precompute(bracket, {"selections": {"fixed": {"set": "FIXED"}, "load": {"set": "LOAD"}},
                             "precision": "exact", "angle": [entry]})
    assert d.data.constraints.edits[0].flat == (axis is None)
    shapes = parse_shapes({"shapes": {"tilt": {"angle": {"tilt": {"angle_deg": 95.0}}},
                                      "back": {"angle": {"tilt": {"delta_deg": -2.0}}}}}, d)
    theta = np.array([0.8, 0.6])
    assert combine(shapes, theta)["angle"]["tilt"]["delta_deg"] == pytest.approx(0.8 * 5.0 - 1.2, abs=1e-6)
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))


def test_plans_and_bounds_take_a_fillet_radius(bracket):
    from solver.workflows import parse_plan, run_doe, shape_bounds

    d = precompute(bracket, {
        "selections": {k.lower(): {"set": k} for k in ("FIXED", "FILLET", "INNER_H", "INNER_V")},
        "fixed": ["fixed"], "fillet": [{"name": "corner", "selection": "fillet", "faces": ["inner_h", "inner_v"]}]})
    shapes = parse_shapes({"shapes": {"grow": {"fillet": {"corner": {"delta": 1.0}}}}}, d)
    res = run_doe(d, shapes, parse_plan([{"grow": g} for g in (-1.0, 0.0, 1.0)]))
    assert [v.status for v in res.variants] == ["ok"] * 3 and all(v.inverted == 0 for v in res.variants)
    b = shape_bounds(d, shapes, lo=-3.0, hi=30.0, tol=0.05).shapes[0]
    assert b.negative.limit == "range" and b.negative.value == -3.0
    assert b.positive.limit == "inversion" and 5.0 < b.positive.value < 30.0 and b.positive.inverted_beyond > 0
