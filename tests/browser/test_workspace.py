"""A workspace per mesh (issue 43): the address names the mesh and session, the regions, presets,
shapes, DOE plan and labelled history belong to their mesh and session on the service, and regions
changed after Create session are marked with one action to rebuild. Also the REPORT's MOVE counter,
which starts again with each session.

Each test drives the page as a person does (keys, pointer, the file chooser, F5) and reads what it
checks back from the service with its own requests. Every test here failed on the editor before
the workspace was added (run against that build once).
"""

from __future__ import annotations

import time
from urllib.parse import urlparse

import httpx
import numpy as np

from tests.browser.conftest import (
    BRACKET,
    DATA,
    bracket_session,
    create,
    drag,
    numeric_move,
    positions,
    report_row,
    settle,
    upload,
)

PLAN = "lift\n0.5\n1.5\n"


def wait_for(fn, what: str, timeout: float = 15.0):
    """Poll ``fn`` until it answers something true; fail naming ``what``."""
    deadline = time.monotonic() + timeout
    while True:
        got = fn()
        if got:
            return got
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.1)


# one tetrahedron: a mesh that is quick to store, to fill the service past one page of its listing
ONE_TET = b"*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n*ELEMENT, TYPE=C3D4, ELSET=E\n1, 1, 2, 3, 4\n"
PAGE = 100  # the service's default page of GET /v1/meshes


def stored_meshes(base: str) -> list[dict]:
    """Every mesh the service lists, oldest first, read page by page with the test's own requests."""
    out: list[dict] = []
    params: dict = {"limit": 1000}
    with httpx.Client(base_url=base) as c:
        for _ in range(100):
            r = c.get("/v1/meshes", params=params)
            assert r.status_code == 200, r.text
            out += r.json()
            if "X-Next-Cursor" not in r.headers:
                return out
            params["cursor"] = r.headers["X-Next-Cursor"]
    raise AssertionError("GET /v1/meshes gave more than 100 pages")


def more_than_a_page(base: str) -> None:
    """Store one-tetrahedron meshes until the service holds more meshes than its listing's default page."""
    n = len(stored_meshes(base))
    with httpx.Client(base_url=base, timeout=60) as c:
        for k in range(max(0, PAGE + 1 - n)):
            r = c.post("/v1/meshes", files={"file": (f"tet{k}.inp", ONE_TET)})
            assert r.status_code == 201, r.text


def workspace(base: str, of: str, ident: str) -> dict:
    r = httpx.get(f"{base}/v1/{of}/{ident}/workspace")
    assert r.status_code == 200, r.text
    return r.json()


def regions(pg) -> dict:
    return {r["name"]: (r["kind"], r["count"]) for r in pg.evaluate("window.tetmorph.regions()")}


def history(pg) -> dict:
    return pg.evaluate("window.tetmorph.history()")


def session_open(pg, sid: str, timeout: float = 60000) -> None:
    pg.wait_for_function("(sid) => { const s = window.tetmorph.session(); return s.id === sid && s.stream"
                         " && s.stream.open; }", arg=sid, timeout=timeout)


def address(pg) -> dict:
    frag = urlparse(pg.url).fragment
    return dict(p.split("=", 1) for p in frag.split("&") if p)


def save_preset(pg, name: str) -> None:
    n = len(pg.evaluate("window.tetmorph.session().presets"))
    pg.fill("#preset-name", name)
    pg.click("#preset-save")
    pg.wait_for_function(f"window.tetmorph.session().presets.length === {n + 1}")


def make_workspace(pg) -> dict:
    """Regions, a session, labelled moves (typed, a preset applied, a shape slider, one undone), a DOE plan.

    Answers what the page shows, once the service holds it (read back with the test's own requests).
    """
    bracket_session(pg)
    sid = pg.evaluate("window.tetmorph.session().id")
    numeric_move(pg, t=(0, 0, 2))
    settle(pg)
    save_preset(pg, "lift")
    numeric_move(pg, t=(0, 0, 4))
    settle(pg)
    pg.click("#presets li:has-text('lift') button[data-act=apply]")
    settle(pg)
    pg.focus("#shapes input[data-shape=lift]")
    pg.keyboard.press("ArrowRight")  # the slider to 0.05: a MOVE, kept in the history as "shapes lift 0.05"
    settle(pg)
    numeric_move(pg, t=(0, 0, 3))
    settle(pg)
    pg.click("#undo")
    settle(pg)
    pg.click("#sec-doe summary")
    pg.fill("#doe-plan", PLAN)
    h = history(pg)
    labels = [e["label"] for e in h["entries"][1:]]
    assert len(set(labels)) >= 3 and "move" not in labels  # the editor's own labels, not generic ones
    want = {"labels": labels, "doe_plan": PLAN, "shape_values": {"lift": 0.05}}
    wait_for(lambda: {k: workspace(pg.base, "sessions", sid)[k] for k in want} == want,
             "the session's workspace on the service")
    wait_for(lambda: (lambda d: len(d["applied"]) + len(d["undone"]) == len(labels))(
        httpx.get(f"{pg.base}/v1/sessions/{sid}/history").json()), "the history on the service")
    wait_for(lambda: workspace(pg.base, "meshes", pg.evaluate("window.tetmorph.mesh().id"))["session"] == sid,
             "the mesh's workspace naming the session")
    return {"sid": sid, "mesh": pg.evaluate("window.tetmorph.mesh().id"), "history": h, "regions": regions(pg),
            "positions": positions(pg), "presets": pg.evaluate("window.tetmorph.session().presets")}


