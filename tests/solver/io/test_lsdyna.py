"""LS-DYNA keyword decks: read as lsdyna-mesh-reader reads them, written back with only moved coordinates changed.

The decks are written here, from the tetrahedra of tests/data/plate.inp (and the mixed elements of
tests/data/mixed.msh), in the small, I10, long and free formats; the public decks that lsdyna-mesh-reader
ships (DYNAmore's examples: hexahedra and shells) check the reader and the writer on decks written by the
real tools. lsdyna-mesh-reader (small format, one-card solids) is the independent reader; the other formats
are checked with a few lines of column or comma parsing here.
"""

from __future__ import annotations

import os
import pathlib
import time

import meshio
import numpy as np
import pytest

from solver import read_mesh, write_mesh
from solver.errors import SolverError, UnreadableFileError, UnsupportedElementError
from solver.io import lsdyna
from solver.io.formats import detect_format, format_of
from tests.conftest import DATA

Deck = pytest.importorskip("lsdyna_mesh_reader").Deck
EXAMPLES = pathlib.Path(pytest.importorskip("lsdyna_mesh_reader.examples").__file__).parent
PUBLIC = ["birdball.k", "EXP_SC_JOINT_SCREW.key", "bird.k", "bracket.k", "wheel.k", "ex_13_thick_shell_elform_2.k"]

WIDTH = {"small": (8, 16), "i10": (10, 16), "long": (20, 20)}


# ---------------------------------------------------------------------------------------------------------------
# decks written here


def _plate() -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    m = meshio.read(DATA / "plate.inp")
    tets = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
    return np.asarray(m.points, float), tets, {k: np.asarray(v) for k, v in m.point_sets.items()}


def _real(x: float, w: int) -> str:
    """A coordinate the way LS-PrePost writes one: scientific, filling the field."""
    return f"{x:{w}.{w - 7}e}"


def _ints(values, w: int) -> str:
    return "".join(f"{int(v):{w}d}" for v in values)


def _nodes(ids, P, fmt: str) -> list[str]:
    if fmt == "free":
        return [f"{i},{float(x)!r}, {float(y)!r} ,{float(z)!r},0,0" for i, (x, y, z) in zip(ids, P, strict=True)]
    wi, wr = WIDTH[fmt]
    return [f"{i:{wi}d}" + "".join(_real(v, wr) for v in p) + _ints([0, 0], wi) for i, p in zip(ids, P, strict=True)]


def _solids(eids, pids, conn, fmt: str, form: str) -> list[str]:
    """Solid cards: ``degenerate`` (n1 n2 n3 n4 n4 n4 n4 n4), ``four`` (n5..n8 blank), ``two`` (eid pid / nodes)."""
    out = []
    wi = 0 if fmt == "free" else WIDTH[fmt][0]
    for e, p, c in zip(eids, pids, conn, strict=True):
        nodes = list(c) if len(c) != 4 else (list(c) if form == "four" else list(c) + [c[3]] * 4)
        if fmt == "free":
            out += [f"{e},{p}", ",".join(map(str, nodes))] if form == "two" else [",".join(map(str, [e, p, *nodes]))]
        elif form == "two":
            out += [_ints([e, p], wi), _ints(nodes, wi)]
        else:
            out.append(_ints([e, p, *nodes], wi))
    return out


def _plate_deck(fmt: str = "small", form: str = "degenerate", keyword: str = "*ELEMENT_SOLID"):
    """A deck of the plate: ids shifted (nodes 1001, 1004, ...), two parts, node sets; and what it holds."""
    P, T, sets = _plate()
    nid = 1001 + 3 * np.arange(len(P))
    eid = 501 + 2 * np.arange(len(T))
    pid = np.where(P[T].mean(axis=1)[:, 0] < 80, 1, 2)
    head = ["*KEYWORD" + {"long": " LONG=Y", "i10": " I10=Y"}.get(fmt, ""), "*TITLE", "plate with four holes"]
    w = 20 if fmt == "long" else 10
    lines = head + ["*PART", "left half", _ints([1, 1, 1], w), "*PART", "right half", _ints([2, 1, 1], w)]
    lines += ["$ the nodes", "*NODE", "$#   nid               x               y               z      tc      rc"]
    lines += _nodes(nid, P, fmt)
    lines += ["*ELEMENT_SOLID" if keyword == "*ELEMENT_SOLID" and form != "two" else
              (keyword + " (ten nodes format)" if keyword == "*ELEMENT_SOLID" else keyword)]
    lines += _solids(eid, pid, nid[T], fmt, form)
    fixed = nid[sets["FIXED"]]
    lines += ["*SET_NODE_LIST_TITLE", "clamped end", _ints([7], w)]
    lines += [(",".join(map(str, fixed[k:k + 8])) if fmt == "free" else _ints(fixed[k:k + 8], w))
              for k in range(0, len(fixed), 8)]
    lines += ["*SET_NODE_LIST_GENERATE", _ints([8], w), _ints([nid[0], nid[9], nid[20], nid[29]], w)]
    lines += ["*SET_PART_LIST", _ints([9], w), _ints([2], w), "*END", ""]
    return "\n".join(lines).encode(), P, T, nid, eid, pid, sets


