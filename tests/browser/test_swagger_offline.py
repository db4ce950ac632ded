"""``/docs`` renders the API in a real browser with every other host unreachable, under its own policy."""

from __future__ import annotations

from urllib.parse import urlsplit

import httpx


def test_swagger_ui_renders_every_operation_with_no_other_host_reachable(browser, server):
    doc = httpx.get(server + "/openapi.json").json()
    operations = sum(1 for item in doc["paths"].values() for m in item
                     if m in ("get", "put", "post", "delete", "options", "head", "patch", "trace"))
    own = urlsplit(server).netloc
    ctx = browser.new_context(viewport={"width": 1300, "height": 800})
    try:
        pg = ctx.new_page()
        elsewhere, violations, errors = [], [], []

        def only_the_service(route):
            if urlsplit(route.request.url).netloc == own or route.request.url.startswith("data:"):
                route.continue_()
            else:
                elsewhere.append(route.request.url)
                route.abort()

        pg.route("**/*", only_the_service)
        pg.on("console", lambda m: violations.append(m.text) if "Content Security Policy" in m.text else None)
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(server + "/docs")
        pg.wait_for_selector(".opblock", timeout=30000)
        shown = pg.locator(".opblock").count()
        assert shown == operations, (shown, operations)
        assert pg.locator(".info .title").inner_text().startswith("tetmorph")
        pg.locator(".opblock-summary").first.click()  # an operation opens: its parameters render
        pg.wait_for_selector(".opblock-body", timeout=10000)
        assert elsewhere == [] and violations == [] and errors == [], (elsewhere, violations, errors)
    finally:
        ctx.close()
