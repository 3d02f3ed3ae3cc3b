"""The probe filter's arithmetic: a Kalman filter on the error, and a likelihood test for changes.

Pure numpy functions, shared by :class:`greyml.Compensator` (which runs them
at every probe reading) and :meth:`greyml.ThermalTransferFunction.fit`
(which chooses the filter's noise on the training tests' held-out residuals
with them, so that the filter a controller runs is the one calibrated).

The error of the model's correction (measured minus corrected, µm) is
``o + β + v``: three states and a white part.

* ``o``, the offset: an Ornstein-Uhlenbeck process of variance
  ``memory_var`` that forgets itself with ``memory_h`` hours (what the
  held-out residuals' variogram shows);
* ``β``, the bias: a random walk of variance ``bias_var_per_h`` per hour,
  moved by the rate ``r``, itself a random walk of ``rate_var_per_h3`` per
  hour (an integrated random walk): a drifting machine is followed without a
  detector;
* ``v``, white, of variance ``noise_var`` (what no reading removes), plus the
  probe's own noise.

Every variance is multiplied by ``scale``, chosen so that the filter's
standardised innovations on the training tests have a mean square of 1.

Changes the random walks are too slow for (a crash, a moved fixture, a
sensor that lost its gain) are found by a generalised likelihood ratio test
(Willsky and Jones, 1976) for a step in the bias or a ramp from some reading
among the last :data:`WINDOW`: for each onset, the innovations' expected
response to a unit change (its *signature*, which the filter's own gains
shape) is carried, and the statistic is ``(Σ ρ·ν/S)² / Σ ρ²/S``; the test
fires above the χ²₁ quantile of ``rate / (2·WINDOW)`` (a Bonferroni bound
over the onsets and both kinds), so that unchanged Gaussian innovations
raise at most ``rate`` false alarms per reading. On firing, the estimated
change is added to the states, its variance to their covariance.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import chdtri

__all__ = [
    "H",
    "KINDS",
    "READING_HOURS",
    "WINDOW",
    "cube",
    "matmul",
    "glr_advance",
    "glr_change",
    "glr_reset",
    "glr_threshold",
    "innovation_memory",
    "observer_noise",
    "replay",
    "transition",
    "update",
]

#: The readings a change may have begun before (the GLR's window).
WINDOW = 12
#: The measurement row: the error read is offset + bias.
H = np.array([1.0, 1.0, 0.0])
#: The kinds of change the likelihood test looks for.
KINDS = ("step", "ramp")
#: The grid of reading intervals (h) the filter's noise is chosen on.
READING_HOURS = (0.25, 1.0, 4.0)


def matmul(a, b):
    """``a @ b``, each entry's products added in order from the first, as the C and
    Structured Text exports' loops add them.

    numpy's ``@`` hands small matrices to BLAS, which may fuse a multiply with an
    add and order the sum its own way: on an ill-conditioned covariance (a
    variance of 1e16 after a large change) the filter's numbers then
    differed from the exports' in the third digit. ``b`` is a vector (``k``) or
    a matrix (``k``, ``m``); ``a`` is (..., ``k``) or (..., ``n``, ``k``).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if b.ndim == 1:  # (..., k) @ (k,) or (..., n, k) @ (k,)
        terms = a * b
        out = terms[..., 0]
        for k in range(1, b.shape[0]):
            out = out + terms[..., k]
        return out
    terms = a[..., :, :, None] * b  # (..., n, k, m)
    out = terms[..., 0, :]
    for k in range(1, b.shape[0]):
        out = out + terms[..., k, :]
    return out


def cube(dh):
    """``dh**3`` as C's ``pow(dh, 3.0)`` gives it: infinity where it overflows (Python's
    float power raises ``OverflowError`` there)."""
    try:
        return dh**3
    except OverflowError:
        return math.inf


def transition(dh, memory_h, memory_var, bias_var_per_h, rate_var_per_h3, scale=1.0):
    """``(F, Q)`` carrying the states ``(o, β, r)`` over ``dh`` hours (≥ 0)."""
    phi = math.exp(-dh / memory_h) if math.isfinite(memory_h) else 1.0
    qb, qr = bias_var_per_h, rate_var_per_h3
    F = np.array([[phi, 0.0, 0.0], [0.0, 1.0, dh], [0.0, 0.0, 1.0]])
    Q = np.array(
        [
            [memory_var * (1.0 - phi * phi), 0.0, 0.0],
            [0.0, qb * dh + qr * cube(dh) / 3.0, qr * dh * dh / 2.0],
            [0.0, qr * dh * dh / 2.0, qr * dh],
        ]
    )
    return F, scale * Q


