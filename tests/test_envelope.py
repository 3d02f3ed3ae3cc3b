"""Inputs outside what training saw (issue 39, item 5): the envelope, its follower, and the
interval widened by the model's response to the excess, in batch and in the stream.

The follower and the envelope are checked against cases computed by hand; the
widening against known gains (a static term: exactly ``|gain × excess|``; a
fitted model at rest: its steady-state gain times the excess); the stream
against batch ``predict_interval``; the saved envelope against a hostile file.
"""

import json
import math
import zipfile

import numpy as np
import pandas as pd
import pytest

from greyml import Compensator, ThermalTransferFunction, make_test_index
from greyml.controller import Uncertainty
from greyml.dynamic import InputEnvelope
from greyml.dynamic._envelope import envelope_of, follow, follow_step, reach_of
from greyml.persist import load_model, save_model

# -- the kernel, by hand --------------------------------------------------------


def test_the_follower_by_hand_with_the_range_and_the_rate_both_binding():
    # rows 60 s apart; at most 60 per hour: one unit per row; range [0, 5.5]
    env = InputEnvelope(("T",), np.array([0.0]), np.array([5.5]), np.array([60.0]))
    x = np.array([2.0, 5.0, 6.0, 12.0, 13.0, 4.0, -3.0, -2.5])[:, None]
    dt = np.full(8, 60.0)
    bounds = [(0, 6), (6, 8)]  # a second test, without history
    got = follow(x, dt, bounds, env)[:, 0]
    # 2 (inside); 3, 4, 5 (one unit a row: the rate); 5.5 (the range); 4.5 (down one
    # unit); the second test starts at the range's edge, 0, and follows -2.5 there (the
    # follower may move a part in 1e9 more than the rate: RATE_SLACK)
    np.testing.assert_allclose(got, [2.0, 3.0, 4.0, 5.0, 5.5, 4.5, 0.0, 0.0], rtol=1e-8)
    excess = x[:, 0] - got
    np.testing.assert_allclose(excess, [0.0, 2.0, 2.0, 7.0, 7.5, -0.5, -3.0, -2.5], atol=1e-8)
    assert excess[0] == 0.0 and excess[4] == 7.5  # the range binds exactly
    # carried into the second test, the follower goes on from 4.5, one unit a row
    carried = follow(x, dt, bounds, env, carry=[False, True])[:, 0]
    np.testing.assert_allclose(carried[6:], [3.5, 2.5], rtol=1e-8)


def test_the_batch_follower_is_the_row_by_row_kernel_bit_for_bit():
    # a random walk that leaves and re-enters the envelope by both edges and the rate;
    # four tests, the third carrying the second's follower
    rng = np.random.default_rng(3)
    n = 4000
    x = np.cumsum(rng.normal(0.0, 0.3, (n, 3)), axis=0) + rng.normal(0.0, 0.05, (n, 3))
    x[1000:1010] += 5.0  # a jump
    dt = rng.choice([10.0, 15.0, 60.0], n)
    bounds = [(0, 900), (900, 2000), (2000, 3100), (3100, n)]
    carry = [False, False, True, False]
    env = InputEnvelope(
        ("a", "b", "c"),
        np.array([-3.0, -1.0, 0.0]),
        np.array([3.0, 2.0, 0.0]),
        np.array([40.0, 90.0, 0.0]),
    )
    got = follow(x, dt, bounds, env, carry=carry)
    expected = np.empty_like(x)
    state = None
    for i, (start, stop) in enumerate(bounds):
        if not carry[i]:
            state = None
        for k in range(start, stop):
            state = follow_step(state, x[k], reach_of(env.max_rate_per_h, dt[k]), env.low, env.high)
            expected[k] = state
    assert np.array_equal(got, expected)
    inside = (got == x).mean(axis=0)
    assert 0.05 < inside[0] < 0.95 and 0.05 < inside[1] < 0.95 and inside[2] == 0.0


def test_the_envelope_by_hand_with_a_weightless_row_and_a_constant_input():
    x = np.array([[1.0, 7.0], [3.0, 7.0], [10.0, 7.0], [2.0, 7.0], [2.5, 7.0]])
    dt = np.array([0.0, 1800.0, 1800.0, 0.0, 900.0])
    weight = np.array([1.0, 1.0, 0.0, 1.0, 1.0])  # row 2 unseen: neither its value nor its rate
    env = envelope_of(x, dt, [(0, 3), (3, 5)], weight, ["a", "c"])
    assert env.names == ("a", "c")
    np.testing.assert_array_equal(env.low, [1.0, 7.0])
    np.testing.assert_array_equal(env.high, [3.0, 7.0])
    # (3 - 1) / 0.5 h = 4 per hour; (2.5 - 2) / 0.25 h = 2; never across tests (3 -> 2)
    np.testing.assert_array_equal(env.max_rate_per_h, [4.0, 0.0])
    # the constant input: span 0, rate 0; its follower is the constant, whatever comes
    followed = follow(np.array([[2.0, 7.0], [2.0, 9.0]]), np.array([0.0, 60.0]), [(0, 2)], env)
    np.testing.assert_array_equal(followed, [[2.0, 7.0], [2.0, 7.0]])


