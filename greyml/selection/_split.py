"""The seeds' validation protocol as a scikit-learn splitter."""

from __future__ import annotations

import numpy as np
from sklearn.model_selection import BaseCrossValidator

from greyml._sequences import groups_of, has_test_index

__all__ = ["TrainOnOneTest"]


def _groups_of(X, groups):
    if groups is not None:
        return np.asarray(groups, dtype=object)
    if X is not None and has_test_index(X):
        return np.asarray(groups_of(X), dtype=object)
    raise ValueError(
        "TrainOnOneTest needs the test of every row: pass groups=greyml.groups_of(X), "
        "or give X with a 'test' index level."
    )


class TrainOnOneTest(BaseCrossValidator):
    """Calibrate on one test, validate on every other (the seeds' protocol).

    Each split trains on all rows of one test and validates on all rows of the
    other tests, so there are as many splits as tests (or one per test in
    ``train_tests``). It is the mirror of :class:`~sklearn.model_selection.LeaveOneGroupOut`
    and is used the same way in ``cross_validate`` and ``GridSearchCV``. The
    tests come from ``groups`` or, when ``groups`` is not given, from the
    ``test`` index level of ``X``.

    Read more in the :ref:`User Guide <ug-train-on-one-test>`.

    Parameters
    ----------
    train_tests : sequence or None, default=None
        Only these tests are calibrated on (e.g. ``["IV"]`` for Abdulshahed et al.'s (2015)
        protocol); ``None`` calibrates on each test in turn.

    See Also
    --------
    greyml.groups_of : the test label of every row, for ``groups=``.
    greyml.GreyInfluenceSelector : the sensor selection validated this way by
        Abdulshahed et al. (2015).

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.selection import TrainOnOneTest
    >>> groups = ["I", "I", "II", "II", "III"]
    >>> for train, test in TrainOnOneTest(train_tests=["II"]).split(np.zeros((5, 1)),
    ...                                                            groups=groups):
    ...     print(train, test)
    [2 3] [0 1 4]
    """

    def __init__(self, train_tests=None):
        self.train_tests = train_tests

    def _labels(self, groups):
        labels = list(dict.fromkeys(groups.tolist()))
        if len(labels) < 2:
            raise ValueError(
                f"TrainOnOneTest needs at least 2 tests; got {len(labels)} "
                f"({', '.join(map(str, labels)) or 'none'})."
            )
        if self.train_tests is None:
            return labels
        wanted = list(self.train_tests)
        missing = [t for t in wanted if t not in labels]
        if missing:
            raise ValueError(
                f"TrainOnOneTest: train_tests {missing} are not among the tests of the "
                f"data ({', '.join(map(str, labels))})."
            )
        return wanted

    def split(self, X, y=None, groups=None):
        """Yield (train, test) row positions, one split per calibration test."""
        groups = _groups_of(X, groups)
        for label in self._labels(groups):
            mask = groups == label
            yield np.flatnonzero(mask), np.flatnonzero(~mask)

    def _iter_test_masks(self, X=None, y=None, groups=None):
        groups = _groups_of(X, groups)
        for label in self._labels(groups):
            yield groups != label

    def get_n_splits(self, X=None, y=None, groups=None):
        """Number of splits: the calibration tests."""
        if self.train_tests is not None:
            return len(list(self.train_tests))
        return len(self._labels(_groups_of(X, groups)))
