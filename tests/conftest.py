"""Fixtures shared by the test modules.

Helpers shared by the volume tests live in ``tests/_surfaces.py``, slow reference implementations in
``tests/naive.py``; objects that more than one test module builds are fixtures here. (The repository's
``conftest.py`` sets up headless rendering and the ``--runslow`` option.)
"""

import pytest

from _surfaces import TINY_VOLUMES


@pytest.fixture(params=TINY_VOLUMES)
def tiny_volume(request):
    """Each tiny volume of :mod:`polygen.volume.datasets` in turn (built on the fly)."""
    from polygen.volume import datasets

    return datasets.load(request.param)
