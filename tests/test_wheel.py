"""``pip wheel .`` builds a wheel with the compiled core, and the numerics pass from it, away from the tree.

The wheel is installed into a new virtualenv in a temporary folder. That
virtualenv sees this one's third-party packages (numpy, scipy, pytest...)
through a path file, but not the project's editable install, so ``solver``
and ``tetmorph_core`` come from the wheel alone; the probe checks it. The
numerics tests run from a copy of ``tests/`` in that folder.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow

#: The numerics: the compiled kernels' callers, end to end.
NUMERICS = ["tests/solver/linalg", "tests/solver/ops", "tests/solver/validity", "tests/solver/deform"]

PROBE = """
import json, sys, solver, tetmorph_core
from solver import load_kernels
load_kernels()
print(json.dumps([solver.__file__, tetmorph_core.__file__, "numba" in sys.modules]))
"""


def _run(cmd: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess[str]:
    from solver.linalg.pardiso import mkl_runtime

    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    if mkl_runtime():  # MKL's library lies in this virtualenv's prefix, not the new one's: say where
        env["TETMORPH_MKL_RT"] = str(mkl_runtime())
    out = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, f"{' '.join(cmd)} failed:\n{out.stdout[-4000:]}\n{out.stderr[-4000:]}"
    return out


@pytest.fixture(scope="module")
def wheel_env(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the new virtualenv's python, the work folder holding a copy of tests/)."""
    tmp = tmp_path_factory.mktemp("wheel")
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp / "dist"), str(ROOT)], tmp, 900)
    wheels = sorted((tmp / "dist").glob("tetmorph-*.whl"))
    assert len(wheels) == 1, wheels
    base = getattr(sys, "_base_executable", sys.executable)
    _run([base, "-m", "venv", str(tmp / "venv")], tmp, 300)
    python = tmp / "venv" / "bin" / "python"
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp,
                     60).stdout.strip())
    # this virtualenv's third-party packages, appended after the new one's own: a plain path line, so the
    # editable install's own path files there are not run
    (site / "third_party.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([str(python), "-m", "pip", "install", "--no-deps", "--no-index", "-q", str(wheels[0])], tmp, 300)
    work = tmp / "work"
    shutil.copytree(ROOT / "tests", work / "tests", ignore=shutil.ignore_patterns("__pycache__", "artifacts"))
    shared = ROOT.parent / "shared"
    if shared.exists():
        (tmp / "shared").symlink_to(shared)
    (work / "pytest.ini").write_text("[pytest]\nmarkers =\n    slow: s\n    fuzz: f\n    ccx: c\n")
    return python, work


def test_the_wheel_installs_the_compiled_core_and_the_solver_away_from_the_tree(wheel_env):
    python, work = wheel_env
    last = _run([str(python), "-c", PROBE], work, 300).stdout.strip().splitlines()[-1]
    solver_file, core_file, numba = json.loads(last)
    venv = python.parent.parent
    assert Path(solver_file).is_relative_to(venv), solver_file
    assert Path(core_file).is_relative_to(venv), core_file
    assert Path(core_file).suffix == ".so"
    assert not numba, "a set-up imported numba"


def test_the_numerics_tests_pass_against_the_installed_wheel(wheel_env):
    python, work = wheel_env
    out = _run([str(python), "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", "-m", "not slow", *NUMERICS],
               work, 1500)
    assert " passed" in out.stdout.splitlines()[-1], out.stdout[-2000:]
