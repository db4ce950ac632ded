"""A full data disk: every write answers 507 storage_full, nothing stored is lost, and /ready says so.

The service runs on a tmpfs of a few MB (mounted here: the test needs root, or CAP_SYS_ADMIN, and
fails when it cannot mount), which a file then fills to the last byte. Every write that needs the
disk is refused whole with 507 ``storage_full`` and ``Retry-After``; what was committed before is
as it was, and once the file is deleted the service goes on where it stopped.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from service.errors import STORAGE_RETRY_AFTER_S

from .conftest import BRACKET, BRACKET_SPEC, MOVES, err, running

DISK_MB = 8
BATCH = {"shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}},
         "plan": {"columns": ["bend"], "rows": [[0.5], [1.0]]}, "format": "inp"}
ARRAYS = {"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "tetrahedra": [[0, 1, 2, 3]], "sets": {},
          "name": "tet"}


@contextlib.contextmanager
def small_disk(path: Path, mb: int) -> Iterator[Path]:
    """A tmpfs of ``mb`` MB mounted on ``path``, unmounted at the end whatever happened."""
    path.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={mb}m,mode=0700", "tmpfs", str(path)],
                       capture_output=True, text=True, timeout=30)
    if r.returncode != 0:
        pytest.fail(f"this test mounts a {mb} MB tmpfs to fill it and needs root (or CAP_SYS_ADMIN); "
                    f"mount answered {r.returncode}: {r.stderr.strip() or r.stdout.strip()}")
    try:
        yield path
    finally:
        if subprocess.run(["umount", str(path)], capture_output=True, timeout=30).returncode != 0:
            subprocess.run(["umount", "-l", str(path)], capture_output=True, timeout=30)


def fill(disk: Path) -> Path:
    """Write a file until the disk refuses another byte (bounded: twice the disk's size, 30 s)."""
    assert os.path.ismount(disk) and shutil.disk_usage(disk).total <= DISK_MB << 20, "not the small disk"
    filler = disk / "filler"
    left = 2 * (DISK_MB << 20)
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    deadline = time.monotonic() + 30
    try:
        for chunk in (1 << 20, 1 << 12, 1):
            for _ in range(2 * (DISK_MB << 20) // max(chunk, 1 << 12) + 8):
                assert time.monotonic() < deadline and left > 0, "the disk took more than its size, or 30 s"
                try:
                    left -= os.write(fd, b"\0" * chunk)
                except OSError as e:
                    assert e.errno == errno.ENOSPC, e
                    break
            else:
                raise AssertionError(f"the disk still took writes of {chunk} bytes")
    finally:
        os.close(fd)
    assert shutil.disk_usage(disk).free == 0
    return filler


def listing(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` and its bytes, but the jobs' folder (checked apart)."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.relative_to(root).parts[0] != "jobs"}


def full(r: Any) -> dict[str, Any]:
    """The envelope of a 507 ``storage_full`` answer, checking its status, code and Retry-After."""
    e = err(r)
    assert r.status_code == 507 and e["code"] == "storage_full", (r.status_code, e)
    assert r.headers["retry-after"] == str(STORAGE_RETRY_AFTER_S) == str(e["details"]["retry_after_s"])
    assert "data directory is full" in e["message"] and "free space" in e["message"], e
    assert "/" not in e["message"], e  # no path of the server
    return e


def wait_batch(tc: Any, sid: str, jid: str, limit_s: float = 60.0) -> dict[str, Any]:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        doc = tc.get(f"/v1/sessions/{sid}/batch/{jid}").json()
        if doc["status"] not in ("queued", "running"):
            return doc
        time.sleep(0.05)
    raise AssertionError(f"batch {jid} still running after {limit_s} s")


def test_a_full_disk_answers_507_stores_nothing_loses_nothing_and_is_not_ready(tmp_path):
    with small_disk(tmp_path / "disk", DISK_MB) as disk:
        data = disk / "data"
        acknowledged: list[dict[str, Any]] = []
        with running(data, min_free_mb=1) as tc:
            assert tc.get("/ready").status_code == 200
            r = tc.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))])
            assert r.status_code == 201, r.text
            mesh_id = r.json()["id"]
            r = tc.post("/v1/sessions", json={"mesh_id": mesh_id, "spec": BRACKET_SPEC})
            assert r.status_code == 201, r.text
            sid = r.json()["id"]
            assert tc.post(f"/v1/sessions/{sid}/deform", json=MOVES[0]).status_code == 200
            acknowledged.append(MOVES[0])
            assert tc.put(f"/v1/sessions/{sid}/history", json={"applied": acknowledged}).status_code == 200
            presets = [{"name": "lift", "move": MOVES[0]}]
            more = [*presets, {"name": "twist", "move": MOVES[1]}]
            assert tc.patch(f"/v1/sessions/{sid}", json={"presets": presets}).status_code == 200
            meshes = tc.get("/v1/meshes").json()
            session = tc.get(f"/v1/sessions/{sid}").json()
            assert session["version"] == 1
            cache_bytes = tc.get("/health").json()["cache_bytes"]
            stored = listing(data)

            filler = fill(disk)

            # every write is refused whole, with the same answer
            full(tc.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]))
            full(tc.post("/v1/meshes/arrays", json=ARRAYS))
            assert tc.get("/v1/meshes").json() == meshes
            for move in (MOVES[1], MOVES[2]):
                full(tc.post(f"/v1/sessions/{sid}/deform", json=move))
            full(tc.post(f"/v1/sessions/{sid}/reset"))
            with tc.websocket_connect(f"/v1/sessions/{sid}/stream") as ws:  # a streamed MOVE: an error frame
                ws.send_text(json.dumps({"seq": 7, "move": MOVES[2]}))
                for _ in range(4):  # a boundary frame may come first; a close ends the wait
                    msg = ws.receive()
                    if msg.get("text") is not None or msg["type"] == "websocket.close":
                        break
                assert msg.get("text") is not None, f"the stream ended instead of answering: {msg}"
                frame = json.loads(msg["text"])
                assert frame["seq"] == 7 and frame["error"]["code"] == "storage_full", frame
                ws.send_text(json.dumps({"seq": 8, "move": {"handles": {"zz": {}}}}))  # the stream is still open
                assert json.loads(ws.receive_text())["error"]["code"] == "invalid_spec"
            full(tc.post("/v1/sessions", json={"mesh_id": mesh_id, "spec": BRACKET_SPEC}))
            assert [s["id"] for s in tc.get("/v1/sessions").json()] == [sid]
            assert tc.get("/health").json()["cache_bytes"] == cache_bytes  # the failed session holds nothing
            full(tc.patch(f"/v1/sessions/{sid}", json={"presets": more}))
            full(tc.put(f"/v1/sessions/{sid}/history", json={"applied": [*acknowledged, MOVES[1]]}))
            now = tc.get(f"/v1/sessions/{sid}").json()
            assert (now["version"], now["last_move"], now["presets"]) == (1, MOVES[0], presets)
            assert tc.get(f"/v1/sessions/{sid}/history").json()["applied"] == acknowledged

            # a batch writes its zip in a job: the job fails with the same code and leaves no file
            r = tc.post(f"/v1/sessions/{sid}/batch", json=BATCH)
            assert r.status_code == 202, r.text
            job = wait_batch(tc, sid, r.json()["id"])
            assert job["status"] == "failed" and job["error"]["code"] == "storage_full", job
            assert [p.name for p in (data / "jobs").rglob("*")
                    if p.is_file() or p.name.startswith("tetmorph-batch-")] == []

            r = tc.get("/ready")
            assert r.status_code == 503 and r.json()["checks"]["store_writable"] is False, r.json()
            assert listing(data) == stored  # byte for byte: no record torn, no file half written, no temp file

            filler.unlink()

            r = tc.get("/ready")
            assert r.status_code == 200 and r.json()["checks"]["store_writable"] is True
            for move in (MOVES[2], MOVES[1]):
                assert tc.post(f"/v1/sessions/{sid}/deform", json=move).status_code == 200
                acknowledged.append(move)
                assert tc.put(f"/v1/sessions/{sid}/history", json={"applied": acknowledged}).status_code == 200
            assert tc.patch(f"/v1/sessions/{sid}", json={"presets": more}).status_code == 200
            assert tc.post("/v1/meshes/arrays", json=ARRAYS).status_code == 201
            now = tc.get(f"/v1/sessions/{sid}").json()
            assert (now["version"], now["last_move"]) == (3, MOVES[1])
            assert tc.get(f"/v1/sessions/{sid}/history").json()["applied"] == acknowledged
            assert list(data.rglob(".tmp-*")) == []

        with running(data, min_free_mb=1) as tc:  # a restart reads every record back whole
            now = tc.get(f"/v1/sessions/{sid}").json()
            assert (now["version"], now["last_move"], len(now["presets"])) == (3, MOVES[1], 2)
            assert tc.get(f"/v1/sessions/{sid}/history").json()["applied"] == [MOVES[0], MOVES[2], MOVES[1]]
            assert len(tc.get("/v1/meshes").json()) == 2
            assert json.loads((data / "sessions" / f"{sid}.json").read_text())["version"] == 3


def test_ready_is_false_while_the_free_space_is_under_the_reserve(tmp_path):
    with small_disk(tmp_path / "disk", DISK_MB) as disk, running(disk / "data", min_free_mb=DISK_MB + 1) as tc:
        r = tc.get("/ready")
        assert r.status_code == 503 and r.json()["checks"]["store_writable"] is False
        # the reserve stops the load balancer's writes only: a write that fits is still taken
        assert tc.post("/v1/meshes/arrays", json=ARRAYS).status_code == 201
