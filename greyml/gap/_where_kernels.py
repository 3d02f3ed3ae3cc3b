"""Kernels of :mod:`greyml.gap._where`: arrays in, arrays out.

Every computation runs test by test: the band decomposition takes one real FFT
per test, and the auto- and cross-correlations add up products of samples of
the same test only, so nothing is ever paired across a test boundary.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import fft as sp_fft

from greyml._sequences import TIME_LEVEL, Segment
from greyml.gap._where_checks import _Layout

_HOUR = 3600.0
_MINUTE = 60.0
#: A driver counts as "on" where ``|value| > _ON_RTOL * max|value|`` of that driver.
_ON_RTOL = 1e-9
#: Periods within this relative distance of a band edge belong to the shorter band.
_EDGE_RTOL = 1e-9
_WHITENESS_MAX_LAGS = 20


def _sum_sq(x: np.ndarray) -> float:
    # not ``x @ x``: a BLAS dot product may start threads that spin on a busy
    # machine (see greyml._threads); numpy's pairwise sum is also more accurate
    return float(np.sum(np.square(x)))


def _summary(x: np.ndarray, rows: np.ndarray, layout: _Layout, total: float) -> dict:
    """RMS, peak (and where), bias and share of the gap values ``x`` at ``rows``."""
    energy = _sum_sq(x)
    i = int(np.argmax(np.abs(x)))
    return {
        "n": int(x.size),
        "rms": math.sqrt(energy / x.size),
        "peak": float(abs(x[i])),
        "peak_test": layout.labels[rows[i]],
        "peak_time_s": float(layout.time[rows[i]]),
        "bias": float(np.mean(x)),
        "share": energy / total if total > 0 else math.nan,
    }


def _drivers_on(D: np.ndarray) -> np.ndarray:
    """Rows where at least one driver is non-zero, relative to its own range."""
    size = np.abs(D)
    return np.any(size > _ON_RTOL * size.max(axis=0), axis=1)


def _default_time_edges(time: np.ndarray) -> np.ndarray:
    t_max = float(time.max())
    step = _HOUR if t_max >= 2 * _HOUR else 15 * _MINUTE
    first = min(0.0, math.floor(float(time.min()) / step))
    last = max(math.ceil(t_max / step), first + 1)
    return step * np.arange(first, last + 1)


def _time_bins(time: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin of every time: ``[a, b)``, the last bin closed ``[a, b]``."""
    outside = (time < edges[0]) | (time > edges[-1])
    if outside.any():
        row = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"The time bins of gap_breakdown span {TIME_LEVEL} {edges[0]:g} to "
            f"{edges[-1]:g} s but the gap has rows from {time.min():g} to "
            f"{time.max():g} s (first outside: row {row}). Widen 'time_edges_s'; "
            "-inf and inf are allowed as its first and last edges."
        )
    bins = np.searchsorted(edges, time, side="right") - 1
    return np.minimum(bins, edges.size - 2)


