"""Reading and writing greyml's test-data layout (CSV with ``test`` and ``time_s``)."""

from greyml.io._csv import check_test_frame, read_tests_csv, write_tests_csv

__all__ = ["check_test_frame", "read_tests_csv", "write_tests_csv"]
