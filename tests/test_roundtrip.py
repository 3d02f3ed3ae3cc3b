"""Every public estimator, fitted pipeline and compensator survives greyml.persist,
pickle and joblib.

The estimators are the entries of ``tests/_estimators.py``'s table that name
the round trip among their suites, each round-tripped once here, through all
three serialisers: each must give *identical* output (``assert_array_equal``)
on tests it was not fitted on and on its training tests, with every attribute
(parameters and fitted state) unchanged; a :class:`~greyml.Compensator` saved
mid-stream resumes where it stopped. ``tests/test_persist.py`` checks greyml's
format on what the table does not hold (scikit-learn's own compositions,
optimiser objects). The second half checks that tampered model files the other
file does not cover fail with a clear greyml error and execute nothing.
"""

import dataclasses
import io
import json
import pickle
import re
import zipfile

import joblib
import numpy as np
import pytest
from _estimators import entries
from scipy.optimize import OptimizeResult
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import GridSearchCV
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from greyml import ANFISFCM, GMC, ANFISGrid, GreyInfluenceSelector, TrainOnOneTest
from greyml.exceptions import UnsafeModelError
from greyml.persist import describe_model, load_model, save_model

DRIVERS = ["T1_C", "T2_C", "T3_C", "T4_C"]


@pytest.fixture
def split(gmc_tests):
    """Fit on tests I and II; the unseen tests III and IV check the loaded model."""
    fit, new = gmc_tests.loc[["I", "II"]], gmc_tests.loc[["III", "IV"]]
    return fit[DRIVERS], fit["dz_um"], new[DRIVERS]


# -- what is round-tripped ---------------------------------------------------


def _search_best(X, y):
    """A GridSearchCV over selector settings and two models; its best pipeline."""
    pipe = Pipeline([("select", GreyInfluenceSelector(random_state=0)), ("model", GMC())])
    search = GridSearchCV(
        pipe,
        {
            "select__n_clusters": [2, 3],
            "model": [GMC(), ANFISFCM(n_clusters=2, max_iter=3, random_state=0)],
        },
        cv=TrainOnOneTest(),
        scoring="neg_root_mean_squared_error",
    )
    return search.fit(X, y)


ROUND_TRIPPED = {entry.name: entry for entry in entries("roundtrip")}
ESTIMATORS = {name: e.estimator for name, e in ROUND_TRIPPED.items() if e.build is None}
COMPENSATORS = {name: e for name, e in ROUND_TRIPPED.items() if e.build is not None}
FITTED = list(ESTIMATORS) + ["gridsearch-best"]


def _fitted(name, X, y):
    if name == "gridsearch-best":
        return _search_best(X, y).best_estimator_
    return clone(ESTIMATORS[name]).fit(X, y)


SERIALISERS = ["persist", "pickle", "joblib"]


def _round_trip(model, how, tmp_path):
    if how == "persist":
        path = save_model(model, tmp_path / "model.greyml")
        # greyml's format: the file is where it was asked for, of trusted types only
        assert path == tmp_path / "model.greyml"
        assert describe_model(path)["untrusted_types"] == []
        return load_model(path)
    if how == "pickle":
        return pickle.loads(pickle.dumps(model, protocol=pickle.HIGHEST_PROTOCOL))
    path = tmp_path / "model.joblib"
    joblib.dump(model, path)
    return joblib.load(path)


def _assert_same_value(a, b, where):
    """Exact equality of two attribute values, recursing into estimators and containers."""
    assert type(a) is type(b), where
    if isinstance(a, BaseEstimator):
        _assert_same_state(a, b, where)
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype, where
        if a.dtype == object:
            assert a.shape == b.shape, where
            for i, (x, z) in enumerate(zip(a.ravel(), b.ravel())):
                _assert_same_value(x, z, f"{where}[{i}]")
        else:
            np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, np.random.Generator):
        assert a.bit_generator.state == b.bit_generator.state, where
    elif isinstance(a, dict):  # dict, OptimizeResult
        assert list(a) == list(b), where
        for key in a:
            _assert_same_value(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), where
        for i, (x, z) in enumerate(zip(a, b)):
            _assert_same_value(x, z, f"{where}[{i}]")
    elif isinstance(a, float | np.floating) and np.isnan(a):
        assert np.isnan(b), where
    elif isinstance(a, TrainOnOneTest):
        assert vars(a) == vars(b), where
    elif dataclasses.is_dataclass(a) and not isinstance(a, type):  # a record: field by field
        assert type(a) is type(b), where
        for field in dataclasses.fields(a):
            name = field.name
            _assert_same_value(getattr(a, name), getattr(b, name), f"{where}.{name}")
    else:
        assert a == b, where


