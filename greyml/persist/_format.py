"""The model file's format: its name, version and limits, and the allowlist of
what a file may create."""

from __future__ import annotations

import importlib
import re
from types import MappingProxyType

import numpy as np
from scipy.optimize import OptimizeResult
from sklearn.compose import TransformedTargetRegressor
from sklearn.linear_model import (
    ElasticNet,
    ElasticNetCV,
    Lasso,
    LassoCV,
    LinearRegression,
    Ridge,
    RidgeCV,
)
from sklearn.model_selection import GroupKFold, KFold, LeaveOneGroupOut
from sklearn.pipeline import FeatureUnion, Pipeline
from sklearn.preprocessing import (
    FunctionTransformer,
    MaxAbsScaler,
    MinMaxScaler,
    PolynomialFeatures,
    RobustScaler,
    StandardScaler,
)

from greyml.controller import Compensator, Uncertainty
from greyml.dynamic import InputEnvelope, IntervalCalibration
from greyml.optimize import CuckooSearch, ParticleSwarm
from greyml.selection import TrainOnOneTest
from greyml.utils.discovery import all_estimators

#: Name written in every model file, checked on loading.
FORMAT_NAME = "greyml-model"
#: Version of the file layout; a reader refuses files of a later version.
FORMAT_VERSION = 1

_MODEL_MEMBER = "model.json"
_ARRAY_MEMBER = re.compile(r"arrays/(?:0|[1-9][0-9]{0,8})\.npy")
_DTYPE_TEXT = re.compile(r"[<>|=]?[?a-zA-Z][0-9]{0,4}(?:\[[0-9]{0,3}[a-zA-Z]{1,2}\])?")
_MAX_DEPTH = 200

_ABSENT = object()  # "no such attribute" where None is a value

#: The most a model file may make :func:`load_model` build, in bytes (256 MiB),
#: unless the caller passes another ``max_bytes``.
DEFAULT_MAX_BYTES = 256 * 2**20
# what one byte of model.json can cost in Python objects, parsed and then built:
# measured up to 77 bytes (4 MiB of "[[[]]]," items took 321 MB; "[]," 50x,
# numbers and strings 12-14x)
_JSON_COST = 128
# what an entry of an object array (a pointer) takes
_OBJECT_ENTRY_BYTES = 8
# what zipfile's index takes per member (~560 bytes measured)
_ENTRY_COST = 1024
# members are read this much at a time, never in one piece
_READ_CHUNK = 2**20
_MAX_NPY_HEADER = 10_000  # numpy's own default; greyml's headers take ~120 bytes
# the longest whole number a model file may spell out: a PCG64 state is 39 digits
_MAX_INT_DIGITS = 60

#: Classes a model file may create, by the name written in the file (read-only).
ALLOWED_CLASSES = MappingProxyType(
    {
        # greyml's estimators, every one that greyml.utils.discovery finds, by
        # its name at the top level (each is exported there), and what they
        # hold as parameters or results
        **{f"greyml.{name}": cls for name, cls in all_estimators()},
        # the runtime object a controller runs, saved with its state
        "greyml.Compensator": Compensator,
        # the records a fitted model or a compensator holds
        "greyml.controller.Uncertainty": Uncertainty,
        "greyml.dynamic.InputEnvelope": InputEnvelope,
        "greyml.dynamic.IntervalCalibration": IntervalCalibration,
        "greyml.optimize.CuckooSearch": CuckooSearch,
        "greyml.optimize.ParticleSwarm": ParticleSwarm,
        "greyml.selection.TrainOnOneTest": TrainOnOneTest,
        "scipy.optimize.OptimizeResult": OptimizeResult,
        # scikit-learn
        "sklearn.compose.TransformedTargetRegressor": TransformedTargetRegressor,
        "sklearn.linear_model.ElasticNet": ElasticNet,
        "sklearn.linear_model.ElasticNetCV": ElasticNetCV,
        "sklearn.linear_model.Lasso": Lasso,
        "sklearn.linear_model.LassoCV": LassoCV,
        "sklearn.linear_model.LinearRegression": LinearRegression,
        "sklearn.linear_model.Ridge": Ridge,
        "sklearn.linear_model.RidgeCV": RidgeCV,
        "sklearn.model_selection.GroupKFold": GroupKFold,
        "sklearn.model_selection.KFold": KFold,
        "sklearn.model_selection.LeaveOneGroupOut": LeaveOneGroupOut,
        "sklearn.pipeline.FeatureUnion": FeatureUnion,
        "sklearn.pipeline.Pipeline": Pipeline,
        "sklearn.preprocessing.FunctionTransformer": FunctionTransformer,
        "sklearn.preprocessing.MaxAbsScaler": MaxAbsScaler,
        "sklearn.preprocessing.MinMaxScaler": MinMaxScaler,
        "sklearn.preprocessing.PolynomialFeatures": PolynomialFeatures,
        "sklearn.preprocessing.RobustScaler": RobustScaler,
        "sklearn.preprocessing.StandardScaler": StandardScaler,
    }
)
_NAME_OF_CLASS = {cls: name for name, cls in ALLOWED_CLASSES.items()}

