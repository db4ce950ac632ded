"""Mesh routes: upload (files, arrays), download, geometry, features."""

from __future__ import annotations

import json

import numpy as np
import pytest

from service.binary import decode_bundle
from tests.conftest import DATA

from ..conftest import BRACKET, BRACKET_SPEC, MOVES, err, upload_bracket


def _inp_bytes(points, tets, kind="C3D4"):
    lines = ["*NODE"] + [f"{i + 1}, {x}, {y}, {z}" for i, (x, y, z) in enumerate(points)]
    lines += [f"*ELEMENT, TYPE={kind}"]
    lines += [f"{e + 1}, " + ", ".join(str(int(v) + 1) for v in t) for e, t in enumerate(tets)]
    return ("\n".join(lines) + "\n").encode()


TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])


def test_uploaded_file_downloads_byte_for_byte_and_converts(client, tc):
    mesh = upload_bracket(client)
    assert client.download_mesh(mesh["id"]) == BRACKET.read_bytes()
    msh = client.download_mesh(mesh["id"], file_format="msh")
    assert msh[:11] == b"$MeshFormat"  # tets + faces: written as Gmsh 2.2
    r = tc.get(f"/v1/meshes/{mesh['id']}/file", params={"format": "tetgen"})
    # TetGen holds neither the deck's named sets nor its CPS3 faces: refused, saying what would be lost
    assert r.status_code == 422 and err(r)["code"] == "lossy_write"
    assert {x["name"] for x in err(r)["details"]["losses"]} >= {"FIXED", "LOAD", "triangle"}


def test_tetgen_upload_needs_its_ele(tc):
    r = tc.post("/v1/meshes", files=[("file", ("beam.node", (DATA / "beam.node").read_bytes()))])
    assert r.status_code == 422 and err(r)["code"] == "missing_companion"


@pytest.mark.parametrize("name,data,code", [
    ("garbage.inp", b"\x00\x01 this is not an abaqus deck \xff" * 10, None),
    ("empty.msh", b"", None),
    ("inverted.inp", _inp_bytes(TET, [[0, 2, 1, 3]]), "inverted_input"),
    ("flat.inp", _inp_bytes(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]]), [[0, 1, 2, 3]]),
     None),
    ("nan.inp", _inp_bytes(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, float("nan")]]),
                           [[0, 1, 2, 3]]), "non_finite_coordinates"),
    ("huge.inp", _inp_bytes(TET * 1e308, [[0, 1, 2, 3]]), "coordinates_out_of_range"),
    ("badindex.inp", _inp_bytes(TET, [[0, 1, 2, 7]]), None),
    ("hexahedron20.inp", _inp_bytes(np.random.default_rng(0).random((20, 3)), [list(range(20))], kind="C3D20"),
     "unsupported_element"),
    ("twisted_hex.inp", _inp_bytes(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1],
                                             [0.2, 0.2, 1], [0, 1, 1.0]]), [list(range(8))], kind="C3D8"),
     "inverted_input"),
    ("surface.xyz", b"1 2 3\n", "unknown_format"),
])
def test_malformed_uploads_are_typed_422(tc, name, data, code):
    r = tc.post("/v1/meshes", files=[("file", (name, data))])
    e = err(r)
    assert r.status_code == 422, e
    if code:
        assert e["code"] == code, e
    assert e["message"]
    assert tc.get("/v1/meshes").json() == []  # nothing stored


def test_a_decompression_bomb_is_refused_before_it_expands(tc, tmp_path):
    from tests.solver.io.test_read import _vtu_bomb

    _vtu_bomb(tmp_path / "bomb.vtu", 300_000_000)
    r = tc.post("/v1/meshes", files=[("file", ("bomb.vtu", (tmp_path / "bomb.vtu").read_bytes()))])
    e = err(r)
    assert r.status_code == 422 and e["code"] == "too_many_points", e
    assert e["details"]["declared"] == 300_000_000
    assert tc.get("/v1/meshes").json() == []  # nothing stored


def test_the_declared_size_bounds_are_service_settings(tmp_path):
    """TETMORPH_MAX_FILE_POINTS / _CELLS bound what an upload may declare, below the library's bounds."""
    from ..conftest import running

    with running(tmp_path, load_kernels=False, max_file_points=500, max_file_cells=100_000) as tc:
        big = (DATA / "bracket.inp").read_bytes()  # 3,461 nodes
        r = tc.post("/v1/meshes", files=[("file", ("bracket.vtu", _as_vtu(big, tmp_path)))])
        e = err(r)
        assert r.status_code == 422 and e["code"] == "too_many_points" and e["details"]["bound"] == 500, e
        assert tc.get("/v1/meshes").json() == []
    with running(tmp_path / "b", load_kernels=False, max_file_cells=10) as tc:
        r = tc.post("/v1/meshes", files=[("file", ("bracket.vtu", _as_vtu(big, tmp_path)))])
        assert r.status_code == 422 and err(r)["code"] == "too_many_cells" and err(r)["details"]["bound"] == 10
    with running(tmp_path / "c", load_kernels=False) as tc:  # the defaults take it
        assert tc.post("/v1/meshes", files=[("file", ("bracket.vtu", _as_vtu(big, tmp_path)))]).status_code == 201


