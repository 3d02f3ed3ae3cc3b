"""Neural models: the multilayer-perceptron baseline of Abdulshahed et al. (2016).

- :class:`MLPBaseline`: a one-hidden-layer perceptron trained by
  Levenberg–Marquardt.

Its warning, :class:`~greyml.exceptions.UnderdeterminedWarning`, is in
:mod:`greyml.exceptions`.
"""

from greyml.neural._mlp import MLPBaseline

__all__ = ["MLPBaseline"]
