"""The service accepts the SPEC forms of the constraint engine: symmetry, cyclic, surface ties, POINT pairs."""

from __future__ import annotations

from service.models.spec import Spec


def test_symmetry_cyclic_surface_ties_points_and_precision_are_accepted():
    doc = {"selections": {"a": {"set": "A"}, "b": {"set": "B"}}, "fixed": ["a"], "handles": {"h": "b"},
           "symmetry": [{"name": "mid", "plane": {"point": [50, 0, 0], "normal": [1, 0, 0]}, "tolerance": 1e-3}],
           "cyclic": [{"name": "c", "axis": {"point": [0, 0, 0], "direction": [0, 0, 1]}, "angle_deg": 30,
                       "faces": ["a", "b"]}],
           "ties": {"surface": [["a", "b"]], "surface_tolerance": 0.01},
           "relative": [{"name": "r", "points": [{"selection": "a"}, {"selection": "b"}], "mode": "translate"}],
           "precision": "exact"}
    assert Spec.model_validate(doc).dump() == doc
