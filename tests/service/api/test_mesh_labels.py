"""The geometry bundle carries a deck's own node numbers (``labels``), vertex by vertex, and element numbers."""

from __future__ import annotations

import meshio
import numpy as np

from service.binary import decode_bundle
from tests.conftest import DATA
from tests.decks import renumbered

from ..conftest import BRACKET


def _labels_of(path) -> list[int]:
    """Node numbers of the deck's *NODE lines, read from its text."""
    out, inside = [], False
    for line in path.read_text().splitlines():
        s = line.strip()
        if s.startswith("**"):
            continue
        if s.startswith("*"):
            inside = s.split(",")[0].strip("* ").upper() == "NODE"
        elif inside and s:
            out.append(int(s.split(",")[0]))
    return out


def test_a_renumbered_deck_s_node_numbers_come_with_its_geometry(client, tc, tmp_path):
    deck = renumbered(BRACKET, tmp_path / "gaps.inp", lambda n: 10 * n + 7)
    mesh = client.upload_mesh(deck)
    arrays, _ = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert arrays["labels"].dtype == np.uint32
    assert arrays["labels"].tolist() == _labels_of(deck)  # 17, 27, ..., one per vertex in file order
    # vertex i of the bundle is the point meshio reads i-th, which the deck numbers labels[i]
    np.testing.assert_allclose(arrays["V"], meshio.read(deck).points, atol=1e-4)
    np.testing.assert_allclose(arrays["V"], meshio.read(BRACKET).points, atol=1e-4)  # renumbering moved nothing


def test_files_without_node_numbers_have_no_labels(client, tc):
    mesh = client.upload_mesh(DATA / "beam.node")
    arrays, _ = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert "labels" not in arrays


def _bdf_numbers(path) -> tuple[list[int], dict[int, list[int]]]:
    """GRID ids in file order and CTETRA id -> GRID ids, read from a small-field bulk data deck's text."""
    grids, tets = [], {}
    for line in path.read_text().splitlines():
        card = line[:8].strip().upper()
        if card == "GRID":
            grids.append(int(line[8:16]))
        elif card == "CTETRA":
            tets[int(line[8:16])] = [int(line[k:k + 8]) for k in (24, 32, 40, 48)]
    return grids, tets


def test_a_nastran_deck_s_node_and_element_numbers_come_with_its_geometry(client, tc):
    deck = DATA / "bar_small.bdf"
    grids, tets = _bdf_numbers(deck)
    assert grids and tets
    mesh = client.upload_mesh(deck)
    arrays, _ = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert arrays["labels"].tolist() == grids
    # each row of T belongs to the element the deck numbers element_labels[row], with that element's GRIDs
    T, eids, labels = arrays["T"], arrays["element_labels"], arrays["labels"]
    assert eids.dtype == np.uint32 and eids.shape == (len(T),)
    for row in (0, len(T) // 2, len(T) - 1):
        assert sorted(labels[T[row]].tolist()) == sorted(tets[int(eids[row])])
    assert sorted(eids.tolist()) == sorted(tets)


def test_a_gmsh_mesh_has_no_deck_numbers(client, tc):
    """Gmsh keeps no node or element numbers the editor could pick by: neither array is sent."""
    mesh = client.upload_mesh(DATA / "mixed.msh")
    arrays, _ = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert "element_labels" not in arrays and "labels" not in arrays  # Gmsh: no deck numbers kept


def _element_ids_of(path) -> list[int]:
    """Element numbers of the deck's volume *ELEMENT lines (C3D*), read from its text."""
    out, inside = [], False
    for line in path.read_text().splitlines():
        s = line.strip()
        if s.startswith("**"):
            continue
        if s.startswith("*"):
            inside = s.split(",")[0].strip("* ").upper() == "ELEMENT" and "TYPE=C3D" in s.upper().replace(" ", "")
        elif inside and s:
            out.append(int(s.split(",")[0]))
    return out


def test_a_deck_s_element_numbers_come_with_its_geometry(client, tc):
    """The quality check answers deck ids; the editor finds their elements with ``element_ids``."""
    mesh = client.upload_mesh(BRACKET)  # its tets are numbered after its surface elements
    arrays, _ = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert arrays["element_ids"].dtype == np.uint32
    assert arrays["element_ids"].tolist() == _element_ids_of(BRACKET)
    assert arrays["element_ids"][0] != 1 and "tet_element" not in arrays  # tets only: row k of T is element k


def test_a_mixed_mesh_names_the_element_of_each_corner_tet(client, tc):
    mesh = client.upload_mesh(DATA / "mixed.msh")
    arrays, head = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    owner, T = arrays["tet_element"], arrays["T"]
    assert owner.shape == (len(T),) and "element_ids" not in arrays  # gmsh: positions are the ids
    counts = np.bincount(owner, minlength=head["elements"])
    assert counts.min() >= 1 and set(np.unique(counts)) <= {1, 4, 6, 8}  # tet; pyramid, wedge, hexahedron corners
    assert (np.diff(owner) >= 0).all()
