"""Docstring text that several functions share, written once."""

from __future__ import annotations


def shared_doc(**texts):
    """A decorator: each ``{name}`` in the function's docstring becomes ``texts[name]``.

    Only these names are replaced, so other braces (LaTeX, set displays) stay as
    they are; a docstring need not use them all. A text that continues over
    several lines carries the indentation of its place in the docstring. Under
    ``python -OO`` there are no docstrings, and the function is left as it is.
    """

    def decorate(function):
        doc = function.__doc__
        if doc is None:
            return function
        for name, text in texts.items():
            doc = doc.replace("{" + name + "}", text)
        function.__doc__ = doc
        return function

    return decorate
