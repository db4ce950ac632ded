"""The data directory: what an interrupted upload or write leaves is removed at start; a failed write tears nothing."""

from __future__ import annotations

import errno
import shutil

import pytest

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


def _refuse_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_record_write_that_finds_the_disk_full_leaves_the_record_and_no_temporary_file(tmp_path, monkeypatch):
    from service.state import store as store_module

    store = store_module.FileStore(tmp_path)
    record = {"id": "s_0123456789abcdef", "owner": "public", "version": 1, "last_move": {"a": 1}}
    store.save_session(record)
    store.save_history(record["id"], {"applied": [{"a": 1}], "undone": []})
    before = {p.name: p.read_bytes() for p in tmp_path.rglob("*.json")}
    for write in (lambda: store.commit_session({**record, "last_move": {"a": 2}}, 1),
                  lambda: store.save_history(record["id"], {"applied": [], "undone": []}),
                  lambda: store.save_presets(record["id"], [{"name": "p", "move": {}}])):
        with monkeypatch.context() as m, pytest.raises(OSError) as e:
            m.setattr(store_module.os, "fsync", _refuse_space)  # the data reaches the disk at fsync
            write()
        assert e.value.errno == errno.ENOSPC
    assert {p.name: p.read_bytes() for p in tmp_path.rglob("*.json")} == before
    assert list(tmp_path.rglob(".tmp-*")) == []
    assert store.load_session(record["id"])["version"] == 1


def test_the_store_is_not_writable_with_less_free_space_than_its_reserve(tmp_path, monkeypatch):
    from service.state import store as store_module

    free = shutil.disk_usage(tmp_path).free
    assert store_module.FileStore(tmp_path, min_free_bytes=free // 2).writable()
    assert not store_module.FileStore(tmp_path, min_free_bytes=free + (1 << 30)).writable()
    with monkeypatch.context() as m:
        m.setattr(store_module.os, "write", _refuse_space)  # a full file system still creates empty files
        writable = store_module.FileStore(tmp_path).writable()
    assert not writable
    assert list(tmp_path.rglob(".tmp-*")) == []
