"""Decks that include other files: uploaded with their includes, stored, morphed and downloaded as a tree.

The deck comes with the files it includes (``*INCLUDE, INPUT=include/nodes.inp``), as companions
under their paths relative to the deck or all in one zip. The service stores them in the mesh's own
folder and reads nothing outside it; the original download and the morph in the deck's own format
answer a zip of the deck and its includes, each under its path, the deck byte for byte and the
include with the moved coordinates. The formats of the registry are listed by ``GET /v1/formats``
with what they read and how they are written.
"""

from __future__ import annotations

import io
import time
import zipfile
from typing import Any

import numpy as np
import pytest

from solver.io.registry import FORMATS
from tests.conftest import DATA

from ..conftest import err, running

SPEC: dict[str, Any] = {"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}},
                        "fixed": ["root"], "handles": {"tip": "tip"}}
MOVE = {"handles": {"tip": {"translation": [0.0, 1.5, 4.0], "rotation": {"axis": [1, 0, 0], "angle_deg": 5}}}}


def split_deck(include: str = "include/nodes.inp") -> tuple[bytes, bytes]:
    """tests/data/ccx_bracket.inp with its ``*NODE`` block moved to a file it includes: (deck, include)."""
    lines = (DATA / "ccx_bracket.inp").read_bytes().splitlines(keepends=True)
    start = next(i for i, ln in enumerate(lines) if ln.upper().startswith(b"*NODE"))
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith(b"*"))
    deck = b"".join(lines[:start]) + f"*INCLUDE, INPUT={include}\n".encode() + b"".join(lines[end:])
    return deck, b"".join(lines[start:end])


