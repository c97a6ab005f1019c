"""Polygon construction without vertex search (Itoh et al. 2001): Tables 1 and 2, and polygen vs VTK.

For each volume (data 1-5 and 2M with the FEM field ``fem``; 10M with the
analytic field ``gaussians``, the only fields it has), twenty isovalues
``linspace(min, max, 22)[1:-1]``, mean vertex normals and merged vertices
everywhere:

* **Table 1** of the paper: the all-cell scan (``scan``) against volume
  thinning with the hash-based propagation (``thinning``), stage by stage:
  t1 find the intersected cells (for thinning: the skeleton search and the
  seed tests), t2 build the triangle topology, t3 positions and normals;
* **Table 2**: hash-based (``thinning``) against cell-edge-centred
  (``edge-centred``, the same skeleton seeds) construction, ``t_p`` = t2
  (polygon construction) and the total, with the counters the claim rests
  on (vertex look-ups, cells visited by for-loop (3));
* **against VTK**: ``vtkContourFilter`` (merged points, normals on) with and
  without ``vtkSpanSpace`` (``VTK_SMP_BACKEND_IN_USE=STDThread`` on the two
  cores), and the total query time of ``edge-centred`` for the twenty values
  (wall clock, Python and seed search included), FIFO (the paper's order)
  and LIFO;
* **scaling**: the mean time per isovalue against the number of cells, the
  slope of the log-log fit;
* **interactive**: every one of the twenty isovalues on the 2M volume timed
  on its own (best of the repeats), median and maximum.

Preprocessing (the volume's topology, the thinning skeleton, the edge-centred
incidence records) is reported separately; numba kernels are compiled before
any clock starts. Query times are the best of a few sweeps.

    python benchmarks/fast_construction.py                  # data1..data5, 2M, 10M
    python benchmarks/fast_construction.py data1 2M         # a subset
    python benchmarks/fast_construction.py --no-vtk data1   # polygen only
"""

import os

os.environ["VTK_SMP_BACKEND_IN_USE"] = "STDThread"  # before anything imports vtk
os.environ.setdefault("NUMBA_NUM_THREADS", "2")

import gc  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from _common import RESULTS, machine  # noqa: E402
from polygen.volume import datasets, isovalues, methods  # noqa: E402

DATA = ["data1", "data2", "data3", "data4", "data5", "2M", "10M"]
FIELD = {"10M": "gaussians"}
# the paper's numbers (Tables 1 and 2): volume -> values
PAPER_T1 = {
    "data2": dict(n_c=61680, n_n=11624, n_t=80995, n_v=43158, scan=(8.30, 3.80, 0.76, 12.86),
                  thinning=(0.09, 3.45, 0.75, 4.29)),
    "data3": dict(n_c=346644, n_n=62107, n_t=135358, n_v=71358, scan=(42.23, 6.25, 1.14, 49.62),
                  thinning=(0.57, 5.88, 1.15, 7.60)),
}
PAPER_T2 = {  # volume: (n_c, t_p old, t_p new, total old, total new)
    "data2": (61680, 3.45, 2.53, 4.29, 3.35),
    "data3": (346644, 5.88, 4.01, 7.60, 5.52),
    "data5": (458664, 21.35, 15.72, 26.65, 20.61),
    "data4": (557868, 49.80, 36.20, 60.81, 46.80),
}


def sweep_values(s):
    return isovalues(s, 20)


def repeats(n_cells):
    return 7 if n_cells < 100_000 else 5 if n_cells < 1_000_000 else 3 if n_cells < 5_000_000 else 2


def sweep(method, values, repeat):
    """Best-of-``repeat`` sweeps: (total wall s, per-value best s, surfaces of the best sweep, stats per value)."""
    best = float("inf")
    per = np.full(len(values), np.inf)
    out = stats = None
    for _ in range(repeat):
        isos, st = [], []
        t_all = time.perf_counter()
        for i, v in enumerate(values):
            t0 = time.perf_counter()
            iso = method.extract(v)
            per[i] = min(per[i], time.perf_counter() - t0)
            isos.append(iso)
            st.append(dict(getattr(method, "stats", {})))
        total = time.perf_counter() - t_all
        if total < best:
            best, out, stats = total, isos, st
    return best, per, out, stats


