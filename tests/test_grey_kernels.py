"""Grey kernels against closed forms, literal sums and numpy.linalg.lstsq."""

import warnings

import numpy as np
import pytest

from greyml.exceptions import GreyConditioningWarning
from greyml.grey._functions import fit_gm1n
from greyml.grey._kernels import ago, gm1n_design, gmc_lstsq, iago
from greyml.grey._response import (
    gmc_basis,
    gmc_predict,
    gmc_predict_population,
    gmc_response,
    gmc_separable,
    gmc_sse_population,
)
from greyml.optimize._base import PENALTY


def literal_trapezoid(f, b1, x0):
    """DOMAIN.md's trapezoid time response, summed term by term (O(n²))."""
    n = len(f)
    out = [x0]
    for k in range(2, n + 1):
        s = x0 * np.exp(-b1 * (k - 1)) + 0.5 * np.exp(-b1 * (k - 1)) * f[0]
        s += sum(np.exp(-b1 * (k - t)) * f[t - 1] for t in range(2, k))
        out.append(s + 0.5 * f[k - 1])
    return np.array(out)


def literal_midpoint(f, b1, x0):
    """Abdulshahed et al.'s (2016) midpoint variant, summed term by term."""
    n = len(f)
    out = [x0]
    for k in range(2, n + 1):
        s = x0 * np.exp(-b1 * (k - 1))
        s += sum(0.5 * np.exp(-b1 * (k - t + 0.5)) * (f[t - 1] + f[t - 2]) for t in range(2, k + 1))
        out.append(s)
    return np.array(out)