def _assert_same_state(a, b, where="estimator"):
    """Same class, same attributes (parameters and fitted state), equal values."""
    assert type(a) is type(b), where
    assert list(vars(a)) == list(vars(b)), where
    for key in vars(a):
        _assert_same_value(vars(a)[key], vars(b)[key], f"{where}.{key}")


def _outputs(model, X):
    """Everything the model computes from new data: predictions and/or transforms."""
    out = {}
    if hasattr(model, "predict"):
        out["predict"] = model.predict(X)
    if hasattr(model, "transform"):
        out["transform"] = model.transform(X)
        if hasattr(model, "inverse_transform"):
            out["inverse_transform"] = model.inverse_transform(out["transform"])
    assert out
    return out


@pytest.mark.parametrize("how", SERIALISERS)
@pytest.mark.parametrize("name", FITTED)
def test_fitted_round_trip_is_identical_on_new_tests(name, how, split, tmp_path):
    X, y, X_new = split
    model = _fitted(name, X, y)
    before = _outputs(model, X_new)

    loaded = _round_trip(model, how, tmp_path)

    assert loaded is not model
    _assert_same_state(loaded, model, name)
    assert loaded.n_features_in_ == 4
    assert list(loaded.feature_names_in_) == DRIVERS
    after = _outputs(loaded, X_new)
    assert after.keys() == before.keys()
    for key in before:
        # DataFrames (transformers keep the test index) compare with their index
        if hasattr(before[key], "index"):
            assert after[key].index.equals(before[key].index)
            assert list(after[key].columns) == list(before[key].columns)
        np.testing.assert_array_equal(np.asarray(after[key]), np.asarray(before[key]), key)
    # the loaded model is a usable estimator: it clones and refits to the same model
    refit = clone(loaded).fit(X, y)
    for key, value in _outputs(refit, X_new).items():
        np.testing.assert_array_equal(np.asarray(value), np.asarray(before[key]), key)
    # and on the tests it was fitted on
    fitted_on = _outputs(model, X)
    for key, value in _outputs(loaded, X).items():
        np.testing.assert_array_equal(np.asarray(value), np.asarray(fitted_on[key]), key)


def _rows(X):
    """The first test of X as a controller reads it: one dict per row, with its time."""
    first = X.index.get_level_values("test")[0]
    one = X.xs(first, level="test", drop_level=False)
    times = one.index.get_level_values("time_s")
    return [{**row, "time_s": t} for t, row in zip(times, one.to_dict("records"))]


@pytest.mark.parametrize("how", SERIALISERS)
@pytest.mark.parametrize("name", list(COMPENSATORS))
def test_compensator_round_trip_resumes_mid_stream(name, how, split, tmp_path):
    """A Compensator built from a fitted model, saved half-way through a test,
    resumes with the corrections of one that ran on; its model's numbers are kept."""
    X, y, X_new = split
    entry = COMPENSATORS[name]
    rows = _rows(X_new)
    whole = entry.build(clone(entry.estimator).fit(X, y))
    uninterrupted = [whole.update(row) for row in rows]

    first = entry.build(clone(entry.estimator).fit(X, y))
    head = [first.update(row) for row in rows[:40]]
    loaded = _round_trip(first, how, tmp_path)

    assert type(loaded) is type(first) and loaded is not first
    # greyml's format keeps the parameters and the running state, and rebuilds
    # the update plan and its work buffers from the terms at load
    # (test_persist_dynamic.py); pickle and joblib keep every attribute
    if how != "persist":
        _assert_same_state(loaded, first, name)
    _assert_same_value(loaded.get_params(), first.get_params(), f"{name}.get_params()")
    _assert_same_value(loaded.get_state(), first.get_state(), f"{name}.get_state()")
    tail = [loaded.update(row) for row in rows[40:]]
    np.testing.assert_array_equal(head + tail, uninterrupted)


