"""The seeds' metrics as scikit-learn scorers.

scikit-learn's model selection (``cross_validate``, ``GridSearchCV``, ...)
always *maximises* a score. The error measures (RMSE, residual band) are
therefore wrapped with ``greater_is_better=False``, which negates them, and
their names carry the ``neg_`` prefix, as scikit-learn's own
``neg_root_mean_squared_error`` does. R, E and the improvement are already
"higher is better" and keep their sign.

The scorers wrap module-level functions, so they pickle and run on any joblib
backend (``n_jobs``).
"""

from __future__ import annotations

import copy

from sklearn.metrics import get_scorer as _sklearn_get_scorer
from sklearn.metrics import make_scorer

from greyml.metrics._metrics import (
    correlation,
    improvement,
    nash_sutcliffe,
    residual_band,
    rmse,
)

__all__ = ["get_scorer", "scoring"]


SCORERS = {
    "neg_rmse": make_scorer(rmse, greater_is_better=False),
    "correlation": make_scorer(correlation),
    "nash_sutcliffe": make_scorer(nash_sutcliffe),
    "neg_residual_band": make_scorer(residual_band, greater_is_better=False),
    "improvement": make_scorer(improvement),
}
"""greyml's scorers by name. Use :func:`get_scorer` to get a copy of one."""


def get_scorer(name):
    """Return a scorer by name: greyml's metrics first, then scikit-learn's.

    Parameters
    ----------
    name : str, callable or None
        One of ``"neg_rmse"``, ``"correlation"``, ``"nash_sutcliffe"``,
        ``"neg_residual_band"``, ``"improvement"``, or anything that
        :func:`sklearn.metrics.get_scorer` accepts (a scikit-learn scorer name
        such as ``"r2"``, a callable, or None), which is passed on to it.

    Returns
    -------
    scorer : callable
        A scorer ``scorer(estimator, X, y)``, greater is better. For a greyml
        name it is a new copy each call, so changing it (e.g. with
        ``set_score_request``) does not change greyml's own.

    Raises
    ------
    ValueError
        If ``name`` is a string that neither greyml nor scikit-learn knows. The
        message lists greyml's names, and suggests the ``neg_`` name when an
        error measure is asked for without it.

    See Also
    --------
    scoring : Several scorers at once, for multi-metric model selection.
    sklearn.metrics.get_scorer_names : scikit-learn's scorer names.

    Notes
    -----
    The error measures are negated (``neg_`` prefix) because scikit-learn
    maximises scores: ``get_scorer("neg_rmse")(est, X, y)`` equals
    ``-rmse(y, est.predict(X))``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from greyml.metrics import get_scorer
    >>> X = np.array([[0.0], [1.0], [2.0], [3.0]])
    >>> y = np.array([0.0, 2.0, 2.0, 4.0])
    >>> model = LinearRegression().fit(X, y)  # predicts [0.2, 1.4, 2.6, 3.8]
    >>> round(get_scorer("neg_residual_band")(model, X, y), 6)  # max |y - ŷ|
    -0.6
    >>> round(get_scorer("r2")(model, X, y), 6)  # scikit-learn's own: 1 - 0.8/8
    0.9
    """
    if isinstance(name, str):
        if name in SCORERS:
            return copy.deepcopy(SCORERS[name])
        try:
            return _sklearn_get_scorer(name)
        except ValueError:
            hint = ""
            if f"neg_{name}" in SCORERS:
                hint = (
                    f" '{name}' is an error (smaller is better) and scikit-learn"
                    f" maximises scores: use 'neg_{name}'."
                )
            raise ValueError(
                f"{name!r} is neither a greyml scorer nor a scikit-learn one.{hint}"
                f" greyml's scorers are: {', '.join(map(repr, SCORERS))}; "
                f"sklearn.metrics.get_scorer_names() lists scikit-learn's."
            ) from None
    return _sklearn_get_scorer(name)


def scoring(*names):
    """Several scorers by name, as a dict for multi-metric ``scoring=``.

    Parameters
    ----------
    *names : str
        Scorer names, as for :func:`get_scorer` (greyml's or scikit-learn's).
        With none, all five of greyml's, in the order listed under
        :func:`get_scorer`.

    Returns
    -------
    dict of str to callable
        ``{name: scorer}``, in the order given (a repeated name appears
        once). Pass it as ``scoring=`` to ``cross_validate`` (the results are
        under ``"test_<name>"``) or ``GridSearchCV`` (with ``refit`` set to
        one of the names, or False).

    Raises
    ------
    TypeError
        If a name is not a string.
    ValueError
        If a name is unknown (see :func:`get_scorer`).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import Ridge
    >>> from sklearn.model_selection import cross_validate
    >>> from greyml.metrics import scoring
    >>> X = np.arange(12.0).reshape(-1, 1)
    >>> y = 3.0 * X.ravel() + np.array([0.5, -0.5] * 6)
    >>> sorted(scoring("neg_rmse", "nash_sutcliffe"))
    ['nash_sutcliffe', 'neg_rmse']
    >>> result = cross_validate(Ridge(), X, y, cv=3,
    ...                         scoring=scoring("neg_rmse", "nash_sutcliffe"))
    >>> bool(np.all(result["test_neg_rmse"] < 0))
    True
    >>> list(scoring())
    ['neg_rmse', 'correlation', 'nash_sutcliffe', 'neg_residual_band', 'improvement']
    """
    for name in names:
        if not isinstance(name, str):
            raise TypeError(
                f"scorer names must be strings; got {name!r} of type {type(name).__name__}."
            )
    return {name: get_scorer(name) for name in (names or tuple(SCORERS))}
