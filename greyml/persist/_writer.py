"""Writing a model file: :func:`save_model`."""

from __future__ import annotations

import datetime as _datetime
import io
import json
import math
import platform
import zipfile
from pathlib import Path

import numpy as np
import sklearn
from sklearn.base import BaseEstimator
from sklearn.model_selection._search import BaseSearchCV
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from greyml._atomic import check_target, write_atomic
from greyml.persist._format import (
    _BIT_GENERATORS,
    _DTYPE_TEXT,
    _MODEL_MEMBER,
    _NAME_OF_CLASS,
    _NAME_OF_TYPE,
    _NAME_OF_UFUNC,
    FORMAT_NAME,
    FORMAT_VERSION,
    RUNTIME_CLASSES,
    _class_path,
    _greyml_version,
)


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
        # a cache the object rebuilds on load (a compensator's update plan) is not data
        derived = getattr(cls, "_derived_attributes", ())
        node["state"] = {
            k: self.encode(v, f"{where}.{k}") for k, v in state.items() if k not in derived
        }
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
    so an interrupted save never leaves half a model under ``path``; whatever
    stops it (an error, :class:`KeyboardInterrupt`) removes the temporary file.

    Parameters
    ----------
    estimator : estimator
        A fitted greyml estimator, or a scikit-learn ``Pipeline`` (or other
        supported scikit-learn estimator) built from greyml estimators and the
        scikit-learn classes in ``ALLOWED_CLASSES``. From a ``GridSearchCV``,
        save ``best_estimator_``. Other scikit-learn estimators whose state is
        plain attributes can be saved too, but loading them needs ``trusted=``.
        A :class:`greyml.Compensator` (a runtime object, not an estimator) is
        saved with its running state, so that a controller resumes where it
        stopped.
    path : str or path-like
        Where to write. The folder must exist. The suffix is up to you
        (``.greyml`` is a good choice).
    overwrite : bool, default=False
        Replace ``path`` if it is a regular file. By default an existing file
        is left alone and :class:`FileExistsError` is raised. A symbolic link,
        named pipe or device is never replaced (:class:`ValueError`).

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
    >>> from greyml.grey._functions import simulate_gmc
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
    runtime = isinstance(estimator, RUNTIME_CLASSES)
    if not (isinstance(estimator, BaseEstimator) or runtime):
        raise TypeError(
            f"save_model saves a fitted scikit-learn or greyml estimator, or a "
            f"Compensator; got an object of type {type(estimator).__name__}."
        )
    if not runtime:
        check_is_fitted(estimator)
    if path.is_dir():
        raise IsADirectoryError(f"Cannot save the model to {path}: it is a folder.")
    exists = FileExistsError(
        f"{path} already exists; pass overwrite=True to replace it (or choose another file name)."
    )
    check_target(path, overwrite, exists)
    folder = path.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"Cannot save the model to {path}: folder {folder} does not exist.")

    write = _archive_writer(estimator)
    # a new file in the same folder (permissions from the umask), then moved;
    # whatever stops the save (an error, Ctrl-C, SIGTERM in the greyml
    # command) removes it
    write_atomic(path, write, overwrite=overwrite, exists=exists, encoding=None)
    return path


def _archive_writer(estimator):
    """The function that writes the model file of ``estimator`` (a greyml-model zip) to
    the binary handle it is given; the estimator is encoded before it is returned."""
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

    def write(handle):
        with zipfile.ZipFile(handle, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            archive.writestr(_MODEL_MEMBER, payload)
            for name, data in writer.arrays:
                archive.writestr(name, data)

    return write
