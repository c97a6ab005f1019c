"""The constructions of notebook 08 and benchmarks/fast_construction.py: same surfaces, live counters, minima.

Oracles: the full scan's surface (every construction must make it), the
counters' definitions (the walk searches nothing, a hash search probes at
least one slot), and the minimum over runs (never above any run's time).
"""

import numpy as np
import pytest

from polygen.volume import datasets, isovalues
from polygen.volume.constructions import CONSTRUCTIONS, builder_of, prepare_construction, timed_sweep
from polygen.volume.isosurface import extract, same_surface


@pytest.fixture(scope="module")
def data1():
    return datasets.load("data1")


@pytest.mark.parametrize("label", ["scan", *CONSTRUCTIONS])
def test_every_construction_makes_the_scans_surface(data1, label):
    values = isovalues(data1.scalars("fem"), 5)
    m = prepare_construction(label, data1)
    isos, times, probes = timed_sweep(m, values, repeat=2)
    assert times.shape == (5, 3) and np.isfinite(times).all() and (times >= 0).all()
    assert all(same_surface(extract(data1, v, field="fem"), i) for v, i in zip(values, isos))
    # the minimum over the runs: never above the last run's stage times
    last = np.array([[i.t1, i.t2, i.t3] for i in isos])
    assert (times <= last).all()
    lookups = sum(i.vertex_lookups for i in isos)
    if label == "hash":
        assert probes >= lookups > 0
    elif label == "array":
        assert lookups > 0 and probes == 0
    elif label != "scan":
        assert lookups == 0 and probes == 0
    assert (builder_of(m) is None) == (label == "scan")


def test_array_searches_an_edge_array(data1):
    m = prepare_construction("array", data1)
    assert builder_of(m).vertex_search == "array"
    with pytest.raises(KeyError, match="walk-fifo"):
        prepare_construction("nothing", data1)
    with pytest.raises(ValueError, match="repeat"):
        timed_sweep(m, [0.5], repeat=0)
