"""Reading a model file: :func:`load_model` and :func:`describe_model` build the
estimator from the checked tree, or describe it."""

from __future__ import annotations

import dataclasses
import inspect
import math
import warnings
from pathlib import Path

import numpy as np
import sklearn
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import (
    MaxAbsScaler,
    MinMaxScaler,
    PolynomialFeatures,
    RobustScaler,
    StandardScaler,
)

from greyml.exceptions import UnsafeModelError
from greyml.persist._archive import (
    _check_max_bytes,
    _object_shape,
    _open_archive,
    _plan_arrays,
    _read_header,
    _read_npy,
    _referenced_names,
)
from greyml.persist._format import (
    _ABSENT,
    _BIT_GENERATORS,
    _DTYPE_TEXT,
    _MAX_DEPTH,
    _NAME_OF_CLASS,
    _NAME_OF_TYPE,
    _NAME_OF_UFUNC,
    _TYPES,
    _UFUNCS,
    ALLOWED_CLASSES,
    DEFAULT_MAX_BYTES,
    _check_trusted,
    _Corrupt,
    _greyml_version,
    _trusted_classes,
    _untrusted,
)


def _shadows_behaviour(cls, key):
    """True if the class or one of its bases has something named ``key`` (a
    method, property or class attribute), which an instance attribute would hide.

    A dataclass's field is data even when it has a default (which the class
    then holds): the instance's value is what the field is for."""
    if dataclasses.is_dataclass(cls) and key in cls.__dataclass_fields__:
        return False
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
        return set(_spread_keys(self._list(node, "items", depth), "set"))

    def _decode_frozenset(self, node, depth):
        return frozenset(_spread_keys(self._list(node, "items", depth), "frozenset"))

    def _pairs(self, node, depth):
        pairs = self._list(node, "items", depth)
        if not all(type(p) is list and len(p) == 2 for p in pairs):
            raise _Corrupt("a dict node's items are not key-value pairs")
        _spread_keys([p[0] for p in pairs], "dict")
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
        if "memory" in attributes:  # so are folders: a cache the file names is never used
            attributes["memory"] = None
        obj = cls.__new__(cls)
        if "items" in node:
            dict.update(obj, self._pairs(node, depth))
        obj.__dict__.update(attributes)
        if cls in _NAME_OF_CLASS:
            _check_shapes(attributes, name)
        if name.startswith("greyml."):
            _check_greyml_params(obj, name)
        return obj


#: Keys of one dict or set above which they must mostly hash apart (see
#: :func:`_spread_keys`); fewer cost nothing whatever their hashes.
_FEW_KEYS = 64


def _spread_keys(keys, what):
    """``keys``, refused when many share one hash value.

    Numbers and tuples hash the same in every process, so a file can hold
    thousands of dict keys with one hash (``1 + k * (2**61 - 1)``), which
    makes building the dict take time that grows with the square of their
    number (68,000 such keys took 23 s). Counting the distinct hashes costs
    one pass; a container whose keys share hashes more than twice on average
    is refused, which no model's own dicts come near.
    """
    if len(keys) <= _FEW_KEYS:
        return keys
    try:
        distinct = len({hash(k) for k in keys})
    except TypeError:
        raise _Corrupt(f"a {what} holds a key that cannot be hashed") from None
    if 2 * distinct < len(keys):
        raise _Corrupt(
            f"a {what} holds {len(keys):,} keys with only {distinct:,} distinct hash values, "
            "built to make loading slow"
        )
    return keys


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
    "cluster_centers_": [("*", "n")],
    "_mf_of_rule": [("*", "n")],
    "_consequents": [("*", "n+1")],
    "coefs_[0]": [("n", "*")],
}


#: The most inputs or outputs a loaded estimator may declare (``n_features_in_``,
#: ``n_output_features_``): what a file declares is what ``predict`` allocates for
#: every row (a PolynomialFeatures declaring 1e9 outputs made ``greyml predict`` die
#: in NumPy with a MemoryError), so it is bounded and checked against the rest.
MAX_FEATURES = 100_000

#: The sizes a file declares as whole numbers, each in [1, MAX_FEATURES].
_DECLARED_COUNTS = ("n_features_in_", "n_output_features_", "_n_out_full")


def _declared_count(attributes, key, name, low=1):
    """The whole number ``attributes[key]`` in [low, MAX_FEATURES], or _ABSENT."""
    n = attributes.get(key, _ABSENT)
    if n is _ABSENT:
        return n
    if not isinstance(n, int | np.integer) or isinstance(n, bool) or not low <= n <= MAX_FEATURES:
        raise _Corrupt(
            f"the {name} object's {key} is {n!r}, not a whole number in [{low}, {MAX_FEATURES:,}]"
        )
    return int(n)


