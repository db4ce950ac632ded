"""Picking reads out the deck's own node number beside the 0-based vertex id, in a real browser.

The test failed on the editor before the numbers were shown (run against that build once: the
read-out said "vertex 5 · (100, 0, 10) mm" only).
"""

from __future__ import annotations

import numpy as np

from solver import read_mesh
from tests.browser.conftest import BRACKET, DATA, upload
from tests.decks import renumbered


def _hover_and_pick(pg, i: int) -> str:
    p = pg.evaluate("(i) => window.tetmorph.screenOf(i)", int(i))
    pg.mouse.move(p["x"], p["y"])
    pg.wait_for_selector("#pick-tip:not([hidden])")
    tip = pg.inner_text("#pick-tip")
    pg.mouse.click(p["x"], p["y"])
    return tip


def test_a_picked_node_shows_the_deck_s_number(page, tmp_path):
    deck = renumbered(BRACKET, tmp_path / "gaps.inp", lambda n: 10 * n + 7)  # numbers with gaps: 17, 27, ...
    upload(page, deck)
    mesh = read_mesh(BRACKET)
    load = mesh.sets["LOAD"]  # the x = 100 end face, facing the camera of the first view
    i = int(load[np.argmin(mesh.V[load, 1] + mesh.V[load, 2])])
    page.check("input[name=tool][value='pick']")
    tip = _hover_and_pick(page, i)
    assert tip.startswith(f"vertex {i} (node {10 * (i + 1) + 7}) ")  # the deck's *NODE line i+1
    assert f"vertex {i} (node {10 * (i + 1) + 7})" in page.inner_text("#measure [data-key=node0]")


def test_a_file_without_node_numbers_shows_the_vertex_id_only(page):
    upload(page, DATA / "beam.node", DATA / "beam.ele")
    page.check("input[name=tool][value='pick']")
    i = int(np.argmax(page.evaluate("window.tetmorph.boundary()")))
    tip = _hover_and_pick(page, i)
    assert tip.startswith("vertex ") and "(node" not in tip