#: Objects save_model takes besides estimators: a runtime object with a state
#: (nothing to fit), saved and loaded like an estimator.
RUNTIME_CLASSES = (Compensator,)

# type objects (e.g. a ``dtype=np.float64`` parameter): NumPy's scalar types
# and Python's numbers and strings
_TYPES: dict[str, type] = {f"numpy.{t.__name__}": t for t in set(np.sctypeDict.values())}
_TYPES.update({f"builtins.{t.__name__}": t for t in (bool, int, float, complex, str, bytes)})
_NAME_OF_TYPE = {t: name for name, t in _TYPES.items()}

# NumPy ufuncs are pure arithmetic: the only functions a file may name
_UFUNCS: dict[str, np.ufunc] = {
    f"numpy.{name}": obj for name, obj in vars(np).items() if isinstance(obj, np.ufunc)
}
_NAME_OF_UFUNC = {id(f): name for name, f in _UFUNCS.items()}

_BIT_GENERATORS = {
    cls.__name__: cls
    for cls in (
        np.random.MT19937,
        np.random.PCG64,
        np.random.PCG64DXSM,
        np.random.Philox,
        np.random.SFC64,
    )
}


class _Corrupt(Exception):
    """Internal: the file's content is not what greyml writes."""


def _class_path(cls) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _greyml_version():
    from greyml import __version__

    return __version__


def _untrusted(found, extra_classes):
    """(classes, other names) the file names but may not create."""
    classes = {n for n in found["class"] if n not in ALLOWED_CLASSES and n not in extra_classes}
    others = {n for n in found["type"] if n not in _TYPES}
    others |= {n for n in found["ufunc"] if n not in _UFUNCS}
    others |= {f"numpy.random.{n}" for n in found["bit_generator"] if n not in _BIT_GENERATORS}
    return sorted(classes), sorted(others)


def _import_name(name):
    """The object a dotted name refers to, importing its module (trusted names only)."""
    parts = name.split(".")
    for split in range(len(parts) - 1, 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ImportError:
            continue
        try:
            for attr in parts[split:]:
                obj = getattr(obj, attr)
        except AttributeError:
            continue
        return obj
    raise ValueError(f"trusted={name!r}: no such class can be imported.")


def _check_trusted(trusted):
    if trusted is None:
        return []
    if isinstance(trusted, str):
        trusted = [trusted]
    if isinstance(trusted, bool) or not all(isinstance(t, str) for t in trusted):
        raise TypeError(
            "trusted must be a list of class names such as "
            "'sklearn.linear_model.HuberRegressor' (there is no blanket 'trust all')."
        )
    return list(trusted)


def _trusted_classes(trusted, wanted):
    """Map the class names in ``wanted`` that ``trusted`` allows to classes."""
    out = {}
    if not wanted:
        return out
    for name in trusted:
        obj = _import_name(name)
        if not isinstance(obj, type):
            raise ValueError(f"trusted={name!r} is not a class ({type(obj).__name__}).")
        for alias in (name, _class_path(obj)):
            if alias in wanted:
                out[alias] = obj
    return out
