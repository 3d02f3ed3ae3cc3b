"""greyml.persist: models saved without pickle, loaded without running code."""

import io
import json
import os
import pickle
import sys
import zipfile

import numpy as np
import pytest
from _estimators import entries
from sklearn.base import BaseEstimator, clone
from sklearn.compose import TransformedTargetRegressor
from sklearn.exceptions import NotFittedError
from sklearn.linear_model import HuberRegressor, LinearRegression, Ridge, RidgeCV
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import FunctionTransformer, MinMaxScaler, StandardScaler

import greyml
from greyml import (
    AGO,
    ANFISFCM,
    GMC,
    GreyInfluenceSelector,
    groups_of,
)
from greyml.controller import Uncertainty
from greyml.dynamic import InputEnvelope, IntervalCalibration
from greyml.exceptions import UnsafeModelError
from greyml.optimize import CuckooSearch
from greyml.persist import ALLOWED_CLASSES, describe_model, load_model, save_model
from greyml.utils.discovery import all_estimators

DRIVERS = ["T1_C", "T2_C", "T3_C", "T4_C"]


@pytest.fixture
def data(gmc_tests):
    """Two short tests in greyml's (test, time_s) layout."""
    frame = gmc_tests.loc[["I", "II"]]
    return frame[DRIVERS], frame["dz_um"]


def _gridsearch_best(X, y):
    search = GridSearchCV(
        make_pipeline(StandardScaler(), Ridge()),
        {"ridge__alpha": [0.1, 10.0]},
        cv=LeaveOneGroupOut(),
    )
    return search.fit(X, y, groups=groups_of(X)).best_estimator_


# greyml's own estimators and pipelines are round-tripped through this format
# (and pickle and joblib) once, in test_roundtrip.py, from tests/_estimators.py's
# table; here what the table does not hold: scikit-learn's compositions around
# greyml's models, an optimiser object as the solver, a Generator as the seed
MODELS = {
    # an optimiser object as the solver, a Generator as random_state
    "GMC-cs-object": lambda X, y: GMC(
        solver=CuckooSearch(n_population=6, max_iter=3),
        search="full",
        random_state=np.random.default_rng(3),
    ).fit(X, y),
    "selector-scaler-ANFISFCM": lambda X, y: make_pipeline(
        GreyInfluenceSelector(n_clusters=2, random_state=0),
        StandardScaler().set_output(transform="pandas"),
        ANFISFCM(n_clusters=2, max_iter=3, random_state=0),
    ).fit(X, y),
    "selector-scaler-GMC": lambda X, y: make_pipeline(
        GreyInfluenceSelector(n_clusters=2, random_state=0),
        StandardScaler(with_mean=False).set_output(transform="pandas"),
        GMC(),
    ).fit(X, y),
    "scaler-RidgeCV": lambda X, y: make_pipeline(StandardScaler(), RidgeCV()).fit(X, y),
    "gridsearch-best": _gridsearch_best,
    "TransformedTargetRegressor": lambda X, y: TransformedTargetRegressor(
        regressor=LinearRegression(), func=np.arcsinh, inverse_func=np.sinh
    ).fit(X, y),
    "TransformedTargetRegressor-scaler": lambda X, y: TransformedTargetRegressor(
        regressor=Ridge(), transformer=MinMaxScaler()
    ).fit(X, y),
}


def _fitted(name, X, y):
    """A model of MODELS, or an entry of the estimators' table, fitted on (X, y)."""
    if name in MODELS:
        return MODELS[name](X, y)
    (entry,) = [e for e in entries("roundtrip") if e.name == name]
    return clone(entry.estimator).fit(X, y)


def _output(model, X):
    return np.asarray(model.predict(X) if hasattr(model, "predict") else model.transform(X))


def _assert_same(a, b):
    assert type(a) is type(b)
    if isinstance(a, BaseEstimator):
        _assert_same_params(a, b)
    elif isinstance(a, np.random.Generator):
        assert a.bit_generator.state == b.bit_generator.state
    elif isinstance(a, np.ndarray):
        assert np.array_equal(a, b)
    elif isinstance(a, list | tuple):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _assert_same(x, y)
    else:
        assert a == b


