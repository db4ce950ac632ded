"""A cluster on this machine: PostgreSQL, N ``tetmorph serve`` replicas and HAProxy, all on 127.0.0.1.

:class:`LocalCluster` is what ``make cluster`` starts (detached, its state in
``cluster.json`` of its folder, stopped by ``make cluster-down``) and what the
cluster tests and ``benchmarks/bench_cluster.py`` start and stop themselves.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx

from ..process import free_port
from .haproxy import render_config
from .postgres import LocalPostgres

__all__ = ["LocalCluster", "haproxy_binary"]


def haproxy_binary() -> str:
    """The ``haproxy`` program.

    Raises
    ------
    RuntimeError
        Not installed (``make clusterdeps`` installs Debian's).
    """
    found = shutil.which("haproxy") or next((p for p in ("/usr/sbin/haproxy",) if os.path.exists(p)), None)
    if not found:
        raise RuntimeError("haproxy is not installed: run `make clusterdeps` (apt-get install haproxy)")
    return found


def _wait_http(url: str, proc: subprocess.Popen[bytes] | None, timeout: float, what: str, log: Path) -> None:
    deadline = time.monotonic() + timeout
    while True:
        try:
            if httpx.get(url, timeout=1.0).status_code == 200:
                return
        except httpx.TransportError:
            pass
        if (proc is not None and proc.poll() is not None) or time.monotonic() > deadline:
            tail = log.read_text(errors="replace")[-3000:] if log.is_file() else ""
            raise RuntimeError(f"{what} did not answer {url} within {timeout:g} s: {tail}")
        time.sleep(0.1)


class LocalCluster:
    """PostgreSQL, replicas and the balancer in ``folder``.

    Parameters
    ----------
    folder : path
        ``pg/``, ``data/`` (the shared data directory), ``haproxy.cfg``, logs, ``cluster.json``.
    replicas : int
    port : int, optional
        The balancer's port (default: a free one).
    replica_ports : list of int, optional
    pg_port : int, optional
    env : dict, optional
        ``TETMORPH_*`` settings of every replica.
    fast_pg : bool
        PostgreSQL without fsync (tests).
    """

    def __init__(self, folder: str | os.PathLike[str], replicas: int = 3, port: int | None = None,
                 replica_ports: list[int] | None = None, pg_port: int | None = None,
                 env: dict[str, str] | None = None, fast_pg: bool = False) -> None:
        self.folder = Path(folder).absolute()
        self.n = replicas
        self.port = port or free_port()
        self.replica_ports = replica_ports or [free_port() for _ in range(replicas)]
        self.pg = LocalPostgres(self.folder / "pg", pg_port or free_port(), fast=fast_pg)
        self.data = self.folder / "data"
        self.env = env or {}
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self.haproxy: subprocess.Popen[bytes] | None = None

    # ------------------------------------------------------------------ parts
    @property
    def url(self) -> str:
        """The balancer."""
        return f"http://127.0.0.1:{self.port}"

    def names(self) -> list[str]:
        """Replica names ``r1 .. rN``."""
        return [f"r{k + 1}" for k in range(self.n)]

    def replica_url(self, name: str) -> str:
        """One replica, directly."""
        return f"http://127.0.0.1:{self.replica_ports[self.names().index(name)]}"

    def start_replica(self, name: str, timeout: float = 90.0, wait: bool = True) -> None:
        """Start (or start again) one replica."""
        port = self.replica_ports[self.names().index(name)]
        log = self.folder / f"{name}.log"
        env = dict(os.environ, TETMORPH_DATABASE_URL=self.pg.url, TETMORPH_REPLICA_ID=name, **self.env)
        with open(log, "ab") as out:
            self.procs[name] = subprocess.Popen(
                [sys.executable, "-m", "service.cli", "serve", "--host", "127.0.0.1", "--port", str(port),
                 "--data-dir", str(self.data), "--log-level", "warning"],
                env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        if wait:
            _wait_http(self.replica_url(name) + "/health", self.procs[name], timeout, f"replica {name}", log)

    def wait_replica(self, name: str, timeout: float = 90.0) -> None:
        """Wait until a started replica answers."""
        _wait_http(self.replica_url(name) + "/health", self.procs[name], timeout, f"replica {name}",
                   self.folder / f"{name}.log")

    def kill(self, name: str) -> int:
        """``kill -9`` one replica; its process id."""
        p = self.procs[name]
        p.send_signal(signal.SIGKILL)
        p.wait(10)
        return p.pid

    def start_balancer(self, timeout: float = 30.0) -> None:
        """Write ``haproxy.cfg`` and start HAProxy (foreground process)."""
        cfg = self.folder / "haproxy.cfg"
        servers = [(n, f"127.0.0.1:{p}") for n, p in zip(self.names(), self.replica_ports, strict=True)]
        cfg.write_text(render_config(servers, f"127.0.0.1:{self.port}"))
        log = self.folder / "haproxy.log"
        with open(log, "ab") as out:
            self.haproxy = subprocess.Popen([haproxy_binary(), "-db", "-f", str(cfg)], stdout=out,
                                            stderr=subprocess.STDOUT, start_new_session=True)
        _wait_http(self.url + "/health", self.haproxy, timeout, "haproxy", log)

    def wait_ring(self, names: list[str], timeout: float = 30.0) -> None:
        """Wait until the balancer has seen every replica of ``names`` up (its health checks)."""
        deadline = time.monotonic() + timeout
        seen: set[str] = set()
        while time.monotonic() < deadline:
            for _ in range(2 * self.n):
                try:
                    r = httpx.get(self.url + "/health", timeout=2.0)
                    seen.add(r.headers.get("x-tetmorph-replica", ""))
                except httpx.TransportError:
                    pass
            if set(names) <= seen:
                return
            time.sleep(0.3)
        raise RuntimeError(f"the balancer reached {sorted(seen)} of {names} within {timeout:g} s")

    # ------------------------------------------------------------------ whole
    def start(self, timeout: float = 120.0) -> LocalCluster:
        """PostgreSQL, every replica (started together), the balancer."""
        self.folder.mkdir(parents=True, exist_ok=True)
        os.chmod(self.folder, self.folder.stat().st_mode | 0o711)  # PostgreSQL's user reaches pg/ inside
        self.data.mkdir(parents=True, exist_ok=True)
        self.pg.start()
        for name in self.names():
            self.start_replica(name, wait=False)
        for name in self.names():
            self.wait_replica(name, timeout)
        self.start_balancer()
        self.wait_ring(self.names())
        self.save_state()
        return self

    def save_state(self) -> None:
        """``cluster.json``: what :func:`stop_saved` needs to stop a detached cluster."""
        doc: dict[str, Any] = {"url": self.url, "pg_folder": str(self.pg.folder), "pg_port": self.pg.port,
                               "haproxy": self.haproxy.pid if self.haproxy else None,
                               "replicas": {n: {"pid": p.pid, "url": self.replica_url(n)}
                                            for n, p in self.procs.items()}}
        (self.folder / "cluster.json").write_text(json.dumps(doc, indent=2))

    def stop(self) -> None:
        """Stop the balancer, the replicas and PostgreSQL."""
        procs = [self.haproxy] if self.haproxy else []
        procs += list(self.procs.values())
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in procs:
            try:
                p.wait(20)
            except subprocess.TimeoutExpired:
                p.kill()
        self.pg.stop()
        (self.folder / "cluster.json").unlink(missing_ok=True)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def stop_saved(folder: str | os.PathLike[str]) -> bool:
    """Stop the cluster whose ``cluster.json`` is in ``folder`` (``make cluster-down``); False if none."""
    folder = Path(folder)
    state = folder / "cluster.json"
    if not state.is_file():
        return False
    doc = json.loads(state.read_text())
    pids = [doc.get("haproxy")] + [r["pid"] for r in doc.get("replicas", {}).values()]
    for pid in [p for p in pids if p]:
        if _pid_alive(pid):
            os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + 20
    for pid in [p for p in pids if p]:
        while _pid_alive(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        if _pid_alive(pid):
            os.kill(pid, signal.SIGKILL)
    LocalPostgres(doc["pg_folder"], int(doc["pg_port"])).stop()
    state.unlink()
    return True
