"""The shared first-order lag kernel against hand-computed cases and a plain loop."""

import numpy as np
import pytest

from greyml.dynamic._kernels import lag_filter, lag_step, steady_state


def _loop(x, dt, taus, bounds, carry, initial=None):
    """The recursion written out sample by sample."""
    out = np.empty((x.shape[0], x.shape[1], len(taus)))
    state = None if initial is None else np.array(initial, dtype=float)
    for start, stop in bounds:
        for k in range(start, stop):
            if k == start and (state is None or not carry):
                state = steady_state(x[k], len(taus))
            else:
                state = lag_step(state, x[k][:, None], np.exp(-dt[k] / np.asarray(taus)))
            out[k] = state
    return out


def test_hand_computed_step():
    # a unit step after one sample at rest, tau = dt / ln 2: a = 1/2
    x = np.array([[0.0], [1.0], [1.0], [1.0]])
    dt = np.full(4, 10.0)
    lags, final = lag_filter(x, dt, np.array([10.0 / np.log(2.0)]), [(0, 4)])
    np.testing.assert_allclose(lags[:, 0, 0], [0.0, 0.5, 0.75, 0.875], rtol=0, atol=1e-15)
    np.testing.assert_allclose(final, [[0.875]], atol=1e-15)


def test_restart_starts_at_rest_and_carry_runs_on():
    x = np.array([[0.0], [1.0], [5.0], [5.0]])
    dt = np.full(4, 10.0)
    tau = np.array([10.0 / np.log(2.0)])
    restart, _ = lag_filter(x, dt, tau, [(0, 2), (2, 4)])
    carry, _ = lag_filter(x, dt, tau, [(0, 2), (2, 4)], carry=True)
    np.testing.assert_allclose(restart[:, 0, 0], [0.0, 0.5, 5.0, 5.0], atol=1e-15)
    # carried: 0.5 -> 0.5*0.5 + 0.5*5 = 2.75 -> 3.875
    np.testing.assert_allclose(carry[:, 0, 0], [0.0, 0.5, 2.75, 3.875], atol=1e-15)


@pytest.mark.parametrize("carry", [False, True])
@pytest.mark.parametrize("sampling", ["even", "jitter", "runs"])
def test_equals_the_plain_loop_bit_for_bit(carry, sampling):
    rng = np.random.default_rng(3)
    n = 600
    x = rng.normal(size=(n, 3)).cumsum(axis=0)
    dt = {
        "even": np.full(n, 15.0),
        "jitter": rng.uniform(5.0, 20.0, n),
        "runs": np.where(np.arange(n) % 150 == 0, 30.0, 15.0),
    }[sampling]
    taus = np.array([60.0, 300.0, 900.0])
    bounds = [(0, 200), (200, 450), (450, 600)]
    initial = rng.normal(size=(3, 3)) if carry else None
    lags, final = lag_filter(x, dt, taus, bounds, carry=carry, initial=initial)
    expected = _loop(x, dt, taus, bounds, carry, initial)
    np.testing.assert_array_equal(lags, expected)
    np.testing.assert_array_equal(final, expected[-1])


def test_constant_input_stays_put_and_long_tau_barely_moves():
    x = np.full((50, 2), 3.0)
    x[25:, 1] = 4.0
    lags, _ = lag_filter(x, np.full(50, 1.0), np.array([1e9]), [(0, 50)])
    np.testing.assert_array_equal(lags[:, 0, 0], 3.0)
    assert abs(lags[-1, 1, 0] - 3.0) < 1e-7


def test_chunked_even_runs_stay_bit_equal(monkeypatch):
    # long evenly sampled runs are filtered in chunks along time; each chunk
    # continues from the last output of the one before, bit for bit
    import greyml.dynamic._kernels as kernels

    rng = np.random.default_rng(5)
    n = 9000
    x = rng.normal(size=(n, 2)).cumsum(axis=0)
    dt = np.full(n, 15.0)
    taus = np.array([60.0, 900.0])
    bounds = [(0, 5000), (5000, n)]
    expected = _loop(x, dt, taus, bounds, True)
    monkeypatch.setattr(kernels, "_CHUNK_VALUES", 2 * 4096)  # 4096 samples per call
    lags, _ = lag_filter(x, dt, taus, bounds, carry=True)
    np.testing.assert_array_equal(lags, expected)


def test_solve_all_with_a_free_intercept_equals_the_direct_ridge():
    """The intercept eliminated exactly (one eigendecomposition for every penalty)
    gives the solution of the bordered ridge system, penalty by penalty."""
    from greyml.dynamic._gram import _ridge, _standardised, solve_all

    rng = np.random.default_rng(0)
    A = rng.normal(size=(200, 6)) * [1, 10, 0.1, 5, 2, 3] + 3
    A = np.column_stack([A, np.ones(200)])
    y = A[:, :6] @ [1.0, -0.2, 4.0, 0.5, 0.0, 1.5] + 7.0 + rng.normal(size=200)
    G, b = A.T @ A, A.T @ y
    pen = np.r_[np.ones(6), 0.0]
    alphas = np.logspace(-6, 0, 7)
    Gn, bn, scale = _standardised(G, b, 200.0, pen)
    direct = np.column_stack([_ridge(Gn, bn, a * 200.0, pen) for a in alphas]) / scale[:, None]
    np.testing.assert_allclose(solve_all(G, b, 200.0, alphas, pen), direct, rtol=1e-9, atol=1e-11)
    # the smallest penalty recovers least squares: the coefficients and the intercept
    ls = np.linalg.lstsq(A, y, rcond=None)[0]
    np.testing.assert_allclose(solve_all(G, b, 200.0, [0.0], pen)[:, 0], ls, rtol=1e-8)