def _assert_same_params(a, b):
    params_a, params_b = a.get_params(deep=False), b.get_params(deep=False)
    assert params_a.keys() == params_b.keys()
    for key in params_a:
        _assert_same(params_a[key], params_b[key])


@pytest.mark.parametrize("name", list(MODELS))
def test_round_trip_is_exact(name, data, tmp_path):
    X, y = data
    model = MODELS[name](X, y)
    path = save_model(model, tmp_path / "model.greyml")
    assert path == tmp_path / "model.greyml"

    loaded = load_model(path)

    assert type(loaded) is type(model)
    assert np.array_equal(_output(loaded, X), _output(model, X))
    _assert_same_params(loaded, model)
    assert list(loaded.feature_names_in_) == DRIVERS
    assert describe_model(path)["untrusted_types"] == []


def test_the_allowlist_holds_every_estimator_by_its_top_level_name():
    estimators = all_estimators()
    assert len(estimators) >= 11
    for name, cls in estimators:
        assert getattr(greyml, name) is cls  # exported at the top level, as the file names it
        assert ALLOWED_CLASSES[f"greyml.{name}"] is cls
    greyml_classes = {k for k in ALLOWED_CLASSES if k.startswith("greyml.")}
    others = {"greyml.optimize.CuckooSearch", "greyml.optimize.ParticleSwarm"}
    others.add("greyml.selection.TrainOnOneTest")
    others.add("greyml.Compensator")  # the runtime object, saved with its state
    assert greyml.Compensator is ALLOWED_CLASSES["greyml.Compensator"]
    # the records a fitted model and a compensator hold, by their public names
    others |= {"greyml.dynamic.IntervalCalibration", "greyml.controller.Uncertainty"}
    others.add("greyml.dynamic.InputEnvelope")
    assert ALLOWED_CLASSES["greyml.dynamic.InputEnvelope"] is InputEnvelope
    assert ALLOWED_CLASSES["greyml.dynamic.IntervalCalibration"] is IntervalCalibration
    assert ALLOWED_CLASSES["greyml.controller.Uncertainty"] is Uncertainty
    assert greyml_classes == {f"greyml.{name}" for name, _ in estimators} | others


def test_loaded_model_clones_and_refits(data, tmp_path):
    X, y = data
    model = MODELS["selector-scaler-GMC"](X, y)
    loaded = load_model(save_model(model, tmp_path / "m.greyml"))
    refit = clone(loaded).fit(X, y)
    assert np.array_equal(refit.predict(X), model.predict(X))


def test_describe_model(data, tmp_path):
    X, y = data
    path = save_model(MODELS["selector-scaler-GMC"](X, y), tmp_path / "m.greyml")
    info = describe_model(path)
    assert info["class"] == "sklearn.pipeline.Pipeline"
    assert info["format_version"] == 1
    assert info["greyml_version"]
    assert info["saved_at"].endswith("+00:00")
    assert info["feature_names_in"] == DRIVERS
    assert info["n_features_in"] == 4
    assert [cls for _, cls in info["steps"]] == [
        "greyml.GreyInfluenceSelector",
        "sklearn.preprocessing.StandardScaler",
        "greyml.GMC",
    ]
    assert "greyml.GMC" in info["classes"]


def test_never_unpickles(data, tmp_path, monkeypatch):
    X, y = data
    path = save_model(_fitted("GMC-pso", X, y), tmp_path / "m.greyml")

    def refuse(*args, **kwargs):
        raise AssertionError("pickle was used")

    for name in ("load", "loads", "Unpickler"):
        monkeypatch.setattr(pickle, name, refuse)
    load_model(path)


# -- writing ----------------------------------------------------------------


def test_refuses_to_overwrite(data, tmp_path):
    X, y = data
    path = save_model(GMC().fit(X, y), tmp_path / "m.greyml")
    before = path.read_bytes()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        save_model(AGO().fit(X), path)
    assert path.read_bytes() == before
    save_model(AGO().fit(X), path, overwrite=True)
    assert isinstance(load_model(path), AGO)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.greyml"]  # no temporary left


