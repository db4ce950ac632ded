"""What the service does at start, before it answers: its compiled kernels loaded (setting ``load_kernels``)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import json, sys, tempfile
from fastapi.testclient import TestClient
from service.app import create_app
from solver.kernels import loaded
app = create_app(data_dir=tempfile.mkdtemp(), load_kernels=sys.argv[1] == "1")
with TestClient(app) as c:
    ready = c.get("/ready").status_code
    print(json.dumps([ready, loaded()]))
"""


@pytest.mark.parametrize("load", [True, False])
def test_the_service_loads_its_kernels_before_it_answers_unless_told_not_to(load):
    out = subprocess.run([sys.executable, "-c", PROBE, "1" if load else "0"], cwd=ROOT, capture_output=True,
                         text=True, check=True, timeout=300)
    ready, loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert ready == 200
    assert loaded == load


def test_sessions_are_built_with_the_services_solve_options(tmp_path):
    from service.settings import Settings
    from solver import SolveOptions
    from solver.linalg import factorization as fz
    from tests.conftest import DATA

    from .conftest import running

    assert Settings(data_dir=tmp_path, solve_reference=True).solve_options() == SolveOptions.reference()
    assert Settings(data_dir=tmp_path, solve_backend="scipy").solve_options().backend == "scipy"
    spec = {"selections": {"a": {"set": "FIXED"}, "b": {"set": "LOAD"}}, "fixed": ["a"], "handles": {"b": "b"}}
    for settings, backend in (({"solve_backend": "scipy"}, "scipy"), ({}, None)):
        with running(tmp_path / str(len(settings)), load_kernels=False, **settings) as tc:
            mid = tc.post("/v1/meshes", files=[("file", ("bracket.inp", (DATA / "bracket.inp").read_bytes()))])
            r = tc.post("/v1/sessions", json={"mesh_id": mid.json()["id"], "spec": spec})
            assert r.status_code in (201, 202), r.text
            got = tc.post(f"/v1/sessions/{r.json()['id']}/deform?result=report",
                          json={"handles": {"b": {"translation": [0, 0, 1]}}}).json()["report"]["backend"]
            assert got == (backend or fz.backend())  # the default: the environment's choice, as in the library
