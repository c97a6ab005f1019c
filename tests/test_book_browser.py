"""The built book, loaded page by page in a real browser.

The site that ``tests/test_book.py`` builds (``tests/_book.py``: once per session) is served
by a local ``http.server`` on 127.0.0.1 and every page is opened in headless Chromium
through Playwright. A page fails on a resource that does not load (an image, script or
style sheet: a failed request, or a response of 400 or more), on any request that leaves
127.0.0.1 (the book must show itself offline), on a JavaScript console error or uncaught
exception; a chapter page fails when it shows fewer images, loaded, than its notebook
stores. Screenshots of the index and of a chapter page are left in pytest's temporary
folder, whose path ``test_screenshots_are_kept`` prints; never in the repository.

Chromium is Debian's (``apt-get install -y -qq chromium``; ``.ci/run`` installs it where
the image lacks it): the test skips, saying so, only when ``chromium`` is not on the PATH.
"""

import functools
import http.server
import json
import shutil
import threading
from pathlib import Path
from urllib.parse import urlsplit

import pytest

import _book

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = shutil.which("chromium")
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
SHOT_CHAPTER = "06_extrema_graph"

pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (apt-get install -y -qq chromium; .ci/run does)")


def stored_images(ipynb):
    """How many image outputs the notebook stores (one per output, whatever its formats)."""
    cells = json.loads(ipynb.read_text())["cells"]
    return sum(any(k.startswith("image/") for k in o.get("data", {}))
               for c in cells for o in c.get("outputs", []))


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def visit(html, pages, *, shots=None, shot_pages=()):
    """Serve ``html`` and open each of ``pages`` (paths relative to it) in Chromium.

    Returns ``{page: {"problems": [...], "images": n}}``: ``images`` counts the ``<img>``
    of the article that loaded (complete, with a width). Screenshots of ``shot_pages`` go
    to ``shots``.
    """
    from playwright.sync_api import sync_playwright

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_Quiet, directory=str(html)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    base = f"http://127.0.0.1:{server.server_address[1]}/"
    found = {}
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
            try:
                context = browser.new_context(viewport={"width": 1280, "height": 900})
                problems = []

                def route(r):
                    if r.request.url.startswith(base) or r.request.url.startswith("data:"):
                        r.continue_()
                    else:
                        problems.append(f"leaves 127.0.0.1: {r.request.url}")
                        r.abort()

                def on_failed(request):
                    if request.url.startswith(base):
                        problems.append(f"did not load ({request.failure}): {request.url[len(base):]}")

                def on_response(response):
                    if response.status >= 400:
                        problems.append(f"HTTP {response.status}: {response.url[len(base):]}")

                def on_console(message):
                    if message.type == "error":
                        problems.append(f"console error: {message.text}")

                context.route("**/*", route)
                page = context.new_page()
                page.on("requestfailed", on_failed)
                page.on("response", on_response)
                page.on("console", on_console)
                page.on("pageerror", lambda error: problems.append(f"uncaught: {error}"))
                for rel in pages:
                    problems.clear()
                    page.goto(base + rel, wait_until="load")
                    if not rel.startswith("api/"):   # 92 API pages have no script of their own
                        page.wait_for_load_state("networkidle")
                    images = page.evaluate(
                        "() => [...document.querySelectorAll('article img')]"
                        ".filter(i => i.complete && i.naturalWidth > 0).length")
                    found[rel] = {"problems": list(problems), "images": images}
                    if shots is not None and rel in shot_pages:
                        if images:   # a chapter: its first figure in view
                            page.locator("article img").first.scroll_into_view_if_needed()
                        page.screenshot(path=str(shots / rel.replace("/", "_").replace(".html", ".png")),
                                        full_page=False)
            finally:
                browser.close()
    finally:
        server.shutdown()
        server.server_close()
        thread.join()
    return found


@pytest.fixture(scope="module")
def visited(tmp_path_factory):
    html = _book.site(tmp_path_factory)
    pages = sorted(p.relative_to(html).as_posix() for p in html.rglob("*.html")
                   if not p.relative_to(html).parts[0].startswith("_"))
    shots = tmp_path_factory.mktemp("book-screenshots")
    shot_pages = ("index.html", f"notebooks/{SHOT_CHAPTER}.html")
    return visit(html, pages, shots=shots, shot_pages=shot_pages), shots


def test_every_page_loads_cleanly(visited):
    found, _ = visited
    assert {"index.html", "figures.html", "notebooks/index.html"} <= set(found)
    bad = {page: r["problems"] for page, r in found.items() if r["problems"]}
    assert not bad, "\n".join(f"{page}:\n  " + "\n  ".join(p) for page, p in bad.items())


@pytest.mark.parametrize("ipynb", NOTEBOOKS, ids=lambda p: p.stem)
def test_chapter_page_shows_every_stored_figure(visited, ipynb):
    found, _ = visited
    page = f"notebooks/{ipynb.stem}.html"
    assert page in found, f"{page} is not in the book"
    stored = stored_images(ipynb)
    assert found[page]["images"] >= stored, (
        f"{page} shows {found[page]['images']} images, its notebook stores {stored}")


def test_screenshots_are_kept(visited, capsys):
    _, shots = visited
    for name in ("index.png", f"notebooks_{SHOT_CHAPTER}.png"):
        assert (shots / name).stat().st_size > 10_000, f"{name}: no screenshot, or a blank one"
    with capsys.disabled():   # the artefacts' place, in the test's output even when it passes
        print(f"\nbook screenshots: {shots}")