def test_optimiser_result_survives(split, tmp_path):
    """The calibration record of a metaheuristic GMC (scipy's OptimizeResult) is kept."""
    X, y, _ = split
    model = _fitted("GMC-cs", X, y)
    assert isinstance(model.optimizer_result_, OptimizeResult)
    for how in SERIALISERS:
        loaded = _round_trip(model, how, tmp_path)
        assert isinstance(loaded.optimizer_result_, OptimizeResult)
        assert loaded.optimizer_result_.nfev == model.optimizer_result_.nfev
        np.testing.assert_array_equal(loaded.optimizer_result_.x, model.optimizer_result_.x)


@pytest.mark.parametrize("how", ["pickle", "joblib"])
def test_whole_grid_search_round_trips(how, split, tmp_path):
    """pickle and joblib hold the whole search (greyml's format takes best_estimator_)."""
    X, y, X_new = split
    search = _search_best(X, y)
    loaded = _round_trip(search, how, tmp_path)
    assert loaded.best_params_.keys() == search.best_params_.keys()
    assert loaded.best_index_ == search.best_index_
    np.testing.assert_array_equal(
        loaded.cv_results_["mean_test_score"], search.cv_results_["mean_test_score"]
    )
    np.testing.assert_array_equal(loaded.predict(X_new), search.predict(X_new))
    _assert_same_state(loaded.best_estimator_, search.best_estimator_)


@pytest.mark.parametrize("how", ["pickle", "joblib"])
@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_unfitted_round_trip(name, how, split, tmp_path):
    """An unfitted estimator stays unfitted, with its parameters, and fits identically.

    (greyml.persist refuses unfitted estimators; test_persist.py checks that.)
    """
    X, y, X_new = split
    model = clone(ESTIMATORS[name])
    loaded = _round_trip(model, how, tmp_path)
    _assert_same_state(loaded, model, name)
    with pytest.raises(NotFittedError):
        check_is_fitted(loaded)
    expected = _outputs(model.fit(X, y), X_new)
    for key, value in _outputs(loaded.fit(X, y), X_new).items():
        np.testing.assert_array_equal(np.asarray(value), np.asarray(expected[key]), key)


@pytest.mark.parametrize("how", ["pickle", "joblib"])
def test_train_on_one_test_round_trips(how, split, tmp_path):
    X, y, _ = split
    for splitter in (TrainOnOneTest(), TrainOnOneTest(train_tests=["II"])):
        loaded = _round_trip(splitter, how, tmp_path)
        assert type(loaded) is TrainOnOneTest
        assert loaded.train_tests == splitter.train_tests
        assert loaded.get_n_splits(X) == splitter.get_n_splits(X)
        for (a_train, a_test), (b_train, b_test) in zip(
            loaded.split(X), splitter.split(X), strict=True
        ):
            np.testing.assert_array_equal(a_train, b_train)
            np.testing.assert_array_equal(a_test, b_test)


# -- tampered files: a clear greyml error, nothing executed ------------------
#
# test_persist.py covers: os.system / builtins.eval / ... as the top-level class
# or as a parameter, non-allowlisted ufunc / type / bit generator names, a pickled
# object array as a new ndarray member, a file cut in half, one flipped byte, a
# newer format version, a wrong format name, method-shadowing attributes. Below:
# the other hiding places, disguised pickles, more damage, malformed versions,
# added archive members and altered parameters.

TRIPPED = []  # set by anything that runs code from a file


def _trip(*args):
    TRIPPED.append(args)
    return args


class _Sentinel(BaseEstimator):
    """A class that records any attempt to create or fill one of its instances."""

    def __new__(cls, *args, **kwargs):
        TRIPPED.append(("new", cls))
        return super().__new__(cls)

    def __init__(self, flag=None):
        TRIPPED.append(("init", flag))
        self.flag = flag

    def __setstate__(self, state):
        TRIPPED.append(("setstate", state))


class _PickleBomb:
    def __reduce__(self):
        return (_trip, ("unpickled",))


SENTINEL = f"{_Sentinel.__module__}.{_Sentinel.__qualname__}"


@pytest.fixture
def tripwire():
    TRIPPED.clear()
    yield TRIPPED
    assert TRIPPED == [], f"code from a model file ran: {TRIPPED}"


def test_the_tripwires_work():
    """Positive control: unpickling the payloads below does run code."""
    TRIPPED.clear()
    pickle.loads(pickle.dumps(_PickleBomb()))
    buffer = io.BytesIO()
    np.save(buffer, np.array([_PickleBomb()], dtype=object), allow_pickle=True)
    buffer.seek(0)
    np.load(buffer, allow_pickle=True)
    _Sentinel()
    assert len(TRIPPED) == 4
    TRIPPED.clear()