def test_unfitted_estimator_is_not_saved(tmp_path):
    with pytest.raises(NotFittedError):
        save_model(GMC(), tmp_path / "m.greyml")
    with pytest.raises(NotFittedError):
        save_model(make_pipeline(StandardScaler(), GMC()), tmp_path / "m.greyml")
    assert not (tmp_path / "m.greyml").exists()


def test_what_cannot_be_saved_is_named(data, tmp_path):
    X, y = data
    with pytest.raises(TypeError, match=r"Pipeline\.steps\[0\]\[1\]\.func: it is a function"):
        save_model(
            make_pipeline(FunctionTransformer(lambda v: v), Ridge()).fit(X, y), tmp_path / "a"
        )
    search = GridSearchCV(Ridge(), {"alpha": [0.1, 1.0]}, cv=2).fit(X, y)
    with pytest.raises(TypeError, match="best_estimator_"):
        save_model(search, tmp_path / "b")
    with pytest.raises(TypeError, match="estimator"):
        save_model({"not": "a model"}, tmp_path / "c")
    assert list(tmp_path.iterdir()) == []


# -- reading damaged or hostile files ----------------------------------------


def _one_line(exc_info, path):
    message = str(exc_info.value)
    assert "\n" not in message
    assert str(path) in message


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.greyml"):
        load_model(tmp_path / "nothing.greyml")


