r"""JSON objects that name a key twice are refused, not read last-wins.

``json.loads('{"a": 1, "a": 2}')`` is ``{"a": 2}``; other parsers keep the first. A strict
document must mean one thing, so every JSON request body
(:func:`service.api.deps.refuse_duplicate_keys`, a dependency of every ``/v1`` route) and
every stream frame (:func:`loads`) with such an object is refused with 422
``duplicate_key``, naming the key and where it is (``handles.tip.translation``; list
items by their index, ``presets.1.move``). A key spelled with escapes
(``"\u0074ranslation"``) is the same key.

A body is parsed again only when it can hold a repeat: :func:`may_repeat_keys` scans its
text for object keys, and a body whose keys are all different and unescaped (a mesh's
arrays, say) is not parsed here at all.

Examples
--------
>>> duplicate_key('{"handles": {"tip": {"translation": [0, 0, 1], "translation": [0, 0, 2]}}}')
('translation', 'handles.tip.translation')
>>> duplicate_key('[{"a": 1}, {"a": 2}]') is None
True
"""

from __future__ import annotations

import json
import re
from typing import Any

from .errors import ServiceError

__all__ = ["duplicate_key", "duplicate_key_error", "may_repeat_keys", "loads"]

#: A JSON string, and the colon after it when it is an object's key.
_STRING = re.compile(rb'"([^"\\]*(?:\\.[^"\\]*)*)"(\s*:)?', re.S)


class _Repeated(Exception):
    """An object of the text names a key twice (:func:`duplicate_key` says which, and where)."""


def _object(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    doc = dict(pairs)
    if len(doc) < len(pairs):
        raise _Repeated
    return doc


class _Pairs(list):  # type: ignore[type-arg]
    """An object's (key, value) pairs in their order, repeats kept."""


def may_repeat_keys(text: bytes | str) -> bool:
    """False when no object of JSON ``text`` can name a key twice: all its keys differ, none escaped.

    Examples
    --------
    >>> may_repeat_keys(b'{"vertices": [[0, 0, 0]], "name": "a: b"}'), may_repeat_keys(b'[{"a": 1}, {"a": 2}]')
    (False, True)
    """
    raw = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else bytes(text)
    if json.detect_encoding(raw) != "utf-8":
        return True  # UTF-16 or UTF-32 text: the scan reads UTF-8 only
    seen: set[bytes] = set()
    for m in _STRING.finditer(raw):
        if m.group(2) is None:
            continue  # a string value
        key = m.group(1)
        if b"\\" in key or key in seen:
            return True
        seen.add(key)
    return False


def duplicate_key(text: bytes | str) -> tuple[str, str] | None:
    """(key, path) of the first key an object of JSON ``text`` names twice, in document order, else None.

    Text that is not JSON gives None: the parser of its route says what is wrong with it.
    """
    if not may_repeat_keys(text):
        return None
    try:
        json.loads(text, object_pairs_hook=_object)
        return None
    except _Repeated:
        return _locate(json.loads(text, object_pairs_hook=_Pairs))
    except (ValueError, RecursionError):
        return None


def _locate(doc: Any) -> tuple[str, str] | None:
    """The first repeated key of a document parsed into :class:`_Pairs`, with its path."""
    stack: list[tuple[Any, tuple[str, ...]]] = [(doc, ())]
    while stack:
        x, at = stack.pop()
        if isinstance(x, _Pairs):
            seen: set[str] = set()
            for k, _ in x:
                if k in seen:
                    return k, ".".join((*at, k))
                seen.add(k)
            stack.extend((v, (*at, k)) for k, v in reversed(x) if isinstance(v, list))
        elif isinstance(x, list):
            stack.extend((v, (*at, str(i))) for i, v in reversed(list(enumerate(x))) if isinstance(v, list))
    return None


def duplicate_key_error(key: str, path: str, what: str = "request") -> ServiceError:
    """The 422 ``duplicate_key`` error of a key named twice at ``path`` of a request body (or a frame)."""
    return ServiceError("duplicate_key", f"invalid {what}: the key {key!r} appears twice in one object, at {path}; "
                        "each key of a document may appear once", key=key, field=path)


def loads(text: str, what: str = "frame") -> Any:
    """``json.loads`` that raises 422 ``duplicate_key`` for an object naming a key twice (stream frames).

    Raises
    ------
    ServiceError
        ``duplicate_key``, with the key and its path.
    ValueError, RecursionError
        Not JSON, as ``json.loads``.
    """
    try:
        return json.loads(text, object_pairs_hook=_object)
    except _Repeated:
        found = _locate(json.loads(text, object_pairs_hook=_Pairs))
        assert found is not None
        raise duplicate_key_error(*found, what) from None
