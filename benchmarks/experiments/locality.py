"""Does the numbering of nodes and cells matter to the edge-centred construction and its preparation?

The 2M volume (field ``fem``) as loaded -- the data sets' cache stores
every volume with nodes and cells renumbered along a Morton curve
(``UnstructuredVolume.reordered``, see ``datasets.registry._spatial_order``)
-- against the same volume renumbered otherwise, built as a new
``UnstructuredVolume`` from permuted arrays (same geometry and field, same
surfaces):

* ``first-use nodes``: cells as loaded, nodes in the order the cells first use them;
* ``hilbert``: cells along a Hilbert curve of their centroids (18 bits per axis),
  nodes in order of first use by those cells;
* ``random cells`` / ``random nodes`` / ``random``: a random permutation of the
  cells, the nodes, both (what a mesher's numbering can look like; gmsh's
  parallel HXT numbers cells far from spatially).

For each: the ``edge-centred-table`` preparation (wall seconds, one after
the other), then -- every variant prepared and kept -- twenty values
``linspace(min, max, 22)[1:-1]``, each extracted ``REPEATS`` times by each
variant's builder on one thread, the variants interleaved value by value
(mean normals, seed search done beforehand); per value the median, then the
sum / max / median over the values; ``t2`` (the construction alone) per
cell visited by for-loop (3), per cell taken from the queue, and the wall
time per triangle. Interleaving matters: on this shared 2-core machine the
same volume's 20-value ``t2`` sum measured 135-290 ms in separate
processes as the other jobs' load changed, so only the ratios between the
rows of one run mean much. The 1-minute load average at the end is
recorded.

    python benchmarks/experiments/locality.py          # 2M
    python benchmarks/experiments/locality.py data4
"""

import os
import sys
import time

import numpy as np

import _experiment  # noqa: F401  (benchmarks/_common.py, results under experiments/results/)
from _common import write_results
from polygen.volume import UnstructuredVolume, datasets, isovalues, methods

REPEATS = 5
ORDERS = ["as loaded (Morton)", "first-use nodes", "hilbert", "random cells", "random nodes", "random"]
COLUMNS = ["data", "order", "prep_s", "sum_ms", "max_ms", "median_ms", "t2_sum_ms", "t2_max_ms", "ns per visit (t2)",
           "ns per pop (t2)", "ns per triangle (wall)", "/ as loaded (sum)", "triangles (sum)", "load"]


def hilbert_keys(q, bits):
    """Skilling's transpose of 3-D Hilbert indices, vectorised: ``q`` (n, 3) uint64 in [0, 2**bits) -> (n,) keys."""
    x = q.astype(np.uint64).copy()
    one = np.uint64(1)
    m = one << np.uint64(bits - 1)
    b = m
    while b > one:  # inverse undo
        p = b - one
        for i in range(3):
            hi = (x[:, i] & b) != 0
            x[hi, 0] ^= p
            lo = ~hi
            t = (x[lo, 0] ^ x[lo, i]) & p
            x[lo, 0] ^= t
            x[lo, i] ^= t
        b >>= one
    for i in range(1, 3):  # Gray encode
        x[:, i] ^= x[:, i - 1]
    t = np.zeros(x.shape[0], np.uint64)
    b = m
    while b > one:
        t[(x[:, 2] & b) != 0] ^= b - one
        b >>= one
    x ^= t[:, None]
    key = np.zeros(x.shape[0], np.uint64)
    for k in range(bits - 1, -1, -1):
        for i in range(3):
            key = (key << one) | ((x[:, i] >> np.uint64(k)) & one)
    return key


def first_use(cells):
    """Node ids in the order the cells (row by row) first use them."""
    u, first = np.unique(cells.ravel(), return_index=True)
    return u[np.argsort(first, kind="stable")]


def renumbered(vol, node_order, cell_order):
    """``vol`` with new node i = old ``node_order[i]`` and new cell j = old ``cell_order[j]``."""
    new_id = np.empty(vol.n_points, np.int64)
    new_id[node_order] = np.arange(vol.n_points)
    return UnstructuredVolume(vol.points[node_order], new_id[vol.cells[cell_order]],
                              {k: v[node_order] for k, v in vol.fields.items()}, validate=False)


