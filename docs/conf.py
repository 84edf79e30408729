"""Sphinx configuration of the tendon-id documentation.

Build with ``make docs`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``):
warnings are errors.  No extension here needs the network (no intersphinx), and the built site
requests nothing from it: MathJax is bundled (sphinx-mathjax-offline).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # the gallery runs headless

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))  # import the checkout even without an editable install

# Datasets built while the docs run are cached inside the build folder, never in ~/.cache.
os.environ["TENDON_ID_CACHE"] = str(HERE / "_build" / "tendon-id-cache")

import tendon_id  # noqa: E402

# -- project ---------------------------------------------------------------------------------

project = "tendon-id"
author = "tendon-id developers"
copyright = "tendon-id developers"
version = tendon_id.__version__
release = tendon_id.__version__

# -- general ---------------------------------------------------------------------------------

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    # MathJax 3 bundled with the docs (copied into _static): equations render offline, no CDN.
    "sphinx-mathjax-offline",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    # The --help of every command, rendered from the Typer app when the docs build (docs/cli.rst).
    "sphinxcontrib.typer",
]

exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints", "examples/README.rst"]
templates_path = ["_templates"]
root_doc = "index"
default_role = "literal"  # `x` in prose is code, never a cross-reference that could fail
nitpicky = False

# autodoc / autosummary
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc docstrings already say the types
autodoc_mock_imports: list[str] = []

# numpydoc
numpydoc_show_class_members = False
numpydoc_show_inherited_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
numpydoc_xref_param_type = False
numpydoc_attributes_as_param_list = True

# -- sphinx-gallery ----------------------------------------------------------------------------

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "abort_on_example_error": True,
    "remove_config_comments": True,
    "plot_gallery": "True",
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "min_reported_time": 1,
    # The timing pages load DataTables and jQuery from a CDN: left out, so the site requests nothing online.
    "write_computation_times": False,
    # Examples run in separate processes, one per core (at most 4): each is a seeded, self-contained
    # script, so their pages are the same; CI's docs step halves on 2 cores.
    "parallel": max(1, min(4, os.cpu_count() or 1)),
}

# -- HTML ------------------------------------------------------------------------------------

try:
    import pydata_sphinx_theme  # noqa: F401

    html_theme = "pydata_sphinx_theme"
    html_theme_options = {
        "navigation_with_keys": False,
        "show_toc_level": 2,
        "navbar_align": "left",
    }
except ImportError:  # pragma: no cover - the docs extra installs it
    html_theme = "alabaster"
    html_theme_options = {}

html_title = f"tendon-id {release}"
html_static_path: list[str] = []
# Pages written by benchmarks (the regime map), copied as they are to the root of the site.
html_extra_path = ["_extra"]
html_show_sourcelink = False


# -- a directive that renders a settings dataclass as a table of its defaults -------------------
#
#   .. dataclass-defaults:: tendon_id.geometry.RobotGeometry
#
# The table is built from the dataclass fields and the numpydoc ``Parameters`` section of its
# docstring at build time, so the documented defaults can never drift from the code.

import dataclasses  # noqa: E402
import importlib  # noqa: E402
import re  # noqa: E402
from collections.abc import Mapping  # noqa: E402

from docutils.parsers.rst import directives  # noqa: E402
from docutils.statemachine import StringList  # noqa: E402
from numpydoc.docscrape import NumpyDocString  # noqa: E402
from sphinx.util.docutils import SphinxDirective  # noqa: E402

_BARE_DEFAULT = re.compile(r"\s*Default:?\s+[^\s]+\.$")


def _format_default(value) -> str:
    if isinstance(value, Mapping):
        value = dict(value)
    if isinstance(value, float):
        return f"``{value:.6g}``"
    if isinstance(value, tuple):
        return "``(" + ", ".join(f"{v:.6g}" if isinstance(v, float) else repr(v) for v in value) + ")``"
    return f"``{value!r}``"


class DataclassDefaults(SphinxDirective):
    """List-table of a dataclass's fields: name, default, description."""

    required_arguments = 1
    option_spec = {"title": directives.unchanged}

    def run(self):
        module_name, _, cls_name = self.arguments[0].rpartition(".")
        cls = getattr(importlib.import_module(module_name), cls_name)
        descriptions = {}
        for p in NumpyDocString(cls.__doc__ or "")["Parameters"]:
            text = " ".join(line.strip() for line in p.desc)
            text = _BARE_DEFAULT.sub("", text).strip()
            for name in p.name.split(","):
                descriptions[name.strip()] = text
        rows = []
        for f in dataclasses.fields(cls):
            if f.default is not dataclasses.MISSING:
                default = f.default
            elif f.default_factory is not dataclasses.MISSING:
                default = f.default_factory()
            else:
                default = None
            rows.append((f"``{f.name}``", _format_default(default), descriptions.get(f.name, "")))
        lines = [
            f".. list-table:: {self.options.get('title', '')}".rstrip(),
            "   :header-rows: 1",
            "   :widths: 22 22 56",
            "",
            "   * - setting",
            "     - default",
            "     - meaning",
        ]
        if not rows:
            lines += ["   * - (none)", "     -", "     - This effect has no settings of its own."]
        for name, default, desc in rows:
            lines += [f"   * - {name}", f"     - {default}", f"     - {desc}"]
        node_list = StringList(lines, source=f"<dataclass-defaults {self.arguments[0]}>")
        from docutils import nodes

        container = nodes.container()
        self.state.nested_parse(node_list, self.content_offset, container)
        return container.children


# -- a directive that lists the zoo's models from its registry ---------------------------------
#
#   .. zoo-models::
#
# One bullet per registered model: its name and the first line of its class's docstring.


class ZooModels(SphinxDirective):
    """Bullet list of :func:`tendon_id.zoo.names`, each with its class's one-line summary."""

    def run(self):
        from docutils import nodes

        from tendon_id.zoo.registry import model_class, names

        lines = []
        for name in names():
            summary = (model_class(name).__doc__ or "").strip().splitlines()
            lines.append(f"* ``{name}``: {summary[0] if summary else ''}")
        container = nodes.container()
        self.state.nested_parse(StringList(lines, source="<zoo-models>"), self.content_offset, container)
        return container.children


def setup(app):
    app.add_directive("dataclass-defaults", DataclassDefaults)
    app.add_directive("zoo-models", ZooModels)
