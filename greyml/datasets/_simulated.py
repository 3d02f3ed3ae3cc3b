"""Data sets simulated from the seeds' machines and tests."""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd
from sklearn.utils import Bunch

from greyml._docstrings import shared_doc
from greyml._rng import make_generator
from greyml.io import check_test_frame
from greyml.simulation._ambient import AmbientProfile, as_profile
from greyml.simulation._catalogue import gantry_tests, probe_test, vmc_tests
from greyml.simulation._machine import OPERATING_INPUTS, ThermalMachine
from greyml.simulation._presets import gantry, vmc
from greyml.simulation._programme import Programme
from greyml.simulation._simulate import Effects, HeatingTest, simulate_test

__all__ = [
    "make_tests",
    "load_vmc_tests",
    "load_probe_test",
    "load_gantry_tests",
    "bunch_from_frame",
]

#: Seed of the measurement noise in the embedded data sets.
DATASET_SEED = 0

_MACHINES = {"vmc": lambda: vmc("ncdt"), "vmc-probe": lambda: vmc("probe"), "gantry": gantry}


def _machine(machine) -> ThermalMachine:
    if isinstance(machine, ThermalMachine):
        return machine
    if isinstance(machine, str) and machine in _MACHINES:
        return _MACHINES[machine]()
    raise ValueError(
        f"machine must be a ThermalMachine or one of {sorted(_MACHINES)}; got {machine!r}."
    )


def bunch_from_frame(frame, *, sensors, targets, sensor_groups, description, inputs=None):
    """Wrap a test-data frame in the Bunch every greyml loader returns.

    Parameters
    ----------
    frame : DataFrame
        Indexed by ``(test, time_s)``.
    sensors, targets : list of str
        Sensor and target columns.
    sensor_groups : dict
        Category of every sensor column.
    description : str
    inputs : list of str, optional
        Operating-input columns; those of ``frame`` among
        ``spindle_rpm, feed_mm_min, c_rpm, ambient_C`` by default.

    Returns
    -------
    Bunch
        ``frame``, ``sensors``, ``targets``, ``inputs``, ``sensor_groups``,
        ``tests`` (labels in order) and ``description``.

    Raises
    ------
    ValueError
        If ``frame`` does not follow the layout
        (:func:`greyml.io.check_test_frame`), a sensor, target or input is
        not one of its columns, or a sensor has no group.

    Examples
    --------
    >>> import pandas as pd
    >>> from greyml import make_test_index
    >>> from greyml.datasets._simulated import bunch_from_frame
    >>> frame = pd.DataFrame(
    ...     {"spindle_rpm": [4000.0, 0.0, 0.0], "T1_C": [20.0, 20.4, 20.1],
    ...      "dz_um": [0.0, 3.1, 0.0]},
    ...     index=make_test_index(["I", "I", "II"], [0, 60, 0]))
    >>> data = bunch_from_frame(frame, sensors=["T1_C"], targets=["dz_um"],
    ...                         sensor_groups={"T1_C": "spindle"}, description="Two tests.")
    >>> data.tests, data.inputs, data.sensors, data.targets
    (['I', 'II'], ['spindle_rpm'], ['T1_C'], ['dz_um'])
    """
    check_test_frame(frame)
    columns = {str(c) for c in frame.columns}
    roles = {"sensors": sensors, "targets": targets, "inputs": inputs}
    for role, names in roles.items():
        if names is None:
            continue
        if isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise ValueError(f"{role} must be a list of column names; got {names!r}.")
        missing = [n for n in names if n not in columns]
        if missing:
            raise ValueError(
                f"{role} names {missing}, not a column of the frame (its columns: "
                f"{list(frame.columns)})."
            )
    if not isinstance(sensor_groups, Mapping):
        raise ValueError(f"sensor_groups must map sensor names to groups; got {sensor_groups!r}.")
    ungrouped = [n for n in sensors if n not in sensor_groups]
    if ungrouped:
        raise ValueError(f"sensor_groups gives no group for the sensor(s) {ungrouped}.")
    if inputs is None:
        inputs = [c for c in (*OPERATING_INPUTS, "ambient_C") if c in frame.columns]
    tests = list(pd.unique(frame.index.get_level_values("test")))
    return Bunch(
        frame=frame,
        sensors=list(sensors),
        targets=list(targets),
        inputs=list(inputs),
        sensor_groups=dict(sensor_groups),
        tests=tests,
        description=description,
    )


def main_target(machine) -> str:
    """The machine's main displacement: ``dy_um`` for the VMC of Abdulshahed et al.
    (2015), else ``dz_um``."""
    return "dy_um" if _machine(machine).name == "vmc" else "dz_um"


def _X_y(bunch, target):
    if target not in bunch.targets:
        raise ValueError(f"target must be one of {bunch.targets}; got {target!r}.")
    return bunch.frame[bunch.sensors], bunch.frame[target]


