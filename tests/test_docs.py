"""The documentation site (docs/: Sphinx, MyST, the API reference from the docstrings, the
benchmark pages) builds with no warning: `python -m sphinx -W --keep-going -b html docs OUT`;
and the built site works offline: every relative link resolves to a file, nothing is loaded
from the network, the maths render from the bundled MathJax (in Chromium, the network cut),
code blocks wrap, and the left sidebar lists every guide page."""

import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDE = sorted(p.stem for p in (ROOT / "docs" / "guide").glob("*.md"))


class _Refs(HTMLParser):
    """The href and src attributes of a page, with their tag, and the hrefs inside the left
    sidebar's <nav class="bd-docs-nav">."""

    def __init__(self):
        super().__init__()
        self.refs: list[tuple[str, str, str]] = []        # (tag, rel, reference)
        self.sidebar: list[str] = []
        self._depth = 0                                   # nesting inside the sidebar's nav

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if self._depth:
            self._depth += tag == "nav"
        elif tag == "nav" and "bd-docs-nav" in (a.get("class") or "").split():
            self._depth = 1
        for name in ("href", "src"):
            if a.get(name):
                self.refs.append((tag, a.get("rel") or "", a[name]))
                if self._depth and tag == "a":
                    self.sidebar.append(a[name])

    def handle_endtag(self, tag):
        if self._depth and tag == "nav":
            self._depth -= 1


def pages(site: Path) -> list[Path]:
    """The site's HTML pages (the theme's templates copied into _static are none)."""
    return sorted(p for p in site.rglob("*.html") if "_static" not in p.relative_to(site).parts)


def refs(page: Path) -> _Refs:
    parser = _Refs()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser


def broken_links(site: Path) -> list[str]:
    """`page: reference` for every relative href or src of the site's HTML pages that names no
    file (a fragment of the same page, or a URL with a scheme or host, is not checked)."""
    broken = []
    for page in pages(site):
        for _, _, ref in refs(page).refs:
            parts = urlsplit(ref)
            if parts.scheme or parts.netloc or not parts.path:
                continue
            path = unquote(parts.path)
            target = site / path.lstrip("/") if path.startswith("/") else page.parent / path
            if not (target.is_file() or (target / "index.html").is_file()):
                broken.append(f"{page.relative_to(site).as_posix()}: {ref}")
    return broken


def remote_assets(site: Path) -> list[str]:
    """`page: URL` for every script, stylesheet, image or frame a page loads from a network."""
    found = []
    for page in pages(site):
        for tag, rel, ref in refs(page).refs:
            loads = tag in ("script", "img", "iframe", "source") or (
                tag == "link" and any(r in rel.split() for r in ("stylesheet", "preload", "icon")))
            if loads and (urlsplit(ref).scheme in ("http", "https") or ref.startswith("//")):
                found.append(f"{page.relative_to(site).as_posix()}: {ref}")
    return found


def test_the_link_check_finds_a_missing_page_and_a_remote_script(tmp_path):
    (tmp_path / "_modules").mkdir()
    (tmp_path / "api").mkdir()
    (tmp_path / "api" / "qmesh.html").write_text("<p>qmesh</p>")
    (tmp_path / "_modules" / "index.html").write_text(
        '<a href="builtins.html">builtins</a> <a href="../api/qmesh.html#qmesh.mesh">mesh</a> '
        '<a href="#top">top</a> <a href="https://example.org/x.html">out</a> '
        '<a href="../api/">api</a> <img src="../api/missing%20figure.png">')
    (tmp_path / "api" / "index.html").write_text(
        '<script src="https://cdn.example.org/mathjax/tex-chtml.js"></script>'
        '<link rel="stylesheet" href="//cdn.example.org/a.css"><a href="https://example.org">a</a>')
    assert broken_links(tmp_path) == ["_modules/index.html: builtins.html",
                                      "_modules/index.html: ../api/missing%20figure.png"]
    assert remote_assets(tmp_path) == ["api/index.html: https://cdn.example.org/mathjax/tex-chtml.js",
                                       "api/index.html: //cdn.example.org/a.css"]


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built once for this module's tests, warnings as errors."""
    out = tmp_path_factory.mktemp("docs")
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(out / "doctrees"), str(ROOT / "docs"), str(out / "html")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-5000:]
    return out / "html"


@pytest.mark.slow(10)
def test_the_docs_build_without_warnings(site):
    for page in ["index", "guide/getting-started", "guide/algorithm", "api/qmesh", "api/measure",
                 "benchmarks/index"]:
        assert (site / f"{page}.html").stat().st_size > 0, page
    api = (site / "api" / "qmesh.html").read_text()
    assert 'id="qmesh.mesh"' in api and 'id="qmesh.iterate"' in api      # from the docstrings
    assert "(2.94)" in (site / "guide" / "algorithm.html").read_text()    # the chapter's numbers


@pytest.mark.slow(10)
def test_every_relative_link_resolves_and_nothing_comes_from_the_network(site):
    assert len(pages(site)) > 20
    assert broken_links(site) == []
    assert remote_assets(site) == []


@pytest.mark.slow(10)
def test_the_left_sidebar_lists_every_guide_page(site):
    assert len(GUIDE) >= 10
    for name in GUIDE:
        sidebar = refs(site / "guide" / f"{name}.html").sidebar      # the page itself is "#"
        listed = {Path(urlsplit(ref).path).stem or name for ref in sidebar}
        assert set(GUIDE) <= listed, (name, sorted(set(GUIDE) - listed))


@pytest.mark.slow(20)
@pytest.mark.browser
def test_maths_render_and_code_wraps_offline_in_chromium(site):
    """The network cut (any request but a file's aborted): every formula of the algorithm page is
    typeset by MathJax without an error, and no code block of the getting-started page is wider
    than its box (a horizontal scroll bar)."""
    from headless_browser import chromium_page

    def no_network(page):
        page.context.route("**/*", lambda route: route.continue_() if route.request.url.startswith("file:")
                           else route.abort())

    with chromium_page("about:blank") as page:
        no_network(page)
        page.goto((site / "guide" / "algorithm.html").as_uri())
        page.wait_for_function("() => window.MathJax && MathJax.startup && MathJax.startup.promise")
        assert page.evaluate("() => MathJax.startup.promise.then(() => true)")
        typeset = page.locator("mjx-container").count()
        formulas = page.locator(".math").count()
        errors = page.locator("mjx-merror").all_inner_texts()
        assert formulas >= 20 and typeset >= formulas and errors == []
    with chromium_page("about:blank", viewport=(1000, 800)) as page:
        no_network(page)
        page.goto((site / "guide" / "getting-started.html").as_uri())
        widths = page.eval_on_selector_all(".bd-article pre", "pres => pres.map(p => [p.scrollWidth, p.clientWidth])")
        assert len(widths) >= 5 and all(scroll <= client for scroll, client in widths), widths
