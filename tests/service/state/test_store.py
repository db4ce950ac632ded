"""The data directory: what an interrupted upload or write leaves is removed at start."""

from __future__ import annotations

from ..conftest import BRACKET, running


def test_orphan_uploads_are_removed_at_start_and_stored_meshes_kept(tmp_path):
    with running(tmp_path) as tc:
        mid = tc.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))]).json()["id"]
    orphan = tmp_path / "meshes" / "m_orphan0000000000"  # a process killed between the upload and its meta
    orphan.mkdir()
    (orphan / "big.inp").write_bytes(b"*NODE\n" * 1000)
    half = tmp_path / "sessions" / ".tmp-abc.json"  # an atomic write cut short
    half.write_text("{")
    with running(tmp_path) as tc:
        assert not orphan.exists() and not half.exists()
        assert [m["id"] for m in tc.get("/v1/meshes").json()] == [mid]
        assert tc.get(f"/v1/meshes/{mid}/file").content == BRACKET.read_bytes()
