"""Polygon construction without vertex search (Itoh et al. 2001): Tables 1 and 2, fair baselines, VTK.

For each volume (data 1-5 and 2M with the FEM field ``fem``; 10M with the
analytic field ``gaussians``, the only field it has), twenty isovalues
``linspace(min, max, 22)[1:-1]``, mean vertex normals and merged vertices
everywhere:

* **Table 1** of the paper: the all-cell scan (``scan``) against volume
  thinning with the hash-based propagation (``thinning``), stage by stage:
  t1 find the intersected cells (for thinning: the skeleton search and the
  seed tests), t2 build the triangle topology, t3 positions and normals;
* **Table 2 and the four constructions**, all from the same thinning
  skeleton seeds:
  (a) ``hash``: propagation, vertices found again in a hash table keyed by
  the edge's two nodes (the paper's reference [12]; table allocated once,
  emptied by stamps, never cleared inside the timed step);
  (b) ``array``: the same propagation, the vertex id in an array indexed by
  the stored edge id (section 2.1's "if the edges were stored");
  (c) ``walk``: the paper's cell-edge-centred construction, no stored edges,
  the cells around an edge found by walking face neighbours
  (``edge-centred``);
  (d) ``table``: the cell-edge-centred construction with the edge table and
  an edge -> cells index (``edge-centred-table``);
  (c) and (d) in the paper's FIFO order and in LIFO. For each: t1/t2/t3,
  the vertex look-ups *counted by the kernels* (and hash probes), the cells
  visited by for-loop (3); hash and walk key their vertices by node pairs
  (no edge table anywhere; relabelled by edge id only to compare with the
  scan, after the clocks);
* **memory**, a separate experiment, the same for every construction
  (:func:`polygen.volume.constructions.construction_memory`): on a freshly
  loaded volume with its face neighbours built (every construction and seed
  source reads them), the builder alone is prepared and extracts the middle
  value from the thinning skeleton's seeds; counted are the arrays the
  builder holds and the tables it made the volume build (each buffer once),
  cross-checked against the process's resident memory; hash and walk also
  with their vertices labelled by edge id (the registered methods' default);
* **against VTK**: ``vtkContourFilter`` (merged points, normals on) with and
  without ``vtkSpanSpace`` (``VTK_SMP_BACKEND_IN_USE=STDThread`` on the two
  cores);
* **scaling**: the mean time per isovalue against the number of cells.

Preprocessing (the volume's topology, the thinning skeleton, the builders'
records) is reported separately; numba kernels are compiled before any clock
starts; every method makes two untimed calls first (allocations, and the hash
table grows to its size). Query and stage times are CPU seconds of the
process (:func:`cpu_clock`; every polygen kernel on one thread), because the
machine is shared; each value is extracted a few times and every time kept
at its minimum over those repeats; the totals are sums over the twenty
values. VTK's times are wall clock (it runs two threads).

    python benchmarks/fast_construction.py                  # data1..data5, 2M, 10M
    python benchmarks/fast_construction.py data1 2M         # a subset
    python benchmarks/fast_construction.py --no-vtk data1   # polygen only
"""

import os

os.environ["VTK_SMP_BACKEND_IN_USE"] = "STDThread"  # before anything imports vtk
# one thread for every polygen kernel: the constructions compared are serial, and the scan's parallel
# kernels on a shared machine wait for their slowest thread (the paper's machine had one CPU)
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import contextlib  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from _common import RESULTS, machine  # noqa: E402
from polygen.volume import datasets, isovalues  # noqa: E402
from polygen.volume.constructions import (  # noqa: E402
    CONSTRUCTIONS,
    builder_of,
    construction_memory,
    edge_keyed,
    prepare_construction,
)
from polygen.volume.seeds.source import seed_source  # noqa: E402
from polygen.volume.surface import same_surface  # noqa: E402

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


_WALL = time.perf_counter