@pytest.fixture
def model_file(split, tmp_path):
    """A fitted selector + GMC pipeline with a Generator seed, saved by greyml."""
    X, y, _ = split
    pipe = Pipeline(
        [
            ("select", GreyInfluenceSelector(n_clusters=2, random_state=0)),
            (
                "model",
                GMC(
                    solver="pso", n_population=4, max_iter=2, random_state=np.random.default_rng(0)
                ),
            ),
        ]
    )
    return save_model(pipe.fit(X, y), tmp_path / "pipe.greyml")


def _members(path):
    with zipfile.ZipFile(path) as archive:
        return [(info.filename, archive.read(info)) for info in archive.infolist()]


def _write(path, members):
    with zipfile.ZipFile(path, "w") as archive:
        for name, content in members:
            archive.writestr(name, content)
    return path


def _tamper(path, edit=None, extra=(), raw=None):
    """A copy of ``path`` with model.json edited, members added, or its text replaced."""
    members = _members(path)
    header = json.loads(dict(members)["model.json"])
    if edit is not None:
        edit(header)
    text = json.dumps(header) if raw is None else raw(json.dumps(header))
    members = [(n, text.encode() if n == "model.json" else c) for n, c in members]
    return _write(path.with_name("tampered.greyml"), [*members, *extra])


def _gmc_state(header):
    """The state table of the pipeline's GMC step."""
    steps = header["tree"]["state"]["steps"]
    (model_step,) = [s for s in steps if s["items"][0] == "model"]
    return model_step["items"][1]["state"]


def _refused(path, error=ValueError, match=None):
    """Loading fails with exactly ``error`` (no zipfile/NumPy type), one line, naming the file."""
    with pytest.raises(error, match=match) as exc_info:
        load_model(path)
    exc = exc_info.value
    assert type(exc) is error
    # no zipfile / NumPy / json exception chained under it
    assert exc.__cause__ is None and (exc.__context__ is None or exc.__suppress_context__)
    message = str(exc)
    assert "\n" not in message and str(path) in message
    return message


def test_untampered_file_loads(model_file, split, tripwire):
    """The fixture's file is fine: the refusals below come from the edits."""
    X, y, X_new = split
    loaded = load_model(_tamper(model_file))
    assert loaded.predict(X_new).shape == (len(X_new),)


def _obj(name=SENTINEL):
    return {"kind": "object", "class": name, "state": {"flag": "pwned"}}


HIDING_PLACES = {
    "pipeline step": lambda h, o: h["tree"]["state"]["steps"][0]["items"].__setitem__(1, o),
    "list item": lambda h, o: _gmc_state(h).update(x=[1, [2, o]]),
    "tuple item": lambda h, o: _gmc_state(h).update(bounds={"kind": "tuple", "items": [0, o]}),
    "set item": lambda h, o: _gmc_state(h).update(x={"kind": "set", "items": [o]}),
    "dict key": lambda h, o: _gmc_state(h).update(x={"kind": "dict", "items": [[o, 1]]}),
    "dict value": lambda h, o: _gmc_state(h).update(x={"kind": "dict", "items": [["k", o]]}),
    "object array": lambda h, o: _gmc_state(h).update(
        feature_names_in_={"kind": "object_array", "shape": [2], "items": ["T1_C", o]}
    ),
    "complex part": lambda h, o: _gmc_state(h).update(x={"kind": "complex", "real": o, "imag": 0}),
    "optimiser result": lambda h, o: _gmc_state(h)["optimizer_result_"]["items"].append(["x", o]),
    "generator state": lambda h, o: _gmc_state(h)["random_state"]["state"]["items"].append(
        ["x", o]
    ),
}


@pytest.mark.parametrize("place", list(HIDING_PLACES))
@pytest.mark.parametrize("name", [SENTINEL, "builtins.eval"])
def test_unlisted_class_is_refused_wherever_it_hides(model_file, tripwire, place, name):
    path = _tamper(model_file, lambda h: HIDING_PLACES[place](h, _obj(name)))
    message = _refused(path, UnsafeModelError, match="allowlist")
    assert name in message
    assert describe_model(path)["untrusted_types"] == [name]


