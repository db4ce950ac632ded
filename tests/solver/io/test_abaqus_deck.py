"""Abaqus decks as Abaqus reads them: assemblies, several node blocks, sets in every scope, includes.

Every check reads the written file with the few-line reader of tests/solver/io/abaqus_assembly.py
and places the instances with the test's own rotation, not with the reader under test.
"""

from __future__ import annotations

import numpy as np
import pytest

from solver import read_mesh, write_mesh
from solver.errors import LossyWriteError, SolverError, UnreadableFileError
from solver.io import detect_format
from tests.conftest import DATA, shared_file
from tests.solver.io.abaqus_assembly import LUG_SCALE, assembly_deck, bracket, node_lines, place


def _write(tmp_path, text: str, name: str = "assembly.inp"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _by_label(mesh, rows):
    return mesh.V[rows]


def test_a_two_part_assembly_is_read_in_assembly_coordinates(tmp_path):
    labels, X, elabels, conn, sets = bracket()
    mesh = read_mesh(_write(tmp_path, assembly_deck()))
    n = len(labels)
    assert mesh.n == 2 * n and mesh.T10 is not None and len(mesh.T10) == 2 * len(elabels)
    # Bracket-1 first, as written; Lug-1's part-local nodes (half size) placed by its instance lines
    np.testing.assert_array_equal(mesh.V[:n], X)
    np.testing.assert_allclose(mesh.V[n:], place(LUG_SCALE * X), rtol=0, atol=1e-12)
    # part-local numbering: the two parts' node 1 stay two nodes, and the volume is one manifold mesh each
    vol = np.einsum("ij,ij->i", np.cross(mesh.V[mesh.T[:, 1]] - mesh.V[mesh.T[:, 0]],
                                         mesh.V[mesh.T[:, 2]] - mesh.V[mesh.T[:, 0]]),
                    mesh.V[mesh.T[:, 3]] - mesh.V[mesh.T[:, 0]]) / 6
    assert (vol > 0).all()
    np.testing.assert_allclose(vol[len(elabels):].sum(), LUG_SCALE ** 3 * vol[:len(elabels)].sum(), rtol=1e-12)


def test_sets_of_parts_instances_and_the_assembly_are_named_by_scope(tmp_path):
    labels, _, _, _, sets = bracket()
    mesh = read_mesh(_write(tmp_path, assembly_deck()))
    n = len(labels)
    row = {int(lab): k for k, lab in enumerate(labels)}
    fixed = sorted(row[i] for i in sets["FIXED"])
    assert mesh.sets["Bracket-1.FIXED"].tolist() == fixed
    assert mesh.sets["Lug-1.FIXED"].tolist() == [n + k for k in fixed]
    assert mesh.sets["CLAMP"].tolist() == fixed  # *Nset, instance=Bracket-1 naming the part's set
    assert mesh.sets["LUGCLAMP"].tolist() == [n + k for k in fixed]
    assert mesh.sets["Lug-1.ENDS"].tolist() == [n + row[1], n + row[5], n + row[9]]  # GENERATE 1, 9, 4
    assert "FIXED" not in mesh.sets  # no unscoped part set
    # the internal element set of the assembly: the nodes of Lug-1's elements 1, 2, 3
    lug_elems = mesh.source.cells[1].data[:3]
    assert mesh.sets["LUGFEW"].tolist() == sorted(set(lug_elems.ravel().tolist()))


def test_a_zero_move_writes_the_assembly_back_byte_for_byte(tmp_path):
    src = _write(tmp_path, assembly_deck())
    mesh = read_mesh(src)
    w = write_mesh(mesh, mesh.V, tmp_path / "out.inp")
    assert w.patched
    assert (tmp_path / "out.inp").read_bytes() == src.read_bytes()


def test_a_moved_instance_is_written_in_its_part_local_coordinates(tmp_path):
    labels, X, _, _, _ = bracket()
    src = _write(tmp_path, assembly_deck())
    mesh = read_mesh(src)
    n = len(labels)
    V = mesh.V.copy()
    lug = np.arange(n, 2 * n)
    far = lug[X[:, 0] > 60]
    V[far, 2] += 1.5  # the lug's far end lifted in assembly z
    write_mesh(mesh, V, tmp_path / "out.inp")
    before, after = src.read_text().splitlines(), (tmp_path / "out.inp").read_text().splitlines()
    assert len(before) == len(after)
    changed = [k for k, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
    nodes = node_lines((tmp_path / "out.inp").read_text())
    # only node lines of part Lug changed, one per moved node
    assert len(changed) == far.size
    lug_lines = {int(before[k].split(",")[0]) for k in changed}
    assert lug_lines == {int(labels[k - n]) for k in far}
    local = np.array([nodes[("LUG", int(lab))] for lab in labels])
    np.testing.assert_allclose(place(local), V[lug], rtol=0, atol=1e-9)  # the test's own placement
    # and Bracket's lines are untouched
    assert all(nodes[("BRACKET", int(lab))] == x for lab, x in zip(labels, X.tolist(), strict=True))
    back = read_mesh(tmp_path / "out.inp")
    np.testing.assert_allclose(back.V, V, rtol=0, atol=1e-9)


def test_instances_of_one_part_that_now_differ_are_refused_naming_them(tmp_path):
    labels, X, _, _, _ = bracket()
    mesh = read_mesh(_write(tmp_path, assembly_deck(second_bracket=True)))
    n = len(labels)
    assert mesh.n == 3 * n
    np.testing.assert_array_equal(mesh.V[2 * n:], X + [0, -100, 0])  # Bracket-2 (instances in order)
    V = mesh.V.copy()
    V[:n, 2] += 0.5 * (X[:, 0] / 100)  # Bracket-1 bent, Bracket-2 not
    with pytest.raises(LossyWriteError) as e:
        write_mesh(mesh, V, tmp_path / "out.inp")
    assert "Bracket" in e.value.message and "Bracket-1" in e.value.message and "Bracket-2" in e.value.message
    assert not (tmp_path / "out.inp").exists()
    # moved alike, the part holds both
    V = mesh.V.copy()
    V[:n, 2] += 0.5
    V[2 * n:, 2] += 0.5
    write_mesh(mesh, V, tmp_path / "alike.inp")
    nodes = node_lines((tmp_path / "alike.inp").read_text())
    np.testing.assert_allclose([nodes[("BRACKET", int(lab))][2] for lab in labels], X[:, 2] + 0.5, atol=1e-12)


def test_several_node_and_element_blocks_are_one_mesh(tmp_path):
    labels, X, *_ = bracket()
    mesh = read_mesh(_write(tmp_path, assembly_deck(node_blocks=3)))
    np.testing.assert_array_equal(mesh.V[:len(labels)], X)
    # a flat deck whose elements come before some of their nodes, in two *NODE blocks, keywords in any case
    text = (DATA / "ccx_bracket.inp").read_text()
    head, rest = text.split("*ELEMENT", 1)
    node_text = head.split("*NODE, NSET=NALL\n", 1)[1].splitlines(keepends=True)
    half = len(node_text) // 2
    deck = ("*heading\nsplit\n*node , nset = FIRST\n" + "".join(node_text[:half]) + "*ELEMENT" + rest.split("*NSET")[0]
            + "*NoDe\n" + "".join(node_text[half:]))
    m = read_mesh(_write(tmp_path, deck, "split.inp"))
    flat = read_mesh(DATA / "ccx_bracket.inp")
    np.testing.assert_array_equal(m.V, flat.V)
    np.testing.assert_array_equal(m.T10, flat.T10)
    assert m.sets["FIRST"].tolist() == list(range(half))


def test_an_include_is_followed_and_written_back_beside_the_deck(tmp_path):
    text = (DATA / "ccx_bracket.inp").read_text()
    head, rest = text.split("*ELEMENT", 1)
    (tmp_path / "inc").mkdir()
    (tmp_path / "inc" / "nodes.inp").write_text(head.split("\n", 2)[2])  # the *NODE block
    src = _write(tmp_path, "*HEADING\nwith an include\n*INCLUDE, INPUT=inc/nodes.inp\n*ELEMENT" + rest, "main.inp")
    mesh = read_mesh(src)
    flat = read_mesh(DATA / "ccx_bracket.inp")
    np.testing.assert_array_equal(mesh.V, flat.V)
    out = tmp_path / "out"
    out.mkdir()
    write_mesh(mesh, mesh.V, out / "main.inp")
    assert (out / "main.inp").read_bytes() == src.read_bytes()
    assert (out / "inc" / "nodes.inp").read_bytes() == (tmp_path / "inc" / "nodes.inp").read_bytes()
    V = mesh.V + [0, 0, 1.0]
    write_mesh(mesh, V, out / "moved.inp")
    assert (out / "moved.inp").read_bytes() == src.read_bytes()  # the nodes live in the include
    nodes = node_lines((out / "inc" / "nodes.inp").read_text())
    np.testing.assert_allclose([nodes[("", i)] for i in range(1, mesh.n + 1)], V, atol=1e-12)


@pytest.mark.parametrize("target, code", [("../outside.inp", "include_outside"), ("/etc/hostname", "include_outside"),
                                          ("missing.inp", "include_missing"), ("main.inp", "bad_include")])
def test_includes_outside_the_folder_missing_or_circular_are_refused(tmp_path, target, code):
    (tmp_path / "outside.inp").write_text("*NODE\n1, 0, 0, 0\n")
    d = tmp_path / "deck"
    d.mkdir()
    src = _write(d, f"*HEADING\n*INCLUDE, INPUT={target}\n", "main.inp")
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(src)
    assert e.value.code == code and target.split("/")[-1] in e.value.message


@pytest.mark.parametrize("text, code, words", [
    ("*NODE\n1, 0, 0, 0\n1, 1, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 1, 1, 1, 1\n", "duplicate_node", "node 1"),
    ("*PART, NAME=P\n*NODE\n1, 0, 0, 0\n*END PART\n", "bad_instance", "'P'"),
    ("*PART, NAME=P\n*END PART\n*ASSEMBLY, NAME=A\n*INSTANCE, NAME=I, PART=Q\n*END INSTANCE\n", "bad_instance",
     "'Q'"),
    ("*NODE\n1, 0, 0, 0\n*NSET, NSET=A\n NOPE\n", "bad_set", "'NOPE'"),
    ("*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 1, 1, 0\n4, 0, 1, 0\n*ELEMENT, TYPE=S4R\n1, 1, 2, 3, 4\n"
     "*ELEMENT, TYPE=B31\n2, 1, 2\n3, 2, 3\n", "no_elements", "1 shell element (S4R), 2 beam elements (B31)"),
    ("*NODE\n1, 0, 0, x\n", "bad_node_line", "line 2"),
])
def test_malformed_decks_get_typed_errors_that_name_the_defect(tmp_path, text, code, words):
    with pytest.raises(SolverError) as e:
        read_mesh(_write(tmp_path, text, "bad.inp"))
    assert e.value.code == code and words in e.value.message


def test_a_real_cae_deck_reads_its_part_and_assembly_sets():
    mesh = read_mesh(shared_file("tet/tractor_wheel_coarse.INP"))  # COS2ABQ: *PART, *ASSEMBLY, one instance
    text = open(shared_file("tet/tractor_wheel_coarse.INP"), encoding="latin-1").read()
    count = sum(1 for _ in node_lines(text))
    assert mesh.n == count and mesh.sets["PART1-1.NSET1"].size == count
    assert mesh.sets["BC_RIMTIRE"].size == 151


def test_an_lsdyna_like_keyword_file_is_not_sniffed_as_abaqus():
    assert detect_format(b"*KEYWORD\n*NODE\n       1             0.0             0.0             0.0\n") != "abaqus"
    assert detect_format((DATA / "plate.inp").read_bytes()[:8192]) == "abaqus"


def test_the_cli_morphs_an_assembly_in_place_or_flat(tmp_path):
    import json

    from solver.cli import main

    labels, X, *_ = bracket()
    n = len(labels)
    src = _write(tmp_path, assembly_deck())
    spec = {"selections": {"fix": {"set": "Lug-1.FIXED"}, "hole": {"set": "Lug-1.HOLE"},
                           "bracket": {"set": "Bracket-1.FIXED"}},
            "fixed": ["fix", "bracket"], "handles": {"hole": "hole"}}
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    (tmp_path / "moves.json").write_text(json.dumps([{"handles": {"hole": {"translation": [0, 0, 0.5]}}}]))
    args = ["morph", str(src), "--spec", str(tmp_path / "spec.json"), "--moves", str(tmp_path / "moves.json")]
    assert main([*args, "--output", str(tmp_path / "in_place_{i}.inp")]) == 0
    assert main([*args, "--output", str(tmp_path / "flat_{i}.inp"), "--flatten"]) == 0
    in_place = node_lines((tmp_path / "in_place_0.inp").read_text())
    flat = node_lines((tmp_path / "flat_0.inp").read_text())
    assert {p for p, _ in in_place} == {"BRACKET", "LUG"} and {p for p, _ in flat} == {""}
    lug = np.array([in_place[("LUG", int(lab))] for lab in labels])
    flat_lug = np.array([flat[("", int(lab) + 20000)] for lab in labels])  # Lug-1 is the second instance
    np.testing.assert_allclose(place(lug), flat_lug, rtol=0, atol=1e-9)
    assert np.abs(flat_lug - place(LUG_SCALE * X)).max() > 0.1  # it moved
    assert n == len(flat_lug)


def test_an_lsdyna_deck_named_inp_is_named_for_what_it_is(tmp_path):
    text = "*KEYWORD\n*NODE\n       1             0.0             0.0             0.0\n*END\n"
    p = _write(tmp_path, text, "model.inp")
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(p)
    assert e.value.code == "wrong_format" and e.value.details["detected"] == "lsdyna" and ".k" in e.value.message


def test_reading_a_deck_leaves_no_reference_cycle_holding_its_lines(tmp_path):
    """The parsed deck (a tuple per line) is freed when the read returns, not at the next full collection:
    at 1M tets it held about 0.3 GB through the set-up that followed."""
    import gc

    (tmp_path / "a.inp").write_text(assembly_deck())
    for path in (DATA / "bracket.inp", tmp_path / "a.inp"):
        gc.collect()
        gc.disable()
        try:
            mesh = read_mesh(path)
            found = gc.collect()
        finally:
            gc.enable()
        assert mesh.n > 0 and found == 0, (path.name, found)
