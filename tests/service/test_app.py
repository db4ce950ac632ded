"""Property-based tests of the whole HTTP API from its OpenAPI schema (schemathesis).

Every operation gets generated requests, valid and invalid; none may answer
5xx, every status answered must be one the schema documents for the route,
and JSON bodies must match their documented schemas. Path ids point at the
demo mesh and session (real resources) half the time, and the MOVE schema's
example names the demo's handle, so deforms, downloads and resets run for
real, not only 404s. Sized for CI: ``max_examples`` per operation.
"""

from __future__ import annotations

import shutil
import tempfile

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import response_schema_conformance, status_code_conformance

from service.app import create_app
from service.demo import DEMO_MESH, DEMO_SESSION

from .st_transport import send

pytestmark = pytest.mark.fuzz  # generated requests: make test, not make check
_DATA = tempfile.mkdtemp(prefix="tetmorph-schema-")
app = create_app(data_dir=_DATA, demo=True, rate_limit_per_s=0, max_sessions=100_000, job_wait_s=30)
_client = TestClient(app)
_client.__enter__()  # run the lifespan once: the demo mesh and session exist
schema = schemathesis.openapi.from_dict(app.openapi())  # cases go through the client (st_transport)


@schema.parametrize()
@settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))
def test_no_request_answers_5xx_or_an_undocumented_status(case):
    params = case.path_parameters or {}
    if case.method != "DELETE" and hash(repr(case.query)) % 2 == 0:
        if "session_id" in params:
            params["session_id"] = DEMO_SESSION
        if "mesh_id" in params:
            params["mesh_id"] = DEMO_MESH
    response = send(_client, case)
    case.validate_response(response, checks=[not_a_server_error, status_code_conformance,
                                             response_schema_conformance])
    assert response.status_code < 500, response.text
    if response.status_code >= 400:
        body = response.json()
        assert body["error"]["status"] == response.status_code


def test_openapi_documents_the_envelope_and_the_documents():
    doc = app.openapi()
    assert "HTTPValidationError" not in str(doc)
    names = set(doc["components"]["schemas"])
    assert {"Spec", "Move", "Report", "ErrorEnvelope", "SessionDoc", "MeshDoc", "JobDoc", "FormatInfo"} <= names
    deform = doc["paths"]["/v1/sessions/{session_id}/deform"]["post"]
    assert {"200", "401", "404", "410", "422", "429", "500"} <= set(deform["responses"])
    assert deform["requestBody"]["content"]["application/json"]["schema"]["$ref"].endswith("/Move")


def teardown_module():
    """End the module's one lifespan (its workers and stores) and remove its data folder."""
    _client.__exit__(None, None, None)
    shutil.rmtree(_DATA, ignore_errors=True)
