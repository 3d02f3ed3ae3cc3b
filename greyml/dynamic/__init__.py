"""Dynamic thermal models: first-order thermal lags of temperatures and drivers.

The kernels (:mod:`greyml.dynamic._kernels`) are shared by every piece that needs
a thermal lag, :mod:`greyml.gap` included.
"""

from greyml.dynamic._transfer import ThermalTransferFunction

__all__ = ["ThermalTransferFunction"]
