"""Defects of the editor's workflow found by a daily user (issue 43), each driven in a real browser
with the pointer, the keys and the file chooser as a person does.

Every test here failed on the editor before its fix (run against that build once).
"""

from __future__ import annotations

import time

import numpy as np

from tests.browser.conftest import bracket_session, settle


def find_arrow(pg, axis: str = "X") -> dict:
    """A page point over the gizmo's arrow of ``axis``, found by hovering as a person does."""
    c = pg.evaluate("window.tetmorph.pivotScreen()")
    tip = pg.evaluate("(a) => { const p = window.tetmorph.pivot().position; const d = window.tetmorph.mesh().diag;"
                      " const q = p.slice(); q['XYZ'.indexOf(a)] += 0.05 * d;"
                      " return window.tetmorph.worldToPage(q); }", axis)
    d = np.array([tip["x"] - c["x"], tip["y"] - c["y"]])
    d /= np.linalg.norm(d)
    for r in range(20, 200, 4):
        x, y = c["x"] + d[0] * r, c["y"] + d[1] * r
        pg.mouse.move(x, y)
        if pg.evaluate("window.tetmorph.gizmoAxis()") == axis:
            return {"x": x, "y": y, "dir": d}
    raise AssertionError(f"no {axis} arrow of the gizmo found on screen")


def test_a_gizmo_drag_with_the_box_tool_moves_the_handle_and_keeps_the_regions(page):
    bracket_session(page)
    before = {r["name"]: r["count"] for r in page.evaluate("window.tetmorph.regions()")}
    role = page.evaluate("window.tetmorph.role()")
    assert before["LOAD"] > 0 and before["FIXED"] > 0
    page.check("input[name=tool][value='box']")
    p = find_arrow(page, "X")
    x0 = page.evaluate("window.tetmorph.pivot().position[0]")
    page.mouse.down()
    for k in range(1, 13):  # along the arrow, 80 px
        page.mouse.move(p["x"] + p["dir"][0] * 80 * k / 12, p["y"] + p["dir"][1] * 80 * k / 12)
        time.sleep(0.02)
    page.mouse.up()
    settle(page)
    assert page.evaluate("window.tetmorph.pivot().position[0]") > x0 + 1  # the handle went along x
    after = {r["name"]: r["count"] for r in page.evaluate("window.tetmorph.regions()")}
    assert after == before and page.evaluate("window.tetmorph.role()") == role  # no region changed
    assert page.is_hidden("#boxsel")
    # Ctrl+Z takes the drag back, and the regions stay as they are
    page.mouse.move(5, 5)
    page.keyboard.press("Control+z")
    settle(page)
    assert abs(page.evaluate("window.tetmorph.pivot().position[0]") - x0) < 1e-6
    assert {r["name"]: r["count"] for r in page.evaluate("window.tetmorph.regions()")} == before
    # a box drawn off the gizmo still replaces the active region (here with nothing: an empty corner)
    box = page.eval_on_selector("#canvas", "c => { const r = c.getBoundingClientRect(); return [r.left, r.top]; }")
    page.mouse.move(box[0] + 5, box[1] + 5)
    page.mouse.down()
    page.mouse.move(box[0] + 40, box[1] + 40, steps=4)
    page.mouse.up()
    assert {r["name"]: r["count"] for r in page.evaluate("window.tetmorph.regions()")} == {**before, "LOAD": 0}
