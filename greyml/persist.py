"""Save fitted models to a file, and load them back without running code from it.

A pickle (or joblib) file can run any code when it is loaded, so a model file
from someone else is as dangerous as a script from them. greyml's model files
hold data only:

* ``model.json``: the format's name and version, the versions of greyml,
  scikit-learn, NumPy and Python that wrote the file, when it was written, the
  estimator's class and input names, and the object tree: every object as its
  class name and its attributes, every list, tuple and dict spelt out;
* ``arrays/<n>.npy``: every numeric, boolean or text array, in NumPy's own
  format, read back with ``allow_pickle=False``.

Both live in one zip archive. :func:`load_model` first lists every class the
tree names and refuses the file (:class:`UnsafeModelError`) unless each is on
greyml's allowlist or in the caller's ``trusted`` list. Only then does it build
the objects, without calling their ``__init__``: it creates the bare instance
and sets its attributes. Nothing from the file is imported, evaluated or
unpickled.

The allowlist: greyml's estimators (and the optimisers and splitter they may
hold as parameters), the scikit-learn pipelines, scalers, linear models and
splitters listed in ``ALLOWED_CLASSES``, SciPy's ``OptimizeResult``, NumPy's
scalar types, dtypes, random generators and ufuncs (``numpy.log`` as a
``TransformedTargetRegressor`` function, for example), and Python's built-in
containers.

What :func:`load_model` guarantees for a file from anyone, and nothing more:

* **No code from the file is executed.** Nothing is unpickled, imported or
  evaluated; only the classes above are created, and a file sets only data:
  no attribute named like a method, property or other attribute of its class,
  and a function (a NumPy ufunc, a type) only as the value of a constructor
  parameter (``func=numpy.log``).
* **Memory is bounded by** ``max_bytes`` (``DEFAULT_MAX_BYTES``, 256 MiB, by
  default). Only a regular file of at most ``max_bytes`` is opened. Before
  any array is read, what the load will build is added up and the file
  refused if the total passes the limit: zipfile's index of the members
  (1 KiB per 46 bytes of the zip's directory), the JSON description (128
  bytes per byte, what its Python objects can take) and every array as its
  shape and dtype say, each reference to a member counted as a copy of its
  own, each empty axis as one entry and each entry as at least one byte.
  Each member is inflated once, through a reader that stops at its declared
  size.
* **Processes are not taken from the file.** Every loaded object's ``n_jobs``
  is set to ``None`` (joblib's default: one process, unless the caller's
  ``joblib.parallel_backend`` says otherwise); set it after loading if you
  want more.

A file that breaks these rules is refused with one line naming it, and so is
one whose arrays disagree with their estimator (for greyml's and
scikit-learn's estimators on the allowlist: ``feature_names_in_`` has
``n_features_in_`` names, coefficients and scalings one entry per input), or
whose JSON holds a number that overflows. These checks catch files that were
altered carelessly; they are not a guarantee that a file which passes them
holds a right model.
"""

from __future__ import annotations

import contextlib
import datetime as _datetime
import importlib
import inspect
import io
import json
import math
import os
import platform
import re
import secrets
import stat
import warnings
import zipfile
from pathlib import Path
from types import MappingProxyType

import numpy as np
import sklearn
from scipy.optimize import OptimizeResult
from sklearn.base import BaseEstimator
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
from sklearn.model_selection._search import BaseSearchCV
from sklearn.pipeline import FeatureUnion, Pipeline
from sklearn.preprocessing import (
    FunctionTransformer,
    MaxAbsScaler,
    MinMaxScaler,
    PolynomialFeatures,
    RobustScaler,
    StandardScaler,
)
from sklearn.utils.validation import check_is_fitted

from greyml.exceptions import UnsafeModelError
from greyml.dynamic import Compensator, LagFeatures, ThermalTransferFunction
from greyml.fuzzy import ANFISFCM, ANFISGrid
from greyml.grey import AGO, GMC, GNNMCI, AccumulatedTargetRegressor
from greyml.neural import MLPBaseline
from greyml.optimize import CuckooSearch, ParticleSwarm
from greyml.selection import GreyInfluenceSelector, TrainOnOneTest

__all__ = ["UnsafeModelError", "describe_model", "load_model", "save_model"]

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
        # greyml's estimators, and what they hold as parameters or results
        "greyml.AGO": AGO,
        "greyml.AccumulatedTargetRegressor": AccumulatedTargetRegressor,
        "greyml.ANFISFCM": ANFISFCM,
        "greyml.ANFISGrid": ANFISGrid,
        "greyml.Compensator": Compensator,
        "greyml.GMC": GMC,
        "greyml.GNNMCI": GNNMCI,
        "greyml.GreyInfluenceSelector": GreyInfluenceSelector,
        "greyml.LagFeatures": LagFeatures,
        "greyml.MLPBaseline": MLPBaseline,
        "greyml.optimize.CuckooSearch": CuckooSearch,
        "greyml.optimize.ParticleSwarm": ParticleSwarm,
        "greyml.selection.TrainOnOneTest": TrainOnOneTest,
        "greyml.ThermalTransferFunction": ThermalTransferFunction,
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


# -- writing ----------------------------------------------------------------


def _class_path(cls) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _check_plain_state(cls, where):
    """A class outside the allowlist can be saved only if its instances are
    fully described by their ``__dict__`` (no custom pickling)."""
    if "<locals>" in cls.__qualname__:
        raise TypeError(f"Cannot save {where}: {cls.__qualname__} is defined inside a function.")
    custom = [
        name
        for name, base in (
            ("__getstate__", BaseEstimator),
            ("__setstate__", BaseEstimator),
            ("__reduce__", object),
            ("__reduce_ex__", object),
        )
        if getattr(cls, name, None) is not getattr(base, name, None)
    ]
    if custom or getattr(cls, "__slots__", None):
        raise TypeError(
            f"Cannot save {where}: {_class_path(cls)} keeps state outside its attributes "
            f"({', '.join(custom) or '__slots__'}), which greyml's model format cannot hold."
        )


