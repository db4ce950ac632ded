"""Nastran GRID precision: the rounding a written deck leaves is reported, and large field keeps moved nodes.

The written decks are read here by a few lines of fixed-field parsing,
independent of tetmorph's Nastran code.
"""

from __future__ import annotations

import json
import re

import meshio
import numpy as np
import pytest

from solver import precompute, read_mesh, write_mesh
from solver.cli import main
from tests.conftest import DATA

SMALL = DATA / "bar_small.bdf"


def _real(field: str) -> float:
    """A Nastran real: blank is 0, the exponent's E may be left out (``1.5-3``)."""
    s = field.strip()
    if not s:
        return 0.0
    return float(re.sub(r"(?<=[0-9.])([+-])(?=\d+$)", r"e\1", s))


def _grids(text: str) -> dict[int, tuple[np.ndarray, list[str]]]:
    """GRID id -> (X1, X2, X3) and the card's lines, for small-, large- and free-field cards."""
    lines = text.splitlines()
    bulk = next(k for k, ln in enumerate(lines) if ln.startswith("BEGIN BULK"))
    out = {}
    k = bulk + 1
    while not lines[k].startswith("ENDDATA"):
        ln = lines[k]
        if ln.startswith("GRID,"):
            f = ln.split(",")
            out[int(f[1])] = (np.array([_real(v) for v in f[3:6]]), [ln])
        elif ln.startswith("GRID*"):
            nxt = lines[k + 1]
            assert nxt.startswith("*")
            out[int(ln[8:24])] = (np.array([_real(ln[40:56]), _real(ln[56:72]), _real(nxt[8:24])]), [ln, nxt])
            k += 2
            continue
        elif ln.startswith("GRID"):
            f = ln.ljust(48)
            out[int(f[8:16])] = (np.array([_real(f[24:32]), _real(f[32:40]), _real(f[40:48])]), [ln])
        k += 1
    return out


def _moved(V: np.ndarray) -> np.ndarray:
    """Nodes past x = 60 bent down by a smooth amount no 8-column field holds exactly."""
    P = V.copy()
    far = P[:, 0] > 60
    P[far, 2] -= 1e-3 * (P[far, 0] - 60) ** 1.5 / 7
    P[far, 1] += np.sqrt(2) * 1e-4 * P[far, 0]
    return P


@pytest.mark.parametrize("name, low, high", [("bar_small.bdf", 1e-7, 1e-4), ("bar10_small.bdf", 1e-7, 1e-4),
                                             ("bar_large.bdf", 1e-16, 1e-12), ("bar_free.bdf", 0.0, 0.0)])
def test_rounding_of_a_deck_is_reported(tmp_path, name, low, high):
    mesh = read_mesh(DATA / name)
    P = _moved(mesh.V)
    out = tmp_path / "bent.bdf"
    w = write_mesh(mesh, P, out)
    grids = _grids(out.read_text())
    ids = sorted(grids)
    assert len(ids) == mesh.n
    X = np.array([grids[i][0] for i in ids])
    measured = float(np.abs(X - P).max())
    assert w.to_dict()["write_rounding"] == measured
    assert low <= measured <= high  # 8 columns on a 100 mm bar: some 1e-5 are left; 16: some 1e-14
    # unmoved, it is exact
    assert write_mesh(mesh, mesh.V, tmp_path / "rest.bdf").write_rounding == 0.0


def test_rounding_of_a_deck_written_from_another_format(tmp_path):
    mesh = read_mesh(DATA / "bracket.inp")
    P = mesh.V * (1 + 1 / 3)
    out = tmp_path / "bracket.bdf"
    w = write_mesh(mesh, P, out, lossy=True)  # a deck has no named sets
    grids = _grids(out.read_text())
    X = np.array([grids[i][0] for i in sorted(grids)])
    assert not w.patched and w.write_rounding == float(np.abs(X - P).max()) and w.write_rounding < 1e-12


def test_large_field_keeps_moved_nodes_and_the_text_of_the_rest(tmp_path):
    mesh = read_mesh(SMALL)
    P = _moved(mesh.V)
    # a moved node whose new value fits 8 columns exactly stays small field
    exact = int(np.flatnonzero(mesh.V[:, 0] <= 60)[0])
    P[exact] = mesh.V[exact] + [0.0, 0.0, 0.25]
    out = tmp_path / "bent.bdf"
    w = write_mesh(mesh, P, out, nastran_large=True)
    text = out.read_text()
    src = _grids(SMALL.read_text())
    grids = _grids(text)
    ids = sorted(src)
    assert sorted(grids) == ids and len(ids) == mesh.n
    X = np.array([grids[i][0] for i in ids])
    moved = (P != mesh.V).any(1)
    scale = np.abs(P).max(axis=1, keepdims=True)
    assert (np.abs(X - P)[moved] <= 1e-12 * scale[moved]).all()
    for k, i in enumerate(ids):
        if not moved[k]:
            assert grids[i][1] == src[i][1]  # unmoved: the card's line, byte for byte
        elif k == exact:
            assert grids[i][1][0].startswith("GRID ") and (X[k] == P[k]).all()
        else:
            assert grids[i][1][0].startswith("GRID*")
    assert np.count_nonzero([grids[i][1][0].startswith("GRID*") for i in ids]) == moved.sum() - 1
    assert w.write_rounding == float(np.abs(X - P).max())
    # everything but the GRID cards is unchanged, in order
    a = [ln for ln in SMALL.read_text().splitlines() if not ln.startswith("GRID")]
    b = [ln for ln in text.splitlines() if not ln.startswith(("GRID", "*"))]
    assert a == b
    # the deck still parses, with the same cells, and reads back into tetmorph
    back = meshio.read(out)
    np.testing.assert_allclose(back.points, P, rtol=0, atol=1e-12 * 100)
    assert [c.type for c in back.cells] == [c.type for c in meshio.read(SMALL).cells]
    np.testing.assert_array_equal(read_mesh(out).T, mesh.T)