def stage_sums(isos):
    t = np.array([[i.t1, i.t2, i.t3] for i in isos]).sum(axis=0)
    return float(t[0]), float(t[1]), float(t[2])


def vtk_times(vol, field, values, repeat):
    from isosurface import run_vtk, vtk_grid

    grid = vtk_grid(vol, field)
    out = {}
    for label, span in [("vtk", False), ("vtk+spanspace", True)]:
        pre, q, tris, verts = run_vtk(grid, field, values, span_space=span, repeat=repeat)
        out[label] = dict(preprocess_s=pre, query_s=q, triangles=int(sum(tris)), vertices=int(sum(verts)),
                          per_value_triangles=[int(t) for t in tris])
    del grid
    gc.collect()
    return out


def warm_up():
    """Compile every kernel used below once, so no timing includes JIT."""
    vol = datasets.load("data1")
    values = sweep_values(vol.scalars("fem"))[:2]
    for name in ("scan", "thinning", "edge-centred"):
        m = methods.get(name)(vol, field="fem")
        for v in values:
            m.extract(v)
    m = methods.get("edge-centred")(vol, field="fem", order="fifo")
    m.extract(values[0])
    vol = datasets.load("hexa1")
    m = methods.get("edge-centred")(vol, field="fem")
    m.extract(float(np.median(vol.scalars("fem"))))


