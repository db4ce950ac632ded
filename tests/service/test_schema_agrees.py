"""The OpenAPI schema says what the validation enforces: schema-valid requests are accepted (schemathesis).

Every request schemathesis generates as valid for the schema (positive mode) goes to the real
app, path ids pointing at the demo mesh and session, and must not be refused, with the
responses conforming to the schema (status, content type, JSON body). A schema-valid request
may still be refused for what a JSON Schema cannot state; those refusals are listed in
:data:`BEYOND_THE_SCHEMA`, each with why, and matched by their typed code and details, so that
any other refusal fails the test (schemathesis's ``positive_data_acceptance`` check).

Strings are generated without NUL: the service refuses a NUL anywhere a request carries text
(``service.api.deps.refuse_nul``, one rule for every field: PostgreSQL cannot store it), a rule of
the transport that the schema does not repeat on each string.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable
from typing import Any

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis import GenerationMode
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    positive_data_acceptance,
    response_schema_conformance,
    status_code_conformance,
)

from service.app import create_app
from service.demo import DEMO_MESH, DEMO_SESSION

from .st_transport import send

pytestmark = pytest.mark.fuzz  # generated requests: make test, not make check
_DATA = tempfile.mkdtemp(prefix="tetmorph-positive-")
app = create_app(data_dir=_DATA, demo=True, rate_limit_per_s=0, max_sessions=100_000, job_wait_s=30)
client = TestClient(app)
client.__enter__()  # the demo mesh and session exist; the one lifespan of the run
schema = schemathesis.openapi.from_dict(app.openapi())  # cases go through the client (st_transport)
schema.config.generation.update(modes=[GenerationMode.POSITIVE], allow_x00=False)

Refusal = Callable[[dict[str, Any], Any], bool]


def _always(err: dict[str, Any], case: Any) -> bool:
    return True


def _csv_plan(err: dict[str, Any], case: Any) -> bool:
    return isinstance(case.body, dict) and isinstance(case.body.get("plan"), str)


#: Refusals of schema-valid requests that depend on what a JSON Schema cannot state, by error code:
#: (why, which refusals of that code qualify). Every other refusal of a schema-valid request fails.
#: Words of the refusals of relations the schema cannot state (see invalid_request below).
_RELATIONS = ("names are unique", "exceeds max", "non-zero", "sum to 1", "sum to zero", "multiple of 360",
              "strictly increasing 'at'", "needs toward", "runs along the axis", "goes with mode",
              "needs a direction", "maps onto a surface", "goes with projection", "needs an opposite",
              "another selection than", "positive extent", "needs exactly one of", "has exactly one of",
              "[key]: String should match pattern", "one per vertex",
              "String should match pattern '^(0|[1-9][0-9]?),")  # a lattice key, as the library names it


def _relation(e: dict) -> bool:
    """The refusal names such a relation (in its message, or in one of the errors the library lists)."""
    messages = [e["message"], *(str(x.get("message", "")) for x in e["details"].get("errors", []))]
    return any(t in m for m in messages for t in _RELATIONS)


BEYOND_THE_SCHEMA: dict[str, tuple[str, Refusal]] = {
    # the session's SPEC and the mesh (state): names a MOVE or SHAPES use must be the SPEC's; ids, sets
    # and positions must fit the mesh
    "invalid_spec": ("a MOVE names a handle, point, feature, motion, relative or target the session's SPEC "
                     "lacks; or a SPEC or MOVE body breaks one of the relations listed under invalid_request "
                     "(a SPEC or MOVE answers the library's code for them, invalid_spec)",
                     lambda e, c: "unknown" in e["details"] or _relation(e)),
    "unknown_set": ("the mesh has no set of that name", _always),
    "out_of_range": ("a position or length beyond 100 bounding-box diagonals of the session's mesh", _always),
    "index_out_of_range": ("a vertex id beyond the mesh's vertex count (the stored mesh's, or the vertices "
                           "of the same request)", _always),
    "empty_selection": ("the selection selects no vertex of this mesh", _always),
    "empty_band": ("the band holds no boundary face of this mesh", _always),
    "unwritable_format": ("a format written back in place only (GET /v1/formats: converts_to false) takes the "
                          "meshes read from it, not this one, read from another format",
                          lambda e, c: e["details"].get("in_place_only") is True),
    "band_not_separating": ("the band does not cut this mesh's surface in two", _always),
    "element_sets_unsupported": ("result=elset on a mesh whose file format has no element sets (the demo "
                                 "beam is TetGen): the stored mesh's format", _always),
    "repeated_index": ("an element repeats a vertex (a relation between the numbers of one row)", _always),
    "unknown_shape": ("a plan column names no shape of the same request (keys of another field)", _always),
    "invalid_plan": ("a plan row has another number of cells than the header has columns, or a CSV text "
                     "plan does not parse", lambda e, c: "cells" in e["message"] or _csv_plan(e, c)),
    "empty_plan": ("a CSV text plan with no header or no row (the text's content)", _csv_plan),
    "invalid_request": ("two presets of one name (uniqueItems compares whole items, not one field); or "
                        "relations between the numbers of one array or object: a box's min above its max, a "
                        "zero normal or direction, barycentric coordinates that do not sum to 1, weights that "
                        "sum to zero, a cyclic angle of whole turns, a twist table's rows in increasing 'at', "
                        "a bend's toward off its axis, a lattice box of positive extent; fields that one value "
                        "of another requires or excludes (a bend's toward, an 'along' projection's direction "
                        "onto a surface, a symmetric offset's other opposite selection, one of two forms of "
                        "an edit); or the pattern of an object's keys (a lattice's control point 'i,j,k': "
                        "propertyNames, which the generator does not apply)",
                        lambda e, c: _relation(e)),
    # the service's configuration
    "solver_unavailable": ("no FE solver of that name is configured (TETMORPH_STUDY_SOLVERS)", _always),
    "engine_unavailable": ("engine 'ray' without a Ray cluster (TETMORPH_RAY_ADDRESS)", _always),
    "too_many_rows": ("more plan rows than TETMORPH_BATCH_MAX_ROWS", _always),
}


#: Operations that take files: the schema types a file as bytes, so what its name and contents must be
#: (a known extension when no format is given, a readable mesh or surface of that format, a TetGen
#: .node with its .ele, names that do not clean to one) is beyond it. Their form fields are checked
#: as any other request's: an ``invalid_request``, or an ``unknown_format`` for a format given, fails.
FILE_OPERATIONS = {"POST /v1/meshes", "POST /v1/tetrahedralize"}


def _file_refusal(err: dict[str, Any], case: Any) -> bool:
    if case.operation.label not in FILE_OPERATIONS or err.get("code") == "invalid_request":
        return False
    given = isinstance(case.body, dict) and case.body.get("format") is not None
    return not (err.get("code") == "unknown_format" and given)


def beyond_the_schema(response: Any, case: Any) -> bool:
    """True for a refusal listed in :data:`BEYOND_THE_SCHEMA`, or of a file's name or contents."""
    if response.status_code < 400:
        return False
    try:
        err = response.json()["error"]
    except (ValueError, KeyError, TypeError):
        return False
    if not isinstance(err, dict):
        return False
    if _file_refusal(err, case):
        return True
    why = BEYOND_THE_SCHEMA.get(err.get("code"))
    return why is not None and why[1](err, case)


def _on_the_demo(case: Any) -> None:
    params = case.path_parameters or {}
    if "session_id" in params:
        params["session_id"] = DEMO_SESSION
    if "mesh_id" in params:
        params["mesh_id"] = DEMO_MESH


@schema.exclude(method="DELETE").parametrize()  # DELETE on fresh resources: test_delete_fresh.py
@settings(max_examples=20, deadline=None, suppress_health_check=list(HealthCheck))
def test_schema_valid_requests_are_accepted_and_answered_as_documented(case):
    _on_the_demo(case)
    response = send(client, case)
    case.validate_response(response, checks=[not_a_server_error, status_code_conformance, content_type_conformance,
                                             response_schema_conformance])
    if not beyond_the_schema(response, case):
        case.validate_response(response, checks=[positive_data_acceptance])


def teardown_module():
    """End the module's one lifespan (its workers and stores) and remove its data folder."""
    client.__exit__(None, None, None)
    shutil.rmtree(_DATA, ignore_errors=True)
