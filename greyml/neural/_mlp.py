"""The multilayer-perceptron baseline of Abdulshahed et al. (2016), as a regressor."""

from __future__ import annotations

import numbers
import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._checking import checking_split
from greyml._param_validation import Integral, Interval, Real, StrOptions
from greyml._rng import RANDOM_STATE_CONSTRAINT, make_generator
from greyml._threads import blas_threads_for
from greyml._validation import (
    require_y,
    standard_scaling,
    validate_sequences,
)
from greyml.exceptions import UnderdeterminedWarning
from greyml.neural._kernels import (
    ACTIVATIONS,
    init_nguyen_widrow,
    levenberg_marquardt,
    mlp_forward,
    n_params,
    pack,
    unpack,
)

__all__ = ["MLPBaseline", "UnderdeterminedWarning"]


class MLPBaseline(RegressorMixin, BaseEstimator):
    """One-hidden-layer perceptron trained by Levenberg–Marquardt (Abdulshahed et al. (2016)).

    The comparison network of Abdulshahed et al. (2016): inputs, one hidden
    layer of log-sigmoid units, one linear output, trained by Levenberg–Marquardt
    on the mean squared error as MATLAB's ``trainlm`` does, with a performance
    goal, an epoch limit and a stop on checking (validation) data. Rows are
    independent samples (a static map from sensor readings to displacement);
    test boundaries matter only for choosing the checking data.

    Read more in the :ref:`User Guide <ug-mlp-baseline>`.

    Parameters
    ----------
    hidden_layer_sizes : int or tuple of one int, default=10
        Hidden units (Abdulshahed et al. (2016): 10, chosen from 1…15). A tuple is accepted for
        symmetry with :class:`sklearn.neural_network.MLPRegressor`, but only one
        hidden layer is supported. ``fit`` needs at least as many rows as the
        network has weights, h·(p + 2) + 1 for p inputs and h hidden units (61
        for 4 sensors and 10 units), to be determined; with fewer it still
        trains (see Notes) and warns (:class:`~greyml.exceptions.UnderdeterminedWarning`).
    activation : {"logistic", "tanh"}, default="logistic"
        Hidden-layer function: log-sigmoid 1/(1 + e⁻ᶻ) (MATLAB's ``logsig``, seed
        000) or tanh (``tansig``). The output is linear.
    max_iter : int, default=5000
        Largest number of Levenberg–Marquardt epochs per initialisation (seed
        000: 5000).
    goal : float, default=1e-4
        Training stops when the training MSE of the *standardised* target
        reaches ``goal`` (Abdulshahed et al. (2016): 1e-4, i.e. R² ≥ 0.9999 on the training rows).
    n_restarts : int, default=5
        Number of random initialisations; the network with the lowest checking
        MSE (the lowest training MSE when ``validation_fraction=0``) is kept.
    validation_fraction : float in [0, 1), default=0.15
        Share of the data held out as checking data for the validation stop
        (MATLAB's default division keeps 15 % for validation). With several
        tests (a ``test`` index level), whole tests are held out, chosen at
        random; with one test, its last rows. 0 disables the validation stop.
    max_fail : int, default=6
        Stop after this many consecutive epochs without a new lowest checking
        MSE and keep the weights of the lowest one (MATLAB's ``max_fail``).
    random_state : int, Generator, RandomState or None, default=None
        Seeds the initial weights and the choice of held-out tests. The global
        NumPy state is never used.

    Attributes
    ----------
    coefs_ : list of two ndarrays
        Weights in the standardised space, as in ``MLPRegressor``:
        ``coefs_[0]`` of shape (``n_features_in_``, n_hidden) (inputs to hidden),
        ``coefs_[1]`` of shape (n_hidden, 1) (hidden to output).
    intercepts_ : list of two ndarrays
        Biases: ``intercepts_[0]`` of shape (n_hidden,), ``intercepts_[1]`` of
        shape (1,).
    x_mean_, x_scale_ : ndarray of shape (``n_features_in_``,)
        Mean and standard deviation of each column of ``X`` in ``fit``; the
        network sees ``(X − x_mean_) / x_scale_``.
    y_mean_, y_scale_ : float
        Mean and standard deviation of ``y`` in ``fit`` (``y_scale_`` is 1 for a
        constant target); the prediction is ``y_mean_ + y_scale_ ·`` network output.
    loss_ : float
        Training MSE of the kept network on the standardised target (the
        quantity compared with ``goal``; times ``y_scale_**2`` in units of y²).
    best_validation_loss_ : float or None
        Checking MSE of the kept network on the standardised target; ``None``
        when ``validation_fraction=0``.
    n_iter_ : int
        Epochs run by the kept initialisation.
    best_iter_ : int
        Epoch whose weights were kept (before ``n_iter_`` under the validation
        stop).
    stop_reason_ : str
        Why the kept initialisation stopped: ``"goal"``, ``"max_iter"``,
        ``"max_fail"`` (validation stop), ``"min_grad"`` (gradient below 1e-7)
        or ``"mu_max"`` (damping above 1e10: no step lowers the error).
    checking_ : str
        Which rows were held out as checking data.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)

    See Also
    --------
    sklearn.neural_network.MLPRegressor : first-order (Adam, SGD) or L-BFGS
        training of deeper networks.
    greyml.ANFISFCM : the fuzzy model it is the baseline for.

    Notes
    -----
    **Training.** Levenberg–Marquardt as in ``trainlm`` (Hagan and Menhaj,
    1994): each epoch solves (JᵀJ + μI)δ = Jᵀr with the analytic Jacobian J of
    the residuals r, accepts the step if it lowers the training MSE (then
    μ ← μ/10) and otherwise raises μ tenfold and solves again; μ starts at 1e-3.
    It is implemented here (``levenberg_marquardt``) rather
    than with ``scipy.optimize.least_squares(method="lm")`` because MINPACK's
    ``lm`` accepts no callback (SciPy 1.17 offers one for ``"trf"`` and
    ``"dogbox"`` only), so the validation stop would need a run in chunks of
    ``max_nfev``, each restarting MINPACK's damping and scaling from scratch.
    On the benchmark below that route reached a higher training MSE in 400
    function evaluations (about 1.3 s) than this loop does in 200 epochs (about
    0.14 s): MINPACK factorises the n × p Jacobian by QR each iteration, while a
    Cholesky factorisation of the p × p matrix JᵀJ + μI costs little for the
    few hundred weights of a baseline network.

    **Standardisation.** ``X`` and ``y`` are standardised with the statistics
    of all rows given to ``fit`` (MATLAB maps them to [−1, 1]), so the same
    defaults serve temperatures in °C and displacements in µm; the weights are
    initialised by the Nguyen–Widrow rule for that scale.

    **Rows and weights.** Fewer training rows than weights is allowed, as in
    MATLAB: the damping μ keeps every step defined, and the goal or the
    validation stop ends training. ``fit`` then warns
    (:class:`~greyml.exceptions.UnderdeterminedWarning`), since such a network can interpolate
    its training rows; it needs at least two rows. Size the network by
    cross-validation (Abdulshahed et al. (2016) tried 1 to 15 hidden units), e.g.
    ``GridSearchCV`` over ``hidden_layer_sizes`` with
    ``LeaveOneGroupOut`` on the tests; refusing large networks on small folds
    would make such a search fail part-way.

    **Threads.** An epoch's dominant product, JᵀJ, is small for a baseline
    network (13 Mflop for 1275 rows and 71 weights); below
    ``greyml._threads.SMALL_WORK`` flops training runs with one BLAS thread,
    which made epochs several times faster on a busy 2-core machine.

    **Benchmark.** On ``make_friedman1(n_samples=2000, n_features=5,
    noise=1.0, random_state=0)`` split 75/25 (``random_state=0``) the noise
    alone gives a test RMSE of 0.987. The defaults measured a test RMSE of
    0.996-1.044 (median 1.017) over ``random_state`` 0-19, in 0.1-0.3 s per fit
    on two cores. The gap is estimation error, not a training failure: fitted
    to the noise-free function the same network is within 0.03 of it, but 71
    weights fitted to 1500 rows with noise σ add about σ√(71/1500) ≈ 0.22 in
    quadrature. Fewer hidden units (``GridSearchCV``) trade that against bias.

    References
    ----------
    Abdulshahed, A. M., Longstaff, A. P., Fletcher, S. and Potdar, A. (2016).
    Thermal error modelling of a gantry-type 5-axis machine tool using a Grey
    Neural Network Model. Journal of Manufacturing Systems 41, 130-142.
    Hagan, M. T. and Menhaj, M. B. (1994). Training feedforward networks with
    the Marquardt algorithm. IEEE Transactions on Neural Networks 5(6), 989-993.
    Nguyen, D. and Widrow, B. (1990). Improving the learning speed of 2-layer
    neural networks by choosing initial values of the adaptive weights. IJCNN
    1990, vol. 3, 21-26.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.neural import MLPBaseline
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(300, 2))
    >>> y = np.sin(2 * X[:, 0]) + X[:, 1] ** 2
    >>> model = MLPBaseline(hidden_layer_sizes=5, random_state=0).fit(X, y)
    >>> model.coefs_[0].shape, model.coefs_[1].shape
    ((2, 5), (5, 1))
    >>> bool(model.score(X, y) > 0.999)
    True
    """

    _parameter_constraints: dict = {
        "hidden_layer_sizes": [Interval(Integral, 1, None, closed="left"), tuple, list],
        "activation": [StrOptions(set(ACTIVATIONS))],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "goal": [Interval(Real, 0, None, closed="left")],
        "n_restarts": [Interval(Integral, 1, None, closed="left")],
        "validation_fraction": [Interval(Real, 0, 1, closed="left")],
        "max_fail": [Interval(Integral, 1, None, closed="left")],
        "random_state": RANDOM_STATE_CONSTRAINT,
    }

    def __init__(
        self,
        hidden_layer_sizes=10,
        *,
        activation="logistic",
        max_iter=5000,
        goal=1e-4,
        n_restarts=5,
        validation_fraction=0.15,
        max_fail=6,
        random_state=None,
    ):
        self.hidden_layer_sizes = hidden_layer_sizes
        self.activation = activation
        self.max_iter = max_iter
        self.goal = goal
        self.n_restarts = n_restarts
        self.validation_fraction = validation_fraction
        self.max_fail = max_fail
        self.random_state = random_state

    # -- parameter checks -------------------------------------------------
    def _n_hidden(self):
        sizes = self.hidden_layer_sizes
        if isinstance(sizes, (tuple, list)):
            if len(sizes) > 1:
                raise ValueError(
                    f"{type(self).__name__} supports one hidden layer only: "
                    f"hidden_layer_sizes={sizes!r} asks for {len(sizes)} hidden layers. "
                    "Give an int or a 1-tuple such as (10,)."
                )
            if len(sizes) == 1:
                sizes = sizes[0]
        ok = isinstance(sizes, numbers.Integral) and not isinstance(sizes, bool) and sizes >= 1
        if not ok:
            raise ValueError(
                f"The 'hidden_layer_sizes' parameter of {type(self).__name__} must be "
                "an int in the range [1, inf) or a tuple of one such int. Got "
                f"{self.hidden_layer_sizes!r} instead."
            )
        return int(sizes)

    # -- fit / predict ----------------------------------------------------
    def fit(self, X, y):
        """Train the network, keeping the best of ``n_restarts`` initialisations.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Inputs (sensor readings). With a ``test`` level in the row index,
            checking data are whole tests.
        y : array-like or Series of shape (n_samples,)
            The target (e.g. displacement in µm).

        Returns
        -------
        self : MLPBaseline
        """
        self._validate_params()
        n_hidden = self._n_hidden()
        fraction = float(self.validation_fraction)
        require_y(self, y)
        Xa, ya, segments = validate_sequences(
            self,
            X,
            y,
            reset=True,
            min_rows=2,
            n_params_msg=lambda p: f"a {p}-{n_hidden}-1 network",
            reject_constant=True,
            static=True,
        )
        rng = make_generator(self.random_state)
        train, check, self.checking_ = checking_split(segments, fraction, rng)

        self.x_mean_, self.x_scale_, self.y_mean_, self.y_scale_ = standard_scaling(Xa, ya)
        Xs = (Xa - self.x_mean_) / self.x_scale_
        ys = (ya - self.y_mean_) / self.y_scale_
        X_val, y_val = (Xs[check], ys[check]) if check.size else (None, None)
        X_fit, y_fit = Xs[train], ys[train]

        best = None
        n_par = n_params(Xa.shape[1], n_hidden)
        if train.size < n_par:
            fits = (train.size - 1) // (Xa.shape[1] + 2)
            advice = (
                f"hidden_layer_sizes={fits} or fewer is determined"
                if fits >= 1
                else "more rows are needed for a determined fit"
            )
            warnings.warn(
                f"{type(self).__name__} is under-determined: {train.size} training rows for "
                f"the {n_par} weights of a {Xa.shape[1]}-{n_hidden}-1 network. "
                f"Levenberg-Marquardt's damping keeps the fit defined, but it can interpolate "
                f"the training rows; {advice}.",
                UnderdeterminedWarning,
                stacklevel=2,
            )
        # the dominant product of an epoch is JᵀJ: 2 · rows · n_params² flops
        with blas_threads_for(2.0 * train.size * n_par**2):
            for _ in range(self.n_restarts):
                p0 = init_nguyen_widrow(Xa.shape[1], n_hidden, rng, self.activation)
                result = levenberg_marquardt(
                    X_fit,
                    y_fit,
                    p0,
                    n_hidden,
                    self.activation,
                    X_val=X_val,
                    y_val=y_val,
                    max_iter=self.max_iter,
                    goal=float(self.goal),
                    max_fail=self.max_fail,
                )
                key = result.loss if result.val_loss is None else result.val_loss
                if best is None or key < best[0]:
                    best = (key, result)
        result = best[1]
        W, b, v, c = unpack(result.p, Xa.shape[1], n_hidden)
        self.coefs_ = [W.copy(), v.reshape(-1, 1).copy()]
        self.intercepts_ = [b.copy(), np.array([c])]
        self.loss_ = float(result.loss)
        self.best_validation_loss_ = None if result.val_loss is None else float(result.val_loss)
        self.n_iter_ = int(result.n_iter)
        self.best_iter_ = int(result.best_iter)
        self.stop_reason_ = result.stop
        return self

    def predict(self, X):
        """Predict the target of every row of ``X``.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        Xa, _, _ = validate_sequences(self, X, reset=False, static=True)
        Xs = (Xa - self.x_mean_) / self.x_scale_
        p = pack(self.coefs_[0], self.intercepts_[0], self.coefs_[1], self.intercepts_[1])
        n_hidden = self.coefs_[0].shape[1]
        return mlp_forward(Xs, p, n_hidden, self.activation) * self.y_scale_ + self.y_mean_
