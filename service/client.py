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

from .binary import MEDIA_TYPE, decode_frame

__all__ = ["Client", "TetmorphError"]


class TetmorphError(Exception):
    """An error answered by the service (the JSON error envelope).

    Attributes
    ----------
    status : int
    code : str
    message : str
    details : dict
    """

    def __init__(self, status: int, code: str, message: str, details: dict[str, Any]) -> None:
        super().__init__(f"[{status} {code}] {message}")
        self.status = status
        self.code = code
        self.message = message
        self.details = details


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
                 timeout: float = 120.0, http: httpx.Client | None = None) -> None:
        headers = {"X-API-Key": api_key} if api_key else {}
        self._own = http is None
        self.http = http or httpx.Client(base_url=base_url, timeout=timeout)
        self.headers = headers

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection pool (if this client opened it)."""
        if self._own:
            self.http.close()

    # ----------------------------------------------------------------- plumbing
    def _request(self, method: str, url: str, **kw: Any) -> httpx.Response:
        headers = {**self.headers, **kw.pop("headers", {})}
        r = self.http.request(method, url, headers=headers, **kw)
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
        """Upload a mesh file; TetGen ``.node`` files bring their ``.ele`` automatically."""
        path = Path(path)
        extra = [Path(c) for c in companions or []]
        if path.suffix == ".node" and not extra and path.with_suffix(".ele").exists():
            extra = [path.with_suffix(".ele")]
        files = [("file", (path.name, path.read_bytes()))]
        files += [("companions", (c.name, c.read_bytes())) for c in extra]
        data = {k: v for k, v in (("format", file_format), ("name", name)) if v}
        return self._request("POST", "/v1/meshes", files=files, data=data).json()

    def upload_arrays(self, V: Any, T: Any, sets: dict[str, Any] | None = None,
                      name: str | None = None) -> dict[str, Any]:
        """Upload a mesh as arrays: V (n, 3), T (m, 4), named vertex sets."""
        body = {"vertices": np.asarray(V, float).tolist(), "tetrahedra": np.asarray(T, int).tolist(),
                "sets": {k: np.asarray(v, int).tolist() for k, v in (sets or {}).items()},
                "name": name}
        return self._request("POST", "/v1/meshes/arrays", json=body).json()

    def tetrahedralize(self, path: str | os.PathLike[str], **options: Any) -> dict[str, Any]:
        """Tetrahedralize a closed surface file (edge_length, edge_length_fac, epsilon, ...)."""
        path = Path(path)
        data = {k: str(v).lower() if isinstance(v, bool) else str(v) for k, v in options.items()}
        return self._request("POST", "/v1/tetrahedralize",
                             files=[("file", (path.name, path.read_bytes()))], data=data).json()

    def mesh(self, mesh_id: str) -> dict[str, Any]:
        """Describe a stored mesh."""
        return self._request("GET", f"/v1/meshes/{mesh_id}").json()

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
                raise TimeoutError(f"session {doc['id']} still building after {timeout} s")
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
        r = self._request("POST", f"/v1/sessions/{session_id}/deform", params=params,
                          content=json.dumps(move), headers={"content-type": "application/json",
                                                            "accept": MEDIA_TYPE})
        X, header = decode_frame(r.content)
        return X, header["report"]

    def deform_mesh(self, session_id: str, move: dict[str, Any], path: str | os.PathLike[str],
                    file_format: str | None = None) -> dict[str, Any]:
        """Apply a MOVE and write the deformed mesh file; return the short REPORT."""
        fmt = file_format or Path(path).suffix.lstrip(".") or "vtu"
        r = self._request("POST", f"/v1/sessions/{session_id}/deform",
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
        return decode_frame(r.content)[0]

    def reset(self, session_id: str) -> dict[str, Any]:
        """Back to the rest shape."""
        return self._request("POST", f"/v1/sessions/{session_id}/reset").json()

    def delete_session(self, session_id: str) -> None:
        """Delete a session."""
        self._request("DELETE", f"/v1/sessions/{session_id}")
