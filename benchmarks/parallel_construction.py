"""One isosurface by one thread or two: the edge-centred construction, serial against parallel.

For data 4 and the 2M volume (field ``fem``), twenty isovalues
``linspace(min, max, 22)[1:-1]``, the ``edge-centred-table`` method
prepared once (thinning seeds); each value is extracted by the builder with
``threads=1`` (the serial construction) and ``threads=2`` (the parallel one:
each thread runs the serial construction on its own stack, cells and
contested vertices claimed by compare-and-swap, see ``EdgeCentredTable``), and
``threads=2`` with numba limited to one thread ("2 on 1 core": the parallel
algorithm's total work, one thread after the other), ``threads=1`` by the
generic serial kernel with stage 3 in separate passes ("1 generic": the
serial path before the specialised tetrahedron kernel, which builds the
same arrays), ``threads=2`` by the generic parallel kernel with stage 3 in
separate parallel passes ("2 generic": the parallel path before the
specialised parallel flood ``construct_tet_parallel``), and the default
``threads="auto"`` ("auto": two threads when the surface is estimated to
cross at least ``PARALLEL_MIN_CELLS`` cells and no other program's task is
runnable, see ``EdgeCentredTable``), interleaved,
``REPEATS`` times, mean normals on, the seed search done beforehand (it is
the same for both). Per value: the median wall time of ``extract`` (the
construction ``t2`` and positions/normals ``t3`` included) and of ``t2``
alone; per data set the median and the max over the values, and the sum.
Every parallel surface is checked to be the serial one (``same_surface``).
The load average of the machine is recorded before and after: this is a
shared 2-core machine, and the parallel path can only be faster when the
second core is free.

    python benchmarks/parallel_construction.py            # data4, 2M
    python benchmarks/parallel_construction.py data4      # a subset
"""

import os
import sys
import time

import numba
import numpy as np

from _common import write_results
from polygen.volume import datasets, isovalues, methods
from polygen.volume.edge_centred import EdgeCentredTable
from polygen.volume.surface import same_surface

DATA = ["data4", "2M"]
REPEATS = 5
COLUMNS = ["data", "cells", "threads", "median_ms", "max_ms", "sum_ms", "t2_median_ms", "t2_max_ms",
           "cpu_sum_ms", "triangles (sum)", "vertices (sum)", "contested (sum)", "auto: parallel queries",
           "largest: cells per thread",
           "same as serial", "load before", "load after"]


def run(name):
    vol = datasets.load(name)
    s = vol.scalars("fem")
    m = methods.get("edge-centred-table")(vol, field="fem")
    b = m.builder
    values = isovalues(s, 20)
    seeds = [m.source.query(v).cells for v in values]
    for v, sd in zip(values, seeds):  # compile and warm the caches; check the surfaces
        ref = b.extract(v, sd, threads=1)
        assert same_surface(ref, b.extract(v, sd, threads=2)), (name, v)
        assert same_surface(ref, b.extract(v, sd, threads="auto")), (name, v)
        EdgeCentredTable.SPECIALISED_KERNEL = False
        assert same_surface(ref, b.extract(v, sd, threads=2)), (name, v)
        gen = b.extract(v, sd, threads=1)
        EdgeCentredTable.SPECIALISED_KERNEL = True
        for a in ("triangles", "vertices", "normals", "vertex_keys", "triangle_cells"):  # the same arrays
            assert np.array_equal(getattr(ref, a), getattr(gen, a)), (name, v, a)
    load0 = os.getloadavg()[0]
    # "2 on 1 core": the two threads' work run one after the other on one core (numba.set_num_threads(1)):
    # the parallel algorithm's total work, free of waiting for a busy second core
    kinds = [1, 2, "2 on 1 core", "1 generic", "2 generic", "2 generic on 1 core", "auto"]
    balance = []  # the largest surface's cells per thread, threads=2
    went_parallel = 0  # "auto" queries that ran on more than one thread
    wall = {k: np.zeros((REPEATS, len(values))) for k in kinds}
    t2 = {k: np.zeros((REPEATS, len(values))) for k in kinds}
    cpu = {k: np.zeros((REPEATS, len(values))) for k in kinds}
    tris = {k: 0 for k in kinds}
    verts = {k: 0 for k in kinds}
    contested = 0
    n_thr = numba.get_num_threads()
    max_tris = max(b.extract(v, sd).n_triangles for v, sd in zip(values, seeds))
    for r in range(REPEATS):
        for i, (v, sd) in enumerate(zip(values, seeds)):
            for kind in kinds[r % len(kinds):] + kinds[:r % len(kinds)]:
                th = 2 if str(kind).startswith("2") else "auto" if kind == "auto" else 1
                numba.set_num_threads(1 if str(kind).endswith("on 1 core") else n_thr)
                EdgeCentredTable.SPECIALISED_KERNEL = "generic" not in str(kind)
                c0 = time.thread_time()
                t0 = time.perf_counter()
                iso = b.extract(v, sd, threads=th)
                wall[kind][r, i] = time.perf_counter() - t0
                cpu[kind][r, i] = time.thread_time() - c0
                t2[kind][r, i] = iso.t2
                if kind == "auto":
                    went_parallel += b.stats["threads"] > 1
                if r == 0:
                    tris[kind] += iso.n_triangles
                    verts[kind] += iso.n_vertices
                    if kind == 2:
                        contested += b.stats["contested"]
                        if iso.n_triangles == max_tris:
                            balance.append(b.stats["per_thread"])
    EdgeCentredTable.SPECIALISED_KERNEL = True
    numba.set_num_threads(n_thr)
    load1 = os.getloadavg()[0]
    rows = []
    for th in kinds:
        per_value = np.median(wall[th], axis=0) * 1e3
        per_value_t2 = np.median(t2[th], axis=0) * 1e3
        rows.append({"data": name, "cells": vol.n_cells, "threads": th, "median_ms": float(np.median(per_value)),
                     "max_ms": float(per_value.max()), "sum_ms": float(per_value.sum()),
                     "t2_median_ms": float(np.median(per_value_t2)), "t2_max_ms": float(per_value_t2.max()),
                     "cpu_sum_ms": float(np.median(cpu[th], axis=0).sum() * 1e3),
                     "triangles (sum)": tris[th], "vertices (sum)": verts[th],
                     "contested (sum)": contested if str(th).startswith("2") and "generic" not in str(th) else 0,
                     "auto: parallel queries": f"{went_parallel}/{REPEATS * len(values)}" if th == "auto" else "",
                     "largest: cells per thread": str(balance[0]) if th == 2 and balance else "",
                     "same as serial": True, "load before": round(load0, 2), "load after": round(load1, 2)})
    return rows