@contextlib.contextmanager
def cpu_clock():
    """Inside: polygen's stage clocks (``time.perf_counter``) read this process's CPU time instead.

    On a machine shared with other jobs a call spends much of its wall time
    waiting for a core (measured here at a load of 14 on 2 cores: 0.13 s
    wall for 0.018 s of CPU); the CPU time it used does not depend on that.
    Every polygen kernel runs in the calling thread (NUMBA_NUM_THREADS=1).
    """
    time.perf_counter = time.process_time
    try:
        yield
    finally:
        time.perf_counter = _WALL


def sweep(method, values, repeat):
    """Each value extracted ``repeat`` times; every time kept at its minimum over the repeats, per value.

    Returns ``(times, surfaces, stats)``: ``times`` (V, 5) [t1, t2, t3 (CPU
    seconds, see :func:`cpu_clock`), CPU seconds of the call, wall seconds
    of the call], the surfaces and the method's stats of the last repeat.
    """
    times = np.full((len(values), 5), np.inf)
    isos = stats = None
    with cpu_clock():
        for _ in range(repeat):
            isos, stats = [], []
            for i, v in enumerate(values):
                w0 = _WALL()
                c0 = time.process_time()
                iso = method.extract(v)
                cpu = time.process_time() - c0
                wall = _WALL() - w0
                times[i] = np.minimum(times[i], [iso.t1, iso.t2, iso.t3, cpu, wall])
                isos.append(iso)
                stats.append(dict(getattr(method, "stats", {})))
    return times, isos, stats


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


# the constructions compared, all from the thinning skeleton's seeds (as notebook 08 prepares them)
prepare = prepare_construction


