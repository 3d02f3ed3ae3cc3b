"""Every public class and function has a numpydoc docstring with a runnable example.

Issue #7: each name in a public module's ``__all__`` that is a class or a
function carries an ``Examples`` section with at least one ``>>>`` line. The
examples themselves run as doctests (``--doctest-modules`` in pytest's
``addopts``); this checks that they exist.
"""

import importlib
import inspect
import re

import pytest

MODULES = [
    "greyml",
    "greyml.simulation",
    "greyml.datasets",
    "greyml.io",
    "greyml.metrics",
    "greyml.optimize",
    "greyml.grey",
    "greyml.grey.kernels",
    "greyml.fuzzy",
    "greyml.fuzzy.kernels",
    "greyml.neural",
    "greyml.neural.kernels",
    "greyml.preprocessing",
    "greyml.persist",
    "greyml.cli",
    "greyml.selection",
    "greyml.gap",
    "gap_harness",  # benchmarks/gap_harness: the gap validation, outside the package
    "greyml.dynamic",
    "greyml.exceptions",
    "greyml.utils.discovery",
]

# numpydoc section header: the title, then a line of dashes at least as long
_EXAMPLES = re.compile(r"^Examples\n-{8,}\n", re.M)


def _public_names():
    names = []
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isclass(obj) or inspect.isfunction(obj):
                names.append(pytest.param(obj, id=f"{module_name}.{name}"))
    return names


def test_every_public_module_is_checked():
    import pkgutil

    import greyml

    public = {
        name
        for _, name, _ in pkgutil.walk_packages(greyml.__path__, prefix="greyml.")
        if "._" not in name and name != "greyml.utils"
    }
    assert sorted(public - set(MODULES)) == []


def test_every_module_exports_names():
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        assert module.__all__, module_name
        for name in module.__all__:
            assert hasattr(module, name), f"{module_name}.__all__ names missing {name!r}"


@pytest.mark.parametrize("obj", _public_names())
def test_has_examples_section(obj):
    # the object's own docstring: a class does not inherit its base's here
    doc = obj.__doc__
    assert doc and doc.strip(), f"{obj.__qualname__} has no docstring"
    doc = inspect.cleandoc(doc)
    match = _EXAMPLES.search(doc)
    assert match, f"{obj.__qualname__}'s docstring has no numpydoc 'Examples' section"
    assert ">>>" in doc[match.end() :], f"{obj.__qualname__}'s Examples section has no '>>>'"


def test_every_public_module_imports_without_docstrings():
    # python -OO strips docstrings; text shared between docstrings must not need them
    import subprocess
    import sys

    modules = [
        "greyml",
        "greyml.cli",
        "greyml.datasets",
        "greyml.dynamic",
        "greyml.gap",
        "gap_harness",
        "greyml.metrics",
        "greyml.persist",
        "greyml.simulation",
        "greyml.utils.discovery",
    ]
    from pathlib import Path

    benchmarks = str(Path(__file__).resolve().parents[1] / "benchmarks")  # gap_harness
    code = (
        f"import importlib, sys\nsys.path.insert(0, {benchmarks!r})\n"
        f"for m in {modules!r}:\n    importlib.import_module(m)\nprint('ok')"
    )
    done = subprocess.run([sys.executable, "-OO", "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "ok"
