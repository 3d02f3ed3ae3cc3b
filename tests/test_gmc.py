"""GMC: coefficient recovery, tests as sequences, determinism, bad input."""

import warnings

import numpy as np
import pandas as pd
import pytest
from conftest import TRUE_B, TRUE_B1, TRUE_U, exciting_drivers
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import GMC, groups_of, make_test_index
from greyml.exceptions import GreyConditioningWarning, GreyStabilityWarning, GreyWarmStartWarning
from greyml.grey._functions import simulate_gmc
from greyml.grey._kernels import gmc_design
from greyml.optimize import ParticleSwarm

SENSORS = ["T1_C", "T2_C", "T3_C", "T4_C"]


def recovery_problem(seed, n=200, noise=0.01):
    rng = np.random.default_rng(seed)
    X = exciting_drivers(rng, n)
    y_true = simulate_gmc(X, TRUE_B1, TRUE_B, TRUE_U)
    y_meas = y_true + rng.normal(scale=noise * np.abs(y_true).max(), size=n)
    return X, y_true, y_meas


@pytest.mark.parametrize("solver", ["pso", "cs"])
@pytest.mark.parametrize("warm_start_ls", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_metaheuristics_recover_the_model(solver, warm_start_ls, seed):
    """60 samples from the GMC response with known (b₁, bⱼ, u), 4 drivers; the
    later, unseen 140 samples are measured with noise: the calibrated model's RMSE
    there is within 2 % of the true model's."""
    X, y_true, y_meas = recovery_problem(seed)
    model = GMC(solver=solver, warm_start_ls=warm_start_ls, random_state=seed).fit(
        X[:60], y_true[:60]
    )
    later = slice(60, None)
    rmse_model = np.sqrt(np.mean((model.predict(X)[later] - y_meas[later]) ** 2))
    rmse_true = np.sqrt(np.mean((y_true[later] - y_meas[later]) ** 2))
    assert rmse_model <= 1.02 * rmse_true
    assert model.development_coef_ == pytest.approx(TRUE_B1, abs=1e-3)


def test_ls_solver_against_truth():
    """The LS solver fits the grey equation with background values, not the time
    response, so on data from the response its coefficients are biased: recorded
    here with numbers, not hidden."""
    X, y_true, _ = recovery_problem(0)
    model = GMC(solver="ls").fit(X[:60], y_true[:60])
    assert model.development_coef_ == pytest.approx(TRUE_B1, abs=0.02)
    np.testing.assert_allclose(model.driving_coef_, TRUE_B, atol=0.03)
    err = np.abs(model.predict(X)[60:] - y_true[60:]).max()
    assert 1e-4 < err < 0.05 * np.abs(y_true).max()


def test_full_search_of_the_seeds_is_available():
    X, y_true, _ = recovery_problem(0)
    model = GMC(solver="pso", search="full", random_state=0).fit(X[:60], y_true[:60])
    ls = GMC().fit(X[:60], y_true[:60])
    assert model.loss_ <= ls.loss_  # warm-started with LS, never worse


def test_midpoint_response_is_recovered():
    rng = np.random.default_rng(0)
    X = exciting_drivers(rng, 80)
    y = simulate_gmc(X, 0.2, TRUE_B, 1.0, form="midpoint", initial="zero")
    model = GMC(solver="pso", response="midpoint", initial="zero", random_state=0).fit(X, y)
    np.testing.assert_allclose(model.predict(X), y, atol=1e-6 * np.abs(y).max())


def test_multi_test_cross_validation(gmc_tests):
    X, y = gmc_tests[SENSORS], gmc_tests["dz_um"]
    scores = cross_val_score(
        GMC(solver="pso", random_state=0),
        X,
        y,
        groups=groups_of(X),
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    )
    assert scores.shape == (4,)
    # exact data from one model: every held-out test is predicted almost exactly
    assert np.all(-scores < 1e-6 * np.abs(y).max())


def test_no_accumulation_crosses_a_test_boundary(gmc_tests):
    X, y = gmc_tests[SENSORS], gmc_tests["dz_um"]
    model = GMC(solver="ls").fit(X, y)
    pred = pd.Series(model.predict(X), index=X.index)
    order = ["III", "I", "IV", "II"]
    shuffled = pd.concat([X.loc[[t]] for t in order])
    pred2 = pd.Series(model.predict(shuffled), index=shuffled.index)
    for t in order:
        np.testing.assert_array_equal(pred.loc[t].to_numpy(), pred2.loc[t].to_numpy())
        alone = model.predict(X.loc[[t]])
        np.testing.assert_array_equal(alone, pred.loc[t].to_numpy())
    # fitting on reordered tests gives the same coefficients
    refit = GMC(solver="ls").fit(shuffled, y.loc[shuffled.index])
    np.testing.assert_allclose(refit.driving_coef_, model.driving_coef_, rtol=1e-10)
    # and the same data read as one long test gives something else
    flat = GMC(solver="ls").fit(X.to_numpy(), y.to_numpy())
    assert not np.allclose(flat.driving_coef_, model.driving_coef_, rtol=1e-3)


def test_new_test_starts_from_its_own_first_drivers(gmc_tests):
    """predict needs no target: a test's response starts at f(1)/(1 + b₁) (initial="model")."""
    X, y = gmc_tests[SENSORS], gmc_tests["dz_um"]
    model = GMC(solver="pso", random_state=0).fit(X.drop(index="IV"), y.drop(index="IV"))
    new = X.loc[["IV"]]
    pred = model.predict(new)
    f1 = new.iloc[0].to_numpy() @ model.driving_coef_ + model.control_
    assert pred[0] == pytest.approx(f1 / (1 + model.development_coef_), rel=1e-12)
    np.testing.assert_allclose(pred, y.loc["IV"].to_numpy(), atol=1e-6 * np.abs(y).max())
    zero = GMC(solver="ls", initial="zero").fit(X, y)
    assert zero.predict(new)[0] == 0.0


def test_pipeline_and_grid_search(gmc_tests):
    X, y = gmc_tests[SENSORS], gmc_tests["dz_um"]
    # scaling without centring: GMC is invariant to driver units, not to offsets
    pipe = make_pipeline(
        StandardScaler(with_mean=False).set_output(transform="pandas"),
        GMC(random_state=0),
    )
    grid = GridSearchCV(
        pipe,
        {"gmc__solver": ["ls", "pso"]},
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    ).fit(X, y, groups=groups_of(X))
    assert grid.best_params_["gmc__solver"] == "pso"
    assert -grid.best_score_ < 1e-6 * np.abs(y).max()


@pytest.mark.parametrize("solver", ["pso", "cs"])
def test_bit_identical_and_global_state_untouched(solver, gmc_tests):
    X, y = gmc_tests[SENSORS], gmc_tests["dz_um"]
    state = np.random.get_state()
    a = GMC(solver=solver, search="full", random_state=3).fit(X, y).predict(X)
    b = GMC(solver=solver, search="full", random_state=3).fit(X, y).predict(X)
    after = np.random.get_state()
    assert np.array_equal(a, b)
    assert np.array_equal(state[1], after[1]) and state[2:] == after[2:]
    c = GMC(solver=solver, random_state=None).fit(X, y)  # fresh OS entropy, not the global state
    after2 = np.random.get_state()
    assert np.array_equal(state[1], after2[1]) and c.loss_ >= 0


def test_fit_does_not_modify_inputs(gmc_tests):
    X, y = gmc_tests[SENSORS].copy(), gmc_tests["dz_um"].copy()
    X0, y0 = X.copy(), y.copy()
    GMC(solver="pso", random_state=0).fit(X, y).predict(X)
    pd.testing.assert_frame_equal(X, X0)
    pd.testing.assert_series_equal(y, y0)


def test_optimizer_instance_as_solver(gmc_tests):
    X, y = gmc_tests[SENSORS], gmc_tests["dz_um"]
    model = GMC(solver=ParticleSwarm(n_population=10, max_iter=30), random_state=0).fit(X, y)
    # 10 × 31 population evaluations, then the Brent polish
    assert model.optimizer_result_.nfev > 10 * 31 and model.n_iter_ == 30


def test_prediction_that_diverges_raises():
    rng = np.random.default_rng(0)
    X = exciting_drivers(rng, 40)
    model = GMC().fit(X, simulate_gmc(X, 0.3, TRUE_B, 0.0))
    model.development_coef_ = -50.0
    with pytest.raises(ValueError, match="diverges in the single test"):
        model.predict(X)


# ---- bad input names the column and the test -----------------------------------------
def _frame(gmc_tests):
    return gmc_tests[SENSORS].copy(), gmc_tests["dz_um"].copy()


@pytest.mark.parametrize("solver", ["ls", "pso", "cs"])
@pytest.mark.parametrize(
    "corrupt, match",
    [
        (
            lambda X, y: X.iloc.__setitem__((85, 2), np.nan),
            r"column 'T3_C' has NaN in test 'II' at row 85",
        ),
        (
            lambda X, y: X.iloc.__setitem__((3, 0), np.inf),
            r"column 'T1_C' has infinity \(inf\) in test 'I' at row 3",
        ),
        (
            lambda X, y: y.iloc.__setitem__(200, np.nan),
            r"Input y contains NaN: the target y has NaN in test 'III'",
        ),
        (
            lambda X, y: X.__setitem__("T4_C", 21.5),
            r"Column 'T4_C' is constant \(21.5\) in every row of test 'I', test 'II'",
        ),
    ],
)
def test_bad_values_name_column_and_test(solver, corrupt, match, gmc_tests):
    X, y = _frame(gmc_tests)
    corrupt(X, y)
    with pytest.raises(ValueError, match=match):
        GMC(solver=solver, max_iter=2).fit(X, y)


def test_test_with_one_row():
    idx = make_test_index(["A"] * 20 + ["B"], list(range(20)) + [0])
    X = pd.DataFrame(np.random.default_rng(0).random((21, 2)), index=idx, columns=["T1_C", "T2_C"])
    with pytest.raises(
        ValueError, match="Test 'B' has 1 sample; GMC needs at least 2 samples per test"
    ):
        GMC().fit(X, np.arange(21.0))


def test_too_few_samples_for_coefficients():
    X = np.random.default_rng(0).random((5, 4))
    with pytest.raises(
        ValueError,
        match=r"too few samples to fit 6 coefficients .* 5 samples in 1 test\(s\) give 4 equations",
    ):
        GMC().fit(X, np.arange(5.0))


def test_nan_in_predict_names_test(gmc_tests):
    X, y = _frame(gmc_tests)
    model = GMC().fit(X, y)
    X.iloc[300, 1] = np.nan
    with pytest.raises(ValueError, match=r"column 'T2_C' has NaN in test 'IV'"):
        model.predict(X)


def test_mismatched_columns(gmc_tests):
    X, y = _frame(gmc_tests)
    model = GMC().fit(X, y)
    with pytest.raises(ValueError, match="feature names"):
        model.predict(X[SENSORS[::-1]])


@pytest.mark.parametrize(
    "params, match",
    [
        ({"solver": "bfgs"}, "'solver' parameter of GMC must be"),
        (
            {"solver": "pso", "n_population": 1},
            r"'n_population' parameter of GMC must be an int in the range \[2, inf\)",
        ),
        ({"solver": "pso", "bounds": (5, -5)}, "lower 5 is not below upper -5"),
        (
            {"solver": "cs", "bounds": 5.0},
            r"'bounds' parameter of GMC must be.*array-like. Got 5.0",
        ),
        (
            {"solver": "pso", "bounds": ([0, 1], [1, 2])},
            "bounds must be scalars or arrays of length 6",
        ),
        ({"response": "euler"}, "'response' parameter"),
        ({"search": "grid"}, "'search' parameter"),
        ({"bounds": "wide"}, "'bounds' parameter of GMC must be a str among"),
    ],
)
def test_bad_parameters(params, match, gmc_tests):
    X, y = _frame(gmc_tests)
    with pytest.raises(ValueError, match=match):
        GMC(**params).fit(X, y)


def _unstable_data():
    """A drift that grows faster and faster under a steady driver: least
    squares can only fit it with b1 < 0."""
    X = np.linspace(1.0, 2.0, 40)[:, None]
    return X, np.exp(0.05 * np.arange(40))


def test_least_squares_warns_when_unstable():
    X, y = _unstable_data()
    with pytest.warns(GreyStabilityWarning, match=r"b1 = -0\.\d+ < 0.*factor .* over the longest"):
        model = GMC(solver="ls", bounds="papers").fit(X, y)
    assert model.development_coef_ < 0


def test_default_bounds_keep_b1_non_negative_and_papers_box_is_named():
    X, y = _unstable_data()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the default box: no GreyStabilityWarning
        default = GMC().fit(X, y)
    assert default.development_coef_ == 0.0
    boxed = GMC(bounds=(0.0, 100.0)).fit(X, y)
    np.testing.assert_array_equal(default.predict(X), boxed.predict(X))
    with pytest.warns(GreyStabilityWarning):
        papers = GMC(bounds="papers").fit(X, y)
    with pytest.warns(GreyStabilityWarning):
        free = GMC(bounds=(-100.0, 100.0)).fit(X, y)
    assert papers.development_coef_ == free.development_coef_ < 0
    # the swarm's box too: b1 in [0, 100] by default, [-100, 100] by name
    for bounds, lower in [("stable", 0.0), ("papers", -100.0)]:
        lo, hi = GMC(bounds=bounds)._search_bounds(4)
        np.testing.assert_array_equal(lo, [lower, -100, -100, -100])
        np.testing.assert_array_equal(hi, [100.0] * 4)


def test_least_squares_says_why_its_response_overflows():
    # an alternating drift whose least-squares b1 is -202: in the papers' box it
    # is set to -100, whose response overflows; the default box sets it to 0
    Y = (-1.02) ** np.arange(40)
    X, y = np.linspace(1.0, 2.0, 40)[:, None], np.r_[Y[0], np.diff(Y)]
    match = (
        r"GMC\(solver='ls'\) calibration failed: least squares on the grey equation gives "
        r"b1 = -202, outside bounds, so b1 was set to their nearer end, -100; .*overflows"
    )
    with pytest.warns(GreyStabilityWarning), pytest.raises(ValueError, match=match):
        GMC(bounds="papers").fit(X, y)
    assert GMC().fit(X, y).development_coef_ == 0.0


def static_case(seed=0):
    """Issue 15's two tests of 60 rows: a static mix of saturating inputs."""
    t = np.arange(120.0)
    noise = np.random.default_rng(seed).normal(scale=0.01, size=120)
    X = np.column_stack(
        [1 - np.exp(-t / 20), 1 - np.exp(-t / 35), 0.5 * (1 - np.exp(-t / 50)), 0.2 + noise]
    )
    index = make_test_index(np.repeat(["A", "B"], 60), 60.0 * np.r_[np.arange(60), np.arange(60)])
    X = pd.DataFrame(X, index=index, columns=["a", "b", "c", "d"])
    return X, pd.Series(X.to_numpy() @ [3.0, -1.0, 2.0, 0.5], index=index, name="y")


def test_default_gmc_fits_a_static_mix_of_saturating_inputs():
    X, y = static_case()
    # the static target makes the grey equation rank deficient (a line of
    # equally good least-squares solutions); its minimum-norm b1 is -0.41
    with pytest.warns(GreyConditioningWarning):
        model = GMC().fit(X, y)
    assert model.development_coef_ == 0.0
    rmse = float(np.sqrt(np.mean((model.predict(X) - y) ** 2)))
    assert 0.40 < rmse < 0.43, rmse  # measured 0.419, target std 0.715
    with pytest.warns(GreyConditioningWarning):
        swarm = GMC(solver="pso", random_state=0).fit(X, y)
    rmse_swarm = float(np.sqrt(np.mean((swarm.predict(X) - y) ** 2)))
    assert rmse_swarm < 0.1, rmse_swarm  # measured 0.098, b1 = 1.23
    # the papers' box keeps least squares' b1 < 0, whose response explodes
    with pytest.warns(GreyConditioningWarning), pytest.warns(GreyStabilityWarning):
        papers = GMC(bounds="papers").fit(X, y)
    assert np.abs(papers.predict(X) - y).max() > 1e6


def test_least_squares_keeps_b1_in_its_bounds():
    X, y = _unstable_data()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no GreyStabilityWarning: b1 is kept at 0
        model = GMC(solver="ls", bounds=(0.0, 100.0)).fit(X, y)
    assert model.development_coef_ == 0.0
    # the other coefficients are the least-squares ones with b1 = 0
    B, Y = gmc_design(y, X)
    theta, *_ = np.linalg.lstsq(B[:, 1:], Y, rcond=None)
    np.testing.assert_allclose([*model.driving_coef_, model.control_], theta, rtol=1e-9)
    # ... and no other (b, u) with b1 = 0 does better
    best = np.sum((B[:, 1:] @ theta - Y) ** 2)
    rng = np.random.default_rng(0)
    for _ in range(20):
        other = theta + 1e-3 * rng.normal(size=theta.size)
        assert np.sum((B[:, 1:] @ other - Y) ** 2) > best


def test_least_squares_bounds_inside_change_nothing(gmc_tests):
    X, y = gmc_tests.drop(columns="dz_um"), gmc_tests["dz_um"]
    free = GMC(solver="ls").fit(X, y)
    boxed = GMC(solver="ls", bounds=(0.0, 100.0)).fit(X, y)
    assert 0 < free.development_coef_ < 100
    np.testing.assert_array_equal(free.predict(X), boxed.predict(X))


# -- a test that starts mid-run (issue 15, item 5) ------------------------------
def _warm_case():
    """Two cold tests rising from about 20 C (temperatures given as T - 20), a GMC
    target with b1 = 0.05, and the last 30 % of a third, slower test as a new test."""
    rng = np.random.default_rng(3)
    t = np.arange(100.0)

    def run(label, ambient, tau):
        T = ambient + 6 * (1 - np.exp(-t / tau)) + 0.02 * rng.normal(size=t.size)
        X = pd.DataFrame({"T1_C": T - 20.0}, index=make_test_index([label] * t.size, t))
        return X, simulate_gmc(X.to_numpy(), 0.05, [0.6], 0.0)

    (Xa, ya), (Xb, yb), (Xc, yc) = run("A", 20.0, 25), run("B", 20.4, 25), run("C", 20.2, 40)
    X = pd.concat([Xa, Xb])
    y = pd.Series(np.r_[ya, yb], index=X.index, name="dz_um")
    tail = Xc.iloc[70:].copy()
    tail.index = make_test_index(["C-tail"] * 30, t[:30])
    return X, y, tail, yc[70:]


def test_initial_displacement_starts_a_mid_run_test_from_its_measured_value():
    X, y, tail, y_tail = _warm_case()
    model = GMC().fit(X, y)
    assert model.development_coef_ == pytest.approx(0.05, abs=0.002)
    np.testing.assert_allclose(model.start_range_, [[0.0], [0.4]], atol=0.05)
    match = r"test 'C-tail'.*column 'T1_C' starts at 5\.[0-9]"
    with pytest.warns(GreyWarmStartWarning, match=match):
        cold = model.predict(tail)
    start = float(y_tail[0])  # 51.5 um
    for given in (start, {"C-tail": start}, pd.Series({"C-tail": start})):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a test with its start given: no warning
            warm = model.predict(tail, initial_displacement=given)
        assert warm[0] == pytest.approx(start, rel=1e-12)
    cold_rmse = np.sqrt(np.mean((cold - y_tail) ** 2))
    warm_rmse = np.sqrt(np.mean((warm - y_tail) ** 2))
    assert cold_rmse > 25 and warm_rmse < 0.2, (cold_rmse, warm_rmse)  # measured 28.8, 0.12
    # GNNMCI shares the implementation
    from greyml import GNNMCI

    net = GNNMCI(n_population=10, max_iter=10, random_state=0).fit(X, y)
    with pytest.warns(GreyWarmStartWarning, match=r"GNNMCI predicts test 'C-tail'"):
        net.predict(tail)
    assert net.predict(tail, initial_displacement=start)[0] == pytest.approx(start, rel=1e-12)
    # the same through a Pipeline, which hands the keyword to its last step
    pipe = make_pipeline(StandardScaler(with_mean=False).set_output(transform="pandas"), GMC())
    pipe.fit(X, y)
    np.testing.assert_allclose(
        pipe.predict(tail, initial_displacement=start), warm, rtol=1e-6, atol=1e-6
    )


def test_initial_displacement_bad_values():
    X, y, tail, _ = _warm_case()
    model = GMC().fit(X, y)
    with pytest.raises(ValueError, match=r"names test 'D', which X does not hold.*'C-tail'"):
        model.predict(tail, initial_displacement={"D": 1.0})
    with pytest.raises(ValueError, match=r"initial_displacement of test 'C-tail'.*finite.*nan"):
        model.predict(tail, initial_displacement={"C-tail": np.nan})
    with pytest.raises(ValueError, match=r"finite number; got inf"):
        model.predict(tail, initial_displacement=np.inf)
    with pytest.raises(TypeError, match=r"number, a dict or a Series.*got list"):
        model.predict(tail, initial_displacement=[1.0])
    plain = GMC().fit(X.to_numpy(), y.to_numpy())
    with pytest.raises(ValueError, match=r"needs X with a 'test' index level"):
        plain.predict(tail.to_numpy()[:, :1] * 0 + 20.0, initial_displacement={"C-tail": 1.0})
    # a test that starts as the training tests did gets no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(X)
