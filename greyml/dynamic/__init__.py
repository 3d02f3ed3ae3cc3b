"""Dynamic thermal models: first-order thermal lags of temperatures and drivers.

:class:`LagFeatures` turns temperatures and drivers into their thermal lags, so
that a linear model behind it is a dynamic thermal model;
:class:`Compensator` runs such a model sample by sample, as a controller does.
The kernels (:mod:`greyml.dynamic._kernels`) are shared by every piece that
needs a thermal lag, :mod:`greyml.gap` included.
"""

from greyml.dynamic._compensator import Compensator
from greyml.dynamic._lags import LagFeatures
from greyml.dynamic._time import MAX_TERMS, MAX_TIME_CONSTANTS
from greyml.dynamic._transfer import ThermalTransferFunction

__all__ = [
    "Compensator",
    "LagFeatures",
    "MAX_TERMS",
    "MAX_TIME_CONSTANTS",
    "ThermalTransferFunction",
]