def _as_tests(programmes, ambient, history) -> list:
    if isinstance(programmes, (Programme, HeatingTest)):
        programmes = [programmes]
    if isinstance(programmes, Mapping):
        items = list(programmes.items())
    else:
        items = [(None, p) for p in programmes]
    if not items:
        raise ValueError("programmes is empty: give at least one Programme or HeatingTest.")
    tests = []
    for k, (label, p) in enumerate(items):
        if isinstance(p, HeatingTest):
            tests.append(p if label is None else HeatingTest(str(label), *_rest(p)))
            continue
        if not isinstance(p, Programme):
            raise ValueError(
                f"Item {label if label is not None else k!r} of programmes is a "
                f"{type(p).__name__}; expected a Programme or a HeatingTest."
            )
        label = str(label) if label is not None else (p.name or f"test {k + 1}")
        if isinstance(ambient, Mapping) and label not in ambient:
            raise ValueError(
                f"ambient gives no temperature for test {label!r}; it has {list(ambient)}."
            )
        amb = ambient[label] if isinstance(ambient, Mapping) else ambient
        hist = history.get(label) if isinstance(history, Mapping) else history
        tests.append(HeatingTest(label, p, amb, hist))
    labels = [t.label for t in tests]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise ValueError(f"Test labels must be unique; {dup} appear more than once.")
    return tests


def _rest(test):
    return (
        test.programme,
        test.ambient,
        test.history,
        test.history_ambient,
        test.sample_s,
        test.note,
    )


def make_tests(
    machine="vmc",
    programmes=None,
    ambient=20.0,
    effects=None,
    random_state=None,
    *,
    history=None,
    sample_s=None,
    return_X_y=False,
    target=None,
):
    """Simulate heating/cooling tests of a machine into greyml's data layout.

    Parameters
    ----------
    machine : {"vmc", "vmc-probe", "gantry"} or ThermalMachine, default="vmc"
    programmes : Programme, HeatingTest, list or dict of them
        The tests. A dict maps labels to programmes; a list uses each
        programme's ``name`` (or ``"test k"``) as label; HeatingTest items
        bring their own ambient and history. Default: the seeds' tests of
        that machine.
    ambient : AmbientProfile, float or dict, default=20.0
        Air temperature for Programme items (a dict by label).
    effects : Effects, optional
        Effects to include; all by default.
    random_state : int, numpy.random.Generator or None, default=None
        Seed of the measurement noise; each test gets its own stream.
    history : Programme or dict, optional
        What the machine did before each Programme item.
    sample_s : float, optional
        Sampling interval; the machine's by default.
    return_X_y : bool, default=False
        Return ``(X, y)``, the sensor columns and one target, instead.
    target : str, optional
        Target for ``return_X_y``; the machine's main one by default
        (``dy_um`` for the VMC of Abdulshahed et al. (2015), ``dz_um`` otherwise).

    Returns
    -------
    data : Bunch
        ``frame`` (DataFrame indexed by ``(test, time_s)``), ``sensors``,
        ``targets``, ``inputs``, ``sensor_groups``, ``tests``,
        ``description``.
    (X, y) : tuple of DataFrame and Series
        With ``return_X_y=True``.

    Examples
    --------
    >>> from greyml.simulation import Programme, linear_drift
    >>> p = Programme().run(60, spindle_rpm=6000).dwell(60)
    >>> data = make_tests("vmc", {"A": p, "B": p},
    ...                   ambient={"A": 20.0, "B": linear_drift(20.0, 1.0)},
    ...                   random_state=0)
    >>> data.tests, data.frame.shape
    (['A', 'B'], (242, 82))
    >>> X, y = make_tests("vmc", p, random_state=0, return_X_y=True)
    >>> X.shape, y.name
    ((121, 76), 'dy_um')
    """
    m = _machine(machine)
    effects = Effects() if effects is None else effects
    if programmes is None:
        tests = _default_tests(m)
    else:
        tests = _as_tests(programmes, ambient, history)
    if not isinstance(ambient, Mapping):
        as_profile(ambient)  # fail early on a bad ambient
    rng = make_generator(random_state)
    streams = rng.spawn(len(tests))
    frames = []
    for test, stream in zip(tests, streams):
        frames.append(
            simulate_test(
                m,
                test.programme,
                test.ambient,
                effects,
                history=test.history,
                history_ambient=test.history_ambient,
                sample_s=test.sample_s if test.sample_s is not None else sample_s,
                label=test.label,
                random_state=stream,
            )
        )
    frame = pd.concat(frames)
    lines = [f"Simulated tests of {m.description}.", "", "Tests:"]
    for t in tests:
        amb = t.ambient if isinstance(t.ambient, AmbientProfile) else as_profile(t.ambient)
        line = f"- {t.label}: {t.programme.name or t.programme.describe()}; ambient {amb!r}"
        if t.history is not None:
            line += f"; before it: {t.history.name or t.history.describe()}"
        if t.note:
            line += f" ({t.note})"
        lines.append(line)
    off = [n for n in Effects.names() if not getattr(effects, n)]
    lines += ["", "Effects switched off: " + (", ".join(off) if off else "none") + "."]
    bunch = bunch_from_frame(
        frame,
        sensors=m.sensor_names,
        targets=m.target_names,
        sensor_groups=m.sensor_groups,
        description="\n".join(lines),
        inputs=[*m.inputs, "ambient_C"],
    )
    if return_X_y:
        return _X_y(bunch, target or main_target(m))
    return bunch


