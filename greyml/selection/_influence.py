"""Sensor selection by grey influence and fuzzy c-means (Abdulshahed et al. (2015))."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.feature_selection import SelectorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Integral, Interval, Real, StrOptions
from greyml._rng import RANDOM_STATE_CONSTRAINT, make_generator
from greyml._sequences import keep_test_index
from greyml._threads import blas_threads_for
from greyml._validation import column_names, require_y, validate_grey_tests, validate_sequences
from greyml.fuzzy._kernels import fuzzy_cmeans
from greyml.grey._kernels import _grey_lstsq, gm1n_design

__all__ = ["GreyInfluenceSelector"]

_NORMALISATIONS = ("mean", "initial", "range")
_CLUSTER_ON = ("influence", "series")


class GreyInfluenceSelector(SelectorMixin, BaseEstimator):
    """Keep one sensor per group: GM(1,N) influence plus fuzzy c-means.

    Abdulshahed et al.'s (2015) selection of temperature sensors: the GM(1,N) model of the target
    (e.g. a displacement) against every candidate sensor gives each sensor an
    influence weight bⱼ; fuzzy c-means groups the sensors into ``n_clusters``
    clusters; from each cluster the sensor with the largest influence ``|bⱼ|`` is
    kept. The sensors are normalised first, so that their weights can be
    compared.

    Read more in the :ref:`User Guide <ug-grey-influence-selector>`.

    Parameters
    ----------
    n_clusters : int, default=5
        Groups of sensors, hence the number of sensors kept (Abdulshahed et al. (2015): 5). A
        cluster that no sensor belongs to most keeps nothing.
    m : float, default=2.0
        Fuzziness exponent of c-means (> 1).
    cluster_on : {"influence", "series"}, default="influence"
        What c-means groups. ``"influence"``: the sensors' influence weights, as
        Abdulshahed et al. (2015) does (sensors with similar weights form a group).
        ``"series"``: the sensors' series, normalised as ``normalisation``
        says, so sensors that move together form a group whatever their
        weights.
    normalisation : {"range", "mean", "initial"}, default="range"
        Scale of each sensor before GM(1,N): map it to [0, 1] by its range over
        the training rows, or divide it by its mean (grey mean normalisation)
        or by its first value (initial-value normalisation). The grey
        normalisations need a sensor whose mean or first value is far from 0
        (temperatures in °C or K); the range works for any sensor. The
        target is divided by its mean absolute value (this scales every weight
        alike and does not change the ranking).
    max_iter : int, default=300
        c-means iterations.
    tol : float, default=1e-6
        c-means stopping tolerance (root-mean-square change of a membership).
    n_init : int, default=10
        c-means runs from this many random initial partitions; the one with
        the lowest c-means objective is kept (as k-means' ``n_init``). One run
        can settle in a partition that splits one physical group in two.
    random_state : int, Generator or None, default=None
        Seeds c-means' initial partition. The global NumPy state is never used.

    Attributes
    ----------
    influence_ : ndarray of shape (``n_features_in_``,)
        GM(1,N) influence weight bⱼ of every sensor (normalised data).
    development_coef_ : float
        The GM(1,N) development coefficient a.
    membership_ : ndarray of shape (n_clusters, ``n_features_in_``)
        Fuzzy membership of every sensor in every cluster.
    clusters_ : ndarray of shape (``n_features_in_``,)
        The cluster each sensor belongs to most.
    support_ : ndarray of bool, shape (``n_features_in_``,)
        The kept sensors.
    selected_ : list of str
        Names of the kept sensors, cluster by cluster in order of influence.
    n_iter_ : int
        c-means iterations run.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)

    See Also
    --------
    greyml.TrainOnOneTest : the papers' validation, calibrating on one test.

    Notes
    -----
    GM(1,N) accumulates each test separately (the ``test`` index level), so the
    influence weights come from every training test at once without an
    accumulation crossing a boundary. With many near-collinear sensors the
    least-squares system is ill-conditioned and individual weights are
    uncertain; a rank-deficient system warns
    (:class:`~greyml.exceptions.GreyConditioningWarning`) and uses the minimum-norm
    solution.

    References
    ----------
    Abdulshahed, A. M., Longstaff, A. P., Fletcher, S. and Myers, A. (2015).
    Thermal error modelling of machine tools based on ANFIS with fuzzy c-means
    clustering using a thermal imaging camera. Applied Mathematical Modelling
    39, 1837-1852.

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from greyml import GreyInfluenceSelector
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(100.0)
    >>> heat = 1 - np.exp(-t / 30)
    >>> X = pd.DataFrame({
    ...     "spindle_a": 20 + 5 * heat + 0.01 * rng.normal(size=100),
    ...     "spindle_b": 20 + 4.8 * heat + 0.01 * rng.normal(size=100),
    ...     "ambient": 20 + 0.3 * np.sin(t / 15) + 0.01 * rng.normal(size=100),
    ... })
    >>> y = 10 * heat + 2 * np.sin(t / 15)
    >>> selector = GreyInfluenceSelector(n_clusters=2, cluster_on="series",
    ...                                  random_state=0).fit(X, y)
    >>> len(selector.selected_)
    2
    """

    _parameter_constraints: dict = {
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "m": [Interval(Real, 1, None, closed="neither")],
        "cluster_on": [StrOptions(set(_CLUSTER_ON))],
        "normalisation": [StrOptions(set(_NORMALISATIONS))],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "tol": [Interval(Real, 0, None, closed="neither")],
        "n_init": [Interval(Integral, 1, None, closed="left")],
        "random_state": RANDOM_STATE_CONSTRAINT,
    }

    def __init__(
        self,
        n_clusters=5,
        *,
        m=2.0,
        cluster_on="influence",
        normalisation="range",
        max_iter=300,
        tol=1e-6,
        n_init=10,
        random_state=None,
    ):
        self.n_clusters = n_clusters
        self.m = m
        self.cluster_on = cluster_on
        self.normalisation = normalisation
        self.max_iter = max_iter
        self.tol = tol
        self.n_init = n_init
        self.random_state = random_state

    def _normalise(self, Xa, names):
        if self.normalisation == "range":
            lo, hi = Xa.min(axis=0), Xa.max(axis=0)
            return (Xa - lo) / (hi - lo)
        ref = Xa.mean(axis=0) if self.normalisation == "mean" else Xa[0]
        bad = np.flatnonzero(np.abs(ref) < 1e-12 * (np.abs(Xa).max(axis=0) + 1e-300))
        if bad.size:
            what = "mean" if self.normalisation == "mean" else "first value"
            raise ValueError(
                f"GreyInfluenceSelector cannot use normalisation={self.normalisation!r}: "
                f"column {names[bad[0]]!r} has {what} 0. Use normalisation='range'."
            )
        return Xa / ref

    def fit(self, X, y):
        """Rank the sensors by influence, group them, keep one per group.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Candidate sensors; tests from the ``test`` index level.
        y : array-like of shape (n_samples,)
            Target (e.g. displacement).

        Returns
        -------
        self
        """
        self._validate_params()
        require_y(self, y, "the influence of a sensor is measured against the target")
        Xa, ya, segments = validate_grey_tests(
            self, X, y, extra=1, coefficients="GM(1,N) coefficients (a, one b per column)"
        )
        n_features = Xa.shape[1]
        if self.n_clusters > n_features:
            raise ValueError(
                f"GreyInfluenceSelector has n_clusters={self.n_clusters} but X has only "
                f"{n_features} column(s): there cannot be more groups than sensors."
            )
        names = column_names(self, n_features)
        Xn = self._normalise(Xa, names)
        scale = np.mean(np.abs(ya))
        yn = ya / scale if scale > 0 else ya
        test_bounds = [(s.start, s.stop) for s in segments]
        # an SVD of (n × p): small, so one BLAS thread (see greyml._threads)
        with blas_threads_for(Xn.size * n_features):
            theta, _ = _grey_lstsq(
                gm1n_design, yn, Xn, test_bounds, "GreyInfluenceSelector's GM(1,N)", names
            )
        a, b = theta[0], theta[1:]
        self.development_coef_ = float(a)
        self.influence_ = np.asarray(b, dtype=float)

        if self.cluster_on == "influence":
            features = self.influence_[:, None]
        else:
            features = Xn.T
        self.membership_ = self._cmeans(features)
        self.clusters_ = np.argmax(self.membership_, axis=0)
        support = np.zeros(n_features, dtype=bool)
        strength = np.abs(self.influence_)
        order = []
        for k in range(self.n_clusters):
            members = np.flatnonzero(self.clusters_ == k)
            if members.size:
                best = members[np.argmax(strength[members])]
                support[best] = True
                order.append(best)
        self.support_ = support
        order.sort(key=lambda j: -strength[j])
        self.selected_ = [names[j] for j in order]
        return self

    def _cmeans(self, features):
        """Memberships (c, n_sensors) of the sensors described by ``features``."""
        n, c = features.shape[0], self.n_clusters
        if c == 1:
            self.n_iter_ = 0
            return np.ones((1, n))
        span = np.ptp(features, axis=0)
        data = features / np.where(span > 0, span, 1.0)
        _, u, self.n_iter_, _ = fuzzy_cmeans(
            data,
            c,
            self.m,
            self.tol,
            self.max_iter,
            make_generator(self.random_state),
            n_init=self.n_init,
        )
        if not np.isfinite(u).all():
            raise ValueError(
                f"GreyInfluenceSelector: fuzzy c-means with {c} clusters did not reach "
                "a finite partition; try fewer clusters."
            )
        return u

    def transform(self, X):
        """Keep the selected sensors' columns.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)

        Returns
        -------
        X_selected : ndarray or DataFrame of shape (n_samples, n_selected)
            A DataFrame with ``X``'s index when ``X`` has a ``test`` index
            level, so the next step of a Pipeline still sees the tests.
        """
        check_is_fitted(self)
        # the bad value, its column and its test named before any column is dropped
        validate_sequences(self, X, reset=False)
        return keep_test_index(self, X, super().transform(X))

    def _get_support_mask(self):
        check_is_fitted(self)
        return self.support_

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        return tags
