"""RelativeToStart: rises from each test's start, in a Pipeline and a saved model."""

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import Ridge
from sklearn.model_selection import LeaveOneGroupOut, cross_val_predict
from sklearn.pipeline import make_pipeline

from greyml import RelativeToStart, groups_of, make_test_index
from greyml.persist import load_model, save_model


def _frame():
    index = make_test_index(["I"] * 3 + ["II"] * 2 + ["III"] * 3, [0, 60, 120, 0, 60, 0, 60, 120])
    return pd.DataFrame(
        {
            "T1_C": [20.0, 21.5, 23.0, 25.0, 25.5, 19.0, 19.0, 18.0],
            "spindle_rpm": [0.0, 4000.0, 4000.0, 0.0, 8000.0, 100.0, 0.0, 0.0],
        },
        index=index,
    )


def test_each_test_from_its_first_row_by_hand():
    X = _frame()
    before = X.copy()
    Z = RelativeToStart().fit_transform(X)
    assert Z["T1_C"].tolist() == [0.0, 1.5, 3.0, 0.0, 0.5, 0.0, 0.0, -1.0]
    assert Z["spindle_rpm"].tolist() == [0.0, 4000.0, 4000.0, 0.0, 8000.0, 0.0, -100.0, -100.0]
    assert Z.index.equals(X.index) and list(Z.columns) == list(X.columns)
    pd.testing.assert_frame_equal(X, before)  # the user's frame is left as it was


def test_chosen_columns_only_and_names():
    X = _frame()
    model = RelativeToStart(columns=["T1_C"]).fit(X)
    Z = model.transform(X)
    assert model.columns_ == ["T1_C"]
    assert Z["spindle_rpm"].tolist() == X["spindle_rpm"].tolist()
    assert list(model.get_feature_names_out()) == ["T1_C", "spindle_rpm"]
    # positions work too, and an array without a test level is one test
    A = X.to_numpy()
    out = RelativeToStart(columns=[0]).fit_transform(A)
    np.testing.assert_array_equal(out[:, 0], A[:, 0] - A[0, 0])
    np.testing.assert_array_equal(out[:, 1], A[:, 1])


def test_in_a_pipeline_equals_the_frame_written_by_hand():
    X = _frame()
    y = pd.Series([0.0, 3.0, 6.5, 0.0, 1.2, 0.0, 0.1, -1.9], index=X.index)
    groups = groups_of(X)
    by_hand = X - X.groupby(level="test", sort=False).transform("first")
    expected = cross_val_predict(
        Ridge(alpha=1e-3), by_hand, y, groups=groups, cv=LeaveOneGroupOut()
    )
    piped = cross_val_predict(
        make_pipeline(RelativeToStart(), Ridge(alpha=1e-3)),
        X,
        y,
        groups=groups,
        cv=LeaveOneGroupOut(),
    )
    np.testing.assert_allclose(piped, expected, rtol=0, atol=1e-12)


def test_saved_and_loaded_with_its_model(tmp_path):
    X = _frame()
    y = np.arange(len(X), dtype=float)
    pipe = make_pipeline(RelativeToStart(columns=["T1_C"]), Ridge()).fit(X, y)
    path = tmp_path / "m.greyml"
    save_model(pipe, path)
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.predict(X), pipe.predict(X))
    assert loaded[0].columns_ == ["T1_C"]


@pytest.mark.parametrize(
    "columns, match",
    [
        (["T9_C"], r"RelativeToStart: 'T9_C' is not a column of X \(columns: T1_C, spindle_rpm\)"),
        ("T1_C", r"'columns' parameter of RelativeToStart must be a sequence .* \['T1_C'\]"),
        ([5], r"column position 5 is outside the 2 columns"),
        (["T1_C", 0], r"a column is named twice"),
    ],
)
def test_bad_columns(columns, match):
    with pytest.raises(ValueError, match=match):
        RelativeToStart(columns=columns).fit(_frame())


def test_bad_cells_and_columns_named():
    X = _frame()
    bad = X.copy()
    bad.iloc[4, 0] = np.nan
    with pytest.raises(ValueError, match=r"T1_C.*II|II.*T1_C"):
        RelativeToStart().fit(bad)
    model = RelativeToStart().fit(X)
    with pytest.raises(ValueError, match="spindle_rpm|feature names"):
        model.transform(X[["T1_C"]])
