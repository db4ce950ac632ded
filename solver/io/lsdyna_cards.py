"""LS-DYNA keyword decks: keyword lines, and the walk through a deck and the files it includes.

A deck is a list of keywords, each a line that starts with ``*`` and its data
cards up to the next one. :class:`_Block` is one keyword of one file (its
name, the input format its cards are in, and the range of its cards in the
file's bytes); :func:`_walk` gives the blocks of a deck in reading order, the
blocks of an included file where its ``*INCLUDE`` is, acting on ``*KEYWORD``
(the input format: small, I10 or long), ``*INCLUDE`` and ``*END`` and
refusing ``*INCLUDE_TRANSFORM`` and ``*NODE_TRANSFORM``. The loaders find and
read the included files: from the deck's folder (:class:`_DiskLoader`), from
the bytes kept with a mesh (:class:`_TreeLoader`), or none (:class:`_Loader`,
a deck read alone). :func:`includes` lists a deck's included files.
"""

from __future__ import annotations

import os
import posixpath
import re
from collections.abc import Iterator
from dataclasses import dataclass

from ..errors import UnreadableFileError
from .read_bounds import ReadBounds, too_many

#: Deepest chain of ``*INCLUDE`` files followed (the deck itself is depth 0).
MAX_INCLUDE_DEPTH = 8

#: The input format a suffix after a keyword name asks for.
_SUFFIX_FORMAT = {b"+": "long", b"-": "small", b"%": "i10"}


# ----------------------------------------------------------------------------------------------------------------
# keywords and the walk through a deck and its includes


@dataclass
class _Block:
    """One keyword of a deck: its line, and the range of its data cards in its file's bytes."""

    name: str  # upper case, without the format suffix: "NODE", "ELEMENT_SOLID_ORTHO"
    fmt: str  # "small", "i10" or "long"
    file: str  # "" for the deck, else the included file's path relative to the deck's folder
    line: int  # 1-based line number of the keyword line
    data: bytes  # the whole file
    start: int  # offset of the first byte after the keyword line
    end: int  # offset of the next keyword line (or the end of the file)

    def lines(self, blank: bool = False) -> list[tuple[int, bytes]]:
        """The data cards as ``(line number, text without line end)``; comments skipped, blank lines on request."""
        out = []
        body = self.data[self.start:self.end]
        for k, text in enumerate(body.split(b"\n")):
            text = text.rstrip(b"\r")
            if text.startswith(b"$") or (not blank and not text.strip()):
                continue
            out.append((self.line + 1 + k, text))
        if blank and out and not out[-1][1] and body.endswith(b"\n"):
            out.pop()  # the empty string after the last line end
        return out


def _keyword_starts(data: bytes) -> list[int]:
    """Offsets of the lines that start with ``*`` (keyword lines)."""
    out = [0] if data.startswith(b"*") else []
    at = data.find(b"\n*")
    while at >= 0:
        out.append(at + 1)
        at = data.find(b"\n*", at + 2)
    return out


def _keyword(line: bytes) -> tuple[str, str | None, list[bytes]]:
    """A keyword line's name (upper case), the format its suffix asks for (or None), and its other words.

    Examples
    --------
    >>> _keyword(b"*node +")[:2], _keyword(b"*ELEMENT_SOLID%")[:2], _keyword(b"*KEYWORD LONG=Y")
    (('NODE', 'long'), ('ELEMENT_SOLID', 'i10'), ('KEYWORD', None, [b'LONG=Y']))
    """
    words = line[1:].split()
    if not words:
        return "", None, []
    token, rest = words[0], words[1:]
    suffix = None
    if token[-1:] in _SUFFIX_FORMAT:
        suffix, token = token[-1:], token[:-1]
    elif rest and rest[0] in _SUFFIX_FORMAT:
        suffix, rest = rest[0], rest[1:]
    name = token.decode("ascii", "replace").upper()
    return name, (_SUFFIX_FORMAT[suffix] if suffix else None), rest


def _keyword_format(words: list[bytes]) -> str | None:
    """The input format a ``*KEYWORD`` line sets (``LONG=Y``, ``I10=Y``, ``LONG=S``), or None."""
    fmt = None
    for w in words:
        key, _, value = w.upper().partition(b"=")
        if key == b"LONG" and value[:1] == b"Y":
            return "long"
        if key == b"LONG" and value[:1] == b"S":
            fmt = fmt or "small"
        if key == b"I10" and value[:1] == b"Y":
            fmt = "i10"
    return fmt


def _where(file: str, line: int) -> str:
    return f"line {line}" if not file else f"line {line} of {file!r}"


