"""The store a service runs on, chosen by its settings: files, or PostgreSQL records.

Kept apart from both stores so that neither imports the other: :mod:`.pg_store`
builds on :mod:`.store`'s file layout, and this module picks between them.
"""

from __future__ import annotations

import os

from solver.io.bounds import ReadBounds

from .store import FileStore, Store

__all__ = ["open_store"]


def open_store(data_dir: str | os.PathLike[str], database_url: str | None = None,
               bounds: ReadBounds | None = None, min_free_bytes: int = 0) -> Store:
    """The store of the settings: :class:`~.store.FileStore`, or PostgreSQL records when ``database_url`` is set.

    ``bounds`` is what an uploaded file may declare or expand to (checked before it is read);
    with less than ``min_free_bytes`` free in the data directory the store says it is not writable.
    """
    if database_url:
        from .pg_store import PgStore

        return PgStore(database_url, data_dir, bounds, min_free_bytes)
    return FileStore(data_dir, bounds, min_free_bytes)
