"""DOE set-up in the editor (issue 43): bounds and levels typed per shape, the safe bounds of
``tetmorph bounds`` offered, full-factorial and Latin-hypercube plans generated in the page, and the
PLAN downloaded as the CSV ``tetmorph doe`` reads.

The rows are checked here (every combination; one value per stratum; the same seed, the same plan),
the safe bounds against :func:`solver.workflows.bounds.shape_bounds` computed here, and the downloaded
files are run with ``tetmorph doe``. Failed before the set-up was added (no #doe-setup).
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import subprocess
import sys

import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.workflows.bounds import shape_bounds
from solver.workflows.shapes import parse_shapes, variant_move
from tests.browser.conftest import BRACKET
from tests.browser.test_editor_tools import lift_and_twist


def plan(pg) -> tuple[list[str], np.ndarray]:
    rows = list(csv.reader(io.StringIO(pg.input_value("#doe-plan"))))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])


def setup_field(pg, shape: str, field: str) -> str:
    return f"#doe-setup input[data-shape={shape}][data-field={field}]"


def save(pg, selector: str, tmp_path):
    with pg.expect_download() as dl:
        pg.click(selector)
    p = tmp_path / dl.value.suggested_filename
    dl.value.save_as(p)
    return p


def test_plans_are_generated_from_typed_bounds_and_run_with_tetmorph_doe(page, tmp_path):
    lift_and_twist(page)  # presets lift (5 along z) and twist (20 degrees about x)
    page.click("#sec-doe summary")
    assert page.locator("#doe-setup tr[data-shape]").count() == 2
    # the safe bounds, as tetmorph bounds finds them
    page.click("#doe-bounds")
    page.wait_for_selector("#doe-setup button[data-use=lift]", timeout=120000)
    sid = page.evaluate("window.tetmorph.session().id")
    spec = page.evaluate("window.tetmorph.spec()")
    shapes_doc = {"shapes": {p["name"]: p["move"] for p in page.evaluate("window.tetmorph.session().presets")}}
    d = precompute(read_mesh(BRACKET), {k: spec[k] for k in ("selections", "fixed", "handles")})
    lib = {b.shape: b for b in shape_bounds(d, parse_shapes(shapes_doc, d)).shapes}
    assert sid and set(lib) == {"lift", "twist"}
    page.click("#doe-setup button[data-use=lift]")
    lo = float(page.input_value(setup_field(page, "lift", "lo")))
    hi = float(page.input_value(setup_field(page, "lift", "hi")))
    assert lo == pytest.approx(lib["lift"].negative.value, rel=1e-6) and lo < 0
    assert hi == pytest.approx(lib["lift"].positive.value, rel=1e-6) and hi > 0
    # full factorial: lift 3 levels over its safe bounds, twist the values typed
    page.fill(setup_field(page, "lift", "levels"), "3")
    page.fill(setup_field(page, "twist", "levels"), "0, 0.5, 1, -0.25")
    page.click("#doe-ff")
    names, rows = plan(page)
    assert names == ["lift", "twist"]
    want = list(itertools.product([lo, (lo + hi) / 2, hi], [0, 0.5, 1, -0.25]))
    np.testing.assert_allclose(rows, want, rtol=1e-12, atol=1e-12)
    # Latin hypercube: 7 rows, seed 42; twist between -0.5 and 1
    page.fill(setup_field(page, "twist", "lo"), "-0.5")
    page.fill(setup_field(page, "twist", "hi"), "1")
    page.fill("#doe-lhs-n", "7")
    page.fill("#doe-lhs-seed", "42")
    page.click("#doe-lhs")
    names, lhs = plan(page)
    assert names == ["lift", "twist"] and lhs.shape == (7, 2)
    for k, (a, b) in enumerate(((lo, hi), (-0.5, 1.0))):
        strata = np.floor((lhs[:, k] - a) / (b - a) * 7).astype(int)
        assert sorted(strata.tolist()) == list(range(7)), (k, lhs[:, k])  # one value in each stratum
        assert (lhs[:, k] >= a).all() and (lhs[:, k] <= b).all()
    text = page.input_value("#doe-plan")
    page.fill("#doe-lhs-seed", "43")
    page.click("#doe-lhs")
    assert page.input_value("#doe-plan") != text  # another seed, another plan
    page.fill("#doe-lhs-seed", "42")
    page.click("#doe-lhs")
    assert page.input_value("#doe-plan") == text  # the same seed, the same plan
    # a bound that is not a number is refused in words, and the plan stays
    page.fill(setup_field(page, "twist", "hi"), "one")
    page.click("#doe-lhs")
    page.wait_for_selector("#errors:not([hidden])")
    assert "high bound of twist is not a number" in page.inner_text("#error-text")
    assert page.input_value("#doe-plan") == text
    # the files run unchanged with tetmorph doe
    files = {w: save(page, f"#doe-{w}-file", tmp_path) for w in ("spec", "shapes", "plan")}
    assert files["plan"].read_text() == text
    out = subprocess.run([sys.executable, "-m", "service.cli", "doe", str(BRACKET), "--spec", str(files["spec"]),
                          "--shapes", str(files["shapes"]), "--plan", str(files["plan"]),
                          "--output", str(tmp_path / "deck_{i}.inp"), "--summary", str(tmp_path / "summary.csv")],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    summary = list(csv.DictReader((tmp_path / "summary.csv").open()))
    assert len(summary) == 7
    mesh = read_mesh(BRACKET)
    theta = dict(zip(names, lhs[2], strict=True))  # row 3, as the library morphs it
    shapes = parse_shapes(json.loads(files["shapes"].read_text()), d)
    expected = d.solve(variant_move(d, shapes, np.array([theta[n] for n in shapes.names]))).V
    np.testing.assert_allclose(read_mesh(tmp_path / "deck_3.inp").V, expected, atol=1e-4)
    assert mesh.V.shape == expected.shape
