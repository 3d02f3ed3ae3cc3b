import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from greyml import AGO, make_test_index
from greyml.grey import ago, iago


def two_tests():
    idx = make_test_index(["I", "I", "I", "II", "II"], [0, 10, 20, 0, 10])
    return pd.DataFrame(
        {"T1_C": [1.0, 2.0, 3.0, 10.0, 20.0], "T2_C": [0.5, 0.5, 1.0, -1.0, 1.0]},
        index=idx,
    )


def test_hand_computed_per_test():
    X = two_tests()
    out = AGO().fit_transform(X)
    # test I: 1, 1+2, 1+2+3; test II restarts: 10, 10+20
    assert out["T1_C"].tolist() == [1.0, 3.0, 6.0, 10.0, 30.0]
    assert out["T2_C"].tolist() == [0.5, 1.0, 2.0, -1.0, 0.0]
    assert out.index.equals(X.index)


def test_inverse_is_iago():
    X = two_tests()
    ago_ = AGO().fit(X)
    back = ago_.inverse_transform(ago_.transform(X))
    np.testing.assert_array_equal(back.to_numpy(), X.to_numpy())


def test_plain_array_single_test_returns_array():
    out = AGO().fit_transform(np.array([[1.0], [2.0], [4.0]]))
    assert isinstance(out, np.ndarray)
    assert out.ravel().tolist() == [1.0, 3.0, 7.0]


def test_set_output_pandas_keeps_index_and_names():
    X = two_tests()
    out = AGO().set_output(transform="pandas").fit_transform(X)
    assert out.index.equals(X.index)
    assert list(out.columns) == ["T1_C", "T2_C"]
    assert AGO().fit(X).get_feature_names_out().tolist() == ["T1_C", "T2_C"]


def test_does_not_modify_input():
    X = two_tests()
    before = X.copy()
    AGO().fit(X).transform(X)
    pd.testing.assert_frame_equal(X, before)


def test_nan_names_column_and_test():
    X = two_tests()
    X.iloc[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"column 'T2_C' has NaN in test 'II' at row 4"):
        AGO().fit(X)


def test_mismatched_columns_between_fit_and_transform():
    X = two_tests()
    ago_ = AGO().fit(X)
    with pytest.raises(ValueError, match="feature names"):
        ago_.transform(X[["T2_C", "T1_C"]])


@settings(max_examples=200, deadline=None)
@given(
    data=arrays(
        np.float64,
        st.tuples(st.integers(1, 30), st.integers(1, 3)),
        elements=st.floats(-1e6, 1e6, allow_nan=False),
    ),
    cuts=st.lists(st.integers(1, 29), max_size=4),
)
def test_iago_inverts_ago_per_test(data, cuts):
    n = data.shape[0]
    edges = sorted({0, n, *[c for c in cuts if c < n]})
    bounds = list(zip(edges[:-1], edges[1:]))
    np.testing.assert_allclose(iago(ago(data, bounds), bounds), data, rtol=1e-9, atol=1e-6)
    # accumulation restarts at every boundary
    acc = ago(data, bounds)
    for a, _ in bounds:
        np.testing.assert_array_equal(acc[a], data[a])
