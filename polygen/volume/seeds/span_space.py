"""Livnat's span space searched with a k-d tree (5.4.1 [41], Fig. 5.6 (b)).

Each cell is the point ``(S_min, S_max)``; the cells an isosurface ``C``
may cross are the points of the quadrant ``S_min <= C, S_max >= C``.
The points are kept in a balanced 2-d tree split at the median, by
``S_min`` on even levels and ``S_max`` on odd ones. The tree has no
pointers: in a range ``[lo, hi)`` of the permutation the node is the
element at ``mid = (lo + hi) // 2``, its subtrees are ``[lo, mid)`` and
``[mid + 1, hi)``, with keys ``<=`` and ``>=`` the node's key.

Query: a node's split key decides whether one subtree lies wholly inside
or wholly outside the half-plane of that key; a subtree inside both
half-planes is handed over in one piece without comparisons (the "k"
term), one outside either is pruned. Pre O(n log n) (median selection per
level), query O(sqrt(n) + k) (Table 5.2).

``n_tested`` = nodes whose point was compared with ``C`` + cells of
subtrees handed over wholesale; ``cells`` are exactly the active cells.
"""

import numpy as np

from polygen._jit import njit
from polygen.volume.seeds.base import ActiveCellSearch, register

__all__ = ["SpanSpace"]

_STACK = 256  # > 2 * depth of any tree over < 2**63 points


@njit
def _xorshift(x):
    x ^= x << np.uint64(13)
    x ^= x >> np.uint64(7)
    x ^= x << np.uint64(17)
    return x


@njit
def _select(perm, pts, dim, lo, hi, target):
    """Rearrange rows ``lo:hi`` of ``perm`` and ``pts`` so that row ``target`` has the rank-``target`` key.

    The key is ``pts[:, dim]``. Quickselect with a three-way partition, so
    that many equal keys cost no more than distinct ones; the pivot choice
    is pseudo-random but fixed, so the same input always gives the same tree.
    """
    left = lo
    right = hi - 1
    # pivot: median of three pseudo-random rows; a fixed-position pivot
    # degrades to O(n^2) on the patterns the alternating splits leave behind
    state = np.uint64(0x9E3779B97F4A7C15) ^ np.uint64(hi - lo)
    while right > left:
        span = np.uint64(right - left + 1)
        state = _xorshift(state)
        a = pts[left + np.int64(state % span), dim]
        state = _xorshift(state)
        b = pts[left + np.int64(state % span), dim]
        state = _xorshift(state)
        c = pts[left + np.int64(state % span), dim]
        if a > b:
            a, b = b, a
        if b > c:
            b = c
        pivot = a if a > b else b
        lt = left
        i = left
        gt = right
        while i <= gt:
            v = pts[i, dim]
            if v < pivot:
                _swap(perm, pts, lt, i)
                lt += 1
                i += 1
            elif v > pivot:
                _swap(perm, pts, gt, i)
                gt -= 1
            else:
                i += 1
        if target < lt:
            right = lt - 1
        elif target > gt:
            left = gt + 1
        else:
            return


@njit
def _swap(perm, pts, i, j):
    perm[i], perm[j] = perm[j], perm[i]
    x0 = pts[i, 0]
    x1 = pts[i, 1]
    pts[i, 0] = pts[j, 0]
    pts[i, 1] = pts[j, 1]
    pts[j, 0] = x0
    pts[j, 1] = x1


@njit
def _kd_build(perm, pts, lo, hi):
    """Arrange rows ``lo:hi`` of ``perm`` and ``pts`` as an implicit k-d tree.

    ``pts[r] = (S_min, S_max)`` of cell ``perm[r]``; both arrays are permuted
    together, so the tree keeps its keys in tree order (no indirection).
    """
    stack = np.empty((_STACK, 3), dtype=np.int64)
    stack[0, 0] = lo
    stack[0, 1] = hi
    stack[0, 2] = 0
    top = 1
    while top > 0:
        top -= 1
        a = stack[top, 0]
        b = stack[top, 1]
        depth = stack[top, 2]
        if b - a <= 1:
            continue
        mid = (a + b) // 2
        _select(perm, pts, depth % 2, a, b, mid)
        stack[top, 0] = a
        stack[top, 1] = mid
        stack[top, 2] = depth + 1
        stack[top + 1, 0] = mid + 1
        stack[top + 1, 1] = b
        stack[top + 1, 2] = depth + 1
        top += 2


