"""The one place where numba's JIT options are set.

Every kernel in polygen is decorated with :func:`njit` from here, so that
the on-disk cache (a new process does not recompile) and the other options
are the same everywhere. ``POLYGEN_NUMBA_CACHE=0`` turns the cache off,
for example on a read-only install.
"""

import bisect
import ctypes
import errno
import math
import operator
import os
import threading

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None

import numba
import numpy as np
from numba.core import types
from numba.core.caching import IndexDataCacheFile
from numba.core.registry import CPUDispatcher

CACHE = os.environ.get("POLYGEN_NUMBA_CACHE", "1") != "0"
prange = numba.prange

# ------------------------------------------------------------------ poison mode (tests)
#: ``POLYGEN_POISON=1``: every buffer handed out here (:func:`scratch`, :func:`empty`, :func:`output_empty`)
#: is filled with a sentinel before use (NaN for floats, the largest value for integers, True for bools),
#: and a pooled buffer is filled again when it is given back. A wrapper or kernel that reads an element
#: nobody wrote then meets a value no algorithm makes -- an out-of-bounds index, a NaN vertex -- instead
#: of whatever the allocator left there, which is usually plausible. CI runs the volume tests so.
POISON = os.environ.get("POLYGEN_POISON", "0") not in ("", "0")


def poison(a):
    """Fill ``a`` with its dtype's sentinel (see :data:`POISON`); returns ``a``."""
    kind = a.dtype.kind
    if kind in "fc":
        a.fill(np.nan)
    elif kind in "iu":
        a.fill(np.iinfo(a.dtype).max)
    elif kind == "b":
        a.fill(True)
    else:  # pragma: no cover - no other dtype is allocated here
        a.view(np.uint8).fill(0x7F)
    return a


def _poisoned_empty(shape, dtype=np.float64, order="C"):
    return poison(np.empty(shape, dtype, order))


def _poisoned_empty_like(a, dtype=None, order="K", subok=True, shape=None):
    return poison(np.empty_like(a, dtype, order, subok, shape))


#: ``numpy.empty`` for the wrappers' scratch arrays and outputs (:func:`_poisoned_empty` in poison mode)
scratch = _poisoned_empty if POISON else np.empty
#: ``numpy.empty_like``, likewise
scratch_like = _poisoned_empty_like if POISON else np.empty_like


class _Dispatcher(CPUDispatcher):
    """A dispatcher that a kernel calling it with a constant argument does not specialise on the constant.

    numba types a constant argument of a call from one kernel to another as a literal
    (``Literal[int](0)``, ``Literal[bool](True)``) and compiles the callee once per distinct literal
    besides its ``int64`` build: ``_remove(..., 0)`` and ``_remove(..., t)`` were two compilations of
    the whole function (the first run of ``polygen isosurface`` built 170 kernels, 17 of them such
    extra builds). The callee is here compiled for the plain types; the caller converts the constant.
    A call from Python never gives literals.
    """

    def get_call_template(self, args, kws):
        return super().get_call_template(tuple(types.unliteral(a) for a in args),
                                         {k: types.unliteral(v) for k, v in kws.items()})


class _LockedCacheFile(IndexDataCacheFile):
    """numba's cache index and data files of one function, saved under an exclusive file lock.

    numba saves a new build by reading the function's index, choosing the first unused data file
    number and writing both: two processes that save different builds of one function at the same
    moment can choose the same number, and the index then names the other build's code (numba does
    not check the signature on loading). ``polygen isosurface`` compiles in two processes on a first
    run (:func:`polygen.cli.isosurface._warm_up`), and pytest-xdist workers share a cache: a save
    here re-reads the index under a lock on ``<index>.lock``, so the numbers never clash.
    """

    def save(self, key, data):
        if fcntl is None:  # pragma: no cover - not POSIX
            return super().save(key, data)
        with open(self._index_path + ".lock", "ab") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
            return super().save(key, data)


def _plain_types(disp):
    if type(disp) is CPUDispatcher:  # not with NUMBA_DISABLE_JIT (a plain function)
        disp.__class__ = _Dispatcher
        cache_file = getattr(disp._cache, "_cache_file", None)
        if type(cache_file) is IndexDataCacheFile:
            cache_file.__class__ = _LockedCacheFile
    return disp


