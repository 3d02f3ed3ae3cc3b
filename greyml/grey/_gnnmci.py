"""GNNMCI(1,N): Abdulshahed et al.'s (2016) grey neural network, trained by particle swarm."""

from __future__ import annotations

from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Integral, Interval
from greyml._sequences import segment_label
from greyml._validation import validate_sequences
from greyml.grey._gmc import _GreyConvolutionModel
from greyml.grey._kernels import ago
from greyml.grey._response import gmc_forcing, gmc_initial, gnnmci_layers
from greyml.optimize import ParticleSwarm

__all__ = ["GNNMCI"]


class GNNMCI(_GreyConvolutionModel):
    """Grey neural network model with convolution integral, GNNMCI(1,N).

    Abdulshahed et al. (2016) writes the GMC(1,N) time response (midpoint form) as a four-layer
    network: A, w₁₁k; B, a sigmoid; C, products with the (convolved)
    accumulated inputs; D, a weighted sum minus a bias θ. Inputs are
    accumulated (AGO) per test on the way in and the output is differenced
    (IAGO) on the way out. The weights (w₁₁ = b₁, the driving weights and u)
    are trained by particle swarm optimisation minimising Σ(x̂⁽⁰⁾ − x⁽⁰⁾)² over
    the training tests, with Abdulshahed et al.'s (2016) swarm: 90 particles, c₁ = 1.5,
    c₂ = 2, inertia 0.9 → 0.4, 100 epochs.

    Read more in the :ref:`User Guide <ug-gnnmci>`.

    Parameters
    ----------
    n_population : int, default=90
    max_iter : int, default=100
        Swarm size and epochs (Abdulshahed et al. (2016)).
    c1, c2 : float, default=1.5, 2.0
        Cognitive and social coefficients (Abdulshahed et al. (2016)).
    inertia : (float, float), default=(0.9, 0.4)
        Inertia weight, decreased linearly over the epochs (Abdulshahed et al. (2016)).
    search : {"separable", "full"}, default="separable"
        ``"full"``: the swarm searches every weight, as in Abdulshahed et al. (2016).
        ``"separable"``: it searches w₁₁ = b₁ only, and for each particle the
        remaining weights, on which the output depends linearly, are solved
        exactly by least squares; see :class:`GMC` for why this is the default.
    bounds : {"stable", "papers"} or (float, float) or (array, array), \
            default="stable"
        Search box of the weights (as :class:`GMC`). ``"stable"``: w₁₁ = b₁ in
        [0, 100] and every other weight in [−100, 100]. b₁ < 0 is a response
        that grows like e^{−b₁k}: a heated machine that never settles. On two
        training tests such a trajectory can fit well and then predict values
        beyond 10¹⁰ µm on the next test (simulated gantry, Z and C tests → helical),
        so the default keeps the network stable; ``"papers"`` (the same as
        ``(-100, 100)``) is the unconstrained search of Abdulshahed et al. (2016).
    initial : {"model", "zero"}, default="model"
        The starting value x̂₁⁽¹⁾(1) of each test (w₂₁ = −x̂₁⁽¹⁾(1)), as in
        :class:`GMC`: the target of a new test is unknown when it is predicted.
    polish, warm_start_ls : bool, default=True
        As in :class:`GMC`.
    random_state : int, Generator, RandomState or None, default=None
        Seeds the swarm. The global NumPy state is never used.

    Attributes
    ----------
    development_coef_ : float
        w₁₁ = b₁.
    driving_coef_ : ndarray of shape (``n_features_in_``,)
        The driving weights w₂ⱼ = bⱼ.
    control_ : float
        u.
    loss_ : float
        Σ(x̂⁽⁰⁾ − x⁽⁰⁾)² on the training tests.
    optimizer_result_ : scipy.optimize.OptimizeResult
        The swarm's result (with ``history``).
    n_iter_, n_tests_, n_features_in_, feature_names_in_
        As in :class:`GMC`.

    See Also
    --------
    GMC : the same time response calibrated by least squares, PSO or cuckoo
        search with Abdulshahed et al.'s (2017) settings.

    Notes
    -----
    Layer C multiplies by the sigmoid b = 1/(1 + e^{−b₁k}) and layer D
    multiplies by w₃ = 1 + e^{−b₁k}, so the layers multiply out exactly to the
    GMC midpoint response (:meth:`layer_outputs` shows each layer;
    a test checks they agree). greyml therefore evaluates the network through
    the O(n) response GMC shares, which cannot overflow in
    the layer products when ``|b₁k|`` is large. What distinguishes GNNMCI from
    ``GMC(solver="ls")`` is its training: the weights minimise the error of
    the whole trajectory rather than of the grey differential equation.

    References
    ----------
    Abdulshahed, A. M., Longstaff, A. P., Fletcher, S. and Potdar, A. (2016).
    Thermal error modelling of a gantry-type 5-axis machine tool using a Grey
    Neural Network Model. Journal of Manufacturing Systems 41, 130-142.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml import GNNMCI
    >>> from greyml.grey._functions import simulate_gmc
    >>> rng = np.random.default_rng(0)
    >>> X = 1 + rng.random((60, 2))
    >>> y = simulate_gmc(X, development=0.4, driving=[0.5, -0.2], control=0.1,
    ...                  form="midpoint")
    >>> model = GNNMCI(max_iter=30, random_state=0).fit(X, y)
    >>> round(model.development_coef_, 3)
    0.4
    """

    response = "midpoint"

    _parameter_constraints: dict = {
        **_GreyConvolutionModel._parameter_constraints,
        "n_population": [Interval(Integral, 2, None, closed="left")],
        # the swarm's own settings, passed on unchanged
        **{k: ParticleSwarm._parameter_constraints[k] for k in ("c1", "c2", "inertia")},
    }

    def __init__(
        self,
        n_population=90,
        *,
        max_iter=100,
        c1=1.5,
        c2=2.0,
        inertia=(0.9, 0.4),
        search="separable",
        bounds="stable",
        initial="model",
        polish=True,
        warm_start_ls=True,
        random_state=None,
    ):
        self.n_population = n_population
        self.max_iter = max_iter
        self.c1 = c1
        self.c2 = c2
        self.inertia = inertia
        self.search = search
        self.bounds = bounds
        self.initial = initial
        self.polish = polish
        self.warm_start_ls = warm_start_ls
        self.random_state = random_state

    def _check_params(self):
        return ParticleSwarm(
            n_population=self.n_population,
            max_iter=self.max_iter,
            c1=self.c1,
            c2=self.c2,
            inertia=self.inertia,
        )

    def layer_outputs(self, X):
        """Outputs of layers A–D for every test of ``X``.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)

        Returns
        -------
        list of dict
            One dict per test with the test's label under ``"test"`` and the
            layers as the kernel ``gnnmci_layers`` returns them.
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False, min_samples_per_test=1)
        X1 = ago(Xa, [(seg.start, seg.stop) for seg in segments])
        f = gmc_forcing(X1, self.driving_coef_, self.control_)
        x0 = gmc_initial(f[[seg.start for seg in segments]], self.development_coef_, self.initial)
        out = []
        for seg, start in zip(segments, x0):
            layers = gnnmci_layers(
                X1[seg.slice],
                self.development_coef_,
                self.driving_coef_,
                self.control_,
                float(start),
            )
            layers["test"] = seg.label if seg.label is not None else segment_label(seg)
            out.append(layers)
        return out
