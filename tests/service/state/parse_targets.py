"""Functions the parse-pool tests run in its workers (importable by a spawned process)."""

from __future__ import annotations

import os
import time


def echo(x):
    return x, os.getpid()


def sleep(seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


def spin(seconds: float) -> int:
    """Burn CPU (a reader looping on a damaged file)."""
    end = time.monotonic() + seconds
    k = 0
    while time.monotonic() < end:
        k += 1
    return k


def hog(mb: int) -> int:
    """Allocate and touch ``mb`` MiB (a decompression bomb)."""
    block = bytearray(mb * 2**20)
    block[::4096] = b"\x01" * len(block[::4096])
    return len(block)


def refuse() -> None:
    from solver.errors import UnreadableFileError

    raise UnreadableFileError("'x.vtu' is truncated", code="truncated_file", file="x.vtu")


def crash() -> None:
    raise KeyError("np.int64(262)")


_KEPT: list[bytearray] = []


def keep(mb: int) -> int:
    """Allocate, touch and keep ``mb`` MiB (what a large read leaves behind)."""
    block = bytearray(mb * 2**20)
    block[::4096] = b"\x01" * len(block[::4096])
    _KEPT.append(block)
    return len(block)
