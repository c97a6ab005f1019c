"""numba intrinsics shared by the kernel modules: prefetch hints, count of trailing zeros, atomics.

Moved here from :mod:`polygen.volume._edge_centred_kernels` (which imports
them back under the same names) so that other kernels (the thinning FIFO,
:mod:`polygen.volume._thinning_kernels`) can use the same hints and the same
choice between the intrinsics and their plain fallbacks. A kernel that calls
them is decorated ``cache=_KCACHE`` (see below).
"""

import os

import numpy as np

from polygen import _jit
from polygen._jit import njit


# ------------------------------------------------------------------ intrinsics
# The prefetch hint and the count of trailing zeros are written against numba's internals
# (``numba.core.cgutils``) and LLVM intrinsic names (``llvm.prefetch.p0`` is the name under
# opaque pointers, LLVM >= 15). Either can change with a numba/llvmlite release, so a probe kernel
# runs all three at import (cached on disk like the others, so only the first import compiles it);
# when the internals are missing, the probe fails, or ``POLYGEN_PREFETCH=0`` asks for it,
# plain kernels take their place: no prefetch (slower by the misses it overlapped, same results)
# and a loop for the trailing zeros. ``PREFETCH`` says which ones the kernels below were built with.


@njit(inline="always")
def _prefetch_row_plain(arr, i):
    """Fallback of :func:`_prefetch_row`: no hint."""
    return None


@njit(inline="always")
def _prefetch_item_plain(arr, i):
    """Fallback of :func:`_prefetch_item`: no hint."""
    return None


@njit(inline="always")
def _ctz_plain(x):
    """Index of the lowest set bit of ``x`` by shifting; ``x`` must not be 0."""
    x = np.int64(x)
    n = 0
    while (x & 1) == 0:
        x >>= 1
        n += 1
    return n


try:  # numba internals: an ImportError here, or a failing probe below, selects the plain kernels
    from llvmlite import ir
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic
except ImportError:  # pragma: no cover - depends on the numba release
    intrinsic = None