def test_trusting_another_class_does_not_admit_the_hidden_one(model_file, tripwire):
    path = _tamper(model_file, lambda h: HIDING_PLACES["dict key"](h, _obj()))
    with pytest.raises(UnsafeModelError, match=SENTINEL):
        load_model(path, trusted=["sklearn.linear_model.HuberRegressor"])


def _pickled_object_array():
    buffer = io.BytesIO()
    np.save(buffer, np.array([_PickleBomb()], dtype=object), allow_pickle=True)
    return buffer.getvalue()


def _raw_pickle():
    return pickle.dumps(_PickleBomb())


@pytest.mark.parametrize(
    "node, match",
    [
        ({"kind": "ndarray"}, "cannot be read"),
        ({"kind": "scalar", "dtype": "<f8"}, "cannot be read"),
        ({"kind": "scalar", "dtype": "|O"}, "object scalars are not allowed"),
    ],
    ids=["array", "scalar", "object-scalar"],
)
@pytest.mark.parametrize("payload", [_pickled_object_array, _raw_pickle], ids=["npy", "raw"])
def test_pickle_in_an_array_member_is_never_unpickled(model_file, tripwire, node, match, payload):
    """GMC's coefficient array replaced by a pickle, read as an array or a scalar."""
    header = json.loads(dict(_members(model_file))["model.json"])
    member = _gmc_state(header)["driving_coef_"]["file"]
    members = [(n, payload() if n == member else c) for n, c in _members(model_file)]
    path = _write(model_file.with_name("bomb.greyml"), members)
    path = _tamper(path, lambda h: _gmc_state(h).update(driving_coef_={**node, "file": member}))
    message = _refused(path, match=match)
    assert member in message or "object" in message


@pytest.mark.parametrize("keep", [0, 1, 22, 0.25, 0.5, 0.75, -22, -1])
def test_truncated_anywhere_fails_cleanly(model_file, tripwire, keep):
    data = model_file.read_bytes()
    cut = keep if isinstance(keep, int) else int(keep * len(data))
    path = model_file.with_name("cut.greyml")
    path.write_bytes(data[:cut])
    _refused(path)
    with pytest.raises(ValueError):
        describe_model(path)


def test_truncated_array_member_fails_cleanly(model_file, tripwire):
    members = [(n, c[: len(c) - 3] if n == "arrays/0.npy" else c) for n, c in _members(model_file)]
    _refused(_write(model_file.with_name("short.greyml"), members), match="arrays/0.npy")


