"""Shen's ISSUE: an L x L lattice over span space (5.4.1 [51], Fig. 5.6 (c)).

The ``S_min`` axis and the ``S_max`` axis are each cut into ``L`` classes
holding equally many cells (split values taken from the two sorted lists,
as the thesis describes). Lattice element ``(i, j)`` holds the cells whose
``S_min`` lies in class ``i`` and ``S_max`` in class ``j``. For an
isovalue ``C`` in column ``ci`` and row ``rj``:

* elements left of ``ci`` and above ``rj`` lie wholly inside the query
  quadrant: their cells are handed over in one piece (contiguous in memory,
  one copy per column);
* the strip ``(ci, j > rj)`` needs only ``S_min <= C``: a binary search in
  each element's ``S_min``-sorted list;
* the strip ``(i < ci, rj)`` needs only ``S_max >= C``: a binary search in
  each element's ``S_max``-sorted list;
* the corner element ``(ci, rj)`` needs both: a span-space k-d tree kept
  inside each element (``inner="kdtree"``, default) or Giles-Haimes sorted
  lists (``inner="sorted"``);
* every other element is outside.

Pre O(n log n), query O(log(n/L) + sqrt(n)/L + k) (Table 5.2; here each
strip costs O(L log(n/L)) for the binary searches).
``n_tested`` = cells handed over + cells compared in the corner;
``cells`` are exactly the active cells.
"""

import numpy as np

from polygen._jit import njit
from polygen.volume.seeds.base import ActiveCellSearch, IntervalError, register
from polygen.volume.seeds.span_space import _kd_build, _kd_query

__all__ = ["IssueLattice"]

INNER = ("kdtree", "sorted")


@njit
def _build_lattice(cmin, cmax, by_min, by_max, L, kd):
    m = cmin.shape[0]
    negmax = -cmax
    # L - 1 interior split values: class t starts at the (t * m // L)-th smallest
    msplit = np.empty(L - 1)
    xsplit = np.empty(L - 1)
    for t in range(1, L):
        if m == 0:
            msplit[t - 1] = 0.0
            xsplit[t - 1] = 0.0
            continue
        r = (t * m) // L
        msplit[t - 1] = cmin[by_min[r]]
        xsplit[t - 1] = cmax[by_max[m - 1 - r]]  # by_max is descending
    col = np.searchsorted(msplit, cmin, side="right")
    row = np.searchsorted(xsplit, cmax, side="right")
    count = np.zeros(L * L + 1, dtype=np.int64)
    for c in range(m):
        count[col[c] * L + row[c] + 1] += 1
    offsets = np.cumsum(count)
    # stable counting sorts keep each element's cells in S_min / S_max order
    p_min = np.empty(m, dtype=np.int64)
    fill = offsets[:-1].copy()
    for j in range(m):
        c = by_min[j]
        e = col[c] * L + row[c]
        p_min[fill[e]] = c
        fill[e] += 1
    p_max = np.empty(m, dtype=np.int64)
    fill = offsets[:-1].copy()
    for j in range(m):
        c = by_max[j]
        e = col[c] * L + row[c]
        p_max[fill[e]] = c
        fill[e] += 1
    smin = cmin[p_min]
    snegmax = negmax[p_max]
    p_kd = p_min[:0]
    pts = np.empty((0, 2))
    if kd:
        p_kd = p_min.copy()
        pts = np.empty((m, 2))
        pts[:, 0] = smin
        pts[:, 1] = cmax[p_kd]
        for e in range(L * L):
            if offsets[e + 1] - offsets[e] > 1:
                _kd_build(p_kd, pts, offsets[e], offsets[e + 1])
    return msplit, xsplit, offsets, p_min, smin, p_max, snegmax, p_kd, pts


@njit
def _query_lattice(cmin, cmax, L, msplit, xsplit, offsets, p_min, smin, p_max, snegmax, p_kd, pts, kd, value, out):
    ci = np.searchsorted(msplit, value, side="right")
    rj = np.searchsorted(xsplit, value, side="right")
    k = 0
    tested = 0
    # inside: columns < ci, rows > rj (rows rj+1 .. L-1 of a column are contiguous)
    for i in range(ci):
        s = offsets[i * L + rj + 1]
        e = offsets[i * L + L]
        for j in range(s, e):
            out[k] = p_min[j]
            k += 1
        tested += e - s
    # column strip: S_max >= C holds, S_min <= C to find
    for r in range(rj + 1, L):
        el = ci * L + r
        s = offsets[el]
        e = offsets[el + 1]
        if e > s:
            t = s + np.searchsorted(smin[s:e], value, side="right")
            for j in range(s, t):
                out[k] = p_min[j]
                k += 1
            tested += t - s
    # row strip: S_min <= C holds, S_max >= C to find
    for i in range(ci):
        el = i * L + rj
        s = offsets[el]
        e = offsets[el + 1]
        if e > s:
            t = s + np.searchsorted(snegmax[s:e], -value, side="right")
            for j in range(s, t):
                out[k] = p_max[j]
                k += 1
            tested += t - s
    # corner: both bounds
    el = ci * L + rj
    s = offsets[el]
    e = offsets[el + 1]
    if e > s:
        if kd:
            k, tk = _kd_query(p_kd, pts, s, e, value, out, k)
            tested += tk
        else:
            a = np.searchsorted(smin[s:e], value, side="right")
            b = np.searchsorted(snegmax[s:e], -value, side="right")
            if a <= b:
                for j in range(s, s + a):
                    c = p_min[j]
                    if cmax[c] >= value:
                        out[k] = c
                        k += 1
                tested += a
            else:
                for j in range(s, s + b):
                    c = p_max[j]
                    if cmin[c] <= value:
                        out[k] = c
                        k += 1
                tested += b
    return k, tested


def default_lattice_size(m):
    """The default ``L``: about ``sqrt(M) / 8``, between 1 and 512."""
    return int(min(512, max(1, round(np.sqrt(m) / 8))))


class IssueLattice(ActiveCellSearch):
    """Shen's ISSUE lattice over span space (see the module docstring).

    The keyword-only parameters of :meth:`build` are these.

    Other Parameters
    ----------------
    L : int, optional
        Classes per axis; default :func:`default_lattice_size` of ``M``.
    inner : {"kdtree", "sorted"}, default "kdtree"
        The search inside the corner element.
    """

    name = "issue-lattice"

    @classmethod
    def _build(cls, cmin, cmax, *, L=None, inner="kdtree"):
        if L is None:
            L = default_lattice_size(cmin.size)
        if isinstance(L, bool) or not isinstance(L, (int, np.integer)) or not 1 <= L <= 4096:
            raise IntervalError(f"L must be an integer in [1, 4096]; got {L!r}")
        if inner not in INNER:
            raise IntervalError(f"inner must be one of {INNER}; got {inner!r}")
        obj = cls(cmin, cmax)
        obj.L = int(L)
        obj.inner = inner
        (obj.msplit, obj.xsplit, obj.offsets, obj.p_min, obj.smin, obj.p_max, obj.snegmax, obj.p_kd, obj.pts) = _build_lattice(
            cmin, cmax, np.argsort(cmin), np.argsort(-cmax), obj.L, inner == "kdtree"
        )
        return obj

    def _query(self, value):
        k, tested = _query_lattice(
            self.cmin, self.cmax, self.L, self.msplit, self.xsplit, self.offsets, self.p_min, self.smin,
            self.p_max, self.snegmax, self.p_kd, self.pts, self.inner == "kdtree", value, self._out,
        )
        return self._out[:k].copy(), tested, k


register(IssueLattice)
