"""Turn a machine, a programme and an ambient profile into test data."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import lru_cache

import numpy as np
import pandas as pd

from greyml._rng import make_generator
from greyml._sequences import make_test_index
from greyml.simulation import _check
from greyml.simulation._ambient import AmbientProfile, as_profile
from greyml.simulation._machine import (
    FBG_TEMPERATURE_SENSITIVITY_UE_PER_C,
    ThermalMachine,
)
from greyml.simulation._network import add_lag_states, propagate, zoh_discretize
from greyml.simulation._programme import Programme

__all__ = ["Effects", "HeatingTest", "simulate_test"]


@dataclass(frozen=True)
class Effects:
    """Physical effects of the simulation that can be switched off one at a time.

    Every flag is on by default. Switching one off removes one mechanism and
    changes nothing else: the noise of each kind of sensor is drawn from its
    own random stream, so the other columns stay bit for bit the same.

    Parameters
    ----------
    ambient_coupling : bool, default=True
        Changes of the ambient air reach the structure through convection.
        Off: the structure exchanges heat with air held at the temperature the
        ambient had at the start of the test (the ambient sensors and the
        ``ambient_C`` column still show the real air).
    sensor_lag : bool, default=True
        Surface-mounted temperature sensors follow their node through a
        first-order delay (Abdulshahed et al. (2016), Sec. 3.1: surface temperatures lag the
        displacement by about 10 min). Off: they read the node directly.
    initial_disequilibrium : bool, default=True
        A test with a ``history`` starts in the thermal state that the history
        left (a machine that ran or stood in different air before the test,
        Abdulshahed et al. (2015) Fig. 4a). Off: every test starts in equilibrium with the air.
    fbg_cross_sensitivity : bool, default=True
        FBG readings include the grating's own temperature response of
        8.64 µε/°C (Abdulshahed et al. (2016), Sec. 3). Off: pure mechanical strain.
    probe_drift : bool, default=True
        The displacement transducers drift slowly (the machine's
        ``probe_drift_um_per_h``). Off: no drift.
    extra_heat_source : bool, default=True
        The machine's optional heat sources (``HeatSource.extra``, the
        ballscrew nuts heated by feed) dissipate heat. Off: they do not.
    noise : bool, default=True
        White measurement noise on every sensor and on the displacement.

    Examples
    --------
    >>> from greyml.simulation import Effects
    >>> Effects.names()
    ('ambient_coupling', 'sensor_lag', 'initial_disequilibrium', 'fbg_cross_sensitivity',
     'probe_drift', 'extra_heat_source', 'noise')
    >>> quiet = Effects().without("noise", "probe_drift")
    >>> [name for name in Effects.names() if not getattr(quiet, name)]
    ['probe_drift', 'noise']
    >>> lag_only = Effects.none().with_("sensor_lag")
    >>> [name for name in Effects.names() if getattr(lag_only, name)]
    ['sensor_lag']
    """

    ambient_coupling: bool = True
    sensor_lag: bool = True
    initial_disequilibrium: bool = True
    fbg_cross_sensitivity: bool = True
    probe_drift: bool = True
    extra_heat_source: bool = True
    noise: bool = True

    @classmethod
    def names(cls) -> tuple:
        """Names of all the effects."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def none(cls) -> Effects:
        """Every effect off: the bare network."""
        return cls(**{name: False for name in cls.names()})

    def without(self, *names) -> Effects:
        """A copy with the named effects off.

        Examples
        --------
        >>> Effects().without("noise").noise
        False
        """
        return self._set(names, False)

    def with_(self, *names) -> Effects:
        """A copy with the named effects on."""
        return self._set(names, True)

    def _set(self, names, value):
        unknown = [n for n in names if n not in self.names()]
        if unknown:
            raise ValueError(f"Unknown effect(s) {unknown}; the effects are {list(self.names())}.")
        return replace(self, **{n: value for n in names})


