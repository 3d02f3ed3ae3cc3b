"""A simulated fleet of machine tools: the development set beyond CAIVIAC (issue 38).

Eight machines built from :mod:`greyml.simulation`, each a variant of one of
the seed papers' networks (:func:`~greyml.simulation.vmc`, the VMC of
Abdulshahed et al. (2015, 2017); :func:`~greyml.simulation.gantry`, the
gantry of Abdulshahed et al. (2016)). They differ in

* time constants: every heat capacity multiplied by ``slow`` (the network's
  time constants scale with it), every conductance to the air by ``film``;
* sensor layout: 6 to 20 temperature sensors, on the heat sources, on the
  structure far from them, and in the air;
* ambient: constant, a linear drift, the daily cycle, doors opening;
* programme: speed steps, staircases, on/off cycles, idle stretches;
* recording: ``carried`` machines record their tests as consecutive pieces of
  one clock (the state carried from piece to piece, as CAIVIAC does); the
  others record separate tests, each on its own clock starting at rest.

Machine ``vmc-cold`` starts its recording with a day-long (24 h) warm-up from
cold (everything at the air temperature at ``time_s = 0``), followed by
shorter tests on the same clock.

Measurements: every temperature is read with white noise of a quarter of the
sensor's resolution and then rounded to that resolution (0.01 to 0.1 °C);
the probe has white noise of 0.1 to 0.3 µm; the probe fixture does not drift.
The displacement ``y`` is in µm from the recording's zero (the machine at
rest in the air at the recording's start), as a probe zeroed then reads it.
Everything is seeded: the same call gives the same numbers, bit for bit.

``fleet()`` returns one :class:`Machine` per machine, a named tuple
``(name, X, y, drivers, description)``: ``X`` holds the drivers and the
temperatures ``T1_C`` … indexed by ``(test, time_s)`` (:func:`greyml.make_test_index`).
:data:`SPECS` holds what each machine was built from (resolution, the test
that starts from cold, whether the state is carried).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
import pandas as pd

#: Seed of the fleet's programmes and measurement noise.
FLEET_SEED = 38
#: Sampling interval of every machine (s).
SAMPLE_S = 60.0


class Machine(NamedTuple):
    """One machine of the fleet, as the benchmark uses it."""

    name: str
    X: pd.DataFrame
    y: pd.Series
    drivers: tuple
    description: str


@dataclass(frozen=True)
class Spec:
    """How one machine of the fleet is built.

    ``base`` names the network (``"vmc"``, ``"vmc-probe"``, ``"gantry"``);
    ``slow`` multiplies every heat capacity, ``film`` every convective
    conductance; ``sensors`` is the layout (category, node weights, surface
    lag in s); ``ambient`` is the kind of air; ``programmes`` the kind of each
    test's programme; ``carried``: one clock with the state carried, else
    separate tests from rest; ``cold_day``: the first test is a 24 h warm-up
    from cold.
    """

    name: str
    base: str
    target: str
    drivers: tuple
    slow: float
    film: float
    resolution_C: float
    probe_noise_um: float
    sensors: tuple
    ambient: str
    programmes: tuple
    carried: bool
    cold_day: bool = False
    power: float = 1.0

    @property
    def cold_test(self):
        """Label of the day-long warm-up from cold, or None."""
        return "1" if self.cold_day else None

    @property
    def sensor_names(self):
        return [f"T{k}_C" for k in range(1, len(self.sensors) + 1)]


AIR = "ambient"

# Sensor placements on the VMC network (category, node weights, surface lag s)
_VMC_PLACES = {
    "bearings": ("spindle boss", {"spindle_boss": 0.7, "spindle_bearings": 0.3}, 120.0),
    "boss": ("spindle boss", {"spindle_boss": 1.0}, 120.0),
    "motor": ("motors", {"spindle_motor": 1.0}, 120.0),
    "carrier_f": ("spindle carrier", {"carrier_front": 1.0}, 180.0),
    "carrier_r": ("spindle carrier", {"carrier_rear": 1.0}, 180.0),
    "carrier_m": ("spindle carrier", {"carrier_front": 0.5, "spindle_motor": 0.5}, 180.0),
    "column_f": ("column", {"column_front": 1.0}, 300.0),
    "column_r": ("column", {"column_rear": 1.0}, 300.0),
    "column_m": ("column", {"column_front": 0.5, "column_rear": 0.5}, 300.0),
    "base": ("base (far from the sources)", {"base": 1.0}, 300.0),
    "base_t": ("base (far from the sources)", {"base": 0.7, "table": 0.3}, 300.0),
    "table": ("table (far from the sources)", {"table": 1.0}, 300.0),
    "x_screw": ("ballscrews", {"x_screw": 1.0}, 60.0),
    "y_screw": ("ballscrews", {"y_screw": 1.0}, 60.0),
    "z_screw": ("ballscrews", {"z_screw": 1.0}, 60.0),
    "x_motor": ("motors", {"x_motor": 1.0}, 120.0),
    "air_col": ("air near the column", {AIR: 0.9, "column_front": 0.1}, 0.0),
    "air_base": ("air near the base", {AIR: 0.95, "base": 0.05}, 0.0),
    "air": ("air", {AIR: 1.0}, 0.0),
}

# ... and on the gantry network
_GANTRY_PLACES = {
    "c_axis": ("ram", {"c_axis": 0.6, "ram_lower": 0.4}, 600.0),
    "ram_lower": ("ram", {"ram_lower": 0.7, "z_bearing": 0.3}, 600.0),
    "ram_top_f": ("ram", {"ram_top": 0.8, "ram_front": 0.2}, 600.0),
    "ram_top_r": ("ram", {"ram_top": 0.8, "ram_rear": 0.2}, 600.0),
    "ram_front": ("ram", {"ram_front": 1.0}, 600.0),
    "z_motor": ("Z motor", {"z_motor": 1.0}, 600.0),
    "z_screw": ("Z ballscrew", {"z_screw": 0.6, "z_bearing": 0.4}, 300.0),
    "saddle": ("saddle", {"saddle": 1.0}, 600.0),
    "beam": ("cross-beam (far from the sources)", {"beam_front": 0.5, "beam_rear": 0.5}, 600.0),
    "upright": ("uprights (far from the sources)", {"uprights": 1.0}, 600.0),
    "bed": ("bed (far from the sources)", {"bed": 1.0}, 600.0),
    "air_saddle": ("air", {AIR: 0.9, "saddle": 0.1}, 0.0),
    "air_bed": ("air", {AIR: 0.95, "bed": 0.05}, 0.0),
    "air": ("air", {AIR: 1.0}, 0.0),
}


def _places(table, *keys):
    return tuple(table[k] for k in keys)


#: The eight machines.
SPECS = (
    Spec(
        "vmc-steps",
        "vmc",
        "dy_um",
        ("spindle_rpm",),
        slow=1.0,
        film=1.0,
        resolution_C=0.1,
        probe_noise_um=0.2,
        sensors=_places(
            _VMC_PLACES,
            "bearings",
            "motor",
            "carrier_f",
            "carrier_r",
            "column_f",
            "column_r",
            "base",
            "table",
            "air_col",
            "air_base",
        ),
        ambient="constant",
        programmes=("steps", "staircase", "steps", "onoff", "idle", "staircase", "steps"),
        carried=True,
        power=0.6,
    ),
    Spec(
        "vmc-slow-diurnal",
        "vmc",
        "dy_um",
        ("spindle_rpm",),
        slow=2.5,
        film=0.8,
        resolution_C=0.05,
        probe_noise_um=0.3,
        sensors=_places(
            _VMC_PLACES,
            "bearings",
            "boss",
            "motor",
            "carrier_f",
            "carrier_r",
            "carrier_m",
            "column_f",
            "column_r",
            "column_m",
            "base",
            "base_t",
            "table",
            "air_col",
            "air_base",
        ),
        ambient="diurnal",
        programmes=("staircase", "steps", "onoff", "staircase", "steps", "onoff"),
        carried=False,
        power=0.6,
    ),
    Spec(
        "vmc-fast-drift",
        "vmc",
        "dz_um",
        ("spindle_rpm",),
        slow=0.5,
        film=1.2,
        resolution_C=0.01,
        probe_noise_um=0.1,
        sensors=_places(_VMC_PLACES, "motor", "carrier_r", "column_m", "base", "table", "air"),
        ambient="drift",
        programmes=("onoff", "steps", "staircase", "onoff", "idle", "steps"),
        carried=True,
    ),
    Spec(
        "vmc-doors",
        "vmc",
        "dy_um",
        ("spindle_rpm", "feed_mm_min"),
        slow=1.0,
        film=1.0,
        resolution_C=0.1,
        probe_noise_um=0.2,
        sensors=_places(
            _VMC_PLACES,
            "bearings",
            "carrier_m",
            "column_r",
            "base",
            "x_screw",
            "y_screw",
            "x_motor",
            "air_base",
        ),
        ambient="doors",
        programmes=("steps", "onoff", "staircase", "idle", "steps", "staircase", "onoff"),
        carried=False,
        power=0.6,
    ),
    Spec(
        "vmc-probe-feed",
        "vmc-probe",
        "dx_um",
        ("spindle_rpm", "feed_mm_min"),
        slow=1.5,
        film=1.0,
        resolution_C=0.05,
        probe_noise_um=0.3,
        sensors=_places(
            _VMC_PLACES,
            "bearings",
            "motor",
            "carrier_f",
            "column_f",
            "base",
            "x_screw",
            "y_screw",
            "z_screw",
            "x_motor",
            "air_col",
            "air_base",
        ),
        ambient="drift+doors",
        programmes=("steps", "staircase", "onoff", "steps", "idle", "staircase"),
        carried=True,
    ),
    Spec(
        "gantry-c",
        "gantry",
        "dz_um",
        ("c_rpm",),
        slow=1.0,
        film=1.0,
        resolution_C=0.05,
        probe_noise_um=0.2,
        sensors=_places(
            _GANTRY_PLACES,
            "c_axis",
            "ram_lower",
            "ram_top_f",
            "ram_top_r",
            "ram_front",
            "z_motor",
            "saddle",
            "beam",
            "upright",
            "bed",
            "air_saddle",
            "air_bed",
        ),
        ambient="constant+doors",
        programmes=("steps", "staircase", "onoff", "steps", "staircase", "onoff"),
        carried=True,
        power=0.7,
    ),
    Spec(
        "gantry-z-diurnal",
        "gantry",
        "dz_um",
        ("feed_mm_min", "c_rpm"),
        slow=0.7,
        film=1.0,
        resolution_C=0.1,
        probe_noise_um=0.3,
        sensors=_places(
            _GANTRY_PLACES,
            "c_axis",
            "ram_lower",
            "ram_top_f",
            "ram_front",
            "z_motor",
            "z_screw",
            "saddle",
            "beam",
            "upright",
            "bed",
            "air_saddle",
            "air_bed",
            "air",
            "ram_top_r",
            "c_axis",
            "bed",
        ),
        ambient="diurnal",
        programmes=("onoff", "steps", "staircase", "onoff", "steps", "idle"),
        carried=False,
        power=0.4,
    ),
    Spec(
        "vmc-cold",
        "vmc",
        "dy_um",
        ("spindle_rpm",),
        slow=4.0,
        film=0.7,
        resolution_C=0.02,
        probe_noise_um=0.2,
        sensors=_places(
            _VMC_PLACES,
            "bearings",
            "boss",
            "motor",
            "carrier_f",
            "carrier_r",
            "carrier_m",
            "column_f",
            "column_r",
            "column_m",
            "base",
            "base_t",
            "table",
            "x_screw",
            "y_screw",
            "z_screw",
            "x_motor",
            "air_col",
            "air_base",
            "air",
            "bearings",
        ),
        ambient="diurnal",
        programmes=("warmup", "steps", "onoff", "staircase", "idle", "steps"),
        carried=True,
        cold_day=True,
        power=0.5,
    ),
)


# Machines --------------------------------------------------------------------


def _network(spec):
    """The spec's ThermalMachine: a preset with scaled time constants and its own sensors."""
    from greyml.simulation import TemperatureSensor, gantry, vmc

    base = {"vmc": vmc, "vmc-probe": lambda: vmc("probe"), "gantry": gantry}[spec.base]()
    # with no offsets a machine at rest reads the air on every sensor (the cold start)
    sensors = tuple(
        TemperatureSensor(
            name,
            category,
            nodes,
            lag_s=lag_s,
            offset_C=0.0,
            noise_C=spec.resolution_C / 4.0,
        )
        for name, (category, nodes, lag_s) in zip(spec.sensor_names, spec.sensors)
    )
    return replace(
        base.scaled(spec.power),
        capacity=tuple(c * spec.slow for c in base.capacity),
        convection={k: v * spec.film for k, v in base.convection.items()},
        temperature_sensors=sensors,
        fbg_sensors=(),
        displacement={spec.target: base.displacement[spec.target]},
        probe_noise_um={spec.target: spec.probe_noise_um},
        probe_drift_um_per_h={},
        sample_s=SAMPLE_S,
        max_input={},
    )


