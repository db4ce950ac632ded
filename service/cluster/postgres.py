"""A PostgreSQL server in a local folder, run by an unprivileged user, on 127.0.0.1.

``initdb`` refuses to run as root: as root the server's folder is given to
the user ``nobody`` and every PostgreSQL program runs through ``runuser``.
Authentication is ``trust`` for the one local role ``tetmorph``, and the
server listens on 127.0.0.1 and a socket in its folder only.
"""

from __future__ import annotations

import glob
import os
import shutil
import subprocess
import time
from pathlib import Path

__all__ = ["LocalPostgres", "pg_bindir"]

#: The user PostgreSQL runs as when we are root.
PG_USER = "nobody"


def pg_bindir() -> Path:
    """The folder of ``initdb`` and ``pg_ctl``: Debian's newest ``/usr/lib/postgresql/N/bin``, else ``PATH``.

    Raises
    ------
    RuntimeError
        PostgreSQL's server programs are not installed (``make clusterdeps`` installs them).
    """
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"), key=lambda p: int(Path(p).parts[-3]))
    if found:
        return Path(found[-1]).parent
    initdb = shutil.which("initdb")
    if initdb:
        return Path(initdb).resolve().parent
    raise RuntimeError("PostgreSQL's server programs (initdb, pg_ctl) are not installed: run `make clusterdeps` "
                       "(apt-get install postgresql)")


class LocalPostgres:
    """One PostgreSQL server in ``folder``.

    Parameters
    ----------
    folder : path
        Holds ``pgdata/``, the socket and ``postgres.log``; created. Its
        parents must be traversable by ``nobody`` when run as root (``/tmp``).
    port : int
    fast : bool
        ``fsync=off`` (tests: nothing survives the machine anyway).
    """

    def __init__(self, folder: str | os.PathLike[str], port: int, fast: bool = False) -> None:
        self.folder = Path(folder)
        self.port = port
        self.fast = fast
        self.data = self.folder / "pgdata"
        self.log = self.folder / "postgres.log"
        self.bindir = pg_bindir()

    @property
    def url(self) -> str:
        """The database URL for ``TETMORPH_DATABASE_URL``."""
        return f"postgresql://tetmorph@127.0.0.1:{self.port}/tetmorph"

    def _as_user(self, args: list[str]) -> list[str]:
        return ["runuser", "-u", PG_USER, "--", *args] if os.geteuid() == 0 else args

    def _run(self, args: list[str], timeout: float = 120.0) -> None:
        r = subprocess.run(self._as_user(args), capture_output=True, text=True, timeout=timeout)
        if r.returncode != 0:
            raise RuntimeError(f"{' '.join(args[:2])} failed ({r.returncode}): {r.stdout[-2000:]} {r.stderr[-2000:]}")

    def start(self, timeout: float = 60.0) -> str:
        """Initdb (first time), start the server, create the database; the URL."""
        self.folder.mkdir(parents=True, exist_ok=True)
        if os.geteuid() == 0:
            shutil.chown(self.folder, PG_USER)
            os.chmod(self.folder, 0o700)
        if not (self.data / "PG_VERSION").is_file():
            self._run([str(self.bindir / "initdb"), "-D", str(self.data), "-U", "tetmorph", "-A", "trust",
                       "-E", "UTF8", "--no-sync"])
        opts = f"-c listen_addresses=127.0.0.1 -p {self.port} -k {self.folder} -c max_connections=200"
        if self.fast:
            opts += " -c fsync=off -c synchronous_commit=off -c full_page_writes=off"
        self._run([str(self.bindir / "pg_ctl"), "-D", str(self.data), "-l", str(self.log), "-w", "-t",
                   str(int(timeout)), "-o", opts, "start"], timeout=timeout + 10)
        self._create_database(timeout)
        return self.url

    def _create_database(self, timeout: float) -> None:
        import psycopg

        deadline = time.monotonic() + timeout
        while True:
            try:
                with psycopg.connect(f"postgresql://tetmorph@127.0.0.1:{self.port}/postgres", autocommit=True,
                                     connect_timeout=5) as c:
                    if not c.execute("SELECT 1 FROM pg_database WHERE datname = 'tetmorph'").fetchall():
                        c.execute("CREATE DATABASE tetmorph")
                return
            except psycopg.OperationalError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)

    def stop(self) -> None:
        """Stop the server (fast shutdown) if it runs."""
        if (self.data / "postmaster.pid").is_file():
            self._run([str(self.bindir / "pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop"])

    def remove(self) -> None:
        """Stop and delete the folder."""
        self.stop()
        shutil.rmtree(self.folder, ignore_errors=True)
