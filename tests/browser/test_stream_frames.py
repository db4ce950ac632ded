"""Boundary-first frames: the editor draws the boundary at the next paint, unless the full frame is in first."""

from __future__ import annotations

import numpy as np

from solver import precompute, read_mesh

from .conftest import BRACKET, bracket_session, numeric_move, positions, settle


def test_the_boundary_frame_is_drawn_first_then_the_full_frame(page):
    bracket_session(page)
    numeric_move(page, t=(0, 0, 2.0))
    settle(page)
    st = page.evaluate("(() => { const s = window.tetmorph.session(), v = window.tetmorph.view(); "
                       "return {received: s.boundaryReceived, drawn: v.boundaryFrames, skipped: s.boundarySkipped, "
                       "full: v.frames}; })()")
    assert st["received"] >= 1 and st["full"] >= 1  # both kinds arrived
    assert st["drawn"] + st["skipped"] == st["received"]  # each boundary frame painted, or overtaken by its full frame
    mesh = read_mesh(BRACKET)
    d = precompute(mesh, {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}},
                          "fixed": ["FIXED"], "handles": {"LOAD": "LOAD"}})
    expected = d.solve({"handles": {"LOAD": {"translation": [0, 0, 2.0]}}}).V
    np.testing.assert_allclose(positions(page), expected, atol=1e-4)  # the float32 frame of the full solve
