"""Accuracy measures of thermal-error models, as functions and as scorers.

The functions take ``(y_true, y_pred)`` and return a float; they are the
figures the seed papers report for a compensation model:

- :func:`rmse`: root mean squared error;
- :func:`correlation`: Pearson R;
- :func:`nash_sutcliffe`: the efficiency E = 1 - SSE / SST;
- :func:`residual_band`: ``max |y - ŷ|``, the "±" band of the residual;
- :func:`improvement`: ``1 - max |y - ŷ| / max |y|``.

The scorers in :data:`SCORERS` (``"neg_rmse"``, ``"correlation"``,
``"nash_sutcliffe"``, ``"neg_residual_band"``, ``"improvement"``) plug them
into scikit-learn's model selection; :func:`get_scorer` and :func:`scoring`
look them up by name.
"""

from greyml.metrics import _metrics, _scorers
from greyml.metrics._metrics import *  # noqa: F403 (the names of _metrics.__all__)
from greyml.metrics._scorers import *  # noqa: F403 (the names of _scorers.__all__)

__all__ = [*_metrics.__all__, *_scorers.__all__]
