"""Tetrahedralize from the page (issue 43): after a surface upload, a dialog with the edge length, the
job's stage and elapsed time, a Cancel that stops the worker and stores nothing, and the volume mesh
opened when it is done. Driven with the file chooser, the keyboard and clicks, as a person does.

Failed before the dialog existed (no #tetra-dialog: the upload showed only a Tetrahedralize button
that ran at the default edge length, with no Cancel).
"""

from __future__ import annotations

import time

import httpx
import meshio
import numpy as np
import psutil

from service.process import serve_process
from solver.io.tetrahedralize import tetrahedralize
from solver.testing import sphere_surface
from tests.browser.conftest import VIEWPORT

#: fTetWild is not deterministic, even on one thread: five runs of the same sphere at the same edge length
#: gave 1,164 to 1,363 tetrahedra, a CAD-like bunny 21,252 and 23,841 (2026-12, this 2-core VM, busy).
COUNT_TOLERANCE = 0.3


def _workers(proc) -> set[int]:
    """The service's spawned child processes (upload readers and job workers)."""
    out = set()
    for p in psutil.Process(proc.pid).children(recursive=True):
        try:
            if "spawn_main" in " ".join(p.cmdline()):
                out.add(p.pid)
        except psutil.Error:
            continue
    return out


def _status(pg) -> str:
    return pg.evaluate("document.getElementById('tetra-status').textContent")


def test_tetrahedralize_from_the_page_with_an_edge_length_progress_and_cancel(browser, tmp_path):
    V, F = sphere_surface(3, 1.0)  # about 25 s of fTetWild at 0.02 of the diagonal on an idle machine
    stl = tmp_path / "ball.stl"
    meshio.write(stl, meshio.Mesh(V, [("triangle", F)]))
    ctx = browser.new_context(viewport=VIEWPORT, bypass_csp=True)
    pg = ctx.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    try:
        with serve_process(tmp_path / "data") as (base, proc), httpx.Client(base_url=base, timeout=60) as http:
            pg.goto(base + "/")
            pg.wait_for_function("window.tetmorph !== undefined")
            with pg.expect_file_chooser() as fc:
                pg.click("#upload-btn")
            fc.value.set_files(str(stl))
            pg.wait_for_selector("#tetra-dialog[open]", timeout=60000)  # offered after the surface upload
            stored = [m["id"] for m in http.get("/v1/meshes").json()]
            assert len(stored) == 1  # the surface
            assert pg.input_value("#tetra-fac") == "0.05"  # the service's default
            diag = float(np.linalg.norm(V.max(0) - V.min(0)))
            assert abs(float(pg.input_value("#tetra-abs")) / (0.05 * diag) - 1) < 1e-4
            readers = _workers(proc)

            # a long run, then Cancel while fTetWild works
            pg.fill("#tetra-fac", "")
            pg.click("#tetra-fac")
            pg.keyboard.type("0.02")
            assert abs(float(pg.input_value("#tetra-abs")) / (0.02 * diag) - 1) < 1e-4
            pg.click("#tetra-run")
            pg.wait_for_function("document.getElementById('tetra-status').dataset.stage === 'tetrahedralizing'",
                                 timeout=120000)
            assert pg.is_visible("#tetra-bar") and pg.get_attribute("#tetra-bar", "value") is None  # no made-up %
            assert pg.is_disabled("#tetra-run") and pg.is_enabled("#tetra-cancel")
            first = _status(pg)
            pg.wait_for_function(f"document.getElementById('tetra-status').textContent !== {first!r}",
                                 timeout=30000)  # the elapsed time goes on
            assert "tetrahedralizing" in _status(pg) and _status(pg).endswith(" s"), _status(pg)
            job_workers = _workers(proc) - readers
            assert len(job_workers) == 1, job_workers
            pg.click("#tetra-cancel")
            pg.wait_for_function("document.getElementById('tetra-status').textContent.startsWith('Cancelled')",
                                 timeout=30000)
            assert "nothing was stored" in _status(pg)
            psutil.wait_procs([psutil.Process(p) for p in job_workers if psutil.pid_exists(p)], timeout=10)
            assert not any(psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE
                           for p in job_workers)  # the worker process is gone
            time.sleep(1.0)
            assert [m["id"] for m in http.get("/v1/meshes").json()] == stored  # nothing stored
            assert pg.evaluate("window.tetmorph.mesh().id") == stored[0]  # still on the surface

            # again, coarser, to the end: the volume mesh opens
            pg.fill("#tetra-abs", "")
            pg.click("#tetra-abs")
            pg.keyboard.type(f"{0.25 * diag:.6g}")
            assert abs(float(pg.input_value("#tetra-fac")) - 0.25) < 1e-4
            pg.click("#tetra-run")
            pg.wait_for_function("window.tetmorph.mesh().open && window.tetmorph.mesh().name === 'ball.tet'",
                                 timeout=300000)
            assert pg.is_hidden("#tetra-dialog")
            mesh = pg.evaluate("window.tetmorph.mesh()")
            metas = http.get("/v1/meshes").json()
            assert len(metas) == 2 and mesh["id"] in {m["id"] for m in metas}
            (tmp_path / "ball.vtu").write_bytes(http.get(f"/v1/meshes/{mesh['id']}/file").content)
            T = meshio.read(tmp_path / "ball.vtu").cells_dict["tetra"]
            assert mesh["elements"] == len(T)  # the page shows the stored mesh
            used = http.get(f"/v1/meshes/{mesh['id']}").json()["tetrahedralization"]
            assert abs(used["edge_length"] / (0.25 * diag) - 1) < 1e-5  # the absolute length, as typed
        lib, _ = tetrahedralize(V, F, edge_length=float(f"{0.25 * diag:.6g}"))  # the library, same setting
        assert abs(len(T) / len(lib.T) - 1) < COUNT_TOLERANCE, (len(T), len(lib.T))
        assert errors == []
    finally:
        ctx.close()