def same_workspace(pg, was: dict) -> None:
    """The page shows the workspace `was` (its history with its labels, presets, sliders, plan, regions)."""
    session_open(pg, was["sid"])
    pg.wait_for_function(f"window.tetmorph.history().entries.length === {len(was['history']['entries'])}")
    pg.wait_for_function(f"document.getElementById('doe-plan').value === {PLAN!r}")
    assert history(pg) == was["history"]  # labels, MOVEs and the entry shown
    assert pg.evaluate("window.tetmorph.session().presets") == was["presets"]
    assert pg.locator("#presets li").count() == 1
    assert pg.input_value("#shapes input[data-shape=lift]") == "0.05"
    assert regions(pg) == was["regions"]
    np.testing.assert_allclose(positions(pg), was["positions"], atol=1e-4)
    assert address(pg) == {"m": was["mesh"], "s": was["sid"]}
    assert pg.is_hidden("#regions-stale")


def test_a_reload_and_a_second_tab_reopen_the_workspace_from_the_address(pages, server):
    pg = pages(server)
    was = make_workspace(pg)
    assert address(pg) == {"m": was["mesh"], "s": was["sid"]}
    pg.reload()  # F5
    pg.wait_for_function("window.tetmorph !== undefined")
    same_workspace(pg, was)
    assert pg.is_hidden("#welcome")
    # the labels are the service's too, one per MOVE of its history
    labels = [e["label"] for e in was["history"]["entries"][1:]]
    assert workspace(server, "sessions", was["sid"])["labels"] == labels
    # a second tab (a bookmark) on the same address opens the same workspace
    url = urlparse(pg.url)
    tab = pages(server, path=f"/#{url.fragment}")
    same_workspace(tab, was)


def test_the_stored_meshes_list_every_mesh_newest_first(page):
    # more meshes than one page of the listing: the one uploaded last was not on the first page
    more_than_a_page(page.base)
    upload(page, BRACKET)
    mid = page.evaluate("window.tetmorph.mesh().id")
    stored = stored_meshes(page.base)
    assert len(stored) > PAGE and stored[-1]["id"] == mid
    listed = page.eval_on_selector_all("#meshes option", "(os) => os.map((o) => o.value)")
    assert listed == [""] + [m["id"] for m in reversed(stored)]  # every mesh, the newest first
    assert page.input_value("#meshes") == mid
    # the oldest, from the bottom of the list, opens
    page.select_option("#meshes", stored[0]["id"])
    page.click("#open-mesh")
    page.wait_for_function("(id) => window.tetmorph.mesh().id === id && window.tetmorph.mesh().open",
                           arg=stored[0]["id"])


def test_another_mesh_shows_its_own_workspace_and_the_first_comes_back(page, tmp_path):
    more_than_a_page(page.base)  # the bracket is then not on the listing's first page
    was = make_workspace(page)
    # a mesh of its own (each upload is stored as a new mesh): plate.inp with a comment line of its own
    plate_file = tmp_path / "plate.inp"
    plate_file.write_bytes((DATA / "plate.inp").read_bytes() + f"** {tmp_path.name}\n".encode())
    upload(page, plate_file)  # the file chooser's input, as Upload… gives it
    plate = page.evaluate("window.tetmorph.mesh().id")
    assert plate != was["mesh"]
    page.wait_for_function("window.tetmorph.session().id === null")
    # the page clears the regions once the new mesh is drawn: wait for that (a busy machine is slower), then
    # check that nothing of the bracket's workspace is on screen, and that none was stored with the plate
    page.wait_for_function("window.tetmorph.regions().length === 0", timeout=30000)
    # nothing of the bracket's workspace on screen
    assert page.locator("#presets li").count() == 0
    assert page.locator("#shapes input[data-shape]").count() == 0
    assert page.input_value("#doe-plan") == ""
    assert page.locator("#doe-decks li").count() == 0
    assert len(history(page)["entries"]) == 1
    assert page.is_hidden("#gizmo-label")
    assert page.locator("#handle-select option").count() == 0
    assert regions(page) == {}
    assert address(page) == {"m": plate}
    assert workspace(page.base, "meshes", plate)["regions"] is None
    # the bracket again, from the stored meshes: its workspace, its session reattached
    page.select_option("#meshes", was["mesh"])
    page.click("#open-mesh")
    same_workspace(page, was)
    # and the plate again: its own (empty) workspace, the bracket's session left on the service
    page.select_option("#meshes", plate)
    page.click("#open-mesh")
    page.wait_for_function(f"window.tetmorph.mesh().id === '{plate}' && window.tetmorph.session().id === null")
    assert page.locator("#presets li").count() == 0 and page.input_value("#doe-plan") == ""
    assert httpx.get(f"{page.base}/v1/sessions/{was['sid']}").status_code == 200


