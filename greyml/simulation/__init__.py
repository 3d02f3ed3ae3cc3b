"""Lumped-parameter thermal simulation of machine tools.

:func:`simulate_test` builds test data in greyml's layout from

- a machine: :class:`ThermalMachine` (the presets :func:`vmc` and
  :func:`gantry`), its :class:`HeatSource` and its sensors
  (:class:`TemperatureSensor`, :class:`FBGSensor`);
- a test: :class:`HeatingTest`, a :class:`Programme` of :class:`Segment`
  and an ambient profile (a temperature, or an :class:`AmbientProfile` such as
  :func:`linear_drift`, :func:`diurnal` or :func:`door_openings`, which add up);
- the effects to include (:class:`Effects`).

The seed papers' test programmes, simulated, are the data sets of
:mod:`greyml.datasets`.
"""

from greyml.simulation._ambient import AmbientProfile, diurnal, door_openings, linear_drift
from greyml.simulation._machine import FBGSensor, HeatSource, TemperatureSensor, ThermalMachine
from greyml.simulation._presets import gantry, vmc
from greyml.simulation._programme import Programme, Segment
from greyml.simulation._simulate import Effects, HeatingTest, simulate_test

__all__ = [
    "AmbientProfile",
    "Effects",
    "FBGSensor",
    "HeatSource",
    "HeatingTest",
    "Programme",
    "Segment",
    "TemperatureSensor",
    "ThermalMachine",
    "diurnal",
    "door_openings",
    "gantry",
    "linear_drift",
    "simulate_test",
    "vmc",
]
