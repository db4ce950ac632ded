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


#: What only a SPEC or MOVE naming an edit needs: its modules (models, entries, values, resolution).
EDIT_MODULES = ["solver.documents.edits", "solver.documents.edit_moves", "solver.constraints.edit_entries",
                "solver.constraints.edit_values", "solver.constraints.edits", "solver.constraints.feature_edits",
                "solver.constraints.resolve_edits", "solver.constraints.projections"]

PLAIN = """
import json, sys
import solver
from solver import mesh_from_arrays, precompute
from solver.testing import cube_mesh
from solver.documents import move, spec
solver.load_kernels()
d = precompute(mesh_from_arrays(*cube_mesh(2)), {"selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
               "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}}, "fixed": ["a"], "handles": {"b": "b"}})
r = d.solve({"handles": {"b": {"translation": [0, 0, 0.1], "rotation": {"axis": [0, 0, 1], "angle_deg": 5}}}})
loaded = [m for m in EDIT_MODULES if m in sys.modules]
models = (spec.Point, spec.Relative, spec.Motion, spec.Target, spec.Cyclic, move.RelativeMove, move.TargetMove)
built = [m.__name__ for m in models if m.__pydantic_complete__]
s = solver.parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}}, "fixed": ["a"],
                       "radius": [{"name": "bore", "selection": "b",
                                   "axis": {"point": [0, 0, 0], "direction": [0, 0, 1]}}]})
m = solver.parse_move({"radius": {"bore": {"delta": 0.5}}}, [], s.names)
print(json.dumps([loaded, built, r.report["inverted_elements"], [m for m in EDIT_MODULES if m not in sys.modules],
                  [type(e).__name__ for e in s.edits], m.to_dict()["radius"]]))
"""


def test_a_first_set_up_without_edits_loads_no_edit_module_and_builds_no_model_it_does_not_use():
    code = f"EDIT_MODULES = {EDIT_MODULES!r}\n" + PLAIN
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True,
                         timeout=300)
    loaded, built, inverted, absent, edits, value = json.loads(out.stdout.strip().splitlines()[-1])
    assert loaded == [], f"a set-up without edits loaded {loaded}"
    assert built == [], f"a set-up with none of them built the models {built}"
    assert inverted == 0
    # a SPEC and a MOVE that name an edit load what it needs, on first use
    parsing = ["solver.documents.edits", "solver.documents.edit_moves", "solver.constraints.edit_entries",
               "solver.constraints.edit_values"]
    assert not set(parsing) & set(absent), absent
    assert (edits, value) == (["RadiusEntry"], {"bore": {"delta": 0.5}})


def test_a_complete_load_builds_what_only_some_documents_use():
    code = (f"EDIT_MODULES = {EDIT_MODULES!r}\n" "import json, sys, solver\n"
            "from solver.documents.deferred import OnFirstUse\n"
            "from solver.documents.move import Move\n" "from solver.documents.spec import Spec\n"
            "solver.load_kernels(complete=True)\n"
            "members = [m for M in (Spec, Move) for f in M.model_fields.values() for m in f.metadata\n"
            "           if isinstance(m, OnFirstUse)]\n"
            "print(json.dumps([[m for m in EDIT_MODULES if m not in sys.modules], len(members),\n"
            "                  sum(not m.built for m in members)]))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True,
                         timeout=300)
    absent, members, unbuilt = json.loads(out.stdout.strip().splitlines()[-1])
    assert absent == [] and members == 8 + 8 + 8 + 4 and unbuilt == 0  # SPEC: 8 edits, 8 others; MOVE: 8 + 4
