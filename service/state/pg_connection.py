"""The one PostgreSQL connection a :class:`~service.state.pg_store.PgStore` runs its statements on.

Autocommit, a 5 s connect timeout and a 10 s statement timeout. A lost
connection (psycopg's ``OperationalError``) is opened again once per call;
a second failure is raised, and the service answers it as an outage (503,
:func:`service.errors.store_outage`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["PgConnection"]

T = TypeVar("T")


class PgConnection:
    """A connection to ``url``, opened on first use and again after it was lost.

    Parameters
    ----------
    url : str
        ``postgresql://user@host:port/db``.
    """

    def __init__(self, url: str) -> None:
        import psycopg

        self._psycopg = psycopg
        self.url = url
        self._conn: Any = None

    def _connection(self) -> Any:
        if self._conn is None or self._conn.closed:
            self._conn = self._psycopg.connect(self.url, autocommit=True, connect_timeout=5,
                                               options="-c statement_timeout=10000")
        return self._conn

    def run(self, fn: Callable[[Any], T]) -> T:
        """``fn(connection)``, once more on a fresh connection when the first one was lost."""
        try:
            return fn(self._connection())
        except self._psycopg.OperationalError:
            self.close()
            return fn(self._connection())

    def rows(self, sql: str, args: Any = ()) -> list[tuple[Any, ...]]:
        """The rows ``sql`` answers."""
        return self.run(lambda c: c.execute(sql, args).fetchall())

    def exec(self, sql: str, args: Any = ()) -> int:
        """Run ``sql``; the rows it touched."""
        return int(self.run(lambda c: c.execute(sql, args).rowcount))

    def answers(self) -> bool:
        """True when the database answers a query."""
        try:
            self.rows("SELECT 1")
        except self._psycopg.Error:
            return False
        return True

    def close(self) -> None:
        """Close the connection (the next call opens another)."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None


def jsonb(doc: Any) -> Any:
    """``doc`` as a ``jsonb`` parameter."""
    from psycopg.types.json import Jsonb

    return Jsonb(doc)
