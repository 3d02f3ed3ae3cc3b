"""Accuracy measures of thermal-error models, as functions and as scorers.

The functions take ``(y_true, y_pred)`` and return a float; they are the
figures the seed papers report for a compensation model:

- :func:`rmse`: root mean squared error;
- :func:`correlation`: Pearson R;
- :func:`nash_sutcliffe`: the efficiency E = 1 - SSE / SST;
- :func:`residual_band`: ``max |y - ŷ|``, the "±" band of the residual;
- :func:`improvement`: ``1 - max |y - ŷ| / max |y|``.

As scorers (``"neg_rmse"``, ``"correlation"``, ``"nash_sutcliffe"``,
``"neg_residual_band"``, ``"improvement"``) they plug into scikit-learn's
model selection:

- :func:`get_scorer`: one scorer by name, greyml's or scikit-learn's;
- :func:`scoring`: several, as a dict for multi-metric ``scoring=``.
"""

from greyml.metrics._metrics import correlation, improvement, nash_sutcliffe, residual_band, rmse
from greyml.metrics._scorers import get_scorer, scoring

__all__ = [
    "correlation",
    "get_scorer",
    "improvement",
    "nash_sutcliffe",
    "residual_band",
    "rmse",
    "scoring",
]
