"""Grey models: AGO, GM(1,N), GMC(1,N) and the grey neural network GNNMCI(1,N).

- :class:`GMC`: the grey convolution model GMC(1,N), the time response of a
  first-order system driven by the inputs' accumulation;
- :class:`GNNMCI`: the grey neural network GNNMCI(1,N), GMC's response as a
  network trained by particle swarm;
- :class:`AGO`: the accumulated generating operation as a transformer;
- :class:`AccumulatedTargetRegressor`: any regressor fitted on the
  accumulated target and de-accumulated back.

Their warnings are in :mod:`greyml.exceptions`.
"""

from greyml.grey._ago import AGO, AccumulatedTargetRegressor
from greyml.grey._gmc import GMC
from greyml.grey._gnnmci import GNNMCI

__all__ = ["AGO", "AccumulatedTargetRegressor", "GMC", "GNNMCI"]
