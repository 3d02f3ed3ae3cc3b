"""What the diagnosis needs of greyml's simulator: its sensitivities, and its parameters off.

A user who simulates a machine with :mod:`greyml.simulation` hands
:func:`simulator_sensitivities` to ``diagnose_gap(..., sensitivities=)`` so
that a simulation a few percent off is recalibrated rather than blamed on an
effect; :func:`perturb_parameters` gives the machine with its parameters
off, to see how the diagnosis of their own cases fares with such an error.
The simulator is imported when they are called: the diagnosis itself does
not need it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

__all__ = ["perturb_parameters", "simulator_sensitivities"]


def perturb_parameters(machine, error, rng, *, kind="class"):
    """The machine with its parameters off by up to ±``error`` (relative, uniform).

    ``kind="class"``: one factor per physical parameter shared by all
    elements (heat capacity, conductance, convection, expansion) and one per
    heat source's power, as a material constant or a loss estimate is off.
    ``kind="element"``: every capacity, link, convection coefficient, power
    and displacement weight off independently (a harder case).

    Parameters
    ----------
    machine : str or ThermalMachine
        A preset's name (``"vmc"``, ``"gantry"``) or a machine of
        :mod:`greyml.simulation`.
    error : float
        The largest relative error (0.05: up to ±5 %).
    rng : numpy.random.Generator
        Draws the factors.
    kind : {"class", "element"}, default="class"

    Returns
    -------
    ThermalMachine
        A copy of the machine with its parameters off.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.simulation import vmc
    >>> m = vmc()
    >>> off = perturb_parameters(m, 0.05, np.random.default_rng(0))
    >>> [round(a / b, 4) for a, b in zip(off.capacity[:2], m.capacity[:2])]
    [1.0137, 1.0137]
    """
    from greyml.datasets._simulated import _machine

    m = _machine(machine)
    if kind not in ("class", "element"):
        raise ValueError(f"kind must be 'class' or 'element'; got {kind!r}.")

    def draw():
        return 1.0 + error * rng.uniform(-1.0, 1.0)

    classes = ("capacity", "conductance", "convection", "expansion")
    shared = {name: draw() for name in classes} if kind == "class" else {}

    def factor(name):
        return shared[name] if shared else draw()

    return replace(
        m,
        capacity=tuple(c * factor("capacity") for c in m.capacity),
        links=tuple((a, b, g * factor("conductance")) for a, b, g in m.links),
        convection={k: v * factor("convection") for k, v in m.convection.items()},
        sources=tuple(replace(s, power_W=s.power_W * draw()) for s in m.sources),
        displacement={
            t: {k: v * factor("expansion") for k, v in w.items()} for t, w in m.displacement.items()
        },
    )


def _scaled(m, parameter, factor):
    if parameter == "capacity":
        return replace(m, capacity=tuple(c * factor for c in m.capacity))
    if parameter == "conductance":
        return replace(m, links=tuple((a, b, g * factor) for a, b, g in m.links))
    if parameter == "convection":
        return replace(m, convection={k: v * factor for k, v in m.convection.items()})
    if parameter == "expansion":
        return replace(
            m,
            displacement={
                t: {k: v * factor for k, v in w.items()} for t, w in m.displacement.items()
            },
        )
    index = int(parameter)
    return replace(
        m,
        sources=tuple(
            replace(s, power_W=s.power_W * factor) if i == index else s
            for i, s in enumerate(m.sources)
        ),
    )


def simulator_sensitivities(machine, tests, target, *, effects=None, step=0.01):
    """Sensitivities of a simulated target to the machine's physical parameters.

    One column per parameter: heat capacity, conductance, convection,
    expansion (every displacement weight) and the power of each heat source,
    each the change of ``target`` for a relative change of 1 (a forward
    difference at ``step``), on the rows :func:`greyml.datasets.make_tests`
    gives. Columns that are zero everywhere (a source switched off) are
    dropped. Pass the result as ``diagnose_gap(..., sensitivities=)``.

    Parameters
    ----------
    machine : str or ThermalMachine
        A preset's name (``"vmc"``, ``"gantry"``) or a machine of
        :mod:`greyml.simulation`: the simulation as it stands, with its
        parameters as they are (off, if they are).
    tests : dict or sequence
        The tests, as :func:`greyml.datasets.make_tests` takes them.
    target : str
        The simulated column, e.g. ``"dy_um"``.
    effects : Effects, optional
        The simulation's effects (noise always off); all by default.
    step : float, default=0.01
        The relative step of the forward difference.

    Returns
    -------
    DataFrame indexed by (test, time_s)
        One column per parameter, in the target's unit per relative change
        of 1.

    Examples
    --------
    >>> from greyml.simulation import Effects, Programme
    >>> tests = {"A": Programme().run(60, spindle_rpm=8000).dwell(60)}
    >>> S = simulator_sensitivities("vmc", tests, "dy_um", effects=Effects().without("probe_drift"))
    >>> list(S.columns)  # the feed-driven sources are off in this test: dropped
    ['capacity', 'conductance', 'convection', 'expansion',
     'power: spindle bearings', 'power: spindle motor']
    """
    from greyml.datasets import make_tests
    from greyml.datasets._simulated import _machine
    from greyml.simulation import Effects

    m = _machine(machine)
    effects = (Effects() if effects is None else effects).without("noise")
    base = make_tests(m, tests, effects=effects).frame[target]
    columns = {}
    names = ["capacity", "conductance", "convection", "expansion"]
    names += [str(i) for i in range(len(m.sources))]
    for name in names:
        moved = make_tests(_scaled(m, name, 1.0 + step), tests, effects=effects).frame[target]
        column = ((moved - base) / step).to_numpy()
        if np.any(column != 0.0):
            label = name if not name.isdigit() else f"power: {m.sources[int(name)].name}"
            columns[label] = column
    return pd.DataFrame(columns, index=base.index)