def paint_fixed(pg) -> None:
    """Shift-brush a stroke across the middle of the top face into the fixed region, as a person adds to it."""
    pg.check("input[name=role][value='1']")
    pg.check("input[name=tool][value='brush']")
    V = np.array(pg.evaluate("window.tetmorph.rest()")).reshape(-1, 3)
    top = np.flatnonzero((np.abs(V[:, 0] - 50) < 6) & (V[:, 2] > V[:, 2].max() - 1e-6))
    pts = pg.evaluate("(ids) => ids.map((i) => window.tetmorph.screenOf(i))", top.tolist())
    x, y = np.mean([q["x"] for q in pts]), np.mean([q["y"] for q in pts])
    drag(pg, x, y - 4, x, y + 4, steps=4, modifiers=("Shift",))


def test_regions_changed_after_create_are_marked_and_rebuilt_in_one_action(page):
    bracket_session(page)
    sid = page.evaluate("window.tetmorph.session().id")
    save_preset(page, "lift")
    assert page.is_hidden("#regions-stale")
    before = regions(page)
    paint_fixed(page)
    painted = regions(page)
    assert painted["FIXED"][1] > before["FIXED"][1] and painted["LOAD"] == before["LOAD"]
    page.wait_for_selector("#regions-stale", state="visible")
    assert sid in page.inner_text("#regions-stale") and "not in session" in page.inner_text("#regions-stale")
    # the session on the service still has the regions it was created with
    fixed_sel = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["spec"]["selections"]["FIXED"]
    assert fixed_sel == {"set": "FIXED"}
    # the regions on screen are the session's workspace: F5 brings them back, still marked
    wait_for(lambda: workspace(page.base, "sessions", sid)["regions"] is not None, "the regions drawn on the service")
    page.reload()
    page.wait_for_function("window.tetmorph !== undefined")
    session_open(page, sid)
    page.wait_for_function("(n) => window.tetmorph.regions().some((r) => r.name === 'FIXED' && r.count === n)",
                           arg=painted["FIXED"][1])
    page.wait_for_selector("#regions-stale", state="visible")
    role = np.array(page.evaluate("window.tetmorph.role()"))
    # one action: Rebuild session makes a session of the regions on screen, the presets carried over
    page.click("#rebuild-session")
    page.wait_for_function("(sid) => { const s = window.tetmorph.session(); return s.id && s.id !== sid"
                           " && s.stream && s.stream.open; }", arg=sid, timeout=60000)
    new = page.evaluate("window.tetmorph.session().id")
    page.wait_for_selector("#regions-stale", state="hidden")
    spec = httpx.get(f"{page.base}/v1/sessions/{new}").json()["spec"]
    assert sorted(spec["selections"]["FIXED"]["ids"]) == np.flatnonzero(role == 1).tolist()
    page.wait_for_function("window.tetmorph.session().presets.length === 1")
    assert [p["name"] for p in httpx.get(f"{page.base}/v1/sessions/{new}").json()["presets"]] == ["lift"]
    assert address(page)["s"] == new


def test_the_move_counter_starts_again_with_each_session(page):
    bracket_session(page)
    for z in (1, 2):
        numeric_move(page, t=(0, 0, z))
        settle(page)
    assert report_row(page, "seq") == "2"
    # an ordinary lift of the handle: no warning that free nodes outrun it
    assert report_row(page, "free_exceeds") is None
    create(page, replace=True)
    numeric_move(page, t=(0, 0, 1))
    settle(page)
    assert page.evaluate("window.tetmorph.session().seq") == 1
    assert report_row(page, "seq") == "1"


def test_an_address_whose_session_is_gone_opens_its_mesh_with_the_regions(pages, server):
    pg = pages(server)
    bracket_session(pg)
    sid, mesh = pg.evaluate("window.tetmorph.session().id"), pg.evaluate("window.tetmorph.mesh().id")
    want = regions(pg)
    wait_for(lambda: workspace(server, "meshes", mesh)["regions"] is not None, "the mesh's regions on the service")
    assert httpx.delete(f"{server}/v1/sessions/{sid}").status_code == 204
    tab = pages(server, path=f"/#m={mesh}&s={sid}")
    tab.wait_for_function(f"window.tetmorph.mesh().id === '{mesh}'")
    tab.wait_for_selector("#errors:not([hidden])")
    assert sid in tab.inner_text("#error-text") and "no longer on the service" in tab.inner_text("#error-text")
    tab.wait_for_function(f"window.tetmorph.regions().length === {len(want)}")
    assert regions(tab) == want
    assert tab.evaluate("window.tetmorph.session().id") is None
