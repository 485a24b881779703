"""Sphinx configuration of the paa_mj documentation (``sphinx-build -W -b html docs out/docs``)."""
import os
import sys

sys.path.insert(0, os.path.abspath(".."))

from paa_mj import __version__  # noqa: E402

project = "paa_mj"
author = "The paa_mj developers"
copyright = "2026, the paa_mj developers"
version = release = __version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_nb",
]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
nb_execution_mode = "off"  # the test suite runs the tutorial itself (tests/test_docs.py)
numpydoc_show_class_members = False
numpydoc_validation_checks = set()
autodoc_member_order = "bysource"
autodoc_inherit_docstrings = False
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "kip_filmstrip.png"]
html_theme = "alabaster"
html_static_path = []
html_theme_options = {"description": "The PAA gymnast on a high bar, in MuJoCo", "fixed_sidebar": True}
suppress_warnings = ["myst.header"]
nitpicky = False


def _numpydoc_template_compiled_once():
    """numpydoc compiles its docstring template again for every object it documents (about 1,500 times here, a
    fifth of the build's time); the template is the same each time, so it is compiled once and kept."""
    try:
        import numpydoc.docscrape_sphinx as numpydoc_sphinx
    except ImportError:
        return
    environment = getattr(numpydoc_sphinx, "SandboxedEnvironment", None)
    if environment is None or getattr(environment, "_paa_mj_once", False):
        return
    compiled = {}

    class CompiledOnce(environment):
        _paa_mj_once = True

        def get_template(self, name, *args, **kwargs):
            key = (name, type(self.loader).__name__)
            if key not in compiled:
                compiled[key] = super().get_template(name, *args, **kwargs)
            return compiled[key]

    numpydoc_sphinx.SandboxedEnvironment = CompiledOnce


_numpydoc_template_compiled_once()
