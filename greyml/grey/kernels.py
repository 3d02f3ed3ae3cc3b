"""The grey models' numerical kernels: AGO, GM(1,N) and GMC systems, the O(n) time response.

Pure array functions, the ones :class:`greyml.GMC`, :class:`greyml.GNNMCI`,
:func:`greyml.fit_gm1n` and :class:`greyml.GreyInfluenceSelector` call after
validating their input: arrays in and arrays out, tests given by their row
ranges (``test_bounds``), no validation, no random state.
"""

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
    "ago",
    "background",
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
]