@dataclass(frozen=True)
class HeatingTest:
    """One heating/cooling test to simulate.

    Parameters
    ----------
    label : str
        Test label in the ``test`` index level.
    programme : Programme
    ambient : AmbientProfile or float, default=20.0
    history : Programme, optional
        What the machine did before the test; it starts in the state this left
        (with ``Effects.initial_disequilibrium``).
    history_ambient : AmbientProfile or float, optional
        Air during the history; its time runs from the start of the history.
        Defaults to the test's ambient at its start.
    sample_s : float, optional
        Sampling interval; defaults to the machine's.
    note : str, default=""
        What the test is and where it comes from.

    Examples
    --------
    The same hour at 4000 rpm, once from cold and once after 2 h at
    8000 rpm and a 10 min pause: the warm test starts with the spindle
    carrier well above its cold start, the air sensors where they were.

    >>> from greyml.datasets import make_tests
    >>> from greyml.simulation import Effects, HeatingTest, Programme, vmc
    >>> run = Programme().run(60, spindle_rpm=4000)
    >>> cold = HeatingTest("cold", run)
    >>> warm = HeatingTest("warm", run, history=Programme().run(120, spindle_rpm=8000).dwell(10))
    >>> effects = Effects.none().with_("initial_disequilibrium")
    >>> data = make_tests(vmc(), [cold, warm], effects=effects)
    >>> data.tests, data.frame.shape
    (['cold', 'warm'], (122, 82))
    >>> start = data.frame.xs(0.0, level="time_s")[data.sensors]
    >>> warmer = start.loc["warm"] - start.loc["cold"]
    >>> bool(warmer.max() > 10.0), round(float(warmer.min()), 6)
    (True, 0.0)
    """

    label: str
    programme: Programme
    ambient: AmbientProfile | float = 20.0
    history: Programme | None = None
    history_ambient: AmbientProfile | float | None = None
    sample_s: float | None = None
    note: str = ""

    def __post_init__(self):
        _check.label(self.label, "The label of a HeatingTest")
        what = f"test {self.label!r}"
        if not isinstance(self.programme, Programme):
            raise ValueError(
                f"The programme of {what} must be a Programme; got {type(self.programme).__name__}."
            )
        if not self.programme.segments:
            raise ValueError(
                f"The programme of {what} is empty; add segments with run(), dwell() or cycle()."
            )
        as_profile(self.ambient, f"ambient of {what}")
        if self.history is not None and not isinstance(self.history, Programme):
            raise ValueError(
                f"The history of {what} must be a Programme or None; got "
                f"{type(self.history).__name__}."
            )
        if self.history_ambient is not None:
            as_profile(self.history_ambient, f"history_ambient of {what}")
        if self.sample_s is not None:
            _check.real(self.sample_s, f"sample_s of {what}", low=0.0, strict=True)


# ----------------------------------------------------------------- checking
def _check_programme(machine: ThermalMachine, programme: Programme, what: str):
    if not isinstance(programme, Programme):
        raise ValueError(f"{what} must be a Programme; got {type(programme).__name__}.")
    if not programme.segments:
        raise ValueError(f"{what} is empty; add segments with run(), dwell() or cycle().")
    for column in ("spindle_rpm", "feed_mm_min", "c_rpm"):
        levels = programme.levels(column)
        if column not in machine.inputs and np.any(levels > 0):
            k = int(np.flatnonzero(levels > 0)[0])
            raise ValueError(
                f"{what} commands '{column}' in segment {k}, but machine "
                f"{machine.name!r} has no such input (its inputs are "
                f"{list(machine.inputs)})."
            )
        limit = machine.max_input.get(column)
        if limit is not None and np.any(levels > limit):
            k = int(np.flatnonzero(levels > limit)[0])
            raise ValueError(
                f"{what} commands '{column}' = {levels[k]:g} in segment {k}, above "
                f"the maximum {limit:g} of machine {machine.name!r}."
            )


def _check_air(profile, t, label):
    """The ambient profile gives a finite temperature wherever it is used."""
    with np.errstate(all="ignore"):
        air = np.asarray(profile(t), dtype=float)
    bad = np.flatnonzero(~np.isfinite(air))
    if bad.size:
        k = int(bad[0])
        kind = "NaN" if np.isnan(air[k]) else "inf"
        raise ValueError(
            f"The ambient profile {profile!r} gives {air[k]!r} ({kind}) at time_s={t[k]:g} "
            f"of test {label!r}; it must give finite temperatures."
        )


# ------------------------------------------------------------- the pieces
def _step_grid(times, programme, profile, t_end):
    """Breakpoints of the piecewise-constant inputs, including ``times``."""
    pts = [times, programme.boundaries(), profile.breakpoints()]
    grid = np.unique(np.concatenate(pts))
    grid = grid[(grid >= 0) & (grid <= t_end)]
    # merge points closer than a microsecond (rounding of segment sums)
    keep = np.concatenate([[True], np.diff(grid) > 1e-6])
    return grid[keep]


def _node_power(machine, programme, starts, extra):
    S = machine.source_matrix(extra=extra)
    P = np.zeros((len(starts), machine.n_nodes))
    for k, src in enumerate(machine.sources):
        if not S[k].any():
            continue
        P += np.outer(src.power(programme.at(src.input, starts)), S[k])
    return P


