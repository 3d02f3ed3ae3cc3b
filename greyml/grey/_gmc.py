"""GMC(1,N): the grey model with convolution integral, as a regressor."""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Mapping

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Integral, Interval, StrOptions
from greyml._rng import RANDOM_STATE_CONSTRAINT, make_generator
from greyml._sequences import segment_label
from greyml._threads import blas_threads_for
from greyml._validation import column_names, require_y, validate_grey_tests, validate_sequences
from greyml.exceptions import (
    GreyConditioningWarning,
    GreyStabilityWarning,
    GreyWarmStartWarning,
)
from greyml.grey._kernels import _grey_lstsq, ago, gmc_design, gmc_lstsq_fixed_b1
from greyml.grey._response import gmc_predict, gmc_separable, gmc_sse_population
from greyml.optimize import CuckooSearch, ParticleSwarm
from greyml.optimize._base import PENALTY, PopulationOptimizer, check_bounds

__all__ = ["GMC", "GreyConditioningWarning", "GreyStabilityWarning", "GreyWarmStartWarning"]


_SOLVERS = ("ls", "pso", "cs")

#: A test's first value counts as a cold start when it lies within the training
#: tests' first values widened by their range, or by this share of the column's
#: range over the training rows, whichever is larger (one training test has a
#: range of 0).
START_TOLERANCE = 0.1

#: The papers' search box for every grey coefficient, b₁ included (Tien (2012);
#: Abdulshahed et al. (2016, 2017)): ``bounds="papers"``. It admits b₁ < 0, an
#: unstable response; ``bounds="stable"`` (the default) narrows b₁ to [0, 100].
PAPERS_BOUNDS = (-100.0, 100.0)
BOUNDS_NAMES = ("stable", "papers")


def _test_bounds_of(segments):
    return [(s.start, s.stop) for s in segments]


