"""``solver.load_kernels`` leaves every kernel a set-up uses loaded in the process."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Kernels of the stages of a set-up: the interior matrix, the element check (its selection of a
#: large mesh too), the sweeps.
PROBE = """
import json, solver
from solver.ops.mvc_matrix import _fill_rows
from solver.validity.check import _gather_between, _sj_kernel
from solver.linalg.sweeps import _sweep3
ks = [_fill_rows, _sj_kernel, _gather_between, _sweep3]
before = [len(k.signatures) for k in ks]
solver.load_kernels()
print(json.dumps([before, [len(k.signatures) for k in ks]]))
"""


def test_load_kernels_loads_the_kernels_a_set_up_runs():
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, capture_output=True, text=True, check=True,
                         timeout=300)
    before, after = eval(out.stdout.strip().splitlines()[-1])
    assert before == [0, 0, 0, 0]  # importing solver loads none (import stays cheap)
    assert all(n >= 1 for n in after), after
