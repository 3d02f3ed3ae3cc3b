"""Takagi–Sugeno fuzzy inference (ANFIS) with Jang's hybrid learning.

Its numerical kernels are in :mod:`greyml.fuzzy.kernels`.
"""

from greyml._moved import moved_getattr
from greyml.fuzzy import kernels
from greyml.fuzzy._anfis import ANFISFCM, ANFISGrid

__all__ = ["ANFISFCM", "ANFISGrid", "kernels"]

# the kernels were exported here until this release
__getattr__ = moved_getattr("greyml.fuzzy", kernels.__all__, "greyml.fuzzy.kernels")
