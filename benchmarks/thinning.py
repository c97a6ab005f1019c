"""Tables 7.1-7.5 measured, and the O(n) preprocessing of volume thinning (thesis chapter 7).

Part 1, data 1-5 (one run each, as the thesis did): cells registered by the
extrema graph (N_e1 = arc cells + boundary cells) and by thinning (N_e2,
the skeleton), preprocessing of sorted lists, span filtering, the extrema
graph and thinning (Table 7.1), the skeleton's cells by class (Table 7.2),
twenty isosurfaces ``linspace(min, max, 22)[1:-1]`` of the FEM field with
every method (Table 7.3: triangles, vertices, total time), the time to
find the intersected cells (Table 7.4: t1, search + testing the
candidates) and the cells tested (Table 7.5, counted as the thesis did:
cells tested by the search plus cells intersected; for sorted lists and
span filtering every intersected cell is among the candidates, so theirs
is the candidates alone). Every isosurface is checked against the full
scan's (same triangles).

Part 2, O(n): thinning's preprocessing per cell on one family of volumes
from 20k to 10M cells -- a 4:2:1 block with two square through-holes and
a box void, 6 Kuhn tetrahedra per grid cube, the same analytic field
(seeded Gaussian bumps over the bounding box, plus a small slope) at every
size -- and on the FEM data sets. ``T_total`` is thinning's
preprocessing (extrema and marks, classes and n_B, removal, value
classes); the volume's topology tables (face neighbours, boundary groups,
node cells), built once per volume by :class:`UnstructuredVolume`, are
timed apart (``T_topology``). Best of five runs (three above 3M cells). Both parts time the
thesis's serial FIFO (``thin_volume(parallel=False)``); from 200,000 cells Part 2 also times the
two halves at once (the default there, :func:`polygen.volume.thinning.thin_volume`), in the JSON
(``*_halves``) and the printed lines.

Topology tables and numba compilation are excluded from every timing
unless named. Wall-clock seconds on a shared 2-core machine.

    python benchmarks/thinning.py            # data 1-5 (+2M, hexa1-3 for the scaling plot), 20k .. 10M
    python benchmarks/thinning.py --quick    # data 1-2, 20k .. 600k
"""

import argparse
import json
import os
import time

import numpy as np

from _common import RESULTS, machine, fmt, thesis_table
from polygen.volume import UnstructuredVolume, datasets, isovalues, methods
from polygen.volume.thinning import PARALLEL_MIN_CELLS, thin_volume

METHODS = ["scan", "sorted-lists", "span-filter", "extrema-graph", "thinning"]
SHORT = {"scan": "all", "sorted-lists": "sort", "span-filter": "filt", "extrema-graph": "egra", "thinning": "thin"}

THESIS = {  # Tables 7.1-7.5, data 1-5 (IBM RS/6000 model 560)
    "N_e": [20736, 61680, 346644, 557868, 458664],
    "N_n": [4002, 11624, 62107, 97473, 80468],
    "N_ep": [21, 46, 135, 540, 5986],
    "N_e1": [2516, 6480, 20158, 28086, 121492],
    "N_e2": [436, 1365, 3757, 10967, 55536],
    "T_sort": [1.15, 4.12, 47.95, 52.29, 63.60],
    "T_filt": [0.19, 0.52, 2.75, 4.76, 3.66],
    "T_egra": [0.58, 1.53, 7.46, 14.51, 76.78],
    "T_thin": [1.13, 3.22, 16.93, 26.86, 23.22],
    "C1": [21, 45, 124, 491, 3208],
    "C2": [397, 1259, 3453, 9552, 20574],
    "C3": [17, 61, 178, 875, 15312],
    "C4": [1, 0, 2, 49, 16436],
    "N_t": [67875, 80995, 135358, 1164616, 494480],
    "N_v": [34921, 43158, 71358, 588796, 251506],
    "Q_sort": [5.69, 6.85, 15.24, 100.92, 53.48],
    "Q_filt": [5.78, 8.36, 25.51, 107.89, 59.31],
    "Q_egra": [3.31, 4.18, 7.56, 57.72, 26.49],
    "Q_thin": [3.27, 3.96, 7.22, 57.12, 25.21],
    "t1_sort": [2.24, 2.86, 8.65, 42.65, 26.86],
    "t1_filt": [3.13, 5.95, 22.59, 65.08, 40.20],
    "t1_egra": [0.71, 0.98, 2.07, 12.14, 6.35],
    "t1_thin": [0.65, 0.74, 1.76, 11.58, 5.27],
    "N_sort": [51348, 61766, 101951, 879735, 378712],
    "N_filt": [89548, 179088, 786220, 1927026, 1278742],
    "N_egra": [54420, 66618, 115639, 907319, 550605],
    "N_thin": [51762, 63089, 105762, 890134, 436658],
}


