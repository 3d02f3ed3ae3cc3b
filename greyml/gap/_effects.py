"""The library of candidate unmodelled effects: physical signatures from measured columns.

Every effect is a small model of the gap r = measured − simulated built only
from what was measured (drivers, ambient air, temperature sensors, FBGs) and
from the simulation's own prediction, never from how a particular simulator
works inside. Each has linear gains (fitted by least squares) and at most one
time constant τ (searched on a grid); some have variants (one per driver or
per sensor) among which the calibration data choose.

All signatures start at 0 at each test's start, as a displacement measured
from the start of the test does.

Kernels here are pure array functions; :mod:`greyml.gap._search` fits and
scores them. Each effect's candidate is made by its builder (:data:`BUILDERS`;
the user's custom effects by :data:`CUSTOM_BUILDERS`), all with the one
signature ``builder(name, ctx, grid, spec)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from greyml._time import format_duration
from greyml.dynamic._kernels import lag_filter

__all__ = [
    "EFFECTS",
    "Bank",
    "Candidate",
    "LagCache",
    "first_order_lag",
    "lag_bank",
    "tau_grid",
    "BUILDERS",
    "CUSTOM_BUILDERS",
    "build_candidates",
    "custom_description",
]

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


def lag_bank(x, taus, dt, bounds):
    """First-order lags of the columns of ``x`` at every time constant, from rest at 0.

    y[k] = a·y[k−1] + (1 − a)·x[k] with a = exp(−dt/τ) and y = 0 before each
    test: greyml's one lag kernel (:func:`greyml.dynamic._kernels.lag_filter`)
    run on each test from a zero state.

    Parameters
    ----------
    x : ndarray of shape (n, p)
    taus : sequence of float
        Time constants in seconds (> 0).
    dt : sequence of float
        Sampling interval of each test in seconds (one per bound).
    bounds : sequence of (start, stop)

    Returns
    -------
    lags : ndarray of shape (n, p, len(taus))
    """
    x = np.asarray(x, dtype=float)
    taus = np.asarray(taus, dtype=float)
    n, p = x.shape
    out = np.empty((n, p, taus.size))
    zero = np.zeros((p, taus.size))
    for (start, stop), step in zip(bounds, dt):
        steps = np.full(stop - start, float(step))
        out[start:stop], _ = lag_filter(
            x[start:stop], steps, taus, [(0, stop - start)], carry=True, initial=zero
        )
    return out


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
    y = lag_bank(x.reshape(len(x), -1), [tau_s], dt, bounds)[:, :, 0]
    return y.reshape(x.shape)


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


class Bank:
    """A candidate's signatures as one array of columns and the columns of each setting.

    ``values`` (n, V, m) holds every column any setting uses, per variant;
    ``picks`` (S, k) the columns of each setting (setting s, variant v:
    ``values[:, v, picks[s]]``). A two-lag effect stores the lag at each of
    the 12 time constants once, not at each of the 66 pairs. Cross products
    per test are computed once and kept (:mod:`greyml.gap._fit`).
    """

    def __init__(self, values, picks):
        self.values = np.asarray(values, dtype=float)
        self.picks = np.asarray(picks, dtype=np.intp).reshape(len(picks), -1)
        self.cache = {}

    @classmethod
    def of_make(cls, make, settings):
        """The bank of any ``make(setting) -> (n, V, k)``: every setting's columns side by side."""
        blocks = [np.asarray(make(s), dtype=float) for s in settings]
        k = blocks[0].shape[2]
        return cls(np.concatenate(blocks, axis=2), np.arange(len(blocks) * k).reshape(-1, k))

    def features(self, index):
        """(n, V, k): the signatures of setting number ``index``."""
        return self.values[:, :, self.picks[index]]


def lag_picks(settings, taus):
    """The column of each time constant of each setting in a bank of lags at ``taus``."""
    where = {float(t): j for j, t in enumerate(taus)}
    return np.array([[where[float(t)] for t in s] for s in settings], dtype=np.intp)


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
    bank: object = None  # Bank; built from ``make`` when not given
    taus: tuple = ()  # the time constants the settings draw from (for placebos)
    grid: tuple = ()  # the search grid: its ends are the bounds (for warnings)

    def features(self, setting):
        return self.make(setting)

    def get_bank(self):
        """The candidate's :class:`Bank` (built once from ``make`` if not given)."""
        if self.bank is None:
            self.bank = Bank.of_make(self.make, self.settings)
        return self.bank


