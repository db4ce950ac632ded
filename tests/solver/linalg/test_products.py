"""The fused products against scipy's, on a real boundary system, and their shape errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from solver import precompute
from solver.linalg.products import combination, gradient, offset_product, product, shifted_product, stacked_differences
from tests.conftest import bend_spec, load


@pytest.fixture(scope="module")
def systems():
    mesh = load("Armadillo13K.msh")
    pos = precompute(mesh, bend_spec(mesh)).data.positions
    return mesh, pos


def test_gradient_matches_scipy_plain_and_stacked(systems):
    _, pos = systems
    A, At = pos.system.A, pos.system.At
    rng = np.random.default_rng(0)
    x = rng.standard_normal((A.shape[1], 12))
    c = rng.standard_normal((A.shape[0], 12))
    ref = At @ (c - A @ x)
    scale = np.abs(ref).max()
    assert np.abs(gradient(A, At, c, x) - ref).max() <= 1e-12 * scale
    stacked = np.stack([c[:, 3 * j:3 * j + 3] for j in range(4)])  # (4, l, 3)
    assert np.abs(gradient(A, At, stacked, x) - ref).max() <= 1e-12 * scale


def test_interior_products_match_scipy(systems):
    mesh, pos = systems
    rng = np.random.default_rng(1)
    P = mesh.V + rng.standard_normal(mesh.V.shape)
    D = P[pos.coupled] - pos.rest_coupled
    ref = pos.Mfb @ D + pos.r0
    got = shifted_product(pos.Mfb, pos.coupled, P, pos.rest_coupled, pos.r0)
    assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()
    P2 = P + 1.0
    D2 = np.hstack([D, P2[pos.coupled] - pos.rest_coupled])
    assert np.array_equal(stacked_differences([P, P2], pos.coupled, pos.rest_coupled), D2)
    ref2 = pos.Mfb @ D2 + np.tile(pos.r0, (1, 2))
    assert np.abs(offset_product(pos.Mfb, D2, pos.r0) - ref2).max() <= 1e-12 * np.abs(ref2).max()
    F = stacked_differences([P, P2], pos.coupled, pos.rest_coupled, order="F")
    assert F.flags.f_contiguous and np.array_equal(F, D2)
    ref3 = pos.Mfb @ D2
    assert np.abs(product(pos.Mfb, D2) - ref3).max() <= 1e-12 * np.abs(ref3).max()


def test_combination_sums_in_double_and_stores_the_asked_precision():
    rng = np.random.default_rng(2)
    W = rng.standard_normal((2000, 7)).astype(np.float32)
    C = rng.standard_normal((7, 30))
    ref = W.astype(np.float64) @ C
    got = combination(W, C)
    assert got.dtype == np.float64 and np.abs(got - ref).max() <= 1e-13 * np.abs(ref).max()
    single = combination(W, C, np.float32)
    assert single.dtype == np.float32
    # one rounding of the double sum (half a float32 unit), not a sum in float32
    assert (np.abs(single - ref) <= 2.0 ** -24 * np.abs(ref) * (1 + 1e-9)).all()


def test_shapes_that_do_not_agree_are_named():
    A = sp.csr_matrix(np.eye(3))
    with pytest.raises(ValueError, match="gradient"):
        gradient(A, A, np.ones((3, 2)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="offset_product"):
        offset_product(A, np.ones((3, 4)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="product: M"):
        product(A, np.ones((4, 2)))
    with pytest.raises(ValueError, match="combination"):
        combination(np.ones((3, 2)), np.ones((3, 2)))
    with pytest.raises(ValueError, match="shifted_product"):
        shifted_product(A, np.arange(2), np.ones((3, 3)), np.ones((2, 3)), np.ones((3, 3)))


def test_coupled_residual_norms_match_the_formed_right_hand_side(systems):
    from solver.linalg.residual import block_residual, coupled_residual_norms

    mesh, pos = systems
    rng = np.random.default_rng(4)
    D = rng.standard_normal((pos.coupled.size, 12))
    X = rng.standard_normal((pos.free_interior.size, 12))
    B = pos.Mfb @ D + np.tile(pos.r0, (1, 4))
    _, r_ref, x_ref = block_residual(pos.Mff, B, X, 3)
    for Xs in (X, X.astype(np.float32)):
        _, r_ref, x_ref = block_residual(pos.Mff, B, Xs, 3)
        r, x = coupled_residual_norms(pos.Mff, pos.Mfb, pos.r0, D, Xs, 3)
        np.testing.assert_allclose(r, r_ref, rtol=1e-12)
        np.testing.assert_array_equal(x, x_ref)
    with pytest.raises(ValueError, match="coupled_residual_norms"):
        coupled_residual_norms(pos.Mff, pos.Mfb, pos.r0, D[:, :5], X[:, :5], 3)
