"""The schema states the constraints the validation applies, and what it states is accepted.

Each case is a request the schema used to allow and the service refused (found by
tests/service/test_schema_agrees.py); the schema now says so, and values at the edge of what
it allows pass the validation.
"""

from __future__ import annotations

import re

import jsonschema
import pytest
from pydantic import ValidationError

from service.app import create_app
from service.formats import SURFACE_FORMATS, offered, resolve_format
from service.models.batch import BatchCreate, BoundsQuery, PlanTable, StudyCreate
from service.models.formats import MESH_FORMAT_VALUES, SURFACE_FORMAT_VALUES, UPLOAD_FORMAT_VALUES
from service.models.session import Preset
from service.models.spec import Selection
from service.models.uploads import MeshArrays
from solver.documents.shapes import RESERVED, SHAPE_NAME_SCHEMA
from solver.documents.text import BLANKS, HAS_TEXT, NAME_START, NOT_A_NAME, ONE_LINE


@pytest.fixture(scope="module")
def doc(tmp_path_factory):
    return create_app(data_dir=tmp_path_factory.mktemp("schema")).openapi()


def _ok(doc, name, value) -> bool:
    schema = {"$ref": f"#/components/schemas/{name}", "components": doc["components"]}
    return jsonschema.Draft202012Validator(schema).is_valid(value)


def test_integral_numbers_are_integers_for_the_schema_and_the_validation():
    assert Selection.model_validate({"ids": [3.0, 4]}).ids == [3, 4]
    assert BatchCreate.model_validate({"shapes": {"a": {}}, "plan": "a\n1\n", "block": 8.0}).block == 8
    for bad in (3.5, True, "3"):
        with pytest.raises(ValidationError):
            Selection.model_validate({"ids": [bad]})


def test_a_selection_has_exactly_one_kind_and_no_nulls(doc):
    assert _ok(doc, "Selection", {"set": "A"}) and _ok(doc, "Selection", {"ids": [0], "boundary_only": True})
    for bad in ({}, {"set": "A", "ids": [0]}, {"box": None}, {"set": None}, {"boundary_only": True}):
        assert not _ok(doc, "Selection", bad), bad


def test_mesh_arrays_state_their_row_lengths_and_need_elements(doc):
    v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    good = {"vertices": v, "tetrahedra": [[0, 1, 2, 3]]}
    assert _ok(doc, "MeshArrays", good) and _ok(doc, "MeshArrays", {"vertices": v, "triangles": [[0, 1, 2]]})
    MeshArrays.model_validate(good)
    for bad in ({"vertices": v[:3], "tetrahedra": [[0, 1, 2, 3]]}, {"vertices": [[0.0, 0.0]] + v[1:],
                "tetrahedra": [[0, 1, 2, 3]]}, {"vertices": v, "tetrahedra": [[0, 1, 2]]},
                {"vertices": v, "tetrahedra": [], "triangles": []}, {"vertices": v}):
        assert not _ok(doc, "MeshArrays", bad), bad
    with pytest.raises(ValidationError):
        MeshArrays.model_validate({"vertices": v, "tetrahedra": [[0, 1, 2]]})


def test_every_format_the_schema_offers_is_one_the_service_resolves(doc):
    for values, allowed in ((MESH_FORMAT_VALUES, offered()), (UPLOAD_FORMAT_VALUES, {**offered(), **SURFACE_FORMATS}),
                            (SURFACE_FORMAT_VALUES, SURFACE_FORMATS)):
        assert values and all(resolve_format(v, None, allowed)[0] in allowed for v in values)
    file_query = next(p for p in doc["paths"]["/v1/meshes/{mesh_id}/file"]["get"]["parameters"]
                      if p["name"] == "format")
    assert file_query["schema"]["enum"] == MESH_FORMAT_VALUES
    upload = doc["components"]["schemas"]["Body_upload_mesh_v1_meshes_post"]["properties"]
    assert upload["format"]["enum"] == UPLOAD_FORMAT_VALUES and "anyOf" not in upload["companions"]


