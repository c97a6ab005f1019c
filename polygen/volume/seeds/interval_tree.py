"""Cignoni's interval tree (Cignoni et al. 1997): a centred interval tree over the cell intervals.

Not in Table 5.2 of the thesis (it postdates it); it is the usual
O(log n + k) answer to the same query and a reference for the others.

The tree is a balanced binary search tree over the sorted distinct
endpoints ``E`` of all intervals, without pointers: the node of a range
``[lo, hi)`` of ``E`` is ``mid = (lo + hi) // 2`` with split value
``d = E[mid]``. Each interval is stored at the highest node whose ``d`` it
contains (``S_min <= d <= S_max``), in two lists: by ``S_min`` ascending
and by ``S_max`` descending. Query ``C``, walking down from the root:

* ``C < d``: scan the node's ``S_min`` list while ``S_min <= C`` (each such
  interval also has ``S_max >= d > C``), then go left;
* ``C > d``: scan the ``S_max`` list while ``S_max >= C``, then go right;
* ``C == d``: every interval of the node contains ``C`` and none below does.

Pre O(n log n), query O(log n + k). ``n_tested`` counts the cells compared,
the one that stops a scan included (at most one per level above ``k``);
``cells`` are exactly the active cells.
"""

import numpy as np

from polygen._jit import njit
from polygen.volume.seeds.base import ActiveCellSearch, register

__all__ = ["IntervalTree"]


@njit
def _build_tree(cmin, cmax, by_min, by_max):
    m = cmin.shape[0]
    # sorted endpoints by merging the two sorted lists (by_max is descending)
    ends = np.empty(2 * m)
    i = 0
    j = m - 1
    for t in range(2 * m):
        if j < 0 or (i < m and cmin[by_min[i]] <= cmax[by_max[j]]):
            ends[t] = cmin[by_min[i]]
            i += 1
        else:
            ends[t] = cmax[by_max[j]]
            j -= 1
    # distinct endpoints
    n_e = 0
    for j in range(ends.shape[0]):
        if n_e == 0 or ends[j] != ends[n_e - 1]:
            ends[n_e] = ends[j]
            n_e += 1
    split = ends[:n_e].copy()
    node = np.empty(m, dtype=np.int64)
    count = np.zeros(n_e + 1, dtype=np.int64)
    for c in range(m):
        lo = 0
        hi = n_e
        mid = 0
        while True:  # the interval's own endpoints are in E, so this ends at a node
            mid = (lo + hi) // 2
            d = split[mid]
            if cmax[c] < d:
                hi = mid
            elif cmin[c] > d:
                lo = mid + 1
            else:
                break
        node[c] = mid
        count[mid + 1] += 1
    offsets = np.cumsum(count)
    p_min = np.empty(m, dtype=np.int64)
    p_max = np.empty(m, dtype=np.int64)
    fill = offsets[:-1].copy()
    for j in range(m):
        c = by_min[j]
        p_min[fill[node[c]]] = c
        fill[node[c]] += 1
    fill = offsets[:-1].copy()
    for j in range(m):
        c = by_max[j]
        p_max[fill[node[c]]] = c
        fill[node[c]] += 1
    # keys copied into list order: the query scans them without indirection
    return split, offsets, p_min, p_max, cmin[p_min], cmax[p_max]


@njit
def _query_tree(split, offsets, p_min, p_max, kmin, kmax, value, out):
    lo = 0
    hi = split.shape[0]
    k = 0
    tested = 0
    while lo < hi:
        mid = (lo + hi) // 2
        d = split[mid]
        s = offsets[mid]
        e = offsets[mid + 1]
        if value < d:
            for j in range(s, e):
                tested += 1
                if kmin[j] > value:
                    break
                out[k] = p_min[j]
                k += 1
            hi = mid
        elif value > d:
            for j in range(s, e):
                tested += 1
                if kmax[j] < value:
                    break
                out[k] = p_max[j]
                k += 1
            lo = mid + 1
        else:
            for j in range(s, e):
                out[k] = p_min[j]
                k += 1
            tested += e - s
            break
    return k, tested


class IntervalTree(ActiveCellSearch):
    """A centred interval tree with per-node ``S_min``/``S_max`` lists (see the module docstring)."""

    name = "interval-tree"

    @classmethod
    def _build(cls, cmin, cmax):
        obj = cls(cmin, cmax)
        obj.split, obj.offsets, obj.p_min, obj.p_max, obj.kmin, obj.kmax = _build_tree(cmin, cmax, np.argsort(cmin), np.argsort(-cmax))
        return obj

    def _query(self, value):
        k, tested = _query_tree(
            self.split, self.offsets, self.p_min, self.p_max, self.kmin, self.kmax, value, self._out
        )
        return self._out[:k].copy(), tested, k


register(IntervalTree)
