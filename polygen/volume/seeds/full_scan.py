"""The baseline: test the interval of every cell (5.3; "all cells" in Table 6.4)."""

import numpy as np

from polygen._jit import njit
from polygen.volume.seeds.base import ActiveCellSearch, register

__all__ = ["FullScan"]


@njit
def _scan(cmin, cmax, value, out):
    k = 0
    for i in range(cmin.shape[0]):
        # branch-free: always write, advance only on a hit (most cells miss)
        out[k] = i
        k += (cmin[i] <= value) & (cmax[i] >= value)
    return k


class FullScan(ActiveCellSearch):
    """No structure: every query compares all ``M`` intervals (pre O(1), query O(n)).

    ``n_tested == M`` for every query; ``cells`` are exactly the active cells.
    """

    name = "full-scan"
    cells_in_order = True

    @classmethod
    def _build(cls, cmin, cmax):
        return cls(cmin, cmax)

    def _query(self, value):
        k = _scan(self.cmin, self.cmax, value, self._out)
        return self._out[:k].copy(), self.n_cells, k


register(FullScan)