def _levels(spec):
    """The top level of each driver (rpm or mm/min)."""
    return {
        "spindle_rpm": 9000.0 if spec.base == "vmc-probe" else 8000.0,
        "feed_mm_min": 5000.0 if spec.base.startswith("vmc") else 70000.0,
        "c_rpm": 2500.0,
    }


def _programme(kind, spec, rng):
    """One test's programme of ``kind``; levels drawn from ``rng``, every driver used."""
    from greyml.simulation import Programme

    top = _levels(spec)

    def at(fraction):
        return {d: round(top[d] * fraction, -1) for d in spec.drivers}

    p = Programme(name=kind)
    if kind == "warmup":  # a day at a steady speed, from cold
        return p.run(hours=24, **at(0.7))
    if kind == "steps":
        a, b = rng.uniform(0.3, 0.6), rng.uniform(0.7, 1.0)
        return p.run(int(rng.integers(60, 120)), **at(a)).run(90, **at(b)).dwell(120)
    if kind == "staircase":
        for level in np.sort(rng.uniform(0.25, 1.0, size=4)):
            p = p.run(40, **at(level))
        return p.dwell(100)
    if kind == "onoff":
        on, off = int(rng.integers(10, 30)), int(rng.integers(10, 30))
        return p.cycle(on * 60, off * 60, minutes=200, **at(rng.uniform(0.6, 1.0))).dwell(60)
    if kind == "idle":  # a short job, then a long stand (cooling, the air moving)
        return p.run(30, **at(rng.uniform(0.4, 0.8))).dwell(210)
    raise AssertionError(kind)


