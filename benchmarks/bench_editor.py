"""The browser editor at ~100k tets: load time and drag-to-screen latency in headless chromium.

A real ``tetmorph serve`` and Debian's chromium (software WebGL, SwiftShader, on this
machine's 2 cores). The gmsh bracket of ``tests/data/make_bracket.py`` at mesh size 0.95
(107,047 tets) is uploaded through the page; FIXED fixed, LOAD the handle. Then 30
numeric MOVEs are sent one after another, each waiting until its frame is on screen.
"MOVE → frame on screen" is measured from Python and includes Playwright's own
round trips for filling the input and clicking; "send → frame applied" is measured in
the page (WebSocket send to the new positions, normals, quality and colours in place).
The stream sends boundary-first frames; a line under the table says how many of them were
painted before their full frame came (the rest were overtaken and never applied) and the
page's send → boundary painted time.
Prints a table::

    python benchmarks/bench_editor.py [--size 0.95] [--moves 30] [--views]

With ``--views``, a second table gives, for each view of the editor (plain, rest ghost,
displacement colour map, clipping plane, bad-element overlay off), the median time of a
complete frame (render, then one pixel read back, which waits for the frame to be drawn;
``window.tetmorph.measureFrames``) and the page's
send → frame applied time of MOVEs sent with that view on.

With ``--drag STEPS``, the handle is dragged instead, with the real mouse on the gizmo's centre
(``--mesh wheel``: the tractor wheel deck of the shared data, BC_RIMTIRE fixed and BC_SURF the
handle; ``--mesh demo``: the Demo of ``tetmorph serve --demo``; ``--mesh bracket``: the bracket
above), ``--repeat`` drags of STEPS pointer moves each. Each step is timed from the pointer move
to its MOVE's frame applied and the next frame painted ("drag → frame"). ``--load N`` starts N
CPU-bound processes of its own for the drags (and stops them after). ``--root DIR`` serves the
service and the built editor of another checkout (a ``git worktree`` of an earlier commit, its
editor built with ``npm run build``), to compare side by side::

    python benchmarks/bench_editor.py --mesh wheel --drag 20 --repeat 3 [--load 2] [--root DIR]

A row says the checkout (``--label``, else its commit), the mesh, the load, the median and p95 of every
step, each drag's median, the steps timed and missed, and the 1-minute load average before and after.

A second table splits each step's time between the service and the browser, from marks the page
itself takes (``FRAME_PROBE``, installed before the editor loads; it wraps the WebSocket, so the
editor is unchanged and ``--root`` checkouts are measured the same way): "service update" is the
REPORT's ``solve_ms`` of the frame (the update's own timing, on the service); "send → arrived" the
page's time from sending the MOVE to its full frame's arrival (the update, the service's queue and
encoding, the socket); "page: arrived → rendered" the browser's own time, from the frame's arrival
through decoding and applying it (positions, normals, quality, colours: "of which apply") to the next
frame drawn and read back (one pixel, which waits until the renderer has finished it). Each cell is
the median [min-max] over the ``--repeat`` drags of each drag's median step. "frames/s" is how many
full frames the page applied per second of dragging, and "page fps" how many frames it drew
(``requestAnimationFrame``) meanwhile. The 1M-tet part is the bracket at ``--size 0.44``
(``benchmarks/bench_update.py``'s, 1.03M tets)::

    python benchmarks/bench_editor.py --mesh bracket --size 0.44 --drag 10 --repeat 3
Editors from before the test hook (``window.tetmorph.session()`` and the other accessors of
web/src/testhook.js, added later) expose their state object as ``window.tetmorph.state``;
the drags read it through the same few accessors, added to the page (``HOOK_FALLBACK``).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    from playwright.sync_api import sync_playwright

    from service.process import serve_process

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=0.95)
    ap.add_argument("--moves", type=int, default=30)
    ap.add_argument("--views", action="store_true", help="also time each view's frames and MOVEs")
    ap.add_argument("--drag", type=int, default=0, metavar="STEPS", help="time gizmo drags of STEPS pointer moves")
    ap.add_argument("--mesh", choices=("bracket", "wheel", "demo"), default="bracket", help="the mesh of --drag")
    ap.add_argument("--repeat", type=int, default=3, help="drags of --drag")
    ap.add_argument("--load", type=int, default=0, help="CPU-bound processes running during the drags")
    ap.add_argument("--root", type=Path, default=ROOT, help="the checkout whose service and editor are served")
    ap.add_argument("--label", default="", help="what the checkout is called in the row (default: its commit)")
    a = ap.parse_args()
    if a.drag:
        drags(a)
        return
    deck = Path(tempfile.gettempdir()) / f"tetmorph-bracket-{a.size:g}.inp"
    if not deck.exists():
        subprocess.run([sys.executable, str(ROOT / "tests" / "data" / "make_bracket.py"), f"{a.size:g}", str(deck)],
                       check=True)
    with serve_process(tempfile.mkdtemp()) as (base, _), sync_playwright() as p:
        b = p.chromium.launch(executable_path=shutil.which("chromium"),
                              args=["--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        # bypass_csp: Playwright's string predicates run as eval, which the page's CSP refuses
        pg = b.new_context(viewport={"width": 1300, "height": 800}, bypass_csp=True).new_page()
        pg.goto(base + "/")
        t0 = time.perf_counter()
        pg.set_input_files("#upload", str(deck))
        pg.wait_for_function("window.tetmorph.mesh().open", timeout=300000)
        load_s = time.perf_counter() - t0
        tets = pg.evaluate("window.tetmorph.tets().length / 4")
        pg.select_option("#sets", "FIXED")
        pg.click("#set-apply")
        pg.check("input[name=role][value='2']")
        pg.select_option("#sets", "LOAD")
        pg.click("#set-apply")
        t0 = time.perf_counter()
        pg.click("#create")
        pg.wait_for_function("window.tetmorph.session().id !== null", timeout=300000)
        session_s = time.perf_counter() - t0
        lat, frame_ms, apply_ms, rtt, brtt = [], [], [], [], []
        b_last = None
        for k in range(1, a.moves + 1):
            pg.fill("#tz", str(0.5 * k))
            t0 = time.perf_counter()
            pg.click("#apply-move")
            pg.wait_for_function(f"window.tetmorph.session().lastSeq === {k}", timeout=60000)
            pg.evaluate("() => new Promise((r) => requestAnimationFrame(() => r()))")  # drawn
            lat.append(time.perf_counter() - t0)
            frame_ms.append(pg.evaluate("window.tetmorph.report().solve_ms"))
            apply_ms.append(pg.evaluate("window.tetmorph.view().applyMs"))
            rtt.append(pg.evaluate("window.tetmorph.session().roundTripMs"))
            b_ms = pg.evaluate("window.tetmorph.session().boundaryRoundTripMs")
            if b_ms is not None and b_ms != b_last:  # a boundary frame of this MOVE was drawn
                brtt.append(b_ms)
            b_last = b_ms
        counts = pg.evaluate("[window.tetmorph.session().boundaryReceived, window.tetmorph.view().boundaryFrames]")
        views = time_views(pg, a.moves) if a.views else None
        b.close()
    print("| tets | page load + geometry s | session build s | MOVE → frame on screen ms (median) | p95 ms "
          "| server update ms (median) | page: send → frame applied ms (median) | page: apply frame ms (median) |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    print(f"| {int(tets):,} | {load_s:.2f} | {session_s:.2f} | {1e3 * np.median(lat):.0f} | "
          f"{1e3 * np.percentile(lat, 95):.0f} | {np.median(frame_ms):.1f} | {np.median(rtt):.1f} | "
          f"{np.median(apply_ms):.1f} |")
    drawn = f"{np.median(brtt):.1f} ms (median of {len(brtt)})" if brtt else "none drawn"
    print(f"\nboundary-first frames: {counts[0]} received, {counts[1]} painted before their full frame; "
          f"send → boundary painted: {drawn}")
    if views:
        print()
        print("| view | frame ms (median of 30) | page: send → frame applied ms (median) "
              "| page: apply frame ms (median) |")
        print("|---|---:|---:|---:|")
        for name, (fr, sent, applied) in views.items():
            print(f"| {name} | {fr:.1f} | {sent:.1f} | {applied:.1f} |")


def _spin() -> None:
    """A CPU-bound loop (the load of --load)."""
    x = 0
    while True:
        x = (x * 1103515245 + 12345) % 2147483648


WHEEL = ROOT.parent / "shared" / "data" / "tet" / "tractor_wheel_coarse.INP"  # the shared data beside the clone
RAF = "() => new Promise((r) => requestAnimationFrame(() => r()))"
#: The accessors the drags read, for an editor that has only ``window.tetmorph.state`` (no test hook yet).
HOOK_FALLBACK = """() => {
  const t = window.tetmorph;
  if (typeof t.session === "function" || !t.state) return false;
  const s = t.state;
  t.session = () => ({ id: s.sessionId, seq: s.seq, lastSeq: s.lastSeq,
    stream: s.ws ? { open: s.ws.open, readyState: s.ws.ws ? s.ws.ws.readyState : undefined } : null });
  t.mesh = () => ({ open: s.V !== null });
  t.tets = () => Array.from(s.T || []);
  return true;
}"""


def _open(pg, base: str, a: argparse.Namespace) -> str:
    """Open the mesh of --mesh with its regions and a ready session; answers what it is."""
    if a.mesh == "demo":
        pg.click("#demo")
        pg.wait_for_function("window.tetmorph.session().id === 's_demo' && window.tetmorph.session().stream"
                             " && window.tetmorph.session().stream.open", timeout=300000)
        return "Demo beam"
    if a.mesh == "wheel":
        deck = WHEEL
        sets = ("BC_RIMTIRE", "BC_SURF")
    else:
        deck = Path(tempfile.gettempdir()) / f"tetmorph-bracket-{a.size:g}.inp"
        if not deck.exists():
            subprocess.run([sys.executable, str(ROOT / "tests" / "data" / "make_bracket.py"), f"{a.size:g}",
                            str(deck)], check=True)
        sets = ("FIXED", "LOAD")
    pg.set_input_files("#upload", str(deck))
    pg.wait_for_function("window.tetmorph.mesh().open", timeout=300000)
    for role, name in zip(("1", "2"), sets, strict=True):
        pg.check(f"input[name=role][value='{role}']")
        pg.select_option("#sets", name)
        pg.click("#set-apply")
    pg.click("#create")
    pg.wait_for_function("window.tetmorph.session().id !== null && window.tetmorph.session().stream"
                         " && window.tetmorph.session().stream.open", timeout=300000)
    return deck.name


#: Marks the page takes of each streamed frame (see the module's docstring). ``window.__tmFrames`` holds,
#: per full frame applied: seq, sent (the MOVE's send), arrived, applied, rendered (performance.now() ms)
#: and the REPORT's solve_ms; ``window.__tmDraws`` counts the frames drawn.
FRAME_PROBE = """(() => {
  const frames = [], sent = new Map();
  window.__tmFrames = frames;
  window.__tmDraws = 0;
  const tick = () => { window.__tmDraws += 1; requestAnimationFrame(tick); };
  requestAnimationFrame(tick);
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    if (typeof data === "string") {
      try { sent.set(JSON.parse(data).seq, performance.now()); } catch (e) { /* not a MOVE */ }
    }
    return send.call(this, data);
  };
  const slot = Object.getOwnPropertyDescriptor(WebSocket.prototype, "onmessage");
  const head = (buf) => {
    const b = new Uint8Array(buf), h = new DataView(buf).getUint32(4, true);
    return JSON.parse(new TextDecoder().decode(b.subarray(8, 8 + h)));
  };
  Object.defineProperty(WebSocket.prototype, "onmessage", { configurable: true,
    get() { return slot.get.call(this); },
    set(fn) {
      if (typeof fn !== "function") { slot.set.call(this, fn); return; }
      slot.set.call(this, (ev) => {
        if (typeof ev.data === "string") return fn(ev);
        const arrived = performance.now();
        performance.mark("tetmorph:frame-arrived");
        const h = head(ev.data);
        fn(ev);
        if (h.frame === "boundary") return;
        const rec = { seq: h.seq, sent: sent.get(h.seq), arrived, applied: performance.now(), rendered: null,
                      solve_ms: h.report ? h.report.solve_ms : null };
        frames.push(rec);
        requestAnimationFrame(() => {  // after the editor's own draw of this frame (its loop asked first)
          const c = document.getElementById("canvas");
          const gl = c.getContext("webgl2") || c.getContext("webgl");
          if (gl) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
          rec.rendered = performance.now();
          performance.mark("tetmorph:frame-rendered");
          performance.measure("tetmorph:arrived-to-rendered", { start: arrived, end: rec.rendered });
        });
      });
    } });
})()"""


def _split(pg, seqs: list[int], t0: float, t1: float, d0: int, d1: int) -> dict[str, float]:
    """A drag's median service and page times (ms) of the full frames of ``seqs``, and its frame rates."""
    recs = pg.evaluate("(s) => window.__tmFrames.filter((r) => s.includes(r.seq) && r.rendered !== null)", seqs)
    if not recs:
        return {}
    med = lambda xs: float(np.median([x for x in xs if x is not None])) if any(x is not None for x in xs) \
        else float("nan")  # noqa: E731
    applied = pg.evaluate("([a, b]) => window.__tmFrames.filter((r) => r.applied >= a && r.applied <= b).length",
                          [t0, t1])
    secs = max((t1 - t0) / 1e3, 1e-9)
    return {"update": med([r["solve_ms"] for r in recs]),
            "sent_arrived": med([r["arrived"] - r["sent"] if r["sent"] is not None else None for r in recs]),
            "page": med([r["rendered"] - r["arrived"] for r in recs]),
            "apply": med([r["applied"] - r["arrived"] for r in recs]),
            "fps_applied": applied / secs, "fps_drawn": (d1 - d0) / secs}