def warm_up():
    """Compile every kernel used below once, so no timing includes JIT."""
    for name in ("data1", "hexa1"):
        vol = datasets.load(name)
        values = sweep_values(vol.scalars("fem"))[:2]
        for label in ["scan", *CONSTRUCTIONS]:
            m = prepare(label, vol, "fem")
            for v in values:
                m.extract(v)


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
               repeat=rep, load_before=os.getloadavg()[0],
               input_bytes=dict(points=int(vol.points.nbytes), cells=int(vol.cells.nbytes),
                                field=int(vol.scalars(field).nbytes)))
    res = {}
    ref = None
    for label in ["scan", *CONSTRUCTIONS]:
        m = prepare(label, vol, field)
        m.extract(values[len(values) // 2])  # first call: allocations, not timed
        m.extract(values[-1])
        times, isos, stats = sweep(m, values, rep)
        t1, t2, t3, q, wall = (float(x) for x in times.sum(axis=0))
        r = dict(preprocess_s=m.preprocess_s, query_s=q, query_wall_s=wall, t1=t1, t2=t2, t3=t3,
                 per_value_s=times[:, 3].tolist(), triangles=int(sum(i.n_triangles for i in isos)),
                 vertices=int(sum(i.n_vertices for i in isos)),
                 per_value_triangles=[i.n_triangles for i in isos],
                 cells_tested=int(sum(i.cells_tested for i in isos)),
                 cells_intersected=int(sum(i.cells_intersected for i in isos)),
                 vertex_lookups=int(sum(i.vertex_lookups for i in isos)))
        if label == "scan":
            ref = isos
        else:
            r["same_as_scan"] = all(same_surface(a, edge_keyed(label, b, vol), geometry=False)
                                    for a, b in zip(ref, isos))
            b = builder_of(m)
            per_stats = stats
            r["seed_source"] = m.source.name
            r["seed_preprocess_s"] = m.source.preprocess_s
            r["seed_search_s"] = float(sum(st.get("T_search", st.get("T_mg", 0.0)) for st in per_stats))
            if label in ("hash", "array"):
                # the propagator's own counters of the best sweep are gone; run the sweep's values once more
                probes = grows = 0
                t_label = 0.0
                with cpu_clock():
                    for v in values:
                        m.extract(v)
                        probes += b.stats["probes"]
                        grows += b.stats["hash_grows"]
                        t_label += b.stats.get("t_label", 0.0)
                r.update(probes=probes, hash_grows=grows, t_label=t_label)
                r["skeleton_cells"] = m.skeleton.n_cells
            else:
                r["construct_preprocess_s"] = m.construct_preprocess_s
                r["order"] = CONSTRUCTIONS[label][1]["order"]
                for k in ("visits", "pops", "touched", "constructed", "node_vertices", "restarts", "lookups"):
                    r[k] = int(sum(st[k] for st in per_stats))
                if label.startswith("walk"):
                    r["walk_steps"] = int(sum(st["walk_steps"] for st in per_stats))
                    r["probes"] = int(sum(st["probes"] for st in per_stats))
                    r["t_label"] = float(sum(st["t_label"] for st in per_stats))
                else:
                    r["slot_reads"] = int(sum(st["slot_reads"] for st in per_stats))
        res[label] = r
        print(f"{name:6s} {label:11s} pre {m.preprocess_s:7.3f} s  query {q:7.3f} s  t1 {t1:.4f} t2 {t2:.4f} "
              f"t3 {t3:.4f}  {r['triangles']} triangles  lookups {r['vertex_lookups']}  "
              f"same {r.get('same_as_scan')}", file=sys.stderr)
        del m, isos
        gc.collect()
    row["memory"] = memory_experiment(name, field, values[len(values) // 2])
    for label in CONSTRUCTIONS:
        res[label]["memory"] = row["memory"][label]["by_array"]
        res[label]["memory_total"] = row["memory"][label]["total"]
    ref_t = res["scan"]["per_value_triangles"]
    if with_vtk:
        vt = vtk_times(vol, field, values, rep)
        for k, r in vt.items():
            r["same_as_scan"] = r["per_value_triangles"] == ref_t
            print(f"{name:6s} {k:11s} pre {r['preprocess_s']:7.3f} s  query {r['query_s']:7.3f} s  "
                  f"{r['triangles']} triangles", file=sys.stderr)
        res.update(vt)
    row["methods"] = res
    row["load_after"] = os.getloadavg()[0]
    del vol, ref
    gc.collect()
    return row


#: the memory experiment's rows: (row name, construction, labels by edge id)
MEMORY_ROWS = [(k, k, False) for k in CONSTRUCTIONS] + [("hash + edge-id labels", "hash", True),
                                                          ("walk-fifo + edge-id labels", "walk-fifo", True)]


def memory_experiment(name, field, value):
    """:func:`construction_memory` of every construction (and hash and walk labelling by edge id) on a fresh copy
    of ``name``, from the thinning skeleton's seeds for ``value`` (thinned on another copy, no edge table aside),
    with the resident memory read around each (the kernels ran before, in :func:`warm_up` and the sweeps)."""
    ref = datasets.load(name, field=field)
    seeds = seed_source(ref, field, "thinning", edge_table_aside=False).query(value).cells
    del ref
    gc.collect()
    out = {}
    for row, label, labels in MEMORY_ROWS:
        vol = datasets.load(name, field=field)
        out[row] = construction_memory(label, vol, value, seeds, field=field, rss=True, labels=labels)
        r = out[row]
        print(f"{name:6s} memory {row:28s} {r['total'] / r['cells']:7.1f} B/cell (builder {r['builder'] / r['cells']:.1f}"
              f", volume {sum(r['volume'].values()) / r['cells']:.1f}); RSS {r['rss'] / r['total']:.3f} of it",
              file=sys.stderr)
        del vol
        gc.collect()
    return out


def mb(x):
    return f"{x / 1e6:.1f}"


def markdown(rows):
    lines = ["# Polygon construction without vertex search (Itoh et al. 2001): Tables 1, 2, fair baselines, VTK", ""]
    lines += ["Twenty isovalues `linspace(min, max, 22)[1:-1]` per volume, mean vertex normals, merged vertices; "
              "polygen's times in CPU seconds of the process (the machine is shared; one thread), each stage's minimum over the repeats of each value, summed over the values; VTK's in wall seconds (two threads); the paper's numbers (IBM RS/6000 560, 2001) in brackets.", ""]
    lines += ["## Table 1: all-cell scan vs volume thinning (hash-based propagation), stage by stage", "",
              "| data | cells | triangles | vertices | scan t1 | scan t2 | scan t3 | scan total | thinning t1 | "
              "thinning t2 | thinning t3 | thinning total | cells tested scan / thinning |", "|" + "---|" * 13]
    for r in rows:
        sc, th = r["methods"]["scan"], r["methods"]["hash"]
        p = PAPER_T1.get(r["data"])

        def cell(x, k, i):
            return f"{x:.4f}" + (f" [{p[k][i]}]" if p else "")

        lines.append(f"| {r['data']} | {r['cells']}" + (f" [{p['n_c']}]" if p else "") +
                     f" | {sc['triangles']}" + (f" [{p['n_t']}]" if p else "") +
                     f" | {sc['vertices']}" + (f" [{p['n_v']}]" if p else "") + " | " +
                     " | ".join(cell(sc[k], "scan", i) for i, k in enumerate(("t1", "t2", "t3"))) +
                     f" | {sc['query_s']:.4f}" + (f" [{p['scan'][3]}]" if p else "") + " | " +
                     " | ".join(cell(th[k], "thinning", i) for i, k in enumerate(("t1", "t2", "t3"))) +
                     f" | {th['query_s']:.4f}" + (f" [{p['thinning'][3]}]" if p else "") +
                     f" | {sc['cells_tested']} / {th['cells_tested']} |")
    lines += ["", "## The four constructions side by side (all from the thinning skeleton's seeds)", "",
              "(a) hash: propagation + hash keyed by the edge's two nodes (reference [12]); (b) array: propagation + "
              "vertex id in an array indexed by the stored edge id; (c) walk: the paper's edge-centred "
              "construction, no stored edges; (d) table: edge-centred with the edge table and edge -> cells "
              "index. t2 = polygon construction (the paper's t_p); look-ups as counted by the kernels; memory = "
              "the memory experiment's total (MB: the arrays the builder holds and the tables it made the "
              "volume build, after preparation and one extract; next section).", "",
              "| data | cells | construction | t1 | t2 | t3 | total | labels by edge id | vertex look-ups | "
              "hash probes | cells visited by for-loop (3) | walk steps | memory MB | memory by array (MB) | "
              "same as scan |", "|" + "---|" * 15]
    for r in rows:
        for label in CONSTRUCTIONS:
            x = r["methods"][label]
            mem = ", ".join(f"{k} {mb(v)}" for k, v in x["memory"].items())
            lines.append(f"| {r['data']} | {r['cells']} | {label} | {x['t1']:.4f} | {x['t2']:.4f} | {x['t3']:.4f} | "
                         f"{x['query_s']:.4f} | {x.get('t_label', 0.0):.4f} | {x['vertex_lookups']} | "
                         f"{x.get('probes', 0)} | {x.get('visits', '-')} | {x.get('walk_steps', '-')} | "
                         f"{mb(x['memory_total'])} | {mem} | {x['same_as_scan']} |")
    lines += ["", "## Memory per construction (bytes per cell)", "",
              "Measured from the arrays: on a freshly loaded volume with its face neighbours built, the builder "
              "alone is prepared and extracts the middle value from the skeleton's seeds; counted are the arrays "
              "it holds (builder) and the tables it made the volume build (volume), each buffer once; RSS = the "
              "process's resident memory after minus before, as a share of the count.", "",
              "| data | cells | construction | builder | volume tables built | total | total MB | RSS / total |",
              "|" + "---|" * 8]
    for r in rows:
        for row, x in r["memory"].items():
            vt = ", ".join(f"{k} {v / x['cells']:.1f}" for k, v in x["volume"].items()) or "none"
            lines.append(f"| {r['data']} | {r['cells']} | {row} | {x['builder'] / x['cells']:.1f} | {vt} | "
                         f"{x['total'] / x['cells']:.1f} | {mb(x['total'])} | {x['rss'] / x['total']:.3f} |")
    lines += ["", "## What each comparison isolates (t2, FIFO for the edge-centred ones)", "",
              "| data | cells | removing the search, edges stored: table / array | removing the search, no edges: "
              "walk / hash | storing edges, search kept: array / hash | storing edges, no search: table / walk | "
              "the paper's claim, edge-centred / old: walk / hash [paper] | memory walk / hash | "
              "memory table / walk | memory array / hash |", "|" + "---|" * 10]
    for r in rows:
        m = r["methods"]
        h, a, w, tb = (m[k] for k in ("hash", "array", "walk-fifo", "table-fifo"))
        p = PAPER_T2.get(r["data"])
        pp = f" [{p[2] / p[1]:.2f}]" if p else ""
        lines.append(f"| {r['data']} | {r['cells']} | {tb['t2'] / a['t2']:.2f} | {w['t2'] / h['t2']:.2f} | "
                     f"{a['t2'] / h['t2']:.2f} | {tb['t2'] / w['t2']:.2f} | {w['t2'] / h['t2']:.2f}{pp} | "
                     f"{w['memory_total'] / h['memory_total']:.2f} | {tb['memory_total'] / w['memory_total']:.2f} | "
                     f"{a['memory_total'] / h['memory_total']:.2f} |")
    lines += ["", "## Table 2: the paper's old (hash) and new (edge-centred, FIFO) construction", "",
              "| data | cells | t_p old (hash) | t_p new (walk) | t_p new / old | total old | total new | "
              "total new / old |", "|" + "---|" * 8]
    for r in rows:
        h, w = r["methods"]["hash"], r["methods"]["walk-fifo"]
        p = PAPER_T2.get(r["data"])
        b = (lambda i: f" [{p[i]}]") if p else (lambda i: "")
        lines.append(f"| {r['data']} | {r['cells']}{b(0)} | {h['t2']:.4f}{b(1)} | {w['t2']:.4f}{b(2)} | "
                     f"{w['t2'] / h['t2']:.2f}" + (f" [{p[2] / p[1]:.2f}]" if p else "") +
                     f" | {h['query_s']:.4f}{b(3)} | {w['query_s']:.4f}{b(4)} | {w['query_s'] / h['query_s']:.2f}"
                     + (f" [{p[4] / p[3]:.2f}]" if p else "") + " |")
    have_vtk = all("vtk" in r["methods"] for r in rows)
    if have_vtk:
        lines += ["", "## Against VTK: total query time for the twenty values", "",
                  "VTK in wall seconds on two threads, polygen in CPU seconds on one: not the same clock.", "",
                  "| data | cells | field | vtk | vtk+spanspace | scan | hash | array | walk LIFO | table LIFO | "
                  "same triangles as scan: vtk / vtk+spanspace | load before / after |", "|" + "---|" * 12]
        for r in rows:
            m = r["methods"]
            lines.append(f"| {r['data']} | {r['cells']} | {r['field']} | {m['vtk']['query_s']:.4f} | "
                         f"{m['vtk+spanspace']['query_s']:.4f} | {m['scan']['query_s']:.4f} | "
                         f"{m['hash']['query_s']:.4f} | {m['array']['query_s']:.4f} | "
                         f"{m['walk-lifo']['query_s']:.4f} | {m['table-lifo']['query_s']:.4f} | "
                         f"{m['vtk']['same_as_scan']} / {m['vtk+spanspace']['same_as_scan']} | "
                         f"{r['load_before']:.2f} / {r['load_after']:.2f} |")
    lines += ["", "## Preprocessing (s), reported apart from the queries", "",
              "| data | cells | load | topology | thinning skeleton (cells) | walk records | table records | "
              "array propagator | seed search, 20 values |", "|" + "---|" * 9]
    for r in rows:
        m = r["methods"]
        lines.append(f"| {r['data']} | {r['cells']} | {r['load_s']:.3f} | {r['topology_s']:.3f} | "
                     f"{m['walk-lifo']['seed_preprocess_s']:.3f} ({m['hash']['skeleton_cells']}) | "
                     f"{m['walk-lifo']['construct_preprocess_s']:.3f} | {m['table-lifo']['construct_preprocess_s']:.3f}"
                     f" | {m['array']['preprocess_s'] - m['array']['seed_preprocess_s']:.3f} | "
                     f"{m['walk-lifo']['seed_search_s']:.4f} |")
    slope = scaling(rows)
    if slope is not None:
        lines += ["", "## Scaling", "",
                  f"- mean time per isovalue against cells, log-log slope over {', '.join(r['data'] for r in rows)}: "
                  + ", ".join(f"{k} **{v:.3f}**" for k, v in slope.items())]
    lines += ["", "## Notes", "",
              "- t1 / t2 / t3 as in Table 1 of the paper: find the intersected cells (the skeleton search plus the "
              "seed tests) / build the triangle topology / vertex positions and normals; total = CPU time of the "
              "20 calls, Python included (hash and walk key their vertices by node pairs: no labelling by edge "
              "id in the clocks, `labels` 0)",
              "- vertex look-ups: counted in the kernels; hash: one search per polygon vertex per cell (probes: "
              "slots inspected); array: one read of the vertex-id array per polygon vertex per cell; walk: none "
              "(a searching variant counts them: tests/test_edge_centred.py::test_lookup_counter_is_live); "
              "table: no read by a key, its kernels count their slot reads instead (one per triangle corner: "
              "tests/test_constructions.py::test_the_table_kernels_count_their_slot_reads)",
              "- memory: the memory experiment (`construction_memory`), after preparation and one extract; "
              "the volume's own points, cells and field and its face neighbours are not counted; everything "
              "else the construction holds or made the volume build is, the edge table of a labelling by edge "
              "id included (the `+ edge-id labels` rows)",
              "- one thread for every polygen kernel (NUMBA_NUM_THREADS=1; the scan too); vtk: vtkContourFilter, "
              "merged points, ComputeNormalsOn, VTK_SMP_BACKEND_IN_USE=STDThread (both cores); vtk+spanspace adds "
              "SetScalarTree(vtkSpanSpace())",
              "- 10M has analytic fields only (no FEM solve at that size): field `gaussians`; "
              + ("" if any(r["data"] == "10M" for r in rows) else
                 "not in this run: building it did not finish within 29 minutes of wall time here (1 min 43 s "
                 "of CPU, the machine at a load of about 14), past the 10 minutes allowed for it"),
              "- a 2-core machine shared with other jobs: the load average before/after each volume is listed; "
              "times are indicative, counts and bytes are exact (the memory does not depend on the load)",
              f"- machine: {machine()}"]
    return "\n".join(lines) + "\n"


def scaling(rows):
    if len(rows) < 2:
        return None
    n = np.log([r["cells"] for r in rows])
    out = {}
    for label in ("hash", "array", "walk-lifo", "table-lifo"):
        t = np.log([r["methods"][label]["query_s"] / 20 for r in rows])
        out[label] = float(np.polyfit(n, t, 1)[0])
    tri = np.log([r["methods"]["scan"]["triangles"] / 20 for r in rows])
    out["triangles"] = float(np.polyfit(n, tri, 1)[0])
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
