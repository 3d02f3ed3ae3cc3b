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


def test_the_trust_pages_caiviac_numbers_are_the_examples(tmp_path, monkeypatch, capsys):
    """The numbers docs/trust.rst quotes from examples/real_data/plot_caiviac_trust.py."""
    import re
    import runpy

    from conftest import caiviac_csv_or_skip

    caiviac_csv_or_skip()
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.delenv("GREYML_EXAMPLE_OUT", raising=False)
    monkeypatch.chdir(tmp_path)
    example = DOCS.parent / "examples" / "real_data" / "plot_caiviac_trust.py"
    runpy.run_path(str(example), run_name="__main__")
    import matplotlib.pyplot as plt

    plt.close("all")
    out = capsys.readouterr().out
    holds = [float(v) for v in re.findall(r"interval holds +([\d.]+) %", out)]
    rmse = [float(v) for v in re.findall(r"RMSE +([\d.]+) µm", out)]
    fired = re.search(r"change detector fired at ([\d.]+) h from the cycle's start", out)
    page = " ".join((DOCS / "trust.rst").read_text(encoding="utf-8").split())
    assert f"the 90 % interval held {holds[0]:.0f} % of cycle 5's rows" in page
    assert f"90 % interval held {holds[1]:.0f} % of cycle 5's rows" in page
    assert f"RMSE fell from {rmse[0]:.2f} to {rmse[1]:.2f} µm" in page
    assert f"it fired after {fired.group(1)} hours" in page