def _drag(pg, steps: int, sign: int) -> tuple[list[float], int, dict[str, float]]:
    """One drag of the gizmo's centre, 4 px a step: per step, pointer move → frame applied and painted (s).

    Also answers the drag's split (:func:`_split`) between the service and the page, from the page's marks.
    """
    if pg.is_checked("#snap"):
        pg.uncheck("#snap")
    c = pg.evaluate("window.tetmorph.pivotScreen()")
    pg.mouse.move(c["x"], c["y"])
    pg.mouse.down()
    out, missed, seqs = [], 0, []
    p0, d0 = pg.evaluate("[performance.now(), window.__tmDraws || 0]")
    for k in range(1, steps + 1):
        seq = pg.evaluate("window.tetmorph.session().seq")
        t0 = time.perf_counter()
        pg.mouse.move(c["x"] + sign * 4 * k, c["y"] - 2 * k)
        try:
            pg.wait_for_function(f"(() => {{ const s = window.tetmorph.session(); return s.seq > {seq} && "
                                 "s.lastSeq === s.seq; })()", timeout=20000)
        except Exception:  # noqa: BLE001 - a pointer move that sent nothing (off the gizmo) or a frame lost
            missed += 1
            continue
        pg.evaluate(RAF)
        out.append(time.perf_counter() - t0)
        seqs.append(pg.evaluate("window.tetmorph.session().lastSeq"))
    p1, d1 = pg.evaluate("[performance.now(), window.__tmDraws || 0]")
    pg.mouse.up()
    pg.evaluate(RAF)
    return out, missed, _split(pg, seqs, p0, p1, d0, d1)


