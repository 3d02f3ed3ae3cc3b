"""Every example runs as a script, headless, within the time budget."""

import runpy
import time
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").glob("*.py"))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_example_runs(path, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("GREYML_EXAMPLE_OUT", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    start = time.perf_counter()
    runpy.run_path(str(path), run_name="__main__")
    assert time.perf_counter() - start < 60
    import matplotlib.pyplot as plt

    plt.close("all")
    assert capsys.readouterr().out  # every example reports something


def test_there_are_examples():
    assert any(p.name == "plot_gmc_calibration.py" for p in EXAMPLES)
