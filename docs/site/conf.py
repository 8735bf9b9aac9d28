"""Sphinx configuration of boundid's documentation site (`make docs`: HTML in reports/docs/).

Strict: `make docs` runs with -W --keep-going and nitpicky cross-references, so a broken reference to
one of boundid's own names, or a public name documented here without a docstring, fails the build.
Nothing is downloaded at build time (no intersphinx): references to other libraries' names are
ignored below, boundid's own must resolve.
"""

import sys
from pathlib import Path

import boundid

sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))

project = "boundid"
author = "the boundid authors"
copyright = "the boundid authors, MIT licence"  # noqa: A001 (the Sphinx setting's name)
version = release = boundid.__version__

extensions = [
    "myst_nb",  # Markdown pages (MyST) and the lessons' notebooks, executed beforehand by `boundid teach`
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "boundid_sphinx",  # _ext/boundid_sphinx.py: plain-text docstrings, strict references, docstrings required
]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb", ".rst": "restructuredtext"}
# the notebooks in lessons/notebooks/ are copied there by `make docs` already executed (by `boundid teach
# --fast`, which fails on a cell that raises): never executed again here
nb_execution_mode = "off"
root_doc = "index"
exclude_patterns = ["_build", "**/.ipynb_checkpoints"]
templates_path = ["_templates"]

# Markdown: $...$ and $$...$$ maths, ::: fences, anchors on headings down to ### (the included
# docs/references.md sections "refs §OBE", ... are linked by their anchors)
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# API reference: autosummary writes one page per public name into api/generated/ (not in git)
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True, "member-order": "bysource"}
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_preserve_defaults = True
autodoc_class_signature = "mixed"
# Cross-references: boundid's own names must resolve; names of Python, numpy, pandas and the
# other libraries are not checked (no inventories are downloaded)
nitpicky = True
_EXTERNAL = ("np", "numpy", "pd", "pandas", "scipy", "cvxpy", "dask", "distributed", "pinocchio", "pin",
             "matplotlib", "mujoco", "rich", "pyarrow", "typing", "collections", "pathlib", "Path", "abc",
             "numbers", "enum", "concurrent", "threading", "multiprocessing", "datetime", "io", "os", "sys",
             "argparse", "dataclasses", "types", "numba", "highspy", "clarabel", "filterpy", "control")
_BUILTINS = ("int", "float", "str", "bool", "bytes", "dict", "list", "tuple", "set", "frozenset", "object",
             "None", "type", "callable", "Callable", "Iterable", "Iterator", "Sequence", "Mapping", "Any",
             "Literal", "NamedTuple", "TypeVar", "ValueError", "TypeError", "RuntimeError", "Exception",
             "KeyError", "optional", "array_like", "array-like", "ndarray", "DataFrame", "Series", "Self",
             "ArrayLike", "NDArray", "slice", "complex", "range", "Generator", "Protocol", "ClassVar",
             "Ellipsis", "ellipsis", "NotImplemented", "Counter")
nitpick_ignore_regex = [
    (r"py:.*", rf"({'|'.join(_EXTERNAL)})(\..*)?"),
    (r"py:.*", rf"({'|'.join(_BUILTINS)})"),
]

html_theme = "pydata_sphinx_theme"
html_title = f"boundid {release}"
html_static_path = ["_static"]
html_css_files = ["boundid.css"]
html_show_sourcelink = False
html_copy_source = False
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"index": []}
