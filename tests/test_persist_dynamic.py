"""Hostile files of the dynamic models (issue 26): a file that loads is checked before use.

A compensator's saved state and plan, a transfer function's time constants, a
bank of time constants that would cost gigabytes per prediction, a Pipeline's
cache folder: each file is built here from a model fitted in the test, then
altered, and must be refused at load with one line (or loaded with what the
file cannot be trusted with put right), never used to produce NaN, a wrong
sensor, an unbounded correction or a write into a folder the file chose.
"""

import io
import json
import math
import re
import zipfile
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import Ridge
from sklearn.pipeline import Pipeline

from greyml import Compensator, LagFeatures, ThermalTransferFunction, make_test_index
from greyml.cli import main
from greyml.io import write_tests_csv
from greyml.persist import load_model, save_model


def _rewrite(path, edit, out):
    """A copy of model file ``path`` with its object tree changed by ``edit(state)``."""
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    header = json.loads(members["model.json"])
    edit(header["tree"])
    members["model.json"] = json.dumps(header).encode()
    with zipfile.ZipFile(out, "w") as archive:
        for name, content in members.items():
            archive.writestr(name, content)
    return out


def _plan_items(state):
    return dict((k, i) for i, (k, _) in enumerate(state["_plan"]["items"]))


def _refused(path, *words):
    with pytest.raises(ValueError) as info:
        load_model(path)
    message = str(info.value)
    assert "\n" not in message and "Cannot load" in message, message
    for word in words:
        assert word in message, message
    return message


def _rows(n=40):
    t = 60.0 * np.arange(n)
    return [
        {"time_s": float(s), "T1_C": 20.0 + 0.05 * k, "T2_C": 21.0 - 0.02 * k}
        for k, s in enumerate(t)
    ]


@pytest.fixture
def compensator_file(tmp_path):
    comp = Compensator(
        ["T1_C", "T2_C"],
        [("T1_C", 1, 600.0, 2.0), ("T2_C", 1, 1800.0, -1.0), ("T2_C", 1, None, 0.5)],
        relative_to_start=True,
    )
    rows = _rows()
    for r in rows[:20]:
        comp.update(r)
    path = save_model(comp, tmp_path / "comp.greyml")
    expected = [comp.update(r) for r in rows[20:]]
    return path, rows[20:], expected


def test_a_saved_start_that_is_not_finite_is_refused(compensator_file, tmp_path):
    path, _, _ = compensator_file
    for value in ("nan", "inf", "-inf"):
        out = tmp_path / f"start-{value}.greyml"

        def edit(state, value=value):
            state["state"]["_start"] = {"kind": "float", "value": value}

        _refused(_rewrite(path, edit, out), "Compensator", "not finite")


def test_a_saved_lag_state_must_match_the_terms(compensator_file, tmp_path):
    path, _, _ = compensator_file

    def edit(state):
        state["state"]["_lags"] = [1.0, 2.0]  # three terms: two lags, one raw input

    _refused(_rewrite(path, edit, tmp_path / "lags.greyml"), "lags do not match its terms")


def test_the_update_plan_is_made_from_the_terms_never_taken_from_the_file(
    compensator_file, tmp_path
):
    path, rows, expected = compensator_file

    def edit(state):
        items = state["state"]["_plan"]["items"]
        at = _plan_items(state["state"])
        items[at["labels"]][1] = ["T2_C|lag 10 min", "T1_C|lag 30 min"]  # swapped names
        items[at["max_step"]][1] = 1e300
        items[at["check_all"]][1] = True
        state["state"]["_dt"] = 60.0  # a cached step the file pairs with its own _a
        state["state"]["_a"] = [0.999] * 5000

    loaded = load_model(_rewrite(path, edit, tmp_path / "plan.greyml"))
    # the same corrections as the compensator that was saved: the file's plan is gone
    np.testing.assert_array_equal([loaded.update(r) for r in rows], expected)
    assert loaded.get_state()["lags"].keys() == {"T1_C|lag 10 min", "T2_C|lag 30 min"}


def test_too_many_terms_are_refused_at_load(tmp_path):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)])
    path = save_model(comp, tmp_path / "small.greyml")

    def edit(state):
        term = state["state"]["terms"][0]
        state["state"]["terms"] = [term] * 100_001

    many = _rewrite(path, edit, tmp_path / "many.greyml")
    _refused(many, "over the limit max_bytes")  # the size of the file says so first
    with pytest.raises(ValueError, match="more than the 100,000 terms"):
        load_model(many, max_bytes=2**31)  # and past it, the count of terms


def _recording():
    t = 60.0 * np.arange(360)
    rpm = np.where(t < 7200, 3000.0, 0.0)
    X = pd.DataFrame(
        {"spindle_rpm": rpm, "T1_C": 20 + 0.001 * np.cumsum(rpm) / 60},
        index=make_test_index(["a"] * 180 + ["b"] * 180, t),
    )
    return X, 1e-3 * rpm + 0.5 * (X["T1_C"] - 20)


def test_a_transfer_function_with_a_negative_time_constant_is_refused(tmp_path):
    X, y = _recording()
    model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    path = save_model(model, tmp_path / "ttf.greyml")

    def edit(state):
        block = state["state"]["_spec_"][0]  # [column, power, taus]
        block["items"][2]["items"][0] = -300.0

    bad = _rewrite(path, edit, tmp_path / "negative.greyml")
    _refused(bad, "time constant -300.0 s", "not a finite number > 0")
    # and on the command line: one line, exit 2, no compensation written
    data = write_tests_csv(pd.concat([X, y.rename("dz_um")], axis=1), tmp_path / "x.csv")
    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        code = main(["predict", str(bad), str(data), "--out", str(tmp_path / "p.csv")])
    assert code == 2 and err.getvalue().count("\n") == 1, err.getvalue()
    assert not (tmp_path / "p.csv").exists()


