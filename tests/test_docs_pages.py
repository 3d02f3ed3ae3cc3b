"""The examples of the documentation's pages run as written.

Every ``>>>`` line of a ``docs/*.rst`` page is a doctest; its output must be
what the page shows (warnings are errors here as in the rest of the suite).
"""

import doctest
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"
PAGES = sorted(p for p in DOCS.glob("*.rst") if ">>> " in p.read_text(encoding="utf-8"))


def test_the_trust_page_has_examples():
    assert "trust.rst" in [p.name for p in PAGES]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_page_examples_run(page):
    result = doctest.testfile(
        str(page),
        module_relative=False,
        encoding="utf-8",
        optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS,
    )
    assert result.attempted > 10 and result.failed == 0, result


# the numbers docs/trust.rst quotes from examples/real_data/plot_caiviac_trust.py are
# read from the example's one run in test_examples.py