def _check_polynomial(attributes, name, n):
    """A PolynomialFeatures declares the number of outputs its degrees and inputs give."""
    low = _declared_count(attributes, "_min_degree", name, low=0)
    high = _declared_count(attributes, "_max_degree", name, low=0)
    if n is _ABSENT or high is _ABSENT:
        return
    low = 0 if low is _ABSENT else low
    if low > high:
        raise _Corrupt(f"the {name} object's degrees run from {low} down to {high}")
    count = PolynomialFeatures._num_combinations  # scikit-learn's own count of its terms
    flags = {
        "interaction_only": bool(attributes.get("interaction_only")),
        "include_bias": bool(attributes.get("include_bias")),
    }
    for key, start in (("n_output_features_", low), ("_n_out_full", 0)):
        declared = attributes.get(key, _ABSENT)
        if declared is _ABSENT:
            continue
        implied = count(n_features=n, min_degree=start, max_degree=high, **flags)
        if declared != implied:
            raise _Corrupt(
                f"the {name} object's {key} is {declared}, but its {n} inputs and degrees "
                f"{start} to {high} give {implied}"
            )


def _width_out(step):
    """The number of columns a fitted pipeline step gives, when the file says it."""
    if isinstance(step, PolynomialFeatures):
        return getattr(step, "n_output_features_", None)
    if isinstance(step, _SAME_WIDTH):
        return getattr(step, "n_features_in_", None)
    return None


#: Transformers that give as many columns as they take.
_SAME_WIDTH = (MaxAbsScaler, MinMaxScaler, RobustScaler, StandardScaler)


def _check_pipeline(steps, name):
    """Each step of a pipeline takes as many columns as the step before it gives."""
    if not isinstance(steps, list):
        return
    estimators = [s[1] for s in steps if isinstance(s, tuple) and len(s) == 2]
    for before, after in zip(estimators, estimators[1:]):
        width = _width_out(before)
        takes = getattr(after, "n_features_in_", None) if hasattr(after, "__dict__") else None
        if isinstance(width, int) and isinstance(takes, int) and width != takes:
            raise _Corrupt(
                f"the {name} object's step {type(after).__name__} takes {takes} columns, "
                f"but the step before it ({type(before).__name__}) gives {width}"
            )


def _check_shapes(attributes, name):
    """Every size an allowlisted estimator declares is bounded and agrees with the
    others, and every array has the shape its inputs imply."""
    for key in _DECLARED_COUNTS:
        _declared_count(attributes, key, name)
    n = _declared_count(attributes, "n_features_in_", name)
    if name == _NAME_OF_CLASS[PolynomialFeatures]:
        _check_polynomial(attributes, name, n)
    if name == _NAME_OF_CLASS[Pipeline]:
        _check_pipeline(attributes.get("steps"), name)
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
    uses too). The checks are the class's own methods, never an attribute:
    ``_validate_params`` (the declared ``_parameter_constraints``; its
    ``InvalidParameterError`` is a ``ValueError``), then the checks the
    constraints cannot express, and last ``_check_fitted_state``: every fitted
    attribute in its physical domain and consistent with the others (a time
    constant > 0, a compensator's running state against its terms), and the
    cost of one ``predict`` row or ``update`` within the class's limits.
    """
    for check in (
        "_validate_params",
        "_check_params",
        "_check_common_params",
        "_check_fitted_state",
    ):
        method = inspect.getattr_static(type(estimator), check, None)
        if not inspect.isfunction(method):
            continue
        try:
            method(estimator)
        except (ValueError, TypeError, AttributeError) as exc:  # AttributeError: one is missing
            raise _Corrupt(
                f"the {name} object has an invalid parameter: {str(exc).rstrip('.')}"
            ) from None


def _failure(path, exc):
    if isinstance(exc, _Corrupt):
        return ValueError(f"Cannot load {path}: {exc}.")
    return ValueError(
        f"Cannot load {path}: the file is damaged or was not written by greyml "
        f"({type(exc).__name__}: {exc})."
    )


def _scan(path, archive, max_bytes, index_cost):
    """The file's header, what it costs, and every name its tree holds
    (:func:`_referenced_names`); any damage is one line naming the file."""
    try:
        header, json_cost = _read_header(archive, max_bytes, index_cost)
        return header, json_cost, _referenced_names(header["tree"])
    except Exception as exc:  # any damage: one line naming the file
        raise _failure(path, exc) from None


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
    never the file's, and every ``memory`` (a Pipeline's cache folder) is set
    to ``None``, so a refit never writes into a folder the file chose. A
    greyml model's fitted attributes are checked against their physical
    domain and against each other (time constants > 0, a compensator's state
    against its terms), and the work of one ``predict`` row or one ``update``
    is bounded (at most 1,000 time constants and 100,000 terms: the
    ``MAX_TIME_CONSTANTS`` and ``MAX_TERMS`` of ``greyml/dynamic``).

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
        ``n_features_in_``, declares a size (``n_features_in_``,
        ``n_output_features_``) that is not a whole number from 1 to 100,000 or
        disagrees with the others (a pipeline step taking other columns than
        the step before gives), a number that overflows, an attribute that is a
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
        header, json_cost, found = _scan(path, archive, max_bytes, index_cost)
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
        header, _, found = _scan(path, archive, max_bytes, index_cost)
    info = {k: v for k, v in header.items() if k not in ("tree", "format")}
    info["classes"] = sorted(found["class"])
    info["untrusted_types"] = sorted(sum(_untrusted(found, {}), []))
    return info