def _default_tests(m):
    if m.name == "vmc":
        return vmc_tests()
    if m.name == "vmc-probe":
        return [probe_test()]
    if m.name == "gantry":
        return gantry_tests()
    raise ValueError(f"Machine {m.name!r} has no default tests; pass programmes.")


#: The parameters that the loaders below share, put in their docstrings by _loader.
_LOADER_PARAMETERS = """Parameters
    ----------
    effects : Effects, optional
        Effects to include; all by default.
    return_X_y : bool, default=False
        Return the sensor columns and one target."""


_loader = shared_doc(parameters=_LOADER_PARAMETERS)


def _load(machine, effects, return_X_y, target):
    """The seeds' tests of ``machine``, simulated with the datasets' seed: a Bunch or ``(X, y)``."""
    data = make_tests(machine, None, effects=effects, random_state=DATASET_SEED)
    return _X_y(data, target) if return_X_y else data


@_loader
def load_vmc_tests(*, effects=None, return_X_y=False, target="dy_um"):
    """Abdulshahed et al.'s (2015) Tests I–VI on the small VMC, simulated (76 sensors).

    Six heating/cooling tests at 4000 and 8000 rpm in different ambient
    conditions and thermal histories, sampled every minute: columns
    ``spindle_rpm``, ``feed_mm_min``, ``ambient_C``, ``T1_C`` … ``T76_C`` and
    ``dx_um``, ``dy_um``, ``dz_um`` (test-bar displacement relative to each
    test's start). Deterministic.

    {parameters}
    target : str, default="dy_um"
        Target for ``return_X_y`` (Abdulshahed et al. (2015) models the Y error).

    Returns
    -------
    data : Bunch or (X, y)
        See :func:`make_tests`. ``sensor_groups`` maps every sensor to one of
        Abdulshahed et al.'s (2015) categories ("spindle carrier strip 1", "spindle boss",
        "ambient near the column", …).

    Examples
    --------
    >>> data = load_vmc_tests()
    >>> data.tests
    ['I', 'II', 'III', 'IV', 'V', 'VI']
    >>> data.sensor_groups["T68_C"], data.sensor_groups["T18_C"]
    ('ambient near the column', 'spindle carrier strip 1')
    """
    return _load("vmc", effects, return_X_y, target)


@_loader
def load_probe_test(*, effects=None, return_X_y=False, target="dz_um"):
    """Abdulshahed et al.'s (2017) 200-min probing test at 9000 rpm, simulated (9 sensors).

    Sampled every 10 s like the seeds: ``spindle_rpm``, ``feed_mm_min``,
    ``ambient_C``, ``T1_C`` … ``T9_C`` (carrier, spindle boss, X/Y/Z motors,
    X/Y/Z ballscrew nuts, ambient) and ``dx_um``, ``dy_um``, ``dz_um``.
    Deterministic.

    {parameters}
    target : str, default="dz_um"
        Abdulshahed et al. (2017) model the Z error.

    Returns
    -------
    data : Bunch or (X, y)

    Examples
    --------
    >>> X, y = load_probe_test(return_X_y=True)
    >>> X.shape, y.name
    ((1201, 9), 'dz_um')
    """
    return _load("vmc-probe", effects, return_X_y, target)


@_loader
def load_gantry_tests(*, effects=None, return_X_y=False, target="dz_um"):
    """Abdulshahed et al.'s (2016) Z-axis, C-axis and helical tests on the gantry, simulated.

    Sampled every 20 s: ``feed_mm_min``, ``c_rpm``, ``ambient_C``,
    ``T1_C`` … ``T12_C``, ``FBG1_ue`` … ``FBG7_ue`` and ``dy_um``, ``dz_um``.
    Deterministic.

    {parameters}
    target : str, default="dz_um"
        Abdulshahed et al. (2016) models the Z growth of the ram.

    Returns
    -------
    data : Bunch or (X, y)

    Examples
    --------
    >>> data = load_gantry_tests()
    >>> data.tests, len(data.sensors)
    (['Z-axis', 'C-axis', 'helical'], 19)
    """
    return _load("gantry", effects, return_X_y, target)
