"""Hexahedra, wedges and pyramids next to tetrahedra (tests/data/mixed.msh, made by make_mixed.py)."""
from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np
import pytest

from solver import precompute, read_mesh, write_mesh
from solver.errors import InvalidMeshError
from solver.io import mesh_from_meshio
from solver.ops.elements import CORNERS, FACES, MIRROR, corner_jacobians, element_volumes, oriented
from solver.ops.mvc_matrix import mvc_matrix
from solver.validity.quality import element_quality

DATA = Path(__file__).resolve().parents[2] / "data"


MIXED = DATA / "mixed.msh"


SPEC = {"selections": {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}}, "fixed": ["fix"],
        "handles": {"tip": "load"}}


BEND = {"handles": {"tip": {"translation": [0, 0, 4], "rotation": {"axis": [0, 1, 0], "angle_deg": -15}}}}


# Reference nodes of the trilinear hexahedron and the linear wedge (VTK order, gmsh winding for the
# wedge); each element's Jacobian at its own nodes is compared in sign with the rest shape, so the
# count below does not depend on tetmorph's corner tables or on the file's winding.
HEX_REF = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)


def _hex_grad(p: np.ndarray) -> np.ndarray:
    """(8, 3) shape-function gradients of the trilinear hexahedron at reference point p."""
    a = HEX_REF
    g = np.empty((8, 3))
    g[:, 0] = a[:, 0] * (1 + a[:, 1] * p[1]) * (1 + a[:, 2] * p[2]) / 8
    g[:, 1] = a[:, 1] * (1 + a[:, 0] * p[0]) * (1 + a[:, 2] * p[2]) / 8
    g[:, 2] = a[:, 2] * (1 + a[:, 0] * p[0]) * (1 + a[:, 1] * p[1]) / 8
    return g


def _wedge_grad(p: np.ndarray) -> np.ndarray:
    """(6, 3) gradients of N = L_i (1 -+ t) / 2 with L = (1 - r - s, r, s)."""
    r, s, t = p
    L = np.array([1 - r - s, r, s])
    dL = np.array([[-1, -1], [1, 0], [0, 1]], float)
    g = np.zeros((6, 3))
    for half, sign in ((0, -1), (1, 1)):
        f = (1 + sign * t) / 2
        g[3 * half:3 * half + 3, :2] = dL * f
        g[3 * half:3 * half + 3, 2] = L * sign / 2
    return g


WEDGE_REF = np.array([[0, 0, -1], [1, 0, -1], [0, 1, -1], [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)


def _node_dets(X: np.ndarray, kind: str) -> np.ndarray:
    """(m, nodes) Jacobian determinants at the nodes of elements with coordinates X (m, c, 3)."""
    if kind == "pyramid":  # the four tets of the two base diagonals
        tets = [(0, 1, 2, 4), (0, 2, 3, 4), (0, 1, 3, 4), (1, 2, 3, 4)]
        return np.stack([np.einsum("ij,ij->i", X[:, b] - X[:, a], np.cross(X[:, c] - X[:, a], X[:, d] - X[:, a]))
                         for a, b, c, d in tets], axis=1)
    ref, grad = (HEX_REF, _hex_grad) if kind == "hexahedron" else (WEDGE_REF, _wedge_grad)
    out = []
    for p in ref:
        J = np.einsum("mcj,ck->mjk", X, grad(p))
        out.append(np.linalg.det(J))
    return np.stack(out, axis=1)


def independent_inverted(V0: np.ndarray, P: np.ndarray, source: meshio.Mesh) -> int:
    """Elements (tets and others, from the file's own connectivity) whose Jacobian at some node
    changed sign or vanished between the rest shape V0 and P."""
    count = 0
    for c in source.cells:
        if c.type not in ("tetra", "hexahedron", "wedge", "pyramid"):
            continue
        E = np.asarray(c.data)
        if c.type == "tetra":
            d0 = _node_dets(V0[E][:, [0, 1, 2, 3, 3]], "pyramid")[:, :1]  # one tet: (0,1,2,3)
            d1 = _node_dets(P[E][:, [0, 1, 2, 3, 3]], "pyramid")[:, :1]
        else:
            d0, d1 = _node_dets(V0[E], c.type), _node_dets(P[E], c.type)
        count += int(((np.sign(d1) != np.sign(d0)) | (d1 == 0)).any(axis=1).sum())
    return count


@pytest.fixture(scope="module")
def mixed():
    return read_mesh(MIXED)


def test_ideal_elements_score_one_and_faces_point_out():
    s3 = np.sqrt(3) / 2
    shapes = {
        "hexahedron": np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                                [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float),
        "wedge": np.array([[0, 0, 0], [0.5, s3, 0], [1, 0, 0], [0, 0, 1], [0.5, s3, 1], [1, 0, 1]]),
        "pyramid": np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1 / np.sqrt(2)]]),
    }
    volumes = {"hexahedron": 1.0, "wedge": s3 / 2, "pyramid": 1 / (3 * np.sqrt(2))}
    for kind, X in shapes.items():
        E = np.arange(len(X))[None]
        det, sj = corner_jacobians(X, E, kind)
        assert det[0] > 0 and sj[0] == pytest.approx(1.0)
        assert element_volumes(X, E, kind)[0] == pytest.approx(volumes[kind])
        c = X.mean(axis=0)
        for f in FACES[kind]:  # outward: the face normal points away from the centroid
            n = np.cross(X[f[1]] - X[f[0]], X[f[2]] - X[f[0]])
            assert n @ (X[list(f)].mean(axis=0) - c) > 0
        # the other winding is recognised and mirrored back
        M = E[:, MIRROR[kind]]
        assert corner_jacobians(X, M, kind)[0][0] < 0
        assert corner_jacobians(X, oriented(X, M, kind), kind)[0][0] > 0
        assert CORNERS[kind].shape[1] == 4