@pytest.mark.parametrize("b1", [-0.2, 0.0, 0.37, 3.0])
def test_recursion_equals_literal_sums(b1):
    f = np.random.default_rng(0).normal(size=40)
    np.testing.assert_allclose(
        gmc_response(f, b1, 1.3), literal_trapezoid(f, b1, 1.3), rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(
        gmc_response(f, b1, 1.3, "midpoint"),
        literal_midpoint(f, b1, 1.3),
        rtol=1e-12,
        atol=1e-12,
    )


def test_hand_computed_response():
    # b1 = 0 (a = 1), f = [1, 1, 1], x0 = 0: trapezoid x̂(2) = ½·1 + ½·1 = 1, x̂(3) = ½ + 1 + ½ = 2
    np.testing.assert_allclose(gmc_response(np.ones(3), 0.0, 0.0), [0.0, 1.0, 2.0])


def gm1n_data(a, b, n=50, seed=0, bounds=None):
    """x₁ generated exactly from x₁⁰(k) + a·z₁(k) = Σ bⱼ xⱼ¹(k)."""
    rng = np.random.default_rng(seed)
    X = 1.0 + rng.random((n, len(b)))
    y = np.empty(n)
    for start, stop in bounds or [(0, n)]:
        X1 = np.cumsum(X[start:stop], axis=0)
        y[start] = 1.0
        acc = y[start]
        for k in range(1, stop - start):
            rhs = X1[k] @ b
            y[start + k] = (rhs - a * acc) / (1.0 + a / 2.0)
            acc += y[start + k]
    return X, y


def test_gm1n_recovers_noise_free_coefficients():
    a, b = 0.35, np.array([0.4, -0.25, 0.1])
    X, y = gm1n_data(a, b)
    a_hat, b_hat = fit_gm1n(X, y)
    assert abs(a_hat - a) < 1e-10
    np.testing.assert_allclose(b_hat, b, atol=1e-10)


def test_gm1n_design_sign_and_lstsq_with_noise():
    a, b = 0.35, np.array([0.4, -0.25, 0.1])
    X, y = gm1n_data(a, b, seed=3)
    y = y + np.random.default_rng(1).normal(scale=0.05, size=y.size)
    B, Y = gm1n_design(y, X)
    z1 = 0.5 * (np.cumsum(y)[1:] + np.cumsum(y)[:-1])
    np.testing.assert_allclose(B[:, 0], -z1)  # B = [−z₁, x₂¹, …], the corrected sign
    theta = np.linalg.lstsq(B, Y, rcond=None)[0]
    a_hat, b_hat = fit_gm1n(X, y)
    np.testing.assert_allclose(np.r_[a_hat, b_hat], theta, rtol=0, atol=1e-12)


def test_gm1n_never_crosses_tests():
    a, b = 0.2, np.array([0.3, 0.1])
    bounds = [(0, 30), (30, 70)]
    X, y = gm1n_data(a, b, n=70, bounds=bounds)
    import pandas as pd

    from greyml import make_test_index

    idx = make_test_index(["A"] * 30 + ["B"] * 40, list(range(30)) + list(range(40)))
    a_hat, b_hat = fit_gm1n(pd.DataFrame(X, index=idx), pd.Series(y, index=idx))
    assert abs(a_hat - a) < 1e-10 and np.allclose(b_hat, b, atol=1e-10)
    # treated as one sequence the same data does not fit the equation
    a_bad, _ = fit_gm1n(X, y)
    assert abs(a_bad - a) > 1e-6


def test_gm1n_rank_deficient_warns_and_is_finite():
    X, y = gm1n_data(0.3, np.array([0.5, 0.2]))
    X = np.column_stack([X, X[:, 0]])
    with pytest.warns(GreyConditioningWarning, match="rank deficient"):
        a, b = fit_gm1n(X, y)
    assert np.isfinite(a) and np.isfinite(b).all()


def test_gmc_lstsq_recovers_its_own_equation():
    # y built so that x₁⁰(k) + b₁z₁(k) = Σ bⱼ zⱼ(k) + u holds exactly
    rng = np.random.default_rng(5)
    n, b1, b, u = 60, 0.4, np.array([0.7, -0.2]), 0.3
    X = 1 + rng.random((n, 2))
    zX = 0.5 * (np.cumsum(X, 0)[1:] + np.cumsum(X, 0)[:-1])
    y = np.empty(n)
    y[0], acc = 0.5, 0.5
    for k in range(1, n):
        y[k] = (zX[k - 1] @ b + u - b1 * (acc + 0.5 * 0)) / 1.0
        # solve x⁰(k) + b1·½(acc + acc + x⁰(k)) = rhs for x⁰(k)
        y[k] = (zX[k - 1] @ b + u - b1 * acc) / (1 + 0.5 * b1)
        acc += y[k]
    b1_hat, b_hat, u_hat, rank, _ = gmc_lstsq(y, X)
    assert rank == 4
    np.testing.assert_allclose([b1_hat, *b_hat, u_hat], [b1, *b, u], atol=1e-10)


def test_population_matches_single_and_basis_is_linear():
    rng = np.random.default_rng(2)
    X1 = ago(1 + rng.random((50, 3)))
    params = np.array([[0.3, 0.5, -0.2, 0.1, 0.05], [1.2, -0.3, 0.4, 0.2, -1.0]])
    pop = gmc_predict_population(X1, params)
    for i, p in enumerate(params):
        np.testing.assert_allclose(pop[:, i], gmc_predict(X1, p[0], p[1:-1], p[-1]), rtol=1e-13)
        np.testing.assert_allclose(gmc_basis(X1, p[0]) @ p[1:], pop[:, i], rtol=1e-12, atol=1e-12)


def test_separable_finds_exact_linear_part():
    rng = np.random.default_rng(4)
    X1 = ago(1 + rng.random((60, 3)))
    truth = np.array([0.25, 0.5, -0.2, 0.1, 0.05])
    y = gmc_predict(X1, truth[0], truth[1:-1], truth[-1])
    sse, theta = gmc_separable(X1, y, [0.25, 0.5])
    assert sse[0] < 1e-20 and sse[1] > 1e-6
    np.testing.assert_allclose(theta[0], truth[1:], atol=1e-9)


def test_exploding_trajectories_are_large_finite_losses():
    X1 = ago(20 + np.random.default_rng(0).random((200, 2)))
    y = np.zeros(200)
    params = np.array(
        [[-100.0, 100, -100, 100], [-5.0, 1, 1, 1], [-1.0, 1, 1, 0], [100.0, 1, 1, 1]]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sse = gmc_sse_population(X1, y, params)
        sep, _ = gmc_separable(X1, y, params[:, 0])
    assert np.isfinite(sse).all() and np.isfinite(sep).all()
    assert sse[0] == PENALTY and sse[1] == PENALTY
    assert sse[3] < PENALTY


def test_iago_first_value():
    np.testing.assert_array_equal(iago(np.array([[2.0], [5.0], [9.0]])).ravel(), [2.0, 3.0, 4.0])
