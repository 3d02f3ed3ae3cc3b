"""Dynamic thermal models: the displacement as thermal lags of temperatures and drivers.

:class:`ThermalTransferFunction` is the recommended model: each input reaches
the displacement through first-order lags, the sensors, penalty and time
constants chosen inside ``fit`` on whole held-out tests, with intervals
calibrated on them (:class:`IntervalCalibration`) and widened where an input
leaves what training saw (:class:`InputEnvelope`). :class:`LagFeatures` turns
temperatures and drivers into their thermal lags, so that any linear model
behind it is a dynamic thermal model. The one lag kernel
(:mod:`greyml.dynamic._kernels`) is shared by every piece that needs a thermal
lag, :mod:`greyml.gap` and the controller included.

What runs beside the machine (the compensator and its exports) is in
:mod:`greyml.controller`; this package never imports it.
"""

from greyml.dynamic._envelope import InputEnvelope
from greyml.dynamic._intervals import IntervalCalibration
from greyml.dynamic._lags import LagFeatures
from greyml.dynamic._transfer import ThermalTransferFunction

__all__ = [
    "InputEnvelope",
    "IntervalCalibration",
    "LagFeatures",
    "ThermalTransferFunction",
]
