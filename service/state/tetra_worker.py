"""What runs in a tetrahedralization worker process (spawned: no web code is imported).

fTetWild holds the GIL for the whole run, so it cannot share the service's
process; :func:`run` is the entry point of the child.
"""

from __future__ import annotations

import os
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

__all__ = ["run"]


def run(conn: Connection, work: str, V: np.ndarray, F: np.ndarray, options: dict[str, Any]) -> None:
    """Tetrahedralize in the folder ``work``; send ``("ok", V, T, info)`` or ``("error", error_dict)``.

    Before it, ``("stage", name)`` says each step as it starts (``tetrahedralizing``, ``checking``):
    fTetWild reports no progress of its own.

    ``work`` belongs to the job runner, which removes it when this process has ended.
    """
    from solver.errors import SolverError
    from solver.io.tetrahedralize import tetrahedralize

    os.chdir(work)  # fTetWild writes into the working directory
    try:
        mesh, info = tetrahedralize(V, F, **options, stage=lambda name: conn.send(("stage", name)))
        conn.send(("ok", mesh.V, mesh.T, info))
    except SolverError as e:
        conn.send(("error", e.to_dict()))
    except Exception as e:  # noqa: BLE001 - reported to the service as a worker fault
        conn.send(("error", {"type": type(e).__name__, "code": "worker_failed", "message": str(e)[:500],
                             "details": {}}))
    finally:
        conn.close()
