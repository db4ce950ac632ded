"""Fixed and handle selections of quadratic decks hold every node they name, mid-side nodes included.

Node sets and boxes are resolved here independently of the code under test
(from the file's ten-node connectivity and the coordinates), and every
named node is checked: fixed ones at rest, handle ones at the handle's rigid
motion about the centroid of all its nodes.
"""

from __future__ import annotations

import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.constraints.move import axis_angle_matrix
from tests.conftest import bend_spec, longest_axis, shared_file

DECKS = ["tet/kiefer_fea_bracket.vtu", "tet/tractor_wheel_coarse.INP", "tet/segmenttet.inp"]


def _in_box(V: np.ndarray, nodes: np.ndarray, box: dict) -> np.ndarray:
    lo, hi = np.asarray(box["min"]), np.asarray(box["max"])
    return nodes[np.all((V[nodes] >= lo) & (V[nodes] <= hi), axis=1)]


def _move(mesh):
    ax, diag = longest_axis(mesh)
    axis = np.eye(3)[(ax + 1) % 3]
    t = 0.02 * diag * np.eye(3)[(ax + 2) % 3]
    return {"handles": {"h": {"translation": t.tolist(), "rotation": {"axis": axis.tolist(), "angle_deg": 20.0}}}}, \
        axis, t, diag


@pytest.mark.parametrize("name", DECKS)
def test_every_fixed_and_handle_node_of_a_quadratic_deck_is_exact(name):
    mesh = read_mesh(shared_file(name))
    nodes = np.unique(mesh.T10)  # every node of an element, from the file's connectivity
    corners = np.unique(mesh.T10[:, :4])
    spec = bend_spec(mesh)
    fixed = _in_box(mesh.V, nodes, spec["selections"]["fix"]["box"])
    hand = _in_box(mesh.V, nodes, spec["selections"]["hand"]["box"])
    assert np.setdiff1d(fixed, corners).size > 0 and np.setdiff1d(hand, corners).size > 0  # mid-side nodes named
    move, axis, t, diag = _move(mesh)
    r = precompute(mesh, spec).solve(move)
    P = r.V
    assert np.abs(P[fixed] - mesh.V[fixed]).max() <= 1e-12 * diag
    c = mesh.V[hand].mean(axis=0)  # default pivot: the centroid of all the handle's nodes
    R = axis_angle_matrix(axis, np.radians(20.0))
    target = c + t + (mesh.V[hand] - c) @ R.T
    err = np.linalg.norm(P[hand] - target, axis=1).max()
    assert err <= 1e-9 * diag
    # the REPORT's residual is a distance over every constrained node; it agrees with the above
    assert r.report["constraint_residual_max"] <= 1e-9 * diag
    assert r.report["constraint_residual_max"] >= np.linalg.norm(P[hand] - target, axis=1).max() - 1e-12 * diag


def test_a_node_set_keeps_its_mid_side_nodes():
    mesh = read_mesh(shared_file("tet/segmenttet.inp"))
    text = shared_file("tet/segmenttet.inp").read_text().splitlines()
    start = next(i for i, ln in enumerate(text) if ln.lower().replace(" ", "").startswith("*nset,nset=nleft"))
    labels = []
    for ln in text[start + 1:]:
        if ln.startswith("*"):
            break
        labels += [int(x) for x in ln.replace(",", " ").split()]
    assert len(labels) == 298
    spec = {"selections": {"left": {"set": "Nleft"}, "hand": {"set": "Nright"}},
            "fixed": ["left"], "handles": {"h": "hand"}}
    d = precompute(mesh, spec)
    held = np.union1d(d.data.constraints.fixed, d.data.constraints.fixed_mid)
    assert held.size == 298  # corner and mid-side nodes, none dropped
    move, *_ = _move(mesh)
    P = d.solve(move).V
    assert np.abs(P[held] - mesh.V[held]).max() == 0.0
