"""Sphinx configuration of greyml's documentation.

Build from the repository root (the ``docs`` extra installs what it needs)::

    pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

Intersphinx links to Python, NumPy, SciPy, scikit-learn and pandas are made
whenever their inventories can be fetched (a short probe first); offline, the
build goes on without them, with one line on the console and no warning.
``GREYML_DOCS_INTERSPHINX=0`` turns them off. The gallery runs every
``examples/**/plot_*.py``; its sections are the sub-folders of ``examples/``.
"""

import argparse
import os
import re
import shutil
import sys
import urllib.request
from concurrent.futures import ThreadPoolExecutor
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
    "matplotlib.sphinxext.plot_directive",
]
templates_path = ["_templates"]
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
root_doc = "index"
# "On this page" of an API page lists fit(), predict()..., not the class's
# name before each
toc_object_entries_show_parents = "hide"

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

# -- intersphinx: on whenever the inventories can be reached -------------
_INVENTORIES = {
    "python": "https://docs.python.org/3",
    "numpy": "https://numpy.org/doc/stable",
    "scipy": "https://docs.scipy.org/doc/scipy",
    "sklearn": "https://scikit-learn.org/stable",
    "pandas": "https://pandas.pydata.org/docs",
}


def _reachable(url, timeout=4.0):
    """Whether ``url/objects.inv`` answers within ``timeout`` seconds."""
    try:
        with urllib.request.urlopen(f"{url}/objects.inv", timeout=timeout) as answer:
            return answer.status == 200
    except Exception:  # noqa: BLE001 (offline, refused, timed out: no link)
        return False


def _intersphinx_mapping():
    """The inventories that answer now; the others are left out.

    Sphinx warns (an error with ``-W``) about an inventory it cannot fetch, so
    only those that answered a probe a moment ago are given to it: online
    the API pages link to the five projects, offline the build still passes.
    """
    if os.environ.get("GREYML_DOCS_INTERSPHINX", "") == "0":
        return {}
    with ThreadPoolExecutor(len(_INVENTORIES)) as pool:
        up = dict(zip(_INVENTORIES, pool.map(_reachable, _INVENTORIES.values())))
    missing = sorted(name for name, ok in up.items() if not ok)
    if missing:
        print(
            f"greyml docs: no intersphinx links to {', '.join(missing)} (inventory not reachable)"
        )
    return {name: (url, None) for name, url in _INVENTORIES.items() if up[name]}


intersphinx_mapping = _intersphinx_mapping()
intersphinx_timeout = 10

# -- sphinx-gallery ---------------------------------------------------------
# The examples save their figures only when $GREYML_EXAMPLE_OUT names a folder
# (tests/test_examples.py sets it); the gallery captures the figures itself,
# so the build leaves the variable unset and nothing is written or printed.
os.environ.pop("GREYML_EXAMPLE_OUT", None)

sphinx_gallery_conf = {
    # examples/README.txt is the gallery's header; each sub-folder with a
    # README.txt is a section, in this order (a folder not named here comes
    # where "*" is)
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "subsection_order": [
        "../examples/models",
        "../examples/selection",
        "../examples/dynamic",
        "../examples/gap",
        "*",
        "../examples/real_data",
    ],
    "within_subsection_order": "FileNameSortKey",
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
    # "Gallery examples" on every API page: which examples use which greyml
    # name (docs/_templates/autosummary/*.rst holds the minigallery)
    "doc_module": ("greyml",),
    "backreferences_dir": "generated/backreferences",
    "inspect_global_variables": True,
}

# -- the real data ------------------------------------------------------------
# The CAIVIAC recording, never part of greyml: $GREYML_CAIVIAC, else
# ../shared/realdata/caiviac beside this checkout. The variable is set for the
# gallery's examples and the landing figure, which read it from there (and run
# on simulated data, or skip, when the folder holds no cycles.csv).
os.environ.setdefault("GREYML_CAIVIAC", str(HERE.parent.parent / "shared" / "realdata" / "caiviac"))

# -- the landing page's figure (matplotlib's plot directive) ---------------
# docs/landing_figure.py draws the CAIVIAC recording when it is found, else
# the simulated VMC; the caption under it (|landing-data| in index.rst) says
# which.
if (Path(os.environ["GREYML_CAIVIAC"]) / "cycles.csv").is_file():
    _LANDING_DATA = (
        "the CAIVIAC recording of a real machine tool (probe ch1, five 8 h cycles "
        "at 1250 to 5000 rpm), found beside this checkout when the page was "
        "built; displacement from each cycle's first row"
    )
else:
    _LANDING_DATA = (
        "greyml's simulated VMC (six simulated heating and cooling tests), because "
        "the CAIVIAC recording was not found when this page was built; displacement "
        "from each test's first row"
    )
rst_epilog = f"\n.. |landing-data| replace:: {_LANDING_DATA}\n"
plot_include_source = False
plot_html_show_source_link = False
plot_html_show_formats = False
plot_formats = [("png", 100)]
# a figure drawn at 10 in or wider is shown at about 7 in beside the side bars
plot_rcparams = {"figure.autolayout": False, "font.size": 11.5}