def _write(tmp_path: pathlib.Path, name: str, data: bytes) -> pathlib.Path:
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def _moved(V: np.ndarray) -> np.ndarray:
    """Nodes right of x = 80 bent down; some y a tiny negative; some values that need every digit."""
    P = V.copy()
    far = P[:, 0] > 80
    P[far, 2] -= 0.01 * (P[far, 0] - 80) ** 1.5
    P[far & (P[:, 1] < 1e-9), 1] = -3.55e-15
    P[far & (P[:, 1] > 79.99), 1] = 80 + 1 / 3
    return P


def _columns(a: bytes, b: bytes) -> set[int]:
    """Columns where two lines differ (a longer line's tail counts as differing)."""
    return {k for k in range(max(len(a), len(b))) if a[k:k + 1] != b[k:k + 1]}


# ---------------------------------------------------------------------------------------------------------------
# 1. the same nodes and elements as lsdyna-mesh-reader


def test_read_gives_the_nodes_and_tets_lsdyna_mesh_reader_reads(tmp_path):
    data, P, T, nid, eid, pid, _ = _plate_deck("small")
    path = _write(tmp_path, "plate.k", data)
    ref = Deck(path)
    (ns,), (es,) = ref.node_sections, ref.element_solid_sections
    m = lsdyna.read(path)
    assert [c.type for c in m.cells] == ["tetra"]
    np.testing.assert_array_equal(m.points_id, ns.nid)
    np.testing.assert_allclose(m.points, ns.coordinates, rtol=1e-14, atol=1e-12)
    conn = es.node_ids.reshape(-1, 8)
    assert (conn[:, 4:] == conn[:, 3:4]).all()  # the degenerate 8-node form
    np.testing.assert_array_equal(m.cells_id[0], es.eid)
    np.testing.assert_array_equal(m.cells_part[0], es.pid)
    np.testing.assert_array_equal(m.points_id[m.cells[0].data], conn[:, :4])
    mesh = read_mesh(path)  # the whole read: validated, every tet the right way round
    assert mesh.n == len(P) and len(mesh.T) == len(T)
    X = mesh.V[mesh.T]
    v = np.einsum("ij,ij->i", np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), X[:, 3] - X[:, 0])
    assert (v > 0).all()


@pytest.mark.parametrize("name", ["birdball.k", "EXP_SC_JOINT_SCREW.key"])
def test_public_decks_nodes_and_hexahedra_by_id(name):
    deck = lsdyna.read_deck(EXAMPLES / name)
    ref = Deck(EXAMPLES / name)
    (ns,), (es,) = ref.node_sections, ref.element_solid_sections
    np.testing.assert_array_equal(deck.node_ids, ns.nid)
    np.testing.assert_allclose(deck.points, ns.coordinates, rtol=1e-12, atol=1e-12)  # its parser rounds the last bit
    eids, pids, conn = deck.cells["hexahedron"]
    np.testing.assert_array_equal(eids, es.eid)
    np.testing.assert_array_equal(pids, es.pid)
    np.testing.assert_array_equal(deck.node_ids[conn], es.node_ids.reshape(-1, 8))


@pytest.mark.parametrize("name", PUBLIC)
def test_public_decks_nodes_by_id(name):
    deck = lsdyna.read_deck(EXAMPLES / name)
    ref = Deck(EXAMPLES / name)
    np.testing.assert_array_equal(deck.node_ids, np.concatenate([s.nid for s in ref.node_sections]))
    np.testing.assert_allclose(deck.points, np.concatenate([s.coordinates for s in ref.node_sections]), rtol=1e-12,
                               atol=1e-12)


