"""The plate deck of tests/data/plate.inp (gmsh OCC, four holes) and the SPEC the constraint tests share."""

from __future__ import annotations

import numpy as np

from tests.conftest import DATA

PLATE = DATA / "plate.inp"
#: Hole radius and centres (mm), from make_plate.py.
RADIUS = 6.0
HOLES = {1: (160 / 3, 80 / 3), 2: (320 / 3, 80 / 3), 3: (160 / 3, 160 / 3), 4: (320 / 3, 160 / 3)}
#: The exact constraint methods.
EXACT = ("null_space", "kkt")
BEND = {"handles": {"tip": {"translation": [0, 0, 20], "rotation": {"axis": [0, 1, 0], "angle_deg": -25}}}}


def diag(m) -> float:
    """The mesh's bounding-box diagonal."""
    return float(np.linalg.norm(m.V.max(0) - m.V.min(0)))


def plate_spec(**extra):
    """FIXED end fixed, LOAD end the handle "tip", every hole a named selection."""
    sels = {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}, "bottom": {"set": "BOTTOM"},
            **{f"hole{k}": {"set": f"HOLE{k}"} for k in HOLES}}
    return {"selections": sels, "fixed": ["fix"], "handles": {"tip": "load"}, **extra}
