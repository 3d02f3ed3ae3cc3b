"""Grey models: AGO, GM(1,N), GMC(1,N) and the grey neural network GNNMCI(1,N)."""

from greyml.grey._ago import AGO, AccumulatedTargetRegressor
from greyml.grey._functions import fit_gm1n, simulate_gmc
from greyml.grey._gmc import (
    GMC,
    GreyConditioningWarning,
    GreyStabilityWarning,
    GreyWarmStartWarning,
)
from greyml.grey._gnnmci import GNNMCI
from greyml.grey._kernels import (
    ago,
    background,
    gm1n_design,
    gm1n_lstsq,
    gmc_design,
    gmc_lstsq,
    gmc_lstsq_fixed_b1,
    iago,
)
from greyml.grey._response import (
    gmc_basis,
    gmc_predict,
    gmc_predict_population,
    gmc_response,
    gmc_separable,
    gmc_sse_population,
    gnnmci_layers,
)

__all__ = [
    "AGO",
    "AccumulatedTargetRegressor",
    "GMC",
    "GNNMCI",
    "GreyConditioningWarning",
    "GreyStabilityWarning",
    "GreyWarmStartWarning",
    "ago",
    "background",
    "fit_gm1n",
    "gm1n_design",
    "gm1n_lstsq",
    "gmc_basis",
    "gmc_design",
    "gmc_lstsq",
    "gmc_lstsq_fixed_b1",
    "gmc_predict",
    "gmc_predict_population",
    "gmc_response",
    "gmc_separable",
    "gmc_sse_population",
    "gnnmci_layers",
    "iago",
    "simulate_gmc",
]
