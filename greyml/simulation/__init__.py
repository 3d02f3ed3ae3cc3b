"""Lumped-parameter thermal simulation of machine tools.

Kernels (:func:`network_matrices`, :func:`zoh_discretize`, :func:`propagate`,
:func:`steady_state`) are pure array functions; :func:`simulate_test` builds
test data from a :class:`ThermalMachine` (presets :func:`vmc`, :func:`gantry`),
a :class:`Programme`, an ambient profile and a set of :class:`Effects`;
:func:`vmc_tests`, :func:`probe_test` and :func:`gantry_tests` are the seed
papers' test programmes.
"""

from greyml.simulation._ambient import (
    AmbientProfile,
    constant,
    diurnal,
    door_openings,
    linear_drift,
)
from greyml.simulation._catalogue import gantry_tests, probe_test, vmc_tests
from greyml.simulation._machine import (
    FBG_TEMPERATURE_SENSITIVITY_UE_PER_C,
    FBGSensor,
    HeatSource,
    TemperatureSensor,
    ThermalMachine,
)
from greyml.simulation._network import (
    add_lag_states,
    conductance_matrix,
    network_matrices,
    propagate,
    steady_state,
    zoh_discretize,
)
from greyml.simulation._presets import gantry, vmc
from greyml.simulation._programme import Programme, Segment
from greyml.simulation._simulate import Effects, HeatingTest, simulate_test

__all__ = [
    "AmbientProfile",
    "Effects",
    "FBGSensor",
    "FBG_TEMPERATURE_SENSITIVITY_UE_PER_C",
    "HeatSource",
    "HeatingTest",
    "Programme",
    "Segment",
    "TemperatureSensor",
    "ThermalMachine",
    "add_lag_states",
    "conductance_matrix",
    "constant",
    "diurnal",
    "door_openings",
    "gantry",
    "gantry_tests",
    "linear_drift",
    "network_matrices",
    "probe_test",
    "propagate",
    "simulate_test",
    "steady_state",
    "vmc",
    "vmc_tests",
    "zoh_discretize",
]
