"""ANFIS regressors: grid partition (ANFISGrid) and fuzzy c-means (ANFISFCM)."""

from __future__ import annotations

import itertools
import numbers

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._checking import checking_split
from greyml._param_validation import Integral, Interval, Real
from greyml._rng import RANDOM_STATE_CONSTRAINT, make_generator
from greyml._threads import blas_threads_for
from greyml._validation import (
    column_names,
    require_y,
    standard_scaling,
    validate_sequences,
)
from greyml.fuzzy._kernels import (
    NO_FIRE_LOG,
    JangStepSize,
    anfis_forward,
    fcm_memberships,
    fuzzy_cmeans,
    hybrid_learning,
)

__all__ = ["ANFISGrid", "ANFISFCM"]

#: Smallest MF width, in units of the input's standard deviation on the
#: training data: a Gaussian narrower than this is a spike, not a fuzzy set.
MIN_WIDTH = 1e-3


class _ANFISBase(RegressorMixin, BaseEstimator):
    """Shared fit/predict of the two ANFIS partitions; subclasses build the
    initial premise (``_initial_premise``)."""

    _parameter_constraints: dict = {
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "step_size": [Interval(Real, 0, None, closed="neither")],
        "step_increase": [Interval(Real, 0, None, closed="neither")],
        "step_decrease": [Interval(Real, 0, None, closed="neither")],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "validation_fraction": [Interval(Real, 0, 1, closed="left")],
        "error_goal": [Interval(Real, 0, None, closed="left")],
        "random_state": RANDOM_STATE_CONSTRAINT,
    }

    def _check_params(self):
        """Checks of a partition's parameters that the constraints cannot say."""

    def _check_common_params(self):
        """What the constraints cannot say: how the two step factors relate."""
        if not self.step_increase >= 1.0 or not self.step_decrease <= 1.0:
            raise ValueError(
                f"{type(self).__name__} needs step_increase >= 1 and step_decrease <= 1 "
                f"(Jang's rule grows then shrinks the step); got {self.step_increase!r} "
                f"and {self.step_decrease!r}."
            )

    def fit(self, X, y, X_val=None, y_val=None):
        """Hybrid learning on training data, keeping the epoch with the lowest
        checking error.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Inputs (sensor readings). With a ``test`` index level, checking
            data taken by ``validation_fraction`` are whole tests.
        y : array-like of shape (n_samples,)
            Target (e.g. displacement in µm).
        X_val, y_val : array-like, optional
            Explicit checking data (MATLAB's ``anfis`` checking data). Give
            either these or ``validation_fraction``, not both.

        Returns
        -------
        self
        """
        self._validate_params()
        self._check_params()
        self._check_common_params()
        name = type(self).__name__
        require_y(self, y)
        if (X_val is None) != (y_val is None):
            raise ValueError(f"{name}.fit needs X_val and y_val together; got only one.")
        if X_val is not None and self.validation_fraction > 0:
            raise ValueError(
                f"{name}.fit got explicit checking data (X_val, y_val) and "
                f"validation_fraction={self.validation_fraction}; give one of them."
            )
        Xa, ya, segments = validate_sequences(
            self,
            X,
            y,
            reset=True,
            min_rows=self._min_rows,
            n_params_msg=self._params_msg,
            reject_constant=True,
            static=True,
        )
        rng = make_generator(self.random_state)
        if X_val is not None:
            Xc, yc, _ = validate_sequences(self, X_val, y_val, reset=False, static=True)
            train, Xt, yt = np.arange(len(ya)), Xa, ya
            self.checking_ = f"explicit checking data ({len(yc)} rows)"
        else:
            train, check, self.checking_ = checking_split(segments, self.validation_fraction, rng)
            Xt, yt = Xa[train], ya[train]
            Xc, yc = Xa[check], ya[check]
            if len(train) < 2:
                raise ValueError(
                    f"{name}: holding out checking data leaves {len(train)} training "
                    "row(s); lower validation_fraction or give more data."
                )

        # a column constant on the training rows (after a hold-out) keeps unit scale
        self.x_mean_, self.x_scale_, self.y_mean_, self.y_scale_ = standard_scaling(Xt, yt)
        # ... and carries no information: the model ignores it (its standardised
        # value is 0 everywhere, in checking data and in predict too), rather
        # than letting a spike-wide MF on it switch off every rule elsewhere
        constant = np.ptp(Xt, axis=0) == 0
        if constant.any():
            self._constant_inputs = constant
        else:  # kept out of ordinary models (and of their saved files)
            self.__dict__.pop("_constant_inputs", None)
        Xs = self._scaled(Xt)
        ys = (yt - self.y_mean_) / self.y_scale_

        c0, s0, mf_of_rule, mf_input = self._initial_premise(Xs, ys, rng)
        step = JangStepSize(self.step_size, self.step_increase, self.step_decrease)
        n_rules, q = mf_of_rule.shape[0], Xs.shape[1] + 1
        n = len(ys)
        # flops of the consequent system: normal equations n·P², or the dual n²(R + q)
        P = n_rules * q
        work = n * P * P if P <= n else n * n * (n_rules + q)
        with blas_threads_for(work):
            result = self._train(Xs, ys, Xc, yc, c0, s0, mf_of_rule, step)
        self._mf_centres = result["mf_centres"]
        self._mf_widths = result["mf_widths"]
        self._mf_of_rule = mf_of_rule
        self._mf_input = mf_input
        self._consequents = result["consequents"]
        self.n_rules_ = int(mf_of_rule.shape[0])
        self.best_epoch_ = int(result["best_epoch"])
        self.n_iter_ = int(len(result["train_error"]))
        self.train_error_ = result["train_error"] * self.y_scale_
        self.check_error_ = result["check_error"] * self.y_scale_
        self.step_size_ = result["step_size"]
        self.target_name_ = str(y.name) if getattr(y, "name", None) is not None else "y"
        self.rules_ = self._readable_rules()
        return self

    def _train(self, Xs, ys, Xc, yc, c0, s0, mf_of_rule, step):
        return hybrid_learning(
            Xs,
            ys,
            c0,
            s0,
            mf_of_rule,
            n_epochs=self.max_iter,
            alpha=self.alpha,
            step=step,
            min_width=MIN_WIDTH,
            X_check=self._scaled(Xc) if len(yc) else None,
            y_check=(yc - self.y_mean_) / self.y_scale_ if len(yc) else None,
            error_goal=self.error_goal / self.y_scale_,
            floor=NO_FIRE_LOG,
        )

    def _scaled(self, X):
        """Standardised inputs; columns constant on the training rows are 0."""
        with np.errstate(over="ignore"):  # |x| near the float limit: inf, handled
            Xs = (X - self.x_mean_) / self.x_scale_
        constant = getattr(self, "_constant_inputs", None)
        if constant is not None and constant.any():
            Xs[:, constant] = 0.0
        return Xs

    def predict(self, X):
        """Output of the fuzzy inference system at every row of ``X``.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        Xa, _, _ = validate_sequences(self, X, reset=False, static=True)
        Xs = self._scaled(Xa)
        with blas_threads_for(Xs.size * self.n_rules_):
            ys = anfis_forward(
                Xs,
                self._mf_centres,
                self._mf_widths,
                self._mf_of_rule,
                self._consequents,
                floor=NO_FIRE_LOG,
            )[0]
        return self.y_mean_ + self.y_scale_ * ys

    # -- readable rules ---------------------------------------------------
    def _readable_rules(self):
        names = column_names(self, self.n_features_in_)
        mu, sx = self.x_mean_, self.x_scale_
        c = self._mf_centres * sx[self._mf_input] + mu[self._mf_input]
        s = self._mf_widths * sx[self._mf_input]
        theta = self._consequents
        # f(x) = θ0 + Σ θj (xj − μj)/sj, in standardised y: back to raw units
        slopes = self.y_scale_ * theta[:, 1:] / sx
        intercepts = self.y_mean_ + self.y_scale_ * theta[:, 0] - slopes @ mu
        rules = []
        for r, mfs in enumerate(self._mf_of_rule):
            rules.append(
                {
                    "if": [(names[j], float(c[k]), float(s[k])) for j, k in enumerate(mfs)],
                    "then": {
                        "intercept": float(intercepts[r]),
                        "coef": {names[j]: float(slopes[r, j]) for j in range(len(names))},
                    },
                }
            )
        return rules

    def describe_rules(self, unit="", target=None, digits=3, max_rules=None):
        """The rules as text, one per line.

        Parameters
        ----------
        unit : str, default=""
            Unit of the inputs, printed after each centre (e.g. ``"°C"``).
        target : str, optional
            Name of the output; by default the name of ``y`` in ``fit`` (a
            Series' name) or ``"y"``.
        digits : int, default=3
            Significant digits.
        max_rules : int, optional
            Print only the first ``max_rules`` rules.

        Returns
        -------
        str
            Lines such as ``IF T18 is about 31.2 °C (σ 1.4) AND … THEN dz = …``.
        """
        check_is_fitted(self)
        target = self.target_name_ if target is None else target
        u = f" {unit}" if unit else ""
        lines = []
        for i, rule in enumerate(self.rules_[:max_rules]):
            cond = " AND ".join(
                f"{name} is about {c:.{digits}g}{u} (σ {s:.{digits}g})" for name, c, s in rule["if"]
            )
            rhs = f"{rule['then']['intercept']:.{digits}g}"
            for name, b in rule["then"]["coef"].items():
                rhs += f" {'-' if b < 0 else '+'} {abs(b):.{digits}g}·{name}"
            lines.append(f"Rule {i + 1}: IF {cond} THEN {target} = {rhs}")
        return "\n".join(lines)


class ANFISGrid(_ANFISBase):
    """ANFIS with a grid partition: ``n_mfs`` Gaussian MFs per input, one rule
    per combination (mⁿ rules).

    First-order Takagi–Sugeno fuzzy inference (Gaussian MFs, product T-norm,
    normalised firing strengths, linear consequents) trained by Jang's hybrid
    learning: on every epoch the consequents are solved by (ridge) least
    squares with the premise fixed, then the MF centres and widths take one
    gradient step whose length follows Jang's step-size rule. The parameters of
    the epoch with the lowest checking error (or training error, without
    checking data) are kept, as MATLAB's ``anfis`` does.

    Read more in the :ref:`User Guide <ug-anfis-grid>`.

    Parameters
    ----------
    n_mfs : int or sequence of int, default=2
        MFs per input (one number for all inputs, or one per input). Abdulshahed et al.'s (2015)
        best: 3 MFs × 5 inputs = 243 rules.
    mf_overlap : float in (0, 1), default=0.4
        Membership at which neighbouring initial MFs cross. The initial MFs of
        each input are spread evenly over its training range with this overlap
        (MATLAB's ``genfis1`` uses 0.5; see Notes).
    max_iter : int, default=100
        Epochs of hybrid learning.
    step_size : float, default=0.01
        Initial step length k of the premise update, in units of the inputs'
        standard deviations (MATLAB's default 0.01).
    step_increase, step_decrease : float, default=1.1, 0.9
        Jang's rule: grow k after four consecutive error reductions, shrink it
        after two consecutive increase/reduction alternations.
    alpha : float, default=1e-6
        Ridge strength of the consequent least squares, relative to the mean
        diagonal of the normal matrix (see Notes).
    validation_fraction : float in [0, 1), default=0.0
        Share of the data held out as checking data: whole tests when ``X`` has
        a ``test`` index level with several tests, else the last rows. 0 uses
        no checking data (and keeps the epoch of lowest training error).
    error_goal : float, default=0.0
        Stop once the training RMSE (in units of y) reaches it.
    max_rules : int, default=1024
        Largest rule base allowed; beyond it ``fit`` raises and suggests
        :class:`ANFISFCM`. Time grows with the rule count times the samples:
        one epoch of 1,024 rules (10 inputs × 2 MFs) on 10⁴ samples took 15 s
        on a 2-core machine (``benchmarks/bench_scaling.py``).
    random_state : int, Generator or None, default=None
        Chooses held-out tests. The global NumPy state is never used.

    Attributes
    ----------
    rules_ : list of dict
        One dict per rule: ``"if"`` a list of (input, centre, σ) in the inputs'
        units, ``"then"`` the consequent's ``"intercept"`` and ``"coef"`` per
        input, in units of y. See :meth:`describe_rules`.
    n_rules_ : int
    best_epoch_ : int
        The epoch (1-based) whose parameters were kept.
    n_iter_ : int
        Epochs run.
    train_error_, check_error_ : ndarray
        RMSE per epoch on training and checking data (units of y).
    step_size_ : ndarray
        Step length per epoch.
    checking_ : str
        What served as checking data.
    x_mean_, x_scale_ : ndarray of shape (``n_features_in_``,)
    y_mean_, y_scale_ : float
        The standardisation applied before training.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)

    See Also
    --------
    ANFISFCM : one rule per fuzzy c-means cluster, for many inputs.

    Notes
    -----
    The initial MFs of each input are spread evenly over its training range,
    adjacent ones crossing at membership ``mf_overlap``. The default 0.4 is a
    little crisper than MATLAB's 0.5: on Jang's two-input sinc benchmark (16
    rules, 250 epochs) a 0.5 crossing leaves hybrid learning in a basin with
    test RMSE 0.035 for every initial step size from 0.005 to 0.1, where 0.3
    or 0.4 reach 0.011-0.025 (``benchmarks/bench_learning_models.py``).
    The consequent least squares has R(p + 1) unknowns (1,458 for 243 rules
    on five inputs), often more than a short test has samples. It is solved
    as ridge regression, λ = ``alpha`` × mean diag(AᵀA), by Cholesky on the
    normal equations or, when unknowns outnumber samples, on the dual
    system AAᵀ + λI; MATLAB's recursive estimator with initial covariance
    γI is the same regularisation with λ = 1/γ. Widths are kept at or above
    10⁻³ standard deviations of their input.
    Where no rule fires (every firing strength below e^−708, the smallest
    normal double: far outside the training data) the prediction is the
    training mean of y, as MATLAB's ``evalfis`` then gives the middle of the
    output range; elsewhere the plain normalised firing strengths are used, bit
    for bit (``greyml.fuzzy._kernels.NO_FIRE_LOG``). An input constant on
    the training rows (a sensor that varies only in the checking data) is
    ignored: its standardised value is taken as 0 in training and prediction.

    References
    ----------
    Jang, J.-S. R. (1993). ANFIS: adaptive-network-based fuzzy inference
    system. IEEE Transactions on Systems, Man, and Cybernetics 23(3), 665-685.
    Abdulshahed, A. M., Longstaff, A. P. and Fletcher, S. (2015). The
    application of ANFIS prediction models for thermal error compensation on
    CNC machine tools. Applied Soft Computing 27, 158-168. (Abdulshahed et al. (2015): ANFIS-Grid
    and ANFIS-FCM, GM(1,N) sensor selection.)
    Abdulshahed, A. M., Longstaff, A. P., Fletcher, S. and Myers, A. (2015).
    Thermal error modelling of machine tools based on ANFIS with fuzzy c-means
    clustering using a thermal imaging camera. Applied Mathematical Modelling
    39, 1837-1852.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml import ANFISGrid
    >>> X = np.linspace(0, 1, 50)[:, None]
    >>> y = np.where(X[:, 0] < 0.5, 2 * X[:, 0], 1.0)
    >>> model = ANFISGrid(n_mfs=3, max_iter=50).fit(X, y)
    >>> model.n_rules_
    3
    >>> bool(np.sqrt(np.mean((model.predict(X) - y) ** 2)) < 0.05)
    True
    """

    def __init__(
        self,
        n_mfs=2,
        *,
        mf_overlap=0.4,
        max_iter=100,
        step_size=0.01,
        step_increase=1.1,
        step_decrease=0.9,
        alpha=1e-6,
        validation_fraction=0.0,
        error_goal=0.0,
        max_rules=1024,
        random_state=None,
    ):
        self.n_mfs = n_mfs
        self.mf_overlap = mf_overlap
        self.max_iter = max_iter
        self.step_size = step_size
        self.step_increase = step_increase
        self.step_decrease = step_decrease
        self.alpha = alpha
        self.validation_fraction = validation_fraction
        self.error_goal = error_goal
        self.max_rules = max_rules
        self.random_state = random_state

    _parameter_constraints: dict = {
        **_ANFISBase._parameter_constraints,
        "n_mfs": [Interval(Integral, 1, None, closed="left"), "array-like"],
        "mf_overlap": [Interval(Real, 0, 1, closed="neither")],
        "max_rules": [Interval(Integral, 1, None, closed="left")],
    }

    def _check_params(self):
        """What the constraints cannot say: every entry of a sequence ``n_mfs``."""
        n = self.n_mfs
        if not isinstance(n, numbers.Integral):
            try:
                values = list(n)
            except TypeError:
                values = None
            if not values or not all(
                isinstance(v, numbers.Integral) and not isinstance(v, bool) and v >= 1
                for v in values
            ):
                raise ValueError(
                    "The 'n_mfs' parameter of ANFISGrid must be an int >= 1 or a "
                    f"sequence of such ints, one per input. Got {n!r} instead."
                )

    def _mfs_per_input(self, n_features):
        if isinstance(self.n_mfs, numbers.Integral):
            return [int(self.n_mfs)] * n_features
        values = [int(v) for v in self.n_mfs]
        if len(values) != n_features:
            raise ValueError(
                f"ANFISGrid got n_mfs for {len(values)} inputs but X has {n_features} "
                "columns; give one number of MFs per column (or one int for all)."
            )
        return values

    def _n_rules(self, n_features):
        return int(np.prod(self._mfs_per_input(n_features), dtype=float))

    def _min_rows(self, n_features):
        n_rules = self._n_rules(n_features)
        if n_rules > self.max_rules:
            mfs = self._mfs_per_input(n_features)
            raise ValueError(
                f"ANFISGrid with n_mfs={self.n_mfs} on {n_features} inputs would have "
                f"{' × '.join(map(str, mfs))} = {n_rules:,} rules, more than "
                f"max_rules={self.max_rules:,}. Use ANFISFCM (one rule per cluster), "
                "fewer MFs, or fewer inputs."
            )
        return n_features + 2

    def _params_msg(self, n_features):
        return f"the {n_features + 1} consequent parameters of a rule (with more than one sample)"

    def _initial_premise(self, Xs, ys, rng):
        mfs = self._mfs_per_input(Xs.shape[1])
        centres, widths, mf_input = [], [], []
        for j, m in enumerate(mfs):
            lo, hi = Xs[:, j].min(), Xs[:, j].max()
            if m == 1:
                centres.append(np.array([(lo + hi) / 2]))
                widths.append(np.array([max(hi - lo, 1.0)]))
            else:
                centres.append(np.linspace(lo, hi, m))
                # neighbours, (hi - lo)/(m - 1) apart, cross at membership mf_overlap
                half_gap = (hi - lo) / (m - 1) / 2
                widths.append(np.full(m, half_gap / np.sqrt(-2 * np.log(self.mf_overlap))))
            mf_input += [j] * m
        offsets = np.cumsum([0] + mfs[:-1])
        mf_of_rule = np.array(
            list(itertools.product(*[range(o, o + m) for o, m in zip(offsets, mfs)])),
            dtype=np.intp,
        ).reshape(-1, len(mfs))
        widths = np.maximum(np.concatenate(widths), MIN_WIDTH)
        return np.concatenate(centres), widths, mf_of_rule, np.asarray(mf_input)


class ANFISFCM(_ANFISBase):
    """ANFIS with one rule per fuzzy c-means cluster.

    Fuzzy c-means (scikit-fuzzy) clusters the standardised input-output data;
    each cluster becomes a rule whose Gaussian MFs sit at the cluster centre
    with the cluster's fuzzy standard deviation along each input. Jang's hybrid
    learning then tunes the rules as in :class:`ANFISGrid`. The rule count is
    ``n_clusters`` whatever the number of inputs.

    Read more in the :ref:`User Guide <ug-anfis-fcm>`.

    Parameters
    ----------
    n_clusters : int, default=3
        Rules (Abdulshahed et al.'s (2015) best: 3).
    m : float, default=2.0
        Fuzziness exponent of c-means (> 1).
    fcm_max_iter : int, default=300
        c-means iterations.
    fcm_max_samples : int, default=10000
        c-means runs on a random subset of at most this many rows (seeded by
        ``random_state``); the memberships of all rows, and the rule widths,
        follow from its centres. Keeps the clustering's cost bounded.
    fcm_tol : float, default=1e-5
        c-means stops when the root-mean-square change of the memberships
        between iterations falls below it (independent of the sample count).
    max_iter, step_size, step_increase, step_decrease, alpha, \
validation_fraction, error_goal
        As in :class:`ANFISGrid`.
    random_state : int, Generator or None, default=None
        Seeds the initial fuzzy partition (passed to scikit-fuzzy as ``init``,
        so its use of NumPy's global random state is never reached) and the
        choice of held-out tests.

    Attributes
    ----------
    cluster_centers_ : ndarray of shape (n_clusters, ``n_features_in_``)
        c-means centres in the inputs' units (before hybrid learning).
    fpc_ : float
        Fuzzy partition coefficient of the clustering (1 = crisp).
    rules_, n_rules_, best_epoch_, n_iter_, train_error_, check_error_, \
step_size_, checking_, x_mean_, x_scale_, y_mean_, y_scale_, n_features_in_, \
feature_names_in_
        As in :class:`ANFISGrid`.

    See Also
    --------
    ANFISGrid : a grid partition, for few inputs.

    Notes
    -----
    Clustering the joint input-output space (as MATLAB's ``genfis3``) puts rules
    where the input-output behaviour differs, not only where inputs are dense.

    References
    ----------
    Abdulshahed, A. M., Longstaff, A. P. and Fletcher, S. (2015). The
    application of ANFIS prediction models for thermal error compensation on
    CNC machine tools. Applied Soft Computing 27, 158-168. (Abdulshahed et al. (2015): ANFIS-Grid
    and ANFIS-FCM, GM(1,N) sensor selection.)
    Abdulshahed, A. M., Longstaff, A. P., Fletcher, S. and Myers, A. (2015).
    Thermal error modelling of machine tools based on ANFIS with fuzzy c-means
    clustering using a thermal imaging camera. Applied Mathematical Modelling
    39, 1837-1852.
    Bezdek, J. C. (1981). Pattern Recognition with Fuzzy Objective Function
    Algorithms. Plenum.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml import ANFISFCM
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(20, 40, size=(200, 2))
    >>> y = np.where(X[:, 0] > 30, 3 * (X[:, 0] - 30), 0) + 0.5 * X[:, 1]
    >>> model = ANFISFCM(n_clusters=3, max_iter=100, random_state=0).fit(X, y)
    >>> model.n_rules_
    3
    >>> bool(np.sqrt(np.mean((model.predict(X) - y) ** 2)) < 1.0)
    True
    """

    def __init__(
        self,
        n_clusters=3,
        *,
        m=2.0,
        fcm_max_iter=300,
        fcm_max_samples=10000,
        fcm_tol=1e-5,
        max_iter=100,
        step_size=0.01,
        step_increase=1.1,
        step_decrease=0.9,
        alpha=1e-6,
        validation_fraction=0.0,
        error_goal=0.0,
        random_state=None,
    ):
        self.n_clusters = n_clusters
        self.m = m
        self.fcm_max_iter = fcm_max_iter
        self.fcm_max_samples = fcm_max_samples
        self.fcm_tol = fcm_tol
        self.max_iter = max_iter
        self.step_size = step_size
        self.step_increase = step_increase
        self.step_decrease = step_decrease
        self.alpha = alpha
        self.validation_fraction = validation_fraction
        self.error_goal = error_goal
        self.random_state = random_state

    _parameter_constraints: dict = {
        **_ANFISBase._parameter_constraints,
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "m": [Interval(Real, 1, None, closed="neither")],
        "fcm_max_iter": [Interval(Integral, 1, None, closed="left")],
        "fcm_max_samples": [Interval(Integral, 2, None, closed="left")],
        "fcm_tol": [Interval(Real, 0, None, closed="neither")],
    }

    def _min_rows(self, n_features):
        return max(n_features + 2, self.n_clusters)

    def _params_msg(self, n_features):
        return (
            f"{self.n_clusters} clusters and the {n_features + 1} consequent parameters of a rule"
        )

    def _initial_premise(self, Xs, ys, rng):
        n, p = Xs.shape
        c = self.n_clusters
        data = np.column_stack([Xs, ys])
        sample = data
        if n > self.fcm_max_samples:
            # c-means converges in more iterations on more rows; the centres of a
            # random subset of fcm_max_samples rows keep the cost linear in n
            rows = np.sort(rng.choice(n, size=self.fcm_max_samples, replace=False))
            sample = data[rows]
        centres, u, _, fpc = fuzzy_cmeans(sample, c, self.m, self.fcm_tol, self.fcm_max_iter, rng)
        if sample is not data:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                u = fcm_memberships(data, centres, float(self.m))
        if not (np.isfinite(centres).all() and np.isfinite(u).all()):
            raise ValueError(
                f"ANFISFCM: fuzzy c-means with {c} clusters and m={self.m} did not "
                "converge to a finite partition; try fewer clusters or a larger m."
            )
        um = u**self.m
        cx = centres[:, :p]
        var = (um @ Xs**2 - 2 * cx * (um @ Xs) + cx**2 * um.sum(axis=1, keepdims=True)) / um.sum(
            axis=1, keepdims=True
        )
        widths = np.sqrt(np.maximum(var, 0.0))
        # a cluster collapsed onto one value of an input is widened to a
        # tenth of that input's spread, so its rule can still learn
        widths = np.where(widths > 1e-2, widths, 0.1)
        self.fpc_ = fpc
        self.cluster_centers_ = cx * self.x_scale_ + self.x_mean_
        mf_of_rule = np.arange(c * p, dtype=np.intp).reshape(c, p)
        mf_input = np.tile(np.arange(p), c)
        return cx.ravel().copy(), widths.ravel().copy(), mf_of_rule, mf_input
