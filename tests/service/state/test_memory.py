"""Memory of a served process returns near its baseline after its sessions are deleted."""

from __future__ import annotations

import psutil
import pytest

from service.client import Client
from service.process import serve_process

from ..conftest import BRACKET, BRACKET_SPEC, MOVES

SESSIONS = 24


@pytest.mark.slow
def test_memory_returns_near_baseline_after_deleting_sessions(tmp_path, capsys):
    env = {"TETMORPH_MAX_SESSIONS": str(SESSIONS + 2), "TETMORPH_RATE_LIMIT_PER_S": "0"}
    with serve_process(tmp_path, env=env) as (url, proc), Client(url) as c:
        rss = psutil.Process(proc.pid).memory_info
        mid = c.upload_mesh(BRACKET)["id"]
        warm = c.create_session(mid, BRACKET_SPEC)["id"]  # code paths and kernels loaded once
        c.deform(warm, MOVES[0])
        c.delete_session(warm)
        base = rss().rss
        figures = []
        for _ in range(3):  # rounds of SESSIONS sessions, each deleted again
            sids = [c.create_session(mid, BRACKET_SPEC)["id"] for _ in range(SESSIONS)]
            for sid in sids:
                c.deform(sid, MOVES[1])
            peak = rss().rss
            held = sum(c.session(s)["factor_bytes"] for s in sids)
            for sid in sids:
                c.delete_session(sid)
            figures.append((peak, rss().rss, held))
            assert c.http.get("/health").json()["cache_bytes"] == 0
    mb = 2**20
    with capsys.disabled():
        for k, (peak, after, held) in enumerate(figures, 1):
            print(f"\n[memory] round {k}: {SESSIONS} sessions of {BRACKET.name} (factor_bytes {held / mb:.0f} MB): "
                  f"baseline {base / mb:.0f} MB, peak {peak / mb:.0f} MB (+{(peak - base) / mb:.0f}), after deleting "
                  f"{after / mb:.0f} MB (+{(after - base) / mb:.0f})")
    grown = figures[0][0] - base
    assert grown > 20 * mb  # the sessions did take memory
    assert figures[0][1] - base < 0.6 * grown, figures
    # Later rounds end about 12 MB higher each (24 sessions): a Deformer built outside the main thread keeps
    # about 0.5 MB after it is freed (reproduced with the library alone; the service builds in worker
    # threads). Bounded here so that a larger leak fails; the README gives the figures.
    per_round = (figures[-1][1] - figures[0][1]) / (len(figures) - 1)
    assert per_round < 0.5 * grown, figures
