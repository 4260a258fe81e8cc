"""Sphinx configuration of the manta_drake API reference (``make docs``).

The reference's sources are ``docs/api/*.rst``; the other pages of ``docs/`` (Markdown)
and the tutorial notebook are not part of this build. ``_ext/pydrake_system.py`` renders
the Systems' ``.. pydrake_system::`` port blocks as diagrams.
"""

import pathlib
import sys

# A build writes only into its output and cache folders: no __pycache__ in docs/_ext or the
# package (``make docs DOCS_OUT=/elsewhere`` leaves the checkout as it was).
sys.dont_write_bytecode = True

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))  # document the working tree's package

from manta_drake.version import __version__  # noqa: E402

project = "manta_drake"
author = "the manta_drake authors"
copyright = "the manta_drake authors"
version = release = __version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "pydrake_system",
]

root_doc = "api/index"
include_patterns = ["api/**"]
exclude_patterns = ["_build"]
toc_object_entries = False  # the contents list pages, not every function

# Google-style docstrings only.
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_preserve_defaults = True  # `params=DEFAULT_ROBOT`, not its repr
autodoc_class_signature = "mixed"
autodoc_default_options = {"members": True, "show-inheritance": True}

html_theme = "alabaster"
html_title = f"manta_drake {release} API reference"
html_theme_options = {"description": "A Drake simulation of a multi-jointed manta-ray robot"}
html_copy_source = False
html_show_sourcelink = False


def _redirect_index(app, exception):
    """The reference's front page is api/index.html; index.html at the top points to it."""
    if exception is None and app.builder.format == "html" and app.builder.name != "singlehtml":
        target = pathlib.Path(app.outdir) / "index.html"
        target.write_text(
            '<!DOCTYPE html>\n<meta charset="utf-8">\n'
            '<meta http-equiv="refresh" content="0; url=api/index.html">\n'
            "<title>manta_drake API reference</title>\n"
            '<a href="api/index.html">manta_drake API reference</a>\n'
        )


def setup(app):
    app.connect("build-finished", _redirect_index)