class _Writer:
    """Turns an object tree into JSON-ready nodes plus ``.npy`` members."""

    def __init__(self):
        self.arrays: list[tuple[str, bytes]] = []
        self.classes: set[str] = set()
        self._open: set[int] = set()

    def _npy(self, array):
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, array, allow_pickle=False)
        name = f"arrays/{len(self.arrays)}.npy"
        self.arrays.append((name, buffer.getvalue()))
        return name

    def encode(self, value, where):
        kind = type(value)
        if value is None or kind in (bool, int, str):
            return value
        if kind is float:
            return value if math.isfinite(value) else {"kind": "float", "value": repr(value)}
        if isinstance(value, np.generic):
            return self._scalar(value, where)
        if isinstance(value, np.dtype):
            if value.fields is not None or not _DTYPE_TEXT.fullmatch(value.str):
                raise TypeError(f"Cannot save {where}: structured dtype {value} is not supported.")
            return {"kind": "dtype", "value": value.str}
        if isinstance(value, type):
            name = _NAME_OF_TYPE.get(value)
            if name is None:
                raise TypeError(
                    f"Cannot save {where}: it is the class {_class_path(value)}; only NumPy "
                    "scalar types and Python's number and string types can be saved as values."
                )
            return {"kind": "type", "name": name}
        if isinstance(value, np.ufunc):
            name = _NAME_OF_UFUNC.get(id(value))
            if name is None:  # pragma: no cover - a ufunc not exposed by numpy
                raise TypeError(f"Cannot save {where}: the ufunc {value!r} is not numpy's own.")
            return {"kind": "ufunc", "name": name}
        if callable(value) and not isinstance(value, BaseEstimator):
            raise TypeError(
                f"Cannot save {where}: it is a function or callable ({value!r}). A model file "
                "holds no code; only NumPy ufuncs such as numpy.log can be saved by name."
            )
        if id(value) in self._open:
            raise TypeError(f"Cannot save {where}: it contains itself (a reference cycle).")
        self._open.add(id(value))
        try:
            return self._container(value, kind, where)
        finally:
            self._open.discard(id(value))

    def _container(self, value, kind, where):
        if kind is np.ndarray:
            return self._array(value, where)
        if kind is list:
            return [self.encode(v, f"{where}[{i}]") for i, v in enumerate(value)]
        if kind in (tuple, set, frozenset):
            items = value if kind is tuple else sorted(value, key=repr)
            return {
                "kind": kind.__name__,
                "items": [self.encode(v, f"{where}[{i}]") for i, v in enumerate(items)],
            }
        if kind is dict:
            return {"kind": "dict", "items": self._items(value, where)}
        if kind is complex:
            return {
                "kind": "complex",
                "real": self.encode(value.real, where),
                "imag": self.encode(value.imag, where),
            }
        if kind is np.random.Generator:
            bit_generator = value.bit_generator
            name = type(bit_generator).__name__
            if _BIT_GENERATORS.get(name) is not type(bit_generator):
                raise TypeError(f"Cannot save {where}: unknown bit generator {name}.")
            state = self.encode(bit_generator.state, f"{where}.state")
            return {"kind": "generator", "bit_generator": name, "state": state}
        if kind is np.random.RandomState:
            state = value.get_state(legacy=False)
            return {"kind": "random_state", "state": self.encode(state, f"{where}.state")}
        return self._object(value, where)

    def _items(self, mapping, where):
        return [
            [self.encode(k, f"{where} key {k!r}"), self.encode(v, f"{where}[{k!r}]")]
            for k, v in mapping.items()
        ]

    def _scalar(self, value, where):
        dtype = value.dtype
        node = {"kind": "scalar", "dtype": dtype.str}
        if dtype.kind in "biu":
            node["value"] = int(value)
        elif dtype.kind == "f" and dtype.itemsize <= 8:
            node["value"] = self.encode(float(value), where)
        elif dtype.kind == "U":
            node["value"] = str(value)
        elif dtype.hasobject or not _DTYPE_TEXT.fullmatch(dtype.str):
            raise TypeError(f"Cannot save {where}: NumPy scalar of dtype {dtype} is not supported.")
        else:
            node["file"] = self._npy(np.asarray(value))
        return node

    def _array(self, array, where):
        if array.dtype.hasobject:
            if array.dtype != object:
                raise TypeError(f"Cannot save {where}: structured arrays with objects.")
            flat = array.ravel(order="C")
            return {
                "kind": "object_array",
                "shape": list(array.shape),
                "items": [self.encode(v, f"{where}[{i}]") for i, v in enumerate(flat)],
            }
        return {"kind": "ndarray", "file": self._npy(array)}

    def _object(self, value, where):
        cls = type(value)
        if isinstance(value, BaseSearchCV):
            raise TypeError(
                f"Cannot save {where}: it is a {cls.__name__}, which holds scorers and "
                "cross-validation tables. Save its best_estimator_ (refit=True) instead."
            )
        name = _NAME_OF_CLASS.get(cls)
        if name is None:
            if not isinstance(value, BaseEstimator):
                raise TypeError(
                    f"Cannot save {where}: objects of type {_class_path(cls)} are not supported "
                    "(greyml saves estimators, arrays, numbers, strings and containers)."
                )
            _check_plain_state(cls, where)
            name = _class_path(cls)
        self.classes.add(name)
        node = {"kind": "object", "class": name}
        if isinstance(value, dict):
            node["items"] = self._items(value, where)
        state = getattr(value, "__dict__", None)
        if state is None:
            raise TypeError(f"Cannot save {where}: {name} objects have no attribute dictionary.")
        for key in state:
            if type(key) is not str:
                raise TypeError(f"Cannot save {where}: attribute name {key!r} is not a string.")
        node["state"] = {k: self.encode(v, f"{where}.{k}") for k, v in state.items()}
        return node


