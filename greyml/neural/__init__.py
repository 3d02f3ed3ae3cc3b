"""Neural models: the multilayer-perceptron baseline of Abdulshahed et al. (2016)."""

from greyml.neural._kernels import (
    ACTIVATIONS,
    LMResult,
    hidden,
    init_nguyen_widrow,
    levenberg_marquardt,
    mlp_forward,
    mlp_jacobian,
    mlp_residuals,
    n_params,
    pack,
    unpack,
)
from greyml.neural._mlp import MLPBaseline, UnderdeterminedWarning

__all__ = [
    "ACTIVATIONS",
    "LMResult",
    "MLPBaseline",
    "hidden",
    "init_nguyen_widrow",
    "levenberg_marquardt",
    "mlp_forward",
    "mlp_jacobian",
    "mlp_residuals",
    "n_params",
    "UnderdeterminedWarning",
    "pack",
    "unpack",
]
