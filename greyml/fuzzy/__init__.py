"""Takagi–Sugeno fuzzy inference (ANFIS) with Jang's hybrid learning.

- :class:`ANFISGrid`: the rule base from a grid partition of the inputs;
- :class:`ANFISFCM`: the rule base from fuzzy c-means clusters.
"""

from greyml.fuzzy._anfis import ANFISFCM, ANFISGrid

__all__ = ["ANFISFCM", "ANFISGrid"]
