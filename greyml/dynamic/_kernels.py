"""First-order thermal lags: the one O(n) kernel of greyml's dynamic models.

A first-order lag of an input x with time constant τ, exact for an input held
between samples (the sample-and-hold convention of a controller), is

    s_k = a_k · s_{k−1} + (1 − a_k) · x_k,    a_k = exp(−Δt_k / τ),

with Δt_k the step from the previous sample. Everything that needs a thermal lag
(``LagFeatures``, ``ThermalTransferFunction``, the sample-by-sample
``Compensator`` and the lag signatures of :mod:`greyml.gap`) calls these
functions, so batch and streaming results agree to the last bit: the streaming
update :func:`lag_step` performs the same two products and one sum per sample as
the batch recursion (``scipy.signal.lfilter`` where the sampling is even).

Pure array functions: no validation, no pandas.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

__all__ = ["lag_filter", "lag_step", "steady_state"]

# Above this share of rows that start a new run of equal steps, the recursion
# runs row by row (vectorised over columns and time constants) instead of one
# lfilter call per run of equal steps.
_RUN_SHARE = 0.02
# Values per lfilter call (inputs × samples) on evenly sampled runs: 4 MB.
_CHUNK_VALUES = 2**19


def steady_state(x0, n_taus):
    """The lag state at rest at input ``x0``: every lag equals the input.

    Parameters
    ----------
    x0 : ndarray of shape (p,)
    n_taus : int

    Returns
    -------
    state : ndarray of shape (p, n_taus)
    """
    x0 = np.asarray(x0, dtype=float)
    return np.repeat(x0[:, None], n_taus, axis=1)


def lag_step(state, x, a):
    """One sample of the lag recursion: ``a·state + (1 − a)·x``.

    The one update of a lag that every sample-by-sample caller uses (the
    batch recursion on uneven sampling, and :class:`greyml.Compensator`).

    Parameters
    ----------
    state : ndarray
        The lags after the previous sample: (p, m) for p inputs and a bank of
        m time constants, or (k,) for k terms each with its own time constant.
    x : ndarray
        The inputs at this sample, broadcasting against ``state``: (p, 1) for
        a bank, (k,) for terms.
    a : ndarray
        ``exp(−Δt/τ)`` for each time constant, broadcasting against ``state``.

    Returns
    -------
    state : ndarray, shaped as ``state``
    """
    # written as lfilter's direct form computes it: (1 − a)·x + a·s
    return (1.0 - a) * x + a * state


def _filter_even(xt, a, zi):
    """Lags along the last axis of ``xt`` (p, n) for one a; ``zi`` (p,) is the state before."""
    # lfilter's state for b = [1 − a], den = [1, −a] is z = a·s_prev
    y, _ = lfilter([1.0 - a], [1.0, -a], xt, axis=-1, zi=(a * zi)[:, None])
    return y


def lag_filter(x, dt, taus, test_bounds, *, carry=False, initial=None, idle=None, out=None):
    """First-order lags of every column of ``x`` at every time constant.

    Parameters
    ----------
    x : ndarray of shape (n, p)
        Inputs, tests stacked in the order of ``test_bounds``.
    dt : ndarray of shape (n,)
        Step in seconds from the previous sample to each row. ``dt`` at a test's
        first row is used only when the state is carried into that test.
    taus : ndarray of shape (m,)
        Time constants in seconds (> 0).
    test_bounds : sequence of (start, stop)
        Row ranges of the tests, contiguous and in order.
    carry : bool or sequence of bool, default=False
        Whether each test continues the state the test before it left,
        stepping by ``dt`` at its first row (one flag for every test, or one
        per test; the first test's flag is ignored). A test that does not
        carry starts at rest: every lag equals the input at its first row (or
        0 for the ``idle`` columns).
    initial : ndarray of shape (p, m), optional
        State before the first row; it is stepped into the first row by
        ``dt[0]``. By default the first test starts at rest.
    idle : ndarray of shape (p,) of bool, optional
        Columns whose lags start at 0 where a test starts without history (a
        heat source that was off before the test), instead of at the
        column's first value.
    out : ndarray of shape (p, m, n), optional
        C-contiguous float64 array to write the lags into (e.g. a block of a
        larger output array, so that the caller needs no copy); by default a
        new one is allocated.

    Returns
    -------
    lags : ndarray of shape (n, p, m)
        A view of ``out`` (or of the new array) with its axes moved.
    final : ndarray of shape (p, m)
        The state after the last row (to carry on, or to resume streaming).
    """
    x = np.asarray(x, dtype=float)
    dt = np.asarray(dt, dtype=float)
    taus = np.asarray(taus, dtype=float)
    n, p = x.shape
    m = taus.size
    # computed as (p, m, n), each lag a contiguous row, and handed back as an
    # (n, p, m) view: reshaped to (n, p·m) it is a Fortran-ordered array that a
    # DataFrame takes without copying
    store = np.empty((p, m, n)) if out is None else out
    out = np.moveaxis(store, 2, 0)
    xt = np.ascontiguousarray(x.T)
    links = np.broadcast_to(np.asarray(carry, dtype=bool), (len(test_bounds),))
    state = None if initial is None else np.array(initial, dtype=float, copy=True)
    for i, (start, stop) in enumerate(test_bounds):
        if stop <= start:
            continue
        if state is None or (i > 0 and not links[i]):
            # at rest at the first value: s_0 = x_0 (or 0 where idle) whatever the step
            before = steady_state(x[start], m)
            if idle is not None:
                before[np.asarray(idle, dtype=bool)] = 0.0
            first = start + 1
            out[start] = before
        else:
            before = state
            first = start
        _filter_segment(xt[:, first:stop], dt[first:stop], taus, before, store[:, :, first:stop])
        state = out[stop - 1].copy()
    if state is None:
        state = np.full((p, m), np.nan)
    return out, state


def _filter_segment(xt, steps, taus, before, store):
    """Run the recursion over the columns of ``xt`` (p, n) from state ``before`` (p, m)."""
    n = xt.shape[1]
    if n == 0:
        return
    change = np.flatnonzero(np.diff(steps) != 0) + 1
    if change.size > _RUN_SHARE * n + 1:
        # uneven sampling: row by row, vectorised over inputs and time constants
        a_all = np.exp(-steps[:, None] / taus[None, :])
        state = before
        for k in range(n):
            state = lag_step(state, xt[:, k, None], a_all[k])
            store[:, :, k] = state
        return
    run_starts = np.concatenate(([0], change))
    run_stops = np.concatenate((change, [n]))
    # lfilter returns a new array: in chunks of a few MB along time it is
    # recycled by the allocator instead of being fresh (page-faulting) memory;
    # a chunk continues from the last output of the one before, exactly as a
    # new run of equal steps does
    chunk = max(4096, _CHUNK_VALUES // max(1, xt.shape[0]))
    state = before
    for r0, r1 in zip(run_starts, run_stops):
        for j, tau in enumerate(taus):
            a = float(np.exp(-steps[r0] / tau))
            s = state[:, j]
            for c0 in range(r0, r1, chunk):
                c1 = min(c0 + chunk, r1)
                store[:, j, c0:c1] = _filter_even(xt[:, c0:c1], a, s)
                s = store[:, j, c1 - 1]
        state = store[:, :, r1 - 1]