@pytest.mark.parametrize(
    "raw, match",
    [
        (lambda s: s[: len(s) // 2], "not valid JSON"),
        (lambda s: s.replace('"n_features_in": 4', '"n_features_in": NaN'), "NaN"),
        (lambda s: s.replace('{"format": ', '{"format": "x", "format": ', 1), "repeats a key"),
        (lambda s: "[" + s + "]", "wrong format name"),
        (lambda s: s.encode("utf-16").decode("latin-1"), "not valid JSON"),
    ],
    ids=["cut", "nan", "duplicate-key", "not-an-object", "utf-16"],
)
def test_damaged_json_fails_cleanly(model_file, tripwire, raw, match):
    _refused(_tamper(model_file, raw=raw), match=match)


@pytest.mark.parametrize("version", [0, -1, "1", 1.0, True, None, [1]])
def test_malformed_format_version_is_refused(model_file, tripwire, version):
    _refused(_tamper(model_file, lambda h: h.update(format_version=version)), match="version")


def test_missing_format_version_is_refused(model_file, tripwire):
    _refused(_tamper(model_file, lambda h: h.pop("format_version")), match="version")


@pytest.mark.parametrize(
    "name",
    ["payload.pkl", "arrays/0.npy.pkl", "arrays/01.npy", "../model.json", "arrays/", "MODEL.JSON"],
)
def test_unexpected_archive_member_is_refused(model_file, tripwire, name):
    path = _tamper(model_file, extra=[(name, _raw_pickle())])
    _refused(path, match=f"unexpected member '{re.escape(name)}'")
    with pytest.raises(ValueError, match="unexpected member"):
        describe_model(path)


@pytest.mark.parametrize("name", ["model.json", "arrays/0.npy"])
def test_duplicate_archive_member_is_refused(model_file, tripwire, name):
    """Two members of one name: which one a reader sees would depend on the reader."""
    with pytest.warns(UserWarning, match="Duplicate name"):  # zipfile warns the writer
        path = _tamper(model_file, extra=[(name, b"{}")])
    _refused(path, match="same name")


@pytest.mark.parametrize(
    "edit, match",
    [
        # GMC parameters, checked as GMC.fit checks them (predict uses the last two)
        (lambda s: s.update(solver=5), "'solver' parameter of GMC"),
        (lambda s: s.update(n_population="4"), "'n_population' parameter of GMC"),
        (lambda s: s.update(response="evil"), "'response' parameter of GMC"),
        (lambda s: s.update(initial=None), "'initial' parameter of GMC"),
        # the attribute table and containers themselves
        (lambda s: s.clear() or s.update(steps=None), "has no attribute 'bounds'"),
        (lambda s: s.update(bounds={"kind": "dict", "items": "x"}), "no items list"),
        (lambda s: s.update(bounds={"kind": "dict", "items": [[1, 2, 3]]}), "key-value"),
        (lambda s: s.update(bounds={"kind": "tuple"}), "no items list"),
        (
            lambda s: s.update(
                feature_names_in_={"kind": "object_array", "shape": [5], "items": ["a"]}
            ),
            "shape",
        ),
        (lambda s: s.update(x={"kind": "scalar", "dtype": "<f8", "value": "1.0"}), "invalid value"),
        (lambda s: s.update(x={"kind": "scalar", "dtype": "<i8", "value": 1.5}), "invalid value"),
        (lambda s: s.update(x={"kind": "float", "value": "1e999"}), "invalid float"),
        (lambda s: s.update(x={"kind": "dtype", "value": "O; import os"}), "invalid dtype"),
        (lambda s: s.update(x={"kind": "ndarray", "file": 0}), "array reference"),
        (lambda s: s.update(x={"kind": "ndarray", "file": "arrays/999.npy"}), "missing"),
        (lambda s: s["random_state"].update(state="garbage"), None),
        (lambda s: s["random_state"].update(bit_generator="MT19937"), None),
        (lambda s: s["optimizer_result_"].update(items=[["x"]]), "key-value"),
    ],
    ids=[
        "solver-int",
        "n_population-str",
        "response",
        "initial-None",
        "params-missing",
        "dict-items-str",
        "dict-items-triples",
        "tuple-no-items",
        "object-array-shape",
        "float-scalar-str",
        "int-scalar-float",
        "float-literal",
        "dtype-code",
        "array-ref-int",
        "array-missing",
        "generator-state",
        "generator-kind",
        "optimizer-result-items",
    ],
)
def test_altered_attribute_is_refused(model_file, tripwire, edit, match):
    _refused(_tamper(model_file, lambda h: edit(_gmc_state(h))), match=match)


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda h: h["tree"].update(state=[["steps", None]]), "no attribute table"),
        (lambda h: h["tree"].pop("state"), "no attribute table"),
        (
            lambda h: h["tree"]["state"]["steps"][0]["items"][1]["state"].update(cluster_on="x"),
            "'cluster_on' parameter of GreyInfluenceSelector",
        ),
        (
            lambda h: h["tree"]["state"]["steps"][0]["items"][1]["state"].update(n_clusters=2.5),
            "'n_clusters' parameter of GreyInfluenceSelector",
        ),
        (lambda h: h["tree"].update(items=[["a", 1]]), "not a dict"),
        (lambda h: h.update(tree=[]), "no estimator"),
    ],
    ids=[
        "state-list",
        "state-missing",
        "selector-cluster_on",
        "selector-n_clusters",
        "pipeline-dict-items",
        "tree-list",
    ],
)
def test_altered_tree_is_refused(model_file, tripwire, edit, match):
    _refused(_tamper(model_file, edit), match=match)


def test_altered_anfis_parameter_is_refused(split, tmp_path, tripwire):
    X, y, _ = split
    path = save_model(ANFISGrid(n_mfs=2, max_iter=2).fit(X, y), tmp_path / "anfis.greyml")
    for key, value, match in [
        ("n_mfs", "two", "'n_mfs' parameter of ANFISGrid"),
        ("max_iter", -1, "'max_iter' parameter of ANFISGrid"),
        ("step_increase", 0.5, "step_increase >= 1"),
    ]:
        tampered = _tamper(path, lambda h, k=key, v=value: h["tree"]["state"].update({k: v}))
        _refused(tampered, match=match)
