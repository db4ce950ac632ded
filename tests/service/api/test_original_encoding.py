"""A download or DOE deck "in the original format" is the uploaded file, coordinates changed: ASCII stays ASCII.

The editor's "original format" download (GET .../mesh?format=OWN) and a DOE batch's decks are written
in place from the upload's bytes for legacy VTK and Medit, as for decks: the encoding, the header and
every line that holds no moved coordinate are kept.
"""

from __future__ import annotations

import io
import time
import zipfile

import meshio
import numpy as np

from solver import read_mesh
from tests.conftest import DATA
from tests.service.conftest import running

SPEC = {"selections": {"a": {"ids": [0]}, "b": {"ids": [100]}}, "fixed": ["a"], "handles": {"h": "b"}}
MOVE = {"handles": {"h": {"translation": [0.002, 0.0, 0.0]}}}


def _medit(tmp_path):
    """A Medit file of the bracket deck's tets, written by meshio (ASCII)."""
    m = meshio.read(DATA / "bracket.inp")
    path = tmp_path / "bracket.mesh"
    meshio.write(path, meshio.Mesh(m.points, [("tetra", m.cells_dict["tetra"])]))
    return path


def _coordinate_lines(text: bytes) -> tuple[int, int]:
    """[first, end) of the lines holding coordinates: after POINTS (VTK) or Vertices + count (Medit)."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        word = line.strip().split(b" ")[0].lower() if line.strip() else b""
        if word == b"points":
            start = i + 1
            break
        if word == b"vertices":
            start = i + 2
            break
    end = next(k for k in range(start, len(lines)) if lines[k].strip()[:1].isalpha())
    return start, end


def _changed_lines(a: bytes, b: bytes) -> list[int]:
    la, lb = a.splitlines(), b.splitlines()
    assert len(la) == len(lb)
    return [i for i, (x, y) in enumerate(zip(la, lb, strict=True)) if x != y]


def test_the_original_format_keeps_an_ascii_vtk_and_a_medit_file_as_uploaded(tmp_path):
    for path, ext in ((DATA / "wheelset.vtk", "vtk"), (_medit(tmp_path), "mesh")):
        original = path.read_bytes()
        with running(tmp_path / f"data_{ext}") as tc:
            mid = tc.post("/v1/meshes", files=[("file", (path.name, original))]).json()["id"]
            sid = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": SPEC}).json()["id"]
            for _ in range(200):
                if tc.get(f"/v1/sessions/{sid}").json().get("status", "ready") == "ready":
                    break
                time.sleep(0.05)
            assert tc.post(f"/v1/sessions/{sid}/deform", json=MOVE).status_code == 200
            got = tc.get(f"/v1/sessions/{sid}/mesh?format={ext}")
            assert got.status_code == 200, got.text
            changed = _changed_lines(original, got.content)
            assert changed, ext  # the handle's node moved
            if ext == "vtk":
                assert got.content.splitlines()[2] == b"ASCII"
            back = tmp_path / f"back.{ext}"
            back.write_bytes(got.content)
            rest, moved = read_mesh(path), meshio.read(back)
            assert np.abs(moved.points[100] - rest.V[100] - MOVE["handles"]["h"]["translation"]).max() < 1e-9
            lo, hi = _coordinate_lines(original)
            assert all(lo <= i < hi for i in changed), (ext, changed[:5], lo, hi)  # only coordinates differ
            job = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": {"s": MOVE}, "plan": "s\n0.5\n1\n"}).json()
            for _ in range(600):
                doc = tc.get(f"/v1/sessions/{sid}/batch/{job['id']}").json()
                if doc["status"] not in ("queued", "running"):
                    break
                time.sleep(0.1)
            assert doc["status"] == "done", doc
            z = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content))
            decks = sorted(n for n in z.namelist() if n.endswith(f".{ext}"))
            assert len(decks) == 2
            for name in decks:
                deck = z.read(name)
                assert _changed_lines(original, deck)  # the same file, its moved lines changed
                if ext == "vtk":
                    assert deck.splitlines()[2] == b"ASCII"
