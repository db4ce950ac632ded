"""Combining basis shapes: checked against MOVEs composed by hand, and the strict refusals."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from solver import SpecError
from solver.workflows.shapes import combine, parse_shapes, variant_move
from tests.solver.workflows.conftest import plate_shapes

SHAPES = {"shapes": {
    "a": {"handles": {"end": {"translation": [1, 2, 3], "rotation": {"axis": [0, 0, 2], "angle_deg": 10},
                              "scale": 1.1}}},
    "b": {"handles": {"end": {"translation": [0, 0, -1], "rotation": {"axis": [1, 0, 0], "angle_deg": 20}},
                      "hole1": {"translation": [2, 0, 0]}}},
    "c": {"handles": {"hole1": {"scale": 0.9}}},
}}


def test_variant_is_the_weighted_sum_composed_by_hand(plate_deformer):
    d = plate_deformer
    s = parse_shapes(SHAPES, d)
    th = [0.5, -2.0, 1.5]
    mv = variant_move(d, s, th)
    end, hole1 = mv.handles["end"], mv.handles["hole1"]
    # by hand: translations add, quaternion logarithms (angle/2 * unit axis) add, scales multiply as s**value
    assert np.allclose(end.translation, [0.5, 1.0, 3.5], rtol=0, atol=1e-15)
    log = 0.5 * math.radians(10) / 2 * np.array([0, 0, 1.0]) - 2.0 * math.radians(20) / 2 * np.array([1.0, 0, 0])
    assert np.allclose(end.log_rotation, log, rtol=1e-15, atol=1e-16)
    assert end.scale == pytest.approx(1.1 ** 0.5, rel=1e-15)
    assert np.allclose(hole1.translation, [-4.0, 0, 0], rtol=0, atol=1e-15)
    assert hole1.scale == pytest.approx(0.9 ** 1.5, rel=1e-15)
    assert end.pivot is None and hole1.pivot is None  # the handles' rest centroids, as in a MOVE
    assert set(mv.handles) == {"end", "hole1"}  # handles no shape names stay at rest
    # the same MOVE written by hand gives the same positions
    half = float(np.linalg.norm(log))
    hand = {"handles": {"end": {"translation": [0.5, 1.0, 3.5], "scale": 1.1 ** 0.5,
                                "rotation": {"axis": (log / half).tolist(), "angle_deg": math.degrees(2 * half)}},
                        "hole1": {"translation": [-4, 0, 0], "scale": 0.9 ** 1.5}}}
    diff = np.abs(d.solve_positions(mv).P - d.solve_positions(hand).P).max()
    assert diff <= 1e-12 * d.data.constraints.diag


def test_unit_values_give_each_shape_and_zero_the_rest_shape(plate_deformer):
    d = plate_deformer
    s = parse_shapes(SHAPES, d)
    for k, name in enumerate(s.names):
        mv = variant_move(d, s, np.eye(3)[k])
        own = d.parse_move(SHAPES["shapes"][name])
        for h, hm in own.handles.items():
            got = mv.handles[h]
            assert np.allclose(got.translation, hm.translation, atol=1e-15)
            assert np.allclose(got.log_rotation, hm.log_rotation, atol=1e-16)
            assert got.scale == pytest.approx(hm.scale, rel=1e-15)
    rest = d.solve_positions(variant_move(d, s, np.zeros(3))).P
    assert np.abs(rest - d.mesh.V).max() <= 1e-12 * d.data.constraints.diag


def test_constraint_targets_add_as_displacements_and_scales_multiply(constrained):
    d = constrained
    rest = d.data.constraints.rest
    corner0, slide0, gap0 = rest.points["corner"][0], rest.motion["slide"], rest.relative["gap"]
    doc = {"shapes": {
        "lift": {"points": {"corner": (corner0 + [0, 0, 5]).tolist()},
                 "motion": {"slide": {"point": (slide0 + [1, 2, 0]).tolist()}}},
        "spread": {"relative": {"gap": {"offset": (gap0 + [-4, 0, 0]).tolist()}}},
        "grow": {"features": {"hole1": {"scale": 1.2}}},
    }}
    s = parse_shapes(doc, d)
    mv = variant_move(d, s, [2.0, -0.5, 3.0])
    assert np.allclose(mv.points["corner"], corner0 + [0, 0, 10], atol=1e-12)
    assert np.allclose(mv.motion["slide"], slide0 + [2, 4, 0], atol=1e-12)
    assert np.allclose(mv.relative["gap"]["offset"], gap0 + [2, 0, 0], atol=1e-12)
    assert mv.features["hole1"] == pytest.approx(1.2 ** 3, rel=1e-15)
    scaled = parse_shapes({"shapes": {"g1": {"relative": {"gap": {"scale": 1.5}}},
                                      "g2": {"relative": {"gap": {"scale": 0.8}}}}}, d)
    assert variant_move(d, scaled, [2, 1]).relative["gap"]["scale"] == pytest.approx(1.5 ** 2 * 0.8, rel=1e-15)


class _TargetsAware:
    """A deformer whose MOVE parser accepts ``targets`` (as it will once target surfaces are in)."""

    def __init__(self, d):
        self._d, self.handle_names, self.data = d, d.handle_names, d.data

    def parse_move(self, doc):
        return self._d.parse_move(doc.model_copy(update={"targets": {}}))


def test_target_amounts_pass_through_additively(plate_deformer):
    doc = {"shapes": {"x": {"targets": {"skin": {"amount": 2.0}}, "handles": {"end": {"translation": [1, 0, 0]}}},
                      "y": {"targets": {"skin": {"amount": -0.5}, "rib": {"amount": 3.0}}}}}
    s = parse_shapes(doc, _TargetsAware(plate_deformer))
    out = combine(s, [1.5, 2.0])
    assert out["targets"] == {"skin": {"amount": 1.5 * 2.0 + 2.0 * -0.5}, "rib": {"amount": 6.0}}
    bad = {"shapes": {"x": {"targets": {"skin": {"amount": "2"}}}}}
    with pytest.raises(SpecError, match="shape 'x'.*amount"):
        parse_shapes(bad, _TargetsAware(plate_deformer))


def test_pivots_one_per_handle(plate_deformer):
    d = plate_deformer
    turn = {"rotation": {"axis": [0, 1, 0], "angle_deg": 5}}
    ok = parse_shapes({"shapes": {"p": {"handles": {"end": {**turn, "pivot": [160, 0, 0]}}},
                                  "q": {"handles": {"end": {**turn, "pivot": [160, 0, 0]}}},
                                  "t": {"handles": {"end": {"translation": [0, 0, 1], "pivot": [0, 0, 0]}}}}}, d)
    assert combine(ok, [1, 1, 1])["handles"]["end"]["pivot"] == [160.0, 0.0, 0.0]
    with pytest.raises(SpecError, match="shapes 'p' and 'q' turn or scale handle 'end' about different pivots") as e:
        parse_shapes({"shapes": {"p": {"handles": {"end": {**turn, "pivot": [160, 0, 0]}}},
                                 "q": {"handles": {"end": {"scale": 1.1}}}}}, d)
    assert e.value.code == "pivot_conflict" and e.value.details["handle"] == "end"


def test_relative_offset_and_scale_conflict(constrained):
    rest = constrained.data.constraints.rest.relative["gap"]
    with pytest.raises(SpecError, match="'o' and 's' give relative constraint 'gap' an offset and a scale") as e:
        parse_shapes({"shapes": {"o": {"relative": {"gap": {"offset": rest.tolist()}}},
                                 "s": {"relative": {"gap": {"scale": 1.1}}}}}, constrained)
    assert e.value.code == "relative_conflict"


@pytest.mark.parametrize("doc, match, code", [
    ({"shapes": {"bad": {"handles": {"nope": {"translation": [1, 0, 0]}}}}}, r"shape 'bad': .*unknown handle",
     "invalid_spec"),
    ({"shapes": {"bad": {"handles": {"end": {"scale": -1}}}}},
     r"shape 'bad': MOVE.handles.end.scale: Input should be greater than or equal to 0.001, got -1", "invalid_spec"),
    ({"shapes": {"bad": {"points": {"p": [0, 0, 0]}}}}, r"shape 'bad': .*unknown points", "invalid_spec"),
    ({"shapes": {}}, "SHAPES.shapes: Dictionary should have at least 1 item", "invalid_shapes"),
    ({"shape": {}}, "SHAPES document", "invalid_shapes"),
    ({"shapes": {"a": {}}, "extra": 1}, "SHAPES document", "invalid_shapes"),
    ([{"a": {}}], "SHAPES document", "invalid_shapes"),
    ({"shapes": {" a": {}}}, "surrounding blanks", "invalid_shapes"),
    ({"shapes": {"status": {}}}, "reserved", "invalid_shapes"),
])
def test_malformed_shapes_are_refused(plate_deformer, doc, match, code):
    with pytest.raises(SpecError, match=match) as e:
        parse_shapes(doc, plate_deformer)
    assert e.value.code == code
    if "bad" in str(doc):
        assert e.value.details["shape"] == "bad"


def test_variants_a_move_cannot_express_name_the_row(plate_deformer):
    d = plate_deformer
    s = parse_shapes({"shapes": {"spin": {"handles": {"end": {"rotation": {"axis": [0, 0, 1], "angle_deg": 200}}}},
                                 "grow": {"handles": {"hole1": {"scale": 10}}}}}, d)
    with pytest.raises(SpecError, match="plan row 2: handle 'end' turns by 400 degrees") as e:
        variant_move(d, s, [2, 0], "plan row 2")
    assert e.value.code == "rotation_range"
    with pytest.raises(SpecError, match=r"plan row 5: MOVE.handles.hole1.scale: Input should be less than or equal "
                                        r"to 1000"):
        variant_move(d, s, [0, 4], "plan row 5")
    with pytest.raises(SpecError, match="2 finite numbers"):
        variant_move(d, s, [0, np.nan])


def test_readme_shapes_parse(plate_deformer):
    s = parse_shapes(plate_shapes(), plate_deformer)
    assert s.names == ("bend", "hole1_x", "hole2_y", "upper_x")
    assert s.moved.tolist() == [True, True, True, True, True]
    assert dataclasses.is_dataclass(s)