def node_lines(text: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Labels and coordinates of the node lines of a ``*NODE`` block (a parser of its own, not the solver's)."""
    labels, xyz = [], []
    for line in text.decode().splitlines():
        if not line.strip() or line.lstrip().startswith("*"):
            continue
        fields = [f.strip() for f in line.split(",")]
        labels.append(int(fields[0]))
        xyz.append([float(f) for f in fields[1:4]])
    return np.array(labels), np.array(xyz)


def unzipped(body: bytes) -> dict[str, bytes]:
    with zipfile.ZipFile(io.BytesIO(body)) as z:
        return {n: z.read(n) for n in z.namelist()}


def upload(tc, deck: bytes, includes: dict[str, bytes], main: str = "deck.inp", **form: str):
    files = [("file", (main, deck))] + [("companions", (n, b)) for n, b in includes.items()]
    return tc.post("/v1/meshes", files=files, data=form)


def session(tc, mesh_id: str) -> str:
    s = tc.post("/v1/sessions", json={"mesh_id": mesh_id, "spec": SPEC}).json()
    deadline = time.monotonic() + 120
    while s["status"] == "building" and time.monotonic() < deadline:
        time.sleep(0.1)
        s = tc.get(f"/v1/sessions/{s['id']}").json()
    assert s["status"] == "ready", s
    return str(s["id"])


@pytest.mark.parametrize("main,include_name", [("deck.inp", "include/nodes.inp"),
                                               ("model/deck.inp", "model/include/nodes.inp")],
                         ids=["beside", "folder-uploaded"])
def test_a_deck_and_its_include_upload_morph_and_download_as_a_tree(tc, main, include_name):
    deck, nodes = split_deck()
    r = upload(tc, deck, {include_name: nodes}, main=main)
    assert r.status_code == 201, r.text
    mesh = r.json()
    assert mesh["format"] == "abaqus" and mesh["files"] == ["deck.inp", "include/nodes.inp"]
    labels, rest = node_lines(nodes)
    assert mesh["info"]["vertices"] == len(labels)

    original = tc.get(f"/v1/meshes/{mesh['id']}/file")  # the upload byte for byte, each file under its path
    assert original.status_code == 200 and original.headers["content-type"] == "application/zip"
    assert unzipped(original.content) == {"deck.inp": deck, "include/nodes.inp": nodes}

    sid = session(tc, mesh["id"])
    d = tc.post(f"/v1/sessions/{sid}/deform", json=MOVE)
    assert d.status_code == 200, d.text
    V = np.array(d.json()["positions"])
    assert V.shape == rest.shape and np.abs(V - rest).max() > 1.0  # the MOVE moved the tip

    got = tc.get(f"/v1/sessions/{sid}/mesh", params={"format": "inp"})
    assert got.status_code == 200 and got.headers["content-type"] == "application/zip", got.text
    tree = unzipped(got.content)
    assert sorted(tree) == ["deck_deformed.inp", "include/nodes.inp"]
    assert tree["deck_deformed.inp"] == deck  # the nodes are in the include: the deck is unchanged
    moved_labels, moved = node_lines(tree["include/nodes.inp"])
    assert np.array_equal(moved_labels, labels)
    assert np.allclose(moved, V, rtol=1e-12, atol=1e-9)
    unmoved = (V == rest).all(1)
    assert unmoved.any() and (~unmoved).any()
    before = nodes.splitlines()[1:]  # unmoved nodes keep their text
    after = tree["include/nodes.inp"].splitlines()[1:]
    assert all(before[i] == after[i] for i in np.flatnonzero(unmoved))

    same = tc.post(f"/v1/sessions/{sid}/deform", params={"result": "mesh", "format": "abaqus"}, json=MOVE)
    assert same.status_code == 200 and same.headers["content-type"] == "application/zip"
    assert unzipped(same.content) == tree


def test_the_includes_are_stored_with_the_deck_and_read_back_after_a_restart(tmp_path):
    deck, nodes = split_deck()
    with running(tmp_path / "data") as tc:
        r = upload(tc, deck, {"include/nodes.inp": nodes})
        assert r.status_code == 201, r.text
        mid = r.json()["id"]
    assert (tmp_path / "data" / "meshes" / mid / "include" / "nodes.inp").read_bytes() == nodes
    with running(tmp_path / "data") as tc:  # a fresh process: the mesh is read again from the stored files
        assert [m["id"] for m in tc.get("/v1/meshes").json()] == [mid]
        assert unzipped(tc.get(f"/v1/meshes/{mid}/file").content) == {"deck.inp": deck,
                                                                      "include/nodes.inp": nodes}
        own = tc.get(f"/v1/meshes/{mid}/file", params={"format": "inp"})  # written back at rest: the same tree
        assert own.status_code == 200, own.text
        assert unzipped(own.content) == {"deck.inp": deck, "include/nodes.inp": nodes}
        sid = session(tc, mid)
        assert tc.post(f"/v1/sessions/{sid}/deform", json=MOVE).status_code == 200
        tree = unzipped(tc.get(f"/v1/sessions/{sid}/mesh", params={"format": "inp"}).content)
        assert tree["deck_deformed.inp"] == deck and tree["include/nodes.inp"] != nodes


@pytest.mark.parametrize("target,code", [("include/other.inp", "include_missing"),
                                         ("../secret.inp", "include_outside"),
                                         ("/etc/passwd", "include_outside"),
                                         ("include/../../secret.inp", "include_outside")])
def test_an_include_not_uploaded_or_outside_the_decks_folder_is_refused_and_nothing_is_stored(tc, target, code):
    deck, nodes = split_deck(include=target)
    r = upload(tc, deck, {"include/nodes.inp": nodes})
    e = err(r)
    assert r.status_code == 422 and e["code"] == code, e
    assert target in e["message"] or target in str(e["details"])
    assert "/tmp" not in e["message"] and str(tc.app.state.settings.data_dir) not in r.text
    assert tc.get("/v1/meshes").json() == []
    assert not any((tc.app.state.settings.data_dir / "meshes").iterdir())


def test_a_companion_name_cannot_climb_out_of_the_meshs_folder(tc):
    """A companion named with ``..`` or an absolute path is stored by its base name, inside the mesh's folder."""
    deck, nodes = split_deck(include="nodes.inp")
    for name in ("../../nodes.inp", "/tmp/nodes.inp", "..\\nodes.inp"):
        r = upload(tc, deck, {name: nodes})
        assert r.status_code == 201, r.text
        assert r.json()["files"] == ["deck.inp", "nodes.inp"]
    root = tc.app.state.settings.data_dir
    assert not (root / "nodes.inp").exists() and not (root.parent / "nodes.inp").exists()


def _zip(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, body in members.items():
            z.writestr(name, body)
    return buf.getvalue()


def test_a_zip_of_the_deck_and_its_includes_is_one_upload(tc):
    deck, nodes = split_deck()
    for members in ({"deck.inp": deck, "include/nodes.inp": nodes},
                    {"model/deck.inp": deck, "model/include/nodes.inp": nodes, "__MACOSX/model/._deck.inp": b"x"}):
        r = tc.post("/v1/meshes", files=[("file", ("model.zip", _zip(members)))])
        assert r.status_code == 201, r.text
        assert r.json()["files"] == ["deck.inp", "include/nodes.inp"] and r.json()["name"] == "deck.inp"
        assert unzipped(tc.get(f"/v1/meshes/{r.json()['id']}/file").content) == {"deck.inp": deck,
                                                                               "include/nodes.inp": nodes}
    flat, flat_nodes = split_deck(include="nodes.inp")  # both at the top: the deck is the file naming the other
    r = tc.post("/v1/meshes", files=[("file", ("model.zip", _zip({"nodes.inp": flat_nodes, "deck.inp": flat})))])
    assert r.status_code == 201 and r.json()["name"] == "deck.inp", r.text
    tetgen = {n: (DATA / n).read_bytes() for n in ("beam.ele", "beam.node")}  # TetGen's pair: the .node is read
    r = tc.post("/v1/meshes", files=[("file", ("beam.zip", _zip(tetgen)))])
    assert r.status_code == 201 and r.json()["format"] == "tetgen" and r.json()["name"] == "beam.node", r.text
    two = {"a.inp": flat, "b.inp": flat, "nodes.inp": flat_nodes}  # two decks: which one is the mesh is asked
    r = tc.post("/v1/meshes", files=[("file", ("model.zip", _zip(two)))])
    assert r.status_code == 422 and err(r)["code"] == "unknown_format" and err(r)["details"]["candidates"] == [
        "a.inp", "b.inp"], r.text


@pytest.mark.parametrize("member,code", [("../secret.inp", "include_outside"), ("/etc/passwd", "include_outside"),
                                         ("include/../../x.inp", "include_outside")])
def test_a_zip_member_outside_the_archive_is_refused(tc, member, code):
    deck, nodes = split_deck()
    before = tc.get("/v1/meshes").json()
    body = _zip({"deck.inp": deck, "include/nodes.inp": nodes, member: b"*NODE\n"})
    r = tc.post("/v1/meshes", files=[("file", ("model.zip", body))])
    assert r.status_code == 422 and err(r)["code"] == code, r.text
    assert tc.get("/v1/meshes").json() == before


def test_a_zip_expanding_past_the_setting_is_refused_before_it_expands(tmp_path):
    deck, nodes = split_deck()
    with running(tmp_path / "data", load_kernels=False, max_file_expanded_mb=0.1) as tc:
        r = tc.post("/v1/meshes", files=[("file", ("model.zip", _zip({"deck.inp": deck,
                                                                      "include/nodes.inp": nodes})))])
        e = err(r)
        assert r.status_code == 422 and e["code"] == "too_many_bytes", e
        assert e["details"]["setting"] == "TETMORPH_MAX_FILE_EXPANDED_MB"
        assert tc.get("/v1/meshes").json() == []
        r = tc.post("/v1/meshes", files=[("file", ("model.zip", b"PK\x03\x04 not really a zip"))])
        assert r.status_code == 422 and err(r)["code"] == "unreadable_file", r.text


def test_the_formats_list_says_what_each_registered_format_reads_and_how_it_is_written(tc):
    rows = {r["name"]: r for r in tc.get("/v1/formats").json()}
    assert set(FORMATS) <= set(rows)
    abaqus = rows["abaqus"]
    assert abaqus["read"] and abaqus["write"] and abaqus["in_place"] and abaqus["converts_to"]
    assert abaqus["sets"] and abaqus["quadratic"]  # the measured row is kept
    assert "*INCLUDE" in abaqus["reads"] and "outside the deck's folder" in abaqus["refuses"]
    for name, f in FORMATS.items():
        row = rows[name]
        assert row["available"] and row["read"], name
        assert row["title"] == f.title and row["extension"] == f.extensions[0], name
        assert row["extensions"] == list(f.extensions) and row["reads"] == (f.reads or None), name
        assert row["converts_to"] is row["write"] is f.writes, name  # never write: true for an in-place format
        if not f.writes:
            assert row["in_place"], name
    assert not any(r["reads"] for n, r in rows.items() if n not in FORMATS)  # meshio's formats: measured only


def test_a_registered_format_resolves_by_name_alias_and_extension():
    from service.formats import resolve_format

    assert resolve_format("inp") == ("abaqus", ".inp") and resolve_format(None, "part.msh") == ("gmsh", ".msh")
    for name, f in FORMATS.items():
        assert resolve_format(name)[0] == name
        for key in (*f.aliases, *f.extensions, *(e.lstrip(".") for e in f.extensions)):
            assert resolve_format(key)[0] == name, key
        for ext in f.extensions:
            assert resolve_format(None, f"part{ext.upper()}") == (name, ext)


def test_a_mesh_of_another_format_is_not_converted_to_a_format_written_back_in_place_only(tc):
    in_place = [f for f in FORMATS.values() if not f.writes]
    if not in_place:
        pytest.skip("no registered format is written back in place only (writes=False) in this checkout")
    r = tc.post("/v1/meshes", files=[("file", ("mixed.msh", (DATA / "mixed.msh").read_bytes()))])
    assert r.status_code == 201, r.text
    mid = r.json()["id"]
    for f in in_place:
        for key in (f.name, *f.aliases, f.extensions[0].lstrip(".")):
            got = tc.get(f"/v1/meshes/{mid}/file", params={"format": key})
            e = err(got)
            assert got.status_code == 422 and e["code"] == "unwritable_format", e
            assert e["details"]["format"] == f.name and e["details"]["in_place_only"] is True
            assert f.title in e["message"] and "written back only to decks read from it" in e["message"]


def _cdb(P: np.ndarray, T: np.ndarray) -> bytes:
    """A small MAPDL archive: SOLID285 tetrahedra in an NBLOCK / EBLOCK, and the node component TOP."""
    out = ["/PREP7", "ET,       1,285", f"NBLOCK,6,SOLID,{len(P):10d},{len(P):10d}", "(3i8,6e20.13)"]
    out += [f"{i + 1:8d}{0:8d}{0:8d}" + "".join(f"{x:20.13E}" for x in p) for i, p in enumerate(P)]
    out += ["N,R5.3,LOC,       -1,", f"EBLOCK,19,SOLID,{len(T):10d},{len(T):10d}", "(19i8)"]
    out += ["".join(f"{v:8d}" for v in [1, 1, 1, 1, 0, 0, 0, 0, 4, 0, e + 1, *(int(x) + 1 for x in t)])
            for e, t in enumerate(T)]
    out += ["      -1", "CMBLOCK,TOP,NODE,       2", "(8i10)", f"{4:10d}{5:10d}"]
    return ("\n".join(out) + "\n").encode()


def test_a_mesh_read_from_a_format_written_back_in_place_only_downloads_and_morphs_in_it(tc):
    if "ansys-cdb" not in FORMATS:
        pytest.skip("the Ansys .cdb format is not registered in this checkout")
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.0]])
    body = _cdb(P, np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))
    for files, form in (([("file", ("part.cdb", body))], {}), ([("file", ("part.dat", body))], {"format": "cdb"})):
        r = tc.post("/v1/meshes", files=files, data=form)
        assert r.status_code == 201 and r.json()["format"] == "ansys-cdb", r.text
    mid = r.json()["id"]
    for key in ("ansys-cdb", "cdb", "mapdl", ".cdb"):  # written back at rest: byte for byte
        got = tc.get(f"/v1/meshes/{mid}/file", params={"format": key})
        assert got.status_code == 200 and got.content == body, (key, got.text)
    assert tc.get(f"/v1/meshes/{mid}/file", params={"format": "vtu"}).status_code == 200  # converted from it
    spec = {"selections": {"base": {"ids": [0, 1, 2]}, "top": {"set": "TOP"}}, "fixed": ["base"],
            "handles": {"top": "top"}}
    s = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": spec}).json()
    while s["status"] == "building":
        time.sleep(0.1)
        s = tc.get(f"/v1/sessions/{s['id']}").json()
    assert s["status"] == "ready", s
    move = {"handles": {"top": {"translation": [0.0, 0.0, 0.25]}}}
    got = tc.post(f"/v1/sessions/{s['id']}/deform", params={"result": "mesh", "format": "cdb"}, json=move)
    assert got.status_code == 200 and got.headers["content-type"] == "application/octet-stream", got.text
    before, after = body.splitlines(), got.content.splitlines()
    assert len(before) == len(after)
    changed = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
    assert changed == [7, 8]  # the node lines of TOP (nodes 4 and 5), nothing else
    assert float(after[7][64:84]) == pytest.approx(1.25) and float(after[8][64:84]) == pytest.approx(1.25)
