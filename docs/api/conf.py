"""Sphinx configuration of groundplane's API reference (built by tests/test_api_docs.py with
warnings as errors): ``sphinx-build -W -b html docs/api docs/api/_build``."""
project = "groundplane"
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon"]
napoleon_numpy_docstring = True
napoleon_google_docstring = False
autodoc_typehints = "description"
autodoc_member_order = "bysource"
html_theme = "alabaster"
exclude_patterns = ["_build"]
# the docstrings cross-reference internal modules the reference does not document
nitpicky = False
