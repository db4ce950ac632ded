"""The service's OpenAPI schema and the library's parsers bound the documents by the same numbers.

Every numeric bound of every request schema (SPEC, MOVE, SHAPES, batches, bounds searches, uploads)
is one of :mod:`solver.limits`'s, but for the few option domains listed in :data:`DOMAINS`; and for
each bound the library accepts the value at it and refuses the next float beyond it, as the schema
does.
"""

from __future__ import annotations

import math
import tempfile

import numpy as np
import pytest

from service.app import create_app
from solver import SpecError, parse_move, parse_spec
from solver import limits as lim
from solver.constraints.move import MoveBounds

#: The schemas of the SPEC and MOVE documents (and what they hold).
DOCUMENT_SCHEMAS = ("Spec", "Selection", "Box", "Sphere", "Plane", "Constraints", "ThinWalls", "Point",
                    "RelativePoint", "Relative", "Motion", "MirrorPlane", "Cyclic", "Axis", "Direction",
                    "InlineSurface", "Move", "HandleMove", "Rotation", "FeatureMove", "RelativeMove",
                    "TargetMove", "MotionMove")
#: Bounds that are not magnitudes of a quantity: fractions and counts.
STRUCTURAL = {0.0, 1.0}
#: Bounds that are the domain of an option rather than the size of a quantity, each with why.
DOMAINS = {
    ("Body_tetrahedralize_v1_tetrahedralize_post", "epsilon"): 0.1,  # fTetWild's envelope, a fraction of the box
    ("/v1/meshes/{mesh_id}/features", "angle"): 180.0,  # a dihedral angle in degrees
    ("/v1/meshes/{mesh_id}/features", "tol"): 0.1,  # a fraction of the bounding box
}


@pytest.fixture(scope="module")
def schemas():
    app = create_app(data_dir=tempfile.mkdtemp(), load_kernels=False)
    return app.openapi()["components"]["schemas"]


def _bounds(node, out, path=""):
    if isinstance(node, dict):
        for k in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
            if k in node:
                out.append((path, k, float(node[k])))
        for k, v in node.items():
            _bounds(v, out, f"{path}.{k}")
    elif isinstance(node, list):
        for v in node:
            _bounds(v, out, path)
    return out


def test_every_bound_of_the_document_schemas_is_a_library_limit(schemas):
    limits = _limits()
    missing = [s for s in DOCUMENT_SCHEMAS if s not in schemas]
    assert missing == []
    stray = [(name, p, k, v) for name in DOCUMENT_SCHEMAS for p, k, v in _bounds(schemas[name], [])
             if abs(v) not in limits | STRUCTURAL]
    assert stray == []


def _limits():
    return {abs(float(v)) for k, v in vars(lim).items() if k.isupper() and isinstance(v, (int, float))}


def test_every_bound_of_every_request_schema_and_query_is_a_library_limit(schemas):
    app = create_app(data_dir=tempfile.mkdtemp(), load_kernels=False)
    api = app.openapi()
    allowed = _limits() | STRUCTURAL
    stray = []
    for name, schema in api["components"]["schemas"].items():
        for p, k, v in _bounds(schema, []):
            field = p.split(".properties.")[-1].split(".")[0] if ".properties." in p else p
            if abs(v) not in allowed and DOMAINS.get((name, field)) != abs(v):
                stray.append((name, p, k, v))
    for path, ops in api["paths"].items():
        for op in ops.values():
            for prm in op.get("parameters", []):
                for _, k, v in _bounds(prm.get("schema", {}), []):
                    if abs(v) not in allowed and DOMAINS.get((path, prm["name"])) != abs(v):
                        stray.append((path, prm["name"], k, v))
    assert stray == []
    # the workflow requests bound what the library bounds
    assert _schema_max(schemas, "BatchCreate", "block") == lim.BLOCK_MAX
    assert _schema_max(schemas, "StudyCreate", "block") == lim.BLOCK_MAX
    assert _schema_max(schemas, "BoundsQuery", "tol") == lim.BOUNDS_TOL_MAX
    assert _schema_max(schemas, "BoundsQuery", "range") == lim.SHAPE_VALUE_MAX
    assert schemas["BatchCreate"]["properties"]["shapes"]["maxProperties"] == lim.SHAPES_MAX
    assert schemas["PlanTable"]["properties"]["columns"]["maxItems"] == lim.SHAPES_MAX
    assert schemas["MeshArrays"]["properties"]["vertices"]["maxItems"] == lim.MAX_POINTS


