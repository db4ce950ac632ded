"""Pagination of listings: ``limit`` and an opaque ``cursor``; the next cursor rides in headers.

A listing answers a JSON array (oldest first). When more items follow, the
response has ``X-Next-Cursor: CURSOR`` and ``Link: <URL?cursor=CURSOR>; rel="next"``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Annotated, TypeVar

from fastapi import Query, Request, Response

from solver.documents.text import ONE_LINE

from ..errors import ServiceError

__all__ = ["LimitQuery", "CursorQuery", "NameQuery", "page", "PAGE_HEADERS"]

T = TypeVar("T")

LimitQuery = Annotated[int, Query(ge=1, le=1000, description="most items in this page")]
CursorQuery = Annotated[str | None, Query(max_length=64, pattern=r"^[0-9]+-[A-Za-z0-9_-]*$",
                                          json_schema_extra=ONE_LINE,
                                          description="X-Next-Cursor of the previous page")]
NameQuery = Annotated[str | None, Query(max_length=200, description="only items whose name contains this")]

#: OpenAPI description of the paging headers.
PAGE_HEADERS = {
    "X-Next-Cursor": {"description": "cursor of the next page; absent on the last page",
                      "schema": {"type": "string"}},
    "Link": {"description": "RFC 8288 link to the next page (rel=\"next\")", "schema": {"type": "string"}},
}


def _cursor(created: float, ident: str) -> str:
    return f"{int(round(created * 1e6))}-{ident}"


def page(items: Sequence[T], order: Callable[[T], tuple[float, str]], limit: int, cursor: str | None,
         request: Request, response: Response) -> list[T]:
    """The page of ``items`` (sorted by ``order``: creation time, id) after ``cursor``.

    Sets the next-page headers when more items follow. A cursor stays valid
    when its item has been deleted since.

    Raises
    ------
    ServiceError
        422 ``invalid_request`` for a cursor this service did not issue.
    """
    rows = sorted(items, key=order)
    if cursor is not None:
        stamp, sep, ident = cursor.partition("-")
        if not sep or not stamp.isdigit():
            raise ServiceError("invalid_request", f"cursor {cursor!r} is not one this service issued",
                               field="cursor")
        after = (int(stamp), ident)
        rows = [x for x in rows if (int(round(order(x)[0] * 1e6)), order(x)[1]) > after]
    out = rows[:limit]
    if len(rows) > limit:
        nxt = _cursor(*order(out[-1]))
        response.headers["X-Next-Cursor"] = nxt
        response.headers["Link"] = f'<{request.url.include_query_params(cursor=nxt)}>; rel="next"'
    return out
