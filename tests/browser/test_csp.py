"""The editor runs under its Content-Security-Policy: a real browser, the policy enforced (no bypass)."""

from __future__ import annotations

import re

import httpx


def test_the_editor_runs_under_its_policy_and_the_policy_refuses_injected_scripts(browser, demo_server):
    csp = httpx.get(demo_server + "/").headers["content-security-policy"]
    assert "'unsafe-inline'" not in csp.split("script-src", 1)[1].split(";")[0]
    ctx = browser.new_context(viewport={"width": 1300, "height": 800})  # the policy in force
    try:
        pg = ctx.new_page()
        violations, errors = [], []
        pg.on("console", lambda m: violations.append(m.text) if "Content Security Policy" in m.text else None)
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(demo_server + "/")
        pg.wait_for_selector("#welcome-demo")
        for _ in range(100):  # the page's modules loaded through the import map the policy allows by hash
            if pg.evaluate("() => window.tetmorph !== undefined"):
                break
            pg.wait_for_timeout(100)
        pg.click("#welcome-demo")
        for _ in range(300):  # the demo session opens and its stream connects (WebSocket: connect-src 'self')
            if pg.evaluate("() => window.tetmorph.session().id === 's_demo' && window.tetmorph.session().stream.open"):
                break
            pg.wait_for_timeout(100)
        assert pg.evaluate("() => window.tetmorph.session().stream.open")
        assert violations == [] and errors == [], (violations, errors)
        # an inline script added to the page is refused by the same policy
        pg.evaluate("() => { const s = document.createElement('script'); s.textContent = 'window.injected = 1';"
                    " document.body.appendChild(s); }")
        pg.wait_for_timeout(200)
        assert pg.evaluate("() => window.injected === undefined")
        assert any(re.search(r"inline script", v, re.I) for v in violations), violations
    finally:
        ctx.close()