@njit
def _kd_query(perm, pts, lo, hi, value, out, k):
    """Append the cells of the k-d tree in rows ``lo:hi`` with ``S_min <= value <= S_max`` to ``out[k:]``.

    Returns the new ``k`` and the number of cells tested.
    """
    # rows: lo, hi, depth, min known to hold in the whole subtree, max known to hold
    stack = np.empty((_STACK, 5), dtype=np.int64)
    stack[0, 0] = lo
    stack[0, 1] = hi
    stack[0, 2] = 0
    stack[0, 3] = 0
    stack[0, 4] = 0
    top = 1
    tested = 0
    while top > 0:
        top -= 1
        a = stack[top, 0]
        b = stack[top, 1]
        depth = stack[top, 2]
        min_ok = stack[top, 3]
        max_ok = stack[top, 4]
        if b <= a:
            continue
        if min_ok and max_ok:
            for j in range(a, b):
                out[k] = perm[j]
                k += 1
            tested += b - a
            continue
        mid = (a + b) // 2
        c = perm[mid]
        tested += 1
        lo_c = pts[mid, 0]
        hi_c = pts[mid, 1]
        if (min_ok or lo_c <= value) and (max_ok or hi_c >= value):
            out[k] = c
            k += 1
        if depth % 2 == 0:
            # left subtree: kmin <= lo_c; right subtree: kmin >= lo_c
            if lo_c <= value:
                stack[top, 0] = a
                stack[top, 1] = mid
                stack[top, 2] = depth + 1
                stack[top, 3] = 1
                stack[top, 4] = max_ok
                stack[top + 1, 0] = mid + 1
                stack[top + 1, 1] = b
                stack[top + 1, 2] = depth + 1
                stack[top + 1, 3] = min_ok
                stack[top + 1, 4] = max_ok
                top += 2
            else:  # the right subtree starts above C
                stack[top, 0] = a
                stack[top, 1] = mid
                stack[top, 2] = depth + 1
                stack[top, 3] = min_ok
                stack[top, 4] = max_ok
                top += 1
        else:
            # left subtree: kmax <= hi_c; right subtree: kmax >= hi_c
            if hi_c >= value:
                stack[top, 0] = mid + 1
                stack[top, 1] = b
                stack[top, 2] = depth + 1
                stack[top, 3] = min_ok
                stack[top, 4] = 1
                stack[top + 1, 0] = a
                stack[top + 1, 1] = mid
                stack[top + 1, 2] = depth + 1
                stack[top + 1, 3] = min_ok
                stack[top + 1, 4] = max_ok
                top += 2
            else:  # the left subtree ends below C
                stack[top, 0] = mid + 1
                stack[top, 1] = b
                stack[top, 2] = depth + 1
                stack[top, 3] = min_ok
                stack[top, 4] = max_ok
                top += 1
    return k, tested


@njit
def _build_span_space(cmin, cmax):
    m = cmin.shape[0]
    perm = np.arange(m)
    pts = np.empty((m, 2))
    pts[:, 0] = cmin
    pts[:, 1] = cmax
    _kd_build(perm, pts, 0, m)
    return perm, pts


class SpanSpace(ActiveCellSearch):
    """A pointerless k-d tree over the span-space points ``(S_min, S_max)`` (Livnat et al.)."""

    name = "span-space"

    @classmethod
    def _build(cls, cmin, cmax):
        obj = cls(cmin, cmax)
        obj.perm, obj.pts = _build_span_space(cmin, cmax)
        return obj

    def _query(self, value):
        k, tested = _kd_query(self.perm, self.pts, 0, self.perm.shape[0], value, self._out, 0)
        return self._out[:k].copy(), tested, k


register(SpanSpace)
