"""``doe`` on a local Ray (``ray.init(num_cpus=2)``): bit for bit the single-process run; the CLI; the service."""

from __future__ import annotations

import io
import json
import time
import zipfile

import pytest

from solver import read_mesh
from solver.workflows import read_plan, write_summary
from solver.workflows.ray_engine import connect, run_doe_ray
from tests.solver.workflows.conftest import PLAN, SHAPES, SPEC, plate_shapes, plate_spec

from ..service.conftest import running
from .ray_common import PLATE, plan, reference, same_decks


@pytest.fixture(scope="module")
def ray_local():
    ray, started = connect(None, num_cpus=2)
    assert started, "a Ray was already connected in this process"
    yield ray
    ray.shutdown()


def test_two_actors_give_the_single_process_decks_and_summary(tmp_path, ray_local):
    p = plan(10)
    ref = reference(tmp_path / "ref", p, block=3)
    r = run_doe_ray(read_mesh(PLATE), plate_spec(), plate_shapes(), p, output=str(tmp_path / "ray" / "plate_{i}.inp"),
                    block=3, actors=2)
    assert r.timings["actors"] == 2 and r.timings["retried_blocks"] == 0
    same_decks(tmp_path / "ref", tmp_path / "ray", 10)
    write_summary(r, tmp_path / "ray.csv")
    ref_csv = (tmp_path / "ref" / "summary.csv").read_text().replace(str(tmp_path / "ref"), "X")
    assert (tmp_path / "ray.csv").read_text().replace(str(tmp_path / "ray"), "X") == ref_csv
    assert [v.row for v in r.variants] == list(range(1, 11)) and [v.row for v in ref.variants] == list(range(1, 11))


def test_cli_engine_ray(tmp_path, ray_local):
    from service.cli import main

    out = tmp_path / "cli"
    assert main(["doe", str(PLATE), "--spec", str(SPEC), "--shapes", str(SHAPES), "--plan", str(PLAN), "--output",
                 str(out / "plate_{i}.inp"), "--summary", str(out / "summary.csv"), "--block", "3", "--engine", "ray",
                 "--actors", "2"]) == 0
    reference(tmp_path / "ref", read_plan(PLAN), block=3)
    same_decks(tmp_path / "ref", out, 8)


def test_a_bad_plan_fails_before_anything_is_solved(tmp_path, ray_local):
    from solver import SpecError
    from solver.workflows import parse_plan

    with pytest.raises(SpecError) as e:
        run_doe_ray(read_mesh(PLATE), plate_spec(), plate_shapes(), parse_plan([[1.0]], ["twist"]),
                    output=str(tmp_path / "x_{i}.inp"))
    assert e.value.code == "unknown_shape"
    assert not (tmp_path / "x_1.inp").exists()


def test_service_batch_on_ray(tmp_path, ray_local):
    address = ray_local.get_runtime_context().gcs_address
    reference(tmp_path / "ref", read_plan(PLAN), block=3)
    with running(tmp_path / "data", ray_address=address, ray_actors=2) as tc:
        mid = tc.post("/v1/meshes", files=[("file", ("plate.inp", PLATE.read_bytes()))]).json()["id"]
        sid = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": json.loads(SPEC.read_text())}).json()["id"]
        r = tc.post(f"/v1/sessions/{sid}/batch", json={"shapes": plate_shapes()["shapes"], "plan": PLAN.read_text(),
                                                       "engine": "ray", "block": 3})
        assert r.status_code == 202, r.text
        deadline = time.monotonic() + 180
        while (doc := tc.get(r.headers["location"]).json())["status"] in ("queued", "running"):
            assert time.monotonic() < deadline
            time.sleep(0.2)
        assert doc["status"] == "done" and doc["summary"]["engine"] == "ray", doc
        z = zipfile.ZipFile(io.BytesIO(tc.get(doc["result"]).content))
        out = tmp_path / "zip"
        z.extractall(out)
        same_decks(tmp_path / "ref", out, 8)
        assert not [p for p in (tmp_path / "data" / "jobs").rglob("*") if p.is_file() and p.suffix != ".zip"]