@pytest.mark.parametrize(
    "field, value, words",
    [
        ("low", [math.nan], "not finite"),
        ("high", [-1.0], "low 0 above high -1"),
        ("max_rate_per_h", [-2.0], "negative max_rate_per_h"),
    ],
)
def test_a_bad_envelope_is_refused_in_one_line(field, value, words):
    values = {"low": [0.0], "high": [5.0], "max_rate_per_h": [1.0], field: value}
    env = InputEnvelope(("T1_C",), *(np.array(values[k]) for k in values))
    with pytest.raises(ValueError) as info:
        Compensator(["T1_C"], [("T1_C", 1, None, 1.0)], envelope=env).update(
            {"time_s": 0.0, "T1_C": 1.0}
        )
    message = str(info.value)
    assert "\n" not in message and "'T1_C'" in message and words in message, message


def test_an_envelope_of_an_input_the_compensator_lacks_is_refused():
    env = InputEnvelope(("T9_C",), np.array([0.0]), np.array([1.0]), np.array([1.0]))
    with pytest.raises(ValueError, match="names 'T9_C', which is not in inputs"):
        Compensator(["T1_C"], [("T1_C", 1, None, 1.0)], envelope=env).update(
            {"time_s": 0.0, "T1_C": 1.0}
        )


# -- the compensator, by hand: a static term and a lag -----------------------------

ENV = InputEnvelope(("T1_C",), np.array([20.0]), np.array([22.0]), np.array([6.0]))
U = Uncertainty(offset_var=1.0, growth_var_per_h=0.0, noise_var=0.0, memory_var=1.0, memory_h=1e6)


def _half(comp):
    return comp.status.half_width - 1.6448536269514722  # the calibrated part: q·1 µm


def test_a_static_term_widens_by_its_gain_times_the_excess():
    comp = Compensator(["T1_C"], [("T1_C", 1, None, 3.0)], uncertainty=U, envelope=ENV)
    rows = [(0.0, 21.0), (60.0, 21.05), (120.0, 21.5), (180.0, 23.0), (240.0, 22.0)]
    # reach 0.1 K per 60 s row: 21.05 inside; 21.5 is 0.35 K too fast; 23 above 22 and
    # too fast (follower 21.15 + 0.1 = 21.25); 22 too fast from 21.25 (follower 21.35)
    excess = [0.0, 0.0, 0.35, 1.75, 0.65]
    for (t, x), e in zip(rows, excess):
        comp.update({"time_s": t, "T1_C": x})
        assert _half(comp) == pytest.approx(3.0 * e, abs=1e-8)  # RATE_SLACK
        outside = comp.status.outside
        if e == 0.0:
            assert outside == () and _half(comp) == 0.0  # inside: exactly as without
        else:
            assert outside[0][0] == "T1_C" and outside[0][1] == pytest.approx(e, abs=1e-8)


def test_two_inputs_outside_widen_by_both_responses_which_never_cancel():
    env = InputEnvelope(
        ("T1_C", "T2_C"), np.array([20.0, 20.0]), np.array([22.0, 22.0]), np.array([1e3, 1e3])
    )
    terms = [("T1_C", 1, None, 3.0), ("T2_C", 1, None, -2.0)]
    comp = Compensator(["T1_C", "T2_C"], terms, uncertainty=U, envelope=env)
    comp.update({"time_s": 0.0, "T1_C": 23.0, "T2_C": 22.5})  # 1 K and 0.5 K above
    # the model's responses: +3 µm and -1 µm; together +2, but each is unknown: 3 + 1
    assert _half(comp) == pytest.approx(4.0, abs=1e-12)
    assert dict(comp.status.outside) == {"T1_C": 1.0, "T2_C": 0.5}


def test_a_lag_term_widens_by_the_lag_of_the_excess():
    a = math.exp(-60.0 / 600.0)
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 2.0)], uncertainty=U, envelope=ENV)
    comp.update({"time_s": 0.0, "T1_C": 23.0})  # starts above: excess 1, lag at rest at it
    assert _half(comp) == pytest.approx(2.0, abs=1e-12)
    comp.update({"time_s": 60.0, "T1_C": 22.0})  # back inside: the lag still remembers
    assert comp.status.outside == ()
    assert _half(comp) == pytest.approx(2.0 * a, abs=1e-12)


# -- the fitted model: batch, stream, known gains --------------------------------


