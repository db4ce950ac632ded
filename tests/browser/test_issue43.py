"""Defects of the editor's workflow found by a daily user (issue 43), each driven in a real browser
with the pointer, the keys and the file chooser as a person does.

Every test here failed on the editor before its fix (run against that build once).
"""

from __future__ import annotations

import signal
import time

import httpx
import numpy as np
import pytest

from service.process import free_port, serve_process
from tests.browser.conftest import (
    VIEWPORT,
    bracket_session,
    canvas_box,
    confirm,
    differs,
    drag_pivot,
    image,
    load_bracket,
    numeric_move,
    positions,
    rest,
    settle,
)


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


def test_create_session_asks_before_it_replaces_a_moved_session(page):
    bracket_session(page)
    for z in (1, 2, 3):
        numeric_move(page, t=(0, 0, z))
        settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    moved = positions(page)
    history = page.evaluate("window.tetmorph.history()")
    assert len(history["entries"]) == 4
    page.click("#create")
    text = confirm(page, ok=False)
    assert sid in text and "3 moves" in text
    page.wait_for_timeout(500)
    # Cancel: the same session, open and streaming, with its moves, on the service and in the page
    assert page.evaluate("window.tetmorph.session().id") == sid
    assert page.evaluate("window.tetmorph.session().stream.open")
    assert page.evaluate("window.tetmorph.history()") == history
    np.testing.assert_array_equal(positions(page), moved)
    assert httpx.get(f"{page.base}/v1/sessions/{sid}").status_code == 200
    numeric_move(page, t=(0, 0, 4))  # and it still moves
    settle(page)
    assert httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]["handles"]["LOAD"]["translation"][2] == 4
    # OK: a new session at rest replaces it
    page.click("#create")
    confirm(page, ok=True)
    page.wait_for_function(f"window.tetmorph.session().id !== null && window.tetmorph.session().id !== '{sid}'"
                           " && window.tetmorph.session().stream && window.tetmorph.session().stream.open")
    np.testing.assert_array_equal(positions(page), rest(page))
    assert httpx.get(f"{page.base}/v1/sessions/{sid}").status_code == 404
    # a session not moved yet is replaced without a question
    new = page.evaluate("window.tetmorph.session().id")
    page.click("#create")
    page.wait_for_function(f"window.tetmorph.session().id !== null && window.tetmorph.session().id !== '{new}'"
                           " && window.tetmorph.session().stream && window.tetmorph.session().stream.open")
    assert page.is_hidden("#confirm-dialog")


def test_a_refused_typed_axis_goes_back_to_the_axes_in_use_and_says_why(page):
    bracket_session(page)
    page.click("#sec-csys summary")
    page.fill("#csys-origin", "100 10 5")
    page.fill("#csys-x", "0 1 0")
    page.fill("#csys-z", "1 0 0")
    page.click("#csys-set")
    assert page.is_checked("#local")
    in_use = page.evaluate("window.tetmorph.csys()")
    np.testing.assert_allclose(in_use, [[0, 1, 0], [0, 0, 1], [1, 0, 0]], atol=1e-12)
    fields = [page.input_value(f"#csys-{k}") for k in ("origin", "x", "z")]
    # a zero z typed, Enter: refused, said, and the field shows the z in use again
    page.fill("#csys-z", "0 0 0")
    page.press("#csys-z", "Enter")
    page.wait_for_selector("#errors:not([hidden])")
    said = page.inner_text("#error-text")
    assert "z axis is zero" in said and "z (0 0 0)" in said and "local axes in use stay" in said
    assert [page.input_value(f"#csys-{k}") for k in ("origin", "x", "z")] == fields
    assert page.evaluate("window.tetmorph.csys()") == in_use and page.is_checked("#local")
    # an x along z, with the button: the same
    page.fill("#csys-x", "2 0 0")
    page.click("#csys-set")
    page.wait_for_function("document.getElementById('error-text').textContent.includes('x (2 0 0)')")
    assert "along the z axis" in page.inner_text("#error-text")
    assert [page.input_value(f"#csys-{k}") for k in ("origin", "x", "z")] == fields
    assert page.evaluate("window.tetmorph.csys()") == in_use
    # and the moves still go in the axes in use: 3 along the local x is 3 along the global y
    for k, v in (("tx", 3), ("ty", 0), ("tz", 0)):
        page.fill(f"#{k}", str(v))
    page.click("#apply-move")
    settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    h = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]["handles"]["LOAD"]
    np.testing.assert_allclose(h["translation"], [0, 3, 0], atol=1e-9)