def test_large_field_leaves_a_card_with_a_continuation_mark_small(tmp_path):
    deck = (b"BEGIN BULK\nGRID    1               0.      0.      0.\n"
            + b"GRID    2               1.      0.      0.".ljust(72) + b"+G2\n+G2\n"
            + b"CTETRA  1       1       1       2       3       4\n"
            b"GRID    3               0.      1.      0.\nGRID    4               0.      0.      1.\nENDDATA\n")
    src = tmp_path / "t.bdf"
    src.write_bytes(deck)
    mesh = read_mesh(src)
    P = mesh.V + 1 / 3
    write_mesh(mesh, P, tmp_path / "out.bdf", nastran_large=True)
    grids = _grids((tmp_path / "out.bdf").read_text())
    assert [grids[i][1][0][:5] for i in (1, 2, 3, 4)] == ["GRID*", "GRID ", "GRID*", "GRID*"]
    assert "+G2" in grids[2][1][0] and abs(grids[2][0] - P[1]).max() < 1e-6


def test_large_field_is_listed_as_skipped_for_other_formats(tmp_path):
    mesh = read_mesh(DATA / "bracket.inp")
    w = write_mesh(mesh, mesh.V, tmp_path / "b.inp", nastran_large=True)
    assert w.patched and w.write_rounding is None
    assert any(s.startswith("nastran_large") for s in w.skipped)


@pytest.mark.parametrize("large", [False, True])
def test_cli_morph_reports_the_rounding_and_writes_large_field(tmp_path, large):
    spec = tmp_path / "spec.json"
    move = tmp_path / "move.json"
    spec.write_text(json.dumps({"selections": {"root": {"box": {"min": [-1, -1, -1], "max": [0.5, 21, 11]}},
                                               "tip": {"box": {"min": [99.5, -1, -1], "max": [101, 21, 11]}}},
                                "fixed": ["root"], "handles": {"tip": "tip"}}))
    move.write_text(json.dumps({"handles": {"tip": {"translation": [0, 0, 1 / 3]}}}))
    out = tmp_path / "out.bdf"
    rep = tmp_path / "rep.json"
    args = ["morph", str(SMALL), "--spec", str(spec), "--move", str(move), "--output", str(out),
            "--report", str(rep)] + (["--nastran-large"] if large else [])
    assert main(args) == 0
    grids = _grids(out.read_text())
    src = _grids(SMALL.read_text())
    tip = [i for i, (x, _) in src.items() if x[0] > 99.5]
    for i in tip:  # the handle moved by exactly 1/3
        err = abs(grids[i][0][2] - (src[i][0][2] + 1 / 3))
        assert (err <= 1e-12 * 100) if large else (1e-8 < err < 1e-4)
    rounding = json.loads(rep.read_text())["written"]["write_rounding"]
    assert (rounding <= 1e-12 * 100) if large else (1e-8 < rounding < 1e-4)


def test_doe_rows_written_large_field_keep_their_moved_nodes(tmp_path):
    """``tetmorph doe --nastran-large``: each row's moved nodes to 1e-12, read back from its deck here."""
    spec = {"selections": {"root": {"box": {"min": [-1, -1, -1], "max": [0.01, 21, 11]}},
                           "tip": {"box": {"min": [99.99, -1, -1], "max": [101, 21, 11]}}},
            "fixed": ["root"], "handles": {"tip": "tip"}}
    shapes = {"shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 1.0 / 3.0]}}}}}
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    (tmp_path / "shapes.json").write_text(json.dumps(shapes))
    (tmp_path / "plan.csv").write_text("bend\n1\n2.5\n")
    out = {}
    for large in (False, True):
        folder = tmp_path / ("large" if large else "small")
        args = ["doe", str(SMALL), "--spec", str(tmp_path / "spec.json"), "--shapes", str(tmp_path / "shapes.json"),
                "--plan", str(tmp_path / "plan.csv"), "--output", str(folder / "{i}.bdf"),
                "--summary", str(folder / "summary.csv")]
        assert main(args + (["--nastran-large"] if large else [])) == 0
        out[large] = [_grids((folder / f"{i}.bdf").read_text()) for i in (1, 2)]
    src = _grids(SMALL.read_text())
    mesh = read_mesh(SMALL)
    d = precompute(mesh, spec)
    ids = sorted(src)
    for theta, small_row, large_row in zip((1.0, 2.5), out[False], out[True], strict=True):
        P = d.solve({"handles": {"tip": {"translation": [0, 0, theta / 3.0]}}}).V  # the row's positions
        X = np.array([large_row[i][0] for i in ids])
        moved = (P != mesh.V).any(axis=1)
        assert moved.any() and (np.abs(X - P)[moved] <= 1e-12 * np.abs(P).max()).all()
        for k, i in enumerate(ids):
            if not moved[k]:
                assert large_row[i][1] == src[i][1]  # unmoved: the card's text
        big = [i for i in ids if large_row[i][1][0].startswith("GRID*")]
        assert big  # some moved nodes needed large field
        err_small = max(np.abs(small_row[i][0] - large_row[i][0]).max() for i in big)
        assert 1e-9 < err_small < 1e-4  # what the 8-column fields rounded away
