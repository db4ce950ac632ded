"""Run ``tetmorph serve`` in a child process (tests, benchmarks, pipelines).

Examples
--------
::

    with serve_process("/tmp/tm-data") as url:
        Client(url).upload_mesh("part.inp")
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator

import httpx

__all__ = ["free_port", "serve_process"]


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def serve_process(data_dir: str | os.PathLike[str], port: int | None = None,
                  env: dict[str, str] | None = None, startup_s: float = 60.0
                  ) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """Start the service on 127.0.0.1, wait for ``/health``, stop it on exit.

    Parameters
    ----------
    data_dir : path
    port : int, optional
        Defaults to a free port.
    env : dict, optional
        Extra environment (``TETMORPH_*`` settings).
    startup_s : float
        How long to wait for the service to answer.

    Yields
    ------
    (url, process)

    Raises
    ------
    RuntimeError
        The service exited or did not answer in time (with its output).
    """
    port = port or free_port()
    proc = subprocess.Popen([sys.executable, "-m", "service.cli", "serve", "--port", str(port),
                             "--data-dir", os.fspath(data_dir), "--log-level", "warning"],
                            env=dict(os.environ, **(env or {})), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + startup_s
        while True:
            try:
                if httpx.get(url + "/health", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                out = proc.stdout.read() if proc.stdout else ""
                raise RuntimeError(f"tetmorph serve did not start on {url}: {out}")
            time.sleep(0.1)
        yield url, proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