def njit(fn=None, **kwargs):
    """``numba.njit`` with polygen's defaults (``cache=True, nogil=True``).

    Use as ``@njit`` or ``@njit(parallel=True)``. The kernel is compiled for the
    plain types of its arguments when another kernel calls it with a constant
    (see :class:`_Dispatcher`).
    """
    kwargs.setdefault("cache", CACHE)
    kwargs.setdefault("nogil", True)
    if fn is None:
        decorate = numba.njit(**kwargs)
        return lambda f: _plain_types(decorate(f))
    return _plain_types(numba.njit(**kwargs)(fn))


def read_only(a):
    """``a`` read-only: itself when it is already, else a read-only view (the caller's array stays writable).

    numba types an array's writability: a kernel called with a writable array
    where it had a read-only one (or the reverse) is compiled again, seconds
    for a large one. Arrays a kernel only reads go in read-only everywhere.
    """
    if not a.flags.writeable:
        return a
    v = a.view()
    v.setflags(write=False)
    return v


def note_read_only(state):
    """For ``__getstate__``: ``state`` (a copy of an object's ``__dict__``) with the names of its read-only
    arrays under ``"_read_only"``, which :func:`restore_read_only` makes read-only again (pickling and deepcopy
    hand arrays back writable, and the kernels would be compiled again for them; see :func:`read_only`)."""
    state["_read_only"] = [k for k, v in state.items() if isinstance(v, np.ndarray) and not v.flags.writeable]
    return state


def restore_read_only(obj):
    """For ``__setstate__``, after ``obj.__dict__`` was updated: the arrays :func:`note_read_only` named, read-only."""
    for name in obj.__dict__.pop("_read_only", ()):
        getattr(obj, name).setflags(write=False)


@numba.njit(parallel=True, cache=CACHE)
def _touch(n):  # pragma: no cover - trivially small; it makes numba choose its threading layer
    total = 0
    for i in prange(n):
        total += i
    return total


def parallel_kernels_may_overlap():
    """Whether two Python threads may run ``parallel=True`` kernels at the same time.

    True with numba's ``omp`` and ``tbb`` threading layers. The
    ``workqueue`` layer (chosen when neither is installed, or set by
    ``NUMBA_THREADING_LAYER``) is not thread-safe: a parallel region
    launched while another runs aborts the process. polygen's own
    background work (the preparation after a first surface, the edge
    table beside the thinning) asks here first and runs in the calling
    thread instead when this is False.
    """
    _touch(2)  # the layer is chosen at the first parallel launch
    return numba.threading_layer() != "workqueue"


# numpy advises the kernel to back an allocation of 4 MiB or more by transparent huge pages
# (madvise(MADV_HUGEPAGE)). Where the kernel's THP defrag setting is "madvise" (a common default,
# and this project's CI machine), the first write to each fresh 2 MiB page may wait for memory
# compaction: measured here 2.2-3.2 ms per MB written into a new numpy array against 0.46 without
# the advice and 0.57 from numba's allocator, which a surface's output arrays pay in full.
HUGE_ADVICE_BYTES = 1 << 22


@numba.njit(cache=CACHE, nogil=True)
def _words(n):  # pragma: no cover - one line; numba's runtime allocates with plain malloc
    return np.empty(n, np.float64)


