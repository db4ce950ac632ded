"""``import solver`` stays light, and so does a first set-up: heavy modules load only when used."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Modules a first set-up does not need: loaded only when used.
HEAVY = ["scipy.optimize", "scipy.spatial", "meshio", "h5py", "pyvista", "vtk", "service", "fastapi",
         "pydantic_settings", "numba", "igl", "matplotlib"]

PROBE = """
import json, sys
import solver
from solver.kernels import loaded
before = sorted(m for m in sys.modules if m.split(".")[0] in HEAVY or m in HEAVY)
was = loaded()
took = solver.load_kernels()
after = sorted(m for m in sys.modules if m.split(".")[0] in HEAVY or m in HEAVY)
print(json.dumps([before, was, loaded(), after, took, "tetmorph_core" in sys.modules]))
"""


def _probe() -> list:
    code = f"HEAVY = {HEAVY!r}\n" + PROBE
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True,
                         timeout=300)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_importing_solver_loads_no_heavy_module_and_load_kernels_loads_the_core():
    before, was, now, after, took, core = _probe()
    assert before == [], f"import solver loaded {before}"
    assert after == [], f"a first set-up loaded {after}"
    assert (was, now, core) == (False, True, True)
    assert took > 0
