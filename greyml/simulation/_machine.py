"""Description of a machine tool as a thermal network with sensors.

A :class:`ThermalMachine` is plain data: nodes, conductances, heat sources and
output maps (temperature sensors, FBG strain sensors, tool-point displacement).
The presets in :mod:`greyml.simulation._presets` build two of them; the
simulator in :mod:`greyml.simulation._simulate` turns one into test data.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from greyml.simulation import _check
from greyml.simulation._network import network_matrices

__all__ = [
    "AMBIENT",
    "OPERATING_INPUTS",
    "FBG_TEMPERATURE_SENSITIVITY_UE_PER_C",
    "HeatSource",
    "TemperatureSensor",
    "FBGSensor",
    "ThermalMachine",
]

#: Pseudo-node name for the ambient air in sensor weights.
AMBIENT = "ambient"

#: Operating inputs a programme can command, in column order.
OPERATING_INPUTS = ("spindle_rpm", "feed_mm_min", "c_rpm")

#: Apparent strain of a bare fibre Bragg grating per °C (Abdulshahed et al. (2016), Sec. 3).
FBG_TEMPERATURE_SENSITIVITY_UE_PER_C = 8.64


@dataclass(frozen=True)
class HeatSource:
    """A heat input driven by one operating input.

    The power is ``power_W * (|u| / reference) ** exponent`` for the commanded
    value ``u`` of ``input``, shared between ``nodes`` in the given fractions.

    Parameters
    ----------
    name : str
        What dissipates the heat, e.g. ``"spindle bearings"``.
    input : {"spindle_rpm", "feed_mm_min", "c_rpm"}
        The operating input that drives it.
    nodes : mapping of str to float
        Fraction of the heat flowing into each node; the fractions sum to 1.
    power_W : float
        Power at ``u = reference``, in W.
    reference : float
        Input value at which ``power_W`` applies.
    exponent : float, default=1.0
        Exponent of the speed law (1 for losses proportional to speed; 5/3 for
        the viscous friction torque of a rolling bearing, which Palmgren's
        formula makes proportional to ``n^(2/3)``).
    extra : bool, default=False
        Whether the source is the optional extra heat source switched by
        ``Effects.extra_heat_source``.
    note : str, default=""
        Where the numbers come from.

    Examples
    --------
    Bearing friction, 100 W at 8000 rpm: half the speed gives
    100 · 0.5^(5/3) = 31.5 W.

    >>> import numpy as np
    >>> from greyml.simulation import HeatSource
    >>> bearings = HeatSource("spindle bearings", "spindle_rpm", {"spindle": 1.0},
    ...                       power_W=100.0, reference=8000.0, exponent=5 / 3)
    >>> np.round(bearings.power([0.0, 4000.0, 8000.0]), 6).tolist()
    [0.0, 31.498026, 100.0]
    """

    name: str
    input: str
    nodes: Mapping[str, float]
    power_W: float
    reference: float
    exponent: float = 1.0
    extra: bool = False
    note: str = ""

    def __post_init__(self):
        what = f"heat source {self.name!r}"
        _check.label(self.name, "The name of a heat source")
        if self.input not in OPERATING_INPUTS:
            raise ValueError(
                f"'input' of {what} is {self.input!r}; expected one of {list(OPERATING_INPUTS)}."
            )
        _check.real(self.power_W, f"'power_W' of {what}", low=0.0)
        _check.real(self.reference, f"'reference' of {what}", low=0.0, strict=True)
        _check.real(self.exponent, f"'exponent' of {what}", low=0.0, strict=True)
        if hasattr(self.nodes, "items") and not self.nodes:
            raise ValueError(f"'nodes' of {what} is empty; give the node(s) it heats.")
        _check.weights(self.nodes, f"Heat source {self.name!r}", total=1.0)

    def power(self, u):
        """Heat flow in W for commanded values ``u`` (array-like)."""
        u = np.abs(np.asarray(u, dtype=float))
        return self.power_W * (u / self.reference) ** self.exponent


@dataclass(frozen=True)
class TemperatureSensor:
    """A temperature sensor reading a weighted mean of node temperatures.

    Parameters
    ----------
    name : str
        Column name, ``"T<k>_C"``.
    category : str
        Where it sits, e.g. ``"spindle carrier strip 1"`` or ``"ambient"``.
    nodes : mapping of str to float
        Weights (summing to 1) of the node temperatures it reads; the key
        ``"ambient"`` stands for the ambient air.
    lag_s : float, default=0.0
        Time constant of the first-order delay of a surface-mounted sensor
        (thermal contact resistance and the sensor's own mass).
    offset_C : float, default=0.0
        Fixed difference from the weighted node temperature (local position on
        the node, stratification of the air, calibration).
    noise_C : float, default=0.05
        Standard deviation of the white measurement noise.

    Examples
    --------
    A sensor in the node and one on its surface, 5 min behind, on a one-node
    machine that settles 10 K above the air (see :class:`ThermalMachine`):

    >>> from greyml.simulation import (
    ...     Effects, HeatSource, Programme, TemperatureSensor, ThermalMachine, simulate_test)
    >>> sensors = (
    ...     TemperatureSensor("T1_C", "spindle", {"spindle": 1.0}),
    ...     TemperatureSensor("T2_C", "spindle surface", {"spindle": 1.0}, lag_s=300.0),
    ... )
    >>> machine = ThermalMachine(
    ...     "block", ("spindle",), (1000.0,), (), {"spindle": 10.0},
    ...     (HeatSource("motor", "spindle_rpm", {"spindle": 1.0}, 100.0, 1000.0),),
    ...     sensors, inputs=("spindle_rpm",), sample_s=300.0)
    >>> test = simulate_test(machine, Programme().run(60, spindle_rpm=1000), 20.0,
    ...                      Effects.none().with_("sensor_lag"))
    >>> test[["T1_C", "T2_C"]].iloc[[1, -1]].round(2).to_numpy().tolist()  # 5 min, 1 h
    [[29.5, 24.73], [30.0, 30.0]]
    """

    name: str
    category: str
    nodes: Mapping[str, float]
    lag_s: float = 0.0
    offset_C: float = 0.0
    noise_C: float = 0.05

    def __post_init__(self):
        _check.label(self.name, "The name of a temperature sensor")
        what = f"sensor {self.name!r}"
        _check.weights(self.nodes, f"Sensor {self.name!r}", total=1.0)
        _check.real(self.lag_s, f"'lag_s' of {what}", low=0.0)
        _check.real(self.offset_C, f"'offset_C' of {what}")
        _check.real(self.noise_C, f"'noise_C' of {what}", low=0.0)


@dataclass(frozen=True)
class FBGSensor:
    """A fibre Bragg grating strain sensor bonded to the structure.

    The reading (µε, relative to the start of the test) is the mechanical
    strain ``Σ strain[node] ΔT_node`` plus, with the cross-sensitivity effect,
    8.64 µε/°C times the change of the grating temperature
    ``Σ nodes[node] ΔT_node``.

    Parameters
    ----------
    name : str
        Column name, ``"FBG<k>_ue"``.
    category : str
        Where it sits, e.g. ``"ram"`` or ``"cross-beam"``.
    strain : mapping of str to float
        Mechanical strain per kelvin of each node, in µε/K (free expansion of
        the member it is bonded to, plus bending from gradients).
    nodes : mapping of str to float
        Weights of the node temperatures the grating itself is at.
    noise_ue : float, default=0.2
        Standard deviation of the white measurement noise in µε.

    Examples
    --------
    A grating on a member that expands 1 µε/K, on a one-node machine that
    settles 10 K above the air (see :class:`ThermalMachine`): 10 µε of
    strain, plus 8.64 µε/°C · 10 °C with the cross-sensitivity effect.

    >>> from greyml.simulation import (
    ...     Effects, FBGSensor, HeatSource, Programme, ThermalMachine, simulate_test)
    >>> fbg = FBGSensor("FBG1_ue", "spindle", strain={"spindle": 1.0}, nodes={"spindle": 1.0})
    >>> machine = ThermalMachine(
    ...     "block", ("spindle",), (1000.0,), (), {"spindle": 10.0},
    ...     (HeatSource("motor", "spindle_rpm", {"spindle": 1.0}, 100.0, 1000.0),),
    ...     temperature_sensors=(), fbg_sensors=(fbg,), inputs=("spindle_rpm",))
    >>> run = Programme().run(60, spindle_rpm=1000)
    >>> for effects in (Effects.none(), Effects.none().with_("fbg_cross_sensitivity")):
    ...     print(round(float(simulate_test(machine, run, 20.0, effects)["FBG1_ue"].iloc[-1]), 6))
    10.0
    96.4
    """

    name: str
    category: str
    strain: Mapping[str, float]
    nodes: Mapping[str, float]
    noise_ue: float = 0.2

    def __post_init__(self):
        _check.label(self.name, "The name of an FBG sensor")
        what = f"FBG sensor {self.name!r}"
        if not hasattr(self.strain, "items"):
            raise ValueError(f"{what}: strain must map nodes to µε/K; got {self.strain!r}.")
        for node, value in self.strain.items():
            _check.real(value, f"{what}: the strain of node {node!r}")
        _check.weights(self.nodes, what, low=None)
        _check.real(self.noise_ue, f"'noise_ue' of {what}", low=0.0)


@dataclass(frozen=True)
class ThermalMachine:
    """A machine tool as a lumped thermal network with its measurement set-up.

    Parameters
    ----------
    name : str
        Short name, e.g. ``"vmc"``.
    nodes : tuple of str
        Node names.
    capacity : tuple of float
        Heat capacity of each node in J/K.
    links : tuple of (str, str, float)
        Conductances in W/K between pairs of nodes.
    convection : mapping of str to float
        Conductance in W/K from a node to the ambient air (missing nodes: 0).
    sources : tuple of HeatSource
        Heat inputs.
    temperature_sensors : tuple of TemperatureSensor
    fbg_sensors : tuple of FBGSensor
    displacement : mapping of str to mapping of str to float
        For each target column (``"dx_um"``, …) the displacement of the tool
        relative to the workpiece per kelvin of each node, in µm/K.
    probe_noise_um : mapping of str to float
        Standard deviation of the displacement measurement noise per target.
    probe_drift_um_per_h : mapping of str to float
        Slow drift of the displacement transducers per target, in µm/h.
    inputs : tuple of str
        Operating input columns this machine reports.
    max_input : mapping of str to float
        Largest value each operating input may take.
    sample_s : float
        Default sampling interval of its tests in s.
    description : str
        Where the machine and its numbers come from.

    Examples
    --------
    The smallest machine: one node of 1000 J/K losing 10 W/K to the air
    (time constant 100 s), heated with 100 W at 1000 rpm. It settles
    100 W / 10 W/K = 10 K above the air, which a sensor in the node reads as
    30 °C and one halfway to the air as 25 °C; the tool moves
    2 µm/K · 10 K = 20 µm.

    >>> from greyml.simulation import (
    ...     Effects, HeatSource, Programme, TemperatureSensor, ThermalMachine, simulate_test)
    >>> machine = ThermalMachine(
    ...     name="block",
    ...     nodes=("spindle",),
    ...     capacity=(1000.0,),
    ...     links=(),
    ...     convection={"spindle": 10.0},
    ...     sources=(HeatSource("motor", "spindle_rpm", {"spindle": 1.0}, 100.0, 1000.0),),
    ...     temperature_sensors=(
    ...         TemperatureSensor("T1_C", "spindle", {"spindle": 1.0}),
    ...         TemperatureSensor("T2_C", "housing", {"spindle": 0.5, "ambient": 0.5}),
    ...     ),
    ...     displacement={"dz_um": {"spindle": 2.0}},
    ...     inputs=("spindle_rpm",),
    ...     sample_s=600.0,
    ... )
    >>> machine.sensor_names, machine.target_names
    (['T1_C', 'T2_C'], ['dz_um'])
    >>> A, B = machine.state_matrices()  # dT/dt = A T + B [power, air]
    >>> A.tolist(), B.tolist()
    ([[-0.01]], [[0.001, 0.01]])
    >>> test = simulate_test(machine, Programme().run(60, spindle_rpm=1000), 20.0, Effects.none())
    >>> test.iloc[-1].round(6).to_dict()
    {'spindle_rpm': 0.0, 'ambient_C': 20.0, 'T1_C': 30.0, 'T2_C': 25.0, 'dz_um': 20.0}
    """

    name: str
    nodes: tuple
    capacity: tuple
    links: tuple
    convection: Mapping[str, float]
    sources: tuple
    temperature_sensors: tuple
    fbg_sensors: tuple = ()
    displacement: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    probe_noise_um: Mapping[str, float] = field(default_factory=dict)
    probe_drift_um_per_h: Mapping[str, float] = field(default_factory=dict)
    inputs: tuple = ("spindle_rpm", "feed_mm_min")
    max_input: Mapping[str, float] = field(default_factory=dict)
    sample_s: float = 10.0
    description: str = ""

    def __post_init__(self):
        m = f"Machine {self.name!r}"
        nodes = list(self.nodes)
        for node in nodes:
            _check.label(node, f"{m}: a node name")
            if nodes.count(node) > 1:
                raise ValueError(f"{m} has node {node!r} more than once.")
        known = f"which is not one of its nodes {nodes}"
        capacity = list(self.capacity)
        if len(capacity) != len(nodes):
            raise ValueError(
                f"{m}: capacity has {len(capacity)} values for {len(nodes)} node(s); give "
                "one heat capacity (J/K) per node."
            )
        for node, c in zip(nodes, capacity):
            _check.real(c, f"{m}: the capacity of node {node!r}", low=0.0, strict=True)
        for k, link in enumerate(self.links):
            if not (isinstance(link, (tuple, list)) and len(link) == 3):
                raise ValueError(f"{m}: link {k} must be (node, node, conductance); got {link!r}.")
            a, b, g = link
            for end in (a, b):
                _check.member(end, nodes, f"{m}: link {k} names node {end!r}, {known}.")
            if a == b:
                raise ValueError(f"{m}: link {k} joins node {a!r} to itself.")
            _check.real(g, f"{m}: the conductance between {a!r} and {b!r}", low=0.0)
        for node, h in dict(self.convection).items():
            _check.member(node, nodes, f"{m}: convection names node {node!r}, {known}.")
            _check.real(h, f"{m}: the convection of node {node!r}", low=0.0)
        inputs = list(self.inputs)
        for name in inputs:
            _check.member(
                name,
                OPERATING_INPUTS,
                f"{m}: inputs names {name!r}, not an operating input ({list(OPERATING_INPUTS)}).",
            )
        for name, limit in dict(self.max_input).items():
            _check.member(
                name, OPERATING_INPUTS, f"{m}: max_input names {name!r}, not an operating input."
            )
            _check.real(limit, f"{m}: max_input of {name!r}", low=0.0, strict=True)
        allowed = {*nodes, AMBIENT}
        for src in self.sources:
            if not isinstance(src, HeatSource):
                raise ValueError(f"{m}: sources must be HeatSource objects; got {src!r}.")
            for node in src.nodes:
                _check.member(
                    node, nodes, f"{m}: heat source {src.name!r} heats node {node!r}, {known}."
                )
            _check.member(
                src.input,
                inputs,
                f"{m}: heat source {src.name!r} is driven by {src.input!r}, which is not "
                f"one of the machine's inputs {inputs}.",
            )
        seen = set()
        sensors = [*self.temperature_sensors, *self.fbg_sensors]
        for sensor in sensors:
            if not isinstance(sensor, (TemperatureSensor, FBGSensor)):
                raise ValueError(
                    f"{m}: a sensor must be a TemperatureSensor or FBGSensor; got {sensor!r}."
                )
            if sensor.name in seen:
                raise ValueError(f"{m}: the sensor name {sensor.name!r} appears more than once.")
            seen.add(sensor.name)
            maps = [sensor.nodes] + ([sensor.strain] if isinstance(sensor, FBGSensor) else [])
            for weights in maps:
                for node in weights:
                    _check.member(
                        node,
                        allowed,
                        f"{m}: sensor {sensor.name!r} reads node {node!r}, {known} "
                        f"(or {AMBIENT!r}).",
                    )
        for target, per_node in dict(self.displacement).items():
            _check.label(target, f"{m}: a displacement target name")
            for node, value in dict(per_node).items():
                _check.member(
                    node, allowed, f"{m}: displacement {target!r} names node {node!r}, {known}."
                )
                _check.real(value, f"{m}: the displacement {target!r} per kelvin of node {node!r}")
        targets = list(self.displacement)
        for field_name in ("probe_noise_um", "probe_drift_um_per_h"):
            for target, value in dict(getattr(self, field_name)).items():
                if target not in targets:
                    raise ValueError(
                        f"{m}: {field_name} names {target!r}, which is not one of its targets "
                        f"{targets}."
                    )
                low = 0.0 if field_name == "probe_noise_um" else None
                _check.real(value, f"{m}: {field_name} of {target!r}", low=low)
        _check.real(self.sample_s, f"{m}: sample_s", low=0.0, strict=True)

    # ------------------------------------------------------------------ names
    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def temperature_names(self) -> list:
        return [s.name for s in self.temperature_sensors]

    @property
    def fbg_names(self) -> list:
        return [s.name for s in self.fbg_sensors]

    @property
    def sensor_names(self) -> list:
        """Temperature then FBG sensor columns."""
        return self.temperature_names + self.fbg_names

    @property
    def target_names(self) -> list:
        return list(self.displacement)

    @property
    def sensor_groups(self) -> dict:
        """Category of every sensor column."""
        groups = {s.name: s.category for s in self.temperature_sensors}
        groups.update({s.name: s.category for s in self.fbg_sensors})
        return groups

    def node_index(self, name: str) -> int:
        try:
            return self.nodes.index(name)
        except ValueError:
            raise ValueError(
                f"Machine {self.name!r} has no node {name!r}; its nodes are {list(self.nodes)}."
            ) from None

    # --------------------------------------------------------------- matrices
    def node_vector(self, weights: Mapping[str, float]) -> tuple:
        """Node weights as a vector plus the weight of the ambient air."""
        w = np.zeros(self.n_nodes)
        w_amb = 0.0
        for node, value in weights.items():
            if node == AMBIENT:
                w_amb += value
            else:
                w[self.node_index(node)] += value
        return w, w_amb

    def link_array(self) -> np.ndarray:
        """Links as rows ``(i, j, G)``."""
        return np.array(
            [(self.node_index(a), self.node_index(b), g) for a, b, g in self.links],
            dtype=float,
        ).reshape(-1, 3)

    def convection_vector(self) -> np.ndarray:
        h, _ = self.node_vector(self.convection)
        return h

    def state_matrices(self):
        """``A``, ``B`` of the network; inputs are node powers then ambient."""
        return network_matrices(
            np.asarray(self.capacity, dtype=float),
            self.link_array(),
            self.convection_vector(),
        )

    def source_matrix(self, extra: bool = True) -> np.ndarray:
        """``(n_sources, n_nodes)`` share of each source's heat per node."""
        S = np.zeros((len(self.sources), self.n_nodes))
        for k, src in enumerate(self.sources):
            if src.extra and not extra:
                continue
            S[k], _ = self.node_vector(src.nodes)
        return S

    def output_matrix(self, maps) -> np.ndarray:
        """Stack node-weight mappings into a ``(len(maps), n_nodes)`` matrix."""
        M = np.zeros((len(maps), self.n_nodes))
        for k, weights in enumerate(maps):
            M[k], _ = self.node_vector(weights)
        return M

    def scaled(self, heat: float) -> ThermalMachine:
        """A copy with every heat source's power multiplied by ``heat``."""
        return replace(
            self,
            sources=tuple(replace(s, power_W=s.power_W * heat) for s in self.sources),
        )
