"""Properties of the deformation: identity, rigid motions, exact constraints, joint = split."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from solver import (
    ConstraintError,
    InversionError,
    SpecError,
    mesh_from_arrays,
    precompute,
    read_mesh,
)
from solver.constraints.move import axis_angle_matrix
from solver.linalg import factorization as fz
from solver.testing import cube_mesh, sphere_surface
from solver.validity.quality import signed_volumes
from tests.conftest import DATA, bend_move, bend_spec, load, longest_axis, slab

REAL = ["Armadillo13K.msh", "screw.msh", "beam.node"]


def _bend_move(mesh, angle=20.0, frac=0.1):
    ax, diag = longest_axis(mesh)
    side = (ax + 1) % 3
    rot_axis = np.zeros(3)
    rot_axis[(ax + 2) % 3] = 1.0
    t = np.zeros(3)
    t[side] = frac * diag
    return {"handles": {"h": {"translation": t.tolist(),
                              "rotation": {"axis": rot_axis.tolist(), "angle_deg": angle}}}}


def _cube():
    return mesh_from_arrays(*cube_mesh(4))


def _rigid(rng):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = float(rng.uniform(-150, 150))
    t = rng.normal(size=3)
    return axis, angle, t


_CACHE = {}


def _cube_deformer():
    if "d" not in _CACHE:
        m = _cube()
        _CACHE["d"] = precompute(m, bend_spec(m))
    return _CACHE["d"]


@pytest.mark.parametrize("name", REAL)
def test_zero_move_is_identity(name):
    m = load(name)
    d = precompute(m, bend_spec(m))
    r = d.solve({"handles": {}})
    _, diag = longest_axis(m)
    assert np.abs(r.V - m.V).max() <= 1e-10 * diag
    assert r.report["inverted_elements"] == 0


@pytest.mark.parametrize("name", ["Armadillo13K.msh", "beam.node", "screw.msh"])
@pytest.mark.parametrize("solve", ["split", "joint"])
def test_rigid_motion_of_all_constraints_moves_mesh_rigidly(name, solve, rng):
    m = load(name)
    spec = {"selections": {"a": slab(m, 0, 0.1), "b": slab(m, 0.9, 1.0)},
            "handles": {"a": "a", "b": "b"}, "solve": solve}
    d = precompute(m, spec)
    axis, angle, t = _rigid(rng)
    R = axis_angle_matrix(axis, np.radians(angle))
    pivot = m.V[m.referenced].mean(0)
    hm = {"translation": t.tolist(), "rotation": {"axis": axis.tolist(), "angle_deg": angle},
          "pivot": pivot.tolist()}
    r = d.solve({"handles": {"a": hm, "b": hm}})
    expect = pivot + t + (m.V - pivot) @ R.T
    _, diag = longest_axis(m)
    assert np.abs(r.V - expect).max() <= 1e-8 * diag
    assert r.report["inverted_elements"] == 0


def test_uniform_scale_of_all_constraints_scales_mesh():
    m = load("beam.node")
    spec = {"selections": {"a": slab(m, 0, 0.1), "b": slab(m, 0.9, 1.0)}, "handles": {"a": "a", "b": "b"}}
    d = precompute(m, spec)
    pivot = [0.0, 0.5, 0.0]
    hm = {"scale": 1.7, "pivot": pivot}
    r = d.solve({"handles": {"a": hm, "b": hm}})
    np.testing.assert_allclose(r.V, pivot + 1.7 * (m.V - pivot), atol=1e-9)


@pytest.mark.parametrize("name", REAL)
@pytest.mark.parametrize("solve", ["split", "joint"])
def test_hard_constraints_exact_on_real_meshes(name, solve):
    m = load(name)
    d = precompute(m, bend_spec(m, solve=solve))
    mv = _bend_move(m, angle=25.0)
    r = d.solve(mv)
    _, diag = longest_axis(m)
    fixed = d.data.constraints.handle_ids  # handle targets, recomputed independently below
    ids = fixed["h"]
    c = m.V[ids].mean(0)
    h = mv["handles"]["h"]
    R = axis_angle_matrix(np.array(h["rotation"]["axis"]), np.radians(h["rotation"]["angle_deg"]))
    target = c + np.array(h["translation"]) + (m.V[ids] - c) @ R.T
    assert np.abs(r.V[ids] - target).max() <= 1e-10 * diag
    fix = np.flatnonzero(d.data.constraints.owner == -2)
    assert fix.size and np.abs(r.V[fix] - m.V[fix]).max() == 0.0
    assert r.report["constraint_residual_max"] <= 1e-10 * diag
    assert np.isfinite(r.V).all()


@pytest.mark.parametrize("name", ["Armadillo13K.msh", "screw.msh", "wheelset.vtk"])
def test_joint_and_split_agree_when_no_interior_vertex_is_constrained(name):
    m = load(name)
    if name == "wheelset.vtk":  # three bodies: constrain each
        spec = {"selections": {"fix": slab(m, 0, 0.1, boundary_only=True),
                               "hand": slab(m, 0.9, 1.0, boundary_only=True)},
                "fixed": ["fix"], "handles": {"h": "hand"}}
        spec["selections"]["mid"] = slab(m, 0.45, 0.55, boundary_only=True)
        spec["fixed"].append("mid")
    else:
        spec = bend_spec(m, boundary_only=True)
    mv = _bend_move(m)
    try:
        a = precompute(m, {**spec, "solve": "split"}).solve(mv).V
    except ConstraintError:
        pytest.fail("spec leaves a body unconstrained")
    b = precompute(m, {**spec, "solve": "joint"}).solve(mv).V
    _, diag = longest_axis(m)
    assert np.abs(a - b).max() <= 1e-8 * diag


@pytest.mark.parametrize("name", ["Armadillo13K.msh", "beam.node"])
def test_moderate_bend_inverts_nothing_and_count_is_independent(name):
    m = load(name)
    d = precompute(m, bend_spec(m))
    r = d.solve(_bend_move(m, angle=20.0, frac=0.1))
    vol = signed_volumes(r.V, m.T)
    assert r.report["inverted_elements"] == int((vol <= 0).sum()) == 0
    # and a violent move: the report must match an independent count
    r2 = d.solve(_bend_move(m, angle=120.0, frac=0.6))
    vol2 = signed_volumes(r2.V, m.T)
    assert r2.report["inverted_elements"] == int((vol2 <= 0).sum())
    assert r2.report["inverted_ids"] == np.flatnonzero(vol2 <= 0)[:100].tolist()


def test_update_never_refactorizes():
    m = load("Armadillo13K.msh")
    d = precompute(m, bend_spec(m))
    assert d.factorizations >= 2  # rotation + positions were factored in setup
    before = fz.STATS["factorizations"]
    solves = fz.STATS["solves"]
    for ang in (5, 10, 15):
        r = d.solve(_bend_move(m, angle=ang))
        assert r.report["refactorized"] is False
    assert fz.STATS["factorizations"] == before
    assert fz.STATS["solves"] > solves


def test_repeated_solves_identical_and_precompute_equals_one_shot():
    m = load("screw.msh")
    spec = bend_spec(m)
    d = precompute(m, spec)
    mv = _bend_move(m, angle=15)
    a = d.solve(mv).V
    assert np.array_equal(a, d.solve(mv).V)
    np.testing.assert_array_equal(a, precompute(m, spec).solve(mv).V)


def test_reject_policy_raises_with_report():
    m = load("beam.node")
    d = precompute(m, bend_spec(m, inversion="reject"))
    ax, diag = longest_axis(m)
    through = np.zeros(3)
    through[ax] = -1.5 * diag  # push the tip back through the fixed root
    with pytest.raises(InversionError) as e:
        d.solve({"handles": {"h": {"translation": through.tolist()}}})
    assert e.value.report["inverted_elements"] > 0
    assert d.solve(_bend_move(m, angle=5.0)).report["inverted_elements"] == 0


def test_penalty_residual_shrinks_with_beta():
    m = _cube()
    res = []
    for beta in (1e1, 1e3, 1e5):
        d = precompute(m, bend_spec(m, constraints={"method": "penalty", "penalty_weight": beta}))
        res.append(d.solve(_bend_move(m)).report["constraint_residual_max"])
    assert res[0] > res[1] > res[2] > 0
    hard = precompute(m, bend_spec(m)).solve(_bend_move(m)).V
    pen = precompute(m, bend_spec(m, constraints={"method": "penalty", "penalty_weight": 1e6}))
    assert np.abs(pen.solve(_bend_move(m)).V - hard).max() < 1e-3


@pytest.mark.parametrize("opts", [{"laplacian": "uniform"}, {"rotation": "least_squares"}])
def test_options_keep_constraints_exact(opts):
    m = load("Armadillo13K.msh")
    d = precompute(m, bend_spec(m, **opts))
    r = d.solve(_bend_move(m))
    assert r.report["constraint_residual_max"] == 0.0 and np.isfinite(r.V).all()


def test_surface_only_mesh_is_deformed_by_boundary_rows():
    m = read_mesh(DATA / "42400-IDGH.stl")
    assert m.is_surface
    d = precompute(m, bend_spec(m))
    r = d.solve(_bend_move(m, angle=10))
    assert np.isfinite(r.V).all() and r.report["constraint_residual_max"] == 0.0
    V, F = sphere_surface(3)
    s = mesh_from_arrays(V, surface=F)
    d = precompute(s, {"selections": {"n": {"box": {"min": [-1, -1, 0.9], "max": [1, 1, 1]}},
                                      "s": {"box": {"min": [-1, -1, -1], "max": [1, 1, -0.9]}}},
                       "fixed": ["s"], "handles": {"n": "n"}})
    assert np.abs(d.solve({"handles": {}}).V - V).max() < 1e-12


def test_internal_voids_without_constraint_are_refused_when_asked():
    m = load("cones_with_cavities.inp")
    assert m.info()["boundary_shells"] == 3
    with pytest.raises(ConstraintError) as e:
        precompute(m, bend_spec(m, boundary_only=True, voids="refuse"))
    assert e.value.code == "unconstrained_shell"
    assert "internal void" in e.value.message


def test_internal_voids_move_with_the_volume_around_them():
    """cones_with_cavities.inp (FinEtools, MIT): two cavities with no constraint on them."""
    m = load("cones_with_cavities.inp")
    spec = bend_spec(m, boundary_only=True)
    d = precompute(m, spec)
    assert d.solve_mode == "joint" and d.data.constraints.free_shell.sum() == 61 + 37
    with pytest.raises(SpecError, match="split"):
        precompute(m, {**spec, "solve": "split"})
    r = d.solve(bend_move(m, 20, 0.1))
    assert r.report["inverted_elements"] == 0 and r.report["finite"]
    void = np.flatnonzero(d.data.constraints.free_shell)
    assert np.linalg.norm(r.V[void] - m.V[void], axis=1).min() > 0  # the cavities moved
    # with one handle and nothing fixed, a translation or a rotation moves everything rigidly,
    # the cavities included: the volume positions them (translation by the mean-value rows,
    # rotation by the field extended through the tets)
    d1 = precompute(m, {"selections": {"hand": spec["selections"]["hand"]}, "handles": {"h": "hand"}})
    _, diag = longest_axis(m)
    t = np.array([1.0, 2.0, 3.0])
    P = d1.solve({"handles": {"h": {"translation": t.tolist()}}}).V
    assert np.abs(P[void] - m.V[void] - t).max() <= 1e-12 * diag
    R = axis_angle_matrix(np.array([0.0, 0, 1]), np.radians(30))
    c = m.V[d1.data.constraints.handle_ids["h"]].mean(0)
    P = d1.solve({"handles": {"h": {"rotation": {"axis": [0, 0, 1], "angle_deg": 30}}}}).V
    assert np.abs(P[void] - (c + (m.V[void] - c) @ R.T)).max() <= 1e-10 * diag


def test_body_without_constraint_is_refused():
    V, T = cube_mesh(1)
    V2 = np.vstack([V, V + [3, 0, 0]])
    T2 = np.vstack([T, T + len(V)])
    m = mesh_from_arrays(V2, T2)
    with pytest.raises(ConstraintError) as e:
        precompute(m, {"selections": {"a": {"ids": [0]}}, "fixed": ["a"]})
    assert e.value.code == "unconstrained_component"
    assert "body 1" in e.value.message


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3), st.floats(-60, 60), st.floats(0.5, 2.0))
def test_random_moves_keep_constraints_exact(t, angle, scale):
    m = _cube()
    d = _cube_deformer()
    mv = {"handles": {"h": {"translation": t, "rotation": {"axis": [1, 1, 0], "angle_deg": angle},
                            "scale": scale}}}
    r = d.solve(mv)
    assert np.isfinite(r.V).all()
    assert r.report["constraint_residual_max"] <= 1e-12
    assert np.abs(r.V[d.data.constraints.owner == -2] - m.V[d.data.constraints.owner == -2]).max() == 0.0