def _band_of_bins(n: int, dt: float, edges: np.ndarray) -> np.ndarray:
    """Band of every rFFT bin of an ``n``-sample test (0 = longest periods, with DC).

    Bin ``k`` has the period ``n * dt / k``; a period at an edge (to
    ``_EDGE_RTOL``) belongs to the shorter band.
    """
    k = np.arange(n // 2 + 1, dtype=np.float64)
    band = np.zeros(k.size, dtype=np.intp)
    if n < 2:
        return band
    span = n * dt
    for j, edge in enumerate(edges):  # decreasing periods: shorter bands override
        band[k * edge * (1 + _EDGE_RTOL) >= span] = j + 1
    return band


def _band_components(x: np.ndarray, dt: float, edges: np.ndarray) -> np.ndarray:
    """The gap of one test split by frequency band, shape ``(n_bands, n)``.

    The rows add up to ``x`` and are orthogonal to each other (their spectra
    do not overlap), so their energies add up to that of ``x``.
    """
    n = x.size
    spectrum = sp_fft.rfft(x)
    band = _band_of_bins(n, dt, edges)
    out = np.zeros((edges.size + 1, n))
    for j in np.unique(band):
        out[j] = sp_fft.irfft(np.where(band == j, spectrum, 0), n)
    return out


def _lagged_sums(a: np.ndarray, B: np.ndarray, max_lag: int) -> np.ndarray:
    """``S[m + max_lag, j] = sum_t a[t] * B[t - m, j]`` for ``m = -max_lag..max_lag``.

    Zero padding to at least ``n + max_lag`` keeps the circular correlation of
    the FFT from wrapping round within the lags returned.
    """
    n = a.size
    size = sp_fft.next_fast_len(n + max_lag, real=True)
    fa = sp_fft.rfft(a, size)
    fb = sp_fft.rfft(B, size, axis=0)
    circular = sp_fft.irfft(fa[:, None] * np.conj(fb), size, axis=0)
    return np.concatenate([circular[size - max_lag :], circular[: max_lag + 1]])


def _ljung_box(values: np.ndarray, segments: list[Segment], n_lags: int | None):
    """Per-test Ljung-Box statistics summed; pooled lag-1 autocorrelation."""
    q, dof, lag1_num, lag1_den = 0.0, 0, 0.0, 0.0
    for seg in segments:
        c = values[seg.slice] - np.mean(values[seg.slice])
        n = c.size
        energy = _sum_sq(c)
        if n >= 2:
            lag1_num += float(np.sum(c[1:] * c[:-1]))
            lag1_den += energy
        h = min(_WHITENESS_MAX_LAGS, n // 5) if n_lags is None else min(n_lags, n - 1)
        if h < 1:
            continue
        if energy > 0:
            rho = _lagged_sums(c, c[:, None], h)[h + 1 :, 0] / energy
            q += n * (n + 2) * float(np.sum(rho**2 / (n - np.arange(1, h + 1))))
        dof += h
    lag1 = lag1_num / lag1_den if lag1_den > 0 else 0.0
    return q, dof, lag1


def _pooled_cross_correlation(values, S, layout: _Layout, max_lag_s: float):
    """Cross-correlation of the gap with every column of ``S``, pooled over tests.

    Returns the lags in seconds, shape ``(n_lags,)``, the correlations, shape
    ``(n_lags, n_signals)``, the pooled energy of the centred gap and that of
    every centred signal. Each test gives the sums of products at its own lags
    ``m * dt``; they are added up on a common grid with the finest sampling
    interval of all tests, by linear interpolation in the lag where a test is
    sampled more coarsely (exact when all tests share one interval).
    """
    usable = [(seg, dt) for seg, dt in zip(layout.segments, layout.dt) if seg.n >= 2]
    if not usable:
        zeros = np.zeros((1, S.shape[1]))
        return np.zeros(1), zeros, 0.0, np.zeros(S.shape[1])
    step = min(dt for _, dt in usable)
    reach = max((seg.n - 1) * dt for seg, dt in usable)
    n_grid = int(math.floor(min(max_lag_s, reach) / step * (1 + 1e-12)))
    grid = step * np.arange(-n_grid, n_grid + 1)

    sums = np.zeros((grid.size, S.shape[1]))
    energy_r, energy_s = 0.0, np.zeros(S.shape[1])
    for seg, dt in usable:
        c = values[seg.slice] - np.mean(values[seg.slice])
        C = S[seg.slice] - np.mean(S[seg.slice], axis=0)
        energy_r += _sum_sq(c)
        energy_s += np.sum(np.square(C), axis=0)
        max_lag = min(int(math.ceil(max_lag_s / dt * (1 - 1e-12))), seg.n - 1)
        local = _lagged_sums(c, C, max_lag)
        if dt == step and max_lag >= n_grid:
            sums += local[max_lag - n_grid : max_lag + n_grid + 1]
        else:
            lags = dt * np.arange(-max_lag, max_lag + 1)
            for j in range(S.shape[1]):
                sums[:, j] += np.interp(grid, lags, local[:, j], left=0.0, right=0.0)

    scale = np.sqrt(energy_r * energy_s)
    corr = np.divide(sums, scale, out=np.zeros_like(sums), where=scale > 0)
    return grid, np.clip(corr, -1.0, 1.0), energy_r, energy_s
