"""scikit-learn's estimator checks for every greyml estimator."""

from sklearn.utils.estimator_checks import parametrize_with_checks

from greyml import AGO, GMC

# A row's output depends on the rows before it in its test (accumulation,
# convolution): that is the point of a sequence model, so scikit-learn's checks
# that predict on a subset or a permutation of the rows and expect the same
# per-row output cannot hold.
SEQUENCE_REASON = (
    "sequence model: each row's output depends on the earlier rows of its test, "
    "so outputs change when rows are subset or reordered"
)
SEQUENCE_CHECKS = {
    "check_methods_subset_invariance": SEQUENCE_REASON,
    "check_methods_sample_order_invariance": SEQUENCE_REASON,
}

ESTIMATORS = [
    AGO(),
    GMC(solver="ls"),
    GMC(solver="pso"),
    GMC(solver="cs"),
]


def _expected_failures(estimator):
    return dict(SEQUENCE_CHECKS)


@parametrize_with_checks(ESTIMATORS, expected_failed_checks=_expected_failures)
def test_sklearn_compatible(estimator, check):
    check(estimator)
