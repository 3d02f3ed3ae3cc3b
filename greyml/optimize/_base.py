"""One small interface for the population optimisers (PSO, cuckoo search).

An optimiser is a plain object whose ``__init__`` only stores its settings and
whose :meth:`PopulationOptimizer.minimize` takes

* ``fun``: the objective of a whole population at once, ``(P, D) -> (P,)``;
* ``bounds``: ``(lower, upper)``, scalars or arrays of shape ``(D,)``;
* ``rng``: a :class:`numpy.random.Generator` (the only source of randomness);
* ``x0``: optional starting points placed in the initial population.

and returns a :class:`scipy.optimize.OptimizeResult` with ``x``, ``fun``,
``nfev``, ``nit`` and ``history`` (best value after each iteration). Losses that
come back NaN or infinite are replaced by a large finite penalty, so a candidate
that blows up simply loses.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import OptimizeResult

from greyml._validation import check_int_param

__all__ = ["PopulationOptimizer", "PENALTY", "check_bounds"]

#: Loss that replaces NaN or infinite objective values.
PENALTY = 1e200


def check_bounds(bounds, n_dim=None, x0=None):
    """Validate ``(lower, upper)`` and broadcast them to arrays of shape ``(D,)``.

    ``D`` is ``n_dim`` if given, else the bounds' length, else the number of
    columns of the starting points ``x0``.
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


def _check_count(owner, name, value, low=1):
    return check_int_param(owner, name, value, low)


class PopulationOptimizer:
    """Base class: stores settings, checks them in :meth:`minimize`."""

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def get_params(self, deep=True):
        return {k: getattr(self, k) for k in self._param_names}

    def set_params(self, **params):
        for k, v in params.items():
            if k not in self._param_names:
                raise ValueError(f"Invalid parameter {k!r} for {type(self).__name__}.")
            setattr(self, k, v)
        return self

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
    def _evaluate(fun, pop):
        values = np.asarray(fun(pop), dtype=float).reshape(-1)
        if values.shape[0] != pop.shape[0]:
            raise ValueError(
                f"The objective returned {values.shape[0]} values for a population "
                f"of {pop.shape[0]}; it must return one loss per row."
            )
        values = np.where(np.isfinite(values), values, PENALTY)
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

    @staticmethod
    def _result(x, fun, nfev, nit, history, method):
        return OptimizeResult(
            x=np.array(x, dtype=float),
            fun=float(fun),
            nfev=int(nfev),
            nit=int(nit),
            history=np.asarray(history, dtype=float),
            success=bool(np.isfinite(fun) and fun < PENALTY),
            message=f"{method}: iteration budget used",
        )
