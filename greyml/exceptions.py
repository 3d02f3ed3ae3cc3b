"""The warnings and errors that greyml raises.

Every greyml warning and error class is defined here, as scikit-learn keeps its
own in :mod:`sklearn.exceptions`; each is also importable from the module that
raises it (``from greyml.grey import GreyStabilityWarning`` names the same
class as ``from greyml.exceptions import GreyStabilityWarning``), and the
warnings of the estimators from :mod:`greyml` itself.

Every greyml warning is a :class:`UserWarning`, so one filter silences them
all; :class:`UnsafeModelError` is a :class:`ValueError`.
"""

__all__ = [
    "GapWarning",
    "GreyConditioningWarning",
    "GreyStabilityWarning",
    "GreyWarmStartWarning",
    "UnderdeterminedWarning",
    "UnsafeModelError",
    "WarmStartWarning",
]


class GreyConditioningWarning(UserWarning):
    """A grey model's least-squares system is rank deficient or ill-conditioned.

    Examples
    --------
    Two identical sensors make the GM(1,N) system rank deficient; the fit
    warns and returns the minimum-norm solution, which splits the influence
    equally:

    >>> import warnings
    >>> import numpy as np
    >>> from greyml.grey import GreyConditioningWarning, fit_gm1n
    >>> x = np.array([1.0, 1.2, 1.5, 1.9, 2.2])
    >>> y = np.array([0.5, 0.9, 1.4, 1.6, 2.1])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     a, b = fit_gm1n(np.column_stack([x, x]), y)
    >>> [w.category.__name__ for w in caught]
    ['GreyConditioningWarning']
    >>> bool(np.isclose(b[0], b[1]))
    True
    """


class GreyStabilityWarning(UserWarning):
    """A calibrated grey model is unstable: its development coefficient b₁ < 0.

    Its response grows like e^{−b₁k} instead of settling, so it can fit the
    training tests and still predict absurd values on a longer test. The
    warning says by how much the response grows over the longest training
    test. The default ``bounds="stable"`` (any solver, least squares too)
    keeps b₁ ≥ 0; it happens with ``bounds="papers"`` or a box of your own.

    Examples
    --------
    A displacement that grows faster and faster with a steady driver can only
    be fitted with b₁ < 0:

    >>> import warnings
    >>> import numpy as np
    >>> from greyml.grey import GMC, GreyStabilityWarning
    >>> X = np.linspace(1.0, 2.0, 40)[:, None]
    >>> y = np.exp(0.05 * np.arange(40))
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     model = GMC(bounds="papers").fit(X, y)
    >>> [w.category.__name__ for w in caught]
    ['GreyStabilityWarning']
    >>> bool(model.development_coef_ < 0)
    True
    """


class WarmStartWarning(UserWarning):
    """A model predicts a test that starts without the history that made its state.

    A dynamic model (:class:`greyml.ThermalTransferFunction`) carries its lags
    over from the test before on the same clock. A test that begins later on
    its clock but is given alone starts from an assumed state (temperatures at
    rest, drivers idle), and this warning names it: give the rows before it,
    or the displacement measured at its first row
    (``predict(X, initial_displacement=...)``).
    :class:`GreyWarmStartWarning` is its grey models' kind.

    Examples
    --------
    A model fitted on two tests of one clock, asked for the second alone:

    >>> import warnings
    >>> import numpy as np
    >>> import pandas as pd
    >>> from greyml import ThermalTransferFunction, WarmStartWarning, make_test_index
    >>> t = np.arange(0.0, 8 * 3600, 60.0)
    >>> rpm = np.where(t % (4 * 3600) < 2 * 3600, 3000.0, 0.0)
    >>> X = pd.DataFrame({"spindle_rpm": rpm},
    ...                  index=make_test_index(np.where(t < 4 * 3600, "a", "b"), t))
    >>> model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, 1e-3 * rpm)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = model.predict(X.loc[["b"]])
    >>> [w.category.__name__ for w in caught], "test 'b'" in str(caught[0].message)
    (['WarmStartWarning'], True)
    >>> model.predict(X.loc[["b"]], initial_displacement=2.5)[0]
    np.float64(2.5)
    """


