"""The README's commands and examples are what CI runs and what works."""

import re
import warnings
from pathlib import Path

ROOT = Path(__file__).parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _section(title):
    return README.split(f"## {title}", 1)[1].split("\n## ", 1)[0]


def test_ci_runs_the_readme_commands_exactly():
    blocks = re.findall(r"```bash\n(.*?)```", _section("Set-up and the main job"), re.S)
    assert len(blocks) == 2
    assert blocks[0].strip().endswith("pip install -e . && greyml demo")
    assert blocks[1].strip().endswith('pip install -e ".[test]" && python -m pytest')
    # .ci/run holds each command as a line of its own, word for word, in order
    lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    positions = [lines.index(block.strip()) for block in blocks]
    assert positions == sorted(positions)


def test_the_paper_models_example_runs(capsys):
    code = re.findall(r"```python\n(.*?)```", _section("The models of the papers"), re.S)
    assert len(code) == 1 and len(code[0].strip().splitlines()) <= 16
    namespace = {}
    # GMC's default box keeps b1 >= 0: no warning of any kind (the README says so)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        exec(compile(code[0], "README, the models of the papers", "exec"), namespace)
    assert caught == [], [f"{w.category.__name__}: {w.message}" for w in caught]
    assert "It prints no warning" in README
    search = namespace["search"]
    # five sensors and a model chosen leaving whole tests out; RMSE in µm
    assert search.best_params_["select__n_clusters"] in (3, 5)
    assert 0 < -search.best_score_ < 10
    assert capsys.readouterr().out


def test_the_readme_is_short_and_in_the_landing_pages_order():
    # issue 37: at most 1,500 words (as `wc -w` counts), the three jobs in the
    # order of docs/index.rst, dynamic compensation first
    assert len(README.split()) <= 1500
    titles = re.findall(r"^## (.+)$", README, re.M)
    jobs = [
        "Dynamic compensation",
        "The models of the papers",
        "The simulator and the gap diagnosis",
    ]
    assert [t for t in titles if t in jobs] == jobs
    landing = (ROOT / "docs" / "index.rst").read_text(encoding="utf-8")
    order = ["Dynamic compensation", "Models from the papers", "Gap diagnosis"]
    positions = [landing.index(f"\n{title}") for title in order]
    assert positions == sorted(positions)
