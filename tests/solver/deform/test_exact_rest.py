"""A node whose displacement is exactly zero keeps its rest position bit for bit, and its text in the deck."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from solver import precompute, read_mesh, write_mesh
from tests.conftest import DATA


def _spec(mesh) -> dict:
    """The lowest tenth of the part fixed, the highest tenth a handle (node ids, any format)."""
    z = mesh.V[:, 2] if np.ptp(mesh.V[:, 2]) > 0 else mesh.V[:, 1]
    lo, hi = np.quantile(z[mesh.referenced], [0.1, 0.9])
    ref = mesh.referenced
    fixed = np.flatnonzero(ref & (z <= lo))
    top = np.flatnonzero(ref & (z >= hi))
    return {"selections": {"base": {"ids": fixed.tolist()}, "top": {"ids": top.tolist()}},
            "fixed": ["base"], "handles": {"top": "top"}}


ZERO_MOVES = [
    {},
    {"handles": {"top": {"translation": [0, 0, 0], "rotation": {"axis": [0, 1, 0], "angle_deg": 0}, "scale": 1}}},
]


@pytest.mark.parametrize("name", ["bracket.inp", "ccx_bracket.inp", "bar_small.bdf", "bar10_small.bdf",
                                  "mixed.msh", "beam.node"])
@pytest.mark.parametrize("precision", ["exact", "mixed"])
def test_a_zero_move_writes_the_deck_byte_for_byte(name, precision, tmp_path):
    mesh = read_mesh(DATA / name)
    d = precompute(mesh, {**_spec(mesh), "precision": precision})
    for k, move in enumerate(ZERO_MOVES):
        V = d.solve(move).V
        assert np.array_equal(V, mesh.V), f"{int((V != mesh.V).any(axis=1).sum())} nodes moved by a zero MOVE"
        out = tmp_path / f"zero{k}.{name.rsplit('.', 1)[1]}"
        write_mesh(mesh, V, out)
        assert out.read_bytes() == (DATA / name).read_bytes()


def test_vtu_zero_move_is_byte_identical(tmp_path):
    src = tmp_path / "bracket.vtu"
    meshio.write(src, meshio.read(DATA / "bracket.inp"), binary=False)
    mesh = read_mesh(src)
    d = precompute(mesh, _spec(mesh))
    out = tmp_path / "out.vtu"
    write_mesh(mesh, d.solve({}).V, out)
    assert out.read_bytes() == src.read_bytes()


def test_a_plan_row_at_rest_is_the_rest_and_fixed_nodes_never_move(tmp_path):
    mesh = read_mesh(DATA / "bracket.inp")
    spec = _spec(mesh)
    d = precompute(mesh, spec)
    turn = {"handles": {"top": {"translation": [0.5, 0, 0], "rotation": {"axis": [0, 1, 0], "angle_deg": 8}}}}
    rest, moved = (r.V for r in d.solve_many([ZERO_MOVES[1], turn]))
    assert np.array_equal(rest, mesh.V)
    fixed = np.asarray(spec["selections"]["base"]["ids"])
    assert np.array_equal(moved[fixed], mesh.V[fixed])
    assert (moved[np.asarray(spec["selections"]["top"]["ids"])] != mesh.V[spec["selections"]["top"]["ids"]]).any()
    out = tmp_path / "turned.inp"
    write_mesh(mesh, moved, out)
    back = meshio.read(out).points  # an independent reader: the fixed nodes' values as the rest deck's
    np.testing.assert_array_equal(back[fixed], meshio.read(DATA / "bracket.inp").points[fixed])
