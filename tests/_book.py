"""The book, built once per test session for every test that reads it.

``tests/test_book.py``, ``tests/test_book_browser.py`` and ``tests/test_figure_index.py``
read the same site; the first to ask builds it (the README's command, into a temporary
folder), the others get the same folder, or the same failure. ``POLYGEN_BOOK_HTML=<folder>``
points them at a site already built instead (e.g. ``docs/_build/html``).
"""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

_built = {}   # "html": the folder, or "error": why the build failed


def site(tmp_path_factory):
    """The built book's HTML folder (built on the first call of the session)."""
    given = os.environ.get("POLYGEN_BOOK_HTML")
    if given:
        assert (Path(given) / "index.html").exists(), f"POLYGEN_BOOK_HTML={given}: no index.html there"
        return Path(given)
    if "error" in _built:
        raise AssertionError(_built["error"])
    if "html" not in _built:
        out = tmp_path_factory.mktemp("book")
        cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
               "-d", str(out / "doctrees"), "docs", str(out / "html")]
        run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)
        if run.returncode != 0:
            _built["error"] = f"the book does not build without warnings:\n{run.stderr[-6000:]}"
            raise AssertionError(_built["error"])
        _built["html"] = out / "html"
    return _built["html"]
