"""``EdgeCentred.extract_many``'s ``threads``: a whole number >= 1 or None, never silently nothing
(issue 19, item 7: ``threads=-1`` returned ``[]`` and ``threads=0`` was silently the default)."""

import numpy as np
import pytest

from polygen.volume import datasets, methods
from polygen.volume.surface import IsoSurfaceError


@pytest.fixture(scope="module")
def method():
    vol = datasets.load("torus")
    return methods.get("edge-centred")(vol), np.quantile(vol.scalars(), [0.3, 0.5, 0.7])


@pytest.mark.parametrize("threads", [-1, 0, 1.5, 2.0, "2", True])
def test_bad_thread_counts_are_refused(method, threads):
    m, values = method
    with pytest.raises(IsoSurfaceError, match=f"threads must be a whole number >= 1.*got {threads!r}"):
        m.extract_many(values, threads=threads)


@pytest.mark.parametrize("threads", [None, 1, np.int64(2), 5])
def test_good_thread_counts_give_every_surface(method, threads):
    m, values = method
    many = m.extract_many(values, threads=threads)
    assert [i.n_triangles for i in many] == [m.extract(v).n_triangles for v in values]
    assert all(i.n_triangles > 0 for i in many)