class _GreyConvolutionModel(RegressorMixin, BaseEstimator):
    """fit/predict shared by GMC and GNNMCI: both calibrate the GMC(1,N) time
    response (one implementation, :mod:`greyml.grey._response`); they differ in
    their defaults and optimiser. Subclasses define ``_check_params``, which
    returns the population optimiser (or ``None`` for least squares)."""

    _parameter_constraints: dict = {
        "search": [StrOptions({"separable", "full"})],
        "bounds": [StrOptions(set(BOUNDS_NAMES)), "array-like"],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "initial": [StrOptions({"model", "zero"})],
        "polish": ["boolean"],
        "warm_start_ls": ["boolean"],
        "random_state": RANDOM_STATE_CONSTRAINT,
    }

    # -- fit / predict ----------------------------------------------------
    def fit(self, X, y):
        """Calibrate b₁, b₂…b_N and u on one or more tests.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Drivers (sensor readings), rows in time order within each test.
        y : array-like or Series of shape (n_samples,)
            The target (e.g. displacement in µm).

        Returns
        -------
        self
        """
        self._validate_params()
        optimizer = self._check_params()
        require_y(self, y)
        Xa, ya, segments = validate_grey_tests(
            self, X, y, extra=2, coefficients="coefficients (b1, one b per column, u)"
        )
        test_bounds = _test_bounds_of(segments)
        self.n_tests_ = len(segments)
        firsts = Xa[[seg.start for seg in segments]]
        self.start_range_ = np.vstack([firsts.min(axis=0), firsts.max(axis=0)])
        self.start_tolerance_ = np.maximum(
            np.ptp(firsts, axis=0), START_TOLERANCE * np.ptp(Xa, axis=0)
        )
        with blas_threads_for(Xa.size * (Xa.shape[1] + 2)):
            return self._calibrate(Xa, ya, test_bounds, optimizer)

    def _calibrate(self, Xa, ya, test_bounds, optimizer):

        n_theta = Xa.shape[1] + 2
        theta_ls, _ = _grey_lstsq(
            gmc_design, ya, Xa, test_bounds, type(self).__name__, column_names(self, n_theta - 2)
        )
        b1 = theta_ls[0]
        X1 = ago(Xa, test_bounds)

        if optimizer is None:
            # b1 kept in its range (bounds' first entry): outside it, the least
            # squares optimum has b1 at the nearer end
            lower, upper = check_bounds(self._search_bounds(n_theta), n_theta)
            theta = theta_ls
            ls_b1 = float(b1)
            if not lower[0] <= b1 <= upper[0]:
                edge = float(np.clip(b1, lower[0], upper[0]))
                b, u = gmc_lstsq_fixed_b1(ya, Xa, edge, test_bounds)
                theta = np.concatenate([[edge], b, [u]])
            self.optimizer_result_ = None
            self.n_iter_ = 1
        elif self.search == "full":
            lower, upper = check_bounds(self._search_bounds(n_theta), n_theta)
            rng = make_generator(self.random_state)
            x0 = theta_ls[None, :] if self.warm_start_ls and np.isfinite(theta_ls).all() else None
            result = optimizer.minimize(
                _GMCObjective(X1, ya, test_bounds, self.response, self.initial),
                (lower, upper),
                rng,
                x0=x0,
            )
            theta = result.x
            self.optimizer_result_ = result
            self.n_iter_ = result.nit
        else:
            # validated for every coefficient as documented; only b1's entry is used
            lower, upper = check_bounds(self._search_bounds(n_theta), n_theta)
            # b1 is searched on an arcsinh scale: fine near 0, where the stable,
            # physically meaningful development coefficients lie, coarse far out
            lower, upper = np.arcsinh(lower[:1]), np.arcsinh(upper[:1])
            rng = make_generator(self.random_state)
            x0 = (
                np.arcsinh(np.clip([[b1]], np.sinh(lower), np.sinh(upper)))
                if self.warm_start_ls and np.isfinite(b1)
                else None
            )
            objective = _GMCSeparableObjective(X1, ya, test_bounds, self.response, self.initial)
            result = optimizer.minimize(objective, (lower, upper), rng, x0=x0)
            if self.polish:
                _polish(objective, result, lower[0], upper[0])
            result.x = np.sinh(result.x)
            _, lin = gmc_separable(X1, ya, result.x, test_bounds, self.response, self.initial)
            theta = np.concatenate([result.x, lin[0]])
            self.optimizer_result_ = result
            self.n_iter_ = result.nit

        self.development_coef_ = float(theta[0])
        self.driving_coef_ = np.asarray(theta[1:-1], dtype=float)
        self.control_ = float(theta[-1])
        if self.development_coef_ < 0:
            n_max = max(stop - start for start, stop in test_bounds)
            growth = -self.development_coef_ * n_max
            factor = f"{np.exp(growth):,.3g}" if growth < 700 else f"e^{growth:,.0f}"
            warnings.warn(
                f"{type(self).__name__} calibrated an unstable model: b1 = "
                f"{self.development_coef_:.4g} < 0, so its response grows like "
                f"exp({-self.development_coef_:.4g}·k), a factor {factor} over the longest "
                f"training test ({n_max} samples), and more on longer tests. Keep b1 >= 0 "
                "with bounds='stable' (the default, any solver).",
                GreyStabilityWarning,
                stacklevel=3,
            )
        self.loss_ = float(
            gmc_sse_population(X1, ya, theta[None, :], test_bounds, self.response, self.initial)[0]
        )
        if self.loss_ >= PENALTY and optimizer is None:
            where = (
                "inside bounds"
                if theta[0] == ls_b1
                else f"outside bounds, so b1 was set to their nearer end, {theta[0]:g}"
            )
            raise ValueError(
                f"{type(self).__name__}(solver='ls') calibration failed: least squares on the "
                f"grey equation gives b1 = {ls_b1:.4g}, {where}; with it the time response "
                f"grows like exp({-theta[0]:g}·k) and overflows on the training tests. Use "
                "bounds='stable' (b1 >= 0) or solver='pso'."
            )
        if self.loss_ >= PENALTY:
            raise ValueError(
                f"{type(self).__name__} calibration failed: every candidate trajectory diverged on "
                "the training tests. Check the drivers' scale or narrow `bounds`."
            )
        return self

    def predict(self, X, initial_displacement=None):
        """Predict the target of every test in ``X``.

        Each test's response starts from that test's first row: from the
        measured value given in ``initial_displacement``, else from the first
        driver values (see ``initial``); the target is not needed.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        initial_displacement : float, dict, Series or None, default=None
            The measured target at each test's first row, for a test that
            starts mid-run (e.g. the end of the previous test): a float for
            every test, or a mapping (a dict, or a Series indexed by test
            label) from test label to value; tests it leaves out start as with
            ``None``. A given test's prediction starts at that value and adds
            the model's predicted change since the first row
            (``gmc_predict``). With ``None``, a test whose
            first driver values lie away from the training tests' first values
            by more than their range (at least ``START_TOLERANCE`` = 10 % of
            the column's range in ``fit``) gets a
            :class:`~greyml.exceptions.GreyWarmStartWarning` naming the test and the column.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False, min_samples_per_test=1)
        test_bounds = _test_bounds_of(segments)
        start = _initial_values(self, initial_displacement, segments)
        self._check_cold_starts(Xa, segments, start)
        pred = gmc_predict(
            ago(Xa, test_bounds),
            self.development_coef_,
            self.driving_coef_,
            self.control_,
            test_bounds,
            self.response,
            self.initial,
            start=start,
        )
        bad = ~np.isfinite(pred)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            seg = next(s for s in segments if s.start <= row < s.stop)
            raise ValueError(
                f"{type(self).__name__} prediction diverges in {segment_label(seg)} "
                f"from row {row}: "
                f"b1 = {self.development_coef_:g} makes the response grow like "
                f"exp({-self.development_coef_:g}·k) over its {seg.n} samples."
            )
        return pred

    def _check_cold_starts(self, Xa, segments, start):
        """Warn for each test without a given start whose inputs start warm."""
        low_high = getattr(self, "start_range_", None)
        if low_high is None:  # a model saved before the starts were kept
            return
        names = getattr(self, "feature_names_in_", None)
        for seg, given in zip(segments, start):
            if np.isfinite(given):
                continue
            first = Xa[seg.start]
            off = np.maximum(low_high[0] - first, first - low_high[1])
            warm = np.flatnonzero(off > self.start_tolerance_)
            if warm.size == 0:
                continue
            j = int(warm[np.argmax(off[warm] - self.start_tolerance_[warm])])
            column = f"column {names[j]!r}" if names is not None else f"column {j}"
            label = "" if seg.label is None else f"{{{seg.label!r}: value}}"
            warnings.warn(
                f"{type(self).__name__} predicts {segment_label(seg)} from a cold start, "
                f"but its {column} starts at {first[j]:.4g}, away from the training tests' "
                f"first values {low_high[0, j]:.4g} to {low_high[1, j]:.4g} by more than "
                f"{self.start_tolerance_[j]:.3g}: if it starts mid-run, give its measured "
                f"value at the first row, predict(X, initial_displacement="
                f"{label or 'value'}) (greyml predict --initial-displacement).",
                GreyWarmStartWarning,
                stacklevel=3,
            )

    def _search_bounds(self, n_theta):
        """The optimiser's box for (b₁, b₂…b_N, u), with the named boxes resolved."""
        if isinstance(self.bounds, str):
            lower = np.full(n_theta, PAPERS_BOUNDS[0])
            if self.bounds == "stable":
                lower[0] = 0.0
            return lower, np.full(n_theta, PAPERS_BOUNDS[1])
        return self.bounds

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # a grey convolution model is a dynamic model of accumulated series; on
        # i.i.d. regression data (as in scikit-learn's generic checks) it is not
        # expected to fit well.
        tags.regressor_tags.poor_score = True
        return tags


