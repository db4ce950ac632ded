"""Errors of the document models name the field a person wrote, whatever pydantic calls it inside."""

import pytest

from solver.documents.move import Move
from solver.documents.spec import Spec
from solver.documents.validation import validated
from solver.errors import SpecError


@pytest.mark.parametrize("name", ["tip", "tip(1)", "arm[2]", "Move", "constrained-float", "str"])
def test_a_key_that_looks_like_a_union_member_is_kept(name):
    with pytest.raises(SpecError) as e:
        validated(Move, {"handles": {name: {"scale": True}}}, "MOVE")
    assert str(e.value) == f"MOVE.handles.{name}.scale: Input should be a valid number, got True"
    assert e.value.details["field"] == f"MOVE.handles.{name}.scale"


def test_an_optional_bounded_number_is_named_without_its_kind():
    doc = {"selections": {"a": {"ids": [1]}}, "points": [{"name": "p", "edge": [1, 2], "t": 2}]}
    with pytest.raises(SpecError) as e:
        validated(Spec, doc, "SPEC")
    assert str(e.value) == "SPEC.points[0].t: Input should be less than or equal to 1, got 2"
    assert e.value.details["field"] == "SPEC.points[0].t"


def test_a_union_is_named_by_the_member_that_fits():
    with pytest.raises(SpecError) as e:
        validated(Move, {"handles": {"h": {"translation": [0, 0, "x"]}}}, "MOVE")
    assert e.value.details["field"] == "MOVE.handles.h.translation"
    assert all("none" not in err["where"] for err in e.value.details["errors"])


def test_keys_that_look_like_union_members_side_by_side_are_each_named():
    with pytest.raises(SpecError) as e:
        validated(Move, {"handles": {"tip(1)": {"scale": True}, "arm(2)": {"scale": "x"}}}, "MOVE")
    assert [err["where"] for err in e.value.details["errors"]] == ["MOVE.handles.tip(1).scale",
                                                                   "MOVE.handles.arm(2).scale"]
    with pytest.raises(SpecError) as e:
        validated(Spec, {"selections": {"str": {"ids": ["x"]}, "int": {"ids": ["y"]}}}, "SPEC")
    assert [err["where"] for err in e.value.details["errors"]] == ["SPEC.selections.str.ids[0]",
                                                                   "SPEC.selections.int.ids[0]"]
    with pytest.raises(SpecError) as e:
        validated(Move, {"handles": {"[key]": {"scale": True}}}, "MOVE")
    assert e.value.details["field"] == "MOVE.handles.[key].scale"
