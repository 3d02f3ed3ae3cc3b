"""Neural models: the multilayer-perceptron baseline of Abdulshahed et al. (2016).

Its numerical kernels are in :mod:`greyml.neural.kernels`.
"""

from greyml._moved import moved_getattr
from greyml.neural import kernels
from greyml.neural._mlp import MLPBaseline, UnderdeterminedWarning

__all__ = ["MLPBaseline", "UnderdeterminedWarning", "kernels"]

# the kernels were exported here until this release
__getattr__ = moved_getattr("greyml.neural", kernels.__all__, "greyml.neural.kernels")
