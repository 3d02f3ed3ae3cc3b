"""Every example runs as a script, headless (no clock decides pass or fail), once.

Where a test reads an example's output (a number a page quotes, a line it must
print), it reads it here, from this one run.
"""

import re
import runpy
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).parent.parent
# the gallery's sections are sub-folders of examples/ (docs/conf.py orders them)
EXAMPLES = sorted((ROOT / "examples").rglob("*.py"))


def _simulated_tests(out):
    assert "Test VI: largest displacement" in out


def _caiviac_trust(out):
    """The numbers docs/trust.rst quotes from examples/real_data/plot_caiviac_trust.py."""
    if "skipping" in out:  # the CAIVIAC recording is absent: the example says so
        return
    holds = [float(v) for v in re.findall(r"interval holds +([\d.]+) %", out)]
    rmse = [float(v) for v in re.findall(r"RMSE +([\d.]+) µm", out)]
    fired = re.search(r"change detector fired at ([\d.]+) h from the cycle's start", out)
    page = " ".join((ROOT / "docs" / "trust.rst").read_text(encoding="utf-8").split())
    assert f"the 90 % interval held {holds[0]:.0f} % of cycle 5's rows" in page
    assert f"90 % interval held {holds[1]:.0f} % of cycle 5's rows" in page
    assert f"RMSE fell from {rmse[0]:.2f} to {rmse[1]:.2f} µm" in page
    assert f"it fired after {fired.group(1)} hours" in page


# what an example's output must say, beyond running
OUTPUT_CHECKS = {
    "plot_simulated_tests.py": _simulated_tests,
    "plot_caiviac_trust.py": _caiviac_trust,
}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_example_runs(path, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("GREYML_EXAMPLE_OUT", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    # an example may set pandas display options for its own printing; they are
    # restored afterwards so that they cannot leak into other tests' doctests
    kept = ["display.width", "display.float_format", "display.max_columns"]
    with pd.option_context(*[x for name in kept for x in (name, pd.get_option(name))]):
        runpy.run_path(str(path), run_name="__main__")
    import matplotlib.pyplot as plt

    plt.close("all")
    out = capsys.readouterr().out
    assert out  # every example reports something
    # an example that saves its figures (hidden from the gallery's pages) still does
    if "GREYML_EXAMPLE_OUT" in path.read_text(encoding="utf-8") and "skipping" not in out:
        assert sorted(tmp_path.glob("*.png")), f"{path.name} saved no figure"
    OUTPUT_CHECKS.get(path.name, lambda out: None)(out)


def test_there_are_examples():
    assert any(p.name == "plot_gmc_calibration.py" for p in EXAMPLES)
    # every example whose output is read is one that runs
    assert set(OUTPUT_CHECKS) <= {p.name for p in EXAMPLES}
