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

from greyml.metrics._metrics import (
    correlation,
    improvement,
    nash_sutcliffe,
    residual_band,
    rmse,
)
from greyml.metrics._scorers import SCORERS, get_scorer, scoring

__all__ = [
    "rmse",
    "correlation",
    "nash_sutcliffe",
    "residual_band",
    "improvement",
    "SCORERS",
    "get_scorer",
    "scoring",
]
