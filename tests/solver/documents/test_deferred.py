"""Members validated on first use answer what the models answered when the SPEC and MOVE held them built.

The expected locations and messages were read from the models before their edits, points, targets,
symmetries and the MOVE's other members were validated on first use (:mod:`solver.documents.deferred`).
"""

from typing import Annotated

import pytest
from pydantic import BaseModel, ValidationError

from solver.constraints import parse_move, parse_spec
from solver.documents.deferred import OnFirstUse
from solver.documents.move import Move
from solver.documents.spec import Spec
from solver.documents.validation import validated
from solver.errors import SpecError

BASE = {"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}}, "fixed": ["a"], "handles": {"h": "b"}}
AXIS = {"point": [0, 0, 0], "direction": [0, 0, 1]}

SPECS = [  # (members, the errors' (loc, type), the library's message)
    ({"radius": [{"name": 1, "selection": "b", "extra": 2}]},
     [(("radius", 0, "name"), "string_type"), (("radius", 0, "extra"), "extra_forbidden")],
     "SPEC.radius[0].name: Input should be a valid string, got 1 (and 1 more)"),
    ({"radius": ({"name": "r", "selection": "b"},)}, [(("radius",), "list_type")],
     "SPEC.radius: Input should be a valid list, got ({'name': 'r', 'selection': 'b'},)"),
    ({"radius": [{"name": "r", "selection": "b"}] * 3 + ["x"]}, [(("radius", 3), "model_type")],
     "SPEC.radius[3]: Input should be a valid dictionary or instance of Radius, got 'x'"),
    ({"twist": [{"name": "t", "selection": "b", "axis": AXIS, "mode": "bend"}]}, [(("twist", 0), "value_error")],
     "SPEC.twist[0]: mode 'bend' needs toward, the direction the axis curves to"),
    ({"lattice": [{"name": "l", "box": {"min": [0, 0, 0], "max": [1, 1, 1]}, "counts": [2, 2, True]}]},
     [(("lattice", 0, "counts", 2), "int_type")],
     "SPEC.lattice[0].counts[2]: Input should be a valid integer, got True"),
    ({"angle": None}, [(("angle",), "list_type")], "SPEC.angle: Input should be a valid list, got None"),
    ({"points": [{"name": "p", "edge": [0, 1]}, {"name": "q", "face": [0, 1, 2], "barycentric": [0.5, 0.5, 0.5]}]},
     [(("points", 0), "value_error"), (("points", 1), "value_error")],
     "SPEC.points[0]: an edge point needs t, its position along the edge in [0, 1] (and 1 more)"),
    ({"motion": [{"name": "m", "selection": "a"}]}, [(("motion", 0), "value_error")],
     "SPEC.motion[0]: needs exactly one of plane or line"),
    ({"symmetry": [{"name": "s", "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}}] * 101},
     [(("symmetry",), "too_long")], "SPEC.symmetry: List should have at most 100 items after validation, not 101"),
    ({"cyclic": [{"name": "c", "axis": AXIS, "angle_deg": 720, "faces": ["a", "b"]}]}, [(("cyclic", 0), "value_error")],
     "SPEC.cyclic[0]: angle_deg must not be a multiple of 360, got 720"),
]

MOVES = [
    ({"radius": {"r": {"radius": 1, "delta": 1}}}, [(("radius", "r"), "value_error")],
     "MOVE.radius.r: needs exactly one of radius or delta"),
    ({"fillet": []}, [(("fillet",), "dict_type")], "MOVE.fillet: Input should be a valid dictionary"),
    ({"twist": {"t": {"table": [{"at": 0}]}}},
     [(("twist", "t", "table", "list[TwistAngle]", 0, "angle_deg"), "missing"), (("twist", "t", "table", "none"),
                                                                                "none_required")],
     "MOVE.twist.t.table[0].angle_deg: Field required"),
    ({"relative": {"r": {"offset": [0, 0, 1], "scale": 2}}, "features": {"f": {"scale": -1}}},
     [(("relative", "r"), "value_error"), (("features", "f", "scale"), "greater_than_equal")],
     "MOVE.relative.r: needs exactly one of offset or scale (and 1 more)"),
]


def _errors(model, doc):
    with pytest.raises(ValidationError) as e:
        model.model_validate(doc)
    return [(tuple(err["loc"]), err["type"]) for err in e.value.errors()]


@pytest.mark.parametrize(("members", "errors", "message"), SPECS)
def test_a_spec_member_validated_on_first_use_is_named_as_before(members, errors, message):
    doc = {**BASE, **members}
    assert _errors(Spec, doc) == errors
    with pytest.raises(SpecError) as e:
        parse_spec(doc)
    assert str(e.value) == message
    assert e.value.details["errors"][0]["loc"] == list(errors[0][0])


@pytest.mark.parametrize(("members", "errors", "message"), MOVES)
def test_a_move_member_validated_on_first_use_is_named_as_before(members, errors, message):
    assert _errors(Move, members) == errors
    with pytest.raises(SpecError) as e:
        validated(Move, members, "MOVE")
    assert str(e.value) == message


def test_the_validation_context_reaches_a_member_validated_on_first_use():
    doc = {**BASE, "targets": [{"name": "t", "selection": "a", "surface": "part.stl"}]}
    with pytest.raises(SpecError) as e:
        validated(Spec, doc, "SPEC")
    assert str(e.value) == ("SPEC.targets[0]: the surface is a stored surface {mesh_id} or {vertices, triangles}; "
                            "a file path is read by the library, never by the service")
    assert validated(Spec, doc, "SPEC", context={"files": True}).targets[0].surface == "part.stl"


def test_members_validated_on_first_use_hold_their_models_and_dump_as_given():
    doc = {**BASE, "radius": [{"name": "bore", "selection": "b", "axis": AXIS}],
           "points": [{"name": "p", "edge": [0, 1], "t": 0.25}],
           "cyclic": [{"name": "c", "axis": AXIS, "angle_deg": 90.0, "faces": ["a", "b"]}]}
    spec = Spec.model_validate(doc)
    assert type(spec.radius[0]).__name__ == "Radius" and spec.radius[0].axis.direction == [0.0, 0.0, 1.0]
    assert spec.dump() == doc
    assert [e.name for e in parse_spec(doc).edits] == ["bore"]
    move = {"handles": {"h": {"translation": [0, 0, 1]}}, "radius": {"bore": {"radius": 2.0}},
            "targets": {"t": {"amount": 0.5}}}
    assert Move.model_validate(move).dump() == move
    assert parse_move(move, ["h"], {"radius": ["bore"], "targets": ["t"]}).edits["radius"]["bore"].radius == 2.0


def test_an_empty_member_is_a_new_empty_value_and_other_containers_are_refused():
    given: list = []
    spec = Spec.model_validate({**BASE, "radius": given, "points": given})
    assert spec.radius == [] and spec.radius is not given and spec.points is not given
    assert _errors(Move, {"radius": {}, "relative": []}) == [(("relative",), "dict_type")]


def test_on_first_use_gives_the_types_schema_and_validates_strictly():
    class Doc(BaseModel):
        xs: Annotated[list[int], OnFirstUse(2)] = []

    assert Doc.model_json_schema() == {"properties": {"xs": {"default": [], "items": {"type": "integer"},
                                                             "maxItems": 2, "title": "Xs", "type": "array"}},
                                       "title": "Doc", "type": "object"}
    assert Doc(xs=[1, 2]).xs == [1, 2]
    with pytest.raises(ValidationError) as e:
        Doc(xs=[1, "2"])
    assert [(err["loc"], err["type"]) for err in e.value.errors()] == [(("xs", 1), "int_type")]
    with pytest.raises(ValidationError) as e:
        Doc(xs=[1, 2, 3])
    assert [(err["loc"], err["type"]) for err in e.value.errors()] == [(("xs",), "too_long")]


def test_a_member_validated_on_first_use_copies_as_a_field_does():
    import copy

    field = copy.deepcopy(Spec.model_fields["points"])
    assert any(isinstance(m, OnFirstUse) for m in field.metadata)
