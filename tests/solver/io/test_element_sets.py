"""Element sets in each deck's syntax, read back by small parsers written here, and the formats refused."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from solver.errors import SolverError
from solver.io import read_mesh
from solver.io.element_sets import SET_FORMATS, deck_element_ids, element_set
from tests.conftest import DATA

IDS = np.array([137, 138, 2001, 99999, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18])


def abaqus_elset(text):
    """``{name: ids}`` of the ``*ELSET`` blocks of a deck's text."""
    sets, name = {}, None
    for line in text.splitlines():
        if line.startswith("*"):
            head = [f.strip() for f in line.split(",")]
            name = next((f.split("=")[1] for f in head[1:] if f.upper().startswith("ELSET=")), None) \
                if head[0].upper() == "*ELSET" else None
            if name:
                sets[name] = []
        elif name:
            sets[name] += [int(f) for f in line.split(",") if f.strip()]
    return sets


def test_abaqus_elset_reads_back_and_meshio_reads_the_deck_with_it(tmp_path):
    text = element_set("abaqus", "BAD", IDS)
    assert abaqus_elset(text) == {"BAD": IDS.tolist()}
    assert max(len(line.split(",")) for line in text.splitlines()[1:]) <= 16  # Abaqus reads 16 entries a line
    mesh = read_mesh(DATA / "bracket.inp")
    ids = deck_element_ids(mesh)[[0, 5, 77]]
    deck = tmp_path / "with_set.inp"
    deck.write_text((DATA / "bracket.inp").read_text() + element_set("abaqus", "BAD", ids))
    m = meshio.read(deck, file_format="abaqus")  # an independent reader: the set names those elements
    tet_block = next(k for k, c in enumerate(m.cells) if c.type == "tetra")
    np.testing.assert_array_equal(np.sort(m.cell_sets["BAD"][tet_block]), [0, 5, 77])


def test_nastran_set1_fields():
    text = element_set("nastran", "BAD", IDS, set_id=7)
    cards = [ln for ln in text.splitlines() if not ln.startswith("$")]
    assert cards[0].startswith("SET1") and all(c.startswith("+") for c in cards[1:])
    fields = [c[k:k + 8].strip() for c in cards for k in range(8, len(c), 8)]
    assert int(fields[0]) == 7 and [int(f) for f in fields[1:]] == IDS.tolist()
    assert max(len(c) for c in cards) <= 72  # small field: nine 8-column fields


def test_cdb_cmblock_fields():
    lines = element_set("ansys-cdb", "BAD", IDS).splitlines()
    head = lines[0].split(",")
    assert head[:3] == ["CMBLOCK", "BAD", "ELEM"] and int(head[3]) == IDS.size and lines[1] == "(8i10)"
    got = [int(ln[k:k + 10]) for ln in lines[2:] for k in range(0, len(ln), 10)]
    assert got == IDS.tolist() and max(len(ln) for ln in lines[2:]) == 80


def test_lsdyna_set_solid_fields():
    lines = element_set("lsdyna", "BAD", IDS, set_id=3).splitlines()
    assert lines[:2] == ["*SET_SOLID_TITLE", "BAD"] and int(lines[2]) == 3
    assert [int(ln[k:k + 10]) for ln in lines[3:] for k in range(0, len(ln), 10)] == IDS.tolist()


@pytest.mark.parametrize("fmt", ["gmsh", "vtu", None])
def test_formats_without_element_sets_are_refused(fmt):
    with pytest.raises(SolverError) as e:
        element_set(fmt, "BAD", IDS)
    assert e.value.code == "element_sets_unsupported" and e.value.details["formats"] == list(SET_FORMATS)
    with pytest.raises(SolverError) as e:
        element_set("abaqus", "BAD", IDS, assembly=True)
    assert e.value.code == "element_sets_unsupported" and "flat" in e.value.message


def test_nastran_deck_ids():
    mesh = read_mesh(DATA / "bar_small.bdf")
    lines = (DATA / "bar_small.bdf").read_text().splitlines()
    ctetra = [int(ln[8:16]) for ln in lines if ln.startswith("CTETRA")]
    np.testing.assert_array_equal(deck_element_ids(mesh), ctetra)
