"""Sphinx configuration of uw3p's documentation site (``make docs``; warnings are errors)."""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "uw3p"
author = "uw3p contributors"
copyright = "2026, uw3p contributors"  # noqa: A001
try:
    from importlib.metadata import version as _version

    release = _version("uw3p")
except Exception:  # pragma: no cover - an uninstalled checkout
    release = "unknown"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "uw3p_gallery",
    "uw3p_pages",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3

templates_path = ["_templates"]
autosummary_generate = True
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

html_theme = "pydata_sphinx_theme"
html_title = f"uw3p {release}"
html_theme_options = {"navigation_depth": 2, "show_toc_level": 2}

#: Where the gallery takes its figures: ``UW3P_FIGURES`` (``make docs`` sets it), else
#: ``figures/`` of the checkout (``make reproduce-figures``).
uw3p_figures = os.environ.get("UW3P_FIGURES", str(ROOT / "figures"))
