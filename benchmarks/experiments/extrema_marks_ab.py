"""The extrema's marks (Fig. 6.5's first loop, ``T_pe`` in the thinning) before and after.

``before``: the cell loop as it was (a test per node for each of the four
marks), copied here; ``after``: the package's ``_mark_cells`` (a cell with
no tie at its largest and smallest node marks all its nodes and puts the
two extremes' marks back). Timed: the marks alone, and the whole of
``find_extrema`` with each (its other steps are the package's). One
process, 2M (field ``fem``) and 10M, JIT warm, ``ROUNDS`` interleaved
rounds, the best per arm; both arms must give equal marks and extrema.
``/proc/loadavg`` before and after.

Criterion, fixed before measuring: adopt if ``after`` is faster than
``before`` for ``find_extrema`` at both 2M and 10M and all tests pass.

    python benchmarks/experiments/extrema_marks_ab.py            # 2M 10M
"""

import sys
import time

import numpy as np

from polygen._jit import njit
from polygen.volume import _extrema_kernels as _k
from polygen.volume import datasets
from polygen.volume import extrema_graph as eg

import _experiment  # noqa: F401  (benchmarks/_common.py, results under experiments/results/)
from _common import write_results

ROUNDS = 5


@njit
def _mark_cells_before(cells, s, not_max, not_min, plural_max, plural_min):
    nn = cells.shape[1]
    for c in range(cells.shape[0]):
        hi = s[cells[c, 0]]
        lo = hi
        for i in range(1, nn):
            v = s[cells[c, i]]
            if v > hi:
                hi = v
            if v < lo:
                lo = v
        n_hi = 0
        n_lo = 0
        for i in range(nn):
            v = s[cells[c, i]]
            if v == hi:
                n_hi += 1
            if v == lo:
                n_lo += 1
        for i in range(nn):
            node = cells[c, i]
            v = s[node]
            if v < hi:
                not_max[node] = True
            elif n_hi > 1:
                plural_max[node] = True
            if v > lo:
                not_min[node] = True
            elif n_lo > 1:
                plural_min[node] = True


AFTER = _k._mark_cells
ARMS = {"before": _mark_cells_before, "after": AFTER}


def marks(fn, cells, s):
    out = [np.zeros(s.shape[0], np.bool_) for _ in range(4)]
    fn(cells, s, *out)
    return out


def find_extrema_with(fn, vol):
    _k._mark_cells = fn  # find_extrema reads the kernel from the module at call time
    try:
        return eg.find_extrema(vol)
    finally:
        _k._mark_cells = AFTER


def loadavg():
    return open("/proc/loadavg").read().split()[:3]


def main(names):
    data = {}
    for name in names:
        vol = datasets.load(name, field=None if name == "10M" else "fem")
        vol.node_cells
        cells, s = np.ascontiguousarray(vol.cells, np.int64), np.ascontiguousarray(vol.scalars(), np.float64)
        data[name] = vol, cells, s
        ref = marks(ARMS["before"], cells, s)
        ext = find_extrema_with(ARMS["before"], vol)
        for fn in ARMS.values():
            assert all(np.array_equal(a, b) for a, b in zip(marks(fn, cells, s), ref))
            assert np.array_equal(find_extrema_with(fn, vol).nodes, ext.nodes)
    load_before = loadavg()
    times = {}
    for _ in range(ROUNDS):
        for name in names:
            vol, cells, s = data[name]
            for arm, fn in ARMS.items():
                t0 = time.perf_counter()
                marks(fn, cells, s)
                t1 = time.perf_counter()
                find_extrema_with(fn, vol)
                t2 = time.perf_counter()
                times.setdefault((name, arm, "marks"), []).append(t1 - t0)
                times.setdefault((name, arm, "find_extrema"), []).append(t2 - t1)
    load_after = loadavg()
    rows = []
    for name in names:
        row = {"data": name, "cells": data[name][0].n_cells}
        for arm in ARMS:
            for part in ("marks", "find_extrema"):
                row[f"{arm} {part} s"] = min(times[name, arm, part])
                row[f"{arm} {part} rounds"] = " ".join(f"{t:.3f}" for t in times[name, arm, part])
        row["after faster"] = bool(row["after find_extrema s"] < row["before find_extrema s"])
        rows.append(row)
        print(row, flush=True)
    cols = ["data", "cells", "before marks s", "after marks s", "before find_extrema s", "after find_extrema s",
            "after faster", "before find_extrema rounds", "after find_extrema rounds"]
    notes = [f"best of {ROUNDS} interleaved rounds, one process", f"loadavg before {load_before}, after {load_after}",
             "criterion (fixed before measuring): adopt if after is faster for find_extrema at 2M and 10M"]
    suffix = "" if list(names) == ["2M", "10M"] else "_" + "_".join(names)
    print(write_results(f"extrema_marks_ab{suffix}", rows, cols,
                        title="The extrema's marks: a test per node before, stores without tests after", notes=notes))


if __name__ == "__main__":
    main(sys.argv[1:] or ["2M", "10M"])