def _shapes_parser_takes(name: str) -> bool:
    """The rule of solver.workflows.shapes.parse_shapes for a shape name."""
    return bool(name) and name == name.strip() and all(ord(c) >= 32 for c in name) and name not in RESERVED


def _admitted(name: str) -> bool:
    """What the schema of a trimmed name admits, read as a Python client reads it."""
    return 1 <= len(name) <= 200 and bool(re.search(NAME_START, name)) and not re.search(NOT_A_NAME, name)


def test_shape_names_and_plan_columns_state_what_the_shapes_parser_asks():
    for name in ("bend", "hole 1", "a\u00e9b"):
        assert _admitted(name) and _shapes_parser_takes(name)
    for name in (" bend", "bend ", "a\x1cb", "\x1db", "b\u3000", "", "a\nb", "a\n"):
        assert not _admitted(name), repr(name)
    for c in map(chr, range(0x3001)):  # every name the pattern admits is one the parser takes
        for name in (c, f"a{c}", f"{c}a", f"a{c}b"):
            if _admitted(name):
                assert _shapes_parser_takes(name), repr(name)
    for model in (BoundsQuery, BatchCreate, StudyCreate):
        shapes = model.model_json_schema()["properties"]["shapes"]
        assert shapes["propertyNames"] == SHAPE_NAME_SCHEMA
    columns = PlanTable.model_json_schema()["properties"]["columns"]
    assert columns["uniqueItems"] is True and columns["items"] == SHAPE_NAME_SCHEMA
    # the schema refuses what the parser refuses beyond the pattern: the DOE summary's own columns
    names = jsonschema.Draft202012Validator(SHAPE_NAME_SCHEMA)
    for name in RESERVED:
        assert not names.is_valid(name) and not _shapes_parser_takes(name), name
    for name in ("bend", "hole 1", "statuses"):
        assert names.is_valid(name) and _shapes_parser_takes(name), name
    rows = PlanTable.model_json_schema()["properties"]["rows"]
    assert rows["items"]["items"] == {"type": "number"}
    rng = BoundsQuery.model_json_schema()["properties"]["range"]
    assert rng["prefixItems"] == [{"maximum": 0}, {"minimum": 0}]


def test_the_blanks_are_pythons_white_space():
    blank = re.compile(f"[{BLANKS}]")
    assert [c for c in map(chr, range(0x110000)) if c.isspace()] == [c for c in map(chr, range(0x110000))
                                                                      if blank.fullmatch(c)]


def test_a_preset_name_needs_text_by_the_schema_pattern_and_by_the_validation():
    for name in ("lift", " a ", "\u00a0x"):
        assert re.search(HAS_TEXT, name)
        Preset.model_validate({"name": name, "move": {}})
    for name in (" ", "\x1d ", "\u3000\t"):
        assert not re.search(HAS_TEXT, name)
        with pytest.raises(ValidationError):
            Preset.model_validate({"name": name, "move": {}})
    assert Preset.model_json_schema()["properties"]["name"]["pattern"] == HAS_TEXT


def test_the_cursor_and_metrics_patterns_admit_what_the_routes_take(doc):
    sessions = {p["name"]: p["schema"] for p in doc["paths"]["/v1/sessions"]["get"]["parameters"]}
    assert sessions["cursor"]["not"] == ONE_LINE["not"]  # a Python $ would take "1-a\n"
    cursor = sessions["cursor"]["anyOf"][0]["pattern"]
    assert re.search(cursor, "1764579600000000-s_0a1b") and not re.search(cursor, "0") and not re.search(cursor, "x-1")
    quality = {p["name"]: p["schema"] for p in doc["paths"]["/v1/sessions/{session_id}/quality"]["get"]["parameters"]}
    metrics = quality["metrics"]["pattern"]
    for good in ("volume", "volume, aspect_ratio", ",volume,,"):
        assert re.search(metrics, good), good
    for bad in ("", ",", "volumes", "volume aspect_ratio", "in_flight_reset"):
        assert not re.search(metrics, bad), bad
