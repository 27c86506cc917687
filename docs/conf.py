"""Sphinx configuration of the vibtrans documentation (`make docs`).

Sphinx with MyST (myst-nb) and the PyData theme: the convention of the
field's libraries (numpy, xarray, HoloViz), Markdown pages that also read
well on GitHub, notebooks executed at every build (an error fails it), the
API reference from the docstrings (autodoc) and the command-line reference
from the parser itself (sphinx-argparse).  Built with -W: a warning fails.
"""

import argparse
import os
import re
import sys

from docutils import nodes
from sphinx.util.docutils import SphinxDirective

import vibtrans

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "_ext"))

project = "vibtrans"
author = "the vibtrans developers"
release = version = vibtrans.__version__

extensions = [
    "myst_nb",  # Markdown pages and executed notebooks (MyST-NB)
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.napoleon",  # the public API's numpydoc sections
    "sphinx.ext.viewcode",
    "benchresults",  # the latest benchmark results as tables (docs/_ext)
]
# the benches' JSON records (vibtrans.tools.results), relative to this folder
bench_results_dir = "../benchmarks/results"
# .rst first: autosummary writes its generated pages with the first suffix
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**/.ipynb_checkpoints", "figures/README.md"]
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# every notebook runs at every build; a failing cell fails the build
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_timeout = 600
nb_merge_streams = True

autosummary_generate = True
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"
napoleon_google_docstring = False
napoleon_numpy_docstring = True


def _as_text(line):
    """A docstring line as reStructuredText showing it as written: `name`
    as inline code, every other markup character escaped."""
    parts = re.split(r"`([^`]+)`", line)
    for i, part in enumerate(parts):
        if i % 2:
            parts[i] = f"``{part}``"
        else:
            for c in "\\*`|_":
                part = part.replace(c, "\\" + c)
            parts[i] = part
    return "".join(parts)


_NUMPYDOC_SECTIONS = {
    "Parameters",
    "Returns",
    "Raises",
    "Yields",
    "Attributes",
    "Other Parameters",
    "See Also",
    "Notes",
    "Examples",
    "Warns",
}
# sections whose unindented lines are names and types (napoleon reads them)
_NAMED_SECTIONS = {"Parameters", "Returns", "Raises", "Yields", "Attributes", "Other Parameters", "Warns"}


def _is_numpydoc(lines):
    return any(
        line.strip() in _NUMPYDOC_SECTIONS and nxt.strip() and set(nxt.strip()) == {"-"}
        for line, nxt in zip(lines, lines[1:])
    )


def _numpydoc_as_written(lines):
    """A numpydoc docstring's prose escaped as in `_as_text`, its section
    headers and the names and types of its entries left for napoleon."""
    out, section = [], None
    for i, line in enumerate(lines):
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() in _NUMPYDOC_SECTIONS and nxt.strip() and set(nxt.strip()) == {"-"}:
            section = line.strip()
            out.append(line)
        elif line.strip() and set(line.strip()) == {"-"}:
            out.append(line)
        elif section in _NAMED_SECTIONS and line and not line[0].isspace():
            out.append(line)
        else:
            out.append(_as_text(line))
    return out


def _docstring_as_written(app, what, name, obj, options, lines):
    """The docstrings are plain text written for `help()` (A*, m*, x*(t) and
    ASCII tables): the first paragraph stays text, its markup characters
    escaped (autosummary's one-line summaries come from it: a literal block
    there left every summary empty), the rest is shown as written, in a
    literal block, rather than parsed as reStructuredText (which would read
    every * as emphasis).  A numpydoc docstring (the public API's) keeps
    its sections for napoleon, its prose escaped."""
    if not lines:
        return
    if _is_numpydoc(lines):
        lines[:] = _numpydoc_as_written(lines)
        return
    cut = lines.index("") if "" in lines else len(lines)
    first = [_as_text(line) for line in lines[:cut]]
    rest = lines[cut:]
    while rest and not rest[0].strip():
        rest = rest[1:]
    lines[:] = first + (["", "::", ""] + ["    " + line for line in rest] + [""] if rest else [])


class CommandLineHelp(SphinxDirective):
    """`vibtrans --help` and every command's `--help`, from the parser
    (`vibtrans.cli.build_parser`), one section a command."""

    def run(self):
        from vibtrans.cli import build_parser

        os.environ["COLUMNS"] = "90"  # argparse's wrap width, fixed for the page
        parser = build_parser()
        out = [nodes.literal_block(text=parser.format_help(), language="text")]
        for action in parser._actions:  # read only: the sub-commands' parsers
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    section = nodes.section(ids=[f"vibtrans-{name}"])
                    section += nodes.title(text=f"vibtrans {name}")
                    section += nodes.literal_block(text=sub.format_help(), language="text")
                    out.append(section)
        return out


def setup(app):
    # before napoleon (priority 500), which turns numpydoc sections into fields
    app.connect("autodoc-process-docstring", _docstring_as_written, priority=400)
    app.add_directive("vibtrans-help", CommandLineHelp)


html_theme = "pydata_sphinx_theme"
# the light/dark mode a first visit gets (without it the theme's script
# logs "Got invalid theme mode" on every page: devtools/docshots.py)
html_context = {"default_mode": "auto"}
# pages with no sub-pages: no empty "Section Navigation" column beside them
html_sidebars = {"getting-started": [], "reference/*": [], "MODEL": [], "DYNAMICS": [], "SECURITY": []}
html_title = "vibtrans"
html_logo = None
html_theme_options = {
    "navigation_with_keys": False,
    "header_links_before_dropdown": 4,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "secondary_sidebar_items": ["page-toc"],
}
html_static_path = []
html_show_sourcelink = False
# Panel's and HoloViews' live-kernel mime types (the page shows their HTML)
suppress_warnings = [
    "myst.header",
    "mystnb.unknown_mime_type",
]  # MODEL.md's numbered sections start at level 2
