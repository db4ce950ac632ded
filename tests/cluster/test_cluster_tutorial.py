"""The cluster tutorial (docs/tutorials/cluster.md) runs as written, on a cluster of its own.

``tests/test_docs.py`` runs every other tutorial's blocks; this page's need PostgreSQL and HAProxy
(``make clusterdeps``, part of ``make test``), so they run here. The page's ports and folder are
the defaults of ``make cluster``; they are replaced by free ones and a fresh folder, so that a
cluster a developer runs is never touched. Whatever the page does, everything it started is stopped.
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import sys
import tempfile
from pathlib import Path

import httpx

from service.cluster.local import stop_saved
from tests.tutorial_blocks import run_steps, steps

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "tutorials" / "cluster.md"
FOLDER = "/tmp/tetmorph-cluster"
BALANCER, FIRST_REPLICA, PG = 8100, 8101, 8199


def _free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _free_ports() -> dict[int, int]:
    """The page's ports (balancer, three consecutive replicas, PostgreSQL) mapped to free ones."""
    for base in range(23000 + os.getpid() % 1000 * 20, 60000, 20):
        ports = [base, base + 1, base + 2, base + 3, base + 9]
        if all(_free(p) for p in ports):
            return dict(zip([BALANCER, FIRST_REPLICA, FIRST_REPLICA + 1, FIRST_REPLICA + 2, PG], ports, strict=True))
    raise RuntimeError("no free ports")


def test_the_cluster_tutorial_runs_as_written(tmp_path, monkeypatch):
    ports = _free_ports()
    folder = tempfile.mkdtemp(prefix="tm-tutorial-cl-")  # under /tmp: PostgreSQL's user reaches it
    blocks = steps(PAGE.read_text())
    code = "\n".join(c for _, c in blocks)
    assert FOLDER in code and all(re.search(rf"\b{p}\b", code) for p in (BALANCER, FIRST_REPLICA, PG)), \
        "the page no longer uses the defaults"

    def private(text: str) -> str:
        text = text.replace(FOLDER, folder)
        return re.sub(r"\b(" + "|".join(map(str, ports)) + r")\b", lambda m: str(ports[int(m.group())]), text)

    blocks = [(lang, private(c)) for lang, c in blocks]
    left = "\n".join(c for _, c in blocks)
    work = tmp_path / "checkout"  # reads like the repository's root, with an out/ of its own
    work.mkdir()
    for name in ("tests", "docs"):
        (work / name).symlink_to(ROOT / name, target_is_directory=True)
    (work / "out").mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setenv("PATH", f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    try:
        assert FOLDER not in left and not any(re.search(rf"\b{p}\b", left) for p in ports)
        scope = run_steps(blocks, work, PAGE.name, timeout=240)
    finally:  # the page stops the cluster itself; this stops it when a block failed before that
        stop_saved(folder)
        shutil.rmtree(folder, ignore_errors=True)
    killed = (work / "out" / "cluster_killed.txt").read_text().strip()
    assert killed in {"r1", "r2", "r3"} and scope["now"] in {"r1", "r2", "r3"} and scope["now"] != killed
    try:
        httpx.get(f"http://127.0.0.1:{ports[BALANCER]}/health", timeout=2)
        raise AssertionError("the balancer still answers after the page stopped the cluster")
    except httpx.TransportError:
        pass
