import numpy as np
import pandas as pd
import pytest

from greyml import _sequences as seq
from greyml import groups_of, make_test_index
from greyml._sequences import Segment

# an alias: pytest would collect a function named test_* imported here


def frame(tests, times):
    return pd.DataFrame(
        {"T1_C": np.arange(len(tests), dtype=float)},
        index=make_test_index(tests, times),
    )


def test_plain_array_is_one_test():
    assert seq.segments_by_test(np.zeros((5, 2))) == [Segment(None, 0, 5)]


def test_segments_in_given_order():
    X = frame(["B", "B", "A", "A", "A"], [0, 10, 0, 10, 20])
    assert seq.segments_by_test(X) == [Segment("B", 0, 2), Segment("A", 2, 5)]
    assert groups_of(X).tolist() == ["B", "B", "A", "A", "A"]


def test_split_test_is_rejected():
    X = frame(["A", "A", "B", "A"], [0, 10, 0, 20])
    with pytest.raises(
        ValueError,
        match=r"Test 'A' appears in two separate runs of rows \(rows 0-1 and 3-3\)",
    ):
        seq.segments_by_test(X)


@pytest.mark.parametrize("times, word", [([0, 10, 10], "repeats"), ([0, 20, 10], "goes back")])
def test_time_must_increase(times, word):
    X = frame(["A", "A", "A"], times)
    with pytest.raises(ValueError, match=f"Time does not increase within test 'A'.*{word}.*row 2"):
        seq.segments_by_test(X)


def test_missing_label():
    X = pd.DataFrame(
        {"a": [1.0, 2.0]},
        index=pd.MultiIndex.from_arrays([["A", None], [0, 1]], names=["test", "time_s"]),
    )
    with pytest.raises(ValueError, match="missing test label at row 1"):
        seq.segments_by_test(X)


def test_index_survives_sklearn_indexing():
    from sklearn.utils import _safe_indexing

    X = frame(["A", "A", "B", "B"], [0, 10, 0, 10])
    sub = _safe_indexing(X, np.array([2, 3]))
    assert seq.segments_by_test(sub) == [Segment("B", 0, 2)]


def test_no_public_name_is_collected_by_pytest():
    import greyml

    # pytest collects from a test module the functions named test* and classes Test*
    # that it imports
    assert [name for name in greyml.__all__ if name.startswith(("test", "Test"))] == []
