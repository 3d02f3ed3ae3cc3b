"""The README's commands and quickstart are what CI runs and what works."""

import re
import subprocess
import sys
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
    # .ci/run extracts the same blocks; check its parser on this README
    script = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    parser = script.split("<<'PY'\n", 1)[1].split("\nPY\n", 1)[0]
    out = subprocess.run(
        [sys.executable, "-c", parser], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert out == [" ".join(b.split()) for b in blocks]


def test_quickstart_runs(capsys):
    code = re.findall(r"```python\n(.*?)```", _section("Quickstart"), re.S)
    assert len(code) == 1 and len(code[0].strip().splitlines()) <= 16
    namespace = {}
    exec(compile(code[0], "README quickstart", "exec"), namespace)
    search = namespace["search"]
    # five sensors and a model chosen leaving whole tests out; RMSE in µm
    assert search.best_params_["select__n_clusters"] in (3, 5)
    assert 0 < -search.best_score_ < 10
    assert capsys.readouterr().out
