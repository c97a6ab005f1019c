"""Gallagher's span filtering: cells in buckets over the value range (5.4.1 [17]; "filter").

The range ``[min S_min, max S_max]`` is cut into ``n_buckets`` equal
classes ``Group_1 .. Group_B``. Two layouts:

``layout="replicate"`` (default; the thesis's wording of 5.4.1)
    a cell is registered in every class from ``Group(S_min)`` to
    ``Group(S_max)``; for an isovalue ``C`` the cells of ``Group(C)`` are the
    candidates, handed over without a test. ``n_tested`` = the size of that
    class; ``cells`` include inactive cells of the class.
``layout="by-min"`` (Gallagher's paper)
    a cell is placed in the class of its ``S_min`` only; inside a class the
    cells are sorted by ``S_max`` descending, and the class keeps its largest
    ``S_max`` (the span limit). A query walks every class at or below
    ``Group(C)`` whose span limit reaches ``C``, each until the first cell
    with ``S_max < C``. ``n_tested`` counts every cell compared, the stopping
    one included; ``cells`` are exactly the active cells.

Pre O(n) (plus a sort per class for "by-min"), query O(n) (Table 5.2).
Classes are assigned by one monotone function of the value in both build
and query, so a cell with ``S_min <= C <= S_max`` is always found, also when
``C`` or an endpoint lies exactly on a class boundary.
"""

import numpy as np

from polygen import _jit
from polygen._jit import njit
from polygen.volume.seeds.base import ActiveCellSearch, IntervalError, register

__all__ = ["SpanFilter"]

LAYOUTS = ("replicate", "by-min")


@njit
def _bucket(x, lo, width, nb):
    # monotone non-decreasing in x, the same arithmetic in build and query
    if width <= 0.0:
        return 0
    t = (x - lo) / width
    # never an index from NaN (inf / inf when max - min overflows float64): NaN goes to class 0
    if t >= nb - 1:
        return nb - 1
    if t > 0.0:
        return int(t)
    return 0


@njit
def _build_replicate(cmin, cmax, lo, width, nb):
    m = cmin.shape[0]
    count = np.zeros(nb + 1, dtype=np.int64)
    for i in range(m):
        b0 = _bucket(cmin[i], lo, width, nb)
        b1 = _bucket(cmax[i], lo, width, nb)
        for b in range(b0, b1 + 1):
            count[b + 1] += 1
    offsets = np.cumsum(count)
    fill = offsets[:-1].copy()
    ids = np.empty(offsets[-1], dtype=np.int64)
    for i in range(m):
        b0 = _bucket(cmin[i], lo, width, nb)
        b1 = _bucket(cmax[i], lo, width, nb)
        for b in range(b0, b1 + 1):
            ids[fill[b]] = i
            fill[b] += 1
    return offsets, ids


@njit
def _query_replicate(cmin, cmax, offsets, ids, lo, hi, width, nb, value, out):
    if not (lo <= value <= hi):
        return 0, 0
    b = _bucket(value, lo, width, nb)
    s = offsets[b]
    e = offsets[b + 1]
    hits = 0
    for j in range(s, e):
        c = ids[j]
        out[j - s] = c
        if cmin[c] <= value and cmax[c] >= value:
            hits += 1
    return e - s, hits


@njit
def _build_by_min(cmin, cmax, order, lo, width, nb):
    m = cmin.shape[0]
    bucket = np.empty(m, dtype=np.int64)
    count = np.zeros(nb + 1, dtype=np.int64)
    for i in range(m):
        b = _bucket(cmin[i], lo, width, nb)
        bucket[i] = b
        count[b + 1] += 1
    offsets = np.cumsum(count)
    # a stable counting sort of the max-descending order keeps each class sorted
    fill = offsets[:-1].copy()
    ids = np.empty(m, dtype=np.int64)
    for j in range(m):
        c = order[j]
        b = bucket[c]
        ids[fill[b]] = c
        fill[b] += 1
    top = np.full(nb, -np.inf)
    for b in range(nb):
        if offsets[b + 1] > offsets[b]:
            top[b] = cmax[ids[offsets[b]]]
    # keys copied into class order: a query reads them without indirection
    return offsets, ids, top, cmin[ids], cmax[ids]


@njit
def _query_by_min(kmin, kmax, offsets, ids, top, lo, hi, width, nb, value, out):
    if not (lo <= value <= hi):
        return 0, 0
    bc = _bucket(value, lo, width, nb)
    k = 0
    tested = 0
    for b in range(bc + 1):
        if top[b] < value:  # no cell of this class reaches C
            continue
        for j in range(offsets[b], offsets[b + 1]):
            tested += 1
            if kmax[j] < value:
                break
            # below Group(C) every S_min < C already; only Group(C) needs the test
            if b == bc and kmin[j] > value:
                continue
            out[k] = ids[j]
            k += 1
    return k, tested


class SpanFilter(ActiveCellSearch):
    """Equal-width value classes over the data range (see the module docstring).

    The keyword-only parameters of :meth:`build` are these.

    Other Parameters
    ----------------
    n_buckets : int, default 64
        Number of classes ``B``.
    layout : {"replicate", "by-min"}, default "replicate"
    """

    name = "span-filter"

    @classmethod
    def _build(cls, cmin, cmax, *, n_buckets=64, layout="replicate"):
        if isinstance(n_buckets, bool) or not isinstance(n_buckets, (int, np.integer)) or n_buckets < 1:
            raise IntervalError(f"n_buckets must be a positive integer; got {n_buckets!r}")
        if layout not in LAYOUTS:
            raise IntervalError(f"layout must be one of {LAYOUTS}; got {layout!r}")
        obj = cls(cmin, cmax)
        nb = int(n_buckets)
        obj.n_buckets = nb
        obj.layout = layout
        obj.cells_in_order = layout == "replicate"  # one class's cells, ascending
        if cmin.size:
            obj.lo = float(cmin.min())
            obj.hi = float(cmax.max())
        else:
            obj.lo, obj.hi = 0.0, -1.0  # empty range: every query misses
        obj.width = (obj.hi - obj.lo) / nb if obj.hi > obj.lo else 0.0
        if layout == "replicate":
            obj.offsets, obj.ids = _build_replicate(cmin, cmax, obj.lo, obj.width, nb)
            obj.top = _jit.scratch(0)
        else:
            obj.offsets, obj.ids, obj.top, obj.kmin, obj.kmax = _build_by_min(cmin, cmax, np.argsort(-cmax), obj.lo, obj.width, nb)
        return obj

    def _query(self, value):
        if self.layout == "replicate":
            k, hits = _query_replicate(
                self.cmin, self.cmax, self.offsets, self.ids, self.lo, self.hi, self.width, self.n_buckets, value, self._out
            )
            return self._out[:k].copy(), k, hits
        k, tested = _query_by_min(
            self.kmin, self.kmax, self.offsets, self.ids, self.top, self.lo, self.hi, self.width,
            self.n_buckets, value, self._out,
        )
        return self._out[:k].copy(), tested, k


register(SpanFilter)
