"""The store a service runs on, chosen by its settings: files, or PostgreSQL records.

Kept apart from both stores so that neither imports the other: :mod:`.pg_store`
builds on :mod:`.store`'s file layout, and this module picks between them.
"""

from __future__ import annotations

import os

from solver.limits import MAX_CELLS, MAX_POINTS

from .store import FileStore, Store

__all__ = ["open_store"]


def open_store(data_dir: str | os.PathLike[str], database_url: str | None = None, max_points: int = MAX_POINTS,
               max_cells: int = MAX_CELLS) -> Store:
    """The store of the settings: :class:`~.store.FileStore`, or PostgreSQL records when ``database_url`` is set.

    ``max_points`` and ``max_cells`` bound what an uploaded file may declare (checked before it is read).
    """
    if database_url:
        from .pg_store import PgStore

        return PgStore(database_url, data_dir, max_points, max_cells)
    return FileStore(data_dir, max_points, max_cells)