def update(x, P, z_minus_model, R):
    """One reading: ``(x, P, innovation, S, K)`` after it (Joseph form).

    ``z_minus_model`` is the reading minus the model's correction there;
    ``R`` the variance of its white part (the model's and the probe's).
    """
    innovation = z_minus_model - float(matmul(x, H))
    PH = matmul(P, H)
    S = float(matmul(PH, H)) + R
    if S <= 0:  # every variance 0: the model is held certain, the reading moves nothing
        S = np.finfo(float).tiny
    K = PH / S
    IKH = np.eye(3) - np.outer(K, H)
    P = matmul(matmul(IKH, P), IKH.T) + np.outer(K, K) * R
    return x + K * innovation, 0.5 * (P + P.T), innovation, S, K


def glr_threshold(rate, window=WINDOW):
    """The statistic above which the test fires: the χ²₁ quantile of ``rate/(2·window)``."""
    return float(chdtri(1.0, rate / (2.0 * window)))


def glr_reset(window=WINDOW):
    """An empty bank: ``(D, A, B, T0, n)``: each kind's (2) and onset's (``window``)
    filter response (3 states), the sums ``Σ ρν/S`` and ``Σ ρ²/S``, the onsets'
    start times, and how many onsets are open."""
    return (
        np.zeros((2, window, 3)),
        np.zeros((2, window)),
        np.zeros((2, window)),
        np.zeros(window),
        0,
    )


def glr_advance(bank, F, K, innovation, S, time_h, previous_h):
    """The bank after a reading at ``time_h`` (the previous one at ``previous_h``).

    ``F`` carried the states from the previous reading, ``K`` is this
    reading's gain. A new onset opens (a change since the previous reading);
    the oldest beyond the window closes. Returns the new bank and
    ``(statistic, kind, slot)`` of the largest statistic (kind 0 step, 1 ramp).
    """
    D0, A0, B0, T00, n = bank
    window = T00.size
    D, A, B, T0 = np.zeros_like(D0), np.zeros_like(A0), np.zeros_like(B0), np.empty_like(T00)
    D[:, 1:], A[:, 1:], B[:, 1:], T0[1:] = D0[:, :-1], A0[:, :-1], B0[:, :-1], T00[:-1]
    T0[0] = previous_h
    n = min(n + 1, window)
    D[:, :n] = matmul(D[:, :n], F.T)  # each response carried to this reading
    G = np.zeros((2, n, 3))
    G[0, :, 1] = 1.0  # a step in the bias
    G[1, :, 1] = time_h - T0[:n]  # a ramp: the bias grows with the time since its start
    G[1, :, 2] = 1.0  # ... at a constant rate
    rho = matmul(G - D[:, :n], H)
    D[:, :n] += rho[..., None] * K
    A[:, :n] += rho * innovation / S
    B[:, :n] += rho * rho / S
    with np.errstate(divide="ignore", invalid="ignore"):
        stat = np.where(B[:, :n] > 0, A[:, :n] ** 2 / B[:, :n], 0.0)
    # a ramp begun since the previous reading has read only once: its signature is the
    # step's times (time_h - previous_h), so its statistic is the step's, and only
    # rounding would choose between them; it is the step until a second reading
    stat[1, 0] = 0.0
    kind, slot = np.unravel_index(int(np.argmax(stat)), stat.shape)
    return (D, A, B, T0, n), (float(stat[kind, slot]), int(kind), int(slot))


def glr_change(bank, kind, slot, time_h):
    """``(dx, dP, size, start_h)``: the change found by the bank (kind, slot) at
    ``time_h``, as the states' correction and its covariance, its size (µm, or
    µm/h for a ramp) and the time (h) it began."""
    D, A, B, T0, _ = bank
    g = np.zeros(3)
    g[1] = 1.0 if kind == 0 else time_h - T0[slot]
    g[2] = 0.0 if kind == 0 else 1.0
    miss = g - D[kind, slot]
    size = A[kind, slot] / B[kind, slot]
    return size * miss, np.outer(miss, miss) / B[kind, slot], float(size), float(T0[slot])


