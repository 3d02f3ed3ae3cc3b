"""The diagnosis on small measured-like cases of benchmarks/gap_harness/_measured.py (a few seeds).

The benchmark ``benchmarks/bench_gap_measured.py`` runs the same families
over 20 seeds of six 5.5-hour tests; these are three tests of 2-3 hours.
"""

import numpy as np
import pytest
from gap_harness._measured import (
    drop_case,
    quantised_null_case,
    run_measured_case,
    smooth_case,
)

SMALL = dict(n_tests=3, hours=3.0)


@pytest.mark.parametrize("quantum, seed", [(1.0, 0), (0.25, 1)])
def test_a_quantised_null_at_15_s_rows_is_within_noise_with_no_event(quantum, seed):
    case = quantised_null_case(quantum, 15.0, seed, n_tests=3, hours=2.0)
    row = run_measured_case(case)
    assert row["detected_quantum"] == pytest.approx(quantum)
    assert row["verdict"] == "within_noise" and row["n_events"] == 0, row
    # the floor holds the rounding: near the true spread of the error
    assert 0.9 <= row["noise_floor"] / row["true_noise"] <= 1.3


def test_the_drop_is_located_at_15_s_and_1_min_rows_at_the_same_time():
    # one seed; the benchmark gives the share over 20 (three 3-hour tests make
    # the search weaker than six 5.5-hour ones: 5 of 6 seeds at 1-min rows)
    rows = [run_measured_case(drop_case(rate, 0, **SMALL)) for rate in (15.0, 60.0)]
    for row in rows:
        assert row["located"] and row["false_events"] == 0, row
    fine, coarse = (row["located_s"] for row in rows)
    assert abs(fine - coarse) <= 600.0


def test_a_case_is_the_same_tests_at_every_rate():
    a, b = (smooth_case(rate, 4, **SMALL) for rate in (60.0, 300.0))
    coarse = b.real.index
    # every 5-min row is a 1-min row, with the same effect there
    assert coarse.isin(a.real.index).all()
    np.testing.assert_allclose(a.effect[a.real.index.isin(coarse)], b.effect, rtol=0, atol=1e-12)


def test_a_smooth_lag_gives_no_event_at_1_min_rows():
    row = run_measured_case(smooth_case(60.0, 3, size=30.0, **SMALL))
    assert row["n_events"] == 0, row


def test_bad_case_settings_say_what_is_wrong():
    with pytest.raises(ValueError, match="sample_s must be a positive multiple of 15 s; got 20"):
        drop_case(20.0, 0, **SMALL)
    with pytest.raises(ValueError, match=r"quantum must be a finite number >= 0; got -1"):
        quantised_null_case(-1.0, 60.0, 0, **SMALL)
