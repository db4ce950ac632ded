"""Fixtures of the browser tests: real ``tetmorph serve`` processes and Debian's chromium.

Servers are started once per test session: ``server`` (defaults), ``demo_server`` (``--demo``:
the demo beam and its session s_demo, as ``make run`` serves them) and ``tight_server`` (at most two
sessions per key, and session creation answers 202 at once so builds are seen in progress).
Every test's sessions are deleted when it ends, so the servers' limits hold for the next.
Screenshots are test output, saved in ``test-artifacts/browser/`` (ignored by git).
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from service.process import free_port, serve_process

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts" / "browser"
EDITOR = ROOT / "service" / "static" / "editor" / ".built"
DATA = ROOT / "tests" / "data"
BRACKET = DATA / "bracket.inp"
VIEWPORT = {"width": 1300, "height": 800}


def shared_data() -> Path | None:
    """The public meshes: ``../shared/data`` beside the repository, else ``/work/shared/data``."""
    for cand in (ROOT.parent / "shared" / "data", Path("/work/shared/data")):
        if cand.is_dir():
            return cand
    return None


def shared_file(rel: str) -> Path:
    """A file of the shared data; skip when no shared folder exists, fail when the file is missing."""
    d = shared_data()
    if d is None:
        pytest.skip("no shared data folder (neither ../shared/data beside the repository nor /work/shared/data)")
    p = d / rel
    if not p.exists():
        pytest.fail(f"{p} is missing from the shared data")
    return p


def _serve(tmp_path_factory, name: str, env: dict[str, str] | None = None):
    if not EDITOR.exists():
        pytest.fail("the editor is not built: run 'make web' (make test does)")
    return serve_process(tmp_path_factory.mktemp(name), env=env)


@pytest.fixture(scope="session")
def server(tmp_path_factory):
    with _serve(tmp_path_factory, "data") as (base, _proc):
        yield base


@contextlib.contextmanager
def demo_process(data_dir: Path):
    """``tetmorph serve --demo`` (the CLI's flag sets the demo; TETMORPH_DEMO alone does not)."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "service.cli", "serve", "--port", str(port), "--data-dir",
                             str(data_dir), "--log-level", "warning", "--demo"], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 90
        while True:
            try:
                if httpx.get(url + "/v1/sessions/s_demo", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                pytest.fail(f"tetmorph serve --demo did not start: {proc.stdout.read() if proc.stdout else ''}")
            time.sleep(0.2)
        yield url
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()


@pytest.fixture(scope="session")
def demo_server(tmp_path_factory):
    if not EDITOR.exists():
        pytest.fail("the editor is not built: run 'make web' (make test does)")
    with demo_process(tmp_path_factory.mktemp("demo")) as base:
        yield base


@pytest.fixture(scope="session")
def tight_server(tmp_path_factory):
    with _serve(tmp_path_factory, "tight", {"TETMORPH_MAX_SESSIONS": "2", "TETMORPH_BUILD_WAIT_S": "0"}) as (base, _):
        yield base


@pytest.fixture(scope="session")
def browser():
    from playwright.sync_api import sync_playwright

    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.fail("chromium is not installed: 'make browser' (make test does) installs it with apt")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=["--use-gl=angle", "--use-angle=swiftshader",
                                                          "--enable-unsafe-swiftshader"])
        yield b
        b.close()


def delete_sessions(base: str, keep: tuple[str, ...] = ()) -> None:
    with httpx.Client(base_url=base) as c:
        for s in c.get("/v1/sessions").json():
            if s["id"] not in keep:
                c.delete(f"/v1/sessions/{s['id']}")


class Pages:
    """Opens pages on a server; checks each for uncaught errors and screenshots it at the end."""

    def __init__(self, browser, request):
        self.browser, self.request, self.open = browser, request, []

    def __call__(self, base: str, viewport: dict | None = None, path: str = "/"):
        # bypass_csp: Playwright's string predicates (wait_for_function) run as eval, which the
        # editor page's Content-Security-Policy refuses; the page's own scripts are the same either way
        ctx = self.browser.new_context(viewport=viewport or VIEWPORT, accept_downloads=True, bypass_csp=True)
        pg = ctx.new_page()
        pg.errors = []
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))
        pg.base = base
        pg.goto(base + path)
        pg.wait_for_function("window.tetmorph !== undefined")
        self.open.append((ctx, pg, base))
        return pg

    def close(self):
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        errors = []
        for k, (ctx, pg, _base) in enumerate(self.open):
            if not pg.is_closed():
                pg.screenshot(path=str(ARTIFACTS / f"{self.request.node.name}-{k}.png"))
            errors += pg.errors
            ctx.close()
        for base in {b for _, _, b in self.open}:
            delete_sessions(base, keep=("s_demo",))
        assert not errors, errors  # no uncaught exception in any page


@pytest.fixture
def pages(browser, request):
    p = Pages(browser, request)
    yield p
    p.close()


@pytest.fixture
def page(pages, server):
    return pages(server)


# ---------------------------------------------------------------------------- helpers
def shot(pg, name: str) -> bytes:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return pg.screenshot(path=str(ARTIFACTS / f"{name}.png"))