class GreyWarmStartWarning(WarmStartWarning):
    """A grey model predicts a test that does not start where the training tests did.

    A grey model predicts the change since each test's first row, where its
    inputs start accumulating. Without the measured displacement there
    (``predict(X, initial_displacement=...)``) it starts from its own value
    for a machine as the training tests started, which is wrong for a test
    that starts mid-run; such a test's inputs often start away from the
    training tests' first values, and then this warning names the test and
    the column.

    Examples
    --------
    Trained on tests that start at 20 °C, applied to one that starts at 30 °C:

    >>> import warnings
    >>> import numpy as np
    >>> import pandas as pd
    >>> from greyml import GMC, make_test_index
    >>> from greyml.grey import GreyWarmStartWarning
    >>> t = np.arange(40.0)
    >>> rise = 5 * (1 - np.exp(-t / 10))
    >>> index = make_test_index(["I"] * 40 + ["II"] * 40, np.r_[t, t])
    >>> X = pd.DataFrame({"T1_C": np.r_[20 + rise, 20.5 + rise]}, index=index)
    >>> y = 2 * (X["T1_C"] - 20)
    >>> model = GMC().fit(X, y)
    >>> hot = pd.DataFrame({"T1_C": 30 + rise}, index=make_test_index(["III"] * 40, t))
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = model.predict(hot)
    >>> [w.category.__name__ for w in caught]
    ['GreyWarmStartWarning']
    >>> "test 'III'" in str(caught[0].message)
    True
    >>> model.predict(hot, initial_displacement={"III": 20.0})[0]
    np.float64(20.0)
    """


class UnderdeterminedWarning(UserWarning):
    """A model has more weights than training rows (equations).

    :class:`~greyml.MLPBaseline` still trains such a network: Levenberg–Marquardt's
    damping μ keeps every step defined, and the goal or the validation stop ends
    training. :class:`~greyml.ThermalTransferFunction` still fits its gains: the
    ridge penalty keeps the solve defined. But many weight vectors then fit the
    training rows equally well, so the model can interpolate them and
    generalise poorly; a smaller model (fewer hidden units, fewer sensors or
    time constants) or more rows make the fit determined.

    Examples
    --------
    Twenty rows of three inputs are fewer than the 51 weights of a 3-10-1
    network:

    >>> import warnings
    >>> import numpy as np
    >>> from greyml.neural import MLPBaseline, UnderdeterminedWarning
    >>> rng = np.random.default_rng(0)
    >>> X, y = rng.random((20, 3)), rng.random(20)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     model = MLPBaseline(max_iter=20, random_state=0).fit(X, y)
    >>> [w.category.__name__ for w in caught]
    ['UnderdeterminedWarning']
    """


class GapWarning(UserWarning):
    """A gap diagnosis whose result needs a second look.

    Raised when a named effect's fitted time constant ends at the bound of
    its search: the true one may lie beyond, and a ``time_s`` column in
    minutes or hours labelled as seconds shows itself this way.

    Examples
    --------
    >>> import warnings
    >>> from greyml.exceptions import GapWarning
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warnings.warn("time constant at its bound", GapWarning)
    >>> caught[0].category.__name__
    'GapWarning'
    """


class UnsafeModelError(ValueError):
    """A model file names a class, type or function that may not be created.

    Raised by :func:`~greyml.persist.load_model` before anything from the file is built. The
    message lists the names; pass those you trust as ``trusted=``.

    Examples
    --------
    scikit-learn's ``DummyRegressor`` is not on greyml's allowlist: its file
    is refused until the class is trusted.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from sklearn.dummy import DummyRegressor
    >>> from greyml.persist import UnsafeModelError, load_model, save_model
    >>> model = DummyRegressor().fit([[0.0], [0.0], [0.0]], [1.0, 2.0, 6.0])
    >>> with tempfile.TemporaryDirectory() as folder:  # doctest: +ELLIPSIS
    ...     path = save_model(model, Path(folder) / "dummy.greyml")
    ...     try:
    ...         load_model(path)
    ...     except UnsafeModelError as exc:
    ...         print(exc)
    ...     again = load_model(path, trusted=["sklearn.dummy.DummyRegressor"])
    Refusing to load ...dummy.greyml: it names classes that are not on greyml's
    allowlist: sklearn.dummy.DummyRegressor (if you trust the file's source, pass
    them as load_model(..., trusted=[...])).
    >>> again.predict([[0.0]]).tolist()
    [3.0]
    >>> issubclass(UnsafeModelError, ValueError)
    True
    """
