"""Grey models: AGO, GM(1,N), GMC(1,N) and the grey neural network GNNMCI(1,N).

Their numerical kernels are in :mod:`greyml.grey.kernels`.
"""

from greyml._moved import moved_getattr
from greyml.grey import kernels
from greyml.grey._ago import AGO, AccumulatedTargetRegressor
from greyml.grey._functions import fit_gm1n, simulate_gmc
from greyml.grey._gmc import (
    GMC,
    GreyConditioningWarning,
    GreyStabilityWarning,
    GreyWarmStartWarning,
)
from greyml.grey._gnnmci import GNNMCI

__all__ = [
    "AGO",
    "AccumulatedTargetRegressor",
    "GMC",
    "GNNMCI",
    "GreyConditioningWarning",
    "GreyStabilityWarning",
    "GreyWarmStartWarning",
    "fit_gm1n",
    "kernels",
    "simulate_gmc",
]

# the kernels were exported here until this release
__getattr__ = moved_getattr("greyml.grey", kernels.__all__, "greyml.grey.kernels")
