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
