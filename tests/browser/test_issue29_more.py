"""Issue 29, the rest of it: the undo history kept with the session on the service, morph domains,
and the gizmo in local axes, each driven in a real browser against a real server.

Every test here failed on the editor before its change (run against that build once).
"""

from __future__ import annotations

import time

import httpx
import numpy as np

from tests.browser.conftest import bracket_session, positions, settle


def _service_history(base: str, sid: str) -> dict:
    r = httpx.get(f"{base}/v1/sessions/{sid}/history")
    assert r.status_code == 200, r.text
    return r.json()


def _tz(move: dict) -> float:
    """The z translation of the only handle of a MOVE the editor sent."""
    (h,) = move["handles"].values()
    return h["translation"][2]


def _wait_history(base: str, sid: str, applied: list[float], undone: list[float], timeout: float = 10) -> dict:
    """Wait until the service holds a history of these z translations (the editor saves it shortly after)."""
    deadline = time.monotonic() + timeout
    while True:
        doc = _service_history(base, sid)
        got = ([_tz(m) for m in doc["applied"]], [_tz(m) for m in doc["undone"]])
        if got == (applied, undone) or time.monotonic() > deadline:
            assert got == (applied, undone), doc
            return doc
        time.sleep(0.1)


def _open_from_sessions(pg, sid: str) -> None:
    pg.click("#sessions-btn")
    pg.click(f"#sessions-table tr[data-id={sid}] button[data-act=open]")
    pg.wait_for_function(f"window.tetmorph.session().id === '{sid}' && window.tetmorph.session().stream.open")


def _editor_history(pg) -> tuple[list, list]:
    """The MOVEs of the editor's history before and after the entry shown (entry 0, the rest, left out)."""
    h = pg.evaluate("window.tetmorph.history()")
    moves = [e["move"] for e in h["entries"]]
    return moves[1:h["index"] + 1], moves[h["index"] + 1:]


def test_the_undo_history_is_kept_with_the_session_on_the_service(pages, server):
    page = pages(server)
    bracket_session(page)
    sid = page.evaluate("window.tetmorph.session().id")
    shapes = []
    for tz in (2, 4, 6):
        page.fill("#tz", str(tz))
        page.keyboard.press("Enter")
        settle(page)
        shapes.append(positions(page))
    page.click("#undo")
    settle(page)
    # on the service, independently of the page: two applied, the third undone
    doc = _wait_history(server, sid, [2, 4], [6])

    page.reload()
    page.wait_for_function("window.tetmorph !== undefined")
    _open_from_sessions(page, sid)
    assert _editor_history(page) == (doc["applied"], doc["undone"])
    np.testing.assert_allclose(positions(page), shapes[1], atol=1e-4)
    page.click("#undo")
    settle(page)
    np.testing.assert_allclose(positions(page), shapes[0], atol=1e-5)
    doc = _wait_history(server, sid, [2], [4, 6])
    assert _editor_history(page) == (doc["applied"], doc["undone"])

    # another browser (nothing of the first one's storage) reopens it with the same history
    other = pages(server)
    _open_from_sessions(other, sid)
    assert _editor_history(other) == (doc["applied"], doc["undone"])
    other.keyboard.press("Control+Shift+Z")
    settle(other)
    np.testing.assert_allclose(positions(other), shapes[1], atol=1e-5)
    _wait_history(server, sid, [2, 4], [6])
