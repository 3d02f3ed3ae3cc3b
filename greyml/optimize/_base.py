"""One small interface for the population optimisers (PSO, cuckoo search).

An optimiser is a plain object whose ``__init__`` only stores its settings and
whose :meth:`PopulationOptimizer.minimize` takes

* ``fun``: the objective of a whole population at once, ``(P, D) -> (P,)``;
* ``bounds``: ``(lower, upper)``, scalars or arrays of shape ``(D,)``;
* ``rng``: a :class:`numpy.random.Generator` (the only source of randomness);
* ``x0``: optional starting points placed in the initial population.

and returns a :class:`scipy.optimize.OptimizeResult` with ``x``, ``fun``,
``nfev``, ``nit``, ``history`` (best value after each iteration) and
``nfev_nonfinite``. Losses that come back NaN, ``+inf`` or ``-inf`` are replaced by
a large finite penalty (:data:`PENALTY`), so a candidate that blows up simply
loses; ``-inf`` is no better than NaN. An objective that raises an arithmetic
error (e.g. ``FloatingPointError`` under ``numpy.errstate(all="raise")``) for a
population is evaluated again row by row, and the rows that raise are
penalised. NumPy's floating-point warnings (overflow in ``exp`` …) inside the
objective are silenced, as their result is handled here. ``nfev_nonfinite``
counts the penalised evaluations; if no evaluation at all was finite,
:meth:`PopulationOptimizer.minimize` raises ``ValueError``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import OptimizeResult
from sklearn.base import BaseEstimator

__all__ = ["PopulationOptimizer", "PENALTY", "check_bounds"]

#: The one loss sentinel of greyml: replaces NaN or infinite objective values
#: here, and is the loss the grey kernels give a candidate whose trajectory
#: overflows. Large enough to lose against any usable candidate, small enough
#: that sums of a few of them stay finite.
PENALTY = 1e200


class _Evaluations:
    """Running count of the objective's evaluations and of the penalised ones."""

    __slots__ = ("n", "n_nonfinite")

    def __init__(self):
        self.n = 0
        self.n_nonfinite = 0


def _losses(fun, pop):
    """``fun(pop)`` as a float vector of length ``len(pop)``, NaN where it raised."""
    # the objective's non-finite values are handled by the caller, so NumPy's
    # warnings about producing them are not the user's concern
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        try:
            values = np.asarray(fun(pop), dtype=float).reshape(-1)
        except ArithmeticError:
            # FloatingPointError / OverflowError / ZeroDivisionError: find the
            # rows that raise, keep the others
            if pop.shape[0] == 1:
                return np.array([np.nan])
            return np.concatenate([_losses(fun, pop[i : i + 1]) for i in range(pop.shape[0])])
    if values.shape[0] != pop.shape[0]:
        raise ValueError(
            f"The objective returned {values.shape[0]} values for a population "
            f"of {pop.shape[0]}; it must return one loss per row."
        )
    return values


def check_bounds(bounds, n_dim=None, x0=None):
    """Validate ``(lower, upper)`` and broadcast them to arrays of shape ``(D,)``.

    ``D`` is ``n_dim`` if given, else the bounds' length, else the number of
    columns of the starting points ``x0``.

    Examples
    --------
    >>> from greyml.optimize._base import check_bounds
    >>> lower, upper = check_bounds((0, [1, 2]))
    >>> lower.tolist(), upper.tolist()
    ([0.0, 0.0], [1.0, 2.0])
    >>> [b.tolist() for b in check_bounds((-1, 1), n_dim=3)]
    [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]
    >>> check_bounds((1, 0))
    Traceback (most recent call last):
    ...
    ValueError: bounds are out of order for parameter 0: lower 1 is not below upper 0.
    """
    try:
        lower, upper = bounds
    except (TypeError, ValueError):
        raise ValueError(f"bounds must be a pair (lower, upper); got {bounds!r}.") from None
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    if n_dim is None:
        n_dim = max(lower.size, upper.size)
        if n_dim == 1 and x0 is not None:
            n_dim = np.atleast_2d(np.asarray(x0, dtype=float)).shape[1]
    try:
        lower = np.broadcast_to(lower, (n_dim,)).copy()
        upper = np.broadcast_to(upper, (n_dim,)).copy()
    except ValueError:
        raise ValueError(
            f"bounds must be scalars or arrays of length {n_dim}; got lower of "
            f"shape {np.shape(lower)} and upper of shape {np.shape(upper)}."
        ) from None
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        raise ValueError("bounds must be finite numbers.")
    bad = np.flatnonzero(lower >= upper)
    if bad.size:
        j = int(bad[0])
        raise ValueError(
            f"bounds are out of order for parameter {j}: lower {lower[j]:g} is not "
            f"below upper {upper[j]:g}."
        )
    return lower, upper


