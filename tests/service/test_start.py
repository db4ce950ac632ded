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
from solver.validity.check import _sj_kernel
app = create_app(data_dir=tempfile.mkdtemp(), load_kernels=sys.argv[1] == "1")
with TestClient(app) as c:
    ready = c.get("/ready").status_code
    print(json.dumps([ready, len(_sj_kernel.signatures)]))
"""


@pytest.mark.parametrize("load", [True, False])
def test_the_service_loads_its_kernels_before_it_answers_unless_told_not_to(load):
    out = subprocess.run([sys.executable, "-c", PROBE, "1" if load else "0"], cwd=ROOT, capture_output=True,
                         text=True, check=True, timeout=300)
    ready, loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert ready == 200
    assert (loaded > 0) == load