def _as_vtu(inp: bytes, tmp_path) -> bytes:
    """The deck as a VTU file (a format that declares its counts in its header)."""
    import meshio

    src, out = tmp_path / "src.inp", tmp_path / "out.vtu"
    src.write_bytes(inp)
    meshio.write(out, meshio.read(src))
    return out.read_bytes()


def test_a_nul_in_any_text_of_a_request_is_refused_before_anything_is_stored(tc):
    tet = _inp_bytes(TET, [[0, 1, 2, 3]])
    r = tc.post("/v1/meshes", files=[("file", ("t.inp", tet))], data={"name": "bad\x00name"})
    assert r.status_code == 422 and "NUL" in err(r)["message"] and err(r)["details"]["field"] == "form field 'name'"
    assert tc.get("/v1/meshes").json() == []
    mid = tc.post("/v1/meshes", files=[("file", ("t.inp", tet))]).json()["id"]
    spec = {"selections": {"a\u0000": {"ids": [0]}, "b": {"ids": [3]}}, "fixed": ["a\u0000"], "handles": {"h": "b"}}
    body = json.dumps({"mesh_id": mid, "spec": spec})  # json writes the NUL as an escape
    r = tc.post("/v1/sessions", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 422 and "NUL" in err(r)["message"], r.text
    assert tc.get("/v1/sessions").json() == []
    assert tc.get("/v1/meshes?name=%00").status_code == 422


def test_malformed_json_arrays(tc):
    bad = [
        ({"vertices": [[0, 0], [1, 0]], "tetrahedra": [[0, 1, 2, 3]]}, "invalid_request"),
        ({"vertices": [[0, 0, 0], [1, 0]], "tetrahedra": [[0, 1, 2, 3]]}, "invalid_request"),
        ({"vertices": TET.tolist(), "tetrahedra": [[0, 1, 2]]}, "invalid_request"),
        ({"vertices": [], "tetrahedra": []}, None),
        ({"vertices": TET.tolist(), "tetrahedra": [[0, 1, 2, 9]]}, None),
        ({"vertices": TET.tolist(), "tetrahedra": [[0, 1, 2, 3]], "sets": {"a": [12]}},
         "index_out_of_range"),
        ({"vertices": "abc"}, "invalid_request"),
    ]
    for body, code in bad:
        r = tc.post("/v1/meshes/arrays", json=body)
        e = err(r)
        assert r.status_code == 422, (body, e)
        if code:
            assert e["code"] == code, e


def test_feature_candidates_and_min_cut_region_over_http(client, tc):
    mesh = upload_bracket(client)
    r = tc.get(f"/v1/meshes/{mesh['id']}/features")
    assert r.status_code == 200
    kinds = [c["kind"] for c in r.json()]
    assert kinds.count("hole") == 1 and kinds.count("plane") == 6
    hole = next(c for c in tc.get(f"/v1/meshes/{mesh['id']}/features?ids=true").json()
                if c["kind"] == "hole")
    assert abs(hole["radius"] - 5) < 1e-6
    band = [{"box": {"min": [52, 2, -1], "max": [68, 18, 2]}, "boundary_only": True},
            {"box": {"min": [52, 2, 8], "max": [68, 18, 11]}, "boundary_only": True}]
    r = tc.post(f"/v1/meshes/{mesh['id']}/feature-region", json={"band": band})
    assert r.status_code == 200
    assert sorted(r.json()["selection"]["ids"]) == sorted(hole["selection"]["ids"])
    # the returned selection is usable as a rigid feature in a session
    spec = {**BRACKET_SPEC, "selections": {**BRACKET_SPEC["selections"], "wall": r.json()["selection"]},
            "features": [{"selection": "wall", "mode": "rigid", "name": "bolt"}]}
    s = client.create_session(mesh["id"], spec)
    X, rep = client.deform(s["id"], MOVES[0])
    assert rep["constraint_residual_max"] < 1e-9
    r = tc.post(f"/v1/meshes/{mesh['id']}/feature-region", json={"band": band[:1]})
    assert r.status_code == 422 and err(r)["code"] == "band_not_separating"
    r = tc.post(f"/v1/meshes/{mesh['id']}/feature-region", json={"band": [{"cube": 1}]})
    assert r.status_code == 422


def test_mixed_element_deck_over_rest(client, tc, tmp_path):
    """Hexahedra, wedges and pyramids: upload, morph, per-element quality (null for tet-only
    metrics), geometry for the viewer, and the Gmsh file back with only node lines changed."""
    mesh = client.upload_mesh(DATA / "mixed.msh")
    assert mesh["info"]["elements"] == 1113 and mesh["info"]["cell_types"]["wedge"] == 172
    spec = {"selections": {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}}, "fixed": ["fix"],
            "handles": {"tip": "load"}}
    s = client.create_session(mesh["id"], spec)
    move = {"handles": {"tip": {"translation": [0, 0, 4], "rotation": {"axis": [0, 1, 0], "angle_deg": -15}}}}
    rep = tc.post(f"/v1/sessions/{s['id']}/deform?result=report&quality=full", json=move).json()["report"]
    assert rep["inverted_elements"] == 0 and rep["constraint_residual_max"] <= 1e-9
    assert sum(rep["quality"]["after"]["scaled_jacobian"]["histogram"]["counts"]) == 1113
    per = tc.get(f"/v1/sessions/{s['id']}/quality?metrics=scaled_jacobian,min_dihedral_deg").json()
    assert per["elements"] == 1113
    assert per["per_element"]["min_dihedral_deg"][797:] == [None] * (1113 - 797)
    assert all(v is not None for v in per["per_element"]["scaled_jacobian"])
    geo, head = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert geo["T"].shape == (797 + 128 * 8 + 172 * 6 + 16 * 4, 4) and head["elements"] == 1113
    body = tc.get(f"/v1/sessions/{s['id']}/mesh?format=msh").content
    src = (DATA / "mixed.msh").read_bytes()
    assert body.split(b"$Nodes")[0] == src.split(b"$Nodes")[0]
    assert body.split(b"$EndNodes")[1] == src.split(b"$EndNodes")[1]


