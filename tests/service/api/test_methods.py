"""A 405 names every method the path answers (``Allow``), as the OpenAPI document lists them."""

from __future__ import annotations

import re

from ..conftest import running

METHODS = ("get", "post", "put", "patch", "delete")


def test_every_405_allows_what_the_openapi_document_lists_for_its_path(tmp_path):
    with running(tmp_path, load_kernels=False) as tc:
        paths = tc.get("/openapi.json").json()["paths"]
        checked = 0
        for template, ops in paths.items():
            listed = sorted(m.upper() for m in ops if m in METHODS)
            missing = [m for m in METHODS if m not in ops]
            if not missing:
                continue
            path = re.sub(r"\{[^}]+\}", "x_1", template)
            # a method another template answers on the same path (GET /v1/meshes/arrays is
            # GET /v1/meshes/{mesh_id}) is routed there: the first that no template answers
            others = {m.upper() for t, o in paths.items() if t != template
                      and re.fullmatch(re.sub(r"\{[^}]+\}", "[^/]+", t), path) for m in o}
            free = [m.upper() for m in missing if m.upper() not in others]
            if not free:
                continue
            r = tc.request(free[0], path)
            assert r.status_code == 405, (template, free[0], r.status_code)
            want = sorted(set(listed) | (others & {m.upper() for m in METHODS}))
            assert sorted(a.strip() for a in r.headers["allow"].split(",")) == want, template
            assert r.json()["error"]["code"] == "method_not_allowed"
            checked += 1
        assert checked > 20
