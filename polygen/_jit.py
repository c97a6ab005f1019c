"""The one place where numba's JIT options are set.

Every kernel in polygen is decorated with :func:`njit` from here, so that
the on-disk cache (a new process does not recompile) and the other options
are the same everywhere. ``POLYGEN_NUMBA_CACHE=0`` turns the cache off,
for example on a read-only install.
"""

import os

import numba
import numpy as np

CACHE = os.environ.get("POLYGEN_NUMBA_CACHE", "1") != "0"
prange = numba.prange


def njit(fn=None, **kwargs):
    """``numba.njit`` with polygen's defaults (``cache=True, nogil=True``).

    Use as ``@njit`` or ``@njit(parallel=True)``.
    """
    kwargs.setdefault("cache", CACHE)
    kwargs.setdefault("nogil", True)
    if fn is None:
        return numba.njit(**kwargs)
    return numba.njit(**kwargs)(fn)


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
    shape = (int(shape),) if np.ndim(shape) == 0 else tuple(int(n) for n in shape)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if nbytes < HUGE_ADVICE_BYTES:
        return np.empty(shape, dtype)
    return _words((nbytes + 7) // 8).view(np.uint8)[:nbytes].view(dtype).reshape(shape)


def astype(a, dtype):
    """``a.astype(dtype)`` into an array from :func:`empty`."""
    out = empty(a.shape, dtype)
    out[...] = a
    return out


# MADV_COLLAPSE (Linux 6.1+): back a range by transparent huge pages now, synchronously, copying the
# pages that are there; safe while other threads read and write the range (it is what khugepaged
# does to running processes). One 2 MiB page maps what takes 512 entries of 4 KiB in the TLB.
_MADV_COLLAPSE = 25
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
        import ctypes

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
    return hi - lo if _madvise(lo, hi - lo, _MADV_COLLAPSE) == 0 else 0