def _air(kind, rng, t0=0.0):
    """The air of a recording (or of one separate test, its clock shifted by ``t0`` s)."""
    from greyml.simulation import diurnal, door_openings, linear_drift

    base = float(rng.uniform(18.5, 22.5))
    hour = (8.0 + t0 / 3600.0) % 24.0
    doors = tuple(np.sort(rng.uniform(600.0, 5 * 3600.0, size=3)))
    if kind == "constant":
        return base
    if kind == "diurnal":
        return diurnal(base, float(rng.uniform(1.0, 2.5)), start_hour=hour)
    if kind == "drift":
        return linear_drift(base, float(rng.uniform(-0.3, 0.4)))
    if kind == "doors":
        return door_openings(base, doors, drop_C=float(rng.uniform(1.0, 3.0)), duration_s=600.0)
    if kind == "drift+doors":
        return linear_drift(0.0, float(rng.uniform(-0.2, 0.3))) + door_openings(
            base, doors, drop_C=1.5, duration_s=900.0
        )
    if kind == "constant+doors":
        return door_openings(base, doors[:2], drop_C=2.0, duration_s=1200.0)
    raise AssertionError(kind)


def _carried_air(kind, rng, durations):
    """One recording's air: doors open within each piece, not all in the first hours."""
    from greyml.simulation import door_openings

    air = _air(kind.replace("+doors", "").replace("doors", "constant"), rng)
    if "doors" not in kind:
        return air
    starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]])
    at = tuple(float(s + rng.uniform(0.1, 0.8) * d) for s, d in zip(starts, durations))
    return air + door_openings(0.0, at, drop_C=float(rng.uniform(1.0, 2.5)), duration_s=900.0)