def run_one(name, with_vtk):
    field = FIELD.get(name, "fem")
    t0 = time.perf_counter()
    vol = datasets.load(name, field=field)
    load_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    vol.face_neighbors, vol.edges, vol.cell_edges, vol.node_cells, vol.boundary_groups, vol.cell_records
    topo_s = time.perf_counter() - t0
    values = sweep_values(vol.scalars(field))
    rep = repeats(vol.n_cells)
    row = dict(data=name, field=field, cells=vol.n_cells, nodes=vol.n_points, load_s=load_s, topology_s=topo_s,
               repeat=rep, load_before=os.getloadavg()[0])

    res = {}
    for label, name_, params in [("scan", "scan", {}), ("thinning", "thinning", {}),
                                 ("edge-centred-fifo", "edge-centred", {"order": "fifo"}),
                                 ("edge-centred-lifo", "edge-centred", {"order": "lifo"})]:
        m = methods.get(name_)(vol, field=field, **params)
        m.extract(values[len(values) // 2])  # first call: allocations, not timed
        q, per, isos, stats = sweep(m, values, rep)
        t1, t2, t3 = stage_sums(isos)
        r = dict(preprocess_s=m.preprocess_s, query_s=q, t1=t1, t2=t2, t3=t3,
                 per_value_s=per.tolist(), triangles=int(sum(i.n_triangles for i in isos)),
                 vertices=int(sum(i.n_vertices for i in isos)),
                 per_value_triangles=[i.n_triangles for i in isos],
                 cells_tested=int(sum(i.cells_tested for i in isos)),
                 cells_intersected=int(sum(i.cells_intersected for i in isos)),
                 vertex_lookups=int(sum(i.vertex_lookups for i in isos)))
        if name_ == "edge-centred":
            r["seed_preprocess_s"] = m.seed_preprocess_s
            r["construct_preprocess_s"] = m.construct_preprocess_s
            r["seed_source"] = m.source.name
            r["order"] = params["order"]
            for k in ("visits", "pops", "touched", "constructed", "node_vertices", "restarts"):
                r[k] = int(sum(st[k] for st in stats))
            r["seed_search_s"] = float(sum(st["T_search"] for st in stats))
        if name_ == "thinning":
            r["skeleton_cells"] = m.skeleton.n_cells
            r["thinning_s"] = m.skeleton.stats["T_total"]
        res[label] = r
        print(f"{name:6s} {label:18s} pre {m.preprocess_s:7.3f} s  query {q:7.3f} s  t1 {t1:.3f} t2 {t2:.3f} "
              f"t3 {t3:.3f}  {r['triangles']} triangles  lookups {r['vertex_lookups']}", file=sys.stderr)
        if label == "edge-centred-lifo":  # the same method, two values at a time on the two cores
            m.extract_many(values[:2], threads=2)  # the second builder's records: allocated once, not timed
            best, isos2 = float("inf"), None
            for _ in range(rep):
                t0 = time.perf_counter()
                got = m.extract_many(values, threads=2)
                dt = time.perf_counter() - t0
                if dt < best:
                    best, isos2 = dt, got
            res["edge-centred-2x"] = dict(query_s=best, threads=2, triangles=int(sum(i.n_triangles for i in isos2)),
                                          vertices=int(sum(i.n_vertices for i in isos2)),
                                          per_value_triangles=[i.n_triangles for i in isos2],
                                          vertex_lookups=int(sum(i.vertex_lookups for i in isos2)))
            print(f"{name:6s} {'edge-centred-2x':18s} query {best:7.3f} s (extract_many, 2 threads)",
                  file=sys.stderr)
            del isos2, got
        del m, isos
        gc.collect()
    ref = res["scan"]["per_value_triangles"]
    for r in res.values():
        r["same_as_scan"] = r["per_value_triangles"] == ref
    if with_vtk:
        vt = vtk_times(vol, field, values, rep)
        for k, r in vt.items():
            r["same_as_scan"] = r["per_value_triangles"] == ref
            print(f"{name:6s} {k:18s} pre {r['preprocess_s']:7.3f} s  query {r['query_s']:7.3f} s  "
                  f"{r['triangles']} triangles", file=sys.stderr)
        res.update(vt)
    row["methods"] = res
    row["load_after"] = os.getloadavg()[0]
    del vol
    gc.collect()
    return row


def markdown(rows):
    lines = ["# Polygon construction without vertex search (Itoh et al. 2001): Tables 1, 2 and VTK", ""]
    lines += ["Twenty isovalues `linspace(min, max, 22)[1:-1]` per volume, mean vertex normals, merged vertices; "
              "times in seconds, best of the sweeps; the paper's numbers (IBM RS/6000 560, 2001) in brackets.", ""]
    lines += ["## Table 1: all-cell scan vs volume thinning (hash-based propagation), stage by stage", "",
              "| data | cells | triangles | vertices | scan t1 | scan t2 | scan t3 | scan total | thinning t1 | "
              "thinning t2 | thinning t3 | thinning total |", "|" + "---|" * 12]
    for r in rows:
        sc, th = r["methods"]["scan"], r["methods"]["thinning"]
        p = PAPER_T1.get(r["data"])

        def cell(x, k, i):
            return f"{x:.4f}" + (f" [{p[k][i]}]" if p else "")

        lines.append(f"| {r['data']} | {r['cells']}" + (f" [{p['n_c']}]" if p else "") +
                     f" | {sc['triangles']}" + (f" [{p['n_t']}]" if p else "") +
                     f" | {sc['vertices']}" + (f" [{p['n_v']}]" if p else "") + " | " +
                     " | ".join(cell(sc[k], "scan", i) for i, k in enumerate(("t1", "t2", "t3"))) +
                     f" | {sc['query_s']:.4f}" + (f" [{p['scan'][3]}]" if p else "") + " | " +
                     " | ".join(cell(th[k], "thinning", i) for i, k in enumerate(("t1", "t2", "t3"))) +
                     f" | {th['query_s']:.4f}" + (f" [{p['thinning'][3]}]" if p else "") + " |")
    lines += ["", "## Table 2: hash-based vs cell-edge-centred construction (both from the thinning skeleton)", "",
              "| data | cells | t_p hash | t_p edge | t_p faster by | total hash | total edge | total faster by | "
              "t_p edge LIFO | vertex look-ups hash / edge | cells visited by for-loop (3) | cells constructed | "
              "cells tested hash / edge |", "|" + "---|" * 13]
    for r in rows:
        th, ec = r["methods"]["thinning"], r["methods"]["edge-centred-fifo"]
        lifo = r["methods"]["edge-centred-lifo"]
        p = PAPER_T2.get(r["data"])
        fp = 1 - ec["t2"] / th["t2"]
        ft = 1 - ec["query_s"] / th["query_s"]
        pp = f" [{1 - p[2] / p[1]:.0%}]" if p else ""
        pt = f" [{1 - p[4] / p[3]:.0%}]" if p else ""
        lines.append(
            f"| {r['data']} | {r['cells']}" + (f" [{p[0]}]" if p else "") +
            f" | {th['t2']:.4f}" + (f" [{p[1]}]" if p else "") + f" | {ec['t2']:.4f}" + (f" [{p[2]}]" if p else "") +
            f" | {fp:.0%}{pp} | {th['query_s']:.4f}" + (f" [{p[3]}]" if p else "") +
            f" | {ec['query_s']:.4f}" + (f" [{p[4]}]" if p else "") + f" | {ft:.0%}{pt} | {lifo['t2']:.4f}"
            f" | {th['vertex_lookups']} / {ec['vertex_lookups']} | {ec['visits']} | {ec['constructed']}"
            f" | {th['cells_tested']} / {ec['cells_tested']} |")
    have_vtk = all("vtk" in r["methods"] for r in rows)
    lines += ["", "## Against VTK: total query time for the twenty values", "",
              "| data | cells | field | vtk | vtk+spanspace | scan | thinning (hash) | edge-centred FIFO | "
              "edge-centred LIFO | edge-centred, 2 values at a time | edge / (vtk+spanspace), one at a time | "
              "edge 2 at a time / (vtk+spanspace) | same triangles as scan: polygen / vtk / vtk+spanspace | "
              "load before / after |", "|" + "---|" * 14]
    for r in rows:
        m = r["methods"]
        vt = m.get("vtk", {}).get("query_s", float("nan"))
        vs = m.get("vtk+spanspace", {}).get("query_s", float("nan"))
        best = min(m["edge-centred-fifo"]["query_s"], m["edge-centred-lifo"]["query_s"])
        two = m["edge-centred-2x"]["query_s"]
        same = all(x["same_as_scan"] for k, x in m.items() if not k.startswith("vtk"))
        same_vtk = " / ".join(str(m[k]["same_as_scan"]) if k in m else "-" for k in ("vtk", "vtk+spanspace"))
        lines.append(f"| {r['data']} | {r['cells']} | {r['field']} | {vt:.4f} | {vs:.4f} | {m['scan']['query_s']:.4f}"
                     f" | {m['thinning']['query_s']:.4f} | {m['edge-centred-fifo']['query_s']:.4f}"
                     f" | {m['edge-centred-lifo']['query_s']:.4f} | {two:.4f} | {best / vs:.3f} | {two / vs:.3f}"
                     f" | {same} / {same_vtk} | {r['load_before']:.2f} / {r['load_after']:.2f} |")
    lines += ["", "## Preprocessing (s), reported apart from the queries", "",
              "| data | cells | load | topology | thinning skeleton (cells) | edge-centred records | "
              "seed search, 20 values |", "|" + "---|" * 7]
    for r in rows:
        ec = r["methods"]["edge-centred-lifo"]
        lines.append(f"| {r['data']} | {r['cells']} | {r['load_s']:.3f} | {r['topology_s']:.3f} | "
                     f"{ec['seed_preprocess_s']:.3f} ({r['methods']['thinning']['skeleton_cells']}) | "
                     f"{ec['construct_preprocess_s']:.3f} | {ec['seed_search_s']:.4f} |")
    slope = scaling(rows)
    lines += ["", "## Scaling and the interactive case", ""]
    if slope is not None:
        lines.append(f"- mean time per isovalue (edge-centred) against cells, log-log slope over "
                     f"{', '.join(r['data'] for r in rows)}: **{slope['lifo']:.3f}** LIFO, {slope['fifo']:.3f} FIFO "
                     f"(triangles per isovalue against cells: {slope['triangles']:.3f})")
        if "lifo_fem" in slope:
            lines.append(f"- the same over the FEM-field volumes only (without 10M, whose field differs): "
                         f"**{slope['lifo_fem']:.3f}** LIFO, {slope['fifo_fem']:.3f} FIFO (triangles: "
                         f"{slope['triangles_fem']:.3f})")
    for r in rows:
        if r["data"] == "2M":
            for label in ("edge-centred-fifo", "edge-centred-lifo"):
                per = np.array(r["methods"][label]["per_value_s"]) * 1e3
                lines.append(f"- 2M, {label}: one isosurface in {np.median(per):.2f} ms median, "
                             f"{per.max():.2f} ms at most (each of the 20 values timed alone, best of the sweeps)")
    lines += ["", "## Notes", "",
              "- t1 / t2 / t3 as in Table 1 of the paper: find the intersected cells (for the skeleton methods "
              "the skeleton search plus the seed tests) / build the triangle topology / vertex positions and "
              "normals; total = wall clock of the 20 calls, Python included",
              "- edge-centred: Fig. 5 of the paper, seeds from the volume-thinning skeleton (the `thinning` "
              "method's), FIFO as in the paper (Table 2) or LIFO (the method's default; the same surface); "
              "vertex look-ups are zero by construction",
              "- cells visited by for-loop (3): for every vertex, the cells around its edge (or node), summed "
              "over the 20 values; cells constructed = cells intersected",
              "- vtk: vtkContourFilter, merged points, ComputeNormalsOn, VTK_SMP_BACKEND_IN_USE=STDThread; "
              "vtk+spanspace adds SetScalarTree(vtkSpanSpace()) (its build is preprocessing); VTK uses both "
              "cores inside each contour, polygen's `edge-centred` one core per value: one value at a time "
              "(the interactive case) or two values at a time on the two cores (`extract_many`, the same "
              "surfaces); vtk+spanspace drops a few triangles on 2M and 10M (the last column)",
              "- 10M has analytic fields only (no FEM solve at that size): field `gaussians`",
              "- a 2-core machine shared with other jobs: the load average before/after each volume is listed; "
              "times are indicative, counts are exact",
              f"- machine: {machine()}"]
    return "\n".join(lines) + "\n"


def scaling(rows):
    if len(rows) < 2:
        return None
    n = np.log([r["cells"] for r in rows])
    out = {}
    fem = np.array([r["field"] == "fem" for r in rows])
    for key, label in (("fifo", "edge-centred-fifo"), ("lifo", "edge-centred-lifo")):
        t = np.log([r["methods"][label]["query_s"] / 20 for r in rows])
        out[key] = float(np.polyfit(n, t, 1)[0])
        if fem.sum() >= 2 and not fem.all():
            out[key + "_fem"] = float(np.polyfit(n[fem], t[fem], 1)[0])
    tri = np.log([r["methods"]["edge-centred-lifo"]["triangles"] / 20 for r in rows])
    out["triangles"] = float(np.polyfit(n, tri, 1)[0])
    if fem.sum() >= 2 and not fem.all():
        out["triangles_fem"] = float(np.polyfit(n[fem], tri[fem], 1)[0])
    return out


def main(argv):
    with_vtk = "--no-vtk" not in argv
    names = [a for a in argv if not a.startswith("--")] or DATA
    warm_up()
    rows = []
    for name in names:
        try:
            rows.append(run_one(name, with_vtk))
        except MemoryError as exc:  # pragma: no cover - depends on the machine
            print(f"{name}: skipped ({exc})", file=sys.stderr)
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = {"machine": machine(), "rows": rows, "slope": scaling(rows)}
    (RESULTS / "fast_construction.json").write_text(json.dumps(out, indent=1) + "\n")
    (RESULTS / "fast_construction.md").write_text(markdown(rows))
    print(f"wrote {RESULTS / 'fast_construction.md'}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
