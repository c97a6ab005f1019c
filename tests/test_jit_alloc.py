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


# ------------------------------------------------------------------ output_empty: recycled output buffers
@pytest.fixture
def pool():
    """An empty pool with the default budget, emptied again afterwards."""
    _jit.release_output_pool()
    yield _jit
    _jit.release_output_pool()


@pytest.mark.parametrize("dtype", [np.float64, np.int64, np.int32, np.float32])
@pytest.mark.parametrize("shape", [0, 7, (5, 3), (1 << 14, 3), (1 << 20, 3)])
def test_output_empty_is_an_ordinary_array(pool, shape, dtype):
    a = pool.output_empty(shape, dtype)
    want = (shape,) if np.ndim(shape) == 0 else shape
    assert a.shape == want and a.dtype == np.dtype(dtype)
    assert a.flags.c_contiguous and a.flags.writeable and a.flags.aligned
    a[...] = 3
    assert a.sum() == 3 * a.size
    b = pickle.loads(pickle.dumps(a))
    assert np.array_equal(a, b) and b.dtype == a.dtype
    assert isinstance(a.base, _jit._Lease) == (a.nbytes >= _jit.OUTPUT_POOL_MIN_BYTES)


def test_a_released_buffer_is_taken_again_and_a_live_one_never(pool):
    a = pool.output_empty((50_000, 3), np.int64)
    where = a.ctypes.data
    view = a[10:20]
    del a
    b = pool.output_empty((50_000, 3), np.int64)
    assert b.ctypes.data != where  # the view keeps a's buffer out of the pool
    del view
    before = dict(pool.pool_stats)
    c = pool.output_empty((49_000, 3), np.int64)  # same size class
    assert c.ctypes.data == where and pool.pool_stats["reused"] == before["reused"] + 1
    assert not np.shares_memory(b, c)


def test_live_arrays_never_share_and_keep_their_contents(pool):
    """A random sequence of takes and releases against a model: every live array keeps what was written."""
    rng = np.random.default_rng(1)
    live = {}
    for step in range(400):
        if live and rng.random() < 0.45:
            del live[rng.choice(list(live))]
        else:
            n = int(rng.integers(1, 200_000))
            a = pool.output_empty(n, np.int64)
            a[...] = step
            live[step] = a
        for k, a in live.items():
            assert a[0] == k and a[-1] == k
    arrays = list(live.values())
    assert not any(np.shares_memory(arrays[i], arrays[j]) for i in range(len(arrays))
                   for j in range(i + 1, len(arrays)))
    assert pool.pool_stats["reused"] > 0


def test_the_pool_keeps_at_most_its_budget(pool, monkeypatch):
    monkeypatch.setattr(_jit, "OUTPUT_POOL_BYTES", 4 << 20)
    arrays = [pool.output_empty(1 << 17, np.float64) for _ in range(8)]  # 1 MiB each
    del arrays
    assert 0 < _jit._pool_held[0] <= 4 << 20
    assert _jit._pool_held[0] == sum(b.nbytes for _, b, _ in _jit._pool)
    assert pool.release_output_pool() > 0 and _jit._pool_held[0] == 0 and not _jit._pool


@pytest.mark.parametrize("nbytes", [1, 4095, 65_536, 65_537, 1 << 20, 5_089_752, 123_456_789])
def test_size_classes_hold_the_request_with_little_to_spare(nbytes):
    k, cap = _jit._size_class(nbytes)
    assert cap >= nbytes and cap % 4096 == 0
    assert k == 0 or _jit._CLASS_BYTES[k - 1] < nbytes  # the smallest that holds it
    assert cap <= max(_jit.OUTPUT_POOL_MIN_BYTES, 2 ** 0.25 * nbytes) + 4096
    assert _jit._size_class(nbytes + 1)[0] >= k and (nbytes < 2 or _jit._size_class(nbytes - 1)[0] <= k)


def test_threads_taking_and_releasing_at_once(pool):
    from concurrent.futures import ThreadPoolExecutor

    def work(seed):
        """Takes and drops arrays, checking that the ones it keeps still hold what it wrote; the misses."""
        rng = np.random.default_rng(seed)
        mine, wrong = [], []
        for i in range(300):
            a = pool.output_empty(int(rng.integers(10_000, 300_000)), np.int64)
            a[...] = seed * 1000 + i
            mine.append((seed * 1000 + i, a))
            if len(mine) > 5:
                mine.pop(int(rng.integers(len(mine))))
            wrong += [want for want, b in mine if b[0] != want or b[-1] != want]
        return wrong

    with ThreadPoolExecutor(4) as ex:
        assert list(ex.map(work, range(4))) == [[], [], [], []]


# ------------------------------------------------------------------ poison mode

_PLANTED = r"""
import numpy as np
from polygen import _jit
assert _jit.POISON
# every allocator hands out the sentinel
for make in (_jit.scratch, _jit.empty, _jit.output_empty):
    f, i, b = make(40000, np.float64), make(40000, np.int32), make(40000, np.bool_)
    assert np.isnan(f).all() and (i == np.iinfo(np.int32).max).all() and b.all(), make
out = _jit.output_empty(1 << 17)
address = out.ctypes.data
del out
again = _jit.output_empty(1 << 17)  # the buffer given back, taken again: poisoned again
assert again.ctypes.data == address and np.isnan(again).all()
# a planted read of an unwritten element: a row laid out for every key but one (as seam_plan's was)
keys = np.arange(10)
rows = _jit.scratch(10, np.int64)
rows[:9] = np.arange(9)
try:
    keys[rows]
except IndexError:
    print("caught")
"""


def test_poison_mode_fails_a_planted_read_of_an_unwritten_element():
    """Under POLYGEN_POISON=1 each buffer holds a sentinel, so reading an unwritten element fails loudly."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, POLYGEN_POISON="1")
    run = subprocess.run([sys.executable, "-c", _PLANTED], env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["caught"]


def test_poison_is_off_by_default():
    import os

    if os.environ.get("POLYGEN_POISON", "0") in ("", "0"):
        assert not _jit.POISON and _jit.scratch is np.empty
    else:  # the poison tier of .ci/run
        assert _jit.POISON and np.isnan(_jit.scratch(3)).all()


def test_a_constant_argument_from_a_kernel_compiles_no_extra_build():
    # numba would compile `pick` three times: for Literal[int](0), Literal[int](1) and int64
    @_jit.njit(cache=False)
    def pick(a, k):
        return a[k]

    @_jit.njit(cache=False)
    def total(a):
        return pick(a, 0) + pick(a, 1) + pick(a, a.shape[0] - 1)

    assert total(np.arange(4.0)) == 4.0
    assert [tuple(map(str, s)) for s in pick.signatures] == [("array(float64, 1d, C)", "int64")]


def test_cached_builds_are_saved_under_a_lock(tmp_path, monkeypatch):
    # two processes saving different builds of one function must not both take data file 1
    import numba

    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(tmp_path))
    locked = []
    flock = _jit.fcntl.flock
    monkeypatch.setattr(_jit.fcntl, "flock", lambda f, op: (locked.append(f.name), flock(f, op)))

    def plus_one(a):
        return a + 1

    fn = _jit.njit(plus_one)
    assert fn(1) == 2 and fn(1.5) == 2.5
    index = [p for p in tmp_path.rglob("*.nbi")]
    assert len(index) == 1 and locked == [str(index[0]) + ".lock"] * 2
    assert len(list(tmp_path.rglob("*.nbc"))) == 2
