"""Shared set-ups of the workflow tests: the plate deck with its holes as handles (tests/data/plate.inp)."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from solver import precompute
from tests.conftest import DATA, load

HERE = pathlib.Path(__file__).parent / "data"
PLATE = DATA / "plate.inp"
SPEC = HERE / "plate_spec.json"
SHAPES = HERE / "plate_shapes.json"
PLAN = HERE / "plate_plan.csv"


def plate_spec(**extra) -> dict:
    return {**json.loads(SPEC.read_text()), **extra}


def plate_shapes() -> dict:
    return json.loads(SHAPES.read_text())


@pytest.fixture(scope="session")
def plate():
    return load("plate.inp")


@pytest.fixture(scope="session")
def plate_deformer(plate):
    """The README example's deformer (default SPEC options: mixed precision)."""
    return precompute(plate, plate_spec())


@pytest.fixture(scope="session")
def plate_exact(plate):
    """The same SPEC with the double-precision interior solve."""
    return precompute(plate, plate_spec(precision="exact"))


def constraint_spec(motion: bool = True, **extra) -> dict:
    """Clamp fixed, end a handle; hole 1 a rigid feature, holes 3-4 a relative pair (turning), a corner
    node held at a point target, and (``motion``) hole 2's centre sliding in its plane."""
    mesh = load("plate.inp")
    corner = int(np.argmin(np.linalg.norm(mesh.V - [150.0, 75.0, 4.0], axis=1)))
    spec = {"selections": {"clamp": {"set": "FIXED"}, "end": {"set": "LOAD"}, "hole1": {"set": "HOLE1"},
                           "hole2": {"set": "HOLE2"}, "hole3": {"set": "HOLE3"}, "hole4": {"set": "HOLE4"}},
            "fixed": ["clamp"], "handles": {"end": "end"},
            "features": [{"selection": "hole1", "mode": "rigid"}],
            "relative": [{"name": "gap", "points": [{"selection": "hole3"}, {"selection": "hole4"}],
                          "mode": "rotate"}],
            "points": [{"name": "corner", "vertices": [corner]}], **extra}
    if motion:
        spec["motion"] = [{"name": "slide", "selection": "hole2", "plane": {"normal": [0, 0, 1]}}]
    return spec


@pytest.fixture(scope="session")
def constrained(plate):
    """:func:`constraint_spec` (vector rows: the motion plane), double-precision interior."""
    return precompute(plate, constraint_spec(precision="exact"))
