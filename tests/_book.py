"""The book, built once per test session for every test that reads it.

``tests/test_book.py``, ``tests/test_book_browser.py`` and ``tests/test_figure_index.py``
read the same site; the first to ask builds it (the README's command, into a temporary
folder; under pytest-xdist one build shared by the workers), the others get the same folder,
or the same failure. ``POLYGEN_BOOK_HTML=<folder>``
points them at a site already built instead (e.g. ``docs/_build/html``).
"""

import fcntl
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
        # under pytest-xdist each worker is a session: the first to come builds into the folder the
        # workers share (their base temp's parent), the others wait on the lock and read its outcome
        base = tmp_path_factory.getbasetemp()
        shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
        out = shared / "book"
        out.mkdir(exist_ok=True)
        with open(out / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not (out / "outcome").exists():
                cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                       "-d", str(out / "doctrees"), "docs", str(out / "html")]
                run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)
                (out / "outcome").write_text("ok" if run.returncode == 0 else
                                             f"the book does not build without warnings:\n{run.stderr[-6000:]}")
        outcome = (out / "outcome").read_text()
        if outcome != "ok":
            _built["error"] = outcome
            raise AssertionError(outcome)
        _built["html"] = out / "html"
    return _built["html"]