class GMC(_GreyConvolutionModel):
    """Grey model with convolution integral, GMC(1,N).

    The target x₁ (e.g. a tool-point displacement) and the drivers x₂…x_N (the
    columns of ``X``, e.g. temperatures) are accumulated per test (1-AGO); the
    accumulated target obeys

        dx₁⁽¹⁾/dt + b₁x₁⁽¹⁾ = Σⱼ bⱼxⱼ⁽¹⁾ + u,

    whose discrete time response (a convolution, evaluated in O(n) by a
    first-order recursion) is differenced back (IAGO) into the prediction.

    Read more in the :ref:`User Guide <ug-gmc>`.

    Parameters
    ----------
    solver : {"ls", "pso", "cs"} or PopulationOptimizer, default="ls"
        ``"ls"``: least squares on the grey equation with background values
        (the "GMC-LS" baseline of Abdulshahed et al. (2016)). ``"pso"`` / ``"cs"``: particle swarm
        or cuckoo search minimising Σ(x̂₁⁽⁰⁾ − x₁⁽⁰⁾)² of the time response
        (Abdulshahed et al. (2017)), with ``n_population`` and ``max_iter``; or pass a
        configured :class:`~greyml.optimize.ParticleSwarm` /
        :class:`~greyml.optimize.CuckooSearch` to set every optimiser option.
    search : {"separable", "full"}, default="separable"
        What the population solvers search. ``"separable"``: only b₁; for each
        candidate b₁ the other coefficients solve the trajectory least-squares
        problem exactly, because the response is linear in (b₂…b_N, u) once b₁
        is fixed (variable projection). ``"full"``: every coefficient, as in
        Abdulshahed et al. (2017). The separable search reaches the trajectory optimum in a
        budget where the full search does not (see Notes).
    bounds : {"stable", "papers"} or (float, float) or (array, array), \
            default="stable"
        Search box. ``"stable"``: b₁ in [0, 100] and every other coefficient
        in [−100, 100], so that every solver calibrates a response that
        settles (b₁ ≥ 0), as :class:`GNNMCI` does. ``"papers"``: [−100, 100] for
        every coefficient, b₁ included, the setting of Tien (2012) and
        Abdulshahed et al. (2017); it admits b₁ < 0, which
        :class:`~greyml.exceptions.GreyStabilityWarning` reports. A pair gives the box itself.
        With ``search="full"``: for (b₁, b₂…b_N, u),
        the same for all coefficients when scalars. With
        ``search="separable"``: for b₁ (the first entry when arrays are given).
        With ``solver="ls"``: the range of b₁ only; if the least-squares b₁
        falls outside it, b₁ is set to the nearer end and the other
        coefficients are solved again (the least-squares optimum within the
        range).
    n_population : int, default=25
        Particles or nests (Abdulshahed et al. (2017): 25).
    max_iter : int, default=100
        Optimiser iterations (Abdulshahed et al. (2017): 100).
    response : {"trapezoid", "midpoint"}, default="trapezoid"
        Discretisation of the convolution: the trapezoid form of Tien (2012) and
        Abdulshahed et al. (2017), or the midpoint form printed in Abdulshahed et al. (2016).
    initial : {"model", "zero"}, default="model"
        How each test's response starts, in ``fit`` and in ``predict`` alike (the
        target of a new test is unknown when it is predicted). ``"model"``: the
        grey equation at k = 1, x̂₁⁽⁰⁾(1) = f(1) / (1 + b₁), from that test's own
        first driver values. ``"zero"``: x̂₁⁽⁰⁾(1) = 0, for displacements measured
        from a datum taken at the start of each test.
    polish : bool, default=True
        With ``search="separable"``: refine the optimiser's best b₁ by a bounded
        Brent search in its neighbourhood, kept only if it lowers the loss (as
        ``polish`` in :func:`scipy.optimize.differential_evolution`). Population
        methods find the right basin quickly but converge slowly inside it.
    warm_start_ls : bool, default=True
        Put the least-squares solution (clipped to ``bounds``) into the initial
        population of the PSO/CS solvers. The optimisers still search the whole
        box; this only makes sure they never end worse than the LS baseline's
        time response.
    random_state : int, Generator, RandomState or None, default=None
        Seeds the population solvers. The global NumPy state is never used.

    Attributes
    ----------
    development_coef_ : float
        b₁.
    driving_coef_ : ndarray of shape (``n_features_in_``,)
        b₂…b_N, one per column of ``X``.
    control_ : float
        u, the grey control parameter.
    loss_ : float
        Σ(x̂₁⁽⁰⁾ − x₁⁽⁰⁾)² of the fitted model over the training tests.
    optimizer_result_ : scipy.optimize.OptimizeResult or None
        What the optimiser returned (with ``history``); ``None`` for ``"ls"``.
    n_tests_ : int
        Number of tests seen in ``fit``.
    n_iter_ : int
        Optimiser iterations run (1 for ``"ls"``, one least-squares solve).
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)

    See Also
    --------
    greyml.AGO : the accumulation on its own.
    greyml.GNNMCI : the same time response as a grey neural network.

    Notes
    -----
    The seeds calibrate all N + 1 coefficients with a metaheuristic in a
    [−100, 100] box. With 25 particles and 100 iterations that search rarely gets
    near the optimum once there are more than two or three drivers (the loss
    surface is a narrow valley); ``search="separable"`` searches b₁ alone and
    keeps the seeds' objective, so it is the default.

    GMC is invariant to the units of a driver (bⱼ rescales) but not to an
    offset: a constant added to a driver accumulates into a ramp that u cannot
    absorb. Scale drivers without centring them (e.g.
    ``StandardScaler(with_mean=False)``) or give temperature rises consistently
    in fit and predict.

    Tests are read from the ``test`` level of the row index of ``X`` (or ``y``);
    accumulation, convolution and differencing restart at each test, and each
    test's prediction depends on that test's rows only. A trajectory that grows
    without bound (b₁ ≪ 0) is a large finite loss for the optimisers; ``predict``
    raises rather than return one that overflows. A mildly negative b₁ (e.g.
    −0.03) grows without overflowing: on a test longer than the training tests
    it can predict absurd values. The default ``bounds="stable"`` therefore
    keeps b₁ ≥ 0; with ``bounds="papers"`` (or any box that admits b₁ < 0)
    ``fit`` warns (:class:`~greyml.exceptions.GreyStabilityWarning`) whenever it ends with b₁ < 0.

    References
    ----------
    Tien, T.-L. (2012). A research on the grey prediction model GM(1,n). Applied
    Mathematics and Computation 218, 4903-4916.
    Abdulshahed, A. M., Longstaff, A. P. and Fletcher, S. (2017). A cuckoo search
    optimisation-based Grey prediction model for thermal error compensation on
    CNC machine tools. Grey Systems: Theory and Application 7(2), 146-155.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml import GMC
    >>> from greyml.grey._functions import simulate_gmc
    >>> rng = np.random.default_rng(0)
    >>> X = 1 + rng.random((60, 2))
    >>> y = simulate_gmc(X, development=0.4, driving=[0.5, -0.2], control=0.1)
    >>> model = GMC(solver="ls").fit(X, y)
    >>> round(model.development_coef_, 2)
    0.4
    """

    def __init__(
        self,
        solver="ls",
        *,
        search="separable",
        bounds="stable",
        n_population=25,
        max_iter=100,
        response="trapezoid",
        initial="model",
        polish=True,
        warm_start_ls=True,
        random_state=None,
    ):
        self.solver = solver
        self.search = search
        self.bounds = bounds
        self.n_population = n_population
        self.max_iter = max_iter
        self.response = response
        self.initial = initial
        self.polish = polish
        self.warm_start_ls = warm_start_ls
        self.random_state = random_state

    _parameter_constraints: dict = {
        **_GreyConvolutionModel._parameter_constraints,
        "solver": [StrOptions(set(_SOLVERS)), PopulationOptimizer],
        "n_population": [Interval(Integral, 2, None, closed="left")],
        "response": [StrOptions({"trapezoid", "midpoint"})],
    }

    # -- parameter checks -------------------------------------------------
    def _check_params(self):
        if isinstance(self.solver, PopulationOptimizer):
            return self.solver
        if self.solver == "ls":
            return None
        if self.solver == "pso":
            return ParticleSwarm(n_population=self.n_population, max_iter=self.max_iter)
        return CuckooSearch(n_population=self.n_population, max_iter=self.max_iter)