@lru_cache(maxsize=64)
def _zoh_cached(a_bytes, a_shape, b_bytes, b_shape, h):
    A = np.frombuffer(a_bytes).reshape(a_shape)
    B = np.frombuffer(b_bytes).reshape(b_shape)
    Phi, Gamma = zoh_discretize(A, B, h)
    Phi.setflags(write=False)
    Gamma.setflags(write=False)
    return Phi, Gamma


def _discretise(A, B, steps):
    """One matrix exponential per distinct step length (remembered across calls).

    Every test of a machine shares A and B, and most share the sampling
    interval, so the exponentials are cached by (A, B, step).
    """
    rounded = np.round(steps, 9)
    lengths, kinds = np.unique(rounded, return_inverse=True)
    Phi = np.empty((len(lengths), A.shape[0], A.shape[0]))
    Gamma = np.empty((len(lengths), A.shape[0], B.shape[1]))
    a = np.ascontiguousarray(A, dtype=float)
    b = np.ascontiguousarray(B, dtype=float)
    key = (a.tobytes(), a.shape, b.tobytes(), b.shape)
    for k, h in enumerate(lengths):
        Phi[k], Gamma[k] = _zoh_cached(*key, float(h))
    return Phi, Gamma, kinds


def _run(A, B, machine, programme, air, x0, grid, extra):
    steps = np.diff(grid)
    starts = grid[:-1]
    P = _node_power(machine, programme, starts, extra)
    U = np.column_stack([P, air(starts + steps / 2.0)])
    Phi, Gamma, kinds = _discretise(A, B, steps)
    return propagate(Phi, Gamma, kinds, x0, U)


def _history_state(A, B, machine, history, history_ambient, extra):
    profile = as_profile(history_ambient)
    t_end = history.duration_s
    # a varying history ambient is held over at most one minute at a time
    grid = _step_grid(np.append(np.arange(0.0, t_end, 60.0), t_end), history, profile, t_end)
    x0 = np.full(A.shape[0], float(profile(0.0)))
    X = _run(A, B, machine, history, profile, x0, grid, extra)
    return X[-1]


