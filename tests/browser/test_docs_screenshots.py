"""The editor tutorial's pictures (docs/tutorials/editor.md), taken while its steps are done for real.

One test walks the page's steps on the CalculiX bracket in chromium against a real ``tetmorph
serve``: open the editor, upload the deck, make regions of its named sets, create a session, drag
the gizmo, type a translation, read the REPORT, undo and redo, download the deck. Each step is
checked from the page's arrays, the service or the downloaded file, and its picture is taken
(a 256-colour PNG, under 150 KB). The pictures go to the test's own folder, so a test run leaves
the tree as it was; ``make docs-pictures`` (``pytest --docs-pictures``) writes them to
``docs/img/editor/``, the docs' own pictures, committed.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
from PIL import Image

from solver import precompute, read_mesh
from tests.browser.conftest import (
    DATA,
    ROOT,
    assign_set,
    create,
    drag_pivot,
    numeric_move,
    positions,
    report_row,
    rest,
    settle,
    upload,
)

DECK = DATA / "ccx_bracket.inp"
IMG = ROOT / "docs" / "img" / "editor"
PAGE = ROOT / "docs" / "tutorials" / "editor.md"
VIEW = {"width": 1200, "height": 700}
MAX_BYTES = 150_000
#: The first tutorial's SPEC and MOVE (docs/tutorials/morph-a-deck.md), as the editor names the regions.
SPEC = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}, "HOLE": {"set": "HOLE"}},
        "fixed": ["FIXED", "LOAD"], "handles": {"HOLE": "HOLE"}}
TYPED = (-4.0, 0.0, 0.0)
#: A node line of the deck: ``id, x, y, z``.
NODE_LINE = re.compile(r"^\s*\d+\s*,\s*[-+0-9.eE]+\s*,\s*[-+0-9.eE]+\s*,\s*[-+0-9.eE]+\s*$")


def picture(pg, folder: Path, name: str, selector: str | None = None) -> Path:
    """Screenshot the page (or one element of it) into FOLDER/NAME.png, as 256 colours."""
    png = pg.locator(selector).screenshot() if selector else pg.screenshot()
    out = folder / f"{name}.png"
    folder.mkdir(parents=True, exist_ok=True)
    Image.open(io.BytesIO(png)).convert("RGB").quantize(colors=256).save(out, optimize=True)
    assert out.stat().st_size < MAX_BYTES, (out, out.stat().st_size)
    return out


def node_block(text: str) -> tuple[list[str], dict[int, np.ndarray], dict[int, str]]:
    """The deck's lines with the coordinates of ``*NODE`` lines blanked out; those coordinates and lines by id."""
    lines, coords, raw, in_node = [], {}, {}, False
    for ln in text.splitlines():
        if ln.startswith("*"):
            in_node = ln.split(",")[0].strip().upper() == "*NODE"  # not *NODE PRINT, *NODE FILE
            lines.append(ln)
        elif in_node and NODE_LINE.match(ln):
            nid, *xyz = ln.split(",")
            coords[int(nid)] = np.array([float(v) for v in xyz])
            raw[int(nid)] = ln
            lines.append(f"{int(nid)}, <x>, <y>, <z>")
        else:
            lines.append(ln)
    return lines, coords, raw