def drags(a: argparse.Namespace) -> None:
    """--drag: drag → frame times on the mesh of --mesh, quiet or under --load."""
    from playwright.sync_api import sync_playwright

    root = a.root.resolve()
    os.chdir(root)  # `python -m service.cli` serves the checkout of the working directory
    sys.path.insert(0, str(root))
    from service.process import serve_process

    commit = a.label or subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                                       text=True).stdout.strip() or root.name
    data = Path(tempfile.mkdtemp())
    if a.mesh == "demo":
        from tests.browser.conftest import demo_process
        server = demo_process(data)
    else:
        server = serve_process(data)
    load = []
    with server as served, sync_playwright() as p:
        base = served if isinstance(served, str) else served[0]
        b = p.chromium.launch(executable_path=shutil.which("chromium"),
                              args=["--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        # bypass_csp: Playwright's string predicates run as eval, which the page's CSP refuses
        ctx = b.new_context(viewport={"width": 1300, "height": 800}, bypass_csp=True)
        ctx.add_init_script(FRAME_PROBE)
        pg = ctx.new_page()
        pg.goto(base + "/")
        pg.wait_for_function("window.tetmorph !== undefined")
        pg.evaluate(HOOK_FALLBACK)
        what = _open(pg, base, a)
        tets = pg.evaluate("window.tetmorph.tets().length / 4")
        _drag(pg, 3, 1)  # warm-up
        load_before = os.getloadavg()[0]
        try:
            load = [multiprocessing.Process(target=_spin, daemon=True) for _ in range(a.load)]
            for proc in load:
                proc.start()
            per, missed, splits = [], 0, []
            for r in range(a.repeat):
                t, m, sp = _drag(pg, a.drag, -1 if r % 2 else 1)
                per.append(t)
                missed += m
                splits.append(sp)
        finally:
            for proc in load:
                proc.terminate()
                proc.join()
        load_after = os.getloadavg()[0]
        b.close()
    every = np.concatenate(per) * 1e3
    medians = [float(np.median(t)) * 1e3 for t in per if t]
    load_word = "quiet" if not a.load else f"{a.load} CPU-bound"
    print("| checkout | mesh | load | drag → frame ms (median) | p95 ms | each drag's median ms | steps | missed "
          "| load average before / after |")
    print("|---|---|---|---:|---:|---|---:|---:|---|")
    print(f"| {commit} | {what} ({int(tets):,} tets) | {load_word} | "
          f"{np.median(every):.0f} | {np.percentile(every, 95):.0f} | "
          f"{' / '.join(f'{m:.0f}' for m in medians)} | {len(every)} | {missed} | "
          f"{load_before:.1f} / {load_after:.1f} |")
    print()
    print(split_table(f"{what} ({int(tets):,} tets)", load_word, a.drag, splits, medians))


def _cell(xs: list[float], digits: int = 0) -> str:
    """median [min-max] of the finite values of ``xs``."""
    v = [x for x in xs if np.isfinite(x)]
    if not v:
        return "n/a"
    return f"{np.median(v):,.{digits}f} [{min(v):,.{digits}f}-{max(v):,.{digits}f}]"


def split_table(what: str, load: str, steps: int, splits: list[dict[str, float]], medians: list[float]) -> str:
    """The service / browser split of the drags, one row: median [min-max] over the drags' medians."""
    got = [s for s in splits if s]
    col = lambda k: [s[k] for s in got]  # noqa: E731
    share = [s["page"] / (s["page"] + s["sent_arrived"]) for s in got
             if np.isfinite(s["page"]) and np.isfinite(s["sent_arrived"])]
    return "\n".join([
        f"{what}, {load}: {len(got)} drags of {steps} steps; median [min-max] over the drags of each drag's median",
        "",
        "| drag → frame on screen ms | service update ms (REPORT) | page: send → frame arrived ms "
        "| page: arrived → rendered ms | of which apply ms | page share of send → rendered | frames/s applied "
        "| page fps |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
        f"| {_cell(medians)} | {_cell(col('update'), 1)} | {_cell(col('sent_arrived'))} | {_cell(col('page'))} "
        f"| {_cell(col('apply'), 1)} | {_cell(share, 2)} | {_cell(col('fps_applied'), 1)} "
        f"| {_cell(col('fps_drawn'), 1)} |"])


#: (label, page script switching the view on, script switching it off)
VIEWS = [
    ("plain (edges, bad-element overlay)", "", ""),
    ("rest ghost", "document.getElementById('ghost').click()", "document.getElementById('ghost').click()"),
    ("displacement colour map",
     "{const s = document.getElementById('color-by'); s.value = 'displacement'; s.dispatchEvent(new Event('change'));}",
     "{const s = document.getElementById('color-by'); s.value = 'regions'; s.dispatchEvent(new Event('change'));}"),
    ("clip plane (z, middle)", "document.getElementById('clip').click()", "document.getElementById('clip').click()"),
    ("bad-element overlay off", "document.getElementById('bad').click()", "document.getElementById('bad').click()"),
]


def time_views(pg, moves: int) -> dict[str, tuple[float, float, float]]:
    """Per view: median frame ms, and median send -> applied and apply ms of MOVEs sent with it on."""
    out = {}
    seq = pg.evaluate("window.tetmorph.session().seq")
    for name, on, off in VIEWS:
        if on:
            pg.evaluate(on)
            pg.evaluate("() => new Promise((r) => requestAnimationFrame(() => r()))")
        frame = pg.evaluate("window.tetmorph.measureFrames(30)")
        sent, applied = [], []
        for k in range(1, moves + 1):
            seq += 1
            pg.fill("#tz", str(0.5 * k + 0.25))
            pg.click("#apply-move")
            pg.wait_for_function(f"window.tetmorph.session().lastSeq === {seq}", timeout=60000)
            sent.append(pg.evaluate("window.tetmorph.session().roundTripMs"))
            applied.append(pg.evaluate("window.tetmorph.view().applyMs"))
        if off:
            pg.evaluate(off)
        out[name] = (frame, float(np.median(sent)), float(np.median(applied)))
    return out


if __name__ == "__main__":
    main()
