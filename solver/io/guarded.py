"""Files that refuse to be read past their end over and over: meshio's readers always terminate.

Several meshio text readers look for a section's closing line with ``while True:
line = f.readline()`` and nothing else to stop them (Kratos ``.mdpa`` looking for
``End Nodes``, Tecplot ``.dat`` counting its data lines): on a file cut before that
line, ``readline()`` answers ``""`` at the end of the file forever, and the read
never returns. :func:`stop_at_end` makes every file meshio opens for reading in
this thread, while it is active, count the reads that find nothing more; past
:data:`MAX_END_READS` of them the read stops with
:class:`~solver.errors.UnreadableFileError` ``truncated_file`` naming the file.
A reader that ends at the end of its file reads there once or a few times, so
nothing else changes.

meshio opens its files with the built-in ``open`` (in :mod:`meshio._files` and in
some format modules); the name ``open`` of meshio's modules is bound to
:func:`guarded_open` once, which opens files as the built-in does unless a read
in the same thread is guarded and the file is opened for reading only.
"""

from __future__ import annotations

import builtins
import contextlib
import io
import os
import sys
import threading
from collections.abc import Iterator
from typing import Any

from ..errors import UnreadableFileError
from .formats import describe

__all__ = ["MAX_END_READS", "stop_at_end", "guarded_open", "PastEnd"]

#: Reads that may find the end of one file (nothing more to read) before the reader is stopped.
MAX_END_READS = 1000


class PastEnd(BaseException):
    """A guarded file was read at its end more than :data:`MAX_END_READS` times.

    A :class:`BaseException`, so that a reader's own ``except Exception`` cannot
    swallow it and read on; :func:`stop_at_end` turns it into the typed error.
    """

    def __init__(self, path: str, reads: int) -> None:
        super().__init__(path, reads)
        self.path = path
        self.reads = reads


_guard = threading.local()


class _Counting:
    """Counts the reads that come back empty; past the bound, raises :class:`PastEnd`."""

    _ends = 0

    def _seen(self, chunk: Any, size: int | None) -> Any:
        if not chunk and size != 0:
            self._ends += 1
            if self._ends > MAX_END_READS and getattr(_guard, "active", False):
                raise PastEnd(os.fsdecode(getattr(self, "name", "?")), self._ends)
        return chunk


class _GuardedBinary(_Counting, io.BufferedReader):
    """A buffered binary file (``open(path, "rb")``) that stops readers looping at its end."""

    def read(self, size: int | None = -1) -> bytes:
        return self._seen(super().read(size), size)  # type: ignore[no-any-return]

    def read1(self, size: int = -1) -> bytes:
        return self._seen(super().read1(size), size)  # type: ignore[no-any-return]

    def readline(self, size: int | None = -1) -> bytes:
        return self._seen(super().readline(size), size)  # type: ignore[no-any-return]


class _GuardedText(_Counting, io.TextIOWrapper):
    """A text file (``open(path)``) that stops readers looping at its end."""

    def read(self, size: int | None = -1) -> str:
        return self._seen(super().read(size), size)  # type: ignore[no-any-return]

    def readline(self, size: int = -1) -> str:  # type: ignore[override]  # text, where the base class reads bytes
        return self._seen(super().readline(size), size)  # type: ignore[no-any-return]


def guarded_open(file: Any, mode: str = "r", buffering: int = -1, encoding: str | None = None,
                 errors: str | None = None, newline: str | None = None, closefd: bool = True,
                 opener: Any = None) -> Any:
    """The built-in ``open``; a file opened for reading in a guarded thread counts its reads at the end.

    Parameters and the file returned are the built-in's (a buffered binary file or a text file);
    unbuffered files, file descriptors and every mode but reading are opened by the built-in.
    """
    if (not getattr(_guard, "active", False) or not isinstance(file, (str, bytes, os.PathLike))
            or set(mode) - set("rbt") or buffering == 0):
        return builtins.open(file, mode, buffering, encoding, errors, newline, closefd, opener)
    raw = io.FileIO(os.fspath(file), "r", closefd=closefd, opener=opener)  # named as the built-in names it
    try:
        binary = _GuardedBinary(raw, buffering if buffering > 1 else io.DEFAULT_BUFFER_SIZE)
        if "b" in mode:
            return binary
        text = _GuardedText(binary, encoding=encoding, errors=errors, newline=newline)
        text.mode = mode  # type: ignore[misc]  # as the built-in sets it
        return text
    except BaseException:
        raw.close()
        raise


def _install() -> None:
    """Bind ``open`` in every loaded meshio module to :func:`guarded_open` (once per module)."""
    for name, module in list(sys.modules.items()):
        if (name == "meshio" or name.startswith("meshio.")) and module is not None \
                and module.__dict__.get("open") is not guarded_open:
            module.open = guarded_open  # type: ignore[attr-defined]


@contextlib.contextmanager
def stop_at_end(fmt: str) -> Iterator[None]:
    """While meshio reads a file as ``fmt`` in this thread, stop a reader that keeps reading at the end of a file.

    Raises
    ------
    UnreadableFileError
        ``truncated_file`` (details ``file``, ``format``, ``reads``), from inside the reader.
    """
    _install()
    before = getattr(_guard, "active", False)
    _guard.active = True
    try:
        yield
    except PastEnd as e:
        name = os.path.basename(e.path)
        raise UnreadableFileError(
            f"{name!r} ends before its reader ({describe(fmt)}) found the end of a section: it read on at the end "
            f"of the file {e.reads:,} times. The file is truncated, or a section's closing line or declared count "
            "is missing or damaged", code="truncated_file", file=name, format=fmt, reads=e.reads) from None
    finally:
        _guard.active = before