def replay(hours, resid, every_h, prior, noise, memory_h, memory_var, qb, qr):
    """The filter run on one test's held-out residuals, read every ``every_h`` hours
    from its first row (scale 1).

    Returns ``(z, logs, corrected, first)``: the standardised innovations
    and the logarithms of their variances, the residual left at every row
    once the filter's correction is subtracted (what a compensator with those
    readings would leave), and the first row a reading reached (rows before
    it are corrected by nothing).
    """
    rows = _reading_rows(hours, every_h)
    corrected = resid.astype(float).copy()
    z, logs = np.empty(rows.size), np.empty(rows.size)
    x, P, last = np.zeros(3), np.zeros((3, 3)), 0.0
    phi_of = (lambda d: np.exp(-d / memory_h)) if math.isfinite(memory_h) else np.ones_like
    for k, i in enumerate(rows):
        if k == 0:  # the first reading: the batch variance there, all in the offset
            x, P = np.zeros(3), np.diag([prior(hours[i]), 0.0, 0.0])
        else:
            F, Q = transition(hours[i] - last, memory_h, memory_var, qb, qr)
            x, P = matmul(F, x), matmul(matmul(F, P), F.T) + Q
        x, P, nu, S, _ = update(x, P, float(resid[i]), noise)
        z[k] = nu / math.sqrt(S)
        logs[k] = math.log(S)
        last = hours[i]
        stop = rows[k + 1] if k + 1 < rows.size else hours.size
        d = hours[i:stop] - last
        corrected[i:stop] -= x[0] * phi_of(d) + x[1] + x[2] * d
    return z, logs, corrected, (int(rows[0]) if rows.size else hours.size)


#: The random walks' variances tried, as shares of the residuals' mean square
#: per hour (bias) and per hour³ (rate).
BIAS_SHARES = (0.0, 1e-3, 1e-2, 1e-1, 1.0)
RATE_SHARES = (0.0, 1e-4, 1e-3, 1e-2, 1e-1)


def _reading_rows(hours, every_h):
    """The rows of one test read every ``every_h`` hours from its first row."""
    at = np.arange(every_h, hours[-1] + 1e-9, every_h)
    rows = np.searchsorted(hours, at - 1e-9)
    return rows[rows < hours.size]


def _innovations(series, every_h, prior, noise, memory_h, memory_var, qb, qr):
    """:func:`replay`'s innovations for every test of ``series`` and every pair
    ``(qb[c], qr[c])`` at once: ``(z, logs)``, each a list (one per test) of arrays
    (n_readings, n_pairs).

    The same recursion as :func:`replay` (which is its reference), run over the
    k-th reading of every test together, vectorised over tests and pairs:
    the cost is the longest test's readings in Python steps, not the sum of
    every test's readings times the pairs.
    """
    qb, qr = np.asarray(qb, dtype=float), np.asarray(qr, dtype=float)
    rows = [_reading_rows(h, every_h) for h, _ in series]
    T, C = len(series), qb.size
    n_read = np.array([r.size for r in rows], dtype=int)
    # the tests with the most readings first: those read a k-th time are a prefix
    rank = np.argsort(-n_read, kind="stable")
    K = int(n_read.max(initial=0))
    hr, zr = np.zeros((T, K)), np.zeros((T, K))
    for j, t in enumerate(rank):
        (h, r), i = series[t], rows[t]
        hr[j, : i.size], zr[j, : i.size] = h[i], r[i]
    z, logs = np.zeros((T, K, C)), np.zeros((T, K, C))
    # the states (offset, bias, rate) and the covariance's six entries, (T, C) each
    x0, x1, x2 = np.zeros((T, C)), np.zeros((T, C)), np.zeros((T, C))
    p00, p01, p02, p11, p12, p22 = (np.zeros((T, C)) for _ in range(6))
    if K:  # the first reading: the batch variance there, all in the offset
        p00[:] = np.array([prior(v) for v in hr[:, 0]])[:, None]
    for k in range(K):
        m = int(np.count_nonzero(n_read > k))  # the first m (ranked) tests are read
        s = slice(0, m)
        if k > 0:
            dh = (hr[s, k] - hr[s, k - 1])[:, None]
            phi = np.exp(-dh / memory_h) if math.isfinite(memory_h) else np.ones_like(dh)
            x0[s] *= phi
            x1[s] += dh * x2[s]
            p11[s] += dh * (2.0 * p12[s] + dh * p22[s]) + qb * dh + qr * dh**3 / 3.0
            p12[s] += dh * p22[s] + qr * dh * dh / 2.0
            p22[s] += qr * dh
            p01[s] = phi * (p01[s] + dh * p02[s])
            p02[s] *= phi
            p00[s] = phi * phi * p00[s] + memory_var * (1.0 - phi * phi)
        nu = zr[s, k, None] - (x0[s] + x1[s])
        h0, h1, h2 = p00[s] + p01[s], p01[s] + p11[s], p02[s] + p12[s]
        S = h0 + h1 + noise
        S = np.where(S <= 0, np.finfo(float).tiny, S)
        k0, k1, k2 = h0 / S, h1 / S, h2 / S
        # Joseph's form, (I − KH)P(I − KH)' + KRK', written out: P − K·PH' − PH·K' + KK'·S
        p00[s] += k0 * (k0 * S - 2.0 * h0)
        p11[s] += k1 * (k1 * S - 2.0 * h1)
        p22[s] += k2 * (k2 * S - 2.0 * h2)
        p01[s] += k0 * k1 * S - k0 * h1 - k1 * h0
        p02[s] += k0 * k2 * S - k0 * h2 - k2 * h0
        p12[s] += k1 * k2 * S - k1 * h2 - k2 * h1
        x0[s] += k0 * nu
        x1[s] += k1 * nu
        x2[s] += k2 * nu
        z[s, k] = nu / np.sqrt(S)
        logs[s, k] = np.log(S)
    back = np.empty(T, dtype=int)
    back[rank] = np.arange(T)
    return (
        [z[back[t], : n_read[t]] for t in range(T)],
        [logs[back[t], : n_read[t]] for t in range(T)],
    )