def _bank_candidate(effect, variants, settings, values, picks, describe, taus=(), grid=()):
    """A candidate whose signatures are columns of ``values`` (n, V, m) picked per setting."""
    bank = Bank(values, picks)
    index = {s: i for i, s in enumerate(settings)}

    def make(setting, bank=bank, index=index):
        return bank.features(index[setting])

    return Candidate(
        effect,
        variants,
        settings,
        make,
        describe,
        bank.picks.shape[1],
        bank,
        tuple(float(t) for t in taus),
        tuple(float(t) for t in grid),
    )


def _per_test_start(values, bounds):
    """Each row's value at its test's first row."""
    out = np.empty_like(values)
    for start, stop in bounds:
        out[start:stop] = values[start]
    return out


def fmt_tau(tau):
    """A time constant in words (:func:`greyml._time.format_duration`)."""
    return format_duration(tau)


def _taus(setting):
    return ", ".join(fmt_tau(t) for t in setting)


def _two_lag_candidate(effect, variants, x, grid, ctx, describe):
    """Two lags τ₁ < τ₂ of the columns of ``x`` (one variant per column, named in ``variants``)."""
    settings = two_lags(grid)
    values = lag_bank(x, grid, ctx.dt, ctx.bounds)
    return _bank_candidate(
        effect, list(variants), settings, values, lag_picks(settings, grid), describe, grid, grid
    )


def _sensor_rise(ctx):
    """Each sensor's rise from its test's first row, (n, p)."""
    return ctx.sensors - _per_test_start(ctx.sensors, ctx.bounds)


def _fixed_candidate(effect, variants, values, describe):
    """A candidate without a time constant: the columns of ``values`` (n, V, k) as they are."""
    k = values.shape[2]
    return _bank_candidate(effect, variants, [()], values, [list(range(k))], describe)


# --------------------------------------------------------------------------
# builders: one per effect, builder(name, ctx, grid, spec) -> Candidate, or a
# str saying why the effect cannot be tried on the columns given
# --------------------------------------------------------------------------


def _ambient(name, ctx, grid, spec):
    if ctx.ambient is None:
        return "needs the ambient column (ambient=)"
    rise = ctx.ambient - _per_test_start(ctx.ambient, ctx.bounds)

    def describe(v, s):
        return f"air {v} through two thermal lags ({_taus(s)})"

    return _two_lag_candidate(name, [ctx.ambient_name], rise[:, None], grid, ctx, describe)


def _heat_source(name, ctx, grid, spec):
    if ctx.drivers.shape[1] == 0:
        return "needs at least one driver column (drivers=)"

    def describe(v, s):
        return f"heat driven by {v}, thermal lags {_taus(s)}"

    return _two_lag_candidate(name, ctx.driver_names, _scaled(ctx.drivers), grid, ctx, describe)


def _sensor_lag(name, ctx, grid, spec):
    if ctx.sensors.shape[1] == 0:
        return "needs temperature sensor columns (sensors=)"
    longest = spec["max_sensor_lag_s"]
    rise = _sensor_rise(ctx)
    taus = grid[grid <= longest]
    taus = taus if taus.size else grid[:1]
    settings = one_lag(taus)
    values = rise[:, :, None] - lag_bank(rise, taus, ctx.dt, ctx.bounds)
    return _bank_candidate(
        name,
        list(ctx.sensor_names),
        settings,
        values,
        lag_picks(settings, taus),
        lambda v, s: f"structure ahead of {v} by about {_taus(s)}",
        taus,
        (grid[0], longest),
    )


def _initial_state(name, ctx, grid, spec):
    if ctx.ambient is None or ctx.sensors.shape[1] == 0:
        return "needs sensors and the ambient column"
    # how far each sensor (and their mean) starts from the air: the state the
    # test starts in, as far as the sensors see it
    start = ctx.sensors - ctx.ambient[:, None]
    start = np.column_stack([start.mean(axis=1), start])
    offset = _per_test_start(start, ctx.bounds)
    names = ["mean sensor"] + list(ctx.sensor_names)
    settings = two_lags(grid)
    values = offset[:, :, None] * -np.expm1(-ctx.t_s[:, None] / grid[None, :])[:, None, :]
    return _bank_candidate(
        name,
        names,
        settings,
        values,
        lag_picks(settings, grid),
        lambda v, s: f"start offset of {v} from the air relaxing with {_taus(s)}",
        grid,
        grid,
    )