def test_the_editor_tutorial_step_by_step(pages, server, tmp_path, request):
    deck = read_mesh(DECK)
    library = precompute(deck, SPEC).solve({"handles": {"HOLE": {"translation": list(TYPED)}}}).V
    pg = pages(server, viewport=VIEW)
    pg.set_default_timeout(30_000)  # every wait is bounded: 30 s, the upload and the build 60 s
    folder = IMG if request.config.getoption("docs_pictures") else tmp_path / "pictures"

    # 1. the editor opened: the first page says what to do
    assert pg.is_visible("#welcome")
    picture(pg, folder, "1-open")

    # 2. the deck uploaded: counts in the header, its named sets offered
    upload(pg, DECK)
    assert pg.is_hidden("#welcome")
    offered = pg.eval_on_selector_all("#sets option", "os => os.map((o) => o.value).filter(Boolean)")
    assert {"FIXED", "LOAD", "HOLE"} <= set(offered)
    np.testing.assert_allclose(rest(pg), deck.V, atol=1e-9)
    picture(pg, folder, "2-uploaded")

    # 3. regions from the deck's named sets: FIXED and LOAD fixed, HOLE the handle; a session
    assign_set(pg, "FIXED", 1)
    assign_set(pg, "LOAD", 1)
    assign_set(pg, "HOLE", 2)
    role = np.array(pg.evaluate("window.tetmorph.role()"))
    fixed = np.union1d(deck.sets["FIXED"], deck.sets["LOAD"])
    assert (role[fixed] == 1).all() and (role[deck.sets["HOLE"]] == 2).all()
    assert (role == 1).sum() == fixed.size and (role == 2).sum() == deck.sets["HOLE"].size
    create(pg, "warn")
    sid = pg.evaluate("window.tetmorph.session().id")
    picture(pg, folder, "3-regions")

    # 4. the gizmo dragged with the mouse: the bore moves, the fixed sets stay
    drag_pivot(pg, -40, 0, steps=15)
    settle(pg)
    dragged = positions(pg)
    shift = dragged - rest(pg)
    assert np.abs(shift[deck.sets["HOLE"]]).max() > 1.0
    assert np.abs(shift[fixed]).max() < 1e-9
    picture(pg, folder, "4-drag")

    # 5. a typed translation, coloured by displacement; the REPORT
    numeric_move(pg, t=TYPED)
    settle(pg)
    typed = positions(pg)
    np.testing.assert_allclose(typed[deck.sets["HOLE"]] - deck.V[deck.sets["HOLE"]],
                               np.tile(TYPED, (deck.sets["HOLE"].size, 1)), atol=1e-5)  # float32 frames
    np.testing.assert_allclose(typed, library, atol=1e-4)
    pg.select_option("#color-by", "displacement")
    pg.wait_for_selector("#legend [data-key=disp-max]")
    largest = float(np.linalg.norm(library - deck.V, axis=1).max())  # a free node near the bore: a little over 4
    shown = report_row(pg, "max_displacement")
    assert shown is not None and abs(float(re.sub(r"[^\d.]", "", shown)) - largest) < 0.01, shown
    assert report_row(pg, "inverted_elements") == "0"
    assert f"**max displacement** {largest:.2f} mm" in PAGE.read_text()  # what the tutorial says it shows
    picture(pg, folder, "5-typed")
    picture(pg, folder, "5-report", "#right section:first-child")

    # 6. undo: back to the dragged shape; redo: the typed one again
    pg.click("#undo")
    settle(pg)
    np.testing.assert_allclose(positions(pg), dragged, atol=1e-5)
    picture(pg, folder, "6-undo")
    pg.click("#redo")
    settle(pg)
    np.testing.assert_allclose(positions(pg), typed, atol=1e-5)

    # 7. download in the deck's own format: only the coordinates of nodes that moved change
    assert ".inp" in pg.inner_text("#format option[value='']")
    with pg.expect_download() as dl:
        pg.click("#download")
    name = dl.value.suggested_filename
    assert name.endswith(".inp"), name
    path = tmp_path / name
    dl.value.save_as(path)
    got_lines, got, got_raw = node_block(path.read_text())
    want_lines, at_rest, rest_raw = node_block(DECK.read_text())
    assert got_lines == want_lines  # every line but the node coordinates is the deck's own
    assert got.keys() == at_rest.keys()
    ids = list(at_rest)  # file order, the order of the mesh's vertices
    X = np.array([got[i] for i in ids])
    X0 = np.array([at_rest[i] for i in ids])
    np.testing.assert_allclose(X, library, atol=1e-6)
    assert all(got_raw[ids[i]] == rest_raw[ids[i]] for i in fixed)  # the fixed nodes' lines, character for character
    assert np.abs(X - X0).max() > 3.9  # and the bore's did change
    picture(pg, folder, "7-download", "#sec-download")
    assert sid == pg.evaluate("window.tetmorph.session().id")
