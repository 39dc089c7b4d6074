"""Sphinx configuration of qmesh's documentation site.

Why Sphinx: it is what the scientific-Python projects qmesh sits beside build their sites with —
NumPy, SciPy, scikit-fem and PyVista — so the API reference comes from the docstrings by
``autodoc`` and the theme is theirs (pydata-sphinx-theme). The pages are Markdown, read by MyST,
with ``dollarmath`` and ``amsmath`` for the equations. Neither the build nor the built pages need a
network: MathJax comes from the ``sphinx-mathjax-offline`` wheel and is copied into ``_static``.

Build: ``python -m sphinx -W --keep-going -b html docs build/docs`` (warnings are errors;
``tests/test_docs.py`` runs this). The benchmark pages ``benchmarks/*.md`` are written by the
scripts in ``benchmarks/`` and included by a glob; the site builds with none of them.
"""

import re
from pathlib import Path

project = "qmesh"
author = "the qmesh developers"
copyright = "the qmesh developers"
try:
    from qmesh import __version__ as release
except ImportError:           # the API pages need qmesh importable; the guide does not
    release = ""
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx-mathjax-offline",      # sets mathjax_path to the copy it puts in _static/mathjax
]

source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "design/README.md", "figures", "**/.ipynb_checkpoints"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# The API reference: members in source order, with their signatures' type hints in the text.
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_mock_imports = []

html_theme = "pydata_sphinx_theme"
html_title = "qmesh"
templates_path = ["_templates"]
html_static_path = ["_static"]
html_css_files = ["wrap-code.css"]          # code blocks wrap instead of scrolling sideways
# Every page in the left sidebar (`_templates/site-nav.html`), so the header holds no page links
# (it showed five and hid the rest under "More").
html_sidebars = {"**": ["site-nav"]}
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "navbar_center": [],
}

# The docstrings are plain text (backticks for names, indented tables of arguments, `|e|_h1`,
# `x**2`), not reStructuredText: `plain_docstring` makes them safe to parse — a name in backticks
# is code (`default_role`), RST's markup characters outside them are escaped, an indented block
# that follows a line of text is shown as it is typed, and a list gets the blank line RST needs.
default_role = "literal"

_BULLET = re.compile(r"^(?:[-*+•]|\d+[.)]) +")
_MARKUP = re.compile(r"(`[^`]*`)|([*|\\])|(?<=\w)_(?!\w)")


def _escape(line: str) -> str:
    """RST's inline markup characters escaped outside `...` spans (which stay code)."""
    def one(m):
        if m.group(1):
            return m.group(1)
        return "\\" + m.group(0)
    return _MARKUP.sub(one, line)


def _paragraphs(lines):
    """The docstring's lines in runs separated by blank lines."""
    run = []
    for line in lines:
        if line.strip():
            run.append(line)
        elif run:
            yield run
            run = []
    if run:
        yield run


def _rst(paragraph: list[str]) -> list[str]:
    """One paragraph of plain text as reStructuredText (a list of lines, blank-separated parts)."""
    first = paragraph[0].lstrip()
    if first.startswith((">>>", ".. ", ":")):
        return paragraph                              # doctest, directive or field: as written
    if len(paragraph) > 1 and re.fullmatch(r"\s*([-=~^])\1{2,}\s*", paragraph[1]):
        # a heading underlined as NumPy's sections are ("Parameters" / "----------")
        return [".. rubric:: " + _escape(first), ""] + (_rst(paragraph[2:]) if paragraph[2:] else [])
    base = min(len(ln) - len(ln.lstrip()) for ln in paragraph)
    parts, in_item = [[]], False
    for line in paragraph:
        indent = len(line) - len(line.lstrip())
        if indent == base and _BULLET.match(line.lstrip()):
            if parts[-1] and not in_item:
                parts.append([])                      # a list needs a blank line before it
            in_item = True
        elif indent == base:
            if in_item:
                parts.append([])                      # text after a list: a blank line first
            in_item = False
        elif not in_item:                             # indented under text: a table or formula
            return ["::", ""] + ["    " + ln for ln in paragraph]
        parts[-1].append(_escape(line[base:]))
    out = []
    for part in parts:
        out.extend(part + [""])
    return out[:-1]


def plain_docstring(app, what, name, obj, options, lines):
    """Rewrite a plain-text docstring, in place, into reStructuredText that says the same."""
    out, literal = [], False
    for paragraph in _paragraphs(lines):
        if literal:          # after a paragraph ending in "::": its literal block, as written
            out.extend(["    " + ln for ln in paragraph] + [""])
        else:
            out.extend(_rst(paragraph) + [""])
        literal = paragraph[-1].rstrip().endswith("::")
    lines[:] = out


def setup(app):
    app.connect("autodoc-process-docstring", plain_docstring, priority=600)
    app.connect("source-read", no_benchmark_pages_yet)
    app.connect("html-collect-pages", no_sourceless_modules, priority=400)


def no_sourceless_modules(app):
    """Drop the modules viewcode found no source for (`builtins`, from a name it met in the API
    pages) before it writes `_modules/index.html`: it lists them there with a link to a page it
    never writes. Runs before viewcode's own handler (priority 400 < 500); adds no page."""
    modules = getattr(app.env, "_viewcode_modules", {})
    for name in [name for name, entry in modules.items() if entry is False]:
        del modules[name]
    return []


# The benchmark pages are the scripts' output (benchmarks/*.md beside benchmarks/index.md), taken
# in by a glob toctree; before any script has written its page, the glob would match nothing and
# Sphinx would warn, so the toctree is left out of that build (`no_benchmark_pages_yet`).
BENCHMARKS = Path(__file__).parent / "benchmarks"
_GLOB_TOCTREE = re.compile(r"^```\{toctree\}\n(?::[^\n]*\n)*\n?\*\n```\n?", flags=re.M)


def no_benchmark_pages_yet(app, docname, source):
    if docname == "benchmarks/index" and not [p for p in BENCHMARKS.glob("*.md") if p.name != "index.md"]:
        source[0] = _GLOB_TOCTREE.sub("No benchmark page has been written yet: run a script of "
                                      "`benchmarks/` to write its page.\n", source[0])
