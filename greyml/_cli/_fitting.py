"""Fitting and predicting for the ``greyml`` subcommands, with warnings collected."""

from __future__ import annotations

import time
import warnings


def _selector(n, cluster_on, random_state, *, quick=False):
    """GreyInfluenceSelector keeping ``n`` sensors; ``cluster_on=None`` is its default."""
    from greyml import GreyInfluenceSelector

    selector = GreyInfluenceSelector(n, n_init=3 if quick else 10, random_state=random_state)
    if cluster_on is not None:
        selector.set_params(cluster_on=cluster_on)
    return selector


def _distinct_warnings(caught):
    """The warnings recorded in ``caught`` as ``"Category: message"``, each once, in order."""
    return list(dict.fromkeys(f"{x.category.__name__}: {x.message}" for x in caught))


def _fit_quietly(estimator, X, y, *, chunks=False, **params):
    """Fit ``estimator`` (``params``: fit parameters such as ``sample_weight``; with
    ``chunks``, ``fit_chunks(X)``); return the seconds taken and the distinct warnings
    raised."""
    from threadpoolctl import threadpool_limits

    # one BLAS thread: the products are small, and on a busy machine more
    # threads only wait for each other (see greyml._threads); files read piece
    # by piece are many rows, whose products are not small
    with (
        threadpool_limits(limits=None if chunks else 1, user_api="blas"),
        warnings.catch_warnings(record=True) as w,
    ):
        warnings.simplefilter("always")
        start = time.perf_counter()
        if chunks:
            estimator.fit_chunks(X)
        else:
            estimator.fit(X, y, **params)
        seconds = time.perf_counter() - start
    return seconds, _distinct_warnings(w)


def _predict_quietly(estimator, X, **params):
    """``estimator.predict(X)`` as floats, and the distinct warnings raised.

    A model whose attributes are malformed (a file altered so that it still
    loads) fails deep inside NumPy or scikit-learn: that is one ValueError
    naming the model's class and what failed, not a traceback.
    """
    import numpy as np

    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        try:
            pred = np.asarray(estimator.predict(X, **params), dtype=float)
        except ValueError:
            raise
        except (TypeError, IndexError, KeyError, AttributeError, np.linalg.LinAlgError) as exc:
            raise ValueError(
                f"the model ({type(_final_step(estimator)).__name__}) could not predict "
                f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}); its "
                "file may have been altered, or the data are not what it was fitted on."
            ) from None
    return pred, _distinct_warnings(w)


def _final_step(estimator):
    steps = getattr(estimator, "steps", None)
    return steps[-1][1] if steps else estimator


#: How the command line names each reference of a model's displacement.
_REFERENCE_WORDS = {
    "start": "as its change since each test's first row (the reference of this model)",
    "recording": "from the recording's zero, as the target in the file (the reference of "
    "this model)",
    "target": "as the target in the file (the model learns its values as they are)",
}


def _reference(estimator):
    """Where a model's predictions are measured from: ``"start"``, ``"recording"`` or
    ``"target"`` (a model that predicts the target's values as it was given them)."""
    from greyml.grey._gmc import _GreyConvolutionModel

    final = _final_step(estimator)
    reference = getattr(final, "reference_", None)
    if reference is not None:
        return reference
    if isinstance(final, _GreyConvolutionModel):
        return "start"
    return "target"


def _measured(y, reference, given=()):
    """The measured target in ``reference``: its change since each test's first row for
    ``"start"`` (except in the tests in ``given``, started at a measured value), else
    as it is."""
    import numpy as np

    values = np.asarray(y, dtype=float).copy()
    if reference != "start":
        return values
    first = y.groupby(level="test", sort=False).transform("first").to_numpy(dtype=float)
    keep = np.isin(np.asarray(y.index.get_level_values("test"), dtype=object), list(given))
    return np.where(keep, values, values - first)