def _initial_values(estimator, given, segments):
    """One starting value per test from ``initial_displacement`` (NaN: not given)."""
    name = type(estimator).__name__
    out = np.full(len(segments), np.nan)
    if given is None:
        return out
    if isinstance(given, numbers.Real) and not isinstance(given, bool):
        if not np.isfinite(given):
            raise ValueError(
                f"{name}: initial_displacement must be a finite number; got {given!r}."
            )
        out[:] = float(given)
        return out
    if not isinstance(given, (Mapping, pd.Series)):
        raise TypeError(
            f"{name}: initial_displacement must be a number, a dict or a Series from test "
            f"label to value, or None; got {type(given).__name__}."
        )
    values = dict(given.items())
    labels = [seg.label for seg in segments]
    if labels == [None]:
        raise ValueError(
            f"{name}: initial_displacement as a mapping needs X with a 'test' index level "
            "to name the tests; X is a single unlabelled test: give a number."
        )
    unknown = [key for key in values if key not in labels]
    if unknown:
        shown = ", ".join(map(repr, labels[:10])) + (", ..." if len(labels) > 10 else "")
        raise ValueError(
            f"{name}: initial_displacement names test {unknown[0]!r}, which X does not hold "
            f"(its tests: {shown})."
        )
    for i, seg in enumerate(segments):
        if seg.label not in values:
            continue
        value = values[seg.label]
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
        if not ok or not np.isfinite(value):
            raise ValueError(
                f"{name}: initial_displacement of {segment_label(seg)} must be a finite "
                f"number; got {value!r}."
            )
        out[i] = float(value)
    return out


