"""Reading and writing greyml's test-data layout (CSV with ``test`` and ``time_s``).

- :func:`read_tests_csv`: a CSV file as a DataFrame indexed by ``test`` and
  ``time_s`` (a logger's file too, its tests given by a column);
- :func:`write_tests_csv`: such a DataFrame back to a file;
- :func:`check_test_frame`: check that a DataFrame is in the layout;
- :class:`TestFiles`: tests in CSV or Parquet files read piece by piece, for a
  fit on more rows than memory holds.
"""

from greyml.io._csv import check_test_frame, read_tests_csv, write_tests_csv
from greyml.io._pieces import TestFiles

__all__ = ["TestFiles", "check_test_frame", "read_tests_csv", "write_tests_csv"]