def ordered(vol, order, rng):
    if order == "as loaded (Morton)":
        return vol
    if order == "first-use nodes":
        return renumbered(vol, first_use(vol.cells), np.arange(vol.n_cells))
    if order == "hilbert":
        lo = vol.points.min(axis=0)
        span = float((vol.points.max(axis=0) - lo).max())
        q = np.clip((vol.points[vol.cells].mean(axis=1) - lo) / span * (2**18 - 1), 0, 2**18 - 1)
        cells = np.argsort(hilbert_keys(q, 18), kind="stable")
        return renumbered(vol, first_use(vol.cells[cells]), cells)
    if order == "random cells":
        return renumbered(vol, np.arange(vol.n_points), rng.permutation(vol.n_cells))
    if order == "random nodes":
        return renumbered(vol, rng.permutation(vol.n_points), np.arange(vol.n_cells))
    return renumbered(vol, rng.permutation(vol.n_points), rng.permutation(vol.n_cells))


def run(name):
    base = datasets.load(name)
    rng = np.random.default_rng(0)
    built = []
    for order in ORDERS:  # every variant prepared first, then timed interleaved (the machine's load drifts)
        vol = ordered(base, order, rng)
        t0 = time.perf_counter()
        m = methods.get("edge-centred-table")(vol, field="fem")
        prep = time.perf_counter() - t0
        values = isovalues(vol.scalars("fem"), 20)
        seeds = [m.source.query(v).cells for v in values]
        for v, sd in zip(values, seeds):  # warm
            m.builder.extract(v, sd, threads=1)
        built.append((order, prep, m.builder, values, seeds))
    k = len(built)
    wall = np.zeros((k, REPEATS, 20))
    t2 = np.zeros((k, REPEATS, 20))
    visits, pops, tris = np.zeros(k), np.zeros(k), np.zeros(k, np.int64)
    for r in range(REPEATS):
        for i in range(20):
            for j in np.roll(np.arange(k), r + i):
                _, _, b, values, seeds = built[j]
                t0 = time.perf_counter()
                iso = b.extract(values[i], seeds[i], threads=1)
                wall[j, r, i] = time.perf_counter() - t0
                t2[j, r, i] = iso.t2
                if r == 0:
                    visits[j] += b.stats["visits"]
                    pops[j] += b.stats["pops"]
                    tris[j] += iso.n_triangles
    load = round(os.getloadavg()[0], 2)
    rows = []
    for j, (order, prep, _, _, _) in enumerate(built):
        w, w2 = np.median(wall[j], axis=0), np.median(t2[j], axis=0)
        rows.append({"data": name, "order": order, "prep_s": prep, "sum_ms": float(w.sum() * 1e3),
                     "max_ms": float(w.max() * 1e3), "median_ms": float(np.median(w) * 1e3),
                     "t2_sum_ms": float(w2.sum() * 1e3), "t2_max_ms": float(w2.max() * 1e3),
                     "ns per visit (t2)": float(w2.sum() / visits[j] * 1e9),
                     "ns per pop (t2)": float(w2.sum() / pops[j] * 1e9),
                     "ns per triangle (wall)": float(w.sum() / tris[j] * 1e9), "triangles (sum)": int(tris[j]),
                     "load": load})
        rows[-1]["/ as loaded (sum)"] = rows[-1]["sum_ms"] / rows[0]["sum_ms"]
        print(rows[-1], flush=True)
    return rows


def main(names):
    rows = []
    for name in names:
        rows += run(name)
    notes = [f"{REPEATS} repeats per value, one thread, the variants interleaved value by value; per value the median, "
             "then sum / max / median over the 20 values; wall = the builder's extract (construction, positions, mean "
             "normals) after the seed search; t2 = the construction alone",
             "prep_s: the edge-centred-table preparation (topology, thinning, edge records), wall, one run",
             "load: 1-minute load average at the end of the timed loop (2 cores shared with other jobs)"]
    return write_results("locality", rows, COLUMNS,
                         title="Node and cell numbering against construction speed", notes=notes)


if __name__ == "__main__":
    print(main(sys.argv[1:] or ["2M"]))