def test_gains_that_do_not_match_the_blocks_are_refused(tmp_path):
    X, y = _recording()
    path = save_model(
        ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y), tmp_path / "t.greyml"
    )

    def edit(state):
        state["state"]["intercept_"] = {"kind": "float", "value": "inf"}

    _refused(_rewrite(path, edit, tmp_path / "inf.greyml"), "intercept_")


@pytest.mark.parametrize("bad", [-15.0, 0.0, {"kind": "float", "value": "inf"}, "15"])
def test_a_saved_sample_interval_must_be_a_finite_positive_number(tmp_path, bad):
    X, y = _recording()
    for model in (LagFeatures([300.0]), ThermalTransferFunction(drivers=["spindle_rpm"])):
        name = type(model).__name__
        path = save_model(model.fit(X, y), tmp_path / f"{name}.greyml")

        def edit(state):
            state["state"]["sample_interval"] = bad

        _refused(_rewrite(path, edit, tmp_path / f"bad-{name}.greyml"), "'sample_interval'")


def test_a_bank_that_would_cost_gigabytes_per_prediction_is_refused(tmp_path):
    X, _ = _recording()
    path = save_model(LagFeatures([300.0]).fit(X), tmp_path / "lags.greyml")

    def edit(state):
        state["state"]["time_constants"] = list(np.linspace(60.0, 1e5, 50_000))

    _refused(_rewrite(path, edit, tmp_path / "bank.greyml"), "50,000 time constants")


def test_a_pipelines_cache_folder_is_never_the_files(tmp_path):
    X, y = _recording()
    model = Pipeline([("lags", LagFeatures([300.0, 900.0])), ("ridge", Ridge())], memory=None)
    path = save_model(model.fit(X, y), tmp_path / "pipe.greyml")

    def edit(state):
        state["state"]["memory"] = str(tmp_path / "cache-the-file-chose")

    loaded = load_model(_rewrite(path, edit, tmp_path / "memory.greyml"))
    assert loaded.memory is None
    from sklearn.base import clone

    clone(loaded).fit(X, y)
    assert not (tmp_path / "cache-the-file-chose").exists()


@pytest.mark.parametrize(
    "value, words",
    [
        (True, "is True (a bool)"),
        (b"21", "is b'21' (a bytes)"),
        ("21", "is '21' (a str)"),
        (np.datetime64("2026-01-01T00:00"), "(a datetime64)"),
    ],
)
def test_the_compensator_takes_real_numbers_only(value, words):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)])
    comp.update({"time_s": 0.0, "T1_C": 20.0})
    before = comp.get_state()
    with pytest.raises(ValueError, match=re.escape(words)) as info:
        comp.update({"time_s": 60.0, "T1_C": value})
    assert "\n" not in str(info.value)
    assert comp.get_state() == before


def test_the_compensator_names_a_repeated_label_and_a_negative_fractional_power():
    comp = Compensator(["T1_C", "rpm"], [("T1_C", 1, 600.0, 1.0), ("rpm", 1.5, None, 1e-3)])
    row = pd.Series([0.0, 20.0, 1.0, 2.0], index=["time_s", "T1_C", "rpm", "rpm"])
    with pytest.raises(ValueError, match="the row names 'rpm' more than once"):
        comp.update(row)
    with pytest.raises(ValueError, match=r"'rpm' is negative \(-3.0\).*power 1.5"):
        comp.update({"time_s": 0.0, "T1_C": 20.0, "rpm": -3.0})
    assert math.isclose(comp.update({"time_s": 0.0, "T1_C": 20.0, "rpm": 4.0}), 20.008)


def test_a_dict_of_keys_sharing_one_hash_is_refused_before_it_is_built(tmp_path):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)])
    path = save_model(comp, tmp_path / "c.greyml")
    modulus = 2**61 - 1  # ints k * modulus + 1 all hash to 1

    def edit(state):
        keys = [1 + k * modulus for k in range(68_000)]
        state["state"]["notes_"] = {"kind": "dict", "items": [[key, 0] for key in keys]}

    message = _refused(_rewrite(path, edit, tmp_path / "flood.greyml"), "distinct hash values")
    assert "68,000 keys with only 1 distinct" in message
    # a set of distinct numbers of the same size is not refused for its hashes
    assert (
        len(
            __import__("greyml.persist._reader", fromlist=["_spread_keys"])._spread_keys(
                list(range(68_000)), "set"
            )
        )
        == 68_000
    )


def test_a_model_with_malformed_attributes_fails_predict_in_one_line(tmp_path):
    from greyml import GMC

    X, y = _recording()
    path = save_model(GMC().fit(X[["T1_C"]], y), tmp_path / "gmc.greyml")

    def edit(state):
        state["state"]["start_range_"] = {"kind": "dict", "items": [["not", "an array"]]}

    bad = _rewrite(path, edit, tmp_path / "bad.greyml")
    load_model(bad)  # it loads: the damage shows only when it predicts
    data = write_tests_csv(pd.concat([X, y.rename("dz_um")], axis=1), tmp_path / "x.csv")
    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        code = main(["predict", str(bad), str(data), "--out", str(tmp_path / "p.csv")])
    assert code == 2, err.getvalue()
    assert err.getvalue().count("\n") == 1 and "Traceback" not in err.getvalue()
