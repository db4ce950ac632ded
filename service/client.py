"""A Python client of the tetmorph service, for pipelines (httpx).

Examples
--------
A pipeline that morphs one deck into many variants::

    from service.client import Client

    with Client("http://127.0.0.1:8000", api_key="...") as tm:
        mesh = tm.upload_mesh("bracket.inp")
        session = tm.create_session(mesh["id"], spec)
        for k, move in enumerate(moves):
            V, report = tm.deform(session["id"], move)          # binary float64 positions
            tm.download_result(session["id"], f"bracket_{k}.inp")
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

from .binary import MEDIA_TYPE, FrameError, decode_frame

__all__ = ["Client", "TetmorphError", "BuildTimeout"]


class TetmorphError(Exception):
    """Any failure of a call: an error the service answered, or no usable answer at all.

    Attributes
    ----------
    status : int
        The HTTP status; 0 when no answer came (``code`` is then
        ``connection_failed`` or ``timeout``).
    code : str
        The service's error code; ``http_error`` for an answer that is not the
        service's envelope (a proxy's page), ``bad_frame`` for a corrupt binary body.
    message : str
    details : dict
    """

    def __init__(self, status: int, code: str, message: str, details: dict[str, Any]) -> None:
        super().__init__(f"[{status} {code}] {message}")
        self.status = status
        self.code = code
        self.message = message
        self.details = details


class BuildTimeout(TetmorphError, TimeoutError):
    """A session build or a job still running when the client stopped waiting."""


def _frame(r: httpx.Response) -> tuple[np.ndarray, dict[str, Any]]:
    try:
        return decode_frame(r.content)
    except (FrameError, ValueError, KeyError) as e:
        raise TetmorphError(r.status_code, "bad_frame", f"the binary body is not a tetmorph frame: {e}", {}) from e


class Client:
    """Talk to a tetmorph service.

    Parameters
    ----------
    base_url : str
        ``http://host:port`` of the service.
    api_key : str, optional
        Sent as ``X-API-Key``.
    timeout : float
        Seconds per request.
    http : httpx.Client, optional
        An existing client (for example FastAPI's ``TestClient``); then
        ``base_url`` is ignored.
    """

    def __init__(self, base_url: str = "http://127.0.0.1:8000", api_key: str | None = None,
                 timeout: float = 120.0, http: httpx.Client | None = None, retries: int = 2,
                 backoff_s: float = 0.2) -> None:
        headers = {"X-API-Key": api_key} if api_key else {}
        self._own = http is None
        self.http = http or httpx.Client(base_url=base_url, timeout=timeout)
        self.headers = headers
        self.retries = retries
        self.backoff_s = backoff_s

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection pool (if this client opened it)."""
        if self._own:
            self.http.close()

    # ----------------------------------------------------------------- plumbing
    def _request(self, method: str, url: str, idempotent: bool | None = None, **kw: Any) -> httpx.Response:
        """One call; transport failures and 502/503/504 of idempotent calls are retried."""
        headers = {**self.headers, **kw.pop("headers", {})}
        again = method in ("GET", "HEAD", "DELETE", "PUT") if idempotent is None else idempotent
        attempts = 1 + (self.retries if again else 0)
        for k in range(attempts):
            last = k == attempts - 1
            try:
                r = self.http.request(method, url, headers=headers, **kw)
            except httpx.TimeoutException as e:
                if last:
                    raise TetmorphError(0, "timeout", f"{method} {url}: no answer in time ({e})", {}) from e
            except httpx.TransportError as e:
                if last:
                    raise TetmorphError(0, "connection_failed", f"{method} {url}: {type(e).__name__}: {e}",
                                        {}) from e
            else:
                if r.status_code not in (502, 503, 504) or last:
                    break
                wait = r.headers.get("retry-after", "")
                if wait.isdigit():  # the service says when (a database restarting): no sooner
                    time.sleep(max(float(wait), self.backoff_s * 2**k))
                    continue
            time.sleep(self.backoff_s * 2**k)
        if r.status_code >= 400:
            try:
                err = r.json()["error"]
            except (ValueError, KeyError, TypeError):
                err = {"code": "http_error", "message": r.text[:500], "details": {}}
            raise TetmorphError(r.status_code, err.get("code", "error"), err.get("message", ""),
                                err.get("details", {}))
        return r

    # ------------------------------------------------------------------ meshes
    def upload_mesh(self, path: str | os.PathLike[str], file_format: str | None = None,
                    companions: list[str | os.PathLike[str]] | None = None,
                    name: str | None = None) -> dict[str, Any]:
        """Upload a mesh file with the files read with it.

        TetGen ``.node`` files bring their ``.ele``, and Abaqus and LS-DYNA decks
        the files they ``*INCLUDE`` (under their paths relative to the deck), unless
        ``companions`` names the files.
        """
        path = Path(path)
        extra = [Path(c) for c in companions or []]
        if path.suffix == ".node" and not extra and path.with_suffix(".ele").exists():
            extra = [path.with_suffix(".ele")]
        if not extra:
            from solver.io.patchers import patcher_for

            p = patcher_for(str(path), file_format)
            if p is not None and p.includes is not None:
                extra = [path.parent / rel for rel in p.includes(str(path))]

        def relative(c: Path) -> str:
            try:
                return c.resolve().relative_to(path.parent.resolve()).as_posix()
            except ValueError:
                return c.name

        files = [("file", (path.name, path.read_bytes()))]
        files += [("companions", (relative(c), c.read_bytes())) for c in extra]
        data = {k: v for k, v in (("format", file_format), ("name", name)) if v}
        return self._request("POST", "/v1/meshes", files=files, data=data).json()

    def upload_arrays(self, V: Any, T: Any, sets: dict[str, Any] | None = None,
                      name: str | None = None) -> dict[str, Any]:
        """Upload a mesh as arrays: V (n, 3), T (m, 4), named vertex sets."""
        body = {"vertices": np.asarray(V, float).tolist(), "tetrahedra": np.asarray(T, int).tolist(),
                "sets": {k: np.asarray(v, int).tolist() for k, v in (sets or {}).items()},
                "name": name}
        return self._request("POST", "/v1/meshes/arrays", json=body).json()

    def tetrahedralize(self, path: str | os.PathLike[str], poll: float = 0.5, timeout: float = 3600.0,
                       **options: Any) -> dict[str, Any]:
        """Tetrahedralize a closed surface file (edge_length, edge_length_fac, epsilon, ...).

        Waits for the job (polling) and returns the stored mesh's document.
        """
        path = Path(path)
        data = {k: str(v).lower() if isinstance(v, bool) else str(v) for k, v in options.items()}
        r = self._request("POST", "/v1/tetrahedralize", files=[("file", (path.name, path.read_bytes()))],
                          data=data)
        if r.status_code == 201:
            return r.json()
        job = r.json()
        deadline = time.monotonic() + timeout
        while job["status"] in ("queued", "running"):
            if time.monotonic() > deadline:
                raise BuildTimeout(0, "timeout", f"job {job['id']} still running after {timeout} s",
                                   {"job_id": job["id"]})
            time.sleep(poll)
            job = self._request("GET", f"/v1/jobs/{job['id']}").json()
        if job["status"] != "done":
            err = job.get("error") or {}
            raise TetmorphError(422, err.get("code", "job_failed"), err.get("message", ""), err.get("details", {}))
        return job["mesh"]

    def mesh(self, mesh_id: str) -> dict[str, Any]:
        """Describe a stored mesh."""
        return self._request("GET", f"/v1/meshes/{mesh_id}").json()

    def symmetry(self, mesh_id: str) -> dict[str, Any]:
        """Mirror planes and the deck's cyclic sectors of a stored volume mesh.

        Returns
        -------
        dict
            ``{"planes": [...], "cyclic": [...]}``: SPEC ``symmetry`` and ``cyclic``
            entries, as ``tetmorph info`` lists them (a plane also says how many
            boundary nodes it matched: drop ``matched`` and ``exact_pairs`` before
            putting it in a SPEC).
        """
        return self._request("GET", f"/v1/meshes/{mesh_id}/symmetry").json()

    def download_mesh(self, mesh_id: str, path: str | os.PathLike[str] | None = None,
                      file_format: str | None = None) -> bytes:
        """The uploaded file (or a conversion); written to ``path`` when given."""
        params = {"format": file_format} if file_format else {}
        data = self._request("GET", f"/v1/meshes/{mesh_id}/file", params=params).content
        if path is not None:
            Path(path).write_bytes(data)
        return data

    def delete_mesh(self, mesh_id: str) -> None:
        """Delete a stored mesh."""
        self._request("DELETE", f"/v1/meshes/{mesh_id}")

    # ---------------------------------------------------------------- sessions
    def create_session(self, mesh_id: str, spec: dict[str, Any], wait: bool = True,
                       poll: float = 0.2, timeout: float = 600.0) -> dict[str, Any]:
        """Create a session; with ``wait`` poll until it is ready.

        Raises
        ------
        TetmorphError
            SPEC errors (422), or a build that failed.
        """
        doc = self._request("POST", "/v1/sessions", json={"mesh_id": mesh_id, "spec": spec}).json()
        deadline = time.monotonic() + timeout
        while wait and doc["status"] == "building":
            if time.monotonic() > deadline:
                raise BuildTimeout(0, "timeout", f"session {doc['id']} still building after {timeout} s",
                                   {"session_id": doc["id"]})
            time.sleep(poll)
            doc = self.session(doc["id"])
        if doc["status"] == "failed":
            err = doc.get("error") or {}
            raise TetmorphError(422, err.get("code", "build_failed"), err.get("message", ""),
                                err.get("details", {}))
        return doc

    def session(self, session_id: str) -> dict[str, Any]:
        """Status, progress, timings and the last REPORT of a session."""
        return self._request("GET", f"/v1/sessions/{session_id}").json()

    def set_presets(self, session_id: str, presets: list[dict[str, Any]]) -> dict[str, Any]:
        """Replace the session's presets (``[{"name", "move": MOVE}]``); return the session document.

        They do not change the session's morph state or version; apply one
        with ``deform(session_id, preset["move"])``.
        """
        return self._request("PATCH", f"/v1/sessions/{session_id}", idempotent=True,
                             json={"presets": presets}).json()

    def history(self, session_id: str) -> dict[str, Any]:
        """The session's undo history: ``{"applied": [MOVE, ...], "undone": [MOVE, ...]}``."""
        return self._request("GET", f"/v1/sessions/{session_id}/history").json()

    def save_history(self, session_id: str, applied: list[dict[str, Any]],
                     undone: list[dict[str, Any]] | None = None) -> dict[str, Any]:
        """Replace the session's undo history (MOVEs applied, oldest first; MOVEs undone, last undone first).

        It does not change the session's morph state or version; returns the history as stored.
        """
        return self._request("PUT", f"/v1/sessions/{session_id}/history", idempotent=True,
                             json={"applied": applied, "undone": undone or []}).json()

    def workspace(self, of: str, ident: str) -> dict[str, Any]:
        """A workspace: ``of`` ``"meshes"`` or ``"sessions"``, ``ident`` the mesh's or session's id."""
        return self._request("GET", f"/v1/{of}/{ident}/workspace").json()

    def save_workspace(self, of: str, ident: str, doc: dict[str, Any]) -> dict[str, Any]:
        """Replace a mesh's or session's workspace (``of`` ``"meshes"`` or ``"sessions"``); return it as stored.

        Fields: ``regions`` (a SPEC draft), ``labels``, ``doe_plan``, ``shape_values``, ``session``.
        """
        return self._request("PUT", f"/v1/{of}/{ident}/workspace", idempotent=True, json=doc).json()

    def deform(self, session_id: str, move: dict[str, Any], kind: str = "positions",
               dtype: str = "float64", inversion: str | None = None
               ) -> tuple[np.ndarray, dict[str, Any]]:
        """Apply a MOVE; return the (n, 3) positions (or displacements) and the REPORT.

        Uses the binary body. Raises :class:`TetmorphError` (422, code
        ``inverted_elements``, ``details["report"]``) for a rejected move.
        """
        params = {"result": "binary", "kind": kind, "dtype": dtype}
        if inversion:
            params["inversion"] = inversion
        # a MOVE is absolute (positions from the rest shape), so sending it again is safe: retried
        r = self._request("POST", f"/v1/sessions/{session_id}/deform", idempotent=True, params=params,
                          content=json.dumps(move), headers={"content-type": "application/json",
                                                            "accept": MEDIA_TYPE})
        X, header = _frame(r)
        return X, header["report"]

    def deform_mesh(self, session_id: str, move: dict[str, Any], path: str | os.PathLike[str],
                    file_format: str | None = None) -> dict[str, Any]:
        """Apply a MOVE and write the deformed mesh file; return the short REPORT."""
        fmt = file_format or Path(path).suffix.lstrip(".") or "vtu"
        r = self._request("POST", f"/v1/sessions/{session_id}/deform", idempotent=True,
                          params={"result": "mesh", "format": fmt}, json=move)
        Path(path).write_bytes(r.content)
        return json.loads(r.headers.get("x-tetmorph-report", "{}"))

    def download_result(self, session_id: str, path: str | os.PathLike[str],
                        file_format: str | None = None) -> None:
        """Write the session's current deformed mesh."""
        fmt = file_format or Path(path).suffix.lstrip(".") or "vtu"
        r = self._request("GET", f"/v1/sessions/{session_id}/mesh", params={"format": fmt})
        Path(path).write_bytes(r.content)

    def positions(self, session_id: str) -> np.ndarray:
        """The session's current positions (float64)."""
        r = self._request("GET", f"/v1/sessions/{session_id}/positions",
                          params={"result": "binary"})
        return _frame(r)[0]

    def reset(self, session_id: str) -> dict[str, Any]:
        """Back to the rest shape."""
        return self._request("POST", f"/v1/sessions/{session_id}/reset", idempotent=True).json()

    def delete_session(self, session_id: str) -> None:
        """Delete a session."""
        self._request("DELETE", f"/v1/sessions/{session_id}")