def _quantise(X, columns, step):
    X[columns] = np.round(X[columns].to_numpy() / step) * step
    return X


def _build(spec, seed):
    from greyml import make_test_index
    from greyml.simulation import Effects, Programme, simulate_test

    rng = np.random.default_rng([seed, SPECS.index(spec)])
    machine = _network(spec)
    programmes = [_programme(kind, spec, rng) for kind in spec.programmes]
    labels = [str(k) for k in range(1, len(programmes) + 1)]
    effects = Effects().without("probe_drift")
    keep = [*spec.drivers, *spec.sensor_names, spec.target]
    if spec.carried:
        durations = [p.duration_s for p in programmes]
        whole = Programme(sum((p.segments for p in programmes), ()), name=spec.name)
        air = _carried_air(spec.ambient, rng, durations)
        frame = simulate_test(machine, whole, air, effects, label=spec.name, random_state=rng)
        t = frame.index.get_level_values("time_s").to_numpy(float)
        edges = np.concatenate([[0.0], np.cumsum(durations)])
        piece = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(labels) - 1)
        frame = frame.set_index(make_test_index(np.asarray(labels)[piece], t))[keep]
    else:
        parts = []
        for label, programme in zip(labels, programmes):
            air = _air(spec.ambient, rng, t0=float(rng.uniform(0, 12 * 3600)))
            parts.append(
                simulate_test(machine, programme, air, effects, label=label, random_state=rng)[keep]
            )
        frame = pd.concat(parts)
    frame = _quantise(frame, spec.sensor_names, spec.resolution_C)
    X = frame[[*spec.drivers, *spec.sensor_names]].astype(float)
    y = frame[spec.target].astype(float).rename(f"{spec.name}/{spec.target}")
    return Machine(spec.name, X, y, tuple(spec.drivers), describe(spec, X, y))