def _drift(name, ctx, grid, spec):
    hours = (ctx.t_s / 3600.0)[:, None, None]
    return _fixed_candidate(
        name, ["time"], hours, lambda v, s: "linear in time since the test start"
    )


def _fbg_temperature(name, ctx, grid, spec):
    if not ctx.target_is_fbg:
        return "the target is not an FBG column (fbgs=)"
    if ctx.sensors.shape[1] == 0:
        return "needs temperature sensor columns (sensors=)"
    return _fixed_candidate(
        name,
        list(ctx.sensor_names),
        _sensor_rise(ctx)[:, :, None],
        lambda v, s: f"proportional to the rise of {v}",
    )


def _nonlinear_expansion(name, ctx, grid, spec):
    variants, columns = ["the simulated target squared"], [ctx.sim**2]
    if ctx.sensors.shape[1]:
        variants.append("the mean sensor rise squared")
        columns.append(_sensor_rise(ctx).mean(axis=1) ** 2)
    square = np.column_stack(columns)[:, :, None]
    return _fixed_candidate(name, variants, square, lambda v, s: f"proportional to {v}")


def _custom_columns(name, ctx, grid, spec):
    """Measured columns through two thermal lags, as ``heat_source``."""

    def describe(v, s):
        return f"user-defined: {v} through thermal lags {_taus(s)}"

    return _two_lag_candidate(name, spec["columns"], _scaled(spec["values"]), grid, ctx, describe)


def _custom_signatures(name, ctx, grid, spec):
    """The user's signature columns, used as they are (one variant)."""
    return _fixed_candidate(
        name,
        [", ".join(spec["columns"])],
        spec["values"][:, None, :],
        lambda v, s: f"user-defined signature ({v})",
    )


#: The builder of each effect, in the order of :data:`EFFECTS`.
BUILDERS = {
    "ambient": _ambient,
    "heat_source": _heat_source,
    "sensor_lag": _sensor_lag,
    "initial_state": _initial_state,
    "drift": _drift,
    "fbg_temperature": _fbg_temperature,
    "nonlinear_expansion": _nonlinear_expansion,
}

#: The builder of a user-defined effect, by the kind of its spec (see build_candidates).
CUSTOM_BUILDERS = {"columns": _custom_columns, "signatures": _custom_signatures}


def custom_description(kind, columns):
    """What a user-defined effect stands for (printed in reports)."""
    if kind == "columns":
        return f"user-defined: {', '.join(columns)} through a thermal lag"
    return "user-defined signature"


def build_candidates(ctx, effects, max_sensor_lag_s=3600.0, custom=None):
    """The candidates of the requested effects that the available columns allow.

    Every effect, built-in or user-defined, is built by its builder
    (:data:`BUILDERS`, :data:`CUSTOM_BUILDERS`) from the context, the grid of
    time constants and its spec.

    Parameters
    ----------
    ctx : GapContext
        Arrays of the measured roles (see :mod:`greyml.gap._prepare`).
    effects : sequence of str
    max_sensor_lag_s : float, default=3600
        Longest lag between the structure and a surface sensor tried; a
        longer one is no longer a sensor's lag but a different thermal path.
    custom : dict, optional
        User-defined effects: name -> ("columns", names, (n, p) array) for
        measured columns through two thermal lags, as ``heat_source``; or
        name -> ("signatures", names, (n, k) array) for signature columns
        used as they are.

    Returns
    -------
    candidates : list of Candidate
    skipped : dict
        Effect name -> why it cannot be tried on these columns.
    """
    grid = tau_grid(ctx.dt, ctx.durations)
    registry = {e: (BUILDERS[e], {"max_sensor_lag_s": max_sensor_lag_s}) for e in effects}
    for name, (kind, columns, values) in (custom or {}).items():
        registry[name] = (CUSTOM_BUILDERS[kind], {"columns": columns, "values": values})
    out, skipped = [], {}
    for name, (build, spec) in registry.items():
        made = build(name, ctx, grid, spec)
        if isinstance(made, str):
            skipped[name] = made
        else:
            out.append(made)
    return out, skipped


def _scaled(x):
    """Columns scaled to their largest absolute value (a column of zeros stays)."""
    scale = np.abs(x).max(axis=0)
    return x / np.where(scale > 0, scale, 1.0)


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