def triangle_set(iso):
    t = np.sort(iso.vertex_keys[iso.triangles], axis=1)
    return t[np.lexsort(t.T[::-1])]


def topology(vol):
    t0 = time.perf_counter()
    for attr in ("face_neighbors", "node_cells", "boundary_cells", "boundary_groups", "cell_components",
                 "cell_edges", "edge_cells", "cell_records"):
        getattr(vol, attr)
    return time.perf_counter() - t0


def warm():
    """Compile every kernel on tiny volumes, so that no timing below includes numba."""
    for name in ("hollow_cube", "hollow_cube_hex"):
        vol = datasets.load(name)
        for mname in METHODS:
            m = methods.get(mname)(vol)
            m.extract(float(np.median(vol.scalars())))


# ------------------------------------------------------------------ part 1: Tables 7.1-7.5
def run_data(name):
    vol = datasets.load(name)
    row = {"data": name, "N_e": vol.n_cells, "N_n": vol.n_points, "boundary_cells": int(vol.boundary_cells.size),
           "T_topology": topology(vol)}
    s = vol.scalars()
    values = isovalues(s, 20)
    ref = {}
    for mname in METHODS:
        # the thesis's thinning: one FIFO, lowest class first (not the two halves at once of large volumes)
        m = methods.get(mname)(vol, **({"parallel": False} if mname == "thinning" else {}))
        short = SHORT[mname]
        row[f"T_{short}"] = m.preprocess_s
        q = t1 = 0.0
        seed_tested = n_ci = all_tested = 0
        same = True
        for v in values:
            t0 = time.perf_counter()
            iso = m.extract(v)
            q += time.perf_counter() - t0
            t1 += iso.t1
            seed_tested += m.seed_cells_tested
            n_ci += iso.cells_intersected
            all_tested += iso.cells_tested
            key = triangle_set(iso)
            if mname == "scan":
                ref[v] = key
                row["N_t"] = row.get("N_t", 0) + iso.triangles.shape[0]
                row["N_v"] = row.get("N_v", 0) + iso.vertices.shape[0]
            else:
                same &= key.shape == ref[v].shape and bool(np.array_equal(key, ref[v]))
        row[f"Q_{short}"] = q
        row[f"t1_{short}"] = t1
        # Table 7.5's count: search tests, plus the intersected cells that propagation registers
        row[f"N_{short}"] = seed_tested + (n_ci if mname in ("extrema-graph", "thinning") else 0)
        row[f"tested_{short}"] = all_tested  # ours: every cell tested, failed neighbour tests included
        row[f"same_{short}"] = same
        if mname == "extrema-graph":
            st = m.graph.stats
            row["N_ep"] = st["extrema"]
            row["N_e1"] = st["graph_cells"] + st["boundary_cells"]
        if mname == "thinning":
            st = m.skeleton.stats
            row["N_e2"] = st["skeleton_cells"]
            for k in ("C1", "C2", "C3", "C4", "C5", "C6", "pricks", "T_pe", "T_thin", "T_register", "walks",
                      "walks_reached", "marked"):
                row[k if k not in ("T_thin",) else "T_thin_removal"] = st[k]
    row["N_ci"] = n_ci
    return row