def test_degenerate_forms_make_tetrahedra_pyramids_wedges_hexahedra(tmp_path):
    m = meshio.read(DATA / "mixed.msh")
    P = np.asarray(m.points, float)
    nid = 1 + np.arange(len(P))
    cards, expect = [], {}
    eid = 1
    for c in m.cells:
        if c.type not in ("tetra", "pyramid", "wedge", "hexahedron"):
            continue
        for e in c.data:
            n = nid[e]
            if c.type == "tetra":
                nodes = [n[0], n[1], n[2], n[2], n[3], n[3], n[3], n[3]]  # the N3 = N4 form
            elif c.type == "pyramid":
                nodes = [*n[:5], n[4], n[4], n[4]]
            elif c.type == "wedge":  # triangles (a, b, c), (d, e, f) as a hexahedron with two collapsed edges
                nodes = [n[0], n[1], n[4], n[3], n[2], n[2], n[5], n[5]]
            else:
                nodes = list(n)
            cards.append(_ints([eid, 1, *nodes], 8))
            expect[eid] = (c.type, set(n.tolist()))
            eid += 1
    deck = "\n".join(["*KEYWORD", "*NODE", *_nodes(nid, P, "small"), "*ELEMENT_SOLID", *cards, "*END", ""])
    path = _write(tmp_path, "mixed.k", deck.encode())
    got = lsdyna.read(path)
    for block, ids in zip(got.cells, got.cells_id, strict=True):
        for e, conn in zip(ids, block.data, strict=True):
            kind, nodes = expect[int(e)]
            assert block.type == kind and set(got.points_id[conn].tolist()) == nodes
    mesh = read_mesh(path)  # tetmorph takes the wedges and pyramids in either winding
    assert mesh.elements == sum(len(c.data) for c in got.cells) == len(expect)


def test_quadratic_tetrahedra_two_cards_mid_edge_nodes(tmp_path):
    P, T, _ = _plate()
    edges = {}
    pts = [*P]
    conn10 = []
    for t in T:  # meshio's (VTK's) tetra10 order: corners, then edges 01 12 20 03 13 23
        mids = []
        for a, b in ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)):
            key = tuple(sorted((t[a], t[b])))
            if key not in edges:
                edges[key] = len(pts)
                pts.append((P[t[a]] + P[t[b]]) / 2)
            mids.append(edges[key])
        conn10.append([*t, *mids])
    pts, conn10 = np.asarray(pts), np.asarray(conn10)
    used = np.unique(conn10)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    pts, conn10 = pts[used], remap[conn10]
    nid = 1 + np.arange(len(pts))
    cards = []
    for e, c in enumerate(conn10):
        cards += [_ints([e + 1, 1], 8), _ints(nid[c], 8)]
    path = _write(tmp_path, "tet10.k", "\n".join(["*KEYWORD", "*NODE", *_nodes(nid, pts, "small"),
                                                  "*ELEMENT_SOLID (ten nodes format)", *cards, "*END", ""]).encode())
    m = lsdyna.read(path)
    (block,) = m.cells
    assert block.type == "tetra10"
    X = m.points[block.data]
    for k, (a, b) in enumerate(((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))):
        np.testing.assert_allclose(X[:, 4 + k], (X[:, a] + X[:, b]) / 2, atol=1e-7)
    v = np.einsum("ij,ij->i", np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), X[:, 3] - X[:, 0])
    assert (v > 0).all()
    mesh = read_mesh(path)
    assert mesh.elements == len(conn10)


@pytest.mark.parametrize("form,keyword", [("four", "*ELEMENT_SOLID"), ("two", "*ELEMENT_SOLID"),
                                          ("degenerate", "*ELEMENT_SOLID_TET4TOTET10"),
                                          ("degenerate", "*element_solid_ortho")])
def test_other_solid_card_forms(tmp_path, form, keyword):
    data, P, T, nid, eid, pid, _ = _plate_deck("small", form, keyword)
    if "ORTHO" in keyword.upper():  # two cards of material directions after each element
        lines = data.decode().split("\n")
        start = next(k for k, ln in enumerate(lines) if ln.upper().startswith("*ELEMENT_SOLID"))
        end = next(k for k in range(start + 1, len(lines)) if lines[k].startswith("*"))
        a, d = _real(1.0, 16) + _real(0.0, 16) * 2, _real(0.0, 16) + _real(1.0, 16) + _real(0.0, 16)
        body = [x for ln in lines[start + 1:end] for x in (ln, a, d)]
        data = "\n".join(lines[:start + 1] + body + lines[end:]).encode()
    m = lsdyna.read(_write(tmp_path, "plate.k", data))
    assert [c.type for c in m.cells] == ["tetra"]
    np.testing.assert_array_equal(m.points_id[m.cells[0].data], nid[T])
    np.testing.assert_array_equal(m.cells_id[0], eid)