def _polish(objective, result, lower, upper):
    """Bounded Brent refinement of a 1-D optimum; kept only if it is better."""
    s0 = float(result.x[0])
    width = 0.02 * (upper - lower)
    lo, hi = max(lower, s0 - width), min(upper, s0 + width)
    if not hi > lo:
        return
    found = minimize_scalar(
        lambda s: float(objective(np.array([[s]]))[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-10 * max(1.0, abs(s0))},
    )
    result.nfev += int(found.nfev)
    if found.fun < result.fun:
        result.x = np.array([found.x])
        result.fun = float(found.fun)
        result.message += "; polished by bounded Brent search"


class _GMCObjective:
    """Picklable population objective: Σ(x̂₁⁽⁰⁾ − x₁⁽⁰⁾)² per candidate."""

    def __init__(self, X1, y, test_bounds, form, initial):
        self.X1 = X1
        self.y = y
        self.test_bounds = test_bounds
        self.form = form
        self.initial = initial

    def __call__(self, params):
        return gmc_sse_population(
            self.X1, self.y, params, self.test_bounds, self.form, self.initial
        )


class _GMCSeparableObjective(_GMCObjective):
    """Loss of each candidate with (b₂…b_N, u) solved exactly (variable projection).

    The candidates are s = arcsinh(b₁).
    """

    def __call__(self, params):
        sse, _ = gmc_separable(
            self.X1, self.y, np.sinh(params[:, 0]), self.test_bounds, self.form, self.initial
        )
        return sse
