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
scores them. Every effect, of the library (:data:`LIBRARY`) or the user's
own, is one :class:`Effect` record: its name, what it stands for, the
columns it needs and its builder, ``builder(effect, ctx, grid) -> Candidate``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from greyml._time import format_duration
from greyml.dynamic._kernels import lag_filter

__all__ = [
    "DESCRIPTIONS",
    "EFFECTS",
    "LIBRARY",
    "Bank",
    "Candidate",
    "Effect",
    "LagCache",
    "build_candidates",
    "columns_effect",
    "first_order_lag",
    "lag_bank",
    "signature_effect",
    "tau_grid",
]

#: Longest lag between the structure and a surface sensor that ``sensor_lag``
#: tries; a longer one is no longer a sensor's lag but a different thermal path.
MAX_SENSOR_LAG_S = 3600.0

#: The roles an effect can need: what to give, in words, and whether a
#: context has it.
_ROLES = {
    "ambient": ("the ambient column (ambient=)", lambda ctx: ctx.ambient is not None),
    "drivers": ("at least one driver column (drivers=)", lambda ctx: ctx.drivers.shape[1] > 0),
    "sensors": ("temperature sensor columns (sensors=)", lambda ctx: ctx.sensors.shape[1] > 0),
    "fbg_target": ("an FBG target (the target among fbgs=)", lambda ctx: ctx.target_is_fbg),
}


@dataclass(frozen=True)
class Effect:
    """One candidate effect: what it is, what it needs and how its signatures are built.

    The library's effects (:data:`LIBRARY`) and the user's custom effects
    are records of this one kind.

    Parameters
    ----------
    name : str
        The name it is reported under.
    description : str
        What it stands for, in words.
    builder : callable
        ``builder(effect, ctx, grid) -> Candidate``: the effect's signatures
        on the measured roles ``ctx`` with time constants from ``grid``.
    columns : tuple of str
        The roles it needs (``"ambient"``, ``"drivers"``, ``"sensors"``,
        ``"fbg_target"``); without them it is not tried.

    Examples
    --------
    >>> from greyml.gap import LIBRARY
    >>> ambient = LIBRARY[0]
    >>> ambient.name, ambient.columns
    ('ambient', ('ambient',))
    >>> ambient.needs()
    'the ambient column (ambient=)'
    """

    name: str
    description: str
    builder: Callable
    columns: tuple = ()

    def needs(self):
        """The columns it needs, in words ("" when it needs none)."""
        return " and ".join(_ROLES[role][0] for role in self.columns)

    def missing(self, ctx):
        """Why it cannot be tried on ``ctx``'s columns, or "" when it can."""
        lacking = [role for role in self.columns if not _ROLES[role][1](ctx)]
        if not lacking:
            return ""
        return "needs " + " and ".join(_ROLES[role][0] for role in lacking)

    def build(self, ctx, grid):
        """The effect's :class:`Candidate` on ``ctx``."""
        return self.builder(self, ctx, grid)


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
    placebo: object = None  # callable rng -> Bank: its own placebo; random walks if None

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


def _taus(setting):
    return ", ".join(format_duration(t) for t in setting)


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
# builders: one per effect, builder(effect, ctx, grid) -> Candidate; the
# Effect record checks first that ctx has the columns the effect needs
# --------------------------------------------------------------------------


def _ambient(effect, ctx, grid):
    rise = ctx.ambient - _per_test_start(ctx.ambient, ctx.bounds)

    def describe(v, s):
        return f"air {v} through two thermal lags ({_taus(s)})"

    return _two_lag_candidate(effect.name, [ctx.ambient_name], rise[:, None], grid, ctx, describe)


def _heat_source(effect, ctx, grid):
    def describe(v, s):
        return f"heat driven by {v}, thermal lags {_taus(s)}"

    return _two_lag_candidate(
        effect.name, ctx.driver_names, _scaled(ctx.drivers), grid, ctx, describe
    )


def _sensor_lag(effect, ctx, grid):
    rise = _sensor_rise(ctx)
    taus = grid[grid <= MAX_SENSOR_LAG_S]
    taus = taus if taus.size else grid[:1]
    settings = one_lag(taus)
    values = rise[:, :, None] - lag_bank(rise, taus, ctx.dt, ctx.bounds)
    return _bank_candidate(
        effect.name,
        list(ctx.sensor_names),
        settings,
        values,
        lag_picks(settings, taus),
        lambda v, s: f"structure ahead of {v} by about {_taus(s)}",
        taus,
        (grid[0], MAX_SENSOR_LAG_S),
    )


def _initial_state(effect, ctx, grid):
    # how far each sensor (and their mean) starts from the air: the state the
    # test starts in, as far as the sensors see it
    start = ctx.sensors - ctx.ambient[:, None]
    start = np.column_stack([start.mean(axis=1), start])
    offset = _per_test_start(start, ctx.bounds)
    names = ["mean sensor"] + list(ctx.sensor_names)
    settings = two_lags(grid)
    shapes = -np.expm1(-ctx.t_s[:, None] / grid[None, :])[:, None, :]
    picks = lag_picks(settings, grid)
    cand = _bank_candidate(
        effect.name,
        names,
        settings,
        offset[:, :, None] * shapes,
        picks,
        lambda v, s: f"start offset of {v} from the air relaxing with {_taus(s)}",
        grid,
        grid,
    )
    cand.placebo = partial(_offset_placebo, shapes, ctx.bounds, len(names), picks)
    return cand


