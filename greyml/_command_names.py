"""Names the ``greyml`` command line offers, importable without NumPy or pandas.

:mod:`greyml.cli` builds its parser from them without importing the numerical
code, so that ``greyml --help`` and ``greyml --version`` answer at once;
:mod:`greyml._cli` uses the same names.
"""

from greyml._time import TIME_UNITS

__all__ = ["CSV_TIME_UNITS", "MACHINES", "MODEL_NAMES"]

#: Model names of ``greyml fit --model``, with the class each one builds.
MODEL_NAMES = {
    "gmc": "GMC",
    "gnnmci": "GNNMCI",
    "anfis-grid": "ANFISGrid",
    "anfis-fcm": "ANFISFCM",
    "mlp": "MLPBaseline",
    "transfer-function": "ThermalTransferFunction",
}

#: Machines of ``greyml simulate --machine``.
MACHINES = ("vmc", "vmc-probe", "gantry")

#: Units of ``--time-unit`` (those of :data:`greyml._time.TIME_UNITS`).
CSV_TIME_UNITS = tuple(TIME_UNITS)