def test_mixed_deck_reads_with_sets_and_volume(mixed):
    info = mixed.info()
    assert info["cell_types"]["hexahedron"] == 128 and info["cell_types"]["wedge"] == 172
    assert info["cell_types"]["pyramid"] == 16 and info["tetrahedra"] == 797
    assert info["elements"] == 128 + 172 + 16 + 797
    assert {"FIXED", "LOAD", "HEX", "TET", "WEDGE"} <= set(info["sets"])
    assert info["bodies"] == 1 and info["boundary_shells"] == 1
    q = element_quality(mixed.V, mixed.T, mixed.cells)
    assert q["volume"].sum() == pytest.approx(20 * 10 * 10 * 2 + 20 * 10 * 4, rel=1e-12)
    assert np.isnan(q["min_dihedral_deg"][len(mixed.T):]).all()  # tet metrics only on tets
    # boundary vertices are exactly those on the outer faces of the stepped bar
    V, lo, hi = mixed.V, np.zeros(3), np.array([40.0, 10.0, 14.0])
    on_box = ((np.isclose(V, lo) | np.isclose(V, hi)).any(axis=1)
              | (np.isclose(V[:, 2], 10.0) & (V[:, 0] <= 20 + 1e-9))
              | (np.isclose(V[:, 0], 20.0) & (V[:, 2] >= 10 - 1e-9)))
    assert on_box[mixed.boundary].all() and not on_box[mixed.interior].any()


def test_mean_value_rows_reproduce_interior_vertices(mixed):
    I = mixed.interior
    W, S = mvc_matrix(mixed.V, mixed.T, I, mixed.cells)
    assert np.allclose(np.asarray(W.sum(axis=1)).ravel()[I], 1.0)
    assert np.abs(W @ mixed.V - mixed.V * I[:, None]).max() <= 1e-12 * 40
    assert (S[I] > 0).all()
    # a hex-block vertex's row reaches the far corners of its eight hexahedra (faces, not tets)
    hexv = np.unique(mixed.cells["hexahedron"])
    i = next(v for v in hexv if I[v] and v not in mixed.T and v not in mixed.cells.get("pyramid", []))
    assert W[i].nnz == 26


def test_bend_is_exact_valid_and_split_equals_joint(mixed):
    out = {}
    for mode in ("split", "joint"):
        d = precompute(mixed, {**SPEC, "solve": mode})
        r = d.solve(BEND)
        out[mode] = r
        assert r.report["constraint_residual_max"] <= 1e-10 * 45
        assert r.report["inverted_elements"] == 0 == independent_inverted(mixed.V, r.V, mixed.source)
    a, b = out["split"].V, out["joint"].V
    assert np.abs(a - b).max() <= 1e-8 * np.abs(a - mixed.V).max()


def test_rigid_motion_of_every_constraint_moves_the_whole_mesh(mixed):
    spec = {"selections": {"a": {"set": "FIXED"}, "b": {"set": "LOAD"}}, "handles": {"a": "a", "b": "b"}}
    d = precompute(mixed, spec)
    R = {"axis": [1, 2, 3], "angle_deg": 35}
    piv = [5.0, 1.0, 2.0]
    r = d.solve({"handles": {h: {"translation": [3, -2, 1], "rotation": R, "pivot": piv} for h in "ab"}})
    ax = np.array([1, 2, 3]) / np.sqrt(14)
    th = np.radians(35)
    K = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    Rm = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
    want = (mixed.V - piv) @ Rm.T + piv + [3, -2, 1]
    assert np.abs(r.V - want).max() <= 1e-8 * 45


