"""Sensor selection and test-aware model selection.

- :class:`GreyInfluenceSelector`: the sensors of greatest grey influence, one
  per group of similar sensors, as a scikit-learn selector;
- :class:`TrainOnOneTest`: the papers' splitter, calibrating on one test and
  validating on the others.
"""

from greyml.selection._influence import GreyInfluenceSelector
from greyml.selection._split import TrainOnOneTest

__all__ = ["GreyInfluenceSelector", "TrainOnOneTest"]