class PopulationOptimizer(BaseEstimator):
    """Base class: stores settings, checks them in :meth:`minimize`.

    A subclass stores its settings in ``__init__`` (keyword arguments kept
    unchanged, as for any scikit-learn estimator), declares them in
    ``_parameter_constraints`` and implements ``population_size`` and
    ``minimize``. As a scikit-learn ``BaseEstimator`` it has ``get_params``,
    ``set_params``, ``repr`` and ``_validate_params``; this class adds
    equality and helpers for the initial population, the evaluation of a
    population and the result.

    Examples
    --------
    A random search in a few lines:

    >>> import numpy as np
    >>> from greyml.optimize._base import PopulationOptimizer, check_bounds
    >>> class RandomSearch(PopulationOptimizer):
    ...     def __init__(self, n_points=100):
    ...         self.n_points = n_points
    ...
    ...     @property
    ...     def population_size(self):
    ...         return self.n_points
    ...
    ...     def minimize(self, fun, bounds, rng, x0=None):
    ...         lower, upper = check_bounds(bounds, x0=x0)
    ...         rng = self._check_rng(rng)
    ...         pop = self._initial_population(self.n_points, lower, upper, rng, x0)
    ...         values = self._evaluate(fun, pop)
    ...         best = int(np.argmin(values))
    ...         return self._result(pop[best], values[best], len(pop), 1, [values[best]],
    ...                             "Random search")
    >>> search = RandomSearch(n_points=50)
    >>> search
    RandomSearch(n_points=50)
    >>> search.set_params(n_points=20) == RandomSearch(20)
    True

    A starting point ``x0`` joins the population, here at the optimum:

    >>> sphere = lambda P: (P ** 2).sum(axis=1)
    >>> res = search.minimize(sphere, (-1, 1), np.random.default_rng(0), x0=[[0.0, 0.0]])
    >>> res.x.tolist(), res.fun, res.nfev
    ([0.0, 0.0], 0.0, 20)
    """

    #: Constraints of the settings, as scikit-learn declares an estimator's
    #: parameters; a subclass that declares none is not checked.
    _parameter_constraints: dict = {}

    def __eq__(self, other):
        return type(self) is type(other) and self.get_params() == other.get_params()

    __hash__ = None

    @property
    def population_size(self) -> int:
        raise NotImplementedError

    def minimize(self, fun, bounds, rng, x0=None):  # pragma: no cover - abstract
        raise NotImplementedError

    # helpers shared by the subclasses -------------------------------------
    @staticmethod
    def _evaluate(fun, pop, count=None):
        """Losses of the population, NaN/±inf (or a raising row) → :data:`PENALTY`.

        ``count`` (an ``_Evaluations``), if given, is advanced by the number of
        rows and of penalised rows.
        """
        values = _losses(fun, pop)
        finite = np.isfinite(values)
        if count is not None:
            count.n += values.shape[0]
            count.n_nonfinite += int(values.shape[0] - np.count_nonzero(finite))
        values = np.where(finite, values, PENALTY)
        return np.minimum(values, PENALTY)

    @staticmethod
    def _initial_population(n, lower, upper, rng, x0):
        pop = lower + rng.random((n, lower.size)) * (upper - lower)
        if x0 is not None:
            x0 = np.atleast_2d(np.asarray(x0, dtype=float))
            if x0.shape[1] != lower.size:
                raise ValueError(
                    f"x0 has {x0.shape[1]} columns but the problem has {lower.size} parameters."
                )
            k = min(len(x0), n)
            pop[:k] = np.clip(x0[:k], lower, upper)
        return pop

    @staticmethod
    def _check_rng(rng):
        if not isinstance(rng, np.random.Generator):
            raise TypeError(
                "rng must be a numpy.random.Generator (e.g. "
                f"numpy.random.default_rng(0)); got {type(rng).__name__}."
            )
        return rng

    def _result(self, x, fun, nfev, nit, history, method, count=None):
        """The :class:`~scipy.optimize.OptimizeResult`; with ``count``, raise
        ``ValueError`` if no evaluation was finite and report ``nfev_nonfinite``."""
        nonfinite = None if count is None else count.n_nonfinite
        if count is not None and count.n > 0 and nonfinite == count.n:
            raise ValueError(
                f"{type(self).__name__} ({method}): the objective returned no finite "
                f"value in {count.n:,} evaluations (every loss was NaN, +inf or -inf, "
                "or raised an arithmetic error). Check the objective and the bounds: "
                "it must be finite somewhere inside them."
            )
        result = OptimizeResult(
            x=np.array(x, dtype=float),
            fun=float(fun),
            nfev=int(nfev),
            nit=int(nit),
            history=np.asarray(history, dtype=float),
            success=bool(np.isfinite(fun) and fun < PENALTY),
            message=f"{method}: iteration budget used",
        )
        if nonfinite is not None:
            result.nfev_nonfinite = int(nonfinite)
        return result
