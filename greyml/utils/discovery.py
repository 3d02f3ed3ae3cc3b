"""Utilities to discover greyml's estimators (as :mod:`sklearn.utils.discovery`)."""

import inspect
import pkgutil
from importlib import import_module
from operator import itemgetter
from pathlib import Path

__all__ = ["all_estimators"]

#: The mixin that each ``type_filter`` keyword selects, by its name in scikit-learn.
_TYPE_FILTERS = {
    "classifier": "ClassifierMixin",
    "regressor": "RegressorMixin",
    "transformer": "TransformerMixin",
    "cluster": "ClusterMixin",
}


def all_estimators(type_filter=None):
    """Every estimator that greyml defines, as ``(name, class)`` pairs.

    Walks greyml's public modules (those without a ``_`` in their path, as
    :func:`sklearn.utils.discovery.all_estimators` walks scikit-learn's) and
    returns the public classes defined in greyml that derive from
    scikit-learn's ``BaseEstimator`` and are not abstract, each once, sorted
    by name. scikit-learn's own estimators that a greyml module imports are
    left out, and so are the splitters and optimisers, which are not
    estimators.

    Parameters
    ----------
    type_filter : {"regressor", "transformer", "classifier", "cluster"} \
            or list of such str, default=None
        Which kind of estimators to return: those with the matching
        scikit-learn mixin (``RegressorMixin``, ``TransformerMixin``, ...), or
        with any of them for a list. ``None`` returns every estimator.
        :class:`~greyml.Compensator` is not one: it is the runtime object a
        controller runs (``update``), with nothing to fit.

    Returns
    -------
    estimators : list of tuple
        ``(name, class)`` pairs, ``name`` the class's name.

    Raises
    ------
    ValueError
        If ``type_filter`` names another kind.

    See Also
    --------
    sklearn.utils.discovery.all_estimators : The same for scikit-learn.

    Examples
    --------
    >>> from greyml.utils.discovery import all_estimators
    >>> names = [name for name, _ in all_estimators()]
    >>> "GMC" in names and "LagFeatures" in names
    True
    >>> [name for name, _ in all_estimators(type_filter="transformer")]
    ['AGO', 'GreyInfluenceSelector', 'LagFeatures', 'RelativeToStart']
    """
    # imported here: greyml.persist builds its allowlist from this function
    import sklearn.base
    from sklearn.base import BaseEstimator

    import greyml
    from greyml.optimize._base import PopulationOptimizer

    if type_filter is None:
        wanted = None
    else:
        kinds = [type_filter] if isinstance(type_filter, str) else list(type_filter)
        unknown = [kind for kind in kinds if kind not in _TYPE_FILTERS]
        if unknown or not kinds:
            raise ValueError(
                "Parameter type_filter must be 'regressor', 'transformer', 'classifier', "
                f"'cluster', a list of them or None, got {type_filter!r}."
            )
        wanted = tuple(getattr(sklearn.base, _TYPE_FILTERS[kind]) for kind in kinds)

    root = str(Path(greyml.__file__).parent)
    found = set()
    for _, module_name, _ in pkgutil.walk_packages(path=[root], prefix="greyml."):
        if "._" in module_name:  # private modules, greyml.__main__ too
            continue
        module = import_module(module_name)
        for name, cls in inspect.getmembers(module, inspect.isclass):
            if (
                not name.startswith("_")
                and cls.__module__.partition(".")[0] == "greyml"
                and issubclass(cls, BaseEstimator)
                # optimisers are BaseEstimators for their parameters, but a
                # setting of an estimator, never fitted to data themselves
                and not issubclass(cls, PopulationOptimizer)
                and not inspect.isabstract(cls)
            ):
                found.add((name, cls))
    if wanted is not None:
        found = {(name, cls) for name, cls in found if issubclass(cls, wanted)}
    return sorted(found, key=itemgetter(0))
