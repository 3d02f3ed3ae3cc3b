"""Sphinx configuration of greyml's documentation.

Build from the repository root (the ``docs`` extra installs what it needs)::

    pip install -e ".[docs]"
    sphinx-build -W --keep-going -b html docs docs/_build/html

The build never needs the network: intersphinx links to Python, NumPy,
SciPy, scikit-learn and pandas are made only when ``GREYML_DOCS_INTERSPHINX=1``.
The gallery runs every ``examples/plot_*.py``; the figures the examples save
themselves go to ``docs/_build/example_out``, not into the working tree.
"""

import os
import shutil
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
os.environ["MPLBACKEND"] = "Agg"

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))  # the package of this checkout, installed or not

import greyml  # noqa: E402

# -- project ---------------------------------------------------------------
project = "greyml"
author = "The greyml developers"
copyright = "The greyml developers"  # noqa: A001 (Sphinx's name)
release = greyml.__version__
version = release

# -- general ---------------------------------------------------------------
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]
templates_path = ["_templates"]
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
root_doc = "index"

# -- autodoc / autosummary / numpydoc --------------------------------------
autosummary_generate = True
# the stubs are regenerated on every build: a stale one (of a name taken out
# of api.rst) would otherwise be a page in no toctree, a warning
shutil.rmtree(HERE / "generated", ignore_errors=True)
autosummary_imported_members = False
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # types are in the numpydoc Parameters sections
autoclass_content = "class"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
numpydoc_validation_checks = set()
numpydoc_xref_param_type = False

# -- intersphinx: only on request, so that the build runs offline ----------
if os.environ.get("GREYML_DOCS_INTERSPHINX", "") == "1":
    intersphinx_mapping = {
        "python": ("https://docs.python.org/3", None),
        "numpy": ("https://numpy.org/doc/stable", None),
        "scipy": ("https://docs.scipy.org/doc/scipy", None),
        "sklearn": ("https://scikit-learn.org/stable", None),
        "pandas": ("https://pandas.pydata.org/docs", None),
    }
else:
    intersphinx_mapping = {}

# -- sphinx-gallery ---------------------------------------------------------
# The examples write their own figures to $GREYML_EXAMPLE_OUT: keep them in
# the build folder.
EXAMPLE_OUT = HERE / "_build" / "example_out"
EXAMPLE_OUT.mkdir(parents=True, exist_ok=True)
os.environ["GREYML_EXAMPLE_OUT"] = str(EXAMPLE_OUT)

EXAMPLES = ROOT / "examples"
GALLERY_HEADER = """\
Examples
========

Scripts that run greyml end to end on simulated and real heating/cooling
tests. They run whenever this documentation is built, and each page shows
the code with the printed output and the figures of that run. The two
CAIVIAC examples read the real recording from ``../shared/realdata/caiviac``
(or ``$GREYML_CAIVIAC``); without it they say so and stop.
"""
_HEADERS = ("GALLERY_HEADER.rst", "GALLERY_HEADER.txt", "README.rst", "README.txt")


def _gallery_source():
    """The examples folder, or a copy of it with a gallery header added.

    sphinx-gallery needs a header file in the folder it reads; while
    ``examples/`` has none, the build reads a copy in ``_build``.
    """
    if any((EXAMPLES / name).is_file() for name in _HEADERS):
        return os.path.relpath(EXAMPLES, HERE)
    staged = HERE / "_build" / "gallery_src"
    if staged.exists():
        shutil.rmtree(staged)
    staged.mkdir(parents=True)
    for script in sorted(EXAMPLES.glob("*.py")):
        shutil.copy2(script, staged / script.name)
    (staged / "README.txt").write_text(GALLERY_HEADER, encoding="utf-8")
    return os.path.relpath(staged, HERE)


sphinx_gallery_conf = {
    "examples_dirs": _gallery_source(),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py",
    "plot_gallery": "True",
    "download_all_examples": False,
    "write_computation_times": False,  # printed in the log; no sg_execution_times.rst
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
}

# -- HTML -------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"greyml {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_static_path = []


# -- module constants -------------------------------------------------------
def _constant_doc(app, what, name, obj, options, lines):
    """Give a re-exported constant the ``#:`` comment where it is defined.

    autodoc reads ``#:`` comments from the module a name is documented in;
    for ``greyml.TEST_LEVEL`` (defined in ``greyml._sequences``) it finds
    none and shows the docstring of ``str``. Look the comment up in the
    greyml module that defines the name, and never show a builtin type's
    docstring for a value.
    """
    if what != "data":
        return
    from sphinx.pycode import ModuleAnalyzer

    short = name.rpartition(".")[2]
    for modname, module in sorted(sys.modules.items()):
        if not modname.startswith("greyml") or getattr(module, short, None) is not obj:
            continue
        try:
            docs = ModuleAnalyzer.for_module(modname).find_attr_docs()
        except Exception:  # noqa: BLE001 (no source: try the next module)
            continue
        comment = docs.get(("", short))
        if comment:
            lines[:] = [line for line in comment if line is not None]
            return
    own = type(obj).__doc__
    if own and " ".join(" ".join(lines).split()) == " ".join(own.split()):
        lines[:] = []


def setup(app):
    # before numpydoc (priority 500) rewrites the docstring
    app.connect("autodoc-process-docstring", _constant_doc, priority=100)