def empty(shape, dtype=np.float64):
    """``numpy.empty(shape, dtype)`` for a fresh output array that a kernel writes at once.

    Arrays of 4 MiB or more are allocated by numba's runtime (``malloc``)
    instead of numpy's allocator, which asks for transparent huge pages: on
    Linux with the THP defrag setting ``madvise`` the first touch of such an
    array can cost five times as much (see ``HUGE_ADVICE_BYTES``). The result
    is an ordinary C-contiguous array (a view on its buffer: ``base`` is not
    None), aligned to 8 bytes at least.
    """
    dtype = np.dtype(dtype)
    # (plain Python, not np.ndim and np.prod: a query asks for a handful of arrays, many of them small)
    if isinstance(shape, (tuple, list)) or (isinstance(shape, np.ndarray) and shape.ndim):
        shape = tuple(int(n) for n in shape)
    else:
        shape = (int(shape),)
    nbytes = math.prod(shape) * dtype.itemsize
    if nbytes < HUGE_ADVICE_BYTES:
        return scratch(shape, dtype)
    out = _words((nbytes + 7) // 8).view(np.uint8)[:nbytes].view(dtype).reshape(shape)
    return poison(out) if POISON else out


def astype(a, dtype, *, output=False):
    """``a.astype(dtype)`` into an array from :func:`empty` (:func:`output_empty` with ``output``)."""
    out = (output_empty if output else empty)(a.shape, dtype)
    out[...] = a
    return out


# ------------------------------------------------------------------ recycled output buffers
# A query's output arrays (a surface's triangles, vertices, normals: megabytes each) are fresh memory,
# and fresh memory is paid for by a page fault per 4 KiB on its first write. malloc hands back memory
# that a program freed, but gives large blocks to the kernel when they are freed (and trims its heap),
# so a surface asked for after other work -- VTK drawing the previous one, say -- faults all over
# again: measured here on 2M, in benchmarks/interactive.py's sweeps between VTK's, 2,000-2,300 faults
# at 6 us each (this VM) turned the 212,073-triangle surface's 15 ms into 29. The output arrays of the
# queries therefore sit on buffers that go back to a small pool when the last array on them is
# dropped, and the next query of a similar size takes them from there, already mapped.


def _default_pool_bytes():
    """A 32nd of the physical memory, between 256 MiB and 2 GiB (256 MiB where it cannot be read).

    Enough for a sweep's surfaces on large volumes: 20 values on 10M are 452 MB of output arrays, and
    with 256 MiB half of them came from fresh memory every sweep (47,000 faults, 8 % of a one-thread
    sweep's time here).
    """
    try:
        ram = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        ram = 0
    return int(min(2 << 30, max(256 << 20, ram // 32)))


#: bytes of released output buffers kept for reuse; the least recently released go first (0: none kept)
OUTPUT_POOL_BYTES = _default_pool_bytes()
#: below this an output array comes from :func:`empty` (malloc keeps such blocks itself)
OUTPUT_POOL_MIN_BYTES = 1 << 16
_pool = []  # (size class, buffer, its address), least recently released first
_pool_held = [0]
_pool_lock = threading.Lock()
#: counters (tests, benchmarks): buffers taken from the pool, buffers allocated, buffers kept on release
pool_stats = {"reused": 0, "allocated": 0, "kept": 0}


def _class_bytes(k):
    return -(-int(math.ceil(OUTPUT_POOL_MIN_BYTES * 2 ** (k / 4))) // 4096) * 4096


#: the buffer sizes: 64 KiB * 2 ** (k / 4) in whole 4 KiB pages, k = 0 .. 127 (up to 2 ** 47 bytes)
_CLASS_BYTES = [_class_bytes(k) for k in range(128)]


def _size_class(nbytes):
    """``(k, bytes)``: the smallest buffer size of :data:`_CLASS_BYTES` that holds ``nbytes`` (at most a fifth
    of a buffer unused, and surfaces of similar sizes share buffers)."""
    k = bisect.bisect_left(_CLASS_BYTES, nbytes)
    return k, _CLASS_BYTES[k]


class _Lease:
    """The owner (``base``) of the arrays on one pooled buffer; gives the buffer back when they are all gone."""

    __slots__ = ("buffer", "address", "size_class", "__array_interface__")

    def __init__(self, buffer, address, size_class, shape, typestr):
        self.buffer = buffer
        self.address = address
        self.size_class = size_class
        self.__array_interface__ = {"data": (address, False), "shape": shape, "typestr": typestr, "version": 3}

    def __del__(self):
        try:
            _give_back(self.buffer, self.address, self.size_class)
        except Exception:  # pragma: no cover - at interpreter exit the module may be half torn down
            pass


def _give_back(buffer, address, size_class):
    """Keep a released buffer for reuse, dropping the least recently released beyond the budget.

    Called from ``__del__``, on whatever thread let the last array go (the
    garbage collector's too, possibly while this thread is inside
    :func:`output_empty`): the lock is only tried, and a buffer that cannot
    be kept right now is simply freed.
    """
    if buffer.nbytes > OUTPUT_POOL_BYTES or not _pool_lock.acquire(blocking=False):
        return
    if POISON:  # an array that outlived its buffer's release reads the sentinel, not a later surface
        buffer.view(np.uint8).fill(0x7F)
    try:
        _pool.append((size_class, buffer, address))
        _pool_held[0] += buffer.nbytes
        pool_stats["kept"] += 1
        while _pool_held[0] > OUTPUT_POOL_BYTES:
            _pool_held[0] -= _pool.pop(0)[1].nbytes
    finally:
        _pool_lock.release()


def output_empty(shape, dtype=np.float64):
    """``numpy.empty(shape, dtype)`` for an output array that the caller hands to the user.

    Arrays of :data:`OUTPUT_POOL_MIN_BYTES` or more sit on a buffer from
    the pool of released output buffers when one of their size class is
    there (its pages already mapped: no page faults), else on a new buffer
    from numba's allocator (as :func:`empty`). When the last array on the
    buffer is dropped it goes back to the pool, which keeps at most
    :data:`OUTPUT_POOL_BYTES` (:func:`release_output_pool` empties it). The
    result is an ordinary writeable C-contiguous array whose ``base`` is
    the buffer's owner; two arrays alive at once never share a buffer.
    """
    dtype = np.dtype(dtype)
    shape = tuple(map(operator.index, shape)) if isinstance(shape, (tuple, list)) else (operator.index(shape),)
    nbytes = math.prod(shape) * dtype.itemsize
    if nbytes < OUTPUT_POOL_MIN_BYTES or nbytes > OUTPUT_POOL_BYTES:
        return empty(shape, dtype)
    k, cap = _size_class(nbytes)
    buffer = None
    with _pool_lock:
        for i in range(len(_pool) - 1, -1, -1):  # the most recently released of this class
            if _pool[i][0] == k:
                _, buffer, address = _pool.pop(i)
                _pool_held[0] -= buffer.nbytes
                pool_stats["reused"] += 1
                break
    if buffer is None:
        buffer = _words(cap // 8)
        address = buffer.ctypes.data
        pool_stats["allocated"] += 1
    out = np.asarray(_Lease(buffer, address, k, shape, dtype.str))
    return poison(out) if POISON else out


def release_output_pool():
    """Free the released output buffers that :func:`output_empty` keeps; returns the bytes freed."""
    with _pool_lock:
        held = _pool_held[0]
        _pool.clear()
        _pool_held[0] = 0
    return held


def _after_fork():  # pragma: no cover - a child must not inherit a lock held by another thread of its parent
    global _pool_lock
    _pool_lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork)


# MADV_COLLAPSE (Linux 6.1+): back a range by transparent huge pages now, synchronously, copying the
# pages that are there; safe while other threads read and write the range (it is what khugepaged
# does to running processes). One 2 MiB page maps what takes 512 entries of 4 KiB in the TLB.
_MADV_COLLAPSE = 25
#: tries of one collapse that the kernel calls a transient failure (``EAGAIN``) before the array keeps its pages
COLLAPSE_TRIES = 3
HUGE_PAGE_BYTES = 1 << 21
_madvise = None


def collapse_to_huge_pages(a):
    """Back the 2 MiB-aligned interior of ``a``'s buffer by transparent huge pages, now.

    For large arrays read at random by the hot kernels (the edge-centred
    records and cell lists): :func:`empty` allocates them without the
    huge-page advice, so that they are filled fast; this collapses them
    afterwards, typically from a background thread
    (:meth:`polygen.volume.edge_centred.EdgeCentredTable.settle`). The
    contents do not change. Returns the bytes collapsed: 0 off Linux, on a
    kernel before 6.1 or with transparent huge pages ``never``, or when the
    kernel refuses (no memory to compact, for example) -- the array then
    simply keeps its 4 KiB pages.
    """
    global _madvise
    a = np.asarray(a)
    if a.nbytes < HUGE_PAGE_BYTES or not a.flags.c_contiguous or not os.uname().sysname == "Linux":
        return 0
    if _madvise is None:
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            fn = libc.madvise
        except (OSError, AttributeError):  # pragma: no cover - not a glibc/musl process
            _madvise = False
            return 0
        fn.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
        fn.restype = ctypes.c_int
        _madvise = fn
    if _madvise is False:  # pragma: no cover
        return 0
    lo = -(-a.ctypes.data // HUGE_PAGE_BYTES) * HUGE_PAGE_BYTES
    hi = (a.ctypes.data + a.nbytes) // HUGE_PAGE_BYTES * HUGE_PAGE_BYTES
    if hi <= lo:
        return 0
    for _ in range(COLLAPSE_TRIES):  # EAGAIN: a transient failure (a page could not be locked): again
        if _madvise(lo, hi - lo, _MADV_COLLAPSE) == 0:
            return hi - lo
        if ctypes.get_errno() != errno.EAGAIN:
            break
    return 0
