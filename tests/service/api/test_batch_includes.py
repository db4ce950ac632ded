"""A batch of a deck that includes its nodes: each row's deck and moved include, in a folder of its own."""

from __future__ import annotations

import csv
import io
import zipfile

import numpy as np

from tests.conftest import DATA

from ..conftest import running
from .test_batch import wait


def _node_lines(text: str) -> dict[int, list[float]]:
    out, inside = {}, False
    for ln in text.splitlines():
        if ln.startswith("*"):
            inside = ln.upper().replace(" ", "").startswith("*NODE")
            continue
        if inside and ln.strip():
            f = ln.split(",")
            out[int(f[0])] = [float(v) for v in f[1:4]]
    return out


def test_a_batch_of_a_deck_with_an_include_answers_each_row_with_its_moved_include(tmp_path):
    text = (DATA / "ccx_bracket.inp").read_text()
    head, rest = text.split("*ELEMENT", 1)
    nodes = head.split("\n", 2)[2]
    deck = "*HEADING\nwith an include\n*INCLUDE, INPUT=include/nodes.inp\n*ELEMENT" + rest
    with running(tmp_path / "data") as tc:
        r = tc.post("/v1/meshes", files=[("file", ("main.inp", deck.encode())),
                                         ("companions", ("include/nodes.inp", nodes.encode()))])
        assert r.status_code == 201, r.text
        spec = {"selections": {"fix": {"set": "FIXED"}, "hole": {"set": "HOLE"}}, "fixed": ["fix"],
                "handles": {"hole": "hole"}}
        sid = tc.post("/v1/sessions", json={"mesh_id": r.json()["id"], "spec": spec}).json()["id"]
        shapes = {"dx": {"handles": {"hole": {"translation": [1.0, 0, 0]}}}}
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": shapes,
                                                       "plan": {"columns": ["dx"], "rows": [[0.0], [2.0]]}})
        assert r.status_code == 202, r.text
        doc = wait(tc, sid, r.json()["id"])
        assert doc["status"] == "done", doc
        z = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content))
        names = set(z.namelist())
        rows = [row["file"] for row in csv.DictReader(io.StringIO(z.read("summary.csv").decode()))]
        assert len(rows) == 2 and all(f in names for f in rows)
        rest0 = _node_lines(nodes)
        hole_text = rest.split("*NSET, NSET=HOLE\n", 1)[1].split("*", 1)[0]
        hole = [int(v) for v in hole_text.replace("\n", ",").split(",") if v.strip()]
        moved = []
        for f in rows:
            folder = f.rsplit("/", 1)[0]
            assert z.read(f).decode() == deck  # the deck itself: byte for byte
            got = _node_lines(z.read(f"{folder}/include/nodes.inp").decode())
            moved.append([got[k][0] - rest0[k][0] for k in hole])
        assert np.allclose(moved[0], 0.0, atol=0) and np.allclose(moved[1], 2.0, atol=1e-12)  # the hole, by 2


def test_the_python_client_uploads_a_deck_with_the_files_it_includes(tmp_path):
    from service.client import Client

    text = (DATA / "ccx_bracket.inp").read_text()
    head, rest = text.split("*ELEMENT", 1)
    (tmp_path / "deck" / "include").mkdir(parents=True)
    (tmp_path / "deck" / "include" / "nodes.inp").write_text(head.split("\n", 2)[2])
    main = tmp_path / "deck" / "main.inp"
    main.write_text("*HEADING\n*INCLUDE, INPUT=include/nodes.inp\n*ELEMENT" + rest)
    with running(tmp_path / "data") as tc:
        doc = Client(http=tc).upload_mesh(main)
        stored = tc.app.state.registry.store.mesh_meta(doc["id"])["files"]
        assert sorted(stored) == ["include/nodes.inp", "main.inp"]
