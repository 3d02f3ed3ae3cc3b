"""Population optimisers shared by the grey and neural models.

Both evaluate the whole population in one vectorised call and draw randomness
only from the :class:`numpy.random.Generator` they are given.
"""

from greyml.optimize._base import PENALTY, PopulationOptimizer, check_bounds
from greyml.optimize._cuckoo import CuckooSearch, levy_steps, mantegna_sigma
from greyml.optimize._pso import ParticleSwarm

__all__ = [
    "PENALTY",
    "CuckooSearch",
    "ParticleSwarm",
    "PopulationOptimizer",
    "check_bounds",
    "levy_steps",
    "mantegna_sigma",
]
