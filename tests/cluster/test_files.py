"""The checked-in cluster files agree with what the code generates, and HAProxy accepts them."""

from __future__ import annotations

import subprocess
from pathlib import Path

from service.cluster.haproxy import COMPOSE_SERVERS, render_config
from service.cluster.local import haproxy_binary

ROOT = Path(__file__).resolve().parents[2]


def test_compose_haproxy_config_is_the_generated_one_and_valid(tmp_path):
    cfg = ROOT / "docker" / "cluster" / "haproxy.cfg"
    assert cfg.read_text() == render_config(COMPOSE_SERVERS, "*:8100")
    local = tmp_path / "local.cfg"
    local.write_text(render_config([("r1", "127.0.0.1:1"), ("r2", "127.0.0.1:2")], "127.0.0.1:3"))
    r = subprocess.run([haproxy_binary(), "-c", "-f", str(local)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stdout + r.stderr
    compose = (ROOT / "docker" / "cluster" / "compose.yaml").read_text()
    for name, _ in COMPOSE_SERVERS:
        assert f"  {name}:" in compose