# ---------------------------------------------------------------------------------------------------------------
# 2. a zero move writes every file back byte for byte


@pytest.mark.parametrize("name", PUBLIC)
def test_zero_move_public_decks_byte_identical(name):
    raw = (EXAMPLES / name).read_bytes()
    deck = lsdyna.read_deck(EXAMPLES / name)
    assert lsdyna.patch(raw, deck.points) == raw
    assert lsdyna.node_line_count(raw) == len(deck.points)


@pytest.mark.parametrize("fmt", ["small", "i10", "long", "free"])
def test_zero_move_written_decks_byte_identical(tmp_path, fmt):
    data = _plate_deck(fmt)[0]
    path = _write(tmp_path, "plate.k", data)
    mesh = read_mesh(path)
    w = write_mesh(mesh, mesh.V, tmp_path / "out.k")
    assert w.patched and (tmp_path / "out.k").read_bytes() == data


def _include_tree(tmp_path: pathlib.Path) -> tuple[pathlib.Path, np.ndarray, np.ndarray, dict[str, bytes]]:
    """main.k: half the nodes, then parts/nodes.k (the other half, long format by its *INCLUDE +), parts/elems.k,
    which includes parts/sets.k by the deck's folder and more.k by its own folder (parts/more.k)."""
    P, T, _ = _plate()
    nid = 1 + np.arange(len(P))
    half = len(P) // 2
    files = {
        "main.k": ["*KEYWORD", "*NODE", *_nodes(nid[:half], P[:half], "small"), "*INCLUDE +", "parts/nodes.k",
                   "$ the elements", "*INCLUDE", "parts/elems.k", "*END"],
        "parts/nodes.k": ["$ included in long format", "*NODE", *_nodes(nid[half:], P[half:], "long")],
        "parts/elems.k": ["*ELEMENT_SOLID", *_solids(1 + np.arange(len(T)), np.ones(len(T), int), nid[T], "small",
                                                     "degenerate"), "*INCLUDE", "parts/sets.k", "*INCLUDE", "more.k"],
        "parts/sets.k": ["*SET_NODE_LIST", _ints([3], 10), _ints(nid[:8], 10)],
        "parts/more.k": ["*KEYWORD", "*SET_NODE_LIST", _ints([4], 10), _ints(nid[-8:], 10), "*END"],
    }
    raw = {k: ("\r\n".join(v) + "\r\n").encode() for k, v in files.items()}
    for k, v in raw.items():
        _write(tmp_path / "in", k, v)
    return tmp_path / "in" / "main.k", P, nid, raw