# -- HTML -------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"greyml {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    # the header holds the root toctree's pages: User guide, API, Examples,
    # Contributing; none hidden under "More"
    "header_links_before_dropdown": 6,
    "navbar_align": "left",
    # the landing page needs its width, not an empty "On this page"
    # the gallery's pages need the width for code and printed tables (lines
    # of up to 100 characters), not an "On this page"
    # (the theme refuses a page that two wildcards match: no "**")
    "secondary_sidebar_items": {
        "*": ["page-toc", "sourcelink"],
        "api/*": ["page-toc", "sourcelink"],
        "generated/*": ["page-toc", "sourcelink"],
        "index": [],
        "auto_examples/**": [],
    },
}
html_sidebars = {"index": []}
# docs/_static/greyml.css: full titles of API pages, wrapped method names
html_static_path = ["_static"]
html_css_files = ["greyml.css"]


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
        # vars(), not getattr(): a package's __getattr__ serves moved names with a warning
        if not modname.startswith("greyml") or vars(module).get(short) is not obj:
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


# -- fitted attributes that are properties -----------------------------------
def _skip_fitted_properties(app, what, name, obj, skip, options):
    """Leave a fitted attribute that is a property (``gains_``) out of the members.

    numpydoc shows it in the class's Attributes, with the property's own
    docstring; listed again among the methods it would be described twice.
    """
    fitted = name.endswith("_") and not name.startswith("_")
    if what == "class" and fitted and isinstance(obj, property):
        return True
    return None


# -- private base classes ---------------------------------------------------
def _public_bases(app, name, obj, options, bases):
    """Show a class's public bases: a private one is replaced by its own.

    ``GMC`` derives from ``_GreyConvolutionModel``, ``ANFISGrid`` from
    ``_ANFISBase``; the "Bases:" line names what a user can look up.
    """
    public = []

    def add(base):
        if base.__name__.startswith("_"):
            for parent in base.__bases__:
                add(parent)
        elif base not in public and base is not object:
            public.append(base)

    for base in list(bases):
        add(base)
    bases[:] = public or [object]


# -- the README, read where it lies ------------------------------------------
# The landing page shows the README's purpose and command-line table, and
# the command-line page its table, read from README.md at build time so that
# the two never drift apart.
from docutils import nodes  # noqa: E402
from docutils.parsers.rst import Directive, directives  # noqa: E402
from docutils.statemachine import StringList  # noqa: E402

README = ROOT / "README.md"


def _readme_section(title):
    """The text of the README's ``## title`` section, or its opening."""
    text = README.read_text(encoding="utf-8")
    if title == "opening":
        body = text.split("\n", 1)[1]  # below "# greyml"
    else:
        body = text.split(f"\n## {title}\n", 1)[1]
    return body.split("\n## ", 1)[0]


def _inline(markdown):
    """Markdown inline markup as reStructuredText: code and links."""
    text = re.sub(r"(?<!`)`([^`]+)`(?!`)", r"``\1``", markdown)
    return re.sub(r"\[([^\]]+)\]\(([^)]+)\)", r"`\1 <\2>`__", text)


class ReadmeDirective(Directive):
    """``.. readme:: Section title`` with ``:part:`` python, paragraphs or table."""

    required_arguments = 1
    final_argument_whitespace = True
    option_spec = {"part": lambda arg: directives.choice(arg, ("python", "paragraphs", "table"))}

    def run(self):
        self.state.document.settings.record_dependencies.add(str(README))
        section = _readme_section(self.arguments[0])
        part = self.options.get("part", "paragraphs")
        if part == "python":
            (code,) = re.findall(r"```python\n(.*?)```", section, re.S)
            block = nodes.literal_block(code, code)
            block["language"] = "python"
            return [block]
        if part == "table":
            rows = [line for line in section.splitlines() if line.startswith("|")]
            cells = [[_inline(c.strip()) for c in row.strip("|").split(" | ")] for row in rows]
            header, body = cells[0], cells[2:]  # cells[1] is the --- line
            lines = [".. list-table::", "   :header-rows: 1", ""]
            for row in [header, *body]:
                lines.append(f"   * - {row[0]}")
                lines.extend(f"     - {cell}" for cell in row[1:])
        else:
            prose = re.sub(r"```.*?```", "", section, flags=re.S)
            lines = [_inline(line) for line in prose.strip().splitlines()]
        container = nodes.container()
        self.state.nested_parse(StringList(lines, str(README)), self.content_offset, container)
        return container.children


class CommandHelpDirective(Directive):
    """``.. greyml-help:: gap``: the ``--help`` text of a command, as of this build.

    Taken from :func:`greyml.cli.build_parser` when the page is built (80
    columns), so the command-line page always shows the options the code has.
    Without an argument: ``greyml --help``.
    """

    optional_arguments = 1

    def run(self):
        from greyml.cli import build_parser

        kept = os.environ.get("COLUMNS")
        os.environ["COLUMNS"] = "80"
        try:
            parser = build_parser()
            if self.arguments:
                (commands,) = [
                    a for a in parser._actions if isinstance(a, argparse._SubParsersAction)
                ]
                parser = commands.choices[self.arguments[0]]
            text = parser.format_help()
        finally:
            if kept is None:
                os.environ.pop("COLUMNS")
            else:
                os.environ["COLUMNS"] = kept
        block = nodes.literal_block(text, text)
        block["language"] = "none"
        return [block]


def setup(app):
    # before numpydoc (priority 500) rewrites the docstring
    app.connect("autodoc-process-docstring", _constant_doc, priority=100)
    app.connect("autodoc-process-bases", _public_bases)
    app.connect("autodoc-skip-member", _skip_fitted_properties)
    app.add_directive("readme", ReadmeDirective)
    app.add_directive("greyml-help", CommandHelpDirective)