def simulate_test(
    machine,
    programme,
    ambient=20.0,
    effects=None,
    *,
    history=None,
    history_ambient=None,
    sample_s=None,
    label="test",
    random_state=None,
):
    """Simulate one heating/cooling test of a machine.

    The network is integrated exactly for inputs held constant over each step
    (a zero-order hold); steps end at every sample time,
    every programme segment boundary and every jump of the ambient profile;
    a smoothly varying ambient is held at its value in the middle of each step.

    Parameters
    ----------
    machine : ThermalMachine
        E.g. :func:`~greyml.simulation.vmc` or :func:`~greyml.simulation.gantry`.
    programme : Programme
        What the machine does from ``time_s = 0``.
    ambient : AmbientProfile or float, default=20.0
        Air temperature, a function of the time from the test start.
    effects : Effects, optional
        Which effects to include; all by default.
    history : Programme, optional
        What the machine did before the test (used with
        ``effects.initial_disequilibrium``); without one, or with the effect
        off, the machine starts in equilibrium with the air.
    history_ambient : AmbientProfile or float, optional
        Air during the history, defaults to the ambient at the test start.
    sample_s : float, optional
        Sampling interval in s; the machine's default if omitted.
    label : str, default="test"
        The test label of the rows.
    random_state : int, numpy.random.Generator or None, default=None
        Seed of the measurement noise.

    Returns
    -------
    frame : DataFrame
        Indexed by ``(test, time_s)``. Columns: the machine's operating
        inputs (mean commanded value over ``[t, t + sample_s)``),
        ``ambient_C``, the temperature sensors ``T<k>_C`` (°C), the FBG
        sensors ``FBG<k>_ue`` (µε, relative to the test start) and the
        displacement targets ``d*_um`` (µm, relative to the test start).

    Examples
    --------
    >>> from greyml.simulation import Programme, vmc, Effects
    >>> p = Programme().run(60, spindle_rpm=8000).dwell(60)
    >>> df = simulate_test(vmc(), p, 20.0, Effects.none(), label="V")
    >>> df.shape
    (121, 82)
    >>> round(float(df["dy_um"].abs().max()))
    79
    """
    if not isinstance(machine, ThermalMachine):
        raise ValueError(f"machine must be a ThermalMachine; got {type(machine).__name__}.")
    effects = Effects() if effects is None else effects
    if not isinstance(effects, Effects):
        raise ValueError(f"effects must be an Effects instance; got {effects!r}.")
    _check_programme(machine, programme, "The programme")
    profile = as_profile(ambient)
    if label is None or not str(label).strip():
        raise ValueError(f"label must name the test (a non-empty string); got {label!r}.")
    rng = make_generator(random_state)
    try:
        dt = float(machine.sample_s if sample_s is None else sample_s)
    except (TypeError, ValueError):
        raise ValueError(
            f"sample_s must be a positive number of seconds; got {sample_s!r}."
        ) from None
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"sample_s must be positive; got {sample_s!r}.")
    n_samples = int(np.floor(programme.duration_s / dt + 1e-9)) + 1
    if n_samples < 2:
        raise ValueError(
            f"sample_s={dt:g} is longer than the programme ({programme.duration_s:g} s): the "
            "test would have a single sample."
        )
    times = np.arange(n_samples) * dt
    t_end = times[-1]

    # --- state equations, with one lag state per lagged surface sensor
    A, B = machine.state_matrices()
    n = machine.n_nodes
    sensors = machine.temperature_sensors
    W = np.zeros((len(sensors), n))
    w_amb = np.zeros(len(sensors))
    for k, s in enumerate(sensors):
        W[k], w_amb[k] = machine.node_vector(s.nodes)
    tau = np.array([s.lag_s for s in sensors], dtype=float)
    lagged = tau > 0
    # the lag states are integrated either way, so that switching the lag off
    # leaves the node temperatures bit for bit the same
    A, B = add_lag_states(A, B, W[lagged], w_amb[lagged], tau[lagged])

    if effects.ambient_coupling:
        air = profile
    else:
        air = as_profile(float(profile(0.0)))

    # --- initial state
    extra = effects.extra_heat_source
    if effects.initial_disequilibrium and history is not None:
        _check_programme(machine, history, "The history")
        h_amb = profile(0.0) if history_ambient is None else history_ambient
        as_profile(h_amb, "history_ambient")
        if not effects.ambient_coupling:
            h_amb = float(profile(0.0))
        x0 = _history_state(A, B, machine, history, h_amb, extra)
    else:
        x0 = np.full(A.shape[0], float(air(0.0)))

    # --- integrate and sample
    grid = _step_grid(times, programme, profile, t_end)
    _check_air(profile, np.union1d(times, (grid[:-1] + grid[1:]) / 2.0), label)
    X = _run(A, B, machine, programme, air, x0, grid, extra)
    idx = np.searchsorted(grid, times - 1e-6)
    X = X[idx]
    T = X[:, :n]
    dT = T - T[0]
    ambient_now = profile(times)

    rng_temp, rng_fbg, rng_probe = rng.spawn(3)

    columns = {}
    for col in machine.inputs:
        columns[col] = programme.mean_over(col, times, dt)
    columns["ambient_C"] = ambient_now

    # temperature sensors
    reading = T @ W.T + np.outer(ambient_now, w_amb)
    if effects.sensor_lag:
        reading[:, lagged] = X[:, n:]
    reading += np.array([s.offset_C for s in sensors])
    if effects.noise:
        sigma = np.array([s.noise_C for s in sensors])
        reading += rng_temp.standard_normal(reading.shape) * sigma
    for k, s in enumerate(sensors):
        columns[s.name] = reading[:, k]

    # FBG strain sensors
    if machine.fbg_sensors:
        fbgs = machine.fbg_sensors
        strain = dT @ machine.output_matrix([f.strain for f in fbgs]).T
        if effects.fbg_cross_sensitivity:
            grating = dT @ machine.output_matrix([f.nodes for f in fbgs]).T
            strain = strain + FBG_TEMPERATURE_SENSITIVITY_UE_PER_C * grating
        if effects.noise:
            sigma = np.array([f.noise_ue for f in fbgs])
            strain = strain + rng_fbg.standard_normal(strain.shape) * sigma
        for k, f in enumerate(fbgs):
            columns[f.name] = strain[:, k]

    # tool-point displacement
    targets = machine.target_names
    disp = dT @ machine.output_matrix([machine.displacement[t] for t in targets]).T
    if effects.probe_drift:
        rate = np.array([machine.probe_drift_um_per_h.get(t, 0.0) for t in targets])
        disp = disp + np.outer(times / 3600.0, rate)
    if effects.noise:
        sigma = np.array([machine.probe_noise_um.get(t, 0.0) for t in targets])
        disp = disp + rng_probe.standard_normal(disp.shape) * sigma
    for k, t in enumerate(targets):
        columns[t] = disp[:, k]

    index = make_test_index([label] * n_samples, times)
    return pd.DataFrame(columns, index=index)
