"""The demo loaded by ``make run``: the bundled TetGen beam, a session, a first MOVE."""

from __future__ import annotations

import json
import logging
from pathlib import Path

from .state.registry import Registry

__all__ = ["DEMO_DIR", "DEMO_MESH", "DEMO_SESSION", "load_demo"]

log = logging.getLogger("tetmorph.service")

DEMO_DIR = Path(__file__).resolve().parents[1] / "examples" / "beam"
DEMO_MESH = "m_demo_beam"
DEMO_SESSION = "s_demo"


async def load_demo(reg: Registry, owner: str) -> None:
    """Store the demo beam and a ready session for ``owner`` unless already there."""
    if not DEMO_DIR.is_dir():
        log.warning("demo data not found at %s; starting without a demo", DEMO_DIR)
        return
    if reg.store.mesh_meta(DEMO_MESH) is None:
        files = {p.name: p.read_bytes() for p in (DEMO_DIR / "beam.node", DEMO_DIR / "beam.ele")}
        await reg.catalogue.add(owner, "beam.node", "tetgen", files, "beam.node", mesh_id=DEMO_MESH)
    if DEMO_SESSION not in reg.sessions:
        spec = json.loads((DEMO_DIR / "spec.json").read_text())
        s = await reg.sessions.create(owner, DEMO_MESH, spec, session_id=DEMO_SESSION)
        moves = json.loads((DEMO_DIR / "moves.json").read_text())
        await reg.moves.deform(s, moves[-1])