if intrinsic is not None:

    def _prefetch_codegen(rw):
        def codegen(context, builder, signature, args):
            aryty = signature.args[0]
            ary = context.make_array(aryty)(context, builder, args[0])
            idx = [context.cast(builder, a, t, types.intp) for a, t in zip(args[1:], signature.args[1:])]
            ptr = cgutils.get_item_pointer(context, builder, aryty, ary, idx, wraparound=False)
            i8p = builder.bitcast(ptr, ir.IntType(8).as_pointer())
            i32 = ir.IntType(32)
            fnty = ir.FunctionType(ir.VoidType(), [i8p.type, i32, i32, i32])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0")
            builder.call(fn, [i8p, i32(rw), i32(3), i32(1)])  # rw, keep in every cache level, data
            return context.get_dummy_value()

        return codegen

    @intrinsic
    def _prefetch_row(typingctx, arr, i):
        """Fetch the line of ``arr[i, 0]`` for writing (a hint; no effect on results)."""
        if not isinstance(arr, types.Array) or arr.ndim != 2 or not isinstance(i, types.Integer):
            return None
        return types.void(arr, i), _prefetch_codegen(1)

    @intrinsic
    def _prefetch_item(typingctx, arr, i):
        """Fetch the line of ``arr[i]`` of a 1-D array for reading (a hint; no effect on results)."""
        if not isinstance(arr, types.Array) or arr.ndim != 1 or not isinstance(i, types.Integer):
            return None
        return types.void(arr, i), _prefetch_codegen(0)

    @intrinsic
    def _ctz(typingctx, x):
        """Index of the lowest set bit of ``x`` (``llvm.cttz``); ``x`` must not be 0."""
        if not isinstance(x, types.Integer):
            return None

        def codegen(context, builder, signature, args):
            ty = context.get_value_type(signature.args[0])
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ty, [ty, ir.IntType(1)]),
                                                f"llvm.cttz.i{ty.width}")
            r = builder.call(fn, [args[0], ir.IntType(1)(1)])
            return context.cast(builder, r, signature.args[0], types.int64)

        return types.int64(x), codegen

    @njit
    def _probe(arr, v, x):
        """All three intrinsics once (cached on disk like every kernel: the next import only loads it)."""
        _prefetch_row(arr, 0)
        _prefetch_item(v, 0)
        return _ctz(x)

    def _element_pointer(context, builder, aryty, ary_val, idx_vals, idx_tys):
        ary = context.make_array(aryty)(context, builder, ary_val)
        idx = [context.cast(builder, a, t, types.intp) for a, t in zip(idx_vals, idx_tys)]
        return cgutils.get_item_pointer(context, builder, aryty, ary, idx, wraparound=False)

    def _cas_codegen(dt, n_idx):
        """The code of a compare-and-swap on the element at the ``n_idx`` indices after the array; ``old``
        and ``new`` follow them."""

        def codegen(context, builder, signature, args):
            a = signature.args
            ptr = _element_pointer(context, builder, a[0], args[0], args[1:1 + n_idx], a[1:1 + n_idx])
            o = context.cast(builder, args[1 + n_idx], a[1 + n_idx], dt)
            n = context.cast(builder, args[2 + n_idx], a[2 + n_idx], dt)
            pair = builder.cmpxchg(ptr, o, n, "seq_cst", "seq_cst")
            return builder.extract_value(pair, 0)

        return codegen

    @intrinsic
    def _cas(typingctx, arr, i, old, new):
        """Compare-and-swap ``arr[i]`` (a 1-D integer array): if it holds ``old``, store ``new``.

        One LLVM ``cmpxchg`` (sequentially consistent on success and failure:
        a ``lock cmpxchg`` on x86). Returns the value ``arr[i]`` held before,
        ``old`` exactly when the swap happened.
        """
        if (not isinstance(arr, types.Array) or arr.ndim != 1 or not isinstance(arr.dtype, types.Integer)
                or not all(isinstance(x, types.Integer) for x in (i, old, new))):
            return None
        return arr.dtype(arr, i, old, new), _cas_codegen(arr.dtype, 1)

    @intrinsic
    def _cas_row(typingctx, arr, i, j, old, new):
        """:func:`_cas` on ``arr[i, j]`` of a 2-D integer array."""
        if (not isinstance(arr, types.Array) or arr.ndim != 2 or not isinstance(arr.dtype, types.Integer)
                or not all(isinstance(x, types.Integer) for x in (i, j, old, new))):
            return None
        return arr.dtype(arr, i, j, old, new), _cas_codegen(arr.dtype, 2)

    @intrinsic
    def _fetch_add(typingctx, arr, i, inc):
        """Atomically add ``inc`` to ``arr[i]`` (1-D integer array, LLVM ``atomicrmw add``); returns the old value."""
        if (not isinstance(arr, types.Array) or arr.ndim != 1 or not isinstance(arr.dtype, types.Integer)
                or not isinstance(i, types.Integer) or not isinstance(inc, types.Integer)):
            return None
        dt = arr.dtype

        def codegen(context, builder, signature, args):
            ptr = _element_pointer(context, builder, signature.args[0], args[0], args[1:2], signature.args[1:2])
            return builder.atomic_rmw("add", ptr, context.cast(builder, args[2], signature.args[2], dt), "seq_cst")

        return dt(arr, i, inc), codegen

    @njit
    def _probe_atomics(a, b):
        """The three atomics once: a swap that happens, one that does not, an add (see :func:`_atomics_work`)."""
        r0 = _cas(a, 0, 5, 7)  # a[0] == 5: swapped to 7, returns 5
        r1 = _cas(a, 1, 5, 7)  # a[1] == 6: unchanged, returns 6
        r2 = _cas_row(b, 0, 1, 3, 4)
        r3 = _fetch_add(a, 2, 10)
        return r0, r1, r2, r3


def _intrinsics_work():
    """Whether the intrinsics compile and give the right answer with this numba/llvmlite."""
    if intrinsic is None:
        return False
    try:
        return int(_probe(np.zeros((1, 16), np.int32), np.zeros(1, np.int32), np.int32(8))) == 3
    except Exception:  # an internal API moved or LLVM rejected the intrinsic: use the plain kernels
        return False


def _atomics_work():
    """Whether compare-and-swap and fetch-and-add compile and behave with this numba/llvmlite.

    Without them there is no parallel construction: ``threads > 1`` runs the
    serial one (:data:`ATOMICS` says which).
    """
    if intrinsic is None:
        return False
    try:
        a = np.array([5, 6, 1], np.int32)
        b = np.array([[0, 3]], np.int64)
        got = tuple(int(x) for x in _probe_atomics(a, b))
        return got == (5, 6, 3, 1) and a.tolist() == [7, 6, 11] and b.tolist() == [[0, 4]]
    except Exception:  # an internal API moved or LLVM rejected the intrinsic
        return False


#: whether the atomics of the parallel construction work here (else ``threads > 1`` runs serially)
ATOMICS = os.environ.get("POLYGEN_ATOMICS", "1") != "0" and _atomics_work()
#: whether the kernels use the prefetch and ctz intrinsics (else the plain fallbacks)
PREFETCH = os.environ.get("POLYGEN_PREFETCH", "1") != "0" and _intrinsics_work()
if not PREFETCH:
    _prefetch_row, _prefetch_item, _ctz = _prefetch_row_plain, _prefetch_item_plain, _ctz_plain
# a kernel's on-disk cache does not know which of the two it was compiled with: only the
# intrinsic build is cached, a fallback build is compiled in its process
_KCACHE = _jit.CACHE and PREFETCH
