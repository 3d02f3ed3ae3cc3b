"""``python -m greyml``: the ``greyml`` command line (see :mod:`greyml.cli`)."""

import sys

from greyml.cli import main

if __name__ == "__main__":
    sys.exit(main())
