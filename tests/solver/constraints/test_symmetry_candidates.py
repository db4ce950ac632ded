"""Symmetry found in a mesh, and the Abaqus cyclic definitions, as SPEC entries that work when pasted."""

from __future__ import annotations

import json

from scipy.spatial import cKDTree

from solver import mesh_from_arrays, precompute, read_mesh
from solver.cli import main
from solver.constraints.symmetry_candidates import abaqus_cyclic, resolve_cyclic, symmetry_candidates
from tests.conftest import DATA, shared_file
from tests.gmsh_parts import symmetric_bar


def test_the_plate_has_its_three_mirror_planes():
    m = read_mesh(DATA / "plate.inp")  # 160 x 80 x 4 with holes at 1/3 and 2/3: symmetric about all three
    planes = {tuple(c["plane"]["normal"]): c for c in symmetry_candidates(m)}
    assert set(planes) == {(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)}
    assert planes[(1.0, 0.0, 0.0)]["plane"]["point"] == [80.0, 40.0, 2.0]


def test_a_cad_part_meshed_unsymmetrically_is_recognised_with_its_gap():
    m = read_mesh(DATA / "bracket.inp")  # a bar with a bolt hole: symmetric about y = 10 and z = 5
    planes = {tuple(c["plane"]["normal"]): c for c in symmetry_candidates(m)}
    assert set(planes) == {(0.0, 1.0, 0.0), (0.0, 0.0, 1.0)}
    c = planes[(0.0, 1.0, 0.0)]
    assert c["plane"]["point"] == [50.0, 10.0, 5.0] and c["exact_pairs"] < 0.5  # gmsh's mesh is not mirrored
    assert 0 < c["tolerance"] < 0.01 * 100  # the chordal gap of the curved hole, well under 1% of the length


def test_a_pasted_candidate_holds_a_symmetric_morph():
    m = mesh_from_arrays(*symmetric_bar(4.0))
    cand = next(c for c in symmetry_candidates(m) if c["plane"]["normal"] == [1.0, 0.0, 0.0])
    assert cand["exact_pairs"] == 1.0 and cand["plane"]["point"][0] == 50.0
    entry = {k: cand[k] for k in ("name", "plane", "tolerance")}
    spec = {"selections": {"end": {"box": {"min": [-1, -1, -1], "max": [1, 21, 11]}},
                           "hole": {"sphere": {"center": [30, 10, 5], "radius": 8}, "boundary_only": True}},
            "fixed": ["end"], "handles": {"h": "hole"}, "symmetry": [entry]}
    r = precompute(m, spec).solve({"handles": {"h": {"translation": [0, 0, 3]}}})
    assert r.report["conflicting_constraints"] == [] and r.report["inverted_elements"] == 0
    mir = r.V * [-1, 1, 1] + [100, 0, 0]
    gap = cKDTree(r.V).query(mir)[0].max()
    assert gap <= 1e-9 * 100


def test_segmenttet_cyclic_definition_is_read_and_its_sign_resolved():
    m = read_mesh(shared_file("tet/segmenttet.inp"))
    (raw,) = abaqus_cyclic(m.raw)
    assert raw["faces"] == ["Nright", "Nleft"] and raw["angle_deg"] == 30.0 and raw["tolerance"] == 0.001
    e = resolve_cyclic(m, raw)
    assert e["angle_deg"] == -30.0
    spec = {"selections": {"Nright": {"set": "Nright"}, "Nleft": {"set": "Nleft"}, "hub": {"ids": [0]}},
            "fixed": ["hub"], "handles": {}, "cyclic": [e]}
    precompute(m, {**spec, "fixed": ["Nright"]})  # the definition is accepted as it is


def test_info_lists_them(capsys):
    assert main(["info", str(shared_file("tet/segmenttet.inp"))]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["symmetry"]["cyclic"][0]["angle_deg"] == -30.0