def _offset_placebo(shapes, bounds, n_variants, picks, rng):
    """``initial_state``'s placebo: random start offsets through the same relaxations.

    Any smooth gap that starts at 0 in each test is fitted in part by some
    per-test amplitude times a relaxation; the effect is credited only if the
    offsets the sensors give do better than as many random ones (one per
    test and variant).
    """
    offset = np.empty((shapes.shape[0], n_variants))
    for start, stop in bounds:
        offset[start:stop] = rng.standard_normal(n_variants)
    return Bank(offset[:, :, None] * shapes, picks)


def _drift(effect, ctx, grid):
    hours = (ctx.t_s / 3600.0)[:, None, None]
    cand = _fixed_candidate(
        effect.name, ["time"], hours, lambda v, s: "linear in time since the test start"
    )
    cand.placebo = partial(_time_placebo, ctx.t_s, min(ctx.dt))
    return cand


def _time_placebo(t_s, step, rng):
    """``drift``'s placebo: one random walk in time since the test start, the same in every test.

    ``drift`` is a function of the time since the start alone, the same in
    every test, so it can carry what all tests share to a held-out test; a
    random function of that time (a random walk in it) has the same freedom.
    The effect is credited only if a straight line does better than such
    random functions: a gap that merely rises in every test (a slow heat
    input the library lacks) is not taken for drift.
    """
    k = np.rint(t_s / step).astype(np.intp)
    walk = np.cumsum(rng.standard_normal(int(k.max()) + 1))
    walk -= walk[0]
    return Bank(walk[k][:, None, None], [[0]])


def _fbg_temperature(effect, ctx, grid):
    return _fixed_candidate(
        effect.name,
        list(ctx.sensor_names),
        _sensor_rise(ctx)[:, :, None],
        lambda v, s: f"proportional to the rise of {v}",
    )


def _nonlinear_expansion(effect, ctx, grid):
    variants, columns = ["the simulated target squared"], [ctx.sim**2]
    if ctx.sensors.shape[1]:
        variants.append("the mean sensor rise squared")
        columns.append(_sensor_rise(ctx).mean(axis=1) ** 2)
    square = np.column_stack(columns)[:, :, None]
    return _fixed_candidate(effect.name, variants, square, lambda v, s: f"proportional to {v}")


#: The library of effects, in the order they are tried.
LIBRARY = (
    Effect(
        "ambient",
        "ambient air reaching the structure through a thermal lag",
        _ambient,
        ("ambient",),
    ),
    Effect(
        "heat_source",
        "an unmodelled heat input driven by a driver, through a thermal lag",
        _heat_source,
        ("drivers",),
    ),
    Effect(
        "sensor_lag",
        "the structure leading or lagging its surface sensors",
        _sensor_lag,
        ("sensors",),
    ),
    Effect(
        "initial_state",
        "machine not at equilibrium at the test start, decaying",
        _initial_state,
        ("sensors", "ambient"),
    ),
    Effect("drift", "slow drift of the probe or sensors in time", _drift),
    Effect(
        "fbg_temperature",
        "temperature cross-sensitivity of the FBG readings",
        _fbg_temperature,
        ("fbg_target", "sensors"),
    ),
    Effect(
        "nonlinear_expansion",
        "expansion not proportional to the temperature rise",
        _nonlinear_expansion,
    ),
)

#: The names of the library's effects, in the order they are tried (a view of :data:`LIBRARY`).
EFFECTS = tuple(effect.name for effect in LIBRARY)

#: What each effect of the library stands for (a view of :data:`LIBRARY`).
DESCRIPTIONS = {effect.name: effect.description for effect in LIBRARY}

_BY_NAME = {effect.name: effect for effect in LIBRARY}


def library_effects(names):
    """The library's :class:`Effect` records of ``names`` (checked names), in that order."""
    return [_BY_NAME[name] for name in names]


def _custom_columns(effect, ctx, grid, *, columns, values):
    """Measured columns through two thermal lags, as ``heat_source``."""

    def describe(v, s):
        return f"user-defined: {v} through thermal lags {_taus(s)}"

    return _two_lag_candidate(effect.name, columns, _scaled(values), grid, ctx, describe)


def _custom_signatures(effect, ctx, grid, *, columns, values):
    """The user's signature columns, used as they are (one variant)."""
    return _fixed_candidate(
        effect.name,
        [", ".join(columns)],
        values[:, None, :],
        lambda v, s: f"user-defined signature ({v})",
    )


def columns_effect(name, columns, values):
    """A user-defined :class:`Effect`: measured columns through two thermal lags.

    ``values`` (n, p) holds the columns named in ``columns``; each is scaled
    to its largest value and is one variant, as a driver of ``heat_source``.
    """
    columns = tuple(columns)
    return Effect(
        name,
        f"user-defined: {', '.join(columns)} through a thermal lag",
        partial(_custom_columns, columns=columns, values=np.asarray(values, dtype=float)),
    )


def signature_effect(name, columns, values):
    """A user-defined :class:`Effect`: signature columns (n, k) whose gains are fitted."""
    return Effect(
        name,
        "user-defined signature",
        partial(_custom_signatures, columns=tuple(columns), values=np.asarray(values, dtype=float)),
    )


def build_candidates(ctx, effects):
    """The candidates of ``effects`` that the available columns allow.

    Parameters
    ----------
    ctx : GapContext
        Arrays of the measured roles (see :mod:`greyml.gap._prepare`).
    effects : sequence of Effect
        The library's effects asked for, then the user's.

    Returns
    -------
    candidates : list of Candidate
    skipped : dict
        Effect name -> why it cannot be tried on these columns.
    """
    grid = tau_grid(ctx.dt, ctx.durations)
    out, skipped = [], {}
    for effect in effects:
        why = effect.missing(ctx)
        if why:
            skipped[effect.name] = why
        else:
            out.append(effect.build(ctx, grid))
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
