"""The one place where numba's JIT options are set.

Every kernel in polygen is decorated with :func:`njit` from here, so that
the on-disk cache (a new process does not recompile) and the other options
are the same everywhere. ``POLYGEN_NUMBA_CACHE=0`` turns the cache off,
for example on a read-only install.
"""

import os

import numba

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
