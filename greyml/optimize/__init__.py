"""Population optimisers shared by the grey and neural models.

- :class:`ParticleSwarm`: particle swarm optimisation with a decreasing
  inertia weight;
- :class:`CuckooSearch`: cuckoo search by Lévy flights.

Both evaluate the whole population in one vectorised call and draw randomness
only from the :class:`numpy.random.Generator` they are given. Pass one as
``solver=`` to :class:`~greyml.GMC`; :class:`~greyml.GNNMCI` takes the
swarm's settings as its own parameters.
"""

from greyml.optimize._cuckoo import CuckooSearch
from greyml.optimize._pso import ParticleSwarm

__all__ = ["CuckooSearch", "ParticleSwarm"]
