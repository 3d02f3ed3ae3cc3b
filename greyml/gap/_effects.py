"""The library of candidate unmodelled effects: physical signatures from measured columns.

Every effect is a small model of the gap r = measured − simulated built only
from what was measured (drivers, ambient air, temperature sensors, FBGs) and
from the simulation's own prediction, never from how a particular simulator
works inside. Each has linear gains (fitted by least squares) and at most one
time constant τ (searched on a grid); some have variants (one per driver or
per sensor) among which the calibration data choose.

All signatures start at 0 at each test's start, as a displacement measured
from the start of the test does.

Kernels here are pure array functions; :mod:`greyml.gap._diagnose` fits and
scores them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

__all__ = ["EFFECTS", "Candidate", "LagCache", "first_order_lag", "tau_grid", "build_candidates"]

#: The fixed names of the effects, in the order they are tried.
EFFECTS = (
    "ambient",
    "heat_source",
    "sensor_lag",
    "initial_state",
    "drift",
    "fbg_temperature",
    "nonlinear_expansion",
)

#: What each effect stands for (printed in reports).
DESCRIPTIONS = {
    "ambient": "ambient air reaching the structure through a thermal lag",
    "heat_source": "an unmodelled heat input driven by a driver, through a thermal lag",
    "sensor_lag": "the structure leading or lagging its surface sensors",
    "initial_state": "machine not at equilibrium at the test start, decaying",
    "drift": "slow drift of the probe or sensors in time",
    "fbg_temperature": "temperature cross-sensitivity of the FBG readings",
    "nonlinear_expansion": "expansion not proportional to the temperature rise",
}


def first_order_lag(x, tau_s, dt, bounds):
    """First-order lag of the columns of ``x`` within each test, from rest.

    y[k] = a·y[k−1] + (1 − a)·x[k] with a = exp(−dt/τ), y before the test = 0;
    ``dt`` is the sampling interval of each test (one per bound).

    Parameters
    ----------
    x : ndarray of shape (n,) or (n, m)
    tau_s : float
        Time constant in seconds (> 0).
    dt : sequence of float
        Sampling interval of each test in seconds.
    bounds : sequence of (start, stop)

    Returns
    -------
    y : ndarray like ``x``
    """
    x = np.asarray(x, dtype=float)
    y = np.empty_like(x)
    for (start, stop), step in zip(bounds, dt):
        a = np.exp(-step / tau_s)
        y[start:stop] = lfilter([1.0 - a], [1.0, -a], x[start:stop], axis=0)
    return y


def tau_grid(dt, durations, n=12):
    """Time constants to search: from 2 samples to twice the longest test, log-spaced."""
    lo = max(2.0 * max(dt), 60.0)
    hi = max(2.0 * max(durations), 4.0 * lo)
    return np.geomspace(lo, hi, n)


def one_lag(grid):
    """Settings of one time constant."""
    return [(float(tau),) for tau in grid]


def two_lags(grid):
    """Settings of two time constants τ₁ < τ₂ (two thermal paths)."""
    return [(float(a), float(b)) for i, a in enumerate(grid) for b in grid[i + 1 :]]


class LagCache:
    """First-order lags of fixed columns, computed once per time constant."""

    def __init__(self, x, dt, bounds):
        self.x = np.asarray(x, dtype=float)
        self.dt = dt
        self.bounds = bounds
        self._lags = {}

    def __call__(self, tau):
        if tau not in self._lags:
            self._lags[tau] = first_order_lag(self.x, tau, self.dt, self.bounds)
        return self._lags[tau]

    def stack(self, setting):
        """(n, V, k): the lag of every column at every time constant of ``setting``."""
        return np.stack([self(tau) for tau in setting], axis=2)


@dataclass
class Candidate:
    """One effect's family of signatures.

    ``make(setting)`` gives an array of shape (n, n_variants, n_features): the
    signatures of every variant for one setting of the time constants
    (``settings`` lists them; ``[()]`` for an effect without one).
    ``variants`` names the variants (e.g. the driver or sensor each uses).
    """

    effect: str
    variants: list
    settings: list
    make: object
    describe: object  # callable (variant label, setting) -> str
    n_features: int

    def features(self, setting):
        return self.make(setting)


def _per_test_start(values, bounds):
    """Each row's value at its test's first row."""
    out = np.empty_like(values)
    for start, stop in bounds:
        out[start:stop] = values[start]
    return out


def fmt_tau(tau):
    """A time constant in words: minutes below 1.5 h, hours above."""
    return f"{tau / 60:.0f} min" if tau < 5400 else f"{tau / 3600:.1f} h"


def _taus(setting):
    return ", ".join(fmt_tau(t) for t in setting)


def build_candidates(ctx, effects, max_sensor_lag_s=3600.0):
    """The candidates of the requested effects that the available columns allow.

    Parameters
    ----------
    ctx : GapContext
        Arrays of the measured roles (see :mod:`greyml.gap._diagnose`).
    effects : sequence of str
    max_sensor_lag_s : float, default=3600
        Longest lag between the structure and a surface sensor tried; a
        longer one is no longer a sensor's lag but a different thermal path.

    Returns
    -------
    candidates : list of Candidate
    skipped : dict
        Effect name -> why it cannot be tried on these columns.
    """
    bounds, dt, t = ctx.bounds, ctx.dt, ctx.t_s
    grid = tau_grid(dt, ctx.durations)
    out, skipped = [], {}
    for effect in effects:
        if effect == "ambient":
            if ctx.ambient is None:
                skipped[effect] = "needs the ambient column (ambient=)"
                continue
            rise = ctx.ambient - _per_test_start(ctx.ambient, bounds)
            lags = LagCache(rise[:, None], dt, bounds)
            out.append(
                Candidate(
                    effect,
                    [ctx.ambient_name],
                    two_lags(grid),
                    lags.stack,
                    lambda v, s: f"air {v} through two thermal lags ({_taus(s)})",
                    2,
                )
            )
        elif effect == "heat_source":
            if ctx.drivers.shape[1] == 0:
                skipped[effect] = "needs at least one driver column (drivers=)"
                continue
            scale = np.abs(ctx.drivers).max(axis=0)
            lags = LagCache(ctx.drivers / np.where(scale > 0, scale, 1.0), dt, bounds)
            out.append(
                Candidate(
                    effect,
                    list(ctx.driver_names),
                    two_lags(grid),
                    lags.stack,
                    lambda v, s: f"heat driven by {v}, thermal lags {_taus(s)}",
                    2,
                )
            )
        elif effect == "sensor_lag":
            if ctx.sensors.shape[1] == 0:
                skipped[effect] = "needs temperature sensor columns (sensors=)"
                continue
            rise = ctx.sensors - _per_test_start(ctx.sensors, bounds)
            lags = LagCache(rise, dt, bounds)

            def lead(setting, rise=rise, lags=lags):
                return (rise - lags(setting[0]))[:, :, None]

            out.append(
                Candidate(
                    effect,
                    list(ctx.sensor_names),
                    one_lag(grid[grid <= max_sensor_lag_s]) or one_lag(grid[:1]),
                    lead,
                    lambda v, s: f"structure ahead of {v} by about {_taus(s)}",
                    1,
                )
            )
        elif effect == "initial_state":
            if ctx.ambient is None or ctx.sensors.shape[1] == 0:
                skipped[effect] = "needs sensors and the ambient column"
                continue
            # how far each sensor (and their mean) starts from the air: the
            # state the test starts in, as far as the sensors see it
            start = ctx.sensors - ctx.ambient[:, None]
            start = np.column_stack([start.mean(axis=1), start])
            offset = _per_test_start(start, bounds)
            names = ["mean sensor"] + list(ctx.sensor_names)

            def relax(setting, offset=offset):
                return np.stack([offset * -np.expm1(-t / tau)[:, None] for tau in setting], axis=2)

            out.append(
                Candidate(
                    effect,
                    names,
                    two_lags(grid),
                    relax,
                    lambda v, s: f"start offset of {v} from the air relaxing with {_taus(s)}",
                    2,
                )
            )
        elif effect == "drift":
            hours = (t / 3600.0)[:, None, None]
            out.append(
                Candidate(
                    effect,
                    ["time"],
                    [()],
                    lambda s, hours=hours: hours,
                    lambda v, s: "linear in time since the test start",
                    1,
                )
            )
        elif effect == "fbg_temperature":
            if not ctx.target_is_fbg:
                skipped[effect] = "the target is not an FBG column (fbgs=)"
                continue
            if ctx.sensors.shape[1] == 0:
                skipped[effect] = "needs temperature sensor columns (sensors=)"
                continue
            rise = ctx.sensors - _per_test_start(ctx.sensors, bounds)
            out.append(
                Candidate(
                    effect,
                    list(ctx.sensor_names),
                    [()],
                    lambda s, rise=rise: rise[:, :, None],
                    lambda v, s: f"proportional to the rise of {v}",
                    1,
                )
            )
        elif effect == "nonlinear_expansion":
            variants, columns = ["the simulated target squared"], [ctx.sim**2]
            if ctx.sensors.shape[1]:
                rise = ctx.sensors - _per_test_start(ctx.sensors, bounds)
                variants.append("the mean sensor rise squared")
                columns.append(rise.mean(axis=1) ** 2)
            square = np.column_stack(columns)[:, :, None]
            out.append(
                Candidate(
                    effect,
                    variants,
                    [()],
                    lambda s, square=square: square,
                    lambda v, s: f"proportional to {v}",
                    1,
                )
            )
        else:  # pragma: no cover - names are checked by the caller
            raise ValueError(effect)
    return out, skipped


def recalibration_candidate(ctx):
    """The simulation's own gain and timing, refitted: not an unmodelled effect.

    A simulation whose parameters are a few percent off misses the measurement
    by a multiple of its own prediction and of its rate: r ≈ a·s + b·(s − L_τ[s])
    with s the simulated target. Those terms are fitted before any effect, so
    that a mis-scaled or mis-timed simulation is not mistaken for an
    unmodelled heat source.
    """
    grid = tau_grid(ctx.dt, ctx.durations)
    lags = LagCache(ctx.sim[:, None], ctx.dt, ctx.bounds)

    def make(setting):
        lead = ctx.sim - lags(setting[0])[:, 0]
        return np.stack([ctx.sim, lead], axis=1)[:, None, :]

    return Candidate(
        "recalibration",
        ["simulated target"],
        one_lag(grid[grid <= max(ctx.durations)]),
        make,
        lambda v, s: f"gain and timing of the {v} (lead {_taus(s)})",
        2,
    )
