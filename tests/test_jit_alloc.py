"""polygen._jit.empty / astype: fresh output arrays outside numpy's huge-page advice."""

import pickle

import numpy as np
import pytest

from polygen import _jit


@pytest.mark.parametrize("dtype", [np.float64, np.int64, np.int32, np.float32, np.bool_])
@pytest.mark.parametrize("shape", [0, 7, (5, 3), (1 << 20, 3), (1 << 22,)])
def test_empty_is_an_ordinary_array(shape, dtype):
    a = _jit.empty(shape, dtype)
    want = (shape,) if np.ndim(shape) == 0 else shape
    assert a.shape == want and a.dtype == np.dtype(dtype)
    assert a.flags.c_contiguous and a.flags.writeable and a.flags.aligned
    assert a.ctypes.data % min(8, a.dtype.itemsize) == 0
    big = a.nbytes >= _jit.HUGE_ADVICE_BYTES
    assert (a.base is not None) == big  # the large ones come from numba's allocator
    a[...] = 1
    assert a.sum() == a.size
    b = pickle.loads(pickle.dumps(a))
    assert b.shape == a.shape and b.dtype == a.dtype and np.array_equal(a, b)


def test_arrays_do_not_share_memory():
    arrays = [_jit.empty((1 << 20,), np.float64) for _ in range(3)]
    for i, a in enumerate(arrays):
        a[...] = i
    assert [float(a[0]) for a in arrays] == [0.0, 1.0, 2.0]
    assert not any(np.shares_memory(arrays[i], arrays[j]) for i in range(3) for j in range(i + 1, 3))


@pytest.mark.parametrize("n", [10, 1 << 20])
def test_astype_equals_numpy(n):
    rng = np.random.default_rng(0)
    a = rng.integers(-2**31, 2**31 - 1, size=(n, 3), dtype=np.int64).astype(np.int32)
    b = _jit.astype(a, np.int64)
    assert b.dtype == np.int64 and np.array_equal(b, a.astype(np.int64))
