"""The symmetry panels offer what the mesh has: its mirror planes and the deck's cyclic sector
(GET /v1/meshes/{id}/symmetry, as ``tetmorph info`` lists them), each drawn while the pointer is on
it and added with one click, driven in a real browser against a real server.

Both tests failed on the editor before the offers were added (run against that build once: no
``#sym-offers`` / ``#cyc-offers`` item ever appeared).
"""

from __future__ import annotations

import json

import httpx
import meshio
import numpy as np
from scipy.spatial import cKDTree

from tests.browser.conftest import (
    BRACKET,
    assign_set,
    create,
    differs,
    load_bracket,
    shared_file,
    upload,
)


def _canvas(pg) -> bytes:
    return pg.locator("#canvas").screenshot()


def _away(pg) -> None:
    """The pointer off the panel and the model, so that nothing is previewed."""
    pg.mouse.move(2, 2)


def test_a_suggested_mirror_plane_is_drawn_on_hover_and_added_with_a_click(page):
    load_bracket(page)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    page.click("#sec-symmetry summary")
    page.wait_for_selector("#sym-offers li button")
    offers = page.locator("#sym-offers li")
    assert offers.count() == 2  # the bracket is symmetric about y = 10 and z = 5, not along x
    assert page.locator("#cyc-offers li").count() == 0 and page.is_hidden("#cyc-offers-hint")  # no *TIE
    y = page.locator("#sym-offers li", has_text="n (0, 1, 0)")
    assert y.count() == 1
    _away(page)
    before = _canvas(page)
    y.hover()
    assert differs(before, _canvas(page)) > 2000  # the plane is drawn while the pointer is on it
    _away(page)
    assert differs(before, _canvas(page)) < 50  # and gone when it leaves
    assert "symmetry" not in page.evaluate("window.tetmorph.spec()")
    y.locator("button").click()
    assert page.locator("#sym-list li").count() == 1
    create(page)
    sid = page.evaluate("window.tetmorph.session().id")
    (entry,) = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["spec"]["symmetry"]
    P = np.asarray(meshio.read(BRACKET).points, float)
    np.testing.assert_allclose(entry["plane"]["point"], (P.min(0) + P.max(0)) / 2, atol=1e-9)
    assert entry["plane"]["normal"] == [0, 1, 0]
    assert 0 < entry["tolerance"] < 0.01 * np.linalg.norm(P.max(0) - P.min(0))  # the gap the service found
    assert set(entry) == {"name", "plane", "tolerance"}  # a SPEC entry: no matched / exact_pairs
    # once added, the offer says so and is not added twice
    assert y.locator("button").is_disabled()


def test_the_deck_s_cyclic_tie_is_offered_and_added_with_a_click(page):
    deck = shared_file("tet/segmenttet.inp")  # *TIE, CYCLIC SYMMETRY of left, right; N=12 about x
    upload(page, deck)
    a = np.radians(15)  # face A held, the rim half way round the sector lifted (typed as a SPEC)
    held = {"selections": {"Nright": {"set": "Nright"}, "rim": {"sphere": {
        "center": [0.05, 0.975 * np.cos(a), 0.975 * np.sin(a)], "radius": 0.1}}}, "fixed": ["Nright"],
        "handles": {"rim": "rim"}}
    page.click("#spec-view")
    page.fill("#spec-text", json.dumps(held))
    page.click("#spec-apply")
    page.click("#spec-close")
    page.click("#sec-symmetry summary")
    page.wait_for_selector("#cyc-offers li button")
    offer = page.locator("#cyc-offers li")
    assert offer.count() == 1 and "T1" in offer.inner_text()
    _away(page)
    before = _canvas(page)
    offer.hover()
    assert differs(before, _canvas(page)) > 30  # the sector's axis is drawn while the pointer is on it
    _away(page)
    offer.locator("button").click()
    assert page.locator("#cyc-list li").count() == 1
    assert page.input_value("#cyc-angle") != ""  # the panel's fields show what was added
    create(page)
    sid = page.evaluate("window.tetmorph.session().id")
    stored = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["spec"]
    (c,) = stored["cyclic"]
    # what the deck says: N=12 about the x axis through the origin, the tie's surfaces left and right
    # (Abaqus names the slave first: face A is the master, Nright)
    assert c["faces"] == ["Nright", "Nleft"] and c["tolerance"] == 0.001 and abs(c["angle_deg"]) == 30
    np.testing.assert_allclose(c["axis"]["point"], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(c["axis"]["direction"], [1, 0, 0], atol=1e-12)
    assert stored["selections"]["Nright"] == {"set": "Nright"} and stored["selections"]["Nleft"] == {"set": "Nleft"}
    # the sign turns face A onto face B
    m = meshio.read(deck)
    A, B = m.points[m.point_sets["Nright"]], m.points[m.point_sets["Nleft"]]

    def gap(deg: float) -> float:
        a = np.radians(deg)
        R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        return float(np.median(cKDTree(B).query(A @ R.T)[0]))

    assert gap(c["angle_deg"]) < 0.1 * gap(-c["angle_deg"])
