"""Every example runs as a script, headless (no clock decides pass or fail)."""

import runpy
from pathlib import Path

import pandas as pd
import pytest

# the gallery's sections are sub-folders of examples/ (docs/conf.py orders them)
EXAMPLES = sorted((Path(__file__).parent.parent / "examples").rglob("*.py"))


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


def test_there_are_examples():
    assert any(p.name == "plot_gmc_calibration.py" for p in EXAMPLES)
