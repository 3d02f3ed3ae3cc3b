"""Cuckoo search via Lévy flights (Yang & Deb 2009), the whole nest set vectorised."""

from __future__ import annotations

import math

import numpy as np

from greyml._param_validation import Integral, Interval, Real
from greyml.optimize._base import PopulationOptimizer, _Evaluations, check_bounds

__all__ = ["CuckooSearch", "mantegna_sigma", "levy_steps"]


def mantegna_sigma(beta):
    """σ_u of Mantegna's algorithm for Lévy-stable steps of exponent ``beta``.

    σ_u = [Γ(1 + β) sin(πβ/2) / (Γ((1 + β)/2) β 2^((β − 1)/2))]^(1/β).

    Examples
    --------
    >>> from greyml.optimize._cuckoo import mantegna_sigma
    >>> mantegna_sigma(1.0)  # Γ(2) sin(π/2) / (Γ(1) · 1 · 2⁰)
    1.0
    >>> round(mantegna_sigma(1.5), 6)
    0.696575
    """
    num = math.gamma(1.0 + beta) * math.sin(math.pi * beta / 2.0)
    den = math.gamma((1.0 + beta) / 2.0) * beta * 2.0 ** ((beta - 1.0) / 2.0)
    return (num / den) ** (1.0 / beta)


def levy_steps(shape, beta, rng, sigma=None):
    """Lévy-flight steps ``s = u / |v|^(1/β)``, u ~ N(0, σ_u²), v ~ N(0, 1) (Mantegna).

    Examples
    --------
    Mostly short steps and now and then a very long one (heavy tails):

    >>> import numpy as np
    >>> from greyml.optimize._cuckoo import levy_steps
    >>> s = levy_steps((100, 100), beta=1.5, rng=np.random.default_rng(0))
    >>> s.shape
    (100, 100)
    >>> bool(np.abs(s).max() > 100 * np.median(np.abs(s)))
    True
    """
    if sigma is None:
        sigma = mantegna_sigma(beta)
    u = rng.standard_normal(shape) * sigma
    v = rng.standard_normal(shape)
    return u / np.abs(v) ** (1.0 / beta)


class CuckooSearch(PopulationOptimizer):
    """Cuckoo search with Lévy flights and nest abandonment.

    Every iteration (all nests at once):

    1. each nest lays a cuckoo egg by a Lévy flight,
       x' = x + α·s·(x − x_best)·N(0, 1), with Mantegna steps s of exponent β;
       the egg replaces its nest if it is no worse;
    2. a fraction ``pa`` of the eggs is discovered: each coordinate is hit with
       probability ``pa``, and along the hit coordinates the nest moves by a
       random difference of two other nests, x' = x + U(0, 1)·(x_{π₁} − x_{π₂});
       the result is again kept if no worse.

    The greedy replacement compares each egg with its own nest, as Yang & Deb's
    published demonstration code does. That code moves the coordinates *not*
    hit (probability 1 − pa); here the hit ones move, as the algorithm's
    description says (a fraction pa of nests is abandoned), which was also the
    more accurate of the two in ``benchmarks/bench_optimizers.py``. Each
    iteration evaluates the population twice, so
    ``nfev = n_population·(1 + 2·max_iter)``.

    Read more in the :ref:`User Guide <ug-gmc-calibration>`.

    Parameters
    ----------
    n_population : int, default=25
        Number of nests (Abdulshahed et al. (2017): 25).
    max_iter : int, default=100
        Iterations (Abdulshahed et al. (2017): 100).
    pa : float, default=0.25
        Discovery rate of alien eggs (Abdulshahed et al. (2017), after Yang 2010).
    alpha : float, default=0.01
        Step-size scale of the Lévy flights (Yang 2010).
    beta : float, default=1.5
        Lévy exponent (Yang & Deb 2009).

    See Also
    --------
    greyml.optimize.ParticleSwarm : the other population optimiser.
    greyml.GMC : calibrated by cuckoo search with ``solver="cs"``.

    References
    ----------
    Yang, X.-S. and Deb, S. (2009). Cuckoo search via Lévy flights. World Congress
    on Nature & Biologically Inspired Computing, 210-214. Mantegna, R. N. (1994).
    Fast, accurate algorithm for numerical simulation of Lévy stable stochastic
    processes. Phys. Rev. E 49, 4677.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.optimize import CuckooSearch
    >>> sphere = lambda P: (P ** 2).sum(axis=1)
    >>> res = CuckooSearch(max_iter=300).minimize(
    ...     sphere, (-5, 5), np.random.default_rng(0), n_dim=3)
    >>> bool(res.fun < 1e-6)
    True
    """

    _parameter_constraints: dict = {
        "n_population": [Interval(Integral, 2, None, closed="left")],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "pa": [Interval(Real, 0, 1, closed="both")],
        "alpha": [Interval(Real, 0, None, closed="neither")],
        "beta": [Interval(Real, 0, 2, closed="right")],
    }

    def __init__(self, n_population=25, max_iter=100, pa=0.25, alpha=0.01, beta=1.5):
        self.n_population = n_population
        self.max_iter = max_iter
        self.pa = pa
        self.alpha = alpha
        self.beta = beta

    @property
    def population_size(self) -> int:
        return self.n_population

    def minimize(self, fun, bounds, rng, x0=None, n_dim=None):
        """Minimise ``fun`` over the box ``bounds`` (same contract as PSO's)."""
        self._validate_params()
        n, iters = int(self.population_size), int(self.max_iter)
        pa, alpha, beta = float(self.pa), float(self.alpha), float(self.beta)
        rng = self._check_rng(rng)
        lower, upper = check_bounds(bounds, n_dim, x0)
        sigma = mantegna_sigma(beta)

        nests = self._initial_population(n, lower, upper, rng, x0)
        count = _Evaluations()
        fit = self._evaluate(fun, nests, count)
        b = int(np.argmin(fit))
        best, best_f = nests[b].copy(), fit[b]
        history = np.empty(iters)

        for t in range(iters):
            # 1. Lévy flights around the current nests, scaled by the distance to the best
            steps = levy_steps(nests.shape, beta, rng, sigma)
            eggs = nests + alpha * steps * (nests - best) * rng.standard_normal(nests.shape)
            self._lay(fun, eggs, nests, fit, lower, upper, count)

            # 2. a fraction pa of the eggs is discovered and the nest moves
            found = rng.random(nests.shape) < pa
            shift = rng.random((n, 1)) * (nests[rng.permutation(n)] - nests[rng.permutation(n)])
            self._lay(fun, nests + shift * found, nests, fit, lower, upper, count)

            b = int(np.argmin(fit))
            if fit[b] < best_f:
                best, best_f = nests[b].copy(), fit[b]
            history[t] = best_f

        return self._result(
            best, best_f, n * (1 + 2 * iters), iters, history, "Cuckoo search", count
        )

    def _lay(self, fun, eggs, nests, fit, lower, upper, count):
        """Clip ``eggs`` to the box, evaluate them, and let each nest whose egg is at
        least as good take it (``nests`` and ``fit`` in place)."""
        np.clip(eggs, lower, upper, out=eggs)
        f_eggs = self._evaluate(fun, eggs, count)
        keep = f_eggs <= fit
        nests[keep] = eggs[keep]
        fit[keep] = f_eggs[keep]