def describe(spec, X=None, y=None):
    """One line: the network, time constants, sensors, air, programmes, recording."""
    recording = (
        "one clock, state carried from test to test"
        if spec.carried
        else "separate tests, each on its own clock from rest"
    )
    far = sum("far" in c or "air" in c for c, _, _ in spec.sensors)
    text = (
        f"{spec.base} network, capacities x{spec.slow:g}, convection x{spec.film:g}, "
        f"heat x{spec.power:g}; {len(spec.sensors)} sensors ({far} far from the sources or in "
        f"the air), resolution {spec.resolution_C:g} °C; air {spec.ambient}; "
        f"{len(spec.programmes)} tests ({', '.join(spec.programmes)}); {recording}; "
        f"probe {spec.target} noise {spec.probe_noise_um:g} µm"
    )
    if spec.cold_day:
        text += "; test 1 a 24 h warm-up from cold"
    if y is not None:
        text += f"; |y| up to {float(np.abs(y).max()):.1f} µm (recording reference)"
    return text


def fleet(names=None, seed=FLEET_SEED):
    """The fleet's machines (all, or those named), each a :class:`Machine`.

    Deterministic: the same ``seed`` gives the same frames, bit for bit.
    """
    specs = SPECS if names is None else [spec_of(n) for n in names]
    return [_build(spec, seed) for spec in specs]


def spec_of(name):
    """The :class:`Spec` of machine ``name``."""
    for spec in SPECS:
        if spec.name == name:
            return spec
    raise ValueError(f"no machine {name!r} in the fleet; the machines are {names()}.")


def names():
    return [spec.name for spec in SPECS]


if __name__ == "__main__":  # a look at the fleet
    import time

    start = time.perf_counter()
    for m in fleet():
        tests = m.X.index.get_level_values(0)
        hours = m.X.groupby(level=0, sort=False).size().to_numpy() * SAMPLE_S / 3600
        print(
            f"{m.name:18s} {len(set(tests))} tests, {len(m.X)} rows, "
            f"{hours.min():.1f}-{hours.max():.1f} h; {m.description}"
        )
    print(f"{time.perf_counter() - start:.1f} s")
