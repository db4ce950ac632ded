"""The displacement colouring of a morph inside a fixed skin (issue 43, defect 5): a cube with its six faces
fixed and an inner cylinder moved. The scale is the largest displacement of any node, and the section is
coloured by displacement when the displacement is the contour.

Failed before the fix: the legend read 0 (the scale was the boundary's largest) and the section was
coloured by quality.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.browser.conftest import numeric_move, positions, rest, set_session, settle
from tests.gmsh_parts import cube_with_core


def rainbow(t: float) -> list[float]:
    """The editor's colour map (meshview.js rainbow), blue to red."""
    x = min(1.0, max(0.0, t)) * 4
    k = min(3, int(np.floor(x)))
    f = x - k
    return [[0, f, 1], [0, 1, 1 - f], [f, 1, 0], [1, 1 - f, 0]][k]


def test_an_interior_morph_shows_in_the_legend_and_the_section(page, tmp_path):
    deck = tmp_path / "cube_core.inp"
    cube_with_core(deck)
    set_session(page, deck, "SKIN", "CORE")
    numeric_move(page, t=(0, 0, 3))
    settle(page)
    d = np.linalg.norm(positions(page) - rest(page), axis=1)
    boundary = np.array(page.evaluate("window.tetmorph.boundary()"), bool)
    assert d[boundary].max() < 1e-6 and d.max() == pytest.approx(3, rel=1e-3)  # all of it inside
    page.select_option("#color-by", "displacement")
    page.wait_for_selector("#legend [data-key=disp-max]")
    top = float(page.inner_text("#legend [data-key=disp-max]").replace(",", ""))
    assert top == pytest.approx(d.max(), rel=1e-3)  # the legend's scale is the interior's largest
    # a section through the core, coloured by displacement corner by corner on that scale
    page.check("#clip")
    page.wait_for_function("window.tetmorph.view().cut > 0")
    cut = page.evaluate("window.tetmorph.sectionColors()")
    T = np.array(page.evaluate("window.tetmorph.tets()")).reshape(-1, 4)
    tets, colours = np.array(cut["tets"]), np.array(cut["colors"])
    first = T[tets, 1]  # the first corner drawn of each tet (its face opposite corner 0)
    want = np.array([rainbow(x / d.max()) for x in d[first]])
    np.testing.assert_allclose(colours, want, atol=2e-3)
    assert (colours[:, 0] > 0.9).sum() > 5  # red: the core's tets, at the largest displacement
    assert (colours[:, 2] > 0.9).sum() > 5  # blue: the skin's
    # quality contour: the section goes back to its metric's colours
    page.select_option("#color-by", "quality")
    page.wait_for_function("window.tetmorph.sectionColors().colors.length > 0")
    again = np.array(page.evaluate("window.tetmorph.sectionColors()")["colors"])
    assert not np.allclose(again, colours, atol=1e-2)