def test_tetgen_upload_downloads_as_a_zip_of_its_original_files(tc):
    import io
    import zipfile

    node, ele = (DATA / "beam.node").read_bytes(), (DATA / "beam.ele").read_bytes()
    r = tc.post("/v1/meshes", files=[("file", ("beam.node", node)), ("companions", ("beam.ele", ele))])
    assert r.status_code == 201, r.text
    got = tc.get(f"/v1/meshes/{r.json()['id']}/file")
    assert got.headers["content-type"] == "application/zip"
    with zipfile.ZipFile(io.BytesIO(got.content)) as z:
        assert sorted(z.namelist()) == ["beam.ele", "beam.node"]
        assert z.read("beam.node") == node and z.read("beam.ele") == ele


@pytest.mark.parametrize("companion", ["beam.node", "../x/beam.node", "beam .ele", "beam_.ele"])
def test_a_companion_stored_under_the_main_files_name_or_anothers_is_refused(tc, companion):
    """Names are cleaned before they are stored (no folders, odd characters as '_'): two uploads that clean to
    one name are refused naming both, instead of one silently replacing the other, and nothing is stored."""
    node, ele = (DATA / "beam.node").read_bytes(), (DATA / "beam.ele").read_bytes()
    before = tc.get("/v1/meshes").json()
    files = [("file", ("beam.node", node)), ("companions", ("beam_.ele", ele)), ("companions", (companion, b"x"))]
    if companion == "beam_.ele":
        files = files[:2] + [("companions", ("beam .ele", b"x"))]
    r = tc.post("/v1/meshes", files=files)
    assert r.status_code == 422 and err(r)["code"] == "duplicate_file_name", r.text
    assert len(err(r)["details"]["files"]) == 2
    assert tc.get("/v1/meshes").json() == before


SETTINGS = {"points": ("max_file_points", "TETMORPH_MAX_FILE_POINTS"),
            "cells": ("max_file_cells", "TETMORPH_MAX_FILE_CELLS"),
            "bytes": ("max_file_expanded_mb", "TETMORPH_MAX_FILE_EXPANDED_MB")}


def test_every_reader_refuses_an_upload_declaring_more_than_its_settings_allow(tmp_path):
    """Medit, TetGen, PLY, OFF, STL, VTU blocks, VTK fields, Gmsh, XDMF and HDF5: 422 naming the bound and its
    setting (set below the library's here, so the service's own bound must be the one applied); nothing stored."""
    from tests.solver.io.test_bounds import crafted, lying_vtu

    from ..conftest import running

    cases = crafted(tmp_path)
    cases["vtu_lying_blocks"] = ({"a.vtu": lying_vtu(8)}, "too_many_bytes", "bytes")
    bounds = {"max_file_points": 40_000_000, "max_file_cells": 200_000_000, "max_file_expanded_mb": 1.0}
    with running(tmp_path / "data", load_kernels=False, **bounds) as tc:
        for case, (files, code, bound) in cases.items():
            main, *rest = files.items()
            r = tc.post("/v1/meshes", files=[("file", main)] + [("companions", c) for c in rest])
            e = err(r)
            assert r.status_code == 422 and e["code"] == code, (case, e)
            assert "MemoryError" not in e["message"] and "allocate" not in e["message"], case
            if bound is not None:
                key, env = SETTINGS[bound]
                want = bounds[key] if bound != "bytes" else 1 << 20
                assert e["details"]["bound"] == want and e["details"]["setting"] == env, (case, e)
                assert env in e["message"] and f"{want:,}" in e["message"], (case, e)
            assert tc.get("/v1/meshes").json() == [], case  # nothing stored
        assert not any((tmp_path / "data" / "meshes").iterdir())
