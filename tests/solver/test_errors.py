"""Every typed error the solver raises for a SPEC, its constraints or its systems, provoked once.

(The file-reading codes are provoked in tests/solver/io, the workflow codes in
tests/solver/workflows; this file covers the constraint and factorization codes.)
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from solver import ConstraintError, FactorizationError, SpecError, mesh_from_arrays, precompute, read_mesh
from solver.linalg import factorization as fz
from solver.testing import cube_mesh
from tests.conftest import DATA, load


@pytest.fixture(scope="module")
def cube():
    return mesh_from_arrays(*cube_mesh(3))


def _spec(**extra):
    return {"selections": {"bottom": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                           "top": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
            "fixed": ["bottom"], "handles": {"top": "top"}, **extra}


def test_overlapping_constraints(cube):
    spec = _spec()
    spec["selections"]["top"] = {"box": {"min": [0, 0, 0], "max": [1, 1, 1]}}
    with pytest.raises(SpecError) as e:
        precompute(cube, spec)
    assert e.value.code == "overlapping_constraints" and e.value.details["ids"]


def test_no_boundary_vertex_for_a_rotating_relative_constraint(cube):
    inner = [int(i) for i in np.flatnonzero(cube.interior)[:2]]
    with pytest.raises(SpecError) as e:
        precompute(cube, _spec(relative=[{"name": "r", "vertices": inner, "mode": "rotate"}], solve="joint"))
    assert e.value.code == "no_boundary_vertex"


def test_constraint_on_a_free_void():
    m = load("cones_with_cavities.inp")
    shells = m.shell_labels
    void = int(np.flatnonzero(shells == shells.max())[0])
    spec = {"selections": {"a": {"box": {"min": [-1e9] * 3, "max": [1e9, 1e9, float(m.V[:, 2].min()) + 1e-6]}},
                           "b": {"box": {"min": [-1e9, -1e9, float(m.V[:, 2].max()) - 1e-6], "max": [1e9] * 3}}},
            "fixed": ["a"], "handles": {"h": "b"}, "points": [{"name": "p", "vertices": [void]}]}
    with pytest.raises(SpecError) as e:
        precompute(m, spec)
    assert e.value.code == "constraint_on_free_void"


def test_target_too_far(tmp_path):
    m = read_mesh(DATA / "plate.inp")
    far = {"vertices": [[0, 0, 50], [200, 0, 50], [0, 100, 50]], "triangles": [[0, 1, 2]]}
    spec = {"selections": {"top": {"set": "TOP"}, "fix": {"set": "BOTTOM"}}, "fixed": ["fix"], "handles": {},
            "targets": [{"name": "t", "selection": "top", "surface": far, "tolerance": 1.0}]}
    with pytest.raises(SpecError) as e:
        precompute(m, spec)
    assert e.value.code == "target_too_far" and e.value.details["nodes"]


def test_non_finite_matrix():
    with pytest.raises(FactorizationError) as e:
        fz.cholesky(sp.csr_matrix(np.array([[1.0, 0.0], [0.0, np.nan]])))
    assert e.value.code == "non_finite_matrix"


def test_singular_lu_through_pardiso():
    n = fz.LU_SMALL + 10  # large enough for PARDISO
    A = sp.identity(n, format="csr") + sp.random(n, n, density=2e-4, random_state=1, format="csr")
    A = sp.lil_matrix(A)
    A[5, :] = 0.0
    A[5, 5] = 0.0
    A = sp.csr_matrix(A)
    A.eliminate_zeros()
    if fz.lu_backend() != "pardiso":
        pytest.fail("MKL PARDISO is a dependency and should be the LU backend here")
    with pytest.raises(FactorizationError) as e:
        fz.lu(A + sp.csr_matrix((n, n)))
    assert e.value.code in ("singular_system", "factorization_failed")


def test_unknown_backend_is_named(tmp_path):
    import subprocess
    import sys

    code = ("from solver.linalg import factorization as f\n"
            "try:\n    f.backend()\nexcept f.FactorizationError as e:\n    print(e.code)")
    out = subprocess.run([sys.executable, "-c", code], env={"TETMORPH_SOLVER": "nonsense", "PATH": "/usr/bin:/bin"},
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "unknown_backend"


def test_unconstrained_shell_when_voids_are_refused():
    m = load("cones_with_cavities.inp")
    spec = {"selections": {"a": {"box": {"min": [-1e9] * 3, "max": [1e9, 1e9, float(m.V[:, 2].min()) + 1e-6]}},
                           "b": {"box": {"min": [-1e9, -1e9, float(m.V[:, 2].max()) - 1e-6], "max": [1e9] * 3}}},
            "fixed": ["a"], "handles": {"h": "b"}, "voids": "refuse"}
    with pytest.raises(ConstraintError) as e:
        precompute(m, spec)
    assert e.value.code == "unconstrained_shell"


def test_too_large_for_pardiso_indices():
    from solver.linalg.pardiso import check_index_range

    check_index_range(2**31 - 1, "fits")
    with pytest.raises(FactorizationError) as e:
        check_index_range(2**31, "interior mean-value system")
    assert e.value.code == "too_large" and e.value.details["nonzeros"] == 2**31
