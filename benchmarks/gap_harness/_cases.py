"""The cases of the withheld-effect validation: real tests with every effect, a
simulation with one or two switched off.

greyml's simulator plays the real machine: random heating tests, the
"simulation" with effects withheld (and its own parameters a few percent
off, with their sensitivities as a user could compute for theirs), and the
cases outside the library (a located event, a custom heat input, a heater
the library lacks). :mod:`gap_harness._withheld` runs the diagnosis on
them. The simulation's parameter error and sensitivities are greyml's own
(:func:`greyml.gap.perturb_parameters`, :func:`greyml.gap.simulator_sensitivities`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from greyml.datasets import make_tests
from greyml.datasets._simulated import _machine, main_target
from greyml.gap import perturb_parameters, simulator_sensitivities
from greyml.simulation import Effects, HeatingTest, Programme, diurnal

__all__ = [
    "CUSTOM_COLUMN",
    "CUSTOM_NAME",
    "FOREIGN_COLUMN",
    "FOREIGN_NAME",
    "WITHHELD",
    "WithheldCase",
    "random_tests",
    "withheld_case",
]

#: The diagnosis's effect names and the simulator effects that produce them.
WITHHELD = {
    "ambient": "ambient_coupling",
    "heat_source": "extra_heat_source",
    "initial_state": "initial_disequilibrium",
    "drift": "probe_drift",
}

_LEVELS = (0.0, 0.0, 0.25, 0.5, 0.75, 1.0)


def random_tests(machine, rng, n_tests=6, hours=5.5):
    """Heating/cooling tests with random duty, diurnal air and some history.

    Each test is a run of blocks of 20-90 min with every input at a random
    level (0 to its maximum, off more often than not); the air follows a
    diurnal cycle of random mean, swing and phase; seven tests in ten (and at
    least two: an effect seen in one test alone cannot be checked on another)
    follow 30-120 min of spindle (first input) work in the test's starting
    air, so they start away from equilibrium.

    Examples
    --------
    >>> import numpy as np
    >>> tests = random_tests("vmc", np.random.default_rng(0), n_tests=3)
    >>> [t.label for t in tests], [t.history is not None for t in tests]
    (['T1', 'T2', 'T3'], [True, True, True])
    """
    m = _machine(machine)
    warm = rng.random(n_tests) < 0.7
    if warm.sum() < 2 <= n_tests:
        warm[rng.choice(n_tests, 2, replace=False)] = True
    out = []
    for k in range(n_tests):
        programme = Programme()
        total = 0.0
        while total < hours * 60.0:
            minutes = int(rng.integers(20, 90))
            levels = {c: float(rng.choice(_LEVELS)) * m.max_input.get(c, 1.0) for c in m.inputs}
            programme = programme.run(minutes, **levels)
            total += minutes
        air = diurnal(
            20.0 + rng.normal(0.0, 1.0),
            float(rng.uniform(0.5, 2.5)),
            start_hour=float(rng.uniform(0.0, 24.0)),
        )
        history = None
        if warm[k]:
            first = m.inputs[0]
            level = float(rng.choice([0.5, 1.0])) * m.max_input.get(first, 1.0)
            history = Programme().run(int(rng.integers(30, 120)), **{first: level})
        out.append(HeatingTest(f"T{k + 1}", programme, air, history))
    return out


@dataclass
class WithheldCase:
    """One withheld-effect case: the data the diagnosis gets, and the truth.

    Made by :func:`withheld_case`; ``real``, ``sim``, ``sensitivities`` and
    ``roles`` go to :func:`diagnose_gap`, the rest is the truth to check it
    against.

    Examples
    --------
    >>> case = withheld_case(("ambient",), 10, 0, n_tests=3)
    >>> sorted(case.roles)
    ['ambient', 'drivers', 'sensors', 'target']
    """

    real: pd.DataFrame
    sim: pd.DataFrame
    sensitivities: pd.DataFrame
    roles: dict  # target, ambient, drivers, sensors
    withheld: tuple
    effect: np.ndarray  # the withheld effects' part of the measured target
    parameter_gap: np.ndarray  # what the simulation's parameter error alone misses
    noise: np.ndarray  # the measurement noise of the target
    custom_effects: dict | None = None  # what the diagnosis is told of a "custom" case
    event: tuple | None = None  # (test, time_s, size) of an "event" case's step


def withheld_case(
    withheld,
    size,
    seed,
    *,
    machine="vmc",
    target=None,
    param_error=0.0,
    kind="class",
    n_tests=6,
    n_sensors=10,
):
    """Build one case: "real" with every effect, the simulation without ``withheld``.

    Each withheld effect's part of the target is scaled so that its peak is
    ``size`` times the standard deviation of the target's measurement noise.
    With ``param_error``, the simulation also runs with its parameters off
    (:func:`perturb_parameters`); its sensitivities are computed at those
    wrong parameters, as a user would compute them.

    Examples
    --------
    >>> import numpy as np
    >>> case = withheld_case(("drift",), 10, 0, n_tests=3)
    >>> case.roles["target"], round(float(np.abs(case.effect).max() / np.std(case.noise)), 3)
    ('dy_um', 10.0)
    """
    m = _machine(machine)
    target = target or main_target(m)
    withheld = tuple(withheld)
    if withheld in _EXTRA:
        return _extra_case(
            withheld[0], size, seed, m, target, param_error, kind, n_tests, n_sensors
        )
    unknown = [w for w in withheld if w not in WITHHELD]
    if unknown:
        raise ValueError(
            f"Cannot withhold {unknown}; the effects are {list(WITHHELD)} (or one of "
            f"{[e[0] for e in _EXTRA]} alone)."
        )
    rng = np.random.default_rng(seed)
    tests = random_tests(m, rng, n_tests)
    quiet, full, real, noise, sigma = _simulated(m, tests, target, seed)
    off = quiet.without(*(WITHHELD[w] for w in withheld))
    effect = np.zeros(len(full))
    for w in withheld:
        part = full[target] - make_tests(m, tests, effects=quiet.without(WITHHELD[w])).frame[target]
        peak = float(np.max(np.abs(part)))
        if peak == 0.0:
            raise ValueError(f"Withholding {w!r} does not change {target!r} on {m.name}.")
        effect += size * sigma / peak * part.to_numpy()
    sim_true = make_tests(m, tests, effects=off).frame[target].to_numpy()
    real = real.copy()
    real[target] = sim_true + effect + noise
    return _case(
        m,
        m,
        tests,
        target,
        off,
        param_error,
        seed,
        n_sensors,
        real,
        sim_true,
        noise,
        withheld=withheld,
        effect=effect,
    )


def _simulated(machine, tests, target, seed):
    """The tests simulated without noise (``full``) and with every effect (``real``).

    Returns the effects without noise, both frames, the noise of the target
    and its standard deviation.
    """
    quiet = Effects().without("noise")
    full = make_tests(machine, tests, effects=quiet).frame
    real = make_tests(machine, tests, effects=Effects(), random_state=seed).frame
    noise = (real[target] - full[target]).to_numpy()
    return quiet, full, real, noise, float(np.std(noise))


def _case(
    m, sim_m, tests, target, effects, param_error, seed, n_sensors, real, sim_true, noise, **extra
):
    """The simulation the diagnosis is given (``sim_m`` with its parameters
    ``param_error`` off), its sensitivities and the roles of the columns."""
    wrong = (
        perturb_parameters(sim_m, param_error, np.random.default_rng([seed, 1]))
        if param_error
        else sim_m
    )
    sim = make_tests(wrong, tests, effects=effects).frame[[target]]
    sensitivities = simulator_sensitivities(wrong, tests, target, effects=effects)
    names = list(m.temperature_names)
    sensors = names[:: max(1, len(names) // n_sensors)][:n_sensors]
    roles = {
        "target": target,
        "ambient": "ambient_C",
        "drivers": list(m.inputs),
        "sensors": sensors,
    }
    return WithheldCase(
        real=real,
        sim=sim,
        sensitivities=sensitivities,
        roles=roles,
        parameter_gap=sim_true - sim[target].to_numpy(),
        noise=noise,
        **extra,
    )


#: The logged column of a "custom" case and the name the diagnosis is told.
CUSTOM_COLUMN, CUSTOM_NAME = "pump_kW", "hydraulics"
#: The logged column of a "foreign" case, and the name it is given as a custom effect.
FOREIGN_COLUMN, FOREIGN_NAME = "fixture_kW", "fixture"
#: The cases outside the library (withheld alone).
_EXTRA = (("event",), ("custom",), ("foreign",), ("foreign_custom",))


def _fixture_heat(index, rng, tau_s):
    """A fixture heater's logged power and its part of the probe reading (unscaled).

    Per test: blocks of 30-120 min, each off or at half or full power (drawn,
    independently of the machine's duty), through one first-order lag of
    ``tau_s`` from rest at the test start.
    """
    from scipy.signal import lfilter

    labels = index.get_level_values("test")
    times = index.get_level_values("time_s").to_numpy(dtype=float)
    power = np.zeros(len(index))
    part = np.zeros(len(index))
    for test in pd.unique(labels):
        rows = np.flatnonzero(labels == test)
        t = times[rows] - times[rows[0]]
        edges = [0.0]
        while edges[-1] < t[-1]:
            edges.append(edges[-1] + 60.0 * float(rng.uniform(30.0, 120.0)))
        levels = rng.choice([0.0, 0.5, 1.0], size=len(edges))
        u = levels[np.searchsorted(edges, t, side="right") - 1]
        dt = float(np.median(np.diff(t)))
        a = np.exp(-dt / tau_s)
        power[rows] = u
        part[rows] = lfilter([1.0 - a], [1.0, -a], u)
    return power, part


def _with_pump(m):
    """The machine with a hydraulic unit on its base, driven by a third logged input."""
    from greyml.simulation import HeatSource

    node = "base" if "base" in m.nodes else m.nodes[-1]
    pump = HeatSource("hydraulic unit", "c_rpm", {node: 1.0}, power_W=150.0, reference=1.0)
    return replace(
        m,
        sources=tuple(m.sources) + (pump,),
        inputs=tuple(m.inputs) + ("c_rpm",),
        max_input={**m.max_input, "c_rpm": 1.0},
    )


def _extra_case(kind_of_case, size, seed, m, target, param_error, kind, n_tests, n_sensors):
    """A case outside the library: a step in the probe reading, or a custom heat input.

    ``"event"``: nothing withheld; the probe reading of one test (drawn)
    steps by 3 to 6 times the noise (drawn, either sign) at a time drawn
    between 10 % and 90 % of the test. ``"custom"``: the real machine has a
    hydraulic unit on its base, driven by a logged column (``pump_kW``) that
    the simulation lacks; its part of the target peaks at ``size`` times the
    noise, and the diagnosis is told of the column only as the custom effect
    ``"hydraulics"``. ``"foreign"``: a heater on the fixture, not in the
    simulation and not in the library, switched in blocks of its own (logged
    as ``fixture_kW``), reaches the probe through a lag of 60-120 min
    (drawn); its part peaks at ``size`` times the noise and the diagnosis is
    not told of it. ``"foreign_custom"``: the same, told of ``fixture_kW``
    as the custom effect ``"fixture"``.
    """
    rng = np.random.default_rng(seed)
    real_m = _with_pump(m) if kind_of_case == "custom" else m
    sim_m = replace(real_m, sources=m.sources)
    tests = random_tests(real_m, rng, n_tests)
    quiet, full, real, noise, sigma = _simulated(real_m, tests, target, seed)
    sim_true = make_tests(sim_m, tests, effects=quiet).frame[target].to_numpy()
    effect = np.zeros(len(full))
    custom, event = None, None
    if kind_of_case == "custom":
        part = full[target].to_numpy() - sim_true
        effect = size * sigma / float(np.max(np.abs(part))) * part
        real = real.rename(columns={"c_rpm": CUSTOM_COLUMN})
        custom = {CUSTOM_NAME: [CUSTOM_COLUMN]}
    elif kind_of_case in ("foreign", "foreign_custom"):
        tau_s = 60.0 * float(rng.uniform(60.0, 120.0))
        power, part = _fixture_heat(real.index, rng, tau_s)
        effect = size * sigma / float(np.max(np.abs(part))) * part
        real = real.assign(**{FOREIGN_COLUMN: power})
        if kind_of_case == "foreign_custom":
            custom = {FOREIGN_NAME: [FOREIGN_COLUMN]}
    else:
        labels = real.index.get_level_values("test")
        times = real.index.get_level_values("time_s").to_numpy(dtype=float)
        test = str(rng.choice(pd.unique(labels)))
        rows = np.flatnonzero(labels == test)
        t0, t1 = times[rows[0]], times[rows[-1]]
        at = float(rng.uniform(t0 + 0.1 * (t1 - t0), t0 + 0.9 * (t1 - t0)))
        step = float(rng.uniform(3.0, 6.0) * rng.choice([-1.0, 1.0]) * sigma)
        hit = rows[times[rows] >= at]
        effect[hit] = step
        event = (test, float(times[hit[0]]), step)
    real = real.copy()
    real[target] = sim_true + effect + noise
    return _case(
        m,
        sim_m,
        tests,
        target,
        quiet,
        param_error,
        seed,
        n_sensors,
        real,
        sim_true,
        noise,
        withheld=(kind_of_case,),
        effect=effect,
        custom_effects=custom,
        event=event,
    )
