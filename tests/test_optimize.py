import pickle

import numpy as np
import pytest

from greyml.optimize import CuckooSearch, ParticleSwarm
from greyml.optimize._cuckoo import levy_steps, mantegna_sigma

OPTIMIZERS = [ParticleSwarm, CuckooSearch]  # classes: each test makes its own


def sphere(P):
    return ((P - 1.5) ** 2).sum(axis=1)


def rastrigin(P):
    return 10 * P.shape[1] + (P**2 - 10 * np.cos(2 * np.pi * P)).sum(axis=1)


@pytest.mark.parametrize("make", OPTIMIZERS, ids=lambda c: c.__name__)
def test_sphere_converges(make):
    res = (
        make().set_params(max_iter=300).minimize(sphere, (-5, 5), np.random.default_rng(0), n_dim=4)
    )
    np.testing.assert_allclose(res.x, 1.5, atol=1e-3)
    assert res.history.shape == (300,) and np.all(np.diff(res.history) <= 0)


@pytest.mark.parametrize("make", OPTIMIZERS, ids=lambda c: c.__name__)
def test_rastrigin_budget_25x100(make):
    opt = make()
    # the benchmark's budget; a random search with the same budget gets ~60
    res = opt.minimize(rastrigin, (-5.12, 5.12), np.random.default_rng(1), n_dim=10)
    assert res.fun < 35
    expected = 25 * 101 if isinstance(opt, ParticleSwarm) else 25 * 201
    assert res.nfev == expected


@pytest.mark.parametrize("make", OPTIMIZERS, ids=lambda c: c.__name__)
def test_same_seed_same_result_and_global_state_untouched(make):
    opt = make()
    state = np.random.get_state()
    a = opt.minimize(rastrigin, (-5.12, 5.12), np.random.default_rng(7), n_dim=5)
    b = opt.minimize(rastrigin, (-5.12, 5.12), np.random.default_rng(7), n_dim=5)
    after = np.random.get_state()
    assert a.fun == b.fun and np.array_equal(a.x, b.x)
    assert (
        all(np.array_equal(u, v) for u, v in zip(state[1:2], after[1:2])) and state[2:] == after[2:]
    )


@pytest.mark.parametrize("make", OPTIMIZERS, ids=lambda c: c.__name__)
def test_nan_and_inf_losses_are_penalised(make):
    opt = make()

    def nasty(P):
        out = sphere(P)
        out[P[:, 0] < 0] = np.nan
        out[P[:, 1] < 0] = np.inf
        return out

    res = opt.minimize(nasty, (-5, 5), np.random.default_rng(0), n_dim=2)
    assert np.isfinite(res.fun) and res.fun < 1e-2


@pytest.mark.parametrize("make", OPTIMIZERS, ids=lambda c: c.__name__)
def test_x0_is_used(make):
    res = (
        make()
        .set_params(max_iter=1)
        .minimize(sphere, (-5, 5), np.random.default_rng(0), x0=[[1.5, 1.5]])
    )
    assert res.fun == 0.0


@pytest.mark.parametrize(
    "bounds, match",
    [
        ((1.0, -1.0), "lower 1 is not below upper -1"),
        ((0, np.inf), "finite"),
        (3.0, "pair"),
    ],
)
def test_bad_bounds(bounds, match):
    with pytest.raises(ValueError, match=match):
        ParticleSwarm().minimize(sphere, bounds, np.random.default_rng(0), n_dim=2)


@pytest.mark.parametrize(
    "opt, match",
    [
        (
            ParticleSwarm(n_population=0),
            r"'n_population' parameter of ParticleSwarm must be an int in the range \[1, inf\). Got 0",
        ),
        (ParticleSwarm(max_iter=0), "'max_iter'"),
        (ParticleSwarm(inertia=0.5), "'inertia'"),
        (
            CuckooSearch(pa=1.5),
            r"'pa' parameter of CuckooSearch must be a float in the range \[0.0, 1.0\]",
        ),
        (CuckooSearch(n_population=1), "'n_population'"),
        (CuckooSearch(beta=3.0), "'beta'"),
    ],
)
def test_bad_settings(opt, match):
    with pytest.raises(ValueError, match=match):
        opt.minimize(sphere, (-1, 1), np.random.default_rng(0), n_dim=2)


def test_rng_must_be_generator():
    with pytest.raises(TypeError, match="numpy.random.Generator"):
        ParticleSwarm().minimize(sphere, (-1, 1), 0, n_dim=2)


def test_objective_must_return_one_value_per_row():
    with pytest.raises(ValueError, match="one loss per row"):
        ParticleSwarm().minimize(lambda P: np.zeros(3), (-1, 1), np.random.default_rng(0), n_dim=2)


def test_mantegna_sigma_closed_form():
    # β = 1.5: σ = [Γ(2.5)·sin(0.75π) / (Γ(1.25)·1.5·2^0.25)]^(1/1.5) ≈ 0.6966
    assert mantegna_sigma(1.5) == pytest.approx(0.696575, rel=1e-5)


def test_levy_steps_heavy_tailed():
    s = levy_steps((200_000,), 1.5, np.random.default_rng(0))
    # heavier tails than a Gaussian of the same median absolute step
    mad = np.median(np.abs(s))
    assert np.mean(np.abs(s) > 10 * mad) > 0.01


def test_optimizers_pickle_and_compare():
    opt = CuckooSearch(n_population=10)
    assert pickle.loads(pickle.dumps(opt)) == opt
    # scikit-learn's repr: the settings that differ from the defaults
    assert repr(ParticleSwarm()) == "ParticleSwarm()"
    assert repr(ParticleSwarm(n_population=10, c1=1.5)) == "ParticleSwarm(c1=1.5, n_population=10)"
