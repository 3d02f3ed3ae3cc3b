"""The README's commands and quickstart are what CI runs and what works."""

import re
import warnings
from pathlib import Path

from greyml import GreyStabilityWarning

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


def test_quickstart_runs(capsys):
    code = re.findall(r"```python\n(.*?)```", _section("Quickstart"), re.S)
    assert len(code) == 1 and len(code[0].strip().splitlines()) <= 16
    namespace = {}
    # least squares picks b1 < 0 on some folds, and GMC says so (the README too)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GreyStabilityWarning)
        exec(compile(code[0], "README quickstart", "exec"), namespace)
    unstable = [w for w in caught if issubclass(w.category, GreyStabilityWarning)]
    assert unstable and all("b1 = -" in str(w.message) for w in unstable)
    assert len(unstable) == len(caught), [str(w.message) for w in caught]
    search = namespace["search"]
    # five sensors and a model chosen leaving whole tests out; RMSE in µm
    assert search.best_params_["select__n_clusters"] in (3, 5)
    assert 0 < -search.best_score_ < 10
    assert capsys.readouterr().out