def _schema_max(schemas, name, field):
    out = _bounds(schemas[name]["properties"][field], [])
    return max(v for _, k, v in out if k in ("maximum", "exclusiveMaximum"))


BASE = {"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}}, "fixed": ["a"], "handles": {"h": "b"}}


def _spec_accepts(**extra):
    try:
        parse_spec({**BASE, **extra})
    except SpecError:
        return False
    return True


def _move_accepts(rot=None, scale=None, translation=None, amount=None, bounds=None):
    h = {}
    if rot is not None:
        h["rotation"] = {"axis": [0, 0, 1], "angle_deg": rot}
    if scale is not None:
        h["scale"] = scale
    if translation is not None:
        h["translation"] = translation
    doc = {"handles": {"h": h}} if h else {"targets": {"t": {"amount": amount}}}
    try:
        parse_move(doc, ["h"], {"targets": ["t"]}, bounds=bounds)
    except SpecError:
        return False
    return True


def beyond(x):
    return math.nextafter(x, math.inf)


def test_the_library_refuses_just_beyond_each_bound_the_schema_states(schemas):
    # penalty weight
    assert _schema_max(schemas, "Constraints", "penalty_weight") == lim.PENALTY_MAX
    assert _spec_accepts(constraints={"method": "penalty", "penalty_weight": lim.PENALTY_MAX})
    assert not _spec_accepts(constraints={"method": "penalty", "penalty_weight": beyond(lim.PENALTY_MAX)})
    # thin-wall weight
    assert _schema_max(schemas, "ThinWalls", "weight") == lim.WALL_WEIGHT_MAX
    assert _spec_accepts(thin_walls={"weight": lim.WALL_WEIGHT_MAX})
    assert not _spec_accepts(thin_walls={"weight": beyond(lim.WALL_WEIGHT_MAX)})
    # coordinates
    box = {"box": {"min": [0, 0, 0], "max": [1, 1, 1]}}
    assert _spec_accepts(selections={**BASE["selections"], "c": {"box": {"min": [-lim.COORD_MAX] * 3, "max": [1] * 3}}})
    assert not _spec_accepts(selections={**BASE["selections"],
                                         "c": {"box": {**box["box"], "max": [beyond(lim.COORD_MAX), 1, 1]}}})
    # vertex ids
    assert _schema_max(schemas, "Selection", "ids") == lim.ID_MAX
    assert _spec_accepts(selections={**BASE["selections"], "c": {"ids": [lim.ID_MAX]}})
    assert not _spec_accepts(selections={**BASE["selections"], "c": {"ids": [lim.ID_MAX + 1]}})
    # angles: a rotation of 1e6 degrees is a mistake, refused, not reduced modulo 360
    assert _schema_max(schemas, "Rotation", "angle_deg") == lim.ANGLE_MAX
    assert _move_accepts(rot=lim.ANGLE_MAX) and _move_accepts(rot=-lim.ANGLE_MAX)
    assert not _move_accepts(rot=beyond(lim.ANGLE_MAX)) and not _move_accepts(rot=1e6)
    # scales
    assert _schema_max(schemas, "HandleMove", "scale") == lim.SCALE_MAX
    assert _move_accepts(scale=lim.SCALE_MAX) and _move_accepts(scale=lim.SCALE_MIN)
    assert not _move_accepts(scale=beyond(lim.SCALE_MAX))
    assert not _move_accepts(scale=math.nextafter(lim.SCALE_MIN, 0))
    # target amounts
    assert _schema_max(schemas, "TargetMove", "amount") == lim.TARGET_AMOUNT_MAX
    assert _move_accepts(amount=lim.TARGET_AMOUNT_MAX) and not _move_accepts(amount=beyond(lim.TARGET_AMOUNT_MAX))
    # translations: EXTENT diagonals of the mesh, on both sides (the library's check is the service's)
    mb = MoveBounds(np.zeros(3), 1.0)
    assert _move_accepts(translation=[lim.EXTENT * 0.999, 0, 0], bounds=mb)
    assert not _move_accepts(translation=[lim.EXTENT * 1.001, 0, 0], bounds=mb)


def test_the_workflows_refuse_just_beyond_each_bound_the_schema_states():
    from solver import precompute
    from solver.mesh import mesh_from_arrays
    from solver.testing import cube_mesh
    from solver.workflows import parse_plan, parse_shapes, run_doe, shape_bounds

    d = precompute(mesh_from_arrays(*cube_mesh(2)), {
        "selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                       "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
        "fixed": ["a"], "handles": {"top": "b"}})
    shapes = parse_shapes({"shapes": {"lift": {"handles": {"top": {"translation": [0, 0, 0.1]}}}}}, d)
    plan = parse_plan([{"lift": 0.5}])

    def refused(call, **kw):
        try:
            call(**kw)
        except SpecError as e:
            return e.details.get("field") or e.code
        return None

    assert refused(run_doe, deformer=d, shapes=shapes, plan=plan, block=lim.BLOCK_MAX) is None
    assert refused(run_doe, deformer=d, shapes=shapes, plan=plan, block=lim.BLOCK_MAX + 1) == "block"
    assert refused(shape_bounds, deformer=d, shapes=shapes, block=lim.BLOCK_MAX + 1) == "block"
    assert refused(shape_bounds, deformer=d, shapes=shapes, tol=beyond(lim.BOUNDS_TOL_MAX)) == "tol"
    assert refused(shape_bounds, deformer=d, shapes=shapes, lo=-0.5, hi=beyond(lim.SHAPE_VALUE_MAX)) == "hi"
    assert refused(shape_bounds, deformer=d, shapes=shapes, lo=-beyond(lim.SHAPE_VALUE_MAX), hi=0.5) == "lo"
    assert refused(shape_bounds, deformer=d, shapes=shapes, lo=-0.5, hi=0.5, tol=lim.BOUNDS_TOL_MAX) is None
    columns = [f"s{k}" for k in range(lim.SHAPES_MAX + 1)]
    assert refused(parse_plan, rows=[[0.0] * len(columns)], columns=columns) == "invalid_plan"
    assert refused(parse_plan, rows=[[0.0] * lim.SHAPES_MAX], columns=columns[:-1]) is None
    too_many = {f"s{k}": {"handles": {"top": {"translation": [0, 0, 0.1]}}} for k in range(lim.SHAPES_MAX + 1)}
    assert refused(parse_shapes, doc={"shapes": too_many}, deformer=d) == "SHAPES.shapes"
    reserved = {"status": {"handles": {"top": {"translation": [0, 0, 0.1]}}}}
    assert refused(parse_shapes, doc={"shapes": reserved}, deformer=d) is not None


def test_the_service_refuses_a_rotation_of_a_million_degrees_naming_the_field(tmp_path):
    from tests.conftest import DATA

    from ..conftest import err, running

    spec = {"selections": {"a": {"set": "FIXED"}, "b": {"set": "LOAD"}}, "fixed": ["a"], "handles": {"b": "b"}}
    with running(tmp_path, load_kernels=False) as tc:
        mid = tc.post("/v1/meshes", files=[("file", ("bracket.inp", (DATA / "bracket.inp").read_bytes()))])
        sid = tc.post("/v1/sessions", json={"mesh_id": mid.json()["id"], "spec": spec}).json()["id"]
        for angle in (1e6, 1e300):
            r = tc.post(f"/v1/sessions/{sid}/deform?result=report",
                        json={"handles": {"b": {"rotation": {"axis": [0, 0, 1], "angle_deg": angle}}}})
            assert r.status_code == 422, r.text
            assert "angle_deg" in err(r)["message"]
        assert tc.get(f"/v1/sessions/{sid}").json()["version"] == 0  # nothing committed
