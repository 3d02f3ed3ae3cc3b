"""Reading and writing greyml's test-data layout (CSV with ``test`` and ``time_s``).

- :func:`read_tests_csv`: a CSV file as a DataFrame indexed by ``test`` and
  ``time_s`` (a logger's file too, its tests given by a column);
- :func:`write_tests_csv`: such a DataFrame back to a file;
- :func:`check_test_frame`: check that a DataFrame is in the layout.
"""

from greyml.io._csv import check_test_frame, read_tests_csv, write_tests_csv

__all__ = ["check_test_frame", "read_tests_csv", "write_tests_csv"]
