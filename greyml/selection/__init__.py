"""Sensor selection and test-aware model selection."""

from greyml.selection._influence import GreyInfluenceSelector
from greyml.selection._split import TrainOnOneTest

__all__ = ["GreyInfluenceSelector", "TrainOnOneTest"]