# ------------------------------------------------------------------ part 2: O(n)
_KUHN = np.array([[0, 1, 2, 6], [0, 1, 5, 6], [0, 4, 5, 6], [0, 4, 7, 6], [0, 3, 7, 6], [0, 3, 2, 6]])
_CORNERS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])


def block_with_holes(s):
    """A (4s, 2s, s) block of unit cubes with two square through-holes and a box void, as tetrahedra."""
    nx, ny, nz = 4 * s, 2 * s, s
    keep = np.ones((nx, ny, nz), bool)
    w = max(1, s // 3)
    for cx in (nx // 4, 3 * nx // 4):  # through-holes along z
        keep[cx - w // 2:cx - w // 2 + w, ny // 2 - w // 2:ny // 2 - w // 2 + w, :] = False
    keep[nx // 2 - w // 2:nx // 2 - w // 2 + w, ny // 2 - w // 2:ny // 2 - w // 2 + w, max(1, nz // 3):nz - max(1, nz // 3)] = False
    ijk = np.argwhere(keep).astype(np.int64)
    del keep
    stride_y, stride_x = nz + 1, (ny + 1) * (nz + 1)
    base = ijk[:, 0] * stride_x + ijk[:, 1] * stride_y + ijk[:, 2]
    del ijk
    off = _CORNERS[:, 0] * stride_x + _CORNERS[:, 1] * stride_y + _CORNERS[:, 2]
    cells = (base[:, None] + off[_KUHN].reshape(1, -1)).reshape(-1, 4)
    del base
    g = np.stack(np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij"), -1)
    points = g.reshape(-1, 3).astype(np.float64) / s
    used = np.zeros(points.shape[0], bool)
    used[cells.ravel()] = True
    new = np.cumsum(used) - 1
    cells = new[cells]
    points = points[used]
    p = points
    field = datasets.gaussian_field(p, n_bumps=60, seed=0, width=0.3) + 0.01 * p[:, 0]
    # Kuhn tetrahedra of a translated cube keep their orientation: fix the sign once
    p0 = points[cells[:6]]
    vol6 = np.einsum("ij,ij->i", np.cross(p0[:, 1] - p0[:, 0], p0[:, 2] - p0[:, 0]), p0[:, 3] - p0[:, 0])
    neg = np.tile(vol6 < 0, cells.shape[0] // 6)
    cells[neg, 1], cells[neg, 2] = cells[neg, 2], cells[neg, 1].copy()
    # numbered along a Morton curve, as every cached data set is (datasets.registry._spatial_order)
    return UnstructuredVolume(points, cells, {"gaussians": field}, validate=False).reordered()


def time_thinning(vol, repeat):
    """Best of ``repeat`` runs of the thesis's serial FIFO; from ``PARALLEL_MIN_CELLS`` cells also of the
    two halves at once (``thin_volume(parallel=True)``: ``*_halves``, with the CPU seconds of the process)."""
    t_top = topology(vol)

    def best_of(parallel):
        best = None
        for _ in range(repeat):
            c0 = time.process_time()
            sk = thin_volume(vol, parallel=parallel)
            cpu = time.process_time() - c0
            if best is None or sk.stats["T_total"] < best[0].stats["T_total"]:
                best = sk, cpu
        return best

    best, cpu = best_of(False)
    st = best.stats
    n = vol.n_cells
    row = {"cells": n, "T_topology": t_top, "T_total": st["T_total"], "T_pe": st["T_pe"], "T_thin": st["T_thin"],
           "T_register": st["T_register"], "ns_per_cell": 1e9 * st["T_total"] / n,
           "ns_per_cell_with_topology": 1e9 * (st["T_total"] + t_top) / n, "skeleton_cells": st["skeleton_cells"],
           "extrema": st["extrema"], "pricks": st["pricks"], "genus": vol.n_through_holes, "voids": vol.n_voids,
           "cpu_total": cpu}
    if n >= PARALLEL_MIN_CELLS:
        halves, cpu = best_of(True)
        hs = halves.stats
        row.update({"T_total_halves": hs["T_total"], "T_thin_halves": hs["T_thin"], "T_halves": hs["T_halves"],
                    "cpu_total_halves": cpu, "skeleton_cells_halves": hs["skeleton_cells"],
                    "band_cells": hs["band_cells"], "removed_in_halves": hs["removed_in_halves"]})
    return row


def scaling(sizes, data_names):
    rows = []
    for s in sizes:
        vol = block_with_holes(s)
        r = time_thinning(vol, 3 if vol.n_cells > 3_000_000 else 5)
        r.update(volume=f"block s={s}", family="block")
        rows.append(r)
        print(f"block s={s}: {r['cells']} cells, {r['T_total']:.3f} s, {r['ns_per_cell']:.0f} ns/cell "
              f"(topology {r['T_topology']:.2f} s)", flush=True)
        del vol
    for name in data_names:
        vol = datasets.load(name)
        r = time_thinning(vol, 3 if vol.n_cells > 3_000_000 else 5)
        r.update(volume=name, family="FEM data")
        rows.append(r)
        print(f"{name}: {r['cells']} cells, {r['T_total']:.3f} s, {r['ns_per_cell']:.0f} ns/cell"
              + (f"; two halves at once {r['T_total_halves']:.3f} s (T_thin {r['T_thin']:.3f} -> "
                 f"{r['T_thin_halves']:.3f}), skeleton {r['skeleton_cells']} -> {r['skeleton_cells_halves']}"
                 if "T_total_halves" in r else ""), flush=True)
        del vol
    return rows


def plot_scaling(rows, path):
    from polygen.plotting.thinning import plot_time_per_cell

    fig = plot_time_per_cell(rows)
    fig.savefig(path, dpi=110, bbox_inches="tight")


# ------------------------------------------------------------------ report
def table(title, rows, keys, thesis=True):
    return thesis_table(title, rows, keys, THESIS if thesis else None)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-tables", action="store_true", help="only the O(n) part")
    args = ap.parse_args()
    load = os.getloadavg()
    warm()
    rows = []
    if not args.no_tables:
        for n in (["data1", "data2"] if args.quick else ["data1", "data2", "data3", "data4", "data5"]):
            t0 = time.perf_counter()
            rows.append(run_data(n))
            print(f"{n}: {time.perf_counter() - t0:.1f} s", flush=True)
    sizes = [8, 11, 17, 24] if args.quick else [8, 11, 17, 24, 36, 50, 62]
    data_names = ["data1", "data2"] if args.quick else ["data1", "data2", "data3", "data5", "data4", "2M",
                                                         "hexa1", "hexa2", "hexa3"]
    srows = scaling(sizes, data_names)
    load_end = os.getloadavg()
    block = [r for r in srows if r["family"] == "block"]
    per = np.array([r["ns_per_cell"] for r in block])
    spread = (float(per.min() / np.median(per) - 1), float(per.max() / np.median(per) - 1))
    worst = max(r["T_total"] / r["cells"] * 1e6 for r in srows)

    RESULTS.mkdir(parents=True, exist_ok=True)
    png = RESULTS / "thinning_scaling.png"
    plot_scaling(srows, png)
    out = {"machine": machine(), "load_start": load, "load_end": load_end, "thesis": THESIS, "rows": rows,
           "scaling": srows, "block_ns_per_cell_spread_vs_median": spread, "worst_s_per_1M_cells": worst}
    name = "thinning_quick" if args.quick else "thinning"
    (RESULTS / f"{name}.json").write_text(json.dumps(out, indent=2, default=float) + "\n")

    md = ["# Volume thinning (thesis chapter 7): Tables 7.1-7.5 on our data 1-5, and O(n) preprocessing", "",
          "One run each (tables), wall-clock seconds on a shared 2-core machine; load average "
          f"{load[0]:.2f} at the start, {load_end[0]:.2f} at the end. Thesis values (IBM RS/6000 560) in "
          "parentheses. Twenty isovalues `linspace(min, max, 22)[1:-1]` of the FEM field. Topology tables and "
          "numba compilation are excluded from every timing.", ""]
    if rows:
        md += table("Table 7.1 - registered cells and preprocessing (s)", rows,
                    ["N_e", "N_n", "N_ep", "N_e1", "N_e2", "T_sort", "T_filt", "T_egra", "T_thin", "T_topology"])
        md += table("Table 7.2 - skeleton cells by class (non-removed face neighbours)", rows,
                    ["C1", "C2", "C3", "C4", "marked", "pricks"])
        md += table("Thinning's preprocessing broken down (s)", rows, ["T_pe", "T_thin_removal", "T_register"])
        md += table("Table 7.3 - twenty isosurfaces (s)", rows,
                    ["N_t", "N_v", "Q_all", "Q_sort", "Q_filt", "Q_egra", "Q_thin"])
        md += table("Table 7.4 - finding the intersected cells, t1 (s)", rows,
                    ["t1_all", "t1_sort", "t1_filt", "t1_egra", "t1_thin"])
        md += table("Table 7.5 - cells tested (the thesis's count) and, ours, every cell tested incl. failed "
                    "neighbour tests", rows,
                    ["N_sort", "N_filt", "N_egra", "N_thin", "N_ci", "tested_sort", "tested_filt", "tested_egra",
                     "tested_thin"])
        md += table("Same triangles as the full scan", rows, ["same_sort", "same_filt", "same_egra", "same_thin"],
                    thesis=False)
        ratio = [r["N_e1"] / r["N_e2"] for r in rows]
        order = [" < ".join(sorted(["sort", "filt", "egra", "thin"], key=lambda k: r[f"N_{k}"])) for r in rows]
        md += ["## Observations", "",
               f"- N_e1 / N_e2 (extrema graph's registered cells over the skeleton's): "
               + ", ".join(f"{x:.1f}" for x in ratio) + " (thesis: "
               + ", ".join(f"{a / b:.1f}" for a, b in zip(THESIS['N_e1'], THESIS['N_e2'])) + ").",
               "- Table 7.5 ordering per data set: " + ", ".join(order) + " (thesis: sort < thin < egra < filt "
               "on all five).", ""]
    md += ["## O(n): thinning's preprocessing per cell", "",
           "| volume | cells | T_total s | ns/cell | T_topology s | ns/cell with topology | skeleton | extrema |"
           " genus | voids |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in srows:
        md.append(f"| {r['volume']} | {r['cells']} | {fmt(r['T_total'])} | {r['ns_per_cell']:.0f} | "
                  f"{fmt(r['T_topology'])} | {r['ns_per_cell_with_topology']:.0f} | {r['skeleton_cells']} | "
                  f"{r['extrema']} | {r['genus']} | {r['voids']} |")
    md += ["", f"- block family, {block[0]['cells']} to {block[-1]['cells']} cells: ns/cell from "
           f"{per.min():.0f} to {per.max():.0f}, {100 * spread[0]:+.0f} % / {100 * spread[1]:+.0f} % around the "
           "median.",
           f"- worst thinning preprocessing: {worst:.3f} s per 1M cells (target: at most 1 s).",
           f"- plot: `{png.name}`", "", f"- machine: {machine()}"]
    (RESULTS / f"{name}.md").write_text("\n".join(md) + "\n")
    print((RESULTS / f"{name}.md").read_text())


if __name__ == "__main__":
    main()