def observer_noise(series, prior, noise, memory_h, memory_var):
    """``(bias_var_per_h, rate_var_per_h3, scale, glr_scale)`` of the filter, chosen on
    ``series``.

    ``series`` is a list of ``(hours since the test's first row, held-out
    residual)`` arrays, one per training test; ``prior(h)`` the offset's
    variance before the first reading at ``h`` hours; ``noise`` the white
    variance; ``memory_h`` and ``memory_var`` the offset's, from the
    residuals' variogram.

    The random walks' variances are the pair on the grid
    (:data:`BIAS_SHARES` × :data:`RATE_SHARES`, shares of the residuals' mean
    square) with the highest Gaussian likelihood of the filter's innovations
    with readings every 15 min, 1 h and 4 h from each test's first row, every
    variance multiplied by the common scale that maximises it; that scale (the
    innovations' mean square) is returned with them, so that the filter's
    innovations on the training tests have a mean square of 1, and so is
    :func:`innovation_memory` of those innovations (what the likelihood test's
    threshold is multiplied by). Every pair and test is run at once
    (:func:`_innovations`), as :func:`replay` runs one.
    """
    series = [(h, r) for h, r in series if r.size]
    if not series:
        return 0.0, 0.0, 1.0, 1.0
    e2 = float(np.mean(np.concatenate([r for _, r in series]) ** 2)) or 1.0
    pairs = [(fb * e2, fr * e2) for fb in BIAS_SHARES for fr in RATE_SHARES]
    qb, qr = np.array(pairs).T
    runs = [
        _innovations(series, every, prior, noise, memory_h, memory_var, qb, qr)
        for every in READING_HOURS
    ]
    z = np.concatenate([a for zs, _ in runs for a in zs])
    if z.shape[0] == 0:
        return 0.0, 0.0, 1.0, 1.0
    logs = np.concatenate([a for _, ls in runs for a in ls])
    scales = np.maximum(np.mean(z**2, axis=0), 1e-12)
    logliks = -0.5 * (np.sum(logs, axis=0) + z.shape[0] * np.log(scales))
    best = 0
    for c in range(1, len(pairs)):  # the first of equal likelihoods, as the grid is ordered
        if logliks[c] > logliks[best] + 1e-9 * abs(logliks[best]):
            best = c
    scale = float(scales[best])
    chosen = [a[:, best] / math.sqrt(scale) for zs, _ in runs for a in zs]
    return float(qb[best]), float(qr[best]), scale, innovation_memory(chosen)


def innovation_memory(runs, window=WINDOW):
    """How much more a sum of consecutive standardised innovations varies than
    independent ones would: the largest, over ``m`` = 1 … ``window``, of the mean
    of ``(z_k + … + z_{k+m−1})² / m`` over every run (each an array of one
    test's innovations), relative to ``m = 1``; at least 1.

    The likelihood test's statistics are such sums squared: with innovations
    that remember each other (a model error slower than the filter assumes)
    they are this many times larger than a χ²₁ under no change, so the
    threshold is raised by it (a long-run variance correction, as Newey and
    West, 1987, make for a sum of correlated terms).
    """
    runs = [np.asarray(z, dtype=float) for z in runs if len(z)]
    if not runs:
        return 1.0
    base = float(np.mean(np.concatenate(runs) ** 2))
    if not base > 0:
        return 1.0
    worst = 1.0
    for m in range(2, window + 1):
        sums = [np.convolve(z, np.ones(m), mode="valid") for z in runs if z.size >= m]
        if not sums:
            break
        sums = np.concatenate(sums)
        worst = max(worst, float(np.mean(sums**2)) / m / base)
    return worst
