"""The book builds with warnings as errors, and shows what the notebooks stored.

The command is the README's: ``python -m sphinx -W --keep-going -b html docs docs/_build/html``
(here into a temporary folder, once per session: ``tests/_book.py``, shared with the
browser test and the figure index's). Sphinx, myst-nb and the theme come with the test
extra: a missing one fails the imports below, it is never skipped.
"""

import json
from html import unescape
import re
from pathlib import Path

import myst_nb  # noqa: F401  (the docs' requirements, in the test extra)
import pydata_sphinx_theme  # noqa: F401
import pytest
import sphinx  # noqa: F401

import _book

ROOT = Path(__file__).resolve().parent.parent


def _pngs(ipynb):
    nb = json.loads(ipynb.read_text())
    return sum("image/png" in o.get("data", {}) for c in nb["cells"] for o in c.get("outputs", []))


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    return _book.site(tmp_path_factory)


def test_index(site):
    html = (site / "index.html").read_text()
    text = unescape(re.sub(r"<[^>]+>", "", html))
    assert "<h1>polygen" in html
    # the two commands, as the README has them
    readme = (ROOT / "README.md").read_text()
    for marker in ("<!-- main-command -->", "<!-- test-command -->"):
        command = readme.split(marker)[1].split("```bash")[1].split("```")[0].strip()
        assert command in text, f"{marker} not on the index"
    for ipynb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        assert f'href="notebooks/{ipynb.stem}.html"' in html, f"{ipynb.stem} missing from the index"


@pytest.mark.parametrize("ipynb", sorted((ROOT / "notebooks").glob("*.ipynb")), ids=lambda p: p.stem)
def test_chapter_page_shows_the_stored_figures(site, ipynb):
    html = (site / "notebooks" / f"{ipynb.stem}.html").read_text()
    shown = len(re.findall(r'<img [^>]*src="\.\./_images/', html))
    assert shown == _pngs(ipynb)


def test_api_reference_covers_every_module(site):
    import pkgutil

    import polygen

    pages = {p.stem for p in (site / "api").glob("*.html")}
    modules = {"polygen"} | {
        m.name for m in pkgutil.walk_packages(polygen.__path__, "polygen.")
        if not any(part.startswith("_") for part in m.name.split("."))
    }
    assert modules <= pages, f"modules without an API page: {sorted(modules - pages)}"