def _tests(n_tests=4, seed=0):
    """Tests of 6 h at 60 s: T1 rises to 20 + 2 K or so, T2 noise; y = 3 (T1 - 20)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 6 * 3600, 60.0)
    frames, labels, times, ys = [], [], [], []
    for i in range(n_tests):
        t1 = 20.0 + np.minimum(t / 3600.0, 1.7 + 0.1 * i)
        t2 = 21.0 + rng.normal(0.0, 0.05, t.size)
        frames.append(np.column_stack([t1, t2]))
        ys.append(3.0 * (t1 - 20.0) + rng.normal(0.0, 0.02, t.size))
        labels += [f"{i + 1}"] * t.size
        times.append(t)
    index = make_test_index(labels, np.concatenate(times))
    X = pd.DataFrame(np.vstack(frames), columns=["T1_C", "T2_C"], index=index)
    return X, np.concatenate(ys)


@pytest.fixture(scope="module")
def fitted():
    X, y = _tests()
    return X, ThermalTransferFunction(reference="recording").fit(X, y)


def test_the_envelope_is_what_the_training_rows_saw(fitted):
    X, model = fitted
    env = model.input_envelope_
    assert env.names == tuple(model.selected_sensors_)
    j = env.names.index("T1_C")
    assert env.low[j] == 20.0 and env.high[j] == pytest.approx(22.0)
    assert env.max_rate_per_h[j] == pytest.approx(1.0)  # 1 K/h


def test_rows_inside_the_envelope_keep_the_interval_exactly(fitted):
    X, model = fitted
    assert (model.outside_envelope(X).to_numpy() == 0.0).all()
    assert (model._envelope_widening(X) == 0.0).all()


def test_a_test_at_rest_above_the_range_widens_by_the_steady_gain_times_the_excess(fitted):
    X, model = fitted
    t = np.arange(0.0, 3600.0, 60.0)
    hot = pd.DataFrame(
        {"T1_C": np.full(t.size, 25.0), "T2_C": np.full(t.size, 21.0)},
        index=make_test_index(["hot"] * t.size, t),
    )
    excess = model.outside_envelope(hot)
    np.testing.assert_allclose(excess["T1_C"], 3.0, rtol=1e-12)  # 25 against 22
    assert (excess.drop(columns="T1_C").to_numpy() == 0.0).all()
    intervals = model.predict_interval(hot)
    inside = model.predict_interval(hot.assign(T1_C=22.0))
    widening = (intervals[:, 2] - intervals[:, 1] - (inside[:, 2] - inside[:, 1])) / 2
    # every lag at rest at 25 against at rest at 22: the steady gain (3 µm/K) times 3 K
    np.testing.assert_allclose(widening, 9.0, rtol=0.02)


def _excursion(X):
    """Test 2 with T1 pushed 1.5 K above from its third hour: a step too fast, then too high."""
    hot = X.copy()
    t = hot.index.get_level_values("time_s").to_numpy()
    second = (hot.index.get_level_values("test") == "2") & (t >= 3 * 3600)
    hot.loc[second, "T1_C"] += 1.5
    return hot


@pytest.mark.parametrize("reference, state", [("start", "restart"), ("recording", "carry")])
def test_the_stream_widens_as_the_batch_interval(reference, state):
    X, y = _tests()
    model = ThermalTransferFunction(reference=reference, state=state).fit(X, y)
    hot = _excursion(X)
    batch = model._envelope_widening(hot)
    excess = model.outside_envelope(hot)
    assert batch.max() > 1.0 and (batch[: 360 + 180] == 0.0).all()
    comp = Compensator.from_model(model, nominal_step_s=60.0)
    plain = Compensator.from_model(model, nominal_step_s=60.0).set_params(envelope=None)
    first, previous = None, None
    for k, (key, row) in enumerate(hot.iterrows()):
        values = {"time_s": key[1], **row.to_dict()}
        for c in (comp, plain):
            if previous is not None and key[0] != previous and state == "restart":
                c.reset()  # a test without history (with "carry": the next piece)
            c.update(values)
        previous = key[0]
        widening = comp.status.half_width - plain.status.half_width
        assert widening == pytest.approx(batch[k], abs=1e-9)
        outside = dict(comp.status.outside)
        expected = {c: v for c, v in excess.iloc[k].items() if v != 0.0}
        assert outside.keys() == expected.keys()
        for c, v in expected.items():
            assert outside[c] == pytest.approx(v, abs=1e-9)
        if outside and first is None:
            first = k
    assert first == 360 + 180  # the step's row: flagged at once


# -- saved and loaded ----------------------------------------------------------------


def test_a_saved_compensator_resumes_outside_the_envelope(fitted, tmp_path):
    X, model = fitted
    hot = _excursion(X)
    rows = [{"time_s": k[1], **r.to_dict()} for k, r in hot.iloc[360:720].iterrows()]
    comp = Compensator.from_model(model)
    for r in rows[:200]:
        comp.update(r)
    assert comp.status.outside  # saved while outside
    before = comp.status
    loaded = load_model(save_model(comp, tmp_path / "c.greyml"))
    assert _same(loaded.status, before)
    for r in rows[200:]:
        assert loaded.update(r) == comp.update(r)
        assert _same(loaded.status, comp.status)
    saved_model = load_model(save_model(model, tmp_path / "m.greyml"))
    np.testing.assert_array_equal(saved_model.predict_interval(hot), model.predict_interval(hot))


def _same(a, b):
    """Two statuses field by field, a NaN equal to a NaN (a field not yet known)."""
    return all(
        x == y
        or (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y))
        for x, y in zip(a, b)
    ) and len(a) == len(b)


def _rewrite(path, edit, out):
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    header = json.loads(members["model.json"])
    edit(header["tree"])
    members["model.json"] = json.dumps(header).encode()
    with zipfile.ZipFile(out, "w") as archive:
        for name, content in members.items():
            archive.writestr(name, content)
    return out


def _envelope_node(tree):
    """The saved InputEnvelope in a model file's tree (the first found)."""
    if isinstance(tree, dict):
        if tree.get("class") == "greyml.dynamic.InputEnvelope":
            return tree
        children = tree.values()
    elif isinstance(tree, list):
        children = tree
    else:
        return None
    for child in children:
        found = _envelope_node(child)
        if found is not None:
            return found
    return None


