"""Fixtures for the service tests: an app on a temporary data directory, the client."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.client import Client
from tests.conftest import DATA

BRACKET = DATA / "bracket.inp"
BRACKET_SPEC: dict[str, Any] = {
    "selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}},
    "fixed": ["root"], "handles": {"tip": "tip"},
}
MOVES: list[dict[str, Any]] = [
    {"handles": {"tip": {"translation": [0.0, 0.0, 4.0]}}},
    {"handles": {"tip": {"translation": [0.0, 2.0, -3.0],
                         "rotation": {"axis": [1, 0, 0], "angle_deg": 15}}}},
    {"handles": {"tip": {"translation": [5.0, 0.0, 0.0], "scale": 1.05}}},
]
BEAM_SPEC = json.loads((DATA.parent.parent / "examples" / "beam" / "spec.json").read_text())


@contextlib.contextmanager
def running(data_dir: Any, **settings: Any) -> Iterator[TestClient]:
    """A TestClient of a fresh app (lifespan started) on ``data_dir``."""
    app = create_app(data_dir=data_dir, **settings)
    with TestClient(app, raise_server_exceptions=False) as tc:
        yield tc


@pytest.fixture
def tc(tmp_path) -> Iterator[TestClient]:
    with running(tmp_path / "data") as c:
        yield c


@pytest.fixture
def client(tc) -> Client:
    return Client(http=tc)


def upload_bracket(client: Client) -> dict[str, Any]:
    return client.upload_mesh(BRACKET)


def err(r) -> dict[str, Any]:
    """The error envelope of a response, checking its shape."""
    body = r.json()
    assert set(body) == {"error"}, body
    e = body["error"]
    assert {"status", "code", "type", "message", "details"} <= set(e), e
    assert e["status"] == r.status_code
    return e


@pytest.fixture(scope="session")
def bracket_library():
    """The library's result for each MOVE, to compare the service against."""
    from solver import read_mesh
    from solver.deform.deformer import precompute

    d = precompute(read_mesh(BRACKET), BRACKET_SPEC)
    return d, [d.solve(m).V for m in MOVES]
