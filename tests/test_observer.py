"""The probe filter's kernels (greyml.dynamic._observer): transitions, the likelihood test's
statistics by hand, its threshold, and the noise chosen on residuals of known structure."""

import math

import numpy as np
import pytest
from scipy.stats import chi2

from greyml.dynamic._observer import (
    WINDOW,
    _innovations,
    glr_advance,
    glr_change,
    glr_reset,
    glr_threshold,
    innovation_memory,
    observer_noise,
    replay,
    transition,
    update,
)


def test_transition_by_hand():
    F, Q = transition(2.0, 1.0, 3.0, 0.5, 0.25, scale=2.0)
    phi = math.exp(-2.0)
    np.testing.assert_allclose(F, [[phi, 0, 0], [0, 1, 2], [0, 0, 1]])
    expected = np.array(
        [
            [3.0 * (1 - phi * phi), 0, 0],
            [0, 0.5 * 2 + 0.25 * 8 / 3, 0.25 * 4 / 2],
            [0, 0.25 * 4 / 2, 0.25 * 2],
        ]
    )
    np.testing.assert_allclose(Q, 2.0 * expected)
    # an infinite memory: the offset never forgets
    F, Q = transition(5.0, math.inf, 3.0, 0.0, 0.0)
    assert F[0, 0] == 1.0 and Q[0, 0] == 0.0


def test_update_by_hand():
    # offset variance 4, bias 0, reading noise 1: gain 0.8 on the offset
    x, P, nu, S, K = update(np.zeros(3), np.diag([4.0, 0.0, 0.0]), 5.0, 1.0)
    assert nu == 5.0 and S == 5.0
    np.testing.assert_allclose(K, [0.8, 0.0, 0.0])
    np.testing.assert_allclose(x, [4.0, 0.0, 0.0])
    assert P[0, 0] == pytest.approx(0.8)


def test_threshold_is_the_bonferroni_chi2_quantile():
    assert glr_threshold(1e-3) == pytest.approx(chi2.isf(1e-3 / (2 * WINDOW), 1), rel=1e-9)
    assert glr_threshold(0.05, window=1) == pytest.approx(chi2.isf(0.025, 1), rel=1e-9)


def test_likelihood_statistics_by_hand():
    """A certain model (gain 0): each onset's statistic is (Σ ρ·ν)² / Σ ρ², ρ = 1 for a
    step, the hours since the onset for a ramp. Innovations 1, 2, 3 at 1, 2, 3 h."""
    bank = glr_reset()
    F, K = np.eye(3), np.zeros(3)
    for t, nu in ((1.0, 1.0), (2.0, 2.0), (3.0, 3.0)):
        bank, best = glr_advance(bank, F, K, nu, 1.0, t, t - 1.0)
    D, A, B, T0, n = bank
    assert n == 3
    # steps from the 3rd, 2nd, 1st reading: 3²/1, 5²/2, 6²/3
    np.testing.assert_allclose(A[0, :3] ** 2 / B[0, :3], [9.0, 12.5, 12.0])
    # ramps from 2 h, 1 h, 0 h: ρ = (1), (1, 2), (1, 2, 3)
    np.testing.assert_allclose(A[1, :3] ** 2 / B[1, :3], [9.0, 64 / 5, 14.0])
    assert best == (pytest.approx(14.0), 1, 2)
    dx, dP, size, start_h = glr_change(bank, 1, 2, 3.0)
    assert size == pytest.approx(1.0) and start_h == 0.0  # 1 µm/h since 0 h
    np.testing.assert_allclose(dx, [0.0, 3.0, 1.0])
    np.testing.assert_allclose(dP, np.outer([0, 3, 1], [0, 3, 1]) / 14.0)


def test_the_window_closes_the_oldest_onset():
    bank = glr_reset()
    for k in range(WINDOW + 5):
        bank, _ = glr_advance(bank, np.eye(3), np.zeros(3), 1.0, 1.0, k + 1.0, float(k))
    D, A, B, T0, n = bank
    assert n == WINDOW
    assert T0[WINDOW - 1] == 5.0  # the oldest onset kept: after the 5th reading
    np.testing.assert_allclose(B[0], np.arange(1, WINDOW + 1))


