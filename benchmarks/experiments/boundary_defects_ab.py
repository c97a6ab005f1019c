"""The boundary check (:func:`polygen.volume.homology.boundary_defects`) before and after its kernel.

``sort``: the implementation before, copied here (a lexsort of every
boundary-face edge, ``np.unique`` of corner keys, a numba union-find over
the corners). ``kernel``: the package's, one pass over the boundary edge
table. The table is built for the boundary groups, which the thinning
computes first (``_beside_fifo``), so ``kernel`` is timed with it built --
the state ``T_check`` sees; ``kernel, cold`` drops it before each call and
so pays for building it too (a caller outside the preparation).

One process, data sets 2M and 10M loaded (field ``fem``; 10M without a
field), JIT warm; ``ROUNDS`` rounds, each running every arm once on every
data set (interleaved); the best of the rounds per arm. Both arms must
return equal arrays. ``/proc/loadavg`` before and after.

Criterion, fixed before measuring: the kernel is adopted if ``kernel`` is
faster than ``sort`` at both 2M and 10M and all tests pass.

    python benchmarks/experiments/boundary_defects_ab.py            # 2M 10M
    python benchmarks/experiments/boundary_defects_ab.py data4
"""

import sys
import time

import numpy as np

from polygen._jit import njit
from polygen.volume import datasets
from polygen.volume.homology import boundary_defects

import _experiment  # noqa: F401  (benchmarks/_common.py, results under experiments/results/)
from _common import write_results

ROUNDS = 5


@njit
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit
def _corner_fans(n_corners, edge_corners):
    parent = np.arange(n_corners)
    for e in range(edge_corners.shape[0]):
        for j in range(2):
            a = _find(parent, edge_corners[e, 2 * j])
            b = _find(parent, edge_corners[e, 2 * j + 1])
            if a != b:
                parent[max(a, b)] = min(a, b)
    for i in range(n_corners):
        parent[i] = _find(parent, i)
    return parent


def defects_by_sort(vol):
    """``boundary_defects`` as it was before the kernel (polygen at efe8dcf)."""
    fn = np.ascontiguousarray(vol.boundary_face_nodes, np.int64)
    nbf, k = fn.shape
    corner = np.arange(nbf * k, dtype=np.int64).reshape(nbf, k)
    a = fn.ravel()
    b = np.roll(fn, -1, axis=1).ravel()
    ca = corner.ravel()
    cb = np.roll(corner, -1, axis=1).ravel()
    swap = a > b
    lo, hi = np.where(swap, b, a), np.where(swap, a, b)
    clo, chi = np.where(swap, cb, ca), np.where(swap, ca, cb)
    order = np.lexsort((hi, lo))
    lo, hi, clo, chi = lo[order], hi[order], clo[order], chi[order]
    start = np.flatnonzero(np.r_[True, (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])])
    count = np.diff(np.r_[start, lo.size])
    bad_edges = np.stack([lo[start[count != 2]], hi[start[count != 2]]], axis=1)
    two = start[count == 2]
    pairs = np.ascontiguousarray(np.stack([clo[two], clo[two + 1], chi[two], chi[two + 1]], axis=1))
    root = _corner_fans(nbf * k, pairs)
    key = np.unique(a * (nbf * k) + root)
    node_of = key // (nbf * k)
    fans = np.bincount(node_of, minlength=vol.n_points)
    return bad_edges.astype(np.int64), np.flatnonzero(fans > 1).astype(np.int64)


def kernel_cold(vol):
    vol.__dict__.pop("boundary_edge_table", None)
    return boundary_defects(vol)


ARMS = {"sort": defects_by_sort, "kernel": boundary_defects, "kernel, cold": kernel_cold}


def loadavg():
    return open("/proc/loadavg").read().split()[:3]


def main(names):
    vols = {}
    for name in names:
        vol = datasets.load(name, field=None if name == "10M" else "fem")
        vol.boundary_groups  # the state the thinning calls the check in: the boundary edge table built
        vols[name] = vol
        for fn in ARMS.values():  # JIT warm, and the arms agree
            e, n = fn(vol)
        ref = defects_by_sort(vol)
        for arm, fn in ARMS.items():
            got = fn(vol)
            assert all(np.array_equal(g, r) and g.dtype == r.dtype for g, r in zip(got, ref)), (name, arm)
    load_before = loadavg()
    times = {(name, arm): [] for name in names for arm in ARMS}
    for _ in range(ROUNDS):
        for name in names:
            for arm, fn in ARMS.items():
                t0 = time.perf_counter()
                fn(vols[name])
                times[name, arm].append(time.perf_counter() - t0)
    load_after = loadavg()
    rows = []
    for name in names:
        vol = vols[name]
        row = {"data": name, "cells": vol.n_cells, "boundary faces": int(vol.boundary_face_nodes.shape[0])}
        for arm in ARMS:
            row[f"{arm} s"] = min(times[name, arm])
            row[f"{arm} rounds"] = " ".join(f"{t:.3f}" for t in times[name, arm])
        row["sort / kernel"] = row["sort s"] / row["kernel s"]
        row["kernel faster"] = bool(row["kernel s"] < row["sort s"])
        rows.append(row)
        print(row, flush=True)
    cols = ["data", "cells", "boundary faces", "sort s", "kernel s", "kernel, cold s", "sort / kernel",
            "kernel faster", "sort rounds", "kernel rounds", "kernel, cold rounds"]
    notes = [f"best of {ROUNDS} interleaved rounds, one process", f"loadavg before {load_before}, after {load_after}",
             "criterion (fixed before measuring): adopt the kernel if it is faster than sort at 2M and 10M"]
    suffix = "" if list(names) == ["2M", "10M"] else "_" + "_".join(names)
    print(write_results(f"boundary_defects_ab{suffix}", rows, cols,
                        title="boundary_defects: the lexsort before, the kernel over the boundary edge table",
                        notes=notes))


if __name__ == "__main__":
    main(sys.argv[1:] or ["2M", "10M"])
