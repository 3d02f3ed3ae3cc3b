"""Particle swarm optimisation, global-best topology, the whole swarm vectorised."""

from __future__ import annotations

import numpy as np

from greyml._param_validation import (
    Integral,
    Interval,
    Real,
    validate_parameter_constraints,
)
from greyml.optimize._base import PopulationOptimizer, _Evaluations, check_bounds

__all__ = ["ParticleSwarm"]


class ParticleSwarm(PopulationOptimizer):
    """Global-best particle swarm with a linearly decreasing inertia weight.

    Each iteration updates every particle at once::

        v ← w·v + c₁·r₁·(p_best − x) + c₂·r₂·(g_best − x),  |v| ≤ κ·(upper − lower)
        x ← x + v

    with r₁, r₂ ~ U(0, 1) drawn per particle and dimension, and w falling linearly
    from ``inertia[0]`` to ``inertia[1]`` over the iterations. A coordinate that
    leaves the box is re-drawn uniformly inside it. (Clipping it instead parks
    particles on the bounds; on a 12-parameter fit in ``benchmarks/`` that made
    the median best value about twice as large.)

    Read more in the :ref:`User Guide <ug-gmc-calibration>`.

    Parameters
    ----------
    n_population : int, default=25
        Swarm size (Abdulshahed et al. (2017): 25; Abdulshahed et al.'s (2016) GNNMCI: 90).
    max_iter : int, default=100
        Iterations after the initial evaluation.
    c1, c2 : float, default=2.0
        Cognitive and social acceleration coefficients (Abdulshahed et al. (2017): 2 and 2;
        Abdulshahed et al. (2016): 1.5 and 2).
    inertia : (float, float), default=(0.9, 0.4)
        Inertia weight at the first and the last iteration.
    velocity_clamp : float, default=0.2
        κ, the largest step per iteration as a fraction of each parameter's range
        (not given by the seeds; 0.2 measured best of 0.2 and 0.5 in
        ``benchmarks/bench_optimizers.py``).

    See Also
    --------
    greyml.optimize.CuckooSearch : the other population optimiser.
    greyml.GMC : calibrated by a particle swarm with ``solver="pso"``.
    greyml.GNNMCI : its weights are trained by a particle swarm.

    References
    ----------
    Kennedy, J. and Eberhart, R. (1995). Particle swarm optimization. Proc. IEEE
    ICNN, 1942-1948. Shi, Y. and Eberhart, R. (1998). A modified particle swarm
    optimizer. Proc. IEEE CEC, 69-73 (the inertia weight).

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.optimize import ParticleSwarm
    >>> sphere = lambda P: (P ** 2).sum(axis=1)
    >>> res = ParticleSwarm(max_iter=200).minimize(
    ...     sphere, (-5, 5), np.random.default_rng(0), n_dim=3)
    >>> bool(res.fun < 1e-8)
    True
    """

    _parameter_constraints: dict = {
        "n_population": [Interval(Integral, 1, None, closed="left")],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "c1": [Interval(Real, 0, None, closed="left")],
        "c2": [Interval(Real, 0, None, closed="left")],
        "inertia": ["array-like"],
        "velocity_clamp": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        n_population=25,
        max_iter=100,
        c1=2.0,
        c2=2.0,
        inertia=(0.9, 0.4),
        velocity_clamp=0.2,
    ):
        self.n_population = n_population
        self.max_iter = max_iter
        self.c1 = c1
        self.c2 = c2
        self.inertia = inertia
        self.velocity_clamp = velocity_clamp

    @property
    def population_size(self) -> int:
        return self.n_population

    def _validated(self):
        self._validate_params()
        try:
            w0, w1 = self.inertia
        except (TypeError, ValueError):
            raise ValueError(
                "The 'inertia' parameter of ParticleSwarm must be a pair "
                f"(start, end). Got {self.inertia!r} instead."
            ) from None
        # each end of the pair, in scikit-learn's words
        weight = [Interval(Real, 0, 2, closed="both")]
        validate_parameter_constraints(
            {"inertia[0]": weight, "inertia[1]": weight},
            {"inertia[0]": w0, "inertia[1]": w1},
            caller_name=type(self).__name__,
        )
        n, iters = int(self.population_size), int(self.max_iter)
        c1, c2, kappa = float(self.c1), float(self.c2), float(self.velocity_clamp)
        w0, w1 = float(w0), float(w1)
        return n, iters, c1, c2, w0, w1, kappa

    def minimize(self, fun, bounds, rng, x0=None, n_dim=None):
        """Minimise ``fun`` over the box ``bounds``.

        Parameters
        ----------
        fun : callable
            ``fun(X) -> losses`` for a population ``X`` of shape ``(P, D)``.
        bounds : (lower, upper)
            Scalars or arrays of shape ``(D,)``.
        rng : numpy.random.Generator
            Source of all randomness.
        x0 : array-like of shape (k, D), optional
            Starting points put into the initial swarm (clipped to the bounds).
        n_dim : int, optional
            Number of parameters when both bounds are scalars.

        Returns
        -------
        scipy.optimize.OptimizeResult
            ``x``, ``fun``, ``nfev``, ``nit``, ``history``.
        """
        n, iters, c1, c2, w0, w1, kappa = self._validated()
        rng = self._check_rng(rng)
        lower, upper = check_bounds(bounds, n_dim, x0)
        span = upper - lower
        vmax = kappa * span

        x = self._initial_population(n, lower, upper, rng, x0)
        count = _Evaluations()
        v = (2.0 * rng.random(x.shape) - 1.0) * vmax
        fx = self._evaluate(fun, x, count)
        pbest, pbest_f = x.copy(), fx.copy()
        g = int(np.argmin(pbest_f))
        gbest, gbest_f = pbest[g].copy(), pbest_f[g]
        history = np.empty(iters)
        weights = np.linspace(w0, w1, iters) if iters > 1 else np.array([w0])

        for t in range(iters):
            r1 = rng.random(x.shape)
            r2 = rng.random(x.shape)
            v *= weights[t]
            v += c1 * r1 * (pbest - x) + c2 * r2 * (gbest - x)
            np.clip(v, -vmax, vmax, out=v)
            x += v
            out = (x < lower) | (x > upper)
            if out.any():
                # re-draw the coordinates that left the box: clipping them would
                # park particles on the bounds (≈10 % of coordinates in tests)
                redraw = lower + rng.random(x.shape) * span
                x[out] = redraw[out]
            fx = self._evaluate(fun, x, count)
            better = fx < pbest_f
            pbest[better] = x[better]
            pbest_f[better] = fx[better]
            g = int(np.argmin(pbest_f))
            if pbest_f[g] < gbest_f:
                gbest, gbest_f = pbest[g].copy(), pbest_f[g]
            history[t] = gbest_f

        return self._result(gbest, gbest_f, n * (iters + 1), iters, history, "PSO", count)
