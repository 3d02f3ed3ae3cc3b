"""A public API a user can hold in their head: few names, each in the API reference, each described.

The public names are those in the ``__all__`` of :mod:`greyml` and of every
public module below it (no ``_`` in its path), found by walking the package,
so that a new sub-package is counted without being listed here.
"""

import ast
import functools
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import greyml

#: At most this many distinct public names, over greyml and its public modules.
MAX_PUBLIC_NAMES = 80

ROOT = Path(greyml.__file__).resolve().parent
DOCS = ROOT.parent / "docs"


def _public_modules():
    names = ["greyml"]
    for info in pkgutil.walk_packages(greyml.__path__, prefix="greyml."):
        if "._" not in info.name:  # private modules, greyml.__main__ too
            names.append(info.name)
    return names


def _public_names():
    """``{name: [(module, object), ...]}`` over every public module's ``__all__``."""
    names = {}
    for module_name in _public_modules():
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):
            names.setdefault(name, []).append((module_name, getattr(module, name)))
    return names


PUBLIC = _public_names()


@functools.cache
def _api_reference():
    pages = [DOCS / "api.rst", *sorted((DOCS / "api").glob("*.rst"))]
    return "\n".join(page.read_text(encoding="utf-8") for page in pages)


@functools.cache
def _attribute_docs():
    """Names assigned at module level with a ``#:`` comment above or a string below,
    over every module of greyml (private ones too: a constant is defined in one)."""
    documented = set()
    for path in ROOT.rglob("*.py"):
        source = path.read_text(encoding="utf-8")
        lines = source.splitlines()
        body = ast.parse(source).body
        for k, node in enumerate(body):
            if isinstance(node, ast.Assign):
                targets = [t.id for t in node.targets if isinstance(t, ast.Name)]
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                targets = [node.target.id]
            else:
                continue
            above = node.lineno >= 2 and lines[node.lineno - 2].lstrip().startswith("#:")
            below = (
                k + 1 < len(body)
                and isinstance(body[k + 1], ast.Expr)
                and isinstance(body[k + 1].value, ast.Constant)
                and isinstance(body[k + 1].value.value, str)
            )
            if above or below:
                documented.update(targets)
    return documented


def test_at_most_80_public_names():
    assert len(PUBLIC) <= MAX_PUBLIC_NAMES, sorted(PUBLIC)


def test_no_kernels_namespace_and_no_kernel_at_the_top_level():
    assert not [name for name in PUBLIC if name == "kernels" or name.endswith(".kernels")]
    assert not [m for m in _public_modules() if m.endswith(".kernels")]
    for name in ("fit_gm1n", "simulate_gmc", "GreyStabilityWarning", "UnderdeterminedWarning"):
        assert name not in greyml.__all__
        with pytest.raises(AttributeError):
            getattr(greyml, name)


def test_warnings_and_errors_are_public_in_greyml_exceptions_only():
    for name, places in PUBLIC.items():
        obj = places[0][1]
        if inspect.isclass(obj) and issubclass(obj, (Warning, Exception)):
            modules = {module for module, _ in places}
            # greyml.gap's own GapWarning: that package's __all__ is edited elsewhere
            assert modules - {"greyml.gap"} == {"greyml.exceptions"}, (name, modules)


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_every_public_name_is_in_the_api_reference(name):
    text = _api_reference()
    assert re.search(rf"(?<!\w){re.escape(name)}(?!\w)", text), (
        f"{name} (from {[m for m, _ in PUBLIC[name]]}) is not in docs/api.rst or docs/api/"
    )


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_every_public_name_has_a_docstring(name):
    module, obj = PUBLIC[name][0]
    if inspect.isclass(obj) or inspect.isfunction(obj) or inspect.ismodule(obj):
        assert obj.__doc__ and obj.__doc__.strip(), f"{module}.{name} has no docstring"
    else:  # a constant: a "#:" comment above its assignment, as Sphinx reads it
        assert name in _attribute_docs(), f"{module}.{name} has no '#:' comment"
