"""The marks of Fig. 6.5's first loop (the extrema's "not-" and "plural" marks) against the rule stated directly.

Oracle: numpy over all cells at once -- a node is "not-maximum" when some
cell holds a larger node, "plural-maximums" when it is the largest of a
cell that holds it more than once tied (and the same for minima). The
kernel stores without a test per node when a cell has no tie; fields
rounded to a few levels make most cells tied, so both paths are checked.
"""

import numpy as np
import pytest

from polygen.volume import _extrema_kernels as _k
from polygen.volume import datasets


def marks_by_rule(cells, s):
    n = s.shape[0]
    v = s[cells]
    hi, lo = v.max(axis=1, keepdims=True), v.min(axis=1, keepdims=True)
    tie_hi = (v == hi).sum(axis=1, keepdims=True) > 1
    tie_lo = (v == lo).sum(axis=1, keepdims=True) > 1
    out = [np.zeros(n, bool) for _ in range(4)]
    for arr, where in zip(out, [v < hi, v > lo, (v == hi) & tie_hi, (v == lo) & tie_lo]):
        arr[cells[where]] = True
    return out  # not_max, not_min, plural_max, plural_min


def marks_by_kernel(cells, s):
    out = [np.zeros(s.shape[0], np.bool_) for _ in range(4)]
    _k._mark_cells(np.ascontiguousarray(cells, np.int64), np.ascontiguousarray(s, np.float64), *out)
    return out


@pytest.mark.parametrize("name", ["data1", "data2", "data3", "data4", "hexa1", "hexa2", "hexa3"])
def test_marks_on_data(name):
    vol = datasets.load(name)
    s = vol.scalars()
    for levels in (None, 2, 5, 40):  # the field, then rounded to a few levels: ties everywhere or in places
        f = s if levels is None else np.round((s - s.min()) / np.ptp(s) * levels)
        got, want = marks_by_kernel(vol.cells, f), marks_by_rule(vol.cells, f)
        assert all(np.array_equal(g, w) for g, w in zip(got, want)), (name, levels)
        if levels == 2:
            assert got[2].any() and got[3].any()  # the tie path ran


def test_marks_on_random_cells():
    rng = np.random.default_rng(6)
    for nn in (3, 4, 8):  # triangles, tetrahedra, hexahedra; repeated nodes within a cell allowed
        cells = rng.integers(0, 50, (300, nn))
        for s in (rng.random(50), rng.integers(0, 3, 50).astype(float)):
            got, want = marks_by_kernel(cells, s), marks_by_rule(cells, s)
            assert all(np.array_equal(g, w) for g, w in zip(got, want)), nn