def main(names):
    rows = []
    for name in names:
        new = run(name)
        rows += new
        print(*new, sep="\n", flush=True)
    notes = [f"{REPEATS} interleaved repeats per value; per value the median, then the median / max / sum over "
             "the 20 values; wall = the builder's extract (construction, positions, mean normals) after the seed "
             "search; t2 = the construction alone",
             "threads = 1: the serial construction (tetrahedra: the specialised kernel construct_tet, positions and "
             "normal sums written as it goes, so its t2 includes them); '1 generic': the generic kernel with "
             "stage 3 in separate passes, "
             "the serial path before (the same arrays, checked)",
             "threads = 2: EdgeCentredTable(..., threads=2), on tetrahedra the specialised parallel flood "
             "construct_tet_parallel (positions and normal sums written by the threads as they go); '2 generic': the "
             "generic parallel kernel with positions and normals in separate parallel passes, the 2-thread path "
             "before; 'auto': the default threads='auto' (2 threads for surfaces estimated at >= PARALLEL_MIN_CELLS "
             "crossed cells when no other program's task is runnable, else 1; 'auto: parallel queries' counts the "
             "2-thread ones); contested: vertices whose id was decided by compare-and-swap (edges between the two "
             "threads' regions), 2-thread run; largest: cells taken by each thread on the largest surface (first "
             "repeat)",
             "cpu_sum_ms: CPU time of the calling thread per extract (time.thread_time), median per value, summed: "
             "all the work for 1 thread and for '2 on 1 core' (the parallel algorithm's total work, free of the "
             "machine's load), the main thread's share for 2 threads",
             "before the compare-and-swap construction (the three-pass path: propagate with claims, number, "
             "write), 2M on a quiet machine: threads=1 median 1.73 / max 39.8 / sum 191.6 ms, threads=2 2.13 / 46.6 / "
             "221.9, 2 on 1 core 3.00 / 80.3 / 377.5 (twice the serial work)",
             "before the specialised parallel flood (threads=2 by the generic kernel, positions and normals in "
             "separate parallel passes), 2M, quiet rerun (load 1.0-1.08): threads=1 median 1.642 / max 32.81 / sum "
             "160.1 ms, threads=2 1.501 / 22.1 / 113.8, 2 on 1 core 1.934 / 41.26 / 199.8",
             f"load: 1-minute load average of the machine ({os.cpu_count()} cores) before / after the timed loop"]
    return write_results("parallel_construction", rows, COLUMNS,
                         title="One isosurface, one thread or two (edge-centred construction)", notes=notes)


if __name__ == "__main__":
    print(main(sys.argv[1:] or DATA))
