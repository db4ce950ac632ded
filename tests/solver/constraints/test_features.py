"""Feature extraction: min-cut regions (Form features §4.3) and automatic hole/boss/plane candidates."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from solver import SpecError, precompute, read_mesh
from solver.cli import main
from solver.constraints.features import feature_candidates, feature_region

DATA = Path(__file__).resolve().parents[2] / "data"


PLATE_HOLES = {1: (160 / 3, 80 / 3), 2: (320 / 3, 80 / 3), 3: (160 / 3, 160 / 3), 4: (320 / 3, 160 / 3)}


def _on_cylinder(mesh, x, y, r):
    return np.flatnonzero(mesh.boundary & (np.abs(np.hypot(mesh.V[:, 0] - x, mesh.V[:, 1] - y) - r) < 1e-6))


def test_every_hole_of_the_plate_is_found_and_no_plane_is_a_cylinder():
    mesh = read_mesh(DATA / "plate.inp")
    cands = feature_candidates(mesh)
    holes = [c for c in cands if c.kind == "hole"]
    assert len(holes) == 4 and not [c for c in cands if c.kind == "boss"]
    found = set()
    for c in holes:
        assert abs(c.params["radius"] - 6.0) < 1e-6
        assert abs(abs(c.params["axis"][2]) - 1) < 1e-9
        k = min(PLATE_HOLES, key=lambda k: np.hypot(*(np.array(PLATE_HOLES[k]) - c.params["center"][:2])))
        assert np.hypot(*(np.array(PLATE_HOLES[k]) - c.params["center"][:2])) < 1e-6
        assert np.array_equal(c.ids, np.sort(mesh.sets[f"HOLE{k}"]))
        found.add(k)
    assert found == set(PLATE_HOLES)
    planes = [c for c in cands if c.kind == "plane"]
    assert len(planes) == 6  # top, bottom and four sides
    for c in planes:
        d = (mesh.V[c.ids] - c.params["point"]) @ c.params["normal"]
        assert np.abs(d).max() < 1e-9


def test_holes_and_bosses_of_a_generated_part(tmp_path):
    """A gmsh block with a through hole (r 4) and a boss (r 3) on top: one of each, nothing else curved."""
    gmsh = pytest.importorskip("gmsh")
    path = str(tmp_path / "part.msh")
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        block = occ.addBox(0, 0, 0, 40, 30, 10)
        hole = occ.addCylinder(12, 15, -1, 0, 0, 12, 4)
        boss = occ.addCylinder(28, 15, 10, 0, 0, 6, 3)
        cut, _ = occ.cut([(3, block)], [(3, hole)])
        occ.fuse(cut, [(3, boss)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 2.0)
        gmsh.model.mesh.generate(3)
        gmsh.write(path)
    finally:
        gmsh.finalize()
    mesh = read_mesh(path)
    cands = feature_candidates(mesh)
    kinds = sorted(c.kind for c in cands if c.kind in ("hole", "boss"))
    assert kinds == ["boss", "hole"]
    hole = next(c for c in cands if c.kind == "hole")
    boss = next(c for c in cands if c.kind == "boss")
    assert abs(hole.params["radius"] - 4) < 1e-6 and abs(boss.params["radius"] - 3) < 1e-6
    assert np.array_equal(hole.ids, _on_cylinder(mesh, 12, 15, 4))
    assert np.array_equal(boss.ids, _on_cylinder(mesh, 28, 15, 3))
    assert not [c for c in cands if c.kind == "other"]


def test_min_cut_separates_the_hole_wall_at_its_sharp_rims():
    mesh = read_mesh(DATA / "bracket.inp")
    r = np.hypot(mesh.V[:, 0] - 60, mesh.V[:, 1] - 10)
    z = mesh.V[:, 2]
    # a loose band around both rims: the wall's border is inside it, not given
    band = np.flatnonzero(mesh.boundary & (r < 8) & ((z > 7) | (z < 3)))
    region = feature_region(mesh, band)
    assert np.array_equal(region["ids"], _on_cylinder(mesh, 60, 10, 5))
    assert abs(region["area"] - 2 * np.pi * 5 * 10) < 0.02 * 2 * np.pi * 5 * 10
    # the region is usable as a rigid feature
    spec = {"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"},
                           "wall": {"ids": region["ids"].tolist()}},
            "fixed": ["root"], "handles": {"tip": "tip"},
            "features": [{"selection": "wall", "mode": "rigid", "name": "bolt"}]}
    P = precompute(mesh, spec).solve({"handles": {"tip": {"translation": [0, 0, 15]}}}).V
    ids = region["ids"]
    D0 = mesh.V[ids, None] - mesh.V[None, ids]
    D = P[ids, None] - P[None, ids]
    assert np.abs(np.linalg.norm(D, axis=2) - np.linalg.norm(D0, axis=2)).max() < 1e-9 * 5


def test_band_that_does_not_separate_is_refused():
    mesh = read_mesh(DATA / "bracket.inp")
    r = np.hypot(mesh.V[:, 0] - 60, mesh.V[:, 1] - 10)
    with pytest.raises(SpecError) as e:
        feature_region(mesh, np.flatnonzero(mesh.boundary & (r < 8) & (mesh.V[:, 2] < 3)))
    assert e.value.code == "band_not_separating" and "1" in str(e.value)
    with pytest.raises(SpecError) as e:
        feature_region(mesh, np.array([0]))
    assert e.value.code == "empty_band"


def test_cli_features_prints_and_writes_sets(tmp_path, capsys):
    out = tmp_path / "plate_features.inp"
    assert main(["features", str(DATA / "plate.inp"), "--write", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    names = [c["name"] for c in doc["candidates"]]
    assert names.count("plane_1") == 1 and sum(n.startswith("hole_") for n in names) == 4
    back = read_mesh(out)
    assert {"hole_1", "hole_4", "plane_6", "HOLE1", "FIXED"} <= set(back.sets)
    np.testing.assert_array_equal(back.V, read_mesh(DATA / "plate.inp").V)
    band = ['{"box": {"min": [52, 2, -1], "max": [68, 18, 2]}, "boundary_only": true}',
            '{"box": {"min": [52, 2, 8], "max": [68, 18, 11]}, "boundary_only": true}']
    assert main(["features", str(DATA / "bracket.inp"), "--band", band[0], "--band", band[1]]) == 0
    assert json.loads(capsys.readouterr().out)["region"]["vertices"] == 61
    assert main(["features", str(DATA / "bracket.inp"), "--band", "{not json"]) == 1
    assert "invalid_json" in capsys.readouterr().err