@pytest.mark.parametrize(
    "field, value, words",
    [
        ("low", "nan", "not finite"),
        ("high", -1e9, "above high"),
        ("max_rate_per_h", -1.0, "negative max_rate_per_h"),
    ],
)
@pytest.mark.parametrize("which", ["compensator", "model"])
def test_a_hostile_saved_envelope_is_refused_at_load(fitted, tmp_path, which, field, value, words):
    _, model = fitted
    obj = Compensator.from_model(model) if which == "compensator" else model
    path = save_model(obj, tmp_path / f"{which}.greyml")

    def edit(tree):
        node = _envelope_node(tree)
        number = {"kind": "float", "value": value} if isinstance(value, str) else value
        node["state"][field] = [number] * len(model.input_envelope_.names)

    with pytest.raises(ValueError) as info:
        load_model(_rewrite(path, edit, tmp_path / "bad.greyml"))
    message = str(info.value)
    assert "\n" not in message and "envelope" in message and words in message, message


# -- the exports -----------------------------------------------------------------------


def test_the_json_and_the_headers_carry_the_envelope(fitted):
    from greyml.controller._export._write import export_text

    _, model = fitted
    comp = Compensator.from_model(model)
    exported = json.loads(export_text(comp, "json"))
    env = model.input_envelope_
    assert [exported["inputs"][j]["name"] for j in exported["envelope"]["inputs"]] == list(
        env.names
    )
    assert exported["envelope"]["low"] == env.low.tolist()
    assert exported["envelope"]["high"] == env.high.tolist()
    assert exported["envelope"]["max_rate_per_h"] == env.max_rate_per_h.tolist()
    names = [v["name"] for v in exported["state"]]
    assert {"ef", "ex", "elag", "widening_um", "outside"} <= set(names)
    for language in ("c", "st"):
        header = export_text(comp, language).split("*)" if language == "st" else "*/")[0]
        flag = "Outside: 0 inside" if language == "st" else "outside: 0 inside"
        assert "Envelope (what training saw" in header and flag in header
    plain = json.loads(export_text(comp.set_params(envelope=None), "json"))
    assert "envelope" not in plain and "outside" not in [v["name"] for v in plain["state"]]


def test_partial_fit_widens_the_envelope_by_what_the_new_tests_saw():
    X, y = _tests()
    model = ThermalTransferFunction(reference="recording").fit(X, y)
    hotter = X.xs("1", level="test", drop_level=False).copy()
    hotter["T1_C"] += 0.5  # 20.5 to 22.2 K: 0.5 K above the highest training value, 22
    hotter.index = make_test_index(["5"] * len(hotter), hotter.index.get_level_values("time_s"))
    before = model.input_envelope_
    model.partial_fit(hotter, 3.0 * (hotter["T1_C"].to_numpy() - 20.0))
    after = model.input_envelope_
    j = after.names.index("T1_C")
    assert after.high[j] == pytest.approx(max(before.high[j], hotter["T1_C"].max()))
    assert after.low[j] == before.low[j] and after.max_rate_per_h[j] == before.max_rate_per_h[j]
    assert (model.outside_envelope(hotter).to_numpy() == 0.0).all()
