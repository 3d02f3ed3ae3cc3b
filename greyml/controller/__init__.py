"""What runs beside the machine: the compensator a controller calls, and its exports.

:class:`Compensator` runs a fitted model (a
:class:`~greyml.ThermalTransferFunction`, or a ``Pipeline(LagFeatures,
[StandardScaler], linear model)``) row by row, with its output limits (clamp,
quantum, rate limit, hold-last-value), its interval and the probe filter that
readings correct; :class:`Uncertainty` is how far it trusts the correction.
``Compensator.export`` writes the same computation as C, IEC 61131-3
Structured Text or JSON (one intermediate program and a writer per language,
in the private ``greyml.controller._export``).

The models live in :mod:`greyml.dynamic`, which never imports this package.
"""

from greyml.controller._compensator import Compensator, Uncertainty

__all__ = ["Compensator", "Uncertainty"]