def _describe_estimator(estimator):
    names = getattr(estimator, "feature_names_in_", None)
    n_features = getattr(estimator, "n_features_in_", None)
    steps = getattr(estimator, "steps", None) if isinstance(estimator, Pipeline) else None
    return {
        "class": _NAME_OF_CLASS.get(type(estimator), _class_path(type(estimator))),
        "n_features_in": int(n_features) if n_features is not None else None,
        "feature_names_in": None if names is None else [str(n) for n in names],
        "steps": None
        if steps is None
        else [
            [str(step), _NAME_OF_CLASS.get(type(est), _class_path(type(est)))]
            for step, est in steps
        ],
    }


def save_model(estimator, path, *, overwrite=False) -> Path:
    """Write a fitted estimator to a greyml model file.

    The file is a zip archive with a JSON description of the estimator and its
    arrays as ``.npy`` entries; it holds no code (see :mod:`greyml.persist`).
    It is written to a temporary file next to ``path`` and moved into place,
    so an interrupted save never leaves half a model under ``path``.

    Parameters
    ----------
    estimator : estimator
        A fitted greyml estimator, or a scikit-learn ``Pipeline`` (or other
        supported scikit-learn estimator) built from greyml estimators and the
        scikit-learn classes in ``ALLOWED_CLASSES``. From a ``GridSearchCV``,
        save ``best_estimator_``. Other scikit-learn estimators whose state is
        plain attributes can be saved too, but loading them needs ``trusted=``.
    path : str or path-like
        Where to write. The folder must exist. The suffix is up to you
        (``.greyml`` is a good choice).
    overwrite : bool, default=False
        Replace ``path`` if it exists. By default an existing file is left
        alone and :class:`FileExistsError` is raised.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    sklearn.exceptions.NotFittedError
        If the estimator has not been fitted.
    FileExistsError
        If ``path`` exists and ``overwrite`` is false.
    TypeError
        If the estimator holds something the format cannot store (a function
        other than a NumPy ufunc, an object that is not an estimator, ...); the
        message names the attribute.

    See Also
    --------
    load_model : Read the file back.
    describe_model : What a file holds, without loading it.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from greyml import GMC
    >>> from greyml.grey import simulate_gmc
    >>> from greyml.persist import load_model, save_model
    >>> X = 1 + np.random.default_rng(0).random((60, 2))
    >>> y = simulate_gmc(X, development=0.4, driving=[0.5, -0.2], control=0.1)
    >>> model = GMC().fit(X, y)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = save_model(model, Path(folder) / "gmc.greyml")
    ...     again = load_model(path)
    >>> bool(np.array_equal(again.predict(X), model.predict(X)))
    True
    """
    path = Path(path)
    if not isinstance(estimator, BaseEstimator):
        raise TypeError(
            f"save_model saves a fitted scikit-learn or greyml estimator; got an object "
            f"of type {type(estimator).__name__}."
        )
    check_is_fitted(estimator)
    if path.is_dir():
        raise IsADirectoryError(f"Cannot save the model to {path}: it is a folder.")
    if path.exists() and not overwrite:
        raise FileExistsError(
            f"{path} already exists; pass overwrite=True to replace it "
            "(or choose another file name)."
        )
    folder = path.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"Cannot save the model to {path}: folder {folder} does not exist.")

    writer = _Writer()
    tree = writer.encode(estimator, type(estimator).__name__)
    header = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "greyml_version": _greyml_version(),
        "sklearn_version": sklearn.__version__,
        "numpy_version": np.__version__,
        "python_version": platform.python_version(),
        "saved_at": _datetime.datetime.now(_datetime.timezone.utc).isoformat(timespec="seconds"),
        **_describe_estimator(estimator),
        "classes": sorted(writer.classes),
        "tree": tree,
    }
    payload = json.dumps(header, allow_nan=False, indent=1).encode("utf-8")

    # a new file in the same folder (permissions from the umask), then moved
    tmp = folder / f".{path.name}.{secrets.token_hex(6)}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with (
            os.fdopen(fd, "wb") as handle,
            zipfile.ZipFile(handle, "w", compression=zipfile.ZIP_DEFLATED) as archive,
        ):
            archive.writestr(_MODEL_MEMBER, payload)
            for name, data in writer.arrays:
                archive.writestr(name, data)
        if overwrite:
            os.replace(tmp, path)
        else:
            _move_without_replacing(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _move_without_replacing(tmp, path):
    try:
        os.link(tmp, path)  # fails if path appeared meanwhile
    except FileExistsError:
        raise FileExistsError(
            f"{path} already exists; pass overwrite=True to replace it."
        ) from None
    except OSError:  # a file system without hard links
        if path.exists():
            raise FileExistsError(
                f"{path} already exists; pass overwrite=True to replace it."
            ) from None
        os.replace(tmp, path)


def _greyml_version():
    from greyml import __version__

    return __version__


# -- reading ----------------------------------------------------------------


def _reject_constant(text):
    raise _Corrupt(f"the JSON holds the non-standard number {text}")


def _finite_float(text):
    value = float(text)
    if not math.isfinite(value):  # 1e999: too large for a float
        raise _Corrupt(f"the JSON holds the number {text[:40]}, which overflows a float")
    return value


def _bounded_int(text):
    if len(text.lstrip("-")) > _MAX_INT_DIGITS:
        raise _Corrupt(
            f"the JSON holds a whole number of {len(text.lstrip('-'))} digits; greyml writes "
            f"at most {_MAX_INT_DIGITS}"
        )
    return int(text)


def _unique_keys(pairs):
    keys = [k for k, _ in pairs]
    if len(set(keys)) != len(keys):
        raise _Corrupt("a JSON object repeats a key")
    return dict(pairs)


def _fill(stream, view, name):
    """Fill ``view`` from ``stream`` a chunk at a time; never read past its end."""
    done, size = 0, len(view)
    while done < size:
        chunk = stream.read(min(size - done, _READ_CHUNK))
        if not chunk:
            raise _Corrupt(f"{name} is shorter than its declared size (the file is truncated)")
        view[done : done + len(chunk)] = chunk
        done += len(chunk)


def _too_big(what, size, max_bytes):
    return _Corrupt(
        f"{what} {size:,} bytes, over the limit max_bytes={max_bytes:,} (if you trust the "
        "file's source, pass a larger max_bytes= to load_model)"
    )


def _read_header(archive, max_bytes, index_cost=0):
    try:
        info = archive.getinfo(_MODEL_MEMBER)
    except KeyError:
        raise _Corrupt(f"not a greyml model file (no {_MODEL_MEMBER} inside)") from None
    # greyml writes model.json and arrays/<n>.npy, each once: anything else was added
    infos = archive.infolist()
    names = [i.filename for i in infos]
    if len(set(names)) != len(names):
        raise _Corrupt("the archive holds two members of the same name; the file has been altered")
    unexpected = [n for n in names if n != _MODEL_MEMBER and not _ARRAY_MEMBER.fullmatch(n)]
    if unexpected:
        raise _Corrupt(
            f"the archive holds the unexpected member {unexpected[0]!r}; the file has been altered"
        )
    for member in infos:
        if member.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise _Corrupt(
                f"{member.filename} is compressed with zip method {member.compress_type}; "
                "greyml writes deflate only"
            )
        if member.flag_bits & 0x1:
            raise _Corrupt(f"{member.filename} is encrypted; greyml never encrypts")
    # what the archive says it holds, added up before anything is inflated
    json_cost = index_cost + _JSON_COST * info.file_size  # with zipfile's index
    declared = json_cost + sum(i.file_size for i in infos if i is not info)
    if declared > max_bytes:
        raise _too_big(
            f"its members declare (counting {_MODEL_MEMBER} {_JSON_COST} times, and the "
            "zip's index)",
            declared,
            max_bytes,
        )
    text = bytearray(info.file_size)
    with archive.open(info) as stream:
        _fill(stream, memoryview(text), _MODEL_MEMBER)
    try:
        header = json.loads(
            text.decode("utf-8"),
            parse_constant=_reject_constant,
            parse_float=_finite_float,
            parse_int=_bounded_int,
            object_pairs_hook=_unique_keys,
        )
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _Corrupt(f"{_MODEL_MEMBER} is not valid JSON ({exc})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
        raise _Corrupt("not a greyml model file (wrong format name)")
    version = header.get("format_version")
    if type(version) is not int or version < 1:
        raise _Corrupt(f"invalid format version {version!r}")
    if version > FORMAT_VERSION:
        raise _Corrupt(
            f"written in model format {version} by a newer greyml "
            f"({header.get('greyml_version')}); this greyml reads format "
            f"{FORMAT_VERSION}. Upgrade greyml to load it"
        )
    if "tree" not in header:
        raise _Corrupt("the model tree is missing")
    return header, json_cost


def _nominal_size(shape, itemsize):
    """What an array counts toward ``max_bytes``: each empty axis as one entry,
    each entry as at least one byte (an array of 10**15 zero-width strings, or
    of shape (10**18, 0), costs nothing to hold but everything to go through)."""
    return math.prod(max(n, 1) for n in shape) * max(itemsize, 1)


def _object_shape(node):
    shape = node.get("shape")
    if (
        type(shape) is not list
        or len(shape) > 32
        or not all(type(n) is int and n >= 0 for n in shape)
    ):
        raise _Corrupt(f"invalid array shape {shape!r}")
    return shape


def _referenced_names(tree):
    """Every class, type, function and bit generator the tree names, by kind;
    also how often each array member is referred to (``"file"``) and what the
    object arrays count toward ``max_bytes`` (``"object_bytes"``)."""
    found = {"class": set(), "type": set(), "ufunc": set(), "bit_generator": set()}
    files: dict[str, int] = {}
    object_bytes = 0
    stack = [iter([tree])]  # iterators, not nodes: memory grows with depth only
    while stack:
        node = next(stack[-1], _ABSENT)
        if node is _ABSENT:
            stack.pop()
            continue
        if len(stack) > _MAX_DEPTH + 1:
            raise _Corrupt(f"the model tree is nested more than {_MAX_DEPTH} levels deep")
        if isinstance(node, list):
            stack.append(iter(node))
        elif isinstance(node, dict):
            kind = node.get("kind")
            if kind == "object":
                found["class"].add(str(node.get("class")))
            elif kind in ("type", "ufunc"):
                found[kind].add(str(node.get("name")))
            elif kind == "generator":
                found["bit_generator"].add(str(node.get("bit_generator")))
            # (what is malformed here is refused when the tree is built)
            if kind == "scalar" and node.get("dtype") in ("|O", "O"):
                raise _Corrupt("object scalars are not allowed")
            name = node.get("file")
            if (
                kind in ("ndarray", "scalar")
                and type(name) is str
                and _ARRAY_MEMBER.fullmatch(name)
            ):
                files[name] = files.get(name, 0) + 1
            elif kind == "object_array":
                with contextlib.suppress(_Corrupt):
                    object_bytes += _nominal_size(_object_shape(node), _OBJECT_ENTRY_BYTES)
            stack.append(iter(node.values()))
    found["file"] = files
    found["object_bytes"] = object_bytes
    return found


def _npy_header(stream, name):
    """(shape, fortran_order, dtype, header length) of an ``.npy`` member."""
    try:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            read = np.lib.format.read_array_header_1_0
        elif version == (2, 0):
            read = np.lib.format.read_array_header_2_0
        else:
            raise ValueError(f".npy format version {version} is not one greyml writes")
        shape, fortran_order, dtype = read(stream, max_header_size=_MAX_NPY_HEADER)
    except (ValueError, SyntaxError, TypeError) as exc:
        raise _Corrupt(f"the array {name} cannot be read ({exc})") from None
    if dtype.hasobject:
        raise _Corrupt(
            f"the array {name} cannot be read (it holds Python objects, which only "
            "pickle could build)"
        )
    if dtype.fields is not None or dtype.subdtype is not None or dtype.kind not in "biufcUSmM":
        raise _Corrupt(f"the array {name} has the dtype {dtype}, which greyml does not write")
    if len(shape) > 32:
        raise _Corrupt(f"the array {name} has {len(shape)} dimensions")
    return shape, fortran_order, dtype, stream.tell()


def _plan_arrays(archive, files, budget, max_bytes):
    """Read each referenced array member's header (not its data) and add up what
    the load will build: every reference a copy of its own. Returns
    ``{name: (info, header)}``."""
    plan = {}
    total = budget
    for name, count in sorted(files.items()):
        try:
            info = archive.getinfo(name)
        except KeyError:
            raise _Corrupt(f"the array {name} is missing") from None
        with archive.open(info) as stream:
            header = _npy_header(stream, name)
        shape, _, dtype, start = header
        if start + math.prod(shape) * dtype.itemsize != info.file_size:
            raise _Corrupt(
                f"the array {name} of shape {tuple(shape)} and dtype {dtype} does not fill "
                f"its member of {info.file_size} bytes"
            )
        total += count * max(info.file_size, start + _nominal_size(shape, dtype.itemsize))
        plan[name] = (info, header)
    if total > max_bytes:
        raise _too_big(
            f"loading it would build (counting {_MODEL_MEMBER} {_JSON_COST} times, the zip's "
            "index, and every reference to an array as a copy of its own)",
            total,
            max_bytes,
        )
    return plan


def _read_npy(archive, info, header):
    """An array member's data, read into an array of the planned shape."""
    shape, fortran_order, dtype, _ = header
    with archive.open(info) as stream:
        if _npy_header(stream, info.filename) != header:  # pragma: no cover - same bytes
            raise _Corrupt(f"the array {info.filename} changed while it was read")
        array = np.empty(shape[::-1] if fortran_order else shape, dtype=dtype)
        if array.nbytes:
            _fill(stream, memoryview(array.reshape(-1).view(np.uint8)), info.filename)
    return array.T if fortran_order else array


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


def _shadows_behaviour(cls, key):
    """True if the class or one of its bases has something named ``key`` (a
    method, property or class attribute), which an instance attribute would hide."""
    return inspect.getattr_static(cls, key, _ABSENT) is not _ABSENT


def _parameter_names(cls):
    """The names ``cls.__init__`` takes: the only attributes a function may be."""
    if hasattr(cls, "_get_param_names"):
        try:
            return set(cls._get_param_names())
        except RuntimeError:  # pragma: no cover - an *args estimator (none is allowed)
            return set()
    return set()


def _dtype(text):
    if type(text) is not str or not _DTYPE_TEXT.fullmatch(text):
        raise _Corrupt(f"invalid dtype {text!r}")
    try:
        return np.dtype(text)
    except TypeError:
        raise _Corrupt(f"invalid dtype {text!r}") from None


class _Reader:
    """Builds objects from the checked tree."""

    def __init__(self, archive, classes, plan):
        self.archive = archive
        self.classes = classes
        self._plan = plan  # {member: (info, npy header)}, from _plan_arrays
        self._read: dict[str, np.ndarray] = {}

    def _npy(self, name):
        # each member is inflated once; a second reference gets a copy (counted
        # in the plan), as greyml writes every array to a member of its own
        if name in self._read:
            return self._read[name].copy(order="K")
        if name not in self._plan:
            raise _Corrupt(f"invalid array reference {name!r}")
        array = _read_npy(self.archive, *self._plan[name])
        self._read[name] = array
        return array

    def decode(self, node, depth=0):
        if depth > _MAX_DEPTH:
            raise _Corrupt(f"the model tree is nested more than {_MAX_DEPTH} levels deep")
        kind = type(node)
        if node is None or kind in (bool, int, float, str):
            return node
        if kind is list:
            return [self.decode(v, depth + 1) for v in node]
        if kind is not dict:
            raise _Corrupt(f"unexpected JSON value {node!r}")
        tag = node.get("kind")
        method = getattr(self, f"_decode_{tag}", None) if type(tag) is str else None
        if method is None:
            raise _Corrupt(f"unknown node kind {tag!r}")
        return method(node, depth + 1)

    def _list(self, node, key, depth):
        items = node.get(key)
        if type(items) is not list:
            raise _Corrupt(f"a {node.get('kind')} node has no {key} list")
        return [self.decode(v, depth) for v in items]

    def _decode_float(self, node, depth):
        if node.get("value") not in ("nan", "inf", "-inf"):
            raise _Corrupt(f"invalid float {node.get('value')!r}")
        return float(node["value"])

    def _decode_complex(self, node, depth):
        return complex(self.decode(node.get("real"), depth), self.decode(node.get("imag"), depth))

    def _decode_tuple(self, node, depth):
        return tuple(self._list(node, "items", depth))

    def _decode_set(self, node, depth):
        return set(self._list(node, "items", depth))

    def _decode_frozenset(self, node, depth):
        return frozenset(self._list(node, "items", depth))

    def _pairs(self, node, depth):
        pairs = self._list(node, "items", depth)
        if not all(type(p) is list and len(p) == 2 for p in pairs):
            raise _Corrupt("a dict node's items are not key-value pairs")
        return [tuple(p) for p in pairs]

    def _decode_dict(self, node, depth):
        return dict(self._pairs(node, depth))

    def _decode_ndarray(self, node, depth):
        return self._npy(node.get("file"))

    def _decode_object_array(self, node, depth):
        shape = _object_shape(node)
        items = self._list(node, "items", depth)
        if len(items) != math.prod(shape):
            raise _Corrupt(f"an object array of shape {tuple(shape)} has {len(items)} items")
        out = np.empty(len(items), dtype=object)
        for i, item in enumerate(items):
            out[i] = item
        return out.reshape(shape)

    def _decode_scalar(self, node, depth):
        dtype = _dtype(node.get("dtype"))
        if dtype.hasobject:
            raise _Corrupt("object scalars are not allowed")
        if "file" in node:
            array = self._npy(node["file"])
            if array.shape != () or array.dtype != dtype:
                raise _Corrupt("a scalar's array does not match its dtype")
            return array[()]
        value = self.decode(node.get("value"), depth)
        allowed = {"b": (int,), "i": (int,), "u": (int,), "f": (float, int), "U": (str,)}
        if type(value) not in allowed.get(dtype.kind, ()):
            raise _Corrupt(f"invalid value {value!r} for a NumPy {dtype} scalar")
        if dtype.kind in "iu" and not np.iinfo(dtype).min <= value <= np.iinfo(dtype).max:
            raise _Corrupt(f"the value {value} overflows a NumPy {dtype} scalar")
        with np.errstate(over="ignore"):
            scalar = dtype.type(value)
        if dtype.kind == "f" and math.isfinite(value) and not np.isfinite(scalar):
            raise _Corrupt(f"the value {value!r} overflows a NumPy {dtype} scalar")
        return scalar

    def _decode_dtype(self, node, depth):
        return _dtype(node.get("value"))

    def _decode_type(self, node, depth):
        return _TYPES[node["name"]]

    def _decode_ufunc(self, node, depth):
        return _UFUNCS[node["name"]]

    def _decode_generator(self, node, depth):
        bit_generator = _BIT_GENERATORS[node["bit_generator"]]()
        bit_generator.state = self.decode(node.get("state"), depth)
        return np.random.Generator(bit_generator)

    def _decode_random_state(self, node, depth):
        random_state = np.random.RandomState()
        random_state.set_state(self.decode(node.get("state"), depth))
        return random_state

    def _decode_object(self, node, depth):
        name = node.get("class")
        cls = self.classes.get(name)
        if cls is None:  # the scan before building should have caught it
            raise UnsafeModelError(f"the class {name!r} is not allowed")
        state = node.get("state")
        if type(state) is not dict:
            raise _Corrupt(f"the {name} object has no attribute table")
        for key in state:
            if not key.isidentifier() or key.startswith("__") or _shadows_behaviour(cls, key):
                raise _Corrupt(f"the {name} object sets the forbidden attribute {key!r}")
        if "items" in node and not issubclass(cls, dict):
            raise _Corrupt(f"the {name} object has dict items but is not a dict")
        attributes = {k: self.decode(v, depth) for k, v in state.items()}
        parameters = _parameter_names(cls)
        for key, value in attributes.items():
            # only data: a function (a ufunc, a type) only as a constructor parameter
            if callable(value) and key not in parameters:
                raise _Corrupt(
                    f"the {name} object sets the attribute {key!r} to a function "
                    f"({_describe_callable(value)}); only data may come from a file"
                )
        if "n_jobs" in attributes:  # processes are the caller's choice, not the file's
            attributes["n_jobs"] = None
        obj = cls.__new__(cls)
        if "items" in node:
            dict.update(obj, self._pairs(node, depth))
        obj.__dict__.update(attributes)
        if cls in _NAME_OF_CLASS:
            _check_shapes(attributes, name)
        if name.startswith("greyml."):
            _check_greyml_params(obj, name)
        return obj


def _describe_callable(value):
    if isinstance(value, np.ufunc):
        return _NAME_OF_UFUNC.get(id(value), repr(value))
    if isinstance(value, type):
        return _NAME_OF_TYPE.get(value, value.__name__)
    return f"a callable {type(value).__name__}"


# The shapes an allowlisted estimator's arrays must have, by attribute name:
# "n" is its n_features_in_, "n+1" one more, "*" any length. A file whose
# shapes disagree was altered (a feature_names_in_ of 10**15 names for a model of
# 4 inputs would make predict hang), and is refused at load.
_FEATURE_SHAPES = {
    # scikit-learn
    "feature_names_in_": [("n",)],
    "coef_": [("n",), ("*", "n")],
    "mean_": [("n",)],
    "var_": [("n",)],
    "scale_": [("n",)],
    "center_": [("n",)],
    "min_": [("n",)],
    "data_min_": [("n",)],
    "data_max_": [("n",)],
    "data_range_": [("n",)],
    "max_abs_": [("n",)],
    "n_samples_seen_": [("n",)],
    # greyml
    "driving_coef_": [("n",)],
    "x_mean_": [("n",)],
    "x_scale_": [("n",)],
    "influence_": [("n",)],
    "clusters_": [("n",)],
    "support_": [("n",)],
    "membership_": [("*", "n")],
    "cluster_centres_": [("*", "n")],
    "_mf_of_rule": [("*", "n")],
    "_consequents": [("*", "n+1")],
    "coefs_[0]": [("n", "*")],
}


def _check_shapes(attributes, name):
    """Every array of an allowlisted estimator has the shape its inputs imply."""
    n = attributes.get("n_features_in_", _ABSENT)
    if n is not _ABSENT:
        if not isinstance(n, int | np.integer) or isinstance(n, bool) or n < 1:
            raise _Corrupt(f"the {name} object's n_features_in_ is {n!r}, not a count of inputs")
        n = int(n)
    names = attributes.get("feature_names_in_", _ABSENT)
    if names is not _ABSENT:
        if not (
            isinstance(names, np.ndarray)
            and names.dtype == object
            and names.ndim == 1
            and all(type(v) is str for v in names)
        ):
            raise _Corrupt(
                f"the {name} object's feature_names_in_ is not a one-dimensional array "
                "of column names"
            )
        if n is _ABSENT:  # n_features_in_ is a property (TransformedTargetRegressor)
            n = len(names)
    if n is _ABSENT:
        return
    sizes = {"n": n, "n+1": n + 1}
    for key, shapes in _FEATURE_SHAPES.items():
        attribute, _, index = key.partition("[")
        value = attributes.get(attribute)
        if index and isinstance(value, list | tuple) and value:
            value = value[0]
        if not isinstance(value, np.ndarray) or (key == "n_samples_seen_" and value.ndim == 0):
            continue
        if not any(
            len(value.shape) == len(shape)
            and all(want == "*" or got == sizes[want] for got, want in zip(value.shape, shape))
            for shape in shapes
        ):
            wanted = " or ".join(
                "(" + ", ".join(str(sizes.get(w, "any")) for w in shape) + ")" for shape in shapes
            )
            raise _Corrupt(
                f"the {name} object's {key} has shape {value.shape}, but its "
                f"n_features_in_ = {n} implies {wanted}"
            )


def _check_greyml_params(estimator, name):
    """A greyml estimator's parameters must pass the checks its ``fit`` runs.

    A model fitted with its parameters passes them, so a failure means the file
    was altered (e.g. ``initial`` or ``response`` of a GMC, which ``predict``
    uses too). The checks are the class's own methods, never an attribute.
    """
    for check in ("_check_params", "_check_common_params"):
        method = inspect.getattr_static(type(estimator), check, None)
        if not inspect.isfunction(method):
            continue
        try:
            method(estimator)
        except (ValueError, TypeError, AttributeError) as exc:  # AttributeError: one is missing
            raise _Corrupt(
                f"the {name} object has an invalid parameter: {str(exc).rstrip('.')}"
            ) from None


@contextlib.contextmanager
def _open_archive(path, max_bytes):
    """The zip archive at ``path``, and what zipfile's index of it takes. ``path``
    must be a regular file of at most ``max_bytes`` (a FIFO or a device such as
    /dev/zero is refused, never read), whose index fits in ``max_bytes`` too."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)  # non-blocking: opening a FIFO does not wait
    except FileNotFoundError:
        raise FileNotFoundError(f"No model file at {path}.") from None
    except IsADirectoryError:  # pragma: no cover - Windows; POSIX opens folders
        raise IsADirectoryError(f"{path} is a folder, not a model file.") from None
    with os.fdopen(fd, "rb") as handle:
        mode = os.fstat(fd)
        if stat.S_ISDIR(mode.st_mode):
            raise IsADirectoryError(f"{path} is a folder, not a model file.")
        if not stat.S_ISREG(mode.st_mode):
            raise ValueError(
                f"Cannot load {path}: it is not a regular file (a device, pipe or socket); "
                "give the path of a model file."
            )
        if mode.st_size > max_bytes:
            raise ValueError(
                f"Cannot load {path}: {_too_big('the file holds', mode.st_size, max_bytes)}."
            )
        index = _zip_index_cost(handle, mode.st_size)
        if index > max_bytes:
            too_big = _too_big("the index of its members would take", index, max_bytes)
            raise ValueError(f"Cannot load {path}: {too_big}.")
        try:
            archive = zipfile.ZipFile(handle)
        except (zipfile.BadZipFile, EOFError, ValueError):
            raise ValueError(
                f"Cannot load {path}: not a greyml model file (not a zip archive; the file "
                "may be truncated or in another format)."
            ) from None
        with archive:
            yield archive, index


def _zip_index_cost(handle, size):
    """What zipfile's index of the archive's members will take (0 if the file
    has no zip end record: zipfile then says it is not a zip). zipfile builds
    one entry (~560 bytes) for every record in the central directory, whose
    size the end record gives; a record takes at least 46 bytes."""
    tail_size = min(size, 22 + 65535 + 20 + 56)  # end record, comment, ZIP64 records
    handle.seek(size - tail_size)
    tail = handle.read(tail_size)
    handle.seek(0)
    at = tail.rfind(b"PK\x05\x06")
    if at < 0 or len(tail) - at < 22:
        return 0
    directory = int.from_bytes(tail[at + 12 : at + 16], "little")
    locator = at - 20  # a ZIP64 file gives the size in its own end record
    if locator >= 56 and tail[locator : locator + 4] == b"PK\x06\x07":
        record = tail[locator - 56 : locator]
        if record[:4] == b"PK\x06\x06":
            directory = int.from_bytes(record[40:48], "little")
    return directory // 46 * _ENTRY_COST


def _check_max_bytes(max_bytes):
    if isinstance(max_bytes, bool) or not isinstance(max_bytes, int | np.integer):
        raise TypeError(
            f"max_bytes must be a whole number of bytes; got {type(max_bytes).__name__}."
        )
    if max_bytes < 1:
        raise ValueError(f"max_bytes must be positive; got {max_bytes}.")
    return int(max_bytes)


def _failure(path, exc):
    if isinstance(exc, _Corrupt):
        return ValueError(f"Cannot load {path}: {exc}.")
    return ValueError(
        f"Cannot load {path}: the file is damaged or was not written by greyml "
        f"({type(exc).__name__}: {exc})."
    )


def load_model(path, *, trusted=None, max_bytes=DEFAULT_MAX_BYTES):
    """Read an estimator written by :func:`save_model`.

    Nothing in the file is executed: no unpickling, no imports, no ``eval``.
    Before building anything, every class the file names is checked against
    greyml's allowlist (``ALLOWED_CLASSES``, plus NumPy's scalar types, dtypes,
    random generators and ufuncs); objects are then created without calling
    their ``__init__`` and given the saved attributes, which must be data
    (see :mod:`greyml.persist` for exactly what is guaranteed). Every loaded
    object's ``n_jobs`` is set to ``None``: how many processes a model uses is
    for the caller to decide (``model.set_params(n_jobs=4)`` after loading),
    never the file's.

    Parameters
    ----------
    path : str or path-like
        A file written by :func:`save_model`.
    trusted : list of str, optional
        Further classes you allow this file to create, as ``"module.Class"``
        (e.g. ``"sklearn.linear_model.HuberRegressor"``, or the defining
        module's path as :func:`describe_model` lists it under
        ``"untrusted_types"``). Their modules are imported. Only classes can be
        trusted; functions named by a file are never called. (There is no
        ``trusted=True``: trust is given class by class, and trusting a class
        lifts none of the other rules, ``n_jobs`` included.)
    max_bytes : int, default=DEFAULT_MAX_BYTES (256 MiB)
        The most the file may make the load build, in bytes: the file
        itself, the sizes its members declare (``model.json`` counted 128
        times, for the Python objects its JSON becomes), and every array,
        each reference to one counted as a copy of its own and each empty
        axis as one entry. All are added up before any array is read, and a
        file over the limit is refused with one line. greyml's own models
        take kilobytes to a few megabytes; raise it only for a file you trust.

    Returns
    -------
    estimator
        The fitted estimator, predicting exactly as it did when saved.

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    UnsafeModelError
        If the file names a class, type or function outside the allowlist
        and ``trusted``; nothing has been built.
    ValueError
        If the file is not a regular file, is not a greyml model, is truncated
        or damaged, was written by a newer format version, holds archive
        members greyml does not write, would take more than ``max_bytes``,
        holds an array whose shape disagrees with its estimator's
        ``n_features_in_``, a number that overflows, an attribute that is a
        function or is named like a method, property or attribute of its
        class, or gives a greyml estimator parameters its ``fit`` would
        reject. The message is one line naming the file.

    Warns
    -----
    UserWarning
        If the file was written with another version of greyml or
        scikit-learn: the model loads, but refit it if its predictions matter.

    See Also
    --------
    save_model : Write a fitted estimator to a model file.
    describe_model : What a file holds, without loading it.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from sklearn.linear_model import RidgeCV
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn.preprocessing import StandardScaler
    >>> from greyml.persist import load_model, save_model
    >>> rng = np.random.default_rng(0)
    >>> X, y = rng.random((30, 3)), rng.random(30)
    >>> model = make_pipeline(StandardScaler(), RidgeCV()).fit(X, y)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = save_model(model, Path(folder) / "ridge.greyml")
    ...     again = load_model(path)
    >>> [name for name, _ in again.steps]
    ['standardscaler', 'ridgecv']
    >>> bool(np.array_equal(again.predict(X), model.predict(X)))
    True
    """
    path = Path(path)
    trusted = _check_trusted(trusted)
    max_bytes = _check_max_bytes(max_bytes)
    with _open_archive(path, max_bytes) as (archive, index_cost):
        try:
            header, json_cost = _read_header(archive, max_bytes, index_cost)
            found = _referenced_names(header["tree"])
        except Exception as exc:  # any damage: one line naming the file
            raise _failure(path, exc) from None
        extra = _trusted_classes(trusted, found["class"] - ALLOWED_CLASSES.keys())
        classes, others = _untrusted(found, extra)
        if classes or others:
            parts = []
            if classes:
                parts.append(
                    f"classes that are not on greyml's allowlist: {', '.join(classes)} (if "
                    "you trust the file's source, pass them as load_model(..., trusted=[...]))"
                )
            if others:
                parts.append(f"functions or types greyml never creates: {', '.join(others)}")
            raise UnsafeModelError(f"Refusing to load {path}: it names {'; and '.join(parts)}.")
        try:
            tree = header["tree"]
            if not (isinstance(tree, dict) and tree.get("kind") == "object"):
                raise _Corrupt("the file holds no estimator")
            if tree.get("class") != header.get("class"):
                raise _Corrupt(
                    f"the header names {header.get('class')!r} but the tree holds "
                    f"{tree.get('class')!r}; the file has been altered"
                )
            plan = _plan_arrays(
                archive, found["file"], json_cost + found["object_bytes"], max_bytes
            )
            estimator = _Reader(archive, {**ALLOWED_CLASSES, **extra}, plan).decode(tree)
        except UnsafeModelError as exc:  # pragma: no cover - the scan above catches these
            raise UnsafeModelError(f"Refusing to load {path}: {exc}.") from None
        except Exception as exc:
            raise _failure(path, exc) from None
    if not hasattr(estimator, "get_params"):
        raise ValueError(f"Cannot load {path}: the file holds no estimator.")
    for library, key, current in (
        ("greyml", "greyml_version", _greyml_version()),
        ("scikit-learn", "sklearn_version", sklearn.__version__),
    ):
        if header.get(key) != current:
            warnings.warn(
                f"{path} was saved with {library} {header.get(key)}; this is {library} "
                f"{current}. The model loads, but refit it if its predictions matter.",
                UserWarning,
                stacklevel=2,
            )
    return estimator


def describe_model(path, *, max_bytes=DEFAULT_MAX_BYTES):
    """What a model file holds, read from its JSON without building anything.

    Parameters
    ----------
    path : str or path-like
        A file written by :func:`save_model`.
    max_bytes : int, default=DEFAULT_MAX_BYTES (256 MiB)
        As :func:`load_model`: the file and what its members declare may take
        at most this many bytes.

    Returns
    -------
    dict
        ``"class"`` (e.g. ``"greyml.GMC"``), ``"format_version"``,
        ``"greyml_version"``, ``"sklearn_version"``, ``"numpy_version"``,
        ``"python_version"``, ``"saved_at"`` (UTC, ISO 8601),
        ``"n_features_in"``, ``"feature_names_in"`` (list or ``None``),
        ``"steps"`` (``[name, class]`` pairs of a Pipeline, else ``None``),
        ``"classes"`` (every class the file would create) and
        ``"untrusted_types"`` (those :func:`load_model` would refuse without
        ``trusted=``).

    Raises
    ------
    FileNotFoundError, ValueError
        As :func:`load_model`.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> import pandas as pd
    >>> from greyml import AGO
    >>> from greyml.persist import describe_model, save_model
    >>> X = pd.DataFrame({"T1_C": [20.0, 20.5, 21.0], "T2_C": [19.0, 19.2, 19.1]})
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     info = describe_model(save_model(AGO().fit(X), Path(folder) / "ago.greyml"))
    >>> info["class"], info["feature_names_in"], info["untrusted_types"]
    ('greyml.AGO', ['T1_C', 'T2_C'], [])
    """
    path = Path(path)
    max_bytes = _check_max_bytes(max_bytes)
    with _open_archive(path, max_bytes) as (archive, index_cost):
        try:
            header, _ = _read_header(archive, max_bytes, index_cost)
            found = _referenced_names(header["tree"])
        except Exception as exc:
            raise _failure(path, exc) from None
    info = {k: v for k, v in header.items() if k not in ("tree", "format")}
    info["classes"] = sorted(found["class"])
    info["untrusted_types"] = sorted(sum(_untrusted(found, {}), []))
    return info
