"""Checks of the built documentation (docs/_build/html).

They need a docs build, which the normal suite does not make: without one
they skip, saying so. ``.ci/run`` builds the docs and then runs this file with
``GREYML_REQUIRE_DOCS_BUILD=1``, which turns a missing build into a failure,
so in CI the checks always run for real.
"""

import os
from pathlib import Path

import pytest

from greyml.utils.discovery import all_estimators

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
HTML = DOCS / "_build" / "html"
BACKREFERENCES = DOCS / "generated" / "backreferences"


def _built(path):
    if path.exists():
        return
    message = f"no docs build at {path.relative_to(ROOT)} (python -m sphinx -b html docs docs/_build/html)"
    if os.environ.get("GREYML_REQUIRE_DOCS_BUILD") == "1":
        pytest.fail(message)
    pytest.skip(message)


def _pages():
    _built(HTML / "index.html")
    pages = sorted(HTML.rglob("*.html"))
    assert len(pages) > 20, [p.name for p in pages]
    return pages


def test_no_page_shows_the_build_machines_paths():
    # an example that prints where it saved a file shows the builder's folders
    folders = {str(ROOT), os.path.realpath(ROOT), str(Path.home())}
    folders = sorted(f for f in folders if len(f) > 4)
    found = []
    for page in _pages():
        text = page.read_text(encoding="utf-8", errors="replace")
        found += [f"{page.relative_to(HTML)}: {f}" for f in folders if f in text]
    assert not found, found


def _public_estimators():
    # each is exported at the top level (test_persist.py checks), where the
    # gallery's back-references name it
    return [f"greyml.{name}" for name, _ in all_estimators()]


def test_every_public_estimator_has_a_gallery_example():
    _built(BACKREFERENCES)
    estimators = _public_estimators()
    assert "greyml.GMC" in estimators and len(estimators) >= 8
    missing = []
    for name in estimators:
        examples = BACKREFERENCES / f"{name}.examples"
        # sphinx-gallery writes one thumbnail per example that uses the name
        text = examples.read_text(encoding="utf-8") if examples.exists() else ""
        if "sphx-glr-thumbcontainer" not in text and "sphx_glr_" not in text:
            missing.append(name)
    assert not missing, f"no gallery example uses {missing}"


def test_api_pages_show_their_gallery_examples():
    _built(HTML / "generated")
    page = (HTML / "generated" / "greyml.GMC.html").read_text(encoding="utf-8")
    assert "Gallery examples" in page and "plot_gmc_calibration" in page