def test_includes_read_in_order_and_zero_move_keeps_every_file(tmp_path):
    path, P, nid, raw = _include_tree(tmp_path)
    assert lsdyna.includes(path) == ["parts/nodes.k", "parts/elems.k", "parts/sets.k", "parts/more.k"]
    mesh = read_mesh(path)
    np.testing.assert_allclose(mesh.V, P, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(mesh.source.points_id, nid)
    assert set(mesh.companions) == {"parts/nodes.k", "parts/elems.k", "parts/sets.k", "parts/more.k"}
    assert mesh.sets["SET_NODE_3"].tolist() == list(range(8))
    assert mesh.sets["SET_NODE_4"].tolist() == list(range(len(P) - 8, len(P)))
    (tmp_path / "out").mkdir()
    w = write_mesh(mesh, mesh.V, tmp_path / "out" / "main.k")
    assert w.patched
    for rel, body in raw.items():
        assert (tmp_path / "out" / rel).read_bytes() == body, rel


def test_includes_real_move_changes_node_fields_only(tmp_path):
    path, P, nid, raw = _include_tree(tmp_path)
    mesh = read_mesh(path)
    Q = _moved(mesh.V)
    (tmp_path / "out").mkdir()
    write_mesh(mesh, Q, tmp_path / "out" / "main.k")
    out = {rel: (tmp_path / "out" / rel).read_bytes() for rel in raw}
    assert out["parts/elems.k"] == raw["parts/elems.k"] and out["parts/sets.k"] == raw["parts/sets.k"]
    back = lsdyna.read(tmp_path / "out" / "main.k")
    np.testing.assert_allclose(back.points, Q, rtol=1e-9, atol=1e-12)
    half = len(P) // 2
    for rel, first, width, count in (("main.k", 0, (8, 16), half), ("parts/nodes.k", half, (20, 20), len(P) - half)):
        a, b = raw[rel].split(b"\r\n"), out[rel].split(b"\r\n")
        assert len(a) == len(b)
        node_lines = [k for k, ln in enumerate(a) if ln[:1].isspace() and len(ln) > 40]
        assert len(node_lines) == count
        for row, k in enumerate(node_lines):
            changed = _columns(a[k], b[k])
            moved = Q[first + row] != P[first + row]
            for j in range(3):
                field = set(range(width[0] + j * width[1], width[0] + (j + 1) * width[1]))
                assert bool(changed & field) <= bool(moved[j])
            assert changed <= set(range(width[0], width[0] + 3 * width[1]))
        assert {k for k in range(len(a)) if a[k] != b[k]} <= set(node_lines)


# ---------------------------------------------------------------------------------------------------------------
# 3. a real move: only coordinate fields change, and lsdyna-mesh-reader reads the new positions


def test_real_move_only_coordinate_columns_change(tmp_path):
    data, P, *_ = _plate_deck("small")
    path = _write(tmp_path, "plate.k", data)
    mesh = read_mesh(path)
    Q = _moved(mesh.V)
    w = write_mesh(mesh, Q, tmp_path / "out.k")
    assert w.patched and w.dropped == []
    new = (tmp_path / "out.k").read_bytes()
    a, b = data.split(b"\n"), new.split(b"\n")
    assert len(a) == len(b)
    first = a.index(b"*NODE") + 2
    rows = {first + r: r for r in range(len(P))}
    changed = [k for k in range(len(a)) if a[k] != b[k]]
    assert changed and set(changed) <= set(rows)
    for k in changed:
        cols = _columns(a[k], b[k])
        assert cols <= set(range(8, 56))
        for j in range(3):
            if Q[rows[k], j] == P[rows[k], j]:
                assert not cols & set(range(8 + 16 * j, 24 + 16 * j))  # an unmoved coordinate keeps its text
    unmoved = [first + r for r in np.flatnonzero((Q == P).all(axis=1))]
    assert all(a[k] == b[k] for k in unmoved)
    ref = Deck(tmp_path / "out.k").node_sections[0]
    np.testing.assert_allclose(ref.coordinates, Q, rtol=1e-9, atol=1e-12)  # 16 columns: 10 digits at worst
    assert (ref.coordinates[Q[:, 1] == -3.55e-15, 1] == -3.55e-15).all()


def test_real_move_public_deck(tmp_path):
    src = EXAMPLES / "EXP_SC_JOINT_SCREW.key"
    raw = src.read_bytes()
    deck = lsdyna.read_deck(src)
    rng = np.random.default_rng(1)
    Q = deck.points + rng.normal(scale=0.1, size=deck.points.shape) * (rng.random(len(deck.points)) < 0.3)[:, None]
    out = _write(tmp_path, "screw.key", lsdyna.patch(raw, Q))
    ref = Deck(out).node_sections[0]
    np.testing.assert_allclose(ref.coordinates, Q, rtol=1e-9, atol=1e-9)
    a, b = raw.split(b"\n"), out.read_bytes().split(b"\n")
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if x != y:
            assert _columns(x, y) <= set(range(8, 56))


# ---------------------------------------------------------------------------------------------------------------
# 4. long, I10 and free format round trips


def _parse_nodes(data: bytes, fmt: str) -> np.ndarray:
    """The node cards of a deck written by _plate_deck, read back by their columns (or commas)."""
    lines = data.split(b"\n")
    k = lines.index(b"*NODE") + 2
    out = []
    while not lines[k].startswith(b"*"):
        if fmt == "free":
            out.append([float(f) for f in lines[k].split(b",")[1:4]])
        else:
            wi, wr = WIDTH[fmt]
            out.append([float(lines[k][wi + j * wr:wi + (j + 1) * wr]) for j in range(3)])
        k += 1
    return np.asarray(out)


@pytest.mark.parametrize("fmt", ["long", "i10", "free"])
def test_long_i10_and_free_format_round_trip(tmp_path, fmt):
    data, P, T, nid, *_ = _plate_deck(fmt)
    path = _write(tmp_path, "plate.k", data)
    mesh = read_mesh(path)
    np.testing.assert_allclose(mesh.V, _parse_nodes(data, fmt), rtol=0, atol=0)
    np.testing.assert_array_equal(mesh.source.points_id[mesh.source.cells[0].data], nid[T])
    Q = _moved(mesh.V)
    write_mesh(mesh, Q, tmp_path / "out.k")
    new = (tmp_path / "out.k").read_bytes()
    tol = 1e-13 if fmt == "long" else 1e-9
    np.testing.assert_allclose(_parse_nodes(new, fmt), Q, rtol=tol, atol=1e-12)
    np.testing.assert_allclose(read_mesh(tmp_path / "out.k").V, Q, rtol=tol, atol=1e-12)
    a, b = data.split(b"\n"), new.split(b"\n")
    first = a.index(b"*NODE") + 2
    assert {k for k in range(len(a)) if a[k] != b[k]} <= set(range(first, first + len(P)))
    if fmt == "free":  # the comma-separated fields keep their blanks: "1001,x, y ,z,0,0"
        for k in range(first, first + len(P)):
            fa, fb = a[k].split(b","), b[k].split(b",")
            assert len(fa) == len(fb) and fa[0] == fb[0] and fa[4:] == fb[4:]
            assert fb[2].startswith(b" ") and fb[2].endswith(b" ")
            assert all(len(f.strip()) <= 16 for f in fb[1:4])
    else:
        wi, wr = WIDTH[fmt]
        for k in range(first, first + len(P)):
            assert _columns(a[k], b[k]) <= set(range(wi, wi + 3 * wr))


def test_long_format_by_keyword_suffix(tmp_path):
    P, T, _ = _plate()
    nid = 10 ** 12 + np.arange(len(P))  # ids that only 20 columns hold
    deck = ["*KEYWORD", "*NODE +", *_nodes(nid, P, "long"), "*ELEMENT_SOLID+",
            *_solids(1 + np.arange(len(T)), np.ones(len(T), int), nid[T], "long", "degenerate"), "*END", ""]
    path = _write(tmp_path, "big.k", "\n".join(deck).encode())
    m = lsdyna.read(path)
    np.testing.assert_array_equal(m.points_id, nid)
    np.testing.assert_array_equal(m.points_id[m.cells[0].data], nid[T])


# ---------------------------------------------------------------------------------------------------------------
# 5. parts and node sets


def test_parts_and_sets_become_sets(tmp_path):
    data, P, T, nid, eid, pid, sets = _plate_deck("small")
    mesh = read_mesh(_write(tmp_path, "plate.k", data))
    assert set(mesh.sets) == {"PART_1", "PART_2", "SET_NODE_7", "SET_NODE_8", "SET_PART_9"}
    for p in (1, 2):
        assert mesh.sets[f"PART_{p}"].tolist() == np.unique(T[pid == p]).tolist()
    assert mesh.sets["SET_PART_9"].tolist() == mesh.sets["PART_2"].tolist()
    assert mesh.sets["SET_NODE_7"].tolist() == np.unique(sets["FIXED"]).tolist()
    gen = [r for r in range(len(P)) if r <= 9 or 20 <= r <= 29]  # ranges by id: 1001..1028, 1061..1088
    assert mesh.sets["SET_NODE_8"].tolist() == gen
    assert mesh.source.set_titles == {"PART_1": "left half", "PART_2": "right half", "SET_NODE_7": "clamped end"}


def test_birdball_sets_and_lowercase_keywords():
    deck = lsdyna.read_deck(EXAMPLES / "birdball.k")  # "*set_node_list_generate" with a free-format range "1,376"
    assert deck.point_sets["SET_NODE_1"].tolist() == np.flatnonzero((deck.node_ids >= 1) &
                                                                    (deck.node_ids <= 376)).tolist()
    assert deck.part_sets == {"SET_PART_2": [2, 3]}


# ---------------------------------------------------------------------------------------------------------------
# 6. detection: a keyword deck is never taken for an Abaqus deck


def test_format_of_and_detection(tmp_path):
    assert format_of("x.k") == format_of("X.KEY") == format_of("model.dyn") == "lsdyna"
    for name in PUBLIC:
        assert detect_format((EXAMPLES / name).read_bytes()[:8192]) == "lsdyna", name
    for fmt in ("small", "long", "free"):
        assert detect_format(_plate_deck(fmt)[0][:8192]) == "lsdyna"
    P, T, _ = _plate()
    nodes_only = "\n".join(["$ nodes of the plate", "*NODE", *_nodes(1 + np.arange(9), P[:9], "small"), ""])
    assert detect_format(nodes_only.encode()) == "lsdyna"  # an include: no *KEYWORD, fixed columns
    solids_only = "\n".join(["*ELEMENT_SOLID", "1,1,1,2,3,4,4,4,4,4", ""])
    assert detect_format(solids_only.encode()) == "lsdyna"
    for inp in sorted(DATA.glob("*.inp")):
        assert detect_format(inp.read_bytes()[:8192]) == "abaqus", inp.name
        assert format_of(inp) == "abaqus"
    path = _write(tmp_path, "plate.k", _plate_deck("small")[0])
    assert read_mesh(path).file_format == "lsdyna"


# ---------------------------------------------------------------------------------------------------------------
# 7. shells and beams are named in words with their counts


def test_shells_and_beams_refused_with_counts(tmp_path):
    data = _plate_deck("small")[0].decode()
    shells = "\n".join(["*ELEMENT_SHELL", *(_ints([90000 + k, 3, 1001, 1004, 1007, 1007], 8) for k in range(1024))])
    beams = "\n".join(["*ELEMENT_BEAM", *(_ints([95000 + k, 4, 1001, 1004, 1007], 8) for k in range(12))])
    path = _write(tmp_path, "mixed.k", data.replace("*END", shells + "\n" + beams + "\n*END").encode())
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(path)
    assert "1,024 shell elements (*ELEMENT_SHELL) and 12 beam elements (*ELEMENT_BEAM)" in e.value.message
    assert e.value.details["types"] == {"*ELEMENT_SHELL": 1024, "*ELEMENT_BEAM": 12}
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(EXAMPLES / "birdball.k")
    assert "100 shell elements (*ELEMENT_SHELL)" in e.value.message and "816 solid elements" in e.value.message
    with pytest.raises(UnsupportedElementError, match=r"192 thick shell elements \(\*ELEMENT_TSHELL\)"):
        read_mesh(EXAMPLES / "ex_13_thick_shell_elform_2.k")


# ---------------------------------------------------------------------------------------------------------------
# 8. damaged decks end quickly in a typed error (or a read)


def _ends_typed(path: pathlib.Path) -> None:
    for reader in (lsdyna.read, read_mesh):
        t = time.perf_counter()
        try:
            reader(path)
        except SolverError:
            pass
        assert time.perf_counter() - t < 10, reader


def test_truncated_and_flipped_decks_end_in_typed_errors(tmp_path):
    data, P, T, *_ = _plate_deck("small")
    for frac in (0.3, 0.6, 0.9):
        path = _write(tmp_path, f"cut{int(frac * 100)}.k", data[:int(len(data) * frac)])
        _ends_typed(path)
    rng = np.random.default_rng(20240611)
    for k in range(20):
        b = bytearray(data)
        b[int(rng.integers(len(b)))] = int(rng.integers(256))
        _ends_typed(_write(tmp_path, f"flip{k}.k", bytes(b)))


def test_cut_inside_a_node_card_is_truncated_file(tmp_path):
    data = _plate_deck("small")[0]
    cut = data.index(b"\n", data.index(b"*NODE") + 500) + 30  # in the middle of a coordinate
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.read(_write(tmp_path, "cut.k", data[:cut]))
    assert e.value.code == "truncated_file"


def test_undefined_node_and_bad_number_named_with_line(tmp_path):
    data = _plate_deck("small")[0]
    lines = data.split(b"\n")
    k = lines.index(b"*ELEMENT_SOLID") + 1
    lines[k] = lines[k][:16] + b"  999999" + lines[k][24:]
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.read(_write(tmp_path, "undef.k", b"\n".join(lines)))
    assert e.value.code == "undefined_node" and e.value.details["node"] == 999999
    assert f"line {k + 1}" in e.value.message and "element 501" in e.value.message
    lines = data.split(b"\n")
    k = lines.index(b"*NODE") + 5
    lines[k] = lines[k][:10] + b"x" + lines[k][11:]
    with pytest.raises(UnreadableFileError, match=f"line {k + 1}"):
        lsdyna.read(_write(tmp_path, "bad.k", b"\n".join(lines)))


# ---------------------------------------------------------------------------------------------------------------
# 9. includes outside the deck's folder are refused


@pytest.mark.parametrize("target", ["../x.k", "/etc/passwd", "..\\..\\x.k", "sub/../../x.k", "C:\\models\\x.k"])
def test_include_outside_the_folder_refused(tmp_path, target):
    _write(tmp_path, "x.k", b"*NODE\n       1             0.0             0.0             0.0\n")
    data = _plate_deck("small")[0].replace(b"*END", b"*INCLUDE\n" + target.encode() + b"\n*END")
    path = _write(tmp_path / "deck", "main.k", data)
    for call in (lsdyna.read, lsdyna.includes, read_mesh):
        with pytest.raises(UnreadableFileError) as e:
            call(path)
        assert e.value.code == "include_outside" and target in e.value.message


def test_include_link_out_of_the_folder_refused(tmp_path):
    outside = _write(tmp_path, "x.k", b"*NODE\n       1             0.0             0.0             0.0\n")
    (tmp_path / "deck").mkdir()
    os.symlink(outside, tmp_path / "deck" / "x.k")
    data = _plate_deck("small")[0].replace(b"*END", b"*INCLUDE\nx.k\n*END")
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.read(_write(tmp_path / "deck", "main.k", data))
    assert e.value.code == "include_outside"


def test_include_cycle_missing_and_too_deep(tmp_path):
    _write(tmp_path, "a.k", b"*INCLUDE\nb.k\n")
    _write(tmp_path, "b.k", b"*INCLUDE\na.k\n")
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.includes(_write(tmp_path, "main.k", b"*KEYWORD\n*INCLUDE\na.k\n*END\n"))
    assert e.value.code == "bad_include" and "cycle" in e.value.message
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.includes(_write(tmp_path, "miss.k", b"*KEYWORD\n*INCLUDE\nnone.k\n*END\n"))
    assert e.value.code == "include_missing" and e.value.details["include"] == "none.k"
    _write(tmp_path, "c.k", b"$ nothing\n")
    _write(tmp_path, "parts/c.k", b"*INCLUDE\nc.k\n")  # c.k beside the deck, not parts/c.k itself: no cycle
    assert lsdyna.includes(_write(tmp_path, "nested.k", b"*KEYWORD\n*INCLUDE\nparts/c.k\n*END\n")) == \
        ["parts/c.k", "c.k"]
    with pytest.raises(UnreadableFileError) as e:  # c.k once from the deck and once from parts/c.k
        lsdyna.includes(_write(tmp_path, "twice.k", b"*KEYWORD\n*INCLUDE\nparts/c.k\nc.k\n*END\n"))
    assert e.value.code == "bad_include" and "twice" in e.value.message
    for k in range(10):
        _write(tmp_path, f"d{k}.k", f"*INCLUDE\nd{k + 1}.k\n".encode())
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.includes(_write(tmp_path, "deep.k", b"*KEYWORD\n*INCLUDE\nd0.k\n*END\n"))
    assert e.value.code == "bad_include" and "deep" in e.value.message


def test_node_transform_refused(tmp_path):
    data = _plate_deck("small")[0].replace(b"*END", b"*NODE_TRANSFORM\n         1         7\n*END")
    with pytest.raises(UnreadableFileError) as e:
        lsdyna.read(_write(tmp_path, "t.k", data))
    assert e.value.code == "unsupported_coordinate_system"


# ---------------------------------------------------------------------------------------------------------------
# the coordinate text


@pytest.mark.parametrize("width", [16, 20])
def test_field_text_fits_and_reads_back_closest(width):
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.normal(size=200) * 10.0 ** rng.integers(-20, 20, 200), [0.0, -0.0, 1 / 3, -1e-300,
                                                                                        1e300, -123456789.123456789]])
    for x in values:
        t = lsdyna.field_text(x, width)
        assert len(t) <= width
        if len(repr(float(x)).replace("e-0", "e-").replace("e+0", "e+")) <= width:
            assert float(t) == x
        else:
            assert abs(float(t) - x) <= abs(x) * (1e-9 if width == 16 else 1e-13)
        assert not t.endswith(b"e+00") and b"e+0" not in t