def test_large_move_counts_inverted_elements_like_an_independent_check(mixed):
    d = precompute(mixed, SPEC)
    r = d.solve({"handles": {"tip": {"translation": [-30, 0, 0]}}}, quality="full")
    n = r.report["inverted_elements"]
    assert n > 0 and n == independent_inverted(mixed.V, r.V, mixed.source)
    assert max(r.report["inverted_ids"]) < mixed.elements
    assert r.report["quality"]["after"]["scaled_jacobian"]["min"] <= 0
    assert len(r.cell_quality["scaled_jacobian"]) == mixed.elements


def test_round_trip_keeps_cells_sets_and_bytes(mixed, tmp_path):
    d = precompute(mixed, SPEC)
    P = d.solve(BEND).V
    src = MIXED.read_bytes()
    out = tmp_path / "out.msh"
    write_mesh(mixed, P, out)
    new = out.read_bytes()
    # only the coordinate lines of $Nodes change
    a, b = src.split(b"$Nodes")[0], new.split(b"$Nodes")[0]
    assert a == b and src.split(b"$EndNodes")[1] == new.split(b"$EndNodes")[1]
    back = read_mesh(out)
    assert np.abs(back.V - P).max() <= 1e-12 * 45
    path = tmp_path / "out.vtu"
    write_mesh(mixed, P, path, quality=True)
    m = read_mesh(path)
    assert {k: len(v) for k, v in m.cells.items()} == {k: len(v) for k, v in mixed.cells.items()}
    assert len(m.T) == len(mixed.T) and np.abs(m.V - P).max() <= 1e-12 * 45
    q = meshio.read(path).cell_data["quality:scaled_jacobian"]
    assert sum(np.isfinite(x).sum() for x in q) == mixed.elements
    # meshio has no Abaqus name for pyramids: a typed error, not a crash
    with pytest.raises(InvalidMeshError, match="pyramid"):
        write_mesh(mixed, P, tmp_path / "out.inp")


def test_hexahedron_only_abaqus_deck(mixed, tmp_path):
    """A deck of C3D8 alone (no tets): read, bent, written back changing only node lines."""
    H = mixed.cells["hexahedron"]
    used = np.unique(H)
    remap = np.full(mixed.n, -1)
    remap[used] = np.arange(used.size)
    V = mixed.V[used]
    deck = tmp_path / "hex.inp"
    meshio.write(deck, meshio.Mesh(V, [("hexahedron", remap[H])],
                                   point_sets={"FIXED": np.flatnonzero(V[:, 0] == 0),
                                               "TIP": np.flatnonzero(V[:, 0] == 20)}))
    m = read_mesh(deck)
    assert len(m.T) == 0 and m.elements == len(H) and int(m.interior.sum()) == 7 * 3 * 3
    d = precompute(m, {"selections": {"f": {"set": "FIXED"}, "t": {"set": "TIP"}}, "fixed": ["f"],
                       "handles": {"tip": "t"}})
    r = d.solve({"handles": {"tip": {"translation": [0, 0, 3], "rotation": {"axis": [0, 1, 0], "angle_deg": -20}}}})
    assert r.report["inverted_elements"] == 0 == independent_inverted(m.V, r.V, m.source)
    out = tmp_path / "out.inp"
    write_mesh(m, r.V, out)
    old, new = deck.read_text().splitlines(), out.read_text().splitlines()
    changed = [i for i, (a, b) in enumerate(zip(old, new, strict=True)) if a != b]
    node_block = range(old.index("*NODE") + 1, old.index("*NODE") + 1 + m.n)
    assert changed and set(changed) <= set(node_block)
    assert np.abs(read_mesh(out).V - r.V).max() <= 1e-9 * 20


def test_bad_mixed_elements_are_named():
    X = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                  [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    twisted = X.copy()
    twisted[6] = [0.2, 0.2, 1.0]  # folds the corners at 6 but not at 0
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_meshio(meshio.Mesh(twisted, [("hexahedron", np.arange(8)[None])]))
    assert e.value.code == "inverted_input" and "hexahedron" in str(e.value)
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_meshio(meshio.Mesh(X, [("hexahedron", np.array([[0, 1, 2, 3, 4, 5, 6, 6]]))]))
    assert e.value.code == "repeated_index"
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_meshio(meshio.Mesh(X, [("wedge", np.array([[0, 1, 2, 4, 5, 99]]))]))
    assert e.value.code == "index_out_of_range"
