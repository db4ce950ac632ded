"""A real PostgreSQL for the tests: Debian's server in a folder of /tmp, on a free port of 127.0.0.1."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator

import pytest

from service.cluster.postgres import LocalPostgres
from service.process import free_port


@pytest.fixture(scope="session")
def pg_url() -> Iterator[str]:
    """The URL of a PostgreSQL started for this test session (fails loudly when it cannot start)."""
    pg = LocalPostgres(tempfile.mkdtemp(prefix="tetmorph-pg-"), free_port(), fast=True)
    url = pg.start()
    try:
        yield url
    finally:
        pg.remove()


def fresh_database(url: str) -> str:
    """Empty the tetmorph tables of the server (each test starts from no records)."""
    import psycopg

    with psycopg.connect(url, autocommit=True) as c:
        for t in ("tm_meshes", "tm_sessions", "tm_expired", "tm_rate"):
            c.execute(f"DROP TABLE IF EXISTS {t}")
    return url
