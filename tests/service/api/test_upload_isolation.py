"""One tenant's slow or hostile upload never holds up another tenant's upload and MOVE.

Uploads are read in worker processes (service/state/parse_pool.py): while tenant alpha's deck is
being read (a deck of 1M elements, each on five continuation lines, which the reader takes
line by line), tenant beta uploads a mesh, makes a session and MOVEs, and is answered before
alpha's read is stopped at its time limit (422 parse_time_limit), after which the service reads
files again.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from tests.conftest import DATA

from ..conftest import err, running

SPEC = {"selections": {"fix": {"set": "FIXED"}, "hole": {"set": "HOLE"}}, "fixed": ["fix"],
        "handles": {"hole": "hole"}}


def _slow_deck(n_elements: int = 1_000_000) -> bytes:
    """A legal deck whose element lines are continued over five lines each (read line by line)."""
    rng = np.random.default_rng(0)
    nodes = "".join(f"{k + 1}, {x:.6f}, {y:.6f}, {z:.6f}\n" for k, (x, y, z) in enumerate(rng.random((2000, 3))))
    conn = rng.integers(1, 2001, size=(n_elements, 4))
    body = "".join(f"{e + 1},\n{a},\n{b},\n{c},\n{d}\n" for e, (a, b, c, d) in enumerate(conn.tolist()))
    return f"*HEADING\nslow\n*NODE\n{nodes}*ELEMENT, TYPE=C3D4\n{body}".encode()


def test_a_slow_upload_of_one_tenant_does_not_hold_up_another_tenants_upload_and_move(tmp_path):
    deck = _slow_deck()
    done: dict[str, float] = {}
    answers: dict[str, object] = {}
    with running(tmp_path / "d", api_keys="alpha,beta", parse_time_limit_s=5.0, parse_workers=2) as tc:
        def alpha() -> None:
            answers["alpha"] = tc.post("/v1/meshes", files=[("file", ("slow.inp", deck))],
                                       headers={"X-API-Key": "alpha"})
            done["alpha"] = time.monotonic()

        beta_key = {"X-API-Key": "beta"}
        t = threading.Thread(target=alpha)
        t0 = time.monotonic()
        t.start()
        time.sleep(0.3)  # alpha's deck is in a reader
        r = tc.post("/v1/meshes", files=[("file", ("ccx_bracket.inp", (DATA / "ccx_bracket.inp").read_bytes()))],
                    headers=beta_key)
        assert r.status_code == 201, r.text
        s = tc.post("/v1/sessions", json={"mesh_id": r.json()["id"], "spec": SPEC}, headers=beta_key)
        assert s.status_code in (201, 202), s.text
        mv = tc.post(f"/v1/sessions/{s.json()['id']}/deform?result=report",
                     json={"handles": {"hole": {"translation": [-1.0, 0, 0]}}}, headers=beta_key)
        assert mv.status_code == 200, mv.text
        done["beta"] = time.monotonic()
        t.join(60)
        assert not t.is_alive()
        a = answers["alpha"]
        # beta was answered while alpha's deck was still being read, and alpha's read was stopped
        assert done["beta"] < done["alpha"], (done["beta"] - t0, done["alpha"] - t0)
        assert a.status_code == 422 and err(a)["code"] == "parse_time_limit", a.text
        assert tc.get("/v1/meshes", headers={"X-API-Key": "alpha"}).json() == []  # nothing stored
        # the worker was replaced: alpha's next upload is read
        r = tc.post("/v1/meshes", files=[("file", ("plate.inp", (DATA / "plate.inp").read_bytes()))],
                    headers={"X-API-Key": "alpha"})
        assert r.status_code == 201, r.text
        assert tc.get("/ready").status_code == 200


def test_a_file_of_nodes_no_element_uses_is_refused_in_the_worker(tmp_path):
    """Within every declared bound: 300,000 points around one tetrahedron (a 'points bomb')."""
    import meshio

    P = np.zeros((300_000, 3))
    P[:4] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    path = tmp_path / "bomb.vtu"
    meshio.write(path, meshio.Mesh(P, [("tetra", np.array([[0, 1, 2, 3]]))]), compression="zlib")
    with running(tmp_path / "d") as tc:
        r = tc.post("/v1/meshes", files=[("file", ("bomb.vtu", path.read_bytes()))])
        assert r.status_code == 422 and err(r)["code"] == "unused_points", r.text
        assert err(r)["details"] == {"nodes": 300_000, "used": 4}
        assert tc.get("/v1/meshes").json() == []