def box_all(pg) -> np.ndarray:
    """Box-select over the whole view (the fixed role, through the mesh): the vertex ids it selected."""
    b = canvas_box(pg)
    pg.mouse.move(b["x"] + 3, b["y"] + 3)
    pg.mouse.down()
    pg.mouse.move(b["x"] + b["w"] - 3, b["y"] + b["h"] - 3, steps=6)
    pg.mouse.up()
    return np.flatnonzero(np.array(pg.evaluate("window.tetmorph.role()")) == 1)


def test_the_section_plane_flips_to_keep_the_other_side(page):
    load_bracket(page)
    z = rest(page)[:, 2]
    cut = z.min() + 0.5 * (z.max() - z.min())
    boundary = np.array(page.evaluate("window.tetmorph.boundary()"), bool)
    page.check("#clip")  # z, half way
    page.wait_for_function("window.tetmorph.view().cut > 0")
    sections = page.evaluate("window.tetmorph.view().cut")
    page.check("input[name=tool][value='box']")
    page.check("input[name=role][value='1']")
    below = box_all(page)  # the box takes only what the section keeps
    assert len(below) and (z[below] <= cut + 1e-6).all()
    np.testing.assert_array_equal(below, np.flatnonzero(boundary & (z <= cut)))
    kept_below = page.locator("#canvas").screenshot()
    page.click("#clip-flip")
    assert page.get_attribute("#clip-flip", "aria-pressed") == "true"
    above = box_all(page)
    assert len(above) and (z[above] >= cut - 1e-6).all()
    np.testing.assert_array_equal(above, np.flatnonzero(boundary & (z >= cut)))
    assert page.evaluate("window.tetmorph.view().cut") == sections  # the same section, seen from the other side
    assert differs(kept_below, page.locator("#canvas").screenshot()) > 2000
    page.mouse.move(5, 5)
    page.keyboard.press("n")  # the key flips it back
    assert page.get_attribute("#clip-flip", "aria-pressed") == "false"
    np.testing.assert_array_equal(box_all(page), below)


SHELL_DECK = """*HEADING
a skin: a shell and a membrane
*NODE
1, 0., 0., 0.
2, 1., 0., 0.
3, 1., 1., 0.
4, 0., 1., 0.
5, 2., 0., 0.
6, 2., 1., 0.
*ELEMENT, TYPE=S4R, ELSET=SKIN
1, 1, 2, 3, 4
*ELEMENT, TYPE=M3D4, ELSET=SKIN
2, 2, 5, 6, 3
"""


def choose_file(pg, path) -> None:
    """Upload… and pick the file in the chooser, as a person does."""
    with pg.expect_file_chooser() as fc:
        pg.click("#upload-btn")
    fc.value.set_files(str(path))


def test_a_shell_deck_and_an_unknown_format_are_refused_in_words(page, tmp_path):
    deck = tmp_path / "skin.inp"
    deck.write_text(SHELL_DECK)
    step = tmp_path / "part.step"
    step.write_text("ISO-10303-21;\n")
    # REST: the codes stay, the words say what the deck has and what tetmorph needs
    r = httpx.post(f"{page.base}/v1/meshes", files={"file": (deck.name, deck.read_bytes())})
    e = r.json()["error"]
    assert r.status_code == 422 and e["code"] == "no_elements" and e["details"]["cells"] == {"S4R": 1, "M3D4": 1}
    for words in ("only shell/surface elements", "1 shell element (S4R), 1 membrane element (M3D4)",
                  "needs a volume mesh of tetrahedra (C3D4, C3D10)", "STL or OBJ and tetrahedralize"):
        assert words in e["message"], (words, e["message"])
    assert "{" not in e["message"] and "its cells" not in e["message"]
    r = httpx.post(f"{page.base}/v1/meshes", files={"file": (step.name, step.read_bytes())})
    e = r.json()["error"]
    assert r.status_code == 422 and e["code"] == "unknown_format"
    assert "surface is accepted too, as STL or OBJ" in e["message"] and "tetrahedralized" in e["message"]
    stored = httpx.get(f"{page.base}/v1/meshes").json()
    # the page: the same, through the file chooser
    choose_file(page, deck)
    page.wait_for_selector("#errors:not([hidden])")
    said = page.inner_text("#error-text")
    assert "not a volume mesh" in said and "only shell/surface elements" in said and "(S4R)" in said
    assert "tetrahedra" in said and "STL or OBJ" in said and "code no_elements" in said
    choose_file(page, step)
    page.wait_for_function("document.getElementById('error-text').textContent.includes('part.step')")
    said = page.inner_text("#error-text")
    assert "STL or OBJ" in said and "tetrahedralizes" in said and "code unknown_format" in said
    assert httpx.get(f"{page.base}/v1/meshes").json() == stored  # nothing was stored
    assert not page.evaluate("window.tetmorph.mesh().open")