def test_replay_leaves_nothing_of_an_offset_read_exactly():
    # a constant offset of 2 µm, read exactly every hour: after the first reading the
    # correction removes it (an infinite memory, no white noise)
    hours = np.arange(0, 8, 0.25)
    resid = np.full(hours.size, 2.0)
    z, logs, corrected, first = replay(hours, resid, 1.0, lambda h: 4.0, 0.0, math.inf, 4.0, 0, 0)
    assert first == 4  # the row at 1 h
    np.testing.assert_allclose(corrected[:4], 2.0)
    np.testing.assert_allclose(corrected[4:], 0.0, atol=1e-12)
    assert z[0] == pytest.approx(1.0)  # 2 µm against a prior SD of 2 µm


def test_the_noise_chosen_follows_a_random_walk():
    """Residuals that walk (1 µm²/h, no offset): the bias's walk is chosen, within a
    decade of the truth, and the innovations' mean square is 1 after the scale."""
    rng = np.random.default_rng(7)
    step_h = 1 / 60
    hours = np.arange(0, 8, step_h)
    series = []
    for _ in range(6):
        walk = np.cumsum(rng.normal(0.0, math.sqrt(step_h), hours.size))
        series.append((hours, walk + rng.normal(0.0, 0.01, hours.size)))
    qb, qr, scale, glr_scale = observer_noise(series, lambda h: 1e-4 + h, 1e-4, 1e-3, 1e-4)
    assert glr_scale >= 1.0
    assert 0.1 <= qb <= 10.0
    z = np.concatenate(
        [
            replay(h, r, every, lambda h: 1e-4 + h, 1e-4, 1e-3, 1e-4, qb, qr)[0]
            for every in (0.25, 1.0, 4.0)
            for h, r in series
        ]
    )
    assert np.mean(z**2) == pytest.approx(scale)


def test_innovations_of_every_test_and_pair_at_once_equal_one_replay_each():
    """The batched recursion that chooses the filter's noise runs, for tests of
    different lengths (one read never, one once) and several noise pairs, exactly
    what :func:`replay` runs for one test and one pair."""
    rng = np.random.default_rng(3)
    prior = lambda h: 0.5 + 0.1 * h  # noqa: E731
    series = [
        (np.arange(0, n) * 0.1, rng.normal(0.0, 1.0, n)) for n in (3, 12, 57, 120)
    ]  # 0.3 h: never read at 0.5 h; 1.2 h: read twice
    qb, qr = np.array([0.0, 0.2, 1.0]), np.array([0.0, 0.05, 0.0])
    for memory_h in (2.0, math.inf):
        z, logs = _innovations(series, 0.5, prior, 0.05, memory_h, 0.3, qb, qr)
        for t, (h, r) in enumerate(series):
            for c in range(qb.size):
                zt, lt, _, _ = replay(h, r, 0.5, prior, 0.05, memory_h, 0.3, qb[c], qr[c])
                np.testing.assert_allclose(z[t][:, c], zt, rtol=1e-12, atol=1e-14)
                np.testing.assert_allclose(logs[t][:, c], lt, rtol=1e-12, atol=1e-14)
    assert [a.shape[0] for a in z] == [0, 2, 11, 23]


def test_innovation_memory_by_hand():
    # innovations that repeat themselves: a sum of m of them is m times one, its square
    # m² times, so m (the longest window that fits: 4) times independent ones
    assert innovation_memory([np.ones(4)]) == pytest.approx(4.0)
    # alternating ones cancel in pairs: never more than independent ones
    assert innovation_memory([np.array([1.0, -1.0, 1.0, -1.0])]) == 1.0
    # two runs: windows never cross from one run into the next
    assert innovation_memory([np.ones(2), -np.ones(2)]) == pytest.approx(2.0)
