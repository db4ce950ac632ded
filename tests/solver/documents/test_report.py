"""The REPORT's model is built from the library's dataclass, and the REPORTs of real updates validate against it."""

from __future__ import annotations

import json
import typing
from dataclasses import field, fields, make_dataclass

import jsonschema
import pytest

from solver import mesh_from_arrays, precompute, read_mesh
from solver.documents.report import Report, report_model
from solver.documents.report_record import Report as LibraryReport
from solver.testing import cube_mesh

from ...conftest import DATA

CUBE_SPEC = {"selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                            "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
             "fixed": ["a"], "handles": {"top": "b"}}
LIFT = {"handles": {"top": {"translation": [0, 0, 0.1]}}}
CRUSH = {"handles": {"top": {"translation": [0, 0, -1.5]}}}  # inverts elements
SCHEMA = Report.model_json_schema(mode="serialization")


def _valid(report: dict) -> None:
    """``report`` has no key the model lacks and validates against the model and its JSON schema."""
    assert set(report) <= set(Report.model_fields), sorted(set(report) - set(Report.model_fields))
    jsonschema.Draft202012Validator(SCHEMA).validate(json.loads(json.dumps(report)))  # as a client reads it
    Report.model_validate(report)


@pytest.fixture(scope="module")
def cube():
    return precompute(mesh_from_arrays(*cube_mesh(3)), CUBE_SPEC)


@pytest.mark.parametrize("move,kw", [(LIFT, {}), (LIFT, {"quality": "full"}), (CRUSH, {"inversion": "clamp"}),
                                     (CRUSH, {"repair": True})])
def test_the_report_of_an_update_validates_against_the_model(cube, move, kw):
    _valid(cube.solve(move, **kw).report)


def test_the_report_of_a_quadratic_deck_validates_against_the_model():
    mesh = read_mesh(str(DATA / "ccx_bracket.inp"))
    d = precompute(mesh, {"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}}, "fixed": ["root"],
                          "handles": {"tip": "tip"}})
    report = d.solve({"handles": {"tip": {"translation": [0, 0, 2]}}}).report
    assert report["element_order"] == 2
    _valid(report)


def test_the_schema_requires_exactly_what_to_dict_always_writes(cube):
    """Every field that may be None set to None: what is left is what the schema requires."""
    report = LibraryReport(**cube.solve(LIFT).report)
    hints = typing.get_type_hints(LibraryReport)
    nullable = {f.name: None for f in fields(LibraryReport) if type(None) in typing.get_args(hints[f.name])}
    for order in (None, 2):  # a linear mesh leaves midside_relaxed out, a quadratic one keeps it
        sparse = report.with_(**nullable).with_(element_order=order).to_dict()
        assert set(sparse) == set(SCHEMA["required"]) | ({"element_order", "midside_relaxed"} if order else set())
        _valid(sparse)


def test_every_field_is_described():
    assert [f for f, s in SCHEMA["properties"].items() if not s.get("description")] == []


def test_a_field_added_to_the_dataclass_is_in_the_model_with_no_second_edit():
    extended = make_dataclass(
        "Extended", [("spare_ms", float, field(default=0.0, metadata={"description": "time spared"})),
                     ("note", str | None, field(default=None, metadata={"description": "a note"}))],
        bases=(LibraryReport,), frozen=True,
        namespace={"MAY_BE_LEFT_OUT": (*LibraryReport.MAY_BE_LEFT_OUT, "note")})
    schema = report_model(extended, "Extended").model_json_schema(mode="serialization")
    assert list(schema["properties"])[-2:] == ["spare_ms", "note"]
    assert schema["properties"]["spare_ms"] == {"anyOf": [{"type": "number"}, {"type": "null"}],  # NaN: null
                                                "description": "time spared", "title": "Spare Ms"}
    assert schema["properties"]["note"]["description"] == "a note"
    assert "spare_ms" in schema["required"] and "note" not in schema["required"]
    assert schema["description"] == SCHEMA["description"] and schema["examples"] == SCHEMA["examples"]


def test_the_schemas_example_is_a_whole_report_the_schema_takes():
    from solver.documents.report import EXAMPLES

    schema = Report.model_json_schema()
    for example in EXAMPLES:
        assert list(jsonschema.Draft202012Validator(schema).iter_errors(example)) == []
        assert set(schema["required"]) <= set(example)
    # a result that is not finite is written with nulls (JSON has no NaN), and still validates
    whole = dict(EXAMPLES[0], finite=False, max_displacement=None, constraint_residual_max=None,
                 min_scaled_jacobian=None)
    assert jsonschema.Draft202012Validator(schema).is_valid(whole)
    assert set(schema["required"]) == {f.name for f in fields(LibraryReport) if f.name not in
                                       LibraryReport.MAY_BE_LEFT_OUT}
