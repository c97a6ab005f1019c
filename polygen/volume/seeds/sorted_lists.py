"""Giles and Haimes's sorted lists (5.4.1 [21]; "sort" in Tables 6.2-7.5).

All cells sorted once by ``S_min`` and once by ``S_max``. For an isovalue
``C`` the cells with ``S_min <= C`` form a prefix of the first list and the
cells with ``S_max >= C`` a prefix of the second (max descending); both
prefix lengths come from a binary search. The shorter prefix is scanned and
its cells tested against the other bound, which leaves exactly the active
cells. Pre O(n log n), query O(n) (Table 5.2): for a value in the middle of
the range either prefix holds a fixed fraction of the cells.
"""

import numpy as np

from polygen._jit import njit
from polygen.volume.seeds.base import ActiveCellSearch, register

__all__ = ["SortedLists"]


@njit
def _query_lists(by_min, smin, max_by_min, by_max, negmax_sorted, min_by_max, value, out):
    a = np.searchsorted(smin, value, side="right")  # cells with S_min <= C
    b = np.searchsorted(negmax_sorted, -value, side="right")  # cells with S_max >= C
    k = 0
    if a <= b:
        for j in range(a):
            out[k] = by_min[j]
            k += max_by_min[j] >= value
        return k, a
    for j in range(b):
        out[k] = by_max[j]
        k += min_by_max[j] <= value
    return k, b


class SortedLists(ActiveCellSearch):
    """Cells sorted by ``S_min`` and by ``S_max``; a query scans the shorter qualifying prefix.

    ``n_tested`` is the length of the prefix scanned (``min(#{S_min <= C},
    #{S_max >= C})``); ``cells`` are exactly the active cells.
    """

    name = "sorted-lists"

    @classmethod
    def _build(cls, cmin, cmax):
        obj = cls(cmin, cmax)
        # numpy's sort is several times faster than numba's; the rest is gathers
        obj.by_min = np.argsort(cmin)
        obj.smin = cmin[obj.by_min]
        neg = -cmax
        obj.by_max = np.argsort(neg)  # S_max descending
        obj.negmax = neg[obj.by_max]
        # each list carries the other bound too, so a scan reads memory in order
        obj.max_by_min = cmax[obj.by_min]
        obj.min_by_max = cmin[obj.by_max]
        return obj

    def _query(self, value):
        k, tested = _query_lists(
            self.by_min, self.smin, self.max_by_min, self.by_max, self.negmax, self.min_by_max, value, self._out
        )
        return self._out[:k].copy(), tested, k


register(SortedLists)