def test_text_file_is_not_a_model(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("spindle warm-up notes\n")
    with pytest.raises(ValueError, match="not a greyml model file") as exc_info:
        load_model(path)
    _one_line(exc_info, path)


def test_other_zip_is_not_a_model(tmp_path):
    path = tmp_path / "other.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("readme.txt", "hello")
    with pytest.raises(ValueError, match="no model.json") as exc_info:
        load_model(path)
    _one_line(exc_info, path)


def test_truncated_and_corrupted_files(data, tmp_path):
    X, y = data
    good = save_model(_fitted("ANFISFCM", X, y), tmp_path / "good.greyml").read_bytes()

    truncated = tmp_path / "truncated.greyml"
    truncated.write_bytes(good[: len(good) // 2])
    with pytest.raises(ValueError) as exc_info:
        load_model(truncated)
    _one_line(exc_info, truncated)

    flipped = tmp_path / "flipped.greyml"
    damaged = bytearray(good)
    damaged[len(good) // 3] ^= 0xFF  # inside a compressed member: CRC mismatch
    flipped.write_bytes(bytes(damaged))
    with pytest.raises(ValueError) as exc_info:
        load_model(flipped)
    _one_line(exc_info, flipped)


def _rewrite(path, edit, out=None, extra=None, text=lambda s: s):
    """Copy a model file with its model.json changed by ``edit(header)``."""
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    header = json.loads(members["model.json"])
    edit(header)
    members["model.json"] = text(json.dumps(header)).encode()
    members.update(extra or {})
    out = out or path.with_name("tampered.greyml")
    with zipfile.ZipFile(out, "w") as archive:
        for name, content in members.items():
            archive.writestr(name, content)
    return out


@pytest.fixture
def gmc_file(data, tmp_path):
    X, y = data
    return save_model(GMC().fit(X, y), tmp_path / "gmc.greyml")


@pytest.mark.parametrize(
    "name", ["os.system", "builtins.eval", "builtins.exec", "subprocess.Popen", "this.Zen"]
)
def test_classes_off_the_allowlist_are_refused(gmc_file, tmp_path, name):
    marker = tmp_path / "pwned"
    payload = {
        "kind": "object",
        "class": name,
        "state": {"args": [f"touch {marker}"], "command": f"touch {marker}"},
    }

    def edit(header):
        header["tree"]["class"] = header["class"] = name
        header["tree"]["state"] = payload["state"]

    path = _rewrite(gmc_file, edit)
    with pytest.raises(UnsafeModelError, match=name.replace(".", r"\.")) as exc_info:
        load_model(path)
    _one_line(exc_info, path)
    assert describe_model(path)["untrusted_types"] == [name]

    # the same, hidden as a nested attribute of an allowed estimator
    nested = _rewrite(gmc_file, lambda h: h["tree"]["state"].update(solver=payload))
    with pytest.raises(UnsafeModelError, match=name.replace(".", r"\.")):
        load_model(nested)
    assert not marker.exists()
    assert "this" not in sys.modules


@pytest.mark.parametrize(
    "node",
    [
        {"kind": "ufunc", "name": "os.system"},
        {"kind": "type", "name": "builtins.eval"},
        {"kind": "generator", "bit_generator": "os.system", "state": {}},
    ],
)
def test_functions_and_types_off_the_allowlist_are_refused(gmc_file, node):
    path = _rewrite(gmc_file, lambda h: h["tree"]["state"].update(solver=node))
    with pytest.raises(UnsafeModelError, match="os.system|builtins.eval"):
        load_model(path)


class _Boom:
    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (os.mkdir, (self.marker,))


def test_pickled_array_is_refused(gmc_file, tmp_path):
    marker = tmp_path / "pwned"
    buffer = io.BytesIO()
    np.save(buffer, np.array([_Boom(marker)], dtype=object), allow_pickle=True)
    node = {"kind": "ndarray", "file": "arrays/99.npy"}
    path = _rewrite(
        gmc_file,
        lambda h: h["tree"]["state"].update(driving_coef_=node),
        extra={"arrays/99.npy": buffer.getvalue()},
    )
    with pytest.raises(ValueError, match="arrays/99.npy") as exc_info:
        load_model(path)
    _one_line(exc_info, path)
    assert not marker.exists()


@pytest.mark.parametrize(
    "edit, match",
    [
        # an attribute that would replace a method
        (
            lambda h: h["tree"]["state"].update(
                predict={"kind": "ufunc", "name": "numpy.negative"}
            ),
            "forbidden attribute 'predict'",
        ),
        (lambda h: h["tree"]["state"].update(__class__=None), "forbidden attribute"),
        (lambda h: h.update({"class": "greyml.AGO"}), "altered"),
        (lambda h: h.update(format_version=99), "newer greyml"),
        (lambda h: h.update(format="something-else"), "not a greyml model"),
        (lambda h: h["tree"]["state"].update(x={"kind": "eval", "code": "1"}), "unknown node"),
        (lambda h: h["tree"]["state"].update(x={"kind": "ndarray", "file": "../x"}), "array"),
    ],
)
def test_tampered_tree_is_refused(gmc_file, edit, match):
    path = _rewrite(gmc_file, edit)
    with pytest.raises(ValueError, match=match) as exc_info:
        load_model(path)
    _one_line(exc_info, path)


def test_deep_nesting_is_refused(gmc_file):
    deep = "[" * 100_000 + "]" * 100_000
    path = _rewrite(
        gmc_file,
        lambda h: h["tree"]["state"].update(x="DEEP"),
        text=lambda s: s.replace('"DEEP"', deep),
    )
    with pytest.raises(ValueError) as exc_info:
        load_model(path)
    _one_line(exc_info, path)


def test_other_version_warns(gmc_file):
    path = _rewrite(gmc_file, lambda h: h.update(greyml_version="0.0.1"))
    with pytest.warns(UserWarning, match="greyml 0.0.1"):
        load_model(path)


def test_trusted_allows_an_extra_class(data, tmp_path):
    X, y = data
    model = make_pipeline(StandardScaler(), HuberRegressor()).fit(X, y)
    path = save_model(model, tmp_path / "huber.greyml")
    name = "sklearn.linear_model._huber.HuberRegressor"
    assert describe_model(path)["untrusted_types"] == [name]
    with pytest.raises(UnsafeModelError, match=name):
        load_model(path)
    for trusted in (["sklearn.linear_model.HuberRegressor"], [name]):
        loaded = load_model(path, trusted=trusted)
        assert np.array_equal(loaded.predict(X), model.predict(X))
    with pytest.raises(TypeError, match="list of class names"):
        load_model(path, trusted=True)
    with pytest.raises(ValueError, match="not a class"):
        load_model(path, trusted=["os.system"])