def image(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def differs(a: bytes, b: bytes) -> int:
    """Number of differing pixels between two PNG screenshots."""
    A, B = image(a), image(b)
    return int(np.count_nonzero(np.abs(A - B).max(axis=2) > 5))


def upload(pg, *paths: Path, name: str | None = None, timeout: float = 60000) -> None:
    pg.set_input_files("#upload", [str(p) for p in paths])
    expected = name or paths[0].name
    pg.wait_for_function(f"window.tetmorph.mesh().open && window.tetmorph.mesh().name === {expected!r}",
                         timeout=timeout)


def load_bracket(pg) -> None:
    upload(pg, BRACKET)


def assign_set(pg, name: str, role: int) -> None:
    pg.check(f"input[name=role][value='{role}']")
    pg.select_option("#sets", name)
    pg.click("#set-apply")


def use_spec(pg, spec: dict) -> None:
    """Type a SPEC into the SPEC dialog and use it (its selections become the regions)."""
    pg.click("#spec-view")
    pg.fill("#spec-text", json.dumps(spec))
    pg.click("#spec-apply")
    pg.click("#spec-close")


def create(pg, policy: str = "warn", timeout: float = 60000, replace: bool = False) -> None:
    """Create a session; ``replace``: the open one was moved, and the question whether to replace it is answered OK."""
    pg.select_option("#policy", policy)
    before = json.dumps(pg.evaluate("window.tetmorph.session().id"))
    pg.click("#create")
    if replace:
        confirm(pg)
    pg.wait_for_function(f"(() => {{ const s = window.tetmorph.session(); return s.id !== null && s.id !== {before}"
                         " && s.stream && (s.stream.open || s.stream.readyState === 1); })()", timeout=timeout)


def set_session(pg, deck: Path, fixed: str, handle: str, policy: str = "warn") -> None:
    """Upload a deck, assign a named set as the fixed region and one as the handle, and create a session."""
    upload(pg, deck)
    assign_set(pg, fixed, 1)
    assign_set(pg, handle, 2)
    create(pg, policy)


def bracket_session(pg, policy: str = "warn") -> None:
    set_session(pg, BRACKET, "FIXED", "LOAD", policy)


def settle(pg, timeout: float = 30000) -> None:
    """Wait until the last MOVE sent has come back over the WebSocket."""
    pg.wait_for_function("(() => { const s = window.tetmorph.session(); return s.seq > 0 && s.lastSeq === s.seq; })()",
                         timeout=timeout)


def numeric_move(pg, t=(0, 0, 0), axis=(0, 0, 1), angle=0.0) -> None:
    for k, v in zip(("tx", "ty", "tz"), t, strict=False):
        pg.fill(f"#{k}", str(v))
    for k, v in zip(("ax", "ay", "az"), axis, strict=False):
        pg.fill(f"#{k}", str(v))
    pg.fill("#angle", str(angle))
    pg.click("#apply-move")


def steady_point(pg, q, tries: int = 30) -> dict:
    """The page point of world point ``q`` once the view has stopped changing.

    A layout change (a panel shown, a scroll bar) resizes the canvas a frame or more later, and moves
    every point on it: a click at a point read before that misses. Read after two animation frames
    until two readings agree.
    """
    last = None
    for _ in range(tries):
        got = pg.evaluate("(q) => new Promise((ok) => requestAnimationFrame(() => requestAnimationFrame("
                          "() => ok(window.tetmorph.worldToPage(q)))))", list(map(float, q)))
        if got == last:
            return got
        last = got
    raise AssertionError(f"the page point of {q} kept changing over {tries} readings")


def positions(pg) -> np.ndarray:
    return np.array(pg.evaluate("window.tetmorph.positions()")).reshape(-1, 3)


def rest(pg) -> np.ndarray:
    return np.array(pg.evaluate("window.tetmorph.rest()")).reshape(-1, 3)


def report_row(pg, key: str) -> str | None:
    """The value cell of a REPORT row (None when the row is not shown)."""
    return pg.evaluate("(key) => { const r = document.querySelector(`#report tr[data-key=${key}]`);"
                       " return r ? r.cells[1].textContent : null; }", key)


def drag(pg, x0: float, y0: float, x1: float, y1: float, steps: int = 12, modifiers: tuple[str, ...] = ()) -> None:
    for m in modifiers:
        pg.keyboard.down(m)
    pg.mouse.move(x0, y0)
    pg.mouse.down()
    pg.mouse.move(x1, y1, steps=steps)
    pg.mouse.up()
    for m in modifiers:
        pg.keyboard.up(m)


def drag_pivot(pg, dx: float, dy: float, steps: int = 12, pause: float = 0.03) -> None:
    """Drag the gizmo with the real mouse from its centre by (dx, dy) pixels, pausing at each step.

    The pauses let the stream answer MOVEs while the drag is still going, as a person's drag does.
    """
    c = pg.evaluate("window.tetmorph.pivotScreen()")
    pg.mouse.move(c["x"], c["y"])
    pg.mouse.down()
    for k in range(1, steps + 1):
        pg.mouse.move(c["x"] + dx * k / steps, c["y"] + dy * k / steps)
        time.sleep(pause)
    pg.mouse.up()


def canvas_box(pg) -> dict:
    return pg.eval_on_selector("#canvas", "c => { const r = c.getBoundingClientRect(); "
                               "return {x: r.left, y: r.top, w: r.width, h: r.height}; }")


def confirm(pg, ok: bool = True, timeout: float = 5000) -> str:
    """Answer the editor's confirmation dialog (OK or Cancel) as a person does; return what it asked."""
    pg.wait_for_selector("#confirm-dialog[open]", timeout=timeout)
    text = pg.inner_text("#confirm-text")
    pg.click("#confirm-ok" if ok else "#confirm-cancel")
    pg.wait_for_selector("#confirm-dialog:not([open])", state="attached", timeout=timeout)
    return text
