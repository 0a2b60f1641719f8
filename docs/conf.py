# Sphinx configuration of jamflow's documentation.
#
# Build (the Python module and the `jamflow` binary come from a build folder, default ../build):
#   PYTHONPATH=build JAMFLOW_BIN=build/jamflow sphinx-build -W -b html docs build/docs/html
# ctest runs the same as Docs.Build (tests/docs/).
import os
import pathlib
import sys

here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here / "_ext"))

# The module and the binary of a build folder: PYTHONPATH and JAMFLOW_BIN when given (ctest
# sets both), else ../build.
build = here.parent / "build"
if "JAMFLOW_BIN" not in os.environ:
    os.environ["JAMFLOW_BIN"] = str(build / "jamflow")
try:
    import jamflow  # noqa: F401
except ImportError:
    sys.path.insert(0, str(build))

project = "jamflow"
author = "the jamflow developers"
copyright = "the jamflow developers"
try:
    import jamflow

    release = version = jamflow.__version__
except ImportError:  # autodoc then fails loudly under -W
    release = version = ""

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "jamflow_cli",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "Thumbs.db", ".DS_Store"]

# MyST: `#anchor` links to headings down to ###, and $...$ left alone (no math extension).
myst_heading_anchors = 3
myst_enable_extensions = ["deflist"]

# autodoc on the compiled module: pybind11 writes the signature as the docstring's first line.
autodoc_docstring_signature = True
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}

html_theme = "furo"
html_title = f"jamflow {release}".strip()
html_show_sourcelink = False


def _hide_pybind11_base(app, name, obj, options, bases):
    # Every class of the module derives from pybind11's internal base; "Bases:" says nothing then.
    bases[:] = [b for b in bases if getattr(b, "__name__", "") != "pybind11_object"]


def setup(app):
    app.connect("autodoc-process-bases", _hide_pybind11_base)