def _in(file: str) -> dict[str, str]:
    """The ``in`` detail of an error in an included file (its path relative to the deck's folder)."""
    return {"in": file} if file else {}


class _Loader:
    """Finds and reads the files a deck includes; the base refuses every ``*INCLUDE`` (a deck patched alone)."""

    def __init__(self, name: str, bounds: ReadBounds | None = None) -> None:
        self.name = name
        self.bounds = bounds or ReadBounds()
        self.order: list[str] = []
        self.total = 0

    def candidates(self, raw: str, file: str, line: int) -> list[str]:
        """The paths, relative to the deck's folder, an include name may mean; refuses names that leave the folder."""
        text = raw.strip().strip("\"'").replace("\\", "/")
        if not text:
            raise UnreadableFileError(f"{self.name!r}: the *INCLUDE at {_where(file, line)} names no file",
                                      code="bad_include", file=self.name, line=line, **_in(file))
        if text.startswith(("/", "~")) or re.match(r"^[A-Za-z]:", text):
            raise self._outside(raw, file, line, "an absolute path")
        out = []
        for base in ("", posixpath.dirname(file)):
            rel = posixpath.normpath(posixpath.join(base, text))
            if rel == ".." or rel.startswith("../"):
                raise self._outside(raw, file, line, "a path that climbs out of it")
            if rel not in out:
                out.append(rel)
        return out

    def _outside(self, raw: str, file: str, line: int, how: str) -> UnreadableFileError:
        return UnreadableFileError(
            f"{self.name!r}: the *INCLUDE at {_where(file, line)} names '{raw.strip()}', {how}; tetmorph follows "
            "includes inside the deck's folder only (upload the included files beside the deck, named relative "
            "to it)", code="include_outside", file=self.name, include=raw.strip(), line=line,
            **_in(file))

    def resolve(self, raw: str, file: str, line: int) -> str:
        """The path, relative to the deck's folder, of the file an ``*INCLUDE`` of ``file`` names."""
        raise ValueError(f"the deck includes {raw.strip()!r} ({_where(file, line)}); its included files are needed "
                         "to write it back")

    def read(self, rel: str) -> bytes:
        """The bytes of an included file (counted: each file once, all of them within the byte bound)."""
        raise NotImplementedError

    def _count(self, rel: str, size: int) -> None:
        if rel in self.order:
            raise UnreadableFileError(f"{self.name!r} includes {rel!r} twice (the second time from another "
                                      "*INCLUDE): its nodes would be defined twice", code="bad_include",
                                      file=self.name, include=rel)
        self.order.append(rel)
        self.total += size
        if self.total > self.bounds.expanded_bytes:
            raise too_many(self.name, "bytes", self.total, self.bounds, held=True)


class _DiskLoader(_Loader):
    """Includes read from the deck's folder."""

    def __init__(self, path: str, bounds: ReadBounds | None = None) -> None:
        super().__init__(os.path.basename(path), bounds)
        self.folder = os.path.dirname(os.path.abspath(path))
        self.real = os.path.realpath(self.folder)

    def _full(self, rel: str) -> str:
        return os.path.join(self.folder, *rel.split("/"))

    def resolve(self, raw: str, file: str, line: int) -> str:
        for rel in self.candidates(raw, file, line):
            full = self._full(rel)
            if os.path.isfile(full):
                if os.path.commonpath([os.path.realpath(full), self.real]) != self.real:
                    raise self._outside(raw, file, line, "a link that leads out of it")
                return rel
        raise UnreadableFileError(
            f"{self.name!r}: the file {raw.strip()!r} that the *INCLUDE at {_where(file, line)} names is not in the "
            "deck's folder; upload it beside the deck", code="include_missing", file=self.name, include=raw.strip(),
            line=line, **_in(file))

    def read(self, rel: str) -> bytes:
        full = self._full(rel)
        self._count(rel, os.path.getsize(full))
        with open(full, "rb") as fh:
            return fh.read()


class _TreeLoader(_Loader):
    """Includes given as bytes by relative path (what :func:`solver.io.read.read_mesh` kept)."""

    def __init__(self, included: dict[str, bytes]) -> None:
        super().__init__("the deck")
        self.included = included

    def resolve(self, raw: str, file: str, line: int) -> str:
        for rel in self.candidates(raw, file, line):
            if rel in self.included:
                return rel
        raise ValueError(f"the included file {raw.strip()!r} ({_where(file, line)}) was not kept with the mesh")

    def read(self, rel: str) -> bytes:
        self._count(rel, 0)
        return self.included[rel]


