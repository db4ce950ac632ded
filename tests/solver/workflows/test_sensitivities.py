"""Shape sensitivities against central differences of full solves (double-precision interior)."""

from __future__ import annotations

import numpy as np
import pytest

from solver import precompute
from solver.deform.solve import solve_positions_many
from solver.workflows import sensitivities as sens_mod
from solver.workflows.sensitivities import left_jacobian, rotation_derivative, shape_sensitivities
from solver.workflows.shapes import parse_shapes, variant_move
from tests.conftest import bend_spec, load
from tests.solver.workflows.conftest import constraint_spec, plate_shapes, plate_spec

TURNS = {"shapes": {
    "bend": {"handles": {"end": {"translation": [0, 0, 8], "rotation": {"axis": [0, 1, 0], "angle_deg": -6}}}},
    "twist": {"handles": {"end": {"rotation": {"axis": [1, 0, 0], "angle_deg": 4}}}},
    "shrink": {"handles": {"end": {"scale": 0.97}}},
    "hole1_x": {"handles": {"hole1": {"translation": [4, 0, 0]}}},
    "hole2_s": {"handles": {"hole2": {"scale": 1.05, "rotation": {"axis": [0, 0, 1], "angle_deg": 10}}}},
}}


def central_differences(d, shapes, theta, h=1e-2):
    """Fourth-order central differences (-f(2h) + 8 f(h) - 8 f(-h) + f(-2h)) / 12h of full solves, every shape."""
    moves = []
    for k in range(shapes.count):
        for step in (2 * h, h, -h, -2 * h):
            t = np.array(theta, float)
            t[k] += step
            moves.append(variant_move(d, shapes, t))
    P = [s.P for s in solve_positions_many(d.data, moves)]
    return np.stack([(-P[4 * k] + 8 * P[4 * k + 1] - 8 * P[4 * k + 2] + P[4 * k + 3]) / (12 * h)
                     for k in range(shapes.count)])


def assert_matches(S, fd, rel=1e-7):
    for k, name in enumerate(S.names):
        scale = np.abs(fd[k]).max()
        assert scale > 0, name
        err = np.abs(S.derivatives[k] - fd[k]).max()
        assert err <= rel * scale, (name, err, scale)


@pytest.mark.parametrize("mode", ["split", "joint"])
def test_handles_turned_moved_and_scaled(plate, plate_exact, mode):
    d = plate_exact if mode == "split" else precompute(plate, plate_spec(precision="exact", solve="joint"))
    assert d.solve_mode == mode and d.data.walls is not None  # the plate's thin-wall rows turn too
    shapes = parse_shapes(TURNS, d)
    theta = np.array([0.8, -1.5, 1.2, 0.6, 1.0])
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))
    assert np.abs(S.positions - d.solve_positions(variant_move(d, shapes, theta)).P).max() == 0
    # linear shapes: the derivative is the response to the shape itself (translations are exactly linear)
    lin = parse_shapes(plate_shapes(), d)
    S0 = shape_sensitivities(d, lin)
    for k in range(lin.count):
        one = d.solve_positions(variant_move(d, lin, np.eye(lin.count)[k] * 1e-3)).P
        if k == 0:
            continue  # bend turns the end: not linear
        assert np.abs(S0.derivatives[k] - (one - d.mesh.V) / 1e-3).max() <= 1e-9 * np.abs(S0.derivatives[k]).max()


@pytest.mark.parametrize("motion", [True, False])
def test_constraint_targets(plate, constrained, motion):
    """Rigid feature and turning relative pair (rotation-field targets), their scales, a point target and a
    motion plane (vector rows when ``motion``)."""
    d = constrained if motion else precompute(plate, constraint_spec(motion=False, precision="exact"))
    rest = d.data.constraints.rest
    doc = {"shapes": {
        "bend": TURNS["shapes"]["bend"],
        "gap_s": {"relative": {"gap": {"scale": 1.05}}},
        "grow": {"features": {"hole1": {"scale": 1.04}}},
        "corner": {"points": {"corner": (rest.points["corner"][0] + [0, 2, 3]).tolist()}},
    }}
    if motion:
        doc["shapes"]["slide"] = {"motion": {"slide": {"point": (rest.motion["slide"] + [0, 0, 0.5]).tolist()}}}
    shapes = parse_shapes(doc, d)
    theta = np.linspace(0.7, -0.4, shapes.count)
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))
    offset = (rest.relative["gap"] + [3, 1, 0]).tolist()
    offs = parse_shapes({"shapes": {"bend": TURNS["shapes"]["bend"],
                                    "gap_o": {"relative": {"gap": {"offset": offset}}}}}, d)
    So = shape_sensitivities(d, offs, [0.5, 0.7])
    assert_matches(So, central_differences(d, offs, [0.5, 0.7]))


