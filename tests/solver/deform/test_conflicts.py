"""A refused conflict names its nodes, the selections that hold each, and the residual.

Real data: ``tests/data/plate.inp`` (FIXED and LOAD ends, the BOTTOM face, four holes).
The expected nodes and selections are computed here from the mesh's own sets.
"""
from __future__ import annotations

import pytest

from solver import ConstraintError, precompute, read_mesh
from tests.solver.plate import BEND, PLATE, plate_spec


@pytest.fixture(scope="module")
def plate():
    return read_mesh(PLATE)




def _holding(plate, v: int) -> list[str]:
    """The plate_spec selections that hold vertex ``v``, in SPEC order (from the deck's sets)."""
    sets = {"fix": "FIXED", "load": "LOAD", "bottom": "BOTTOM", **{f"hole{k}": f"HOLE{k}" for k in range(1, 5)}}
    return [name for name, s in sets.items() if v in set(plate.sets[s].tolist())]


def test_a_conflict_at_rest_names_its_nodes_regions_and_residual(plate):
    fixed = plate.sets["FIXED"]
    v, w = int(fixed[5]), int(fixed[9])
    spec = plate_spec(points=[{"name": "pull", "vertices": [v], "target": (plate.V[v] + [1, 0, 0]).tolist()},
                              {"name": "push", "vertices": [w], "target": (plate.V[w] + [0, 2, 0]).tolist()}],
                      conflicts="reject")
    with pytest.raises(ConstraintError) as e:
        precompute(plate, spec)
    d = e.value.details
    assert e.value.code == "conflicting_constraints"
    assert d["nodes"] == sorted([v, w])
    by_node = dict(zip(d["nodes"], d["regions"], strict=True))
    assert by_node[v] == _holding(plate, v) + ["point pull"]
    assert by_node[w] == _holding(plate, w) + ["point push"]
    assert "fix" in by_node[v] and "fix" in by_node[w]
    assert abs(d["residual"] - 2.0) < 1e-9  # the larger of the two misses, |(0, 2, 0)|


def test_a_move_that_makes_constraints_conflict_names_the_nodes(plate):
    v = int(plate.sets["FIXED"][5])
    d = precompute(plate, plate_spec(points=[{"name": "p", "vertices": [v]}], conflicts="reject"))
    with pytest.raises(ConstraintError) as e:
        d.solve({**BEND, "points": {"p": (plate.V[v] + [0, 0, 3]).tolist()}})
    det = e.value.details
    assert det["nodes"] == [v] and det["regions"] == [_holding(plate, v) + ["point p"]]
    assert abs(det["residual"] - 3.0) < 1e-9
    assert det["report"]["conflicting_constraints"][0]["vertices"] == [v]
