"""greyml: thermal-error models of CNC machine tools, scikit-learn compatible.

From the top level: the estimators and transformers (:class:`ThermalTransferFunction`,
:class:`LagFeatures`, :class:`GMC`, :class:`GNNMCI`, :class:`AGO`,
:class:`AccumulatedTargetRegressor`, :class:`ANFISGrid`, :class:`ANFISFCM`,
:class:`MLPBaseline`, :class:`RelativeToStart`), the sensor selector
(:class:`GreyInfluenceSelector`), the splitter :class:`TrainOnOneTest`, the
runtime :class:`Compensator`, and the helpers of the test layout
(:func:`make_test_index`, :func:`groups_of`). The rest by job:

- :mod:`greyml.datasets`, :mod:`greyml.io`, :mod:`greyml.simulation`: data
  sets, CSV files and the thermal simulator;
- :mod:`greyml.persist`: model files read without pickle;
- :mod:`greyml.gap`: the sim-to-real gap diagnosis;
- :mod:`greyml.fleet`: a fleet's models on a Dask cluster;
- :mod:`greyml.metrics`: accuracy measures and scorers;
- :mod:`greyml.optimize`: the population optimisers of the grey models;
- :mod:`greyml.exceptions`: every warning and error;
- :mod:`greyml.utils.discovery`: the list of greyml's estimators.
"""

# The public names are imported on first use (PEP 562), so that the command
# line answers ``greyml --version`` and ``--help`` without importing NumPy,
# pandas or scikit-learn.
#: greyml's version (PEP 440).
__version__ = "0.1.0.dev0"

#: Where each public name lives.
_LAZY = {
    "groups_of": "greyml._sequences",
    "make_test_index": "greyml._sequences",
    "Compensator": "greyml.controller",
    "LagFeatures": "greyml.dynamic",
    "ThermalTransferFunction": "greyml.dynamic",
    "ANFISFCM": "greyml.fuzzy",
    "ANFISGrid": "greyml.fuzzy",
    "AGO": "greyml.grey",
    "GMC": "greyml.grey",
    "GNNMCI": "greyml.grey",
    "AccumulatedTargetRegressor": "greyml.grey",
    "MLPBaseline": "greyml.neural",
    "RelativeToStart": "greyml.preprocessing",
    "GreyInfluenceSelector": "greyml.selection",
    "TrainOnOneTest": "greyml.selection",
}

__all__ = [
    "AGO",
    "ANFISFCM",
    "GMC",
    "GNNMCI",
    "ANFISGrid",
    "AccumulatedTargetRegressor",
    "Compensator",
    "GreyInfluenceSelector",
    "LagFeatures",
    "MLPBaseline",
    "RelativeToStart",
    "ThermalTransferFunction",
    "TrainOnOneTest",
    "__version__",
    "groups_of",
    "make_test_index",
]


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'greyml' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # the next access is a plain attribute
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
