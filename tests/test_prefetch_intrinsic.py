"""The prefetch hints of the edge-centred kernels (issue 20): they compile, return nothing, change nothing.

``_prefetch_item`` (1-D, read) and ``_prefetch_row`` (2-D row, write) emit
``llvm.prefetch``; where the import-time probe fails the plain no-op kernels
take their place. Either way a call must be a pure hint: no value, no write,
whatever the index.
"""

import numba
import numpy as np

from polygen.volume import _edge_centred_kernels as k


@numba.njit(cache=False)
def _hint_everything(v, a):
    """Every element of ``v`` and every row of ``a`` hinted; returns what the calls returned."""
    r1 = None
    r2 = None
    for i in range(v.shape[0]):
        r1 = k._prefetch_item(v, i)
    for i in range(a.shape[0]):
        r2 = k._prefetch_row(a, i)
    return r1 is None and r2 is None


@numba.njit(cache=False)
def _hint_far(v, i):
    """A hint far outside ``v`` (a prefetch never faults): the caller checks that nothing happened."""
    k._prefetch_item(v, i)
    return v[0]


def test_prefetch_compiles_and_returns_nothing():
    v = np.arange(5, dtype=np.int32)
    a = np.arange(12, dtype=np.int64).reshape(3, 4)
    v0, a0 = v.copy(), a.copy()
    assert _hint_everything(v, a) is True
    # the hints change no element of either array
    assert np.array_equal(v, v0) and np.array_equal(a, a0)


def test_prefetch_out_of_range_is_harmless():
    v = np.arange(3, dtype=np.int32)
    assert _hint_far(v, 1 << 20) == 0
    assert v.tolist() == [0, 1, 2]


def test_prefetch_rejects_wrong_arguments():
    # a 2-D array for the 1-D hint, a float index: numba refuses to type the call (no silent misuse)
    @numba.njit(cache=False)
    def wrong(a):
        k._prefetch_item(a, 0)

    @numba.njit(cache=False)
    def wrong_index(v):
        k._prefetch_item(v, 1.5)

    for fn, arg in ((wrong, np.zeros((2, 2))), (wrong_index, np.zeros(3))):
        if k.PREFETCH:  # the intrinsic types its arguments; the plain fallback accepts anything
            try:
                fn(arg)
            except numba.core.errors.TypingError:
                continue
            raise AssertionError(f"{fn.__name__} compiled")
