"""Every benchmark and example script at least compiles.

The benchmarks are run by hand, not by the suite, so a rename that leaves one
with a repeated keyword (a SyntaxError) would otherwise go unseen.
"""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "benchmarks").glob("*.py")) + sorted((ROOT / "examples").rglob("*.py"))


def test_there_are_scripts_to_check():
    assert len(SCRIPTS) > 10


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_script_compiles(path):
    compile(path.read_text(encoding="utf-8"), str(path), "exec")