def in_sight(pg, selector: str) -> bool:
    """The element is drawn, inside the window, and not covered: what a person sees without scrolling."""
    return pg.eval_on_selector(selector, """e => { const r = e.getBoundingClientRect();
        if (e.hidden || r.width < 2 || r.height < 2) return false;
        if (r.right > innerWidth || r.bottom > innerHeight || r.left < 0 || r.top < 0) return false;
        const hit = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
        return hit === e || e.contains(hit); }""")


def test_the_stream_status_is_in_the_top_bar_while_it_reconnects(browser, tmp_path):
    port, data = free_port(), tmp_path / "data"
    ctx = browser.new_context(viewport=VIEWPORT, bypass_csp=True)
    pg = ctx.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    try:
        with serve_process(data, port=port) as (base, proc):
            pg.goto(base + "/")
            pg.wait_for_function("window.tetmorph !== undefined")
            bracket_session(pg)
            numeric_move(pg, t=(0, 0, 5))
            settle(pg)
            assert pg.is_hidden("#stream-status")
            pg.click("#toggle-left")  # the tools panel out of the way, as while looking at the model
            assert pg.is_hidden("#session-status")
            sid = pg.evaluate("window.tetmorph.session().id")
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=30)
            pg.wait_for_function("/reconnecting/.test(document.getElementById('stream-status').textContent)",
                                 timeout=20000)
            assert in_sight(pg, "#stream-status")
            assert "stream lost" in pg.inner_text("#stream-status")
            drag_pivot(pg, 40, -30)  # a drag while it is down: queued, and the top bar says so
            pg.wait_for_function("/queued/.test(document.getElementById('stream-status').textContent)")
            assert in_sight(pg, "#stream-status")
        with serve_process(data, port=port) as (base, _proc):
            pg.wait_for_selector("#stream-status", state="hidden", timeout=90000)  # back: the notice goes
            settle(pg, timeout=90000)
            assert "reconnected" in pg.evaluate("document.getElementById('session-status').textContent")
            # a stream that ends for good says so in the top bar too
            assert httpx.delete(f"{base}/v1/sessions/{sid}").status_code == 204
            drag_pivot(pg, -30, 20)  # the service ends the stream on the next MOVE
            pg.wait_for_function("/closed/.test(document.getElementById('stream-status').textContent)",
                                 timeout=30000)
            assert in_sight(pg, "#stream-status")
    finally:
        ctx.close()
    assert not errors, errors


def save_png(pg, tmp_path, name: str) -> np.ndarray:
    """Click PNG and read the file the page gives, as RGB."""
    with pg.expect_download() as dl:
        pg.click("#png")
    path = tmp_path / name
    dl.value.save_as(path)
    return image(path.read_bytes())


def gizmo_pixels(img: np.ndarray, centre: tuple[int, int], r: int = 150) -> int:
    """Pixels near the gizmo in the pure red, green or blue of its arrows."""
    x, y = centre
    a = img[max(0, y - r):y + r, max(0, x - r):x + r]
    R, G, B = a[..., 0], a[..., 1], a[..., 2]
    pure = ((R > 200) & (G < 80) & (B < 80)) | ((G > 200) & (R < 80) & (B < 80)) | ((B > 200) & (R < 80) & (G < 80))
    return int(pure.sum())


