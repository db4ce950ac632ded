"""Nastran GRIDs in local coordinate systems (CORD2R, CORD2C, CORD2S): read in the basic system, written back
in their own system, checked against pyNastran, an independent reader.

The decks are bar_small.bdf with a share of its GRIDs rewritten in six systems (one of them a chain of three
RIDs through a cylindrical system) in small, large and free field, with HyperMesh comment cards. The local
numbers are computed here with a few lines of numpy, independent of tetmorph's code.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from solver import read_mesh, write_mesh
from solver.errors import UnreadableFileError
from solver.io.nastran_coords import CoordSystem
from tests.conftest import DATA

SMALL = DATA / "bar_small.bdf"

#: HyperMesh's comment cards, kept byte for byte.
HYPERMESH = ("$$\n$$  HyperMesh commands for coordinate systems\n$$\n"
             '$HMNAME SYSTCOL                1"frames"\n$HWCOLOR SYSTCOL               1       4\n')

#: id -> (kind, RID, A, B, C in the RID system, form of the card).
SYSTEMS = {
    1: ("R", 0, (50.0, 10.0, 5.0), (51.0, 11.0, 6.0), (52.0, 9.0, 5.0), "small"),
    2: ("R", 1, (1.0, 2.0, 3.0), (1.5, 2.0, 4.0), (3.0, 1.0, 3.0), "large"),
    3: ("C", 2, (0.0, 0.0, -10.0), (0.0, 1.0, -10.0), (1.0, 0.0, -10.0), "free"),
    4: ("S", 3, (5.0, 30.0, 2.0), (5.0, 30.0, 12.0), (15.0, 45.0, 2.0), "small"),
    5: ("C", 0, (0.0, 10.0, 5.0), (100.0, 10.0, 5.0), (0.0, 10.0, 15.0), "large"),
    6: ("S", 0, (60.0, 10.0, 5.0), (60.0, 10.0, 15.0), (70.0, 10.0, 5.0), "free"),
}


# ------------------------------------------------------------------ the test's own geometry

def _to_rect(kind: str, X: np.ndarray) -> np.ndarray:
    r, a, b = np.asarray(X, float).T
    if kind == "C":
        return np.c_[r * np.cos(np.radians(a)), r * np.sin(np.radians(a)), b]
    if kind == "S":
        return np.c_[r * np.sin(np.radians(a)) * np.cos(np.radians(b)),
                     r * np.sin(np.radians(a)) * np.sin(np.radians(b)), r * np.cos(np.radians(a))]
    return np.c_[r, a, b]


def _frames() -> dict[int, tuple[str, np.ndarray, np.ndarray]]:
    """id -> (kind, origin, rows x y z), each placed through its RID."""
    out: dict[int, tuple[str, np.ndarray, np.ndarray]] = {}
    for cid, (kind, rid, *abc, _) in SYSTEMS.items():
        pts = np.array(abc, float)
        if rid:
            rk, ro, re_ = out[rid]
            pts = ro + _to_rect(rk, pts) @ re_
        a, b, c = pts
        z = (b - a) / np.linalg.norm(b - a)
        y = np.cross(z, c - a)
        y /= np.linalg.norm(y)
        out[cid] = (kind, a, np.array([np.cross(y, z), y, z]))
    return out


def _local(kind: str, origin: np.ndarray, axes: np.ndarray, P: np.ndarray) -> np.ndarray:
    x, y, z = ((P - origin) @ axes.T).T
    if kind == "C":
        return np.c_[np.hypot(x, y), np.degrees(np.arctan2(y, x)), z]
    if kind == "S":
        return np.c_[np.sqrt(x * x + y * y + z * z), np.degrees(np.arctan2(np.hypot(x, y), z)),
                     np.degrees(np.arctan2(y, x))]
    return np.c_[x, y, z]


def _real(x: float, width: int | None) -> str:
    """A real in at most ``width`` characters (free field: Python's shortest repr)."""
    if width is None:
        s = repr(float(x))
        return s if "." in s or "e" in s else s + "."
    for d in range(width, -1, -1):
        s = f"{x:.{d}f}"
        if len(s) <= width:
            return s if "." in s else s + "."
    raise AssertionError(x)


def _grid(gid: int, cp: int, cd: str, X: np.ndarray, form: str) -> str:
    cps = str(cp) if cp else ""
    if form == "free":
        return f"GRID,{gid},{cps},{','.join(_real(v, None) for v in X)},{cd}\n"
    if form == "large":
        r = [_real(v, 16) for v in X]
        return f"GRID*   {gid:<16d}{cps:<16}{r[0]:>16}{r[1]:>16}\n*       {r[2]:>16}{cd:<16}\n"
    r = [_real(v, 8) for v in X]
    return f"GRID    {gid:<8d}{cps:<8}{r[0]:>8}{r[1]:>8}{r[2]:>8}{cd:<8}".rstrip() + "\n"


def _cord(cid: int) -> str:
    kind, rid, a, b, c, form = SYSTEMS[cid]
    name = "CORD2" + kind
    v = [_real(x, None if form == "free" else 16 if form == "large" else 8) for x in (*a, *b, *c)]
    if form == "free":
        return f"{name},{cid},{rid},{','.join(v[:6])},+\n+,{','.join(v[6:])}\n"
    if form == "large":
        return (f"{name + '*':<8}{cid:<16d}{rid:<16d}{v[0]:>16}{v[1]:>16}\n*       {v[2]:>16}{v[3]:>16}{v[4]:>16}"
                f"{v[5]:>16}\n*       {v[6]:>16}{v[7]:>16}{v[8]:>16}\n")
    return f"{name:<8}{cid:<8d}{rid:<8d}" + "".join(f"{s:>8}" for s in v[:6]) + "+\n+       " + \
        "".join(f"{s:>8}" for s in v[6:]) + "\n"


def _deck(systems: str | None = None, share: int = 2) -> str:
    """bar_small.bdf with GRIDs in the six systems (one GRID in ``share`` keeps basic), in the three field forms.

    A few GRIDs have a CD field (system 5, or 9: a CORD1R system, which only CD names).
    """
    frames = _frames()
    out = []
    k = 0
    for line in SMALL.read_text().splitlines(keepends=True):
        if line.startswith("BEGIN BULK"):
            out.append(line + HYPERMESH)
            out.append(systems if systems is not None else "".join(_cord(c) for c in SYSTEMS))
            out.append("CORD1R  9       1       2       3\n")
            continue
        if not line.startswith("GRID"):
            out.append(line)
            continue
        gid = int(line[8:16])
        P = np.array([float(line[24:32]), float(line[32:40]), float(line[40:48])])
        cp = 0 if k % share == 0 else 1 + (k // share) % len(SYSTEMS)
        cd = "5" if k % 5 == 1 else "9" if k % 5 == 3 else ""
        form = ("small", "large", "free")[k % 3]
        k += 1
        if cp == 0:
            out.append(line if not cd else line.rstrip("\n").ljust(48) + cd + "\n")
            continue
        kind, origin, axes = frames[cp]
        out.append(_grid(gid, cp, cd, _local(kind, origin, axes, P[None])[0], form))
    return "".join(out)


#: pyNastran (BSD-3-Clause), the independent reader, in a virtualenv of its own (it pins numpy < 2)
NASTRAN_PY = Path(__file__).resolve().parents[3] / ".venv-nastran" / "bin" / "python"


def _pynastran(path, punch: bool = False) -> dict[int, np.ndarray]:
    if not NASTRAN_PY.exists():
        pytest.fail(f"{NASTRAN_PY} is missing: make test (the nastrandeps target) makes it")
    out = subprocess.run([str(NASTRAN_PY), str(Path(__file__).with_name("pynastran_positions.py")), str(path),
                          *(["punch"] if punch else [])], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    return {int(k): np.asarray(v, float) for k, v in json.loads(out.stdout).items()}


def _grids(text: str) -> tuple[list[int], list[tuple[str, str]], list[list[str]]]:
    """Ids, (CP, CD) as written, and the lines of each GRID card, in order (small, large and free field)."""
    lines = text.splitlines()
    ids, fields, cards = [], [], []
    k = 0
    while k < len(lines):
        ln = lines[k]
        if ln.startswith("GRID,"):
            f = ln.split(",") + [""] * 8
            ids.append(int(f[1]))
            fields.append((f[2].strip(), f[6].strip()))
            cards.append([ln])
        elif ln.startswith("GRID*"):
            nxt = lines[k + 1]
            ids.append(int(ln[8:24]))
            fields.append((ln[24:40].strip(), nxt[24:40].strip()))
            cards.append([ln, nxt])
            k += 1
        elif ln.startswith("GRID"):
            ids.append(int(ln[8:16]))
            fields.append((ln[16:24].strip(), ln[48:56].strip()))
            cards.append([ln])
        k += 1
    return ids, fields, cards


def _others(text: str) -> list[str]:
    """Every line that is not part of a GRID card."""
    out, skip = [], False
    for ln in text.splitlines(keepends=True):
        if skip and ln.startswith("*"):
            continue
        skip = ln.startswith("GRID*")
        if not ln.startswith("GRID"):
            out.append(ln)
    return out


def _bent(V: np.ndarray) -> np.ndarray:
    """Nodes past x = 60 bent down and sideways by amounts no field holds exactly."""
    P = V.copy()
    far = P[:, 0] > 60
    P[far, 2] -= 1e-3 * (P[far, 0] - 60) ** 1.5 / 7
    P[far, 1] += np.sqrt(2) * 1e-4 * P[far, 0]
    return P


@pytest.fixture
def deck(tmp_path):
    p = tmp_path / "local.bdf"
    p.write_text(_deck())
    return p


# ------------------------------------------------------------------ reading

def test_grids_in_local_systems_read_in_basic_as_pynastran_reads_them(deck):
    mesh = read_mesh(deck)
    ids, fields, _ = _grids(deck.read_text())
    assert {cp for cp, _ in fields} == {"", "1", "2", "3", "4", "5", "6"}
    ref = _pynastran(deck)
    Q = np.array([ref[i] for i in ids])
    np.testing.assert_allclose(mesh.V, Q, rtol=0, atol=1e-9)
    # and where the bar is: the 8-column local fields round by less than 1e-3
    np.testing.assert_allclose(mesh.V, read_mesh(SMALL).V, rtol=0, atol=1e-3)
    np.testing.assert_array_equal(mesh.T, read_mesh(SMALL).T)


@pytest.mark.parametrize("ending", ["ENDDATA\n", ""])
def test_a_fem_deck_without_begin_bulk_reads_and_writes_back(tmp_path, deck, ending):
    """OptiStruct .fem: bulk data alone (HyperMesh header, no SOL, CEND or BEGIN BULK), ENDDATA or not."""
    text = deck.read_text()
    bulk = text[text.index("BEGIN BULK\n") + len("BEGIN BULK\n"):].replace("ENDDATA\n", ending)
    fem = tmp_path / "part.fem"
    fem.write_text("$$\n$$ Optistruct Input Deck Generated by HyperMesh\n$$\n" + bulk)
    mesh = read_mesh(fem)
    assert mesh.file_format == "nastran"
    np.testing.assert_array_equal(mesh.V, read_mesh(deck).V)
    out = tmp_path / "rest.fem"
    w = write_mesh(mesh, mesh.V, out)
    assert w.patched and out.read_bytes() == fem.read_bytes()
    P = _bent(mesh.V)
    w = write_mesh(mesh, P, out)
    assert w.patched and _others(out.read_text()) == _others(fem.read_text())
    ids, _, _ = _grids(out.read_text())
    ref = _pynastran(out, punch=True)
    assert np.abs(np.array([ref[i] for i in ids]) - P).max() == pytest.approx(w.write_rounding, abs=1e-9)
    assert w.write_rounding < 1e-3


# ------------------------------------------------------------------ writing back

def test_a_zero_move_writes_the_deck_back_byte_for_byte(deck, tmp_path):
    mesh = read_mesh(deck)
    out = tmp_path / "same.bdf"
    w = write_mesh(mesh, mesh.V, out)
    assert w.patched and w.write_rounding == 0.0
    assert out.read_bytes() == deck.read_bytes()


@pytest.mark.parametrize("large", [False, True])
def test_moved_nodes_are_written_in_their_own_system(deck, tmp_path, large):
    mesh = read_mesh(deck)
    P = _bent(mesh.V)
    out = tmp_path / "bent.bdf"
    w = write_mesh(mesh, P, out, nastran_large=large)
    assert w.patched
    src, text = deck.read_text(), out.read_text()
    ids0, fields0, cards0 = _grids(src)
    ids, fields, cards = _grids(text)
    assert ids == ids0 and fields == fields0  # CP and CD of every GRID as written
    moved = (P != mesh.V).any(axis=1)
    assert moved.sum() > 50 and (~moved).sum() > 50
    for k in np.flatnonzero(~moved):
        assert cards[k] == cards0[k]  # unmoved: the card's text
    assert _others(text) == _others(src)  # SOL, CEND, CORD2x, CORD1R, HyperMesh comments, elements, loads
    assert HYPERMESH in text
    # pyNastran reads the moved positions back, to what the fields hold
    ref = _pynastran(out)
    Q = np.array([ref[i] for i in ids])
    err = np.abs(Q - P).max()
    assert err == pytest.approx(w.write_rounding, abs=1e-9)
    assert (w.write_rounding < 1e-9) if large else (1e-8 < w.write_rounding < 1e-3)
    # and tetmorph reads them back
    back = read_mesh(out)
    np.testing.assert_allclose(back.V, P, rtol=0, atol=w.write_rounding + 1e-12)
    np.testing.assert_array_equal(back.T, mesh.T)


def test_a_moved_node_keeps_its_azimuth_range(tmp_path):
    """theta = 350 in a cylindrical system stays near 350 (not -10); a node on the axis keeps its theta."""
    text = SMALL.read_text()
    lines = text.splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("GRID    1 "))
    cord = "CORD2C  7               0.      0.      10.     0.      0.      11.\n+       1.      0.      10.\n"
    lines[k] = "GRID    1       7       0.      350.    0.\n"  # on the axis: at (0, 0, 10), as in bar_small
    lines.insert(k, cord)
    p = tmp_path / "cyl.bdf"
    p.write_text("".join(lines))
    mesh = read_mesh(p)
    np.testing.assert_allclose(mesh.V[0], [0.0, 0.0, 10.0], atol=1e-12)
    P = mesh.V.copy()
    P[0] += [0.0, 0.0, 0.5]  # along the axis: r stays 0, theta is undetermined
    write_mesh(mesh, P, tmp_path / "a.bdf")
    assert "GRID    1       7       0.      350.    .5" in (tmp_path / "a.bdf").read_text()
    P[0] = [2 * np.cos(np.radians(-11.0)), 2 * np.sin(np.radians(-11.0)), 10.0]  # theta -11 is 349
    write_mesh(mesh, P, tmp_path / "b.bdf")
    assert "GRID    1       7       2.      349.    0." in (tmp_path / "b.bdf").read_text()


# ------------------------------------------------------------------ refusals

def _refused(tmp_path, text: str, code: str, *words: str) -> UnreadableFileError:
    p = tmp_path / "bad.bdf"
    p.write_text(text)
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(p)
    assert e.value.code == code, (e.value.code, e.value.message)
    for w in words:
        assert w in e.value.message, (w, e.value.message)
    return e.value


def _first_local(text: str) -> int:
    """The id of the first GRID given in a local system."""
    ids, fields, _ = _grids(text)
    return next(i for i, (cp, _) in zip(ids, fields, strict=True) if cp)


def test_an_undefined_system_is_refused_naming_the_grid_and_the_system(tmp_path):
    systems = "".join(_cord(c) for c in SYSTEMS if c != 3)  # system 3 gone: GRIDs in 3, and system 4 (RID 3)
    text = _deck(systems)
    ids, fields, _ = _grids(text)
    first3 = next(i for i, (cp, _) in zip(ids, fields, strict=True) if cp == "3")
    first4 = next(i for i, (cp, _) in zip(ids, fields, strict=True) if cp == "4")
    err = _refused(tmp_path, text, "undefined_coordinate_system", "coordinate system 3", "no CORD2R")
    assert err.details["system"] == 3 and err.details["grid"] in (first3, first4)
    grid = err.details["grid"]
    assert f"GRID {grid}" in err.message and grid in err.details["grids"]
    if grid == first4:
        assert "relative to system 3" in err.message and err.details["chain"] == [4, 3]
    # a CP that names no system at all
    lines = SMALL.read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("GRID"))
    lines[k] = lines[k][:16] + f"{77:<8d}" + lines[k][24:]
    err = _refused(tmp_path, "".join(lines), "undefined_coordinate_system", f"GRID {lines[k][8:16].strip()}",
                   "coordinate system 77")
    assert err.details["chain"] == [77] and err.details["count"] == 1


def test_a_loop_of_rids_is_refused(tmp_path):
    systems = "".join(_cord(c) for c in SYSTEMS if c != 1)
    systems += "CORD2R,1,3,0.,0.,0.,0.,0.,1.,+\n+,1.,0.,0.\n"  # 1 rests on 3, which rests on 2, which rests on 1
    text = _deck(systems)
    err = _refused(tmp_path, text, "cyclic_coordinate_system", "loops")
    assert set(err.details["chain"]) == {1, 2, 3} and f"GRID {err.details['grid']}" in err.message
    assert re.search(r"\b1 -> 3 -> 2 -> 1\b|\b2 -> 1 -> 3 -> 2\b|\b3 -> 2 -> 1 -> 3\b", err.message)


def test_a_cord1_system_and_a_degenerate_one_are_refused_naming_the_card(tmp_path):
    text = _deck().replace("CORD1R  9       1       2       3\n",
                           "CORD1R  9       1       2       3       8       1       2       3\n")
    assert "CORD2S,6,0," in text
    text = text.replace("CORD2S,6,0,", "CORD2S,6,8,")  # system 6 rests on system 8, which three GRIDs define
    err = _refused(tmp_path, text, "unsupported_coordinate_system", "CORD1R", "system 8", "system 6")
    assert err.details["chain"] == [6, 8] and err.details["card"] == "CORD1R"
    flat = ("CORD2R  1       0       50.     10.     5.      51.     11.     6.      +\n"
            "+       53.     13.     8.\n")  # C on the line through A and B
    err = _refused(tmp_path, _deck(flat + "".join(_cord(c) for c in SYSTEMS if c != 1)),
                   "invalid_coordinate_system", "CORD2R", "xz plane")
    assert err.details["system"] == 1 and err.details["card"] == "CORD2R"


# ------------------------------------------------------------------ the module itself

@pytest.mark.parametrize("kind", ["R", "C", "S"])
def test_to_basic_and_from_basic_are_inverse(kind):
    rng = np.random.default_rng(3)
    s = CoordSystem.from_points(1, kind, np.array([[1.0, -2, 3], [1.5, -1, 4], [4.0, 2, -1]]))
    P = rng.normal(scale=20, size=(200, 3))
    X = s.from_basic(P)
    np.testing.assert_allclose(s.to_basic(X), P, rtol=0, atol=1e-11)
    if kind != "R":
        assert (X[:, 0] >= 0).all()
        near = X + [0.0, 0.0, 720.0] if kind == "S" else X + [0.0, 720.0, 0.0]  # two turns further
        Y = s.from_basic(P, near=near)
        np.testing.assert_allclose(Y, near, rtol=0, atol=1e-9)
    np.testing.assert_allclose(_local(kind, s.origin, s.axes, P), X, rtol=0, atol=1e-9)  # the test's formulas
