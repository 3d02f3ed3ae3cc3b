"""Save fitted models to a file, and load them back without running code from it.

- :func:`save_model`: a fitted model (or pipeline) to a file;
- :func:`load_model`: the model back, refusing any class not allowed;
- :func:`describe_model`: what a file holds, read without building anything.

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
tree names and refuses the file (:class:`~greyml.exceptions.UnsafeModelError`) unless each is on
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

The package is in four modules: ``_format`` (the format's name, version and
limits, and the allowlist), ``_writer`` (:func:`save_model`), ``_archive``
(reading the archive within ``max_bytes``) and ``_reader``
(:func:`load_model`, :func:`describe_model`).
"""

from greyml.persist._archive import _read_npy  # noqa: F401 (greyml.persist._read_npy)
from greyml.persist._format import (  # noqa: F401 (the constants, as greyml.persist.NAME)
    ALLOWED_CLASSES,
    DEFAULT_MAX_BYTES,
    FORMAT_NAME,
    FORMAT_VERSION,
)
from greyml.persist._reader import describe_model, load_model
from greyml.persist._writer import save_model

__all__ = ["describe_model", "load_model", "save_model"]