def test_the_png_leaves_out_the_gizmo_and_has_the_legend(page, tmp_path):
    bracket_session(page)
    numeric_move(page, t=(0, 0, 5))
    settle(page)
    b = canvas_box(page)
    c = page.evaluate("window.tetmorph.pivotScreen()")
    centre = (int(c["x"] - b["x"]), int(c["y"] - b["y"]))
    on_screen = image(page.locator("#canvas").screenshot())
    assert gizmo_pixels(on_screen, centre) > 100  # the gizmo is drawn in the view
    png = save_png(page, tmp_path, "regions.png")
    assert list(png.shape[1::-1]) == page.eval_on_selector("#canvas", "c => [c.width, c.height]")
    assert gizmo_pixels(png, centre) < 5  # and not in the picture
    assert gizmo_pixels(image(page.locator("#canvas").screenshot()), centre) > 100  # still in the view after
    # the displacement colouring: the picture carries the scale, its values and the quantity's name
    page.select_option("#color-by", "displacement")
    page.wait_for_selector("#legend [data-key=disp-max]")
    png = save_png(page, tmp_path, "displacement.png")
    drawn = page.evaluate("window.tetmorph.pngLegend()")
    assert drawn["title"] == "displacement magnitude (mm)"
    top = float(drawn["ticks"][-1].replace(",", ""))
    assert top == pytest.approx(np.linalg.norm(positions(page) - rest(page), axis=1).max(), rel=1e-3)
    assert drawn["ticks"] == ["0", page.inner_text("#legend .ramp-ticks span:nth-child(2)"),
                              page.inner_text("#legend [data-key=disp-max]")]
    x, y, w, h = (int(round(drawn["box"][k])) for k in ("x", "y", "w", "h"))
    H, W = png.shape[:2]
    assert 0 < x and x + w <= W and 0 < y and y + h <= H  # in the lower right corner of the picture
    assert x > W / 2 and y > H / 2
    box = png[y:y + h, x:x + w]
    assert (box.max(axis=2) < 90).sum() > 150  # dark text: the name and the values
    sat = box.max(axis=2) - box.min(axis=2)  # the colour scale: the most saturated row, blue to red
    row = box[int(np.argmax((sat > 200).sum(axis=1)))]
    ramp = row[sat[int(np.argmax((sat > 200).sum(axis=1)))] > 200]
    assert len(ramp) > 120
    assert ramp[0, 2] > 200 and ramp[0, 0] < 60 and ramp[-1, 0] > 200 and ramp[-1, 2] < 60


def box_of(pg, selector: str) -> dict:
    return pg.eval_on_selector(selector, "e => { const r = e.getBoundingClientRect();"
                               " return {x: r.left, y: r.top, r: r.right, b: r.bottom, hidden: e.hidden}; }")


def overlap(a: dict, b: dict) -> bool:
    return a["x"] < b["r"] and b["x"] < a["r"] and a["y"] < b["b"] and b["y"] < a["b"]


def lab(rgb) -> np.ndarray:
    """CIELAB (D65) of an sRGB colour in 0..1."""
    c = np.asarray(rgb, float)
    c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]]) @ c
    f = np.cbrt(np.maximum(xyz / [0.95047, 1, 1.08883], 0.008856))
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def test_the_legend_keeps_clear_of_the_gizmo_label(page):
    bracket_session(page)
    stage = box_of(page, "#stage")
    for colour in ("regions", "displacement"):
        page.select_option("#color-by", colour)
        for t in ((0, 0, 0), (20, 0, -30), (0, 0, -10)):
            numeric_move(page, t=t)
            settle(page)
            page.wait_for_timeout(150)
            label, legend = box_of(page, "#gizmo-label"), box_of(page, "#legend")
            assert not label["hidden"] and not legend["hidden"]
            assert not overlap(label, legend), (colour, t, label, legend)
            assert stage["x"] <= legend["x"] and legend["r"] <= stage["r"]  # and in the view
            assert stage["y"] <= legend["y"] and legend["b"] <= stage["b"]


def test_fixed_regions_get_colours_told_apart(page):
    load_bracket(page)
    for _ in range(4):
        page.click("#add-fixed")
    for _ in range(2):
        page.click("#add-handle")
    regions = page.evaluate("window.tetmorph.regions()")
    fixed = [lab(r["color"]) for r in regions if r["kind"] == "fixed"]
    handles = [lab(r["color"]) for r in regions if r["kind"] == "handle"]
    assert len(fixed) == 4 and len(handles) == 2
    apart = min(np.linalg.norm(a - b) for k, a in enumerate(fixed) for b in fixed[k + 1:])
    assert apart >= 30, apart  # CIELAB units: about 2.3 is a just noticeable difference
    assert min(np.linalg.norm(a - b) for a in fixed for b in handles) >= 30
    for other in ("window.tetmorph.qualityColors.poor", "window.tetmorph.previewColor()"):  # poor tets, previews
        c = lab(page.evaluate(other))
        assert min(np.linalg.norm(a - c) for a in fixed + handles) >= 25, other
    # the legend's swatches wear them
    swatches = page.eval_on_selector_all("#legend [data-region] .sw", "els => els.map((e) => getComputedStyle(e)"
                                         ".backgroundColor)")
    assert len(swatches) == 6 and len(set(swatches)) == 6
