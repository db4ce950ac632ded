"""``doe`` on a two-node Ray cluster simulated on this machine, with one actor killed (SIGKILL) mid-run."""

from __future__ import annotations

import os
import signal

import pytest

from solver import read_mesh
from solver.workflows.ray_engine import NAMESPACE, run_doe_ray
from tests.solver.workflows.conftest import plate_shapes, plate_spec

from .ray_common import PLATE, plan, reference, same_decks


@pytest.fixture(scope="module")
def two_nodes():
    """Two Ray nodes of one CPU each, every server on 127.0.0.1, and this process connected to them.

    Ray turns a loopback bootstrap address into the machine's routable one
    unless its "no cluster" switch is set; the switch keeps the driver on the
    loopback address the nodes listen on.
    """
    import ray
    from ray._private import ray_constants
    from ray.cluster_utils import Cluster

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ray_constants, "ENABLE_RAY_CLUSTER", False)
        mp.setenv(ray_constants.ENABLE_RAY_CLUSTERS_ENV_VAR, "0")
        c = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "node_ip_address": "127.0.0.1",
                                                          "include_dashboard": False})
        try:
            c.add_node(num_cpus=1, node_ip_address="127.0.0.1")
            ray.init(address=c.address, namespace=NAMESPACE, log_to_driver=False)
            c.wait_for_nodes()
            yield ray
        finally:
            ray.shutdown()
            c.shutdown()


def test_the_cluster_has_two_nodes_on_the_loopback_address(two_nodes):
    nodes = [n for n in two_nodes.nodes() if n["Alive"]]
    assert len(nodes) == 2 and {n["NodeManagerAddress"] for n in nodes} == {"127.0.0.1"}
    assert [n["Resources"]["CPU"] for n in nodes] == [1.0, 1.0]


def test_a_killed_actor_loses_no_row_and_writes_none_twice(tmp_path, two_nodes):
    ray = two_nodes
    rows, block = 24, 2
    p = plan(rows)
    reference(tmp_path / "ref", p, block=block)
    killed: list[int] = []
    nodes: set[str] = set()
    pids: list[int] = []

    def progress(done: int, total: int) -> None:
        # An actor answers one call at a time, so asking it waits for its block in flight: ask at the
        # first block, kill at the next one, when actor 0 holds a block it has not returned.
        if not pids:
            for k in range(2):
                nodes.add(ray.get(ray.get_actor(f"killtest-{k}", namespace=NAMESPACE).node.remote()))
            pids.append(ray.get(ray.get_actor("killtest-0", namespace=NAMESPACE).pid.remote()))
        elif not killed:
            os.kill(pids[0], signal.SIGKILL)
            killed.append(pids[0])

    out = tmp_path / "ray"
    r = run_doe_ray(read_mesh(PLATE), plate_spec(), plate_shapes(), p, output=str(out / "plate_{i}.inp"),
                    block=block, actors=2, progress=progress, name="killtest")
    assert len(nodes) == 2, "the two actors ran on one node"
    assert killed and r.timings["retried_blocks"] >= 1
    assert [v.row for v in r.variants] == list(range(1, rows + 1))  # every row once, in plan order
    assert sorted(v.file for v in r.variants) == sorted(str(out / f"plate_{i}.inp") for i in range(1, rows + 1))
    same_decks(tmp_path / "ref", out, rows)  # each deck once, bit for bit the single process's
    assert sorted(os.listdir(tmp_path)) == ["ray", "ref"]  # no attempt folder left behind
    assert sorted(os.listdir(out)) == sorted(f"plate_{i}.inp" for i in range(1, rows + 1))
