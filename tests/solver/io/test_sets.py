"""Named sets of decks: every form a reader has for them is read as a set."""

from __future__ import annotations

from solver import precompute, read_mesh
from tests.conftest import shared_file


def test_sets_named_on_node_lines_are_sets_like_any_other():
    path = shared_file("tet/tractor_wheel_coarse.INP")  # *NODE, NSET=NSET1 holds every node of the part
    text = open(path, encoding="latin-1").read().splitlines()
    start = next(k for k, ln in enumerate(text) if ln.upper().replace(" ", "").startswith("*NODE,NSET=NSET1"))
    end = next(k for k in range(start + 1, len(text)) if text[k].startswith("*") and not text[k].startswith("**"))
    expected = sum(1 for ln in text[start + 1:end] if ln.strip() and not ln.startswith("**"))
    mesh = read_mesh(path)
    assert mesh.sets["PART1-1.NSET1"].size == expected == mesh.n  # a part set, named by its instance
    seg = read_mesh(shared_file("tet/segmenttet.inp"))  # *Node,NSET=Nall
    assert seg.sets["Nall"].size == seg.n
    # and a SPEC can name it (an unknown set would be refused with unknown_set)
    d = precompute(seg, {"selections": {"all": {"set": "Nall"}}, "fixed": ["all"]})
    assert d.solve({}).report["max_displacement"] == 0.0