def _include_names(block: _Block) -> list[tuple[int, str]]:
    """The file names an ``*INCLUDE`` card names, with their line numbers (a name ending in `` +`` goes on)."""
    out: list[tuple[int, str]] = []
    pending: tuple[int, str] | None = None
    for line, text in block.lines():
        part = text.decode("utf-8", "replace").rstrip()
        if pending is not None:
            part = pending[1] + part.strip()
            line = pending[0]
            pending = None
        if part.endswith(" +"):
            pending = (line, part[:-2])
            continue
        out.append((line, part.strip()))
    if pending is not None:
        out.append(pending)
    return out


def _walk(data: bytes, loader: _Loader, file: str = "", fmt: str = "small", depth: int = 0,
          chain: tuple[str, ...] = ("",), forced: bool = False) -> Iterator[_Block]:
    """The keywords of a file in reading order, the included files' keywords where their ``*INCLUDE`` is.

    ``*KEYWORD``, ``*INCLUDE`` and ``*END`` are acted on, not yielded. ``fmt`` is the input format the file
    starts in (the including file's, or the one the ``*INCLUDE`` suffix asks for: ``forced``).
    """
    starts = _keyword_starts(data)
    line, last = 1, 0
    for k, s in enumerate(starts):
        line += data.count(b"\n", last, s)
        last = s
        eol = data.find(b"\n", s)
        eol = len(data) if eol < 0 else eol
        name, suffix, words = _keyword(data[s:eol].rstrip(b"\r"))
        block = _Block(name, suffix or fmt, file, line, data, min(eol + 1, len(data)),
                       starts[k + 1] if k + 1 < len(starts) else len(data))
        if name == "END":
            return
        if name == "KEYWORD" or name.startswith("KEYWORD_"):
            asked = _keyword_format(words)
            if asked is not None and (not file or not forced):
                fmt = asked
            continue
        if name == "INCLUDE":
            for at, raw in _include_names(block):
                if depth + 1 > MAX_INCLUDE_DEPTH:
                    raise UnreadableFileError(
                        f"{loader.name!r}: the *INCLUDE at {_where(file, at)} goes {depth + 1} files deep; tetmorph "
                        f"follows includes {MAX_INCLUDE_DEPTH} deep at most", code="bad_include",
                        file=loader.name, include=raw, line=at)
                rel, sub = _load(loader, raw, file, at, chain)
                yield from _walk(sub, loader, rel, suffix or fmt, depth + 1, (*chain, rel), suffix is not None)
            continue
        if name.startswith("INCLUDE_"):
            if name.startswith("INCLUDE_PATH"):
                continue
            code = "unsupported_coordinate_system" if "TRANSFORM" in name else "unsupported_keyword"
            raise UnreadableFileError(
                f"{loader.name!r}: *{name} at {_where(file, line)} is not followed: tetmorph reads files named by a "
                "plain *INCLUDE, whose node positions are the ones written" +
                (" (a transformed include places its nodes elsewhere)" if "TRANSFORM" in name else ""),
                code=code, file=loader.name, keyword=f"*{name}", line=line, **_in(file))
        if name == "NODE_TRANSFORM":
            raise UnreadableFileError(
                f"{loader.name!r}: *NODE_TRANSFORM at {_where(file, line)} moves nodes away from the positions their "
                "cards give; tetmorph reads positions as written. Apply the transformation to the *NODE cards first.",
                code="unsupported_coordinate_system", file=loader.name, keyword="*NODE_TRANSFORM", line=line,
                **_in(file))
        yield block


def _load(loader: _Loader, raw: str, file: str, line: int, chain: tuple[str, ...]) -> tuple[str, bytes]:
    """The path and bytes of the file an ``*INCLUDE`` names; refuses one already being read (a cycle)."""
    rel = loader.resolve(raw, file, line)
    if rel in chain:
        raise UnreadableFileError(
            f"{loader.name!r}: the *INCLUDE at {_where(file, line)} names {rel!r}, which is already being read "
            f"({' -> '.join(repr(c or loader.name) for c in chain)}): the includes form a cycle",
            code="bad_include", file=loader.name, include=rel, line=line, **_in(file))
    return rel, loader.read(rel)


def includes(path: str | os.PathLike[str]) -> list[str]:
    """The files a deck includes, relative to its folder, in reading order.

    Raises
    ------
    UnreadableFileError
        An include outside the deck's folder (``include_outside``), missing (``include_missing``), repeated,
        cyclic or nested deeper than :data:`MAX_INCLUDE_DEPTH` (``bad_include``).
    """
    path = os.fspath(path)
    with open(path, "rb") as fh:
        data = fh.read()
    loader = _DiskLoader(path)
    for _ in _walk(data, loader):
        pass
    return list(loader.order)