def test_kinds_without_a_rule_are_differenced_exactly_when_linear(constrained, monkeypatch):
    d = constrained
    rest = d.data.constraints.rest
    shapes = parse_shapes({"shapes": {
        "bend": TURNS["shapes"]["bend"],
        "corner": {"points": {"corner": (rest.points["corner"][0] + [0, 2, 3]).tolist()}},
        "slide": {"motion": {"slide": {"point": (rest.motion["slide"] + [0, 0, 0.5]).tolist()}}}}}, d)
    theta = [0.3, 1.0, -1.0]
    exact = shape_sensitivities(d, shapes, theta)
    for kind in ("point", "motion"):
        monkeypatch.delitem(sens_mod.ANALYTIC, kind)
    diff = shape_sensitivities(d, shapes, theta)
    assert np.abs(diff.derivatives - exact.derivatives).max() <= 1e-9 * np.abs(exact.derivatives).max()


def test_quadratic_mesh():
    mesh = load("tet/segmenttet.inp")
    d = precompute(mesh, bend_spec(mesh, precision="exact"))
    assert d.data.midside is not None
    shapes = parse_shapes({"shapes": {
        "turn": {"handles": {"h": {"rotation": {"axis": [0, 0, 1], "angle_deg": 5}}}},
        "push": {"handles": {"h": {"translation": [0.5, 0.2, 0], "scale": 1.02}}}}}, d)
    theta = [1.0, 0.5]
    S = shape_sensitivities(d, shapes, theta)
    assert_matches(S, central_differences(d, shapes, theta))
    mid = np.unique(mesh.T10[:, 4:])
    assert np.abs(S.derivatives[:, mid]).max() > 0  # mid-side nodes follow


def test_mixed_precision_within_its_accuracy(plate_deformer, plate_exact):
    mixed = shape_sensitivities(plate_deformer, parse_shapes(TURNS, plate_deformer), [0.8, -1.5, 1.2, 0.6, 1.0])
    exact = shape_sensitivities(plate_exact, parse_shapes(TURNS, plate_exact), [0.8, -1.5, 1.2, 0.6, 1.0])
    for k in range(len(TURNS["shapes"])):
        scale = np.abs(exact.derivatives[k]).max()
        assert np.abs(mixed.derivatives[k] - exact.derivatives[k]).max() <= 1e-5 * scale


def rodrigues(phi, v):
    """Rotation of v by the rotation vector phi, written with complex-safe numpy (for complex steps)."""
    a = np.sqrt((phi * phi).sum())
    k = phi / a
    return v * np.cos(a) + np.cross(k, v) * np.sin(a) + k * (k @ v) * (2 * np.sin(a / 2) ** 2)


@pytest.mark.parametrize("size", [2.5, 0.4, 3e-3, 1.01e-4, 5e-5, 1e-7])
def test_left_jacobian_against_complex_steps(rng, size):
    """``d R(phi) v = (J_l(phi) dphi) x R(phi) v``, against the complex step of Rodrigues' formula
    (exact to round-off); small angles use the series branch."""
    for _ in range(5):
        phi, psi, v = size * rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
        cs = rodrigues(phi + 1e-30j * psi, v.astype(complex)).imag / 1e-30
        got = np.cross(left_jacobian(phi, psi[None, :])[0], rodrigues(phi, v))
        assert np.allclose(got, cs, rtol=0, atol=1e-13 * np.linalg.norm(v) * np.linalg.norm(psi))
        r, dr = phi / 2, psi / 2  # quaternion logarithms
        assert np.allclose(rotation_derivative(rodrigues(phi, v)[None, :], r, dr)[0], cs, rtol=0, atol=1e-13 * 10)
