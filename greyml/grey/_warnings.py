"""Warnings of the grey models (re-exported by :mod:`greyml.grey`)."""

__all__ = ["GreyConditioningWarning", "GreyStabilityWarning", "GreyWarmStartWarning"]


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


class GreyWarmStartWarning(UserWarning):
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
