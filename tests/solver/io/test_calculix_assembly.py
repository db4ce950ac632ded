"""A two-part Abaqus/CAE assembly, morphed and written flat, solved by CalculiX (which reads no assemblies).

The flat deck the test compares with is written by the test itself (tests/solver/io/abaqus_assembly.py):
the bracket where it is, the lug placed with the test's own rotation. Same shape, same modes: the
frequencies ccx prints for both agree to its output precision.
"""

from __future__ import annotations

import numpy as np
import pytest

from solver import precompute, read_mesh, write_mesh
from tests.solver.io.abaqus_assembly import LUG_SCALE, assembly_deck, bracket, flat_deck, node_lines, place
from tests.solver.io.test_calculix import complaints, dat_block, run_ccx

pytestmark = pytest.mark.ccx  # runs CalculiX: make test, not make check


def _frequencies(deck) -> np.ndarray:
    text, dat = run_ccx(deck)
    assert complaints(text) == [], complaints(text)[:5]
    return dat_block(dat, "E I G E N V A L U E   O U T P U T")[:, 3]  # mode, eigenvalue, rad/time, cycles/time


def test_an_assembly_written_flat_has_the_modes_of_the_same_shape_as_a_flat_deck(tmp_path):
    labels, X, *_ = bracket()
    n = len(labels)
    src = tmp_path / "assembly.inp"
    src.write_text(assembly_deck())
    mesh = read_mesh(src)
    # at rest: the flattened assembly against the test's own flat deck
    write_mesh(mesh, mesh.V, tmp_path / "flat_rest.inp", flatten=True)
    (tmp_path / "mine_rest.inp").write_text(flat_deck(X, place(LUG_SCALE * X)))
    rest = _frequencies(tmp_path / "flat_rest.inp")
    np.testing.assert_allclose(rest, _frequencies(tmp_path / "mine_rest.inp"), rtol=1e-5)
    # morphed in assembly coordinates: each part's hole pulled toward its clamp
    spec = {"selections": {"b_fix": {"set": "Bracket-1.FIXED"}, "b_hole": {"set": "Bracket-1.HOLE"},
                           "l_fix": {"set": "Lug-1.FIXED"}, "l_hole": {"set": "Lug-1.HOLE"}},
            "fixed": ["b_fix", "l_fix"], "handles": {"b_hole": "b_hole", "l_hole": "l_hole"}}
    lug_dir = place(np.array([[-1.0, 0, 0]])) - place(np.zeros((1, 3)))
    r = precompute(mesh, spec).solve({"handles": {"b_hole": {"translation": [-6.0, 0, 0]},
                                                  "l_hole": {"translation": (3.0 * lug_dir[0]).tolist()}}})
    assert r.report["inverted_elements"] == 0
    w = write_mesh(mesh, r.V, tmp_path / "flat_moved.inp", flatten=True)
    assert w.path.endswith("flat_moved.inp")
    text = (tmp_path / "flat_moved.inp").read_text()
    keywords = {ln.split(",")[0].strip().upper() for ln in text.splitlines() if ln.startswith("*")
                and not ln.startswith("**")}
    assert not keywords & {"*PART", "*END PART", "*ASSEMBLY", "*INSTANCE", "*INCLUDE"}
    nodes = node_lines(text)  # the flat deck's node lines hold the morphed assembly positions
    got = np.array([nodes[("", k)] for k in sorted(k for _, k in nodes)])
    np.testing.assert_allclose(got, np.r_[r.V[:n], r.V[n:]], rtol=0, atol=1e-9)
    (tmp_path / "mine_moved.inp").write_text(flat_deck(r.V[:n], r.V[n:]))
    moved = _frequencies(tmp_path / "flat_moved.inp")
    np.testing.assert_allclose(moved, _frequencies(tmp_path / "mine_moved.inp"), rtol=1e-5)
    assert np.abs(moved / rest - 1).max() > 1e-4  # the morph changed the modes
