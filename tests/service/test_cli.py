"""The ``tetmorph`` command without the ``service`` extra, and the web-free ``solver`` package."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.conftest import DATA

ROOT = Path(__file__).resolve().parents[2]

# Make the web stack unimportable (as if the extra were not installed), then run the command. pydantic
# is not web code: the library's document models use it, so it is a dependency of the library itself.
BLOCKED = """
import sys
for m in ("fastapi", "starlette", "uvicorn", "pydantic_settings", "httpx", "multipart"):
    sys.modules[m] = None
from service.cli import main
code = main(sys.argv[1:])
leaked = sorted(m for m in ("fastapi", "starlette", "uvicorn") if sys.modules.get(m) is not None)
print("LEAKED", leaked, file=sys.stderr)
sys.exit(code)
"""


def _run(*args: str, code: str = BLOCKED) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env,
                          timeout=300, cwd=ROOT)


def test_info_and_morph_work_without_the_service_extra(tmp_path):
    r = _run("info", str(DATA / "bracket.inp"))
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["tetrahedra"] == 4228
    assert "LEAKED []" in r.stderr
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}},
                                "fixed": ["root"], "handles": {"tip": "tip"}}))
    move = tmp_path / "move.json"
    move.write_text(json.dumps({"handles": {"tip": {"translation": [0, 0, 1]}}}))
    out = tmp_path / "out.vtu"
    r = _run("morph", str(DATA / "bracket.inp"), "--spec", str(spec), "--move", str(move), "--output", str(out))
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 0 and "LEAKED []" in r.stderr


def test_serve_without_the_service_extra_says_how_to_install_it():
    from service.cli import EXIT_NO_SERVICE

    r = _run("serve", "--port", "1")
    assert r.returncode == EXIT_NO_SERVICE, (r.returncode, r.stderr)
    assert "pip install 'tetmorph[service]'" in r.stderr and "fastapi" in r.stderr
    assert "Traceback" not in r.stderr


def test_import_solver_loads_no_web_code():
    code = ("import sys, solver, solver.deform.deformer, solver.io, solver.constraints.features\n"
            "print(sorted(m for m in ('fastapi', 'pydantic', 'starlette', 'uvicorn', 'httpx') if m in sys.modules))")
    r = _run(code=code)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"
