"""greyml: thermal-error models of CNC machine tools, scikit-learn compatible."""

from greyml._sequences import TEST_LEVEL, TIME_LEVEL, make_test_index, test_ids
from greyml.fuzzy import ANFISFCM, ANFISGrid
from greyml.grey import (
    AGO,
    GMC,
    GNNMCI,
    AccumulatedTargetRegressor,
    GreyConditioningWarning,
    GreyStabilityWarning,
    fit_gm1n,
    simulate_gmc,
)
from greyml.dynamic import ThermalTransferFunction
from greyml.neural import MLPBaseline
from greyml.selection import GreyInfluenceSelector, TrainOnOneTest

__version__ = "0.1.0.dev0"

__all__ = [
    "AGO",
    "ANFISFCM",
    "ANFISGrid",
    "AccumulatedTargetRegressor",
    "GMC",
    "GNNMCI",
    "GreyConditioningWarning",
    "GreyStabilityWarning",
    "GreyInfluenceSelector",
    "MLPBaseline",
    "TEST_LEVEL",
    "TIME_LEVEL",
    "ThermalTransferFunction",
    "TrainOnOneTest",
    "fit_gm1n",
    "make_test_index",
    "simulate_gmc",
    "test_ids",
    "__version__",
]
