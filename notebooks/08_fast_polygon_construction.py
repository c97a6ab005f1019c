# ---
# jupyter:
#   jupytext:
#     notebook_metadata_filter: -jupytext.text_representation.jupytext_version
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A fast polygon construction method for isosurface generation (Itoh, Yamaguchi, Koyamada 2001)
#
# An isosurface is made in three stages (the paper's Table 1): **t1** find the cells the
# surface crosses, **t2** build the polygons inside them, **t3** compute the vertex positions
# and normals. Volume thinning (chapter 7) made t1 almost free, so t2 dominates. Most
# polygon vertices are shared by several polygons, so a propagation that builds one cell at
# a time must find each vertex again when the next cell around the same cell edge is built.
#
# The paper's premise (2.1): *if* the volume stored its cell edges, a vertex could be
# registered per edge and nobody would search for it; but volume data keep nodes and cells,
# **not cell edges**, to save memory. So the thesis's propagation finds a vertex again in a
# **hash table keyed by the edge's two end nodes** (reference [12], Fig. 1). The paper turns
# the loop inside out (3.1, Fig. 4): when a vertex is created on a cell edge, **every cell
# sharing that edge is visited at once** (found by walking from face neighbour to face
# neighbour round the edge: still no edge table), its polygon is constructed if missing, and
# the vertex is registered in all of them. No vertex is needed again, so none is searched for.
#
# Four constructions, all from the same thinning-skeleton seeds, separate the two things
# that could make it fast — *removing the search* and *storing the edges*:
#
# | | no stored edges | stored edges |
# |---|---|---|
# | **vertex search** | (a) `hash`: propagation + hash on node pairs (the paper's old method) | (b) `array`: propagation + vertex id in an array indexed by edge id |
# | **no search** | (c) `walk`: the paper's new method (`edge-centred`) | (d) `table`: edge-centred with an edge table and edge → cells index (`edge-centred-table`) |

# %%
import json, os, time  # noqa: E401
from pathlib import Path

FULL = os.environ.get("POLYGEN_FULL") == "1"   # the paper's four volumes for Table 2 when set
import matplotlib.pyplot as plt
import numpy as np

import polygen
from polygen import plotting
from polygen.plotting import volume as plot_volume
from polygen.volume import datasets, isovalues, methods
from polygen.volume.constructions import (builder_of as builder, construction_memory, edge_keyed,
                                          prepare_construction, timed_sweep, timed_sweeps)
from polygen.volume.seeds.source import seed_source
from polygen.volume.edge_centred import EdgeCentredWalk
from polygen.volume.isosurface import extract, same_surface
import numba

pv = plotting.setup_notebook()
# each value this many times, every stage time kept at its minimum: 7 so that a run beside other work
# (the test command runs two test processes and this kernel on two cores) still finds one undisturbed;
# at 3, data2's 20 ms sweep once measured the walk at 0.97 of the hash (0.63-0.71 when quiet)
REPEATS = 7
numba.set_num_threads(1)     # every construction on one core (the scan's kernels are parallel otherwise)

# %%
# the paper's volumes 1-4 are ours data2, data3, data5, data4 (61680, 346644, 458664, 557868 cells)
TABLE1_DATA = ["data2", "data3"]
TABLE2_DATA = ["data2", "data3"] + (["data5", "data4"] if FULL else [])
HEX_DATA = ["hexa1", "hexa2"] + (["hexa3"] if FULL else [])
PAPER_T1 = {  # Table 1: n_c, n_n, n_t, n_v; (t1, t2, t3, total) all-cell scan / volume thinning
    "data2": (61680, 11624, 80995, 43158, (8.30, 3.80, 0.76, 12.86), (0.09, 3.45, 0.75, 4.29)),
    "data3": (346644, 62107, 135358, 71358, (42.23, 6.25, 1.14, 49.62), (0.57, 5.88, 1.15, 7.60)),
}
PAPER_T2 = {  # Table 2: n_c, n_t, n_v, t_p old, t_p new, total old, total new
    "data2": (61680, 80995, 43158, 3.45, 2.53, 4.29, 3.35),
    "data3": (346644, 135398, 71358, 5.88, 4.01, 7.60, 5.52),
    "data5": (458664, 494480, 251506, 21.35, 15.72, 26.65, 20.61),
    "data4": (557868, 1164616, 588796, 49.80, 36.20, 60.81, 46.80),
}
# our label -> the construction (polygen.volume.constructions): method, parameters, the propagator's vertex search;
# "array": the same thinning seeds, the vertex found by its edge id. "hash" and "walk" store no edges: their
# surfaces are keyed by node pairs, relabelled by edge id (edge_keyed) only to compare them with the scan's
CONSTRUCTIONS = {"hash": "hash", "array": "array", "walk": "walk-fifo", "table": "table-fifo"}

# %% [markdown]
# ## Figs 1 and 4 — a search per polygon against a registration per cell
#
# One isosurface of data 1. The hash-based propagation looks a vertex up once for every cell
# that uses it; the edge-centred constructions *visit* every cell round the vertex's edge once,
# when the vertex is created, and store the vertex into it. Every cell round a crossed edge is
# crossed and uses the vertex, so both make the same number of (vertex, cell) pairings — the
# counts below come from different kernels, each counting what it does. The look-ups are counted
# by the kernels: the walk makes none, and a deliberately searching variant of the walk
# (`search=True`: each polygon vertex looked up by its edge's nodes) counts them, so the
# counter is live. The table's kernels have no read by a key to count; they count what they do
# read, a vertex id from its cell's slot per triangle corner (`slot reads`, 3 per triangle).

# %%
vol = datasets.load("data1")
s = vol.scalars("fem")
value = float(np.linspace(s.min(), s.max(), 22)[10])
ms = {label: prepare_construction(c, vol) for label, c in CONSTRUCTIONS.items()}
isos = {label: edge_keyed(CONSTRUCTIONS[label], m.extract(value), vol) for label, m in ms.items()}
seeds = ms["walk"].source.query(value).cells
searching = EdgeCentredWalk(vol, "fem", order="fifo", search=True).extract(value, seeds)
scan = extract(vol, value, field="fem")
rows = [{"construction": k, "triangles": i.n_triangles, "vertices": i.n_vertices, "vertex look-ups": i.vertex_lookups,
         "hash probes": builder(ms[k]).stats.get("probes", 0),
         "cells visited by for-loop (3)": ms[k].stats.get("visits", "-"),
         "slot reads": ms[k].stats.get("slot_reads", "-")} for k, i in isos.items()]
rows.append({"construction": "walk, searching", "triangles": searching.n_triangles,
             "vertices": searching.n_vertices, "vertex look-ups": searching.vertex_lookups, "hash probes": "",
             "cells visited by for-loop (3)": "", "slot reads": ""})
print(plotting.table(rows, list(rows[0])))
assert all(same_surface(scan, i) for i in [*isos.values(), searching])

# %%
h, a, w, t = (isos[k] for k in CONSTRUCTIONS)
st = ms["walk"].stats
assert w.vertex_lookups == t.vertex_lookups == 0 < searching.vertex_lookups   # no search, and the counter is live
assert ms["table"].stats["slot_reads"] == 3 * t.n_triangles                   # the table reads each corner's slot
assert h.vertex_lookups == a.vertex_lookups == st["visits"] == ms["table"].stats["visits"]   # the same pairings
assert builder(ms["hash"]).stats["probes"] >= h.vertex_lookups                 # each search inspects >= 1 slot
# for-loop (3) registers a vertex once in each cell round its edge: the visits the kernel counted are the
# polygon vertices per cell, counted here from the triangles it wrote; each crossed cell popped once
per_cell = np.array([np.unique(w.triangles[w.triangle_cells == c]).size for c in np.unique(w.triangle_cells)])
assert per_cell.sum() == st["visits"] and st["pops"] == scan.cells_intersected
print(f"{st['visits']} visits for {st['pops']} polygons: {np.bincount(per_cell).tolist()} cells visited 0, 1, 2, ... times")

# %% [markdown]
# The paper notes the price (3.2): most cells are processed several times by for-loop (3) before
# they are taken from the FIFO once. Here every crossed tetrahedron is visited once per polygon
# vertex, three or four times — that holds by construction, so it is shown, not asserted.

# %% [markdown]
# ## Fig. 5 — the construction from the skeleton seeds
#
# The skeleton cells that the surface crosses are queued; each cell taken from the FIFO
# creates its missing vertices, and each new vertex constructs and queues the cells around its
# edge. Colour = the order in which the cells were taken from the FIFO (red dots: the seeds).
# Every part of the surface is reached from a seed of its own.

# %%
_, first = np.unique(w.triangle_cells, return_index=True)
pop_order = w.triangle_cells[np.sort(first)]          # triangles are written when their cell is popped
plot_volume.plot_propagation_order(vol, w, pop_order, seeds=seeds).show()
labels, n_parts = scan.connected_components()
print(f"{seeds.size} skeleton seeds for {n_parts} connected parts; {w.n_triangles} triangles = scan's {scan.n_triangles}")
assert len(set(labels[np.isin(scan.triangle_cells, seeds)])) == n_parts   # a seed in every part


# %% [markdown]
# ## Table 1 — the all-cell scan against volume thinning, stage by stage
#
# Twenty isovalues `linspace(min, max, 22)[1:-1]` per volume, the thesis's propagation with its
# vertex hash (`thinning`) against testing every cell (`scan`); times measured now on this
# machine (the paper's: IBM RS/6000 model 560), each value run `REPEATS` times and each stage
# kept at its minimum. The paper claims (Table 1) that thinning cuts t1 to a trifle — 0.09 s of
# 8.30 s and 0.57 s of 42.23 s, about 1 % — and with it the total, from 12.86 s to 4.29 s.

# %%
rows1, t1_data = [], {}
for name in TABLE1_DATA:
    v = datasets.load(name)
    values = isovalues(v.scalars("fem"), 20)
    sc = methods.get("scan")(v, field="fem")
    th = methods.get("thinning")(v, field="fem")
    th.extract(values[0])
    (sc_isos, sc_t, _), (th_isos, th_t, th_probes) = (timed_sweep(x, values, repeat=REPEATS) for x in (sc, th))
    assert all(same_surface(a_, b_) for a_, b_ in zip(sc_isos, th_isos))
    seed_tests = sum(th.source.query(x).n_tested for x in values)   # t1's work: the skeleton's cells tested
    t1_data[name] = dict(scan_tests=20 * v.n_cells, seed_tests=seed_tests, scan=sc_t.sum(axis=0),
                         thin=th_t.sum(axis=0), lookups=sum(i.vertex_lookups for i in th_isos), probes=th_probes,
                         t2_tests=sum(i.cells_tested for i in th_isos) - seed_tests,
                         crossed=sum(i.cells_intersected for i in th_isos))
    p = PAPER_T1[name]
    for label, t, paper in (("scan", sc_t.sum(axis=0), p[4]), ("thinning", th_t.sum(axis=0), p[5])):
        rows1.append({"data": name, "method": label, "n_c": v.n_cells, "(paper)": p[0],
                      "n_t": sum(i.n_triangles for i in sc_isos), "(paper) ": p[2],
                      "t1": t[0], "t1 paper": paper[0], "t2": t[1], "t2 paper": paper[1],
                      "t3": t[2], "t3 paper": paper[2], "total": t.sum(), "total paper": paper[3]})
print(plotting.table(rows1, list(rows1[0])))

# %% [markdown]
# **t1: the claim holds.** The cells tested to find the seeds, against the scan's 20 · n_c, are
# far below the paper's own ratio of t1 times (0.09 / 8.30 and 0.57 / 42.23).
#
# **The total: the headline does not hold here.** The paper's thinning cut the total from
# 12.86 s to 4.29 s and from 49.62 s to 7.60 s. In the benchmark (CPU time, data 1–3, rerun
# after the hash propagation got records of its own instead of the volume's cell records)
# thinning's total is 1.08–1.60 of the scan's, nearest even on the largest (the printout gives
# this run's totals). The reason is t2, not t1: in the paper the scan and the propagation took
# about the same t2 (3.80 s and 3.45 s; 6.25 s and 5.88 s), so thinning's savings in t1 went
# straight to the total. Here the propagation's t2 is 3.3–3.7 times the scan's. The scan builds the
# polygons of the cells t1 found in cell order, reading the vertex ids from an array indexed
# by the stored edge id; the propagation walks the mesh in breadth-first order, *tests* every
# face neighbour of every crossed cell in t2 (the tested cells that are not crossed are work
# the scan does not have there), and finds each vertex again by a hash search. The asserts
# check those mechanisms on the counters of this run; the times are printed.

# %%
for name, d in t1_data.items():
    p = PAPER_T1[name]
    ratio = d["seed_tests"] / d["scan_tests"]
    total_s, total_t = d["scan"].sum(), d["thin"].sum()
    print(f"{name}: seed tests {d['seed_tests']} / scan tests {d['scan_tests']} = {ratio:.2%} "
          f"(paper's t1 ratio {p[5][0] / p[4][0]:.2%}); t2 thinning / scan {d['thin'][1] / d['scan'][1]:.1f} "
          f"(paper {p[5][1] / p[4][1]:.2f}); total scan {total_s:.3f} s, thinning {total_t:.3f} s, "
          f"thinning / scan {total_t / total_s:.2f} (paper {p[5][3] / p[4][3]:.2f}); t2 tests of cells not crossed "
          f"{d['t2_tests'] - d['crossed']}, hash look-ups {d['lookups']}, probes {d['probes']}")
    assert ratio < p[5][0] / p[4][0]                            # t1's work: below the paper's t1 ratio
    assert d["t2_tests"] > d["crossed"]                         # the propagation tests cells it does not build
    assert d["probes"] >= d["lookups"] > 0                      # and searches every vertex; each search probes


# %% [markdown]
# ## Table 2 and the four constructions
#
# The paper (Table 2) measured the new construction at 0.68–0.74 of the old one's polygon
# time (t_p, "about 25 percent" faster) and 0.73–0.78 of its total ("about 20 percent"). Here
# the four constructions run on the paper's volumes 1 and 2 (all four with `POLYGEN_FULL=1`),
# twenty values each, from the same skeleton seeds, the four sweeps interleaved in every round. (What
# each holds is measured apart, below.)

# %%
rows2, res2, n_cells = [], {}, {}
for name in TABLE2_DATA:
    v = datasets.load(name)
    values = isovalues(v.scalars("fem"), 20)
    n_cells[name] = v.n_cells
    scan_isos = [extract(v, x, field="fem") for x in values]
    out, ms = {}, {label: prepare_construction(CONSTRUCTIONS[label], v) for label in CONSTRUCTIONS}
    for m in ms.values():
        m.extract(values[len(values) // 2])
    swept = timed_sweeps(ms, values, repeat=REPEATS)  # interleaved: every construction under the same load
    for label, (isos2, t, probes) in swept.items():
        assert all(same_surface(a_, edge_keyed(CONSTRUCTIONS[label], b_, v)) for a_, b_ in zip(scan_isos, isos2))
        out[label] = dict(t=t.sum(axis=0), lookups=sum(i.vertex_lookups for i in isos2), probes=probes)
        rows2.append({"data": name, "n_c": v.n_cells, "construction": label, "t1": t[:, 0].sum(),
                      "t2 (t_p)": t[:, 1].sum(), "t3": t[:, 2].sum(), "total": t.sum(),
                      "look-ups": out[label]["lookups"], "probes": probes})
    res2[name] = out
print(plotting.table(rows2, list(rows2[0])))

# %% [markdown]
# The paper's Table 2 beside ours: the old construction is `hash`, the new one `walk` (both
# FIFO, from the skeleton). Times are not comparable across machines; the ratios are. The paper's
# claim, asserted per volume, is that the new construction takes less time than the old; its own
# ratios are printed beside ours (on data 3 ours has measured from 0.50 to 0.69 in different runs
# against the paper's 0.68, so asserting its exact ratio would test the machine's load, not the
# method).

# %%
rows_t2 = []
for name, out in res2.items():
    p = PAPER_T2[name]
    h, w = out["hash"]["t"], out["walk"]["t"]
    rows_t2.append({"data": name, "n_c": n_cells[name], "(paper)": p[0], "t_p old": h[1], "(paper) ": p[3], "t_p new": w[1], "(paper)  ": p[4],
                    "t_p new/old": w[1] / h[1], "paper ratio": p[4] / p[3], "total old": h.sum(), "(paper)   ": p[5],
                    "total new": w.sum(), "(paper)    ": p[6], "total new/old": w.sum() / h.sum(),
                    "paper ratio ": p[6] / p[5]})
print(plotting.table(rows_t2, list(rows_t2[0])))
for r in rows_t2:   # the paper's claim on each of its volumes: the new construction takes less time than the old
    assert r["t_p new/old"] < 1, r   # (its measured ratios, 0.68-0.74, are printed beside ours: a CPU-time
    assert r["total new/old"] < 1, r  # ratio within a few % of them moves with the machine's load)

# %% [markdown]
# ## Memory: the bytes each construction holds
#
# The paper's reason for not storing edges is memory, so each construction's memory is measured
# the same way, written down before the run (`construction_memory`): a freshly loaded volume, its
# face neighbours built (every construction and the thinning read them; not counted); then the
# builder alone is prepared and extracts the middle value from the skeleton's seeds. Counted, each
# buffer once: every array the builder holds, and every table it made the volume build — for
# `array` the cell records with edge ids and the edge table, for `table` the edge table. `hash`
# and `walk` key their vertices by node pairs and store no edge anywhere; the rows `+ labels` are
# them labelling the vertices by edge id, as the registered methods do by default, which makes the
# volume build its edge table. The process's resident memory, read before and after, is printed
# beside as a check (a test holds it within 10 % of the count on data 2).

# %%
MEMORY_ROWS = [("hash", "hash", False), ("array", "array", False), ("walk", "walk-fifo", False),
               ("table", "table-fifo", False), ("hash + labels", "hash", True), ("walk + labels", "walk-fifo", True)]
memo, rows_m = {}, []
for name in TABLE2_DATA:
    v = datasets.load(name)
    value_m = isovalues(v.scalars("fem"), 20)[10]
    seeds_m = seed_source(v, "fem", "thinning", edge_table_aside=False).query(value_m).cells
    memo[name] = {}
    for row, label, labels in MEMORY_ROWS:
        r = construction_memory(label, datasets.load(name), value_m, seeds_m, rss=True, labels=labels)
        memo[name][row] = r
        rows_m.append({"data": name, "construction": row, "builder B/cell": r["builder"] / r["cells"],
                       "volume tables built B/cell": sum(r["volume"].values()) / r["cells"],
                       "which": ", ".join(r["volume"]) or "-", "total B/cell": r["total"] / r["cells"],
                       "total MB": r["total"] / 1e6, "RSS / total": r["rss"] / r["total"]})
print(plotting.table(rows_m, list(rows_m[0])))

# %% [markdown]
# Until this count, `hash` reported 46 bytes per tetrahedron (2.86 MB on data 2) while it held the
# volume's cell records with their edge ids and the whole edge table it had made the volume build
# for them (about 7.7 MB); the walk's edge-id labelling had its edge list left out and the cells'
# edge ids never counted. Now `hash` reads records of its own (nodes and face neighbours, 32 bytes
# a tetrahedron) and holds what it reports. What the paper's premise says, asserted per volume on
# this count: storing edges costs memory (`array` above `hash`, `table` above `walk`), and the
# constructions without stored edges make the volume build no edge table.

# %%
for name, mm in memo.items():
    assert mm["hash"]["volume"] == {} and mm["walk"]["volume"] == {}                     # no edges stored
    assert mm["array"]["total"] > mm["hash"]["total"] and mm["table"]["total"] > mm["walk"]["total"]
    print(f"{name}: walk / hash {mm['walk']['total'] / mm['hash']['total']:.2f}, table / walk "
          f"{mm['table']['total'] / mm['walk']['total']:.2f}, array / hash {mm['array']['total'] / mm['hash']['total']:.2f}"
          f"; with edge-id labels walk / hash {mm['walk + labels']['total'] / mm['hash + labels']['total']:.2f}")

# %% [markdown]
# ## Which speed-up comes from removing the search, which from storing edges
#
# * **removing the search without stored edges** — `walk` against `hash`: the paper's comparison,
#   the claim above;
# * **removing the search when edges are stored** — `array` against `hash` is not it: `array`
#   still looks every vertex up (as many look-ups as `hash`), but by one array read at the edge
#   id instead of a hash search; it measures what *storing edges* buys a search;
# * **storing edges when there is no search** — `table` against `walk`: the same for-loops,
#   the cells round an edge read from a list instead of found by walking;
# * `table` against `array`: removing the search when the edges are stored.
#
# The paper's reason for not storing edges is memory; the last columns say what each costs here.
#
# In the benchmark (data 1–5 and 2M, CPU time, `benchmarks/results/fast_construction.md`, rerun
# with the memory counted from the arrays held) the paper's speed-up is the removal of the search:
# `walk` takes 0.50–0.73 of `hash`'s t2 (0.70 on data 2, 0.50–0.54 on data 3–5), against the
# paper's 0.68–0.74. Storing the edges does little for a search (`array` / `hash` 0.84–1.06: a
# stamped hash keyed by node pairs costs about what an array read at the edge id costs, once
# neither is cleared in the timed step) but much for the edge-centred loop (`table` / `walk`
# 0.55–0.69: reading the cells round an edge from a list instead of walking to them), for 1.6–1.7
# times the memory (the edge table the volume builds for it included). That is why `edge-centred-table` is the fastest of the
# four, and `edge-centred` is the paper's method as the paper states it. (`vol.isosurface` used
# `edge-centred-table` by default until it got a construction that walks nothing at all: the
# section "Beyond the paper" below.)

# %%
rows_i = []
for name, out in res2.items():
    t2 = {k: out[k]["t"][1] for k in out}
    mem = {k: memo[name][k]["total"] for k in out}
    rows_i.append({"data": name, "walk/hash (no search, no edges)": t2["walk"] / t2["hash"],
                   "array/hash (edges, search kept)": t2["array"] / t2["hash"],
                   "table/walk (edges, no search)": t2["table"] / t2["walk"],
                   "table/array (no search, edges)": t2["table"] / t2["array"],
                   "MB hash": mem["hash"] / 1e6, "MB array": mem["array"] / 1e6, "MB walk": mem["walk"] / 1e6,
                   "MB table": mem["table"] / 1e6})
print(plotting.table(rows_i, list(rows_i[0])))

# %% [markdown]
# What the counters of this run say, whatever the clock did: removing the hash does not remove
# the look-ups (`array` makes exactly as many as `hash`, each one array read and no probe);
# the edge-centred constructions make none; and storing edges costs memory — the edge → cells
# lists and the edge table of `table`, the cell records with edge ids and the edge table of
# `array`. One thing does not follow the paper's premise here, and it still holds now that
# `hash`'s memory is counted from what it holds (it holds no edges): `walk` needs *more* memory
# than `hash` (1.5–2.1 times on data 1–5 and 2M in the benchmark), because it keeps a vertex slot per local edge and node
# for every cell (40 bytes a tetrahedron, in 80-byte records), where `hash` keeps 32-byte records
# and a table sized for the largest surface only. Labelling by edge id narrows the gap (the same
# edge table on both sides) but does not close it. The walk is faster than `hash` either way.

# %%
for name, out in res2.items():
    h, a, w, t = (out[k] for k in CONSTRUCTIONS)
    assert h["lookups"] == a["lookups"] > 0 and w["lookups"] == t["lookups"] == 0
    assert h["probes"] >= h["lookups"] and a["probes"] == 0
    mm = {k: memo[name][k]["total"] for k in ("hash", "array", "walk", "table")}
    assert mm["table"] > mm["walk"] and mm["array"] > mm["hash"]          # storing edges costs memory
    assert mm["walk"] > mm["hash"]                                        # and the walk needs more than hash
    print(f"{name}: memory held, MB: hash {mm['hash'] / 1e6:.1f}, array {mm['array'] / 1e6:.1f}, "
          f"walk {mm['walk'] / 1e6:.1f}, table {mm['table'] / 1e6:.1f}; walk / hash {mm['walk'] / mm['hash']:.2f}")

# %% [markdown]
# ## The hexahedral version (the paper's future work)
#
# The same loop on hexahedral volumes: twelve local edges, eight nodes, the marching-hexahedra
# polygons (face-centre rule on ambiguous faces), and the walk round an edge crosses the two
# faces of each hexahedron that contain it (four cells round an edge inside the volume).

# %%
rows_h = []
for name in HEX_DATA:
    v = datasets.load(name)
    values = isovalues(v.scalars("fem"), 20)
    ref = [extract(v, x, field="fem") for x in values]
    got = {}
    for label in ("hash", "walk", "table"):
        m = prepare_construction(CONSTRUCTIONS[label], v)
        got[label] = ([edge_keyed(CONSTRUCTIONS[label], m.extract(x), v) for x in values],
                      [dict(m.stats) for x in values])
    (old, _), (new, st), (tab, _) = got["hash"], got["walk"], got["table"]
    assert all(same_surface(a_, b_) and same_surface(a_, c_) and same_surface(a_, d_)
               for a_, b_, c_, d_ in zip(ref, old, new, tab))
    rows_h.append({"data": name, "cells": v.n_cells, "triangles": sum(i.n_triangles for i in new),
                   "look-ups hash": sum(i.vertex_lookups for i in old),
                   "look-ups walk / table": f"{sum(i.vertex_lookups for i in new)} / "
                                            f"{sum(i.vertex_lookups for i in tab)}"})
print(plotting.table(rows_h, list(rows_h[0])))
assert all(r["look-ups hash"] > 0 and r["look-ups walk / table"] == "0 / 0" for r in rows_h)

# %% [markdown]
# ## The benchmark
#
# `benchmarks/fast_construction.py` runs the same comparison on all five volumes, the
# 2-million-cell one and the 10-million-cell one (its analytic field `gaussians`: no FEM
# solve at that size), with `vtkContourFilter` beside. The results committed in
# `benchmarks/results/fast_construction.md` are its rerun on data 1–5 and 2M with VTK (not 10M:
# building that volume did not finish on the shared machine), after the memory count was made
# honest and the look-up counters made to count the reads they name; polygen's times there are
# CPU seconds on one thread, VTK's wall seconds on two. They are shown here as recorded, for
# reading; nothing above rests on them, and no assert reads them.

# %%
RESULTS = Path(polygen.__file__).resolve().parents[1] / "benchmarks" / "results" / "fast_construction.json"
bench = json.loads(RESULTS.read_text()) if RESULTS.exists() else {"rows": []}
rows_b = []
for r in bench["rows"]:
    m = r["methods"]
    rows_b.append({"data": r["data"], "cells": r["cells"], **{f"t2 {k}": m[k]["t2"] for k in
                   ("hash", "array", "walk-fifo", "table-fifo")},
                   **{f"MB {k}": m[k]["memory_total"] / 1e6 for k in ("hash", "array", "walk-fifo", "table-fifo")},
                   "total walk-lifo": m["walk-lifo"]["query_s"],
                   "vtk+spanspace (wall, 2 threads)": m.get("vtk+spanspace", {}).get("query_s", float("nan"))})
if rows_b:
    print(plotting.table(rows_b, list(rows_b[0])))

# %%
if len(rows_b) >= 2:
    cells = np.array([r["cells"] for r in bench["rows"]], float)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for key in ("scan", "hash", "array", "walk-lifo", "table-lifo"):
        if all(key in r["methods"] for r in bench["rows"]):
            t = np.array([r["methods"][key]["query_s"] / 20 for r in bench["rows"]])
            ax.loglog(cells, t * 1e3, "o-", label=f"{key} (slope {plot_volume.loglog_slope(cells, t):.2f})")
    ax.set_xlabel("cells")
    ax.set_ylabel("CPU ms per isovalue (mean of 20, recorded)")
    ax.legend(fontsize=8)
    plt.show()

# %% [markdown]
# ## Beyond the paper: a construction that walks nothing
#
# The edge-centred loop removes the vertex search. What is left of its cost on today's
# processors is the walk itself: a chain of dependent loads (a cell's record, the cells round
# one of its edges, their records), each into arrays far larger than the caches. Our
# `active-scan` (`polygen.volume.active_scan`) has no walk:
#
# * the cells are stored in **span-space order** (Livnat, Shen & Johnson 1996): in rows of
#   their minimum, each row sorted by maximum. The cells a value crosses are then a prefix of
#   every row below the value: one binary search per row;
# * the table holds each cell's nodes and edge ids in that order, so the scan streams through it;
#   on a volume of 32,768 cells or more the order is kept per **block** of 16,384 consecutive cells
#   (neighbours in the volume), so that a query's reads of node values and vertices stay near each other,
#   each block with rows of its own (equally filled by its cells' minima);
# * every edge has one **owner**, its first cell, fixed when the table is built. Every cell of a
#   crossed edge is crossed, so the owner is among the scanned cells and makes the edge's vertex:
#   no search, and no registration into the neighbours.
#
# It tests the crossed cells and at most one row more in each block (the row whose bounds hold the value).
# Below: data 3 (2M with `POLYGEN_FULL=1`), the same twenty values, against the edge-centred
# construction with the edge table, both on one core as above. The bytes per cell are what each
# method holds itself (`memory_bytes()`), the volume's tables apart: both read the volume's edge
# table (the table's records are built from it, and active-scan's table holds each cell's edge ids).
# `vol.isosurface` uses it by default; `benchmarks/results/interactive.md` has both on two cores
# against VTK's strongest configuration.

# %%
BEYOND = "2M" if FULL else "data3"
vb = datasets.load(BEYOND, field="fem")
sb = vb.scalars("fem")
values_b = isovalues(sb, 20)
cell_min, cell_max = sb[vb.cells].min(axis=1), sb[vb.cells].max(axis=1)
beyond = {name: methods.get(name)(vb, field="fem") for name in ("edge-centred-table", "active-scan")}
widest_row = int(np.diff(beyond["active-scan"].scan.row_off).max())  # one row of one block
n_blocks = beyond["active-scan"].scan.block_min.size
runs_b = {name: [] for name in beyond}
for _ in range(REPEATS):
    for name, m in beyond.items():
        t0 = time.perf_counter()
        runs_b[name].append([m.extract(x) for x in values_b])
        runs_b[name][-1] = (time.perf_counter() - t0, runs_b[name][-1])
rows_y = []
for name, runs in runs_b.items():
    surfaces = runs[-1][1]
    rows_y.append({"construction": name, "s per 20 values (median)": float(np.median([t for t, _ in runs])),
                   "cells tested": sum(i.cells_tested for i in surfaces),
                   "cells crossed": sum(i.cells_intersected for i in surfaces),
                   "triangles": sum(i.n_triangles for i in surfaces),
                   "bytes per cell held (volume tables apart)": beyond[name].memory_bytes() / vb.n_cells})
print(plotting.table(rows_y, list(rows_y[0])))
print(f"{BEYOND}: {vb.n_cells} cells; active-scan's blocks: {n_blocks}, rows (all blocks): "
      f"{beyond['active-scan'].scan.row_off.size - 1}, the widest {widest_row} cells")

# %%
for x, a_, b_ in zip(values_b, runs_b["edge-centred-table"][-1][1], runs_b["active-scan"][-1][1]):
    crossed = int(np.sum((cell_min < x) & (cell_max >= x)))
    assert same_surface(a_, b_)                                        # the same surface
    assert b_.cells_intersected == crossed <= b_.cells_tested <= crossed + n_blocks * widest_row
assert rows_y[1]["bytes per cell held (volume tables apart)"] < rows_y[0]["bytes per cell held (volume tables apart)"]

# %% [markdown]
# ## Volumes larger than one machine
#
# A billion-cell result does not fit one machine (its cell indices alone are ≈ 32 GB), and
# solvers that run on clusters write it in pieces anyway. `PartitionedVolume` holds such
# pieces (or splits one volume into `K` Morton ranges of cells); each partition is prepared
# once on a Dask worker and kept there (an actor), every partition extracts its part of a
# surface with the normals of its own vertices, and the parts are **stitched on the
# workers**: merged pairwise up a tree of neighbouring partitions, only the seam vertices
# (both nodes of their edge on another partition too) matched by the pair of *global* node
# ids of their edge and kept once, their normals made at the root — only the stitched
# surface travels to the client. Here data 3 in four partitions on a `LocalCluster` of two
# worker processes, twenty values, against the single volume, stitched on the workers as a
# cluster would (`stitch_on="workers"`; by default, `"auto"`, a cluster whose workers all
# run on the client's machine stitches on the client instead: the workers report their counts and
# seam vertices, the client lays the stitched arrays out in one shared-memory block, and each
# worker writes its own rows of them there — on two cores that is faster than the tree,
# `benchmarks/results/partitioned.md`).

# %%
from polygen.volume.distributed import local_client
from polygen.volume.distributed import prepare as dask_prepare
from polygen.volume.partitioned import PartitionedVolume, scale_model

big = datasets.load("data3")
values_p = isovalues(big.scalars("fem"), 20)
single_p = methods.get(methods.DEFAULT)(big, field="fem").extract_many(values_p)
pvol = PartitionedVolume.split(big, 4)
client = local_client(2)                       # 2 worker processes, 1 thread each
on_dask = dask_prepare(pvol, "fem", client=client, stitch_on="workers")
stitched = on_dask.extract_many(values_p)
for a_, b_ in zip(single_p, stitched):         # the stitched surface is the single volume's
    assert (b_.n_triangles, b_.n_vertices) == (a_.n_triangles, a_.n_vertices)
    assert abs(b_.area() - a_.area()) <= 1e-9 * a_.area()
print(f"{len(values_p)} values: {sum(s.n_triangles for s in stitched)} triangles, "
      f"{sum(s.n_vertices for s in stitched)} vertices, as the single volume; "
      f"{sum(s.seam_vertices for s in stitched)} seam vertices made on two sides and kept once")

# %% [markdown]
# What each partition did over the twenty values (its worker, its preparation there, the
# cells its surface parts crossed, its extraction work t1 + t2 + t3, the crossed seam cells
# it propagated from), and the bytes one query moved: the pieces the partitions made, the
# part of them that crossed from one worker to the other to be merged, and the stitched
# surfaces that reached the client.

# %%
rows_p = [{"partition": i, "worker": on_dask.placement[i].rsplit(":", 1)[-1], "cells": inf["n_cells"],
           "prepare s": on_dask.prepare_s[i], "crossed": sum(s.partitions[i]["cells_intersected"] for s in stitched),
           "triangles": sum(s.partitions[i]["n_triangles"] for s in stitched),
           "work s": sum(s.partitions[i]["t1"] + s.partitions[i]["t2"] + s.partitions[i]["t3"] for s in stitched),
           "seam seeds": sum(s.partitions[i]["seam_seeds"] for s in stitched)} for i, inf in enumerate(on_dask.infos)]
print(plotting.table(rows_p, list(rows_p[0])))
n_tri = sum(s.n_triangles for s in stitched)
print(f"per query of {len(values_p)} values: pieces made {on_dask.bytes_pieces_last / 1e6:.2f} MB, "
      f"between workers {on_dask.bytes_workers_last / 1e6:.2f} MB, to the client {on_dask.bytes_last / 1e6:.2f} MB "
      f"({on_dask.bytes_pieces_last / n_tri:.1f}, {on_dask.bytes_workers_last / n_tri:.1f}, "
      f"{on_dask.bytes_last / n_tri:.1f} bytes per triangle); stitch work on the workers "
      f"{sum(s.stitch_s for s in stitched):.3f} s ({sum(s.stitch_cpu_s for s in stitched):.3f} s of CPU)")
# neighbours share a worker: the lower merges move nothing, the root merges one side
assert 0 < on_dask.bytes_workers_last < on_dask.bytes_pieces_last

# %%
plot_volume.plot_partitions(big, stitched[9], pvol.partition_of_cells()).show()

# %% [markdown]
# ### The 1B-cell volume on 64 workers, on paper
#
# From the costs measured in this run — preparation seconds per cell `p` (the partitions'
# own preparation on their workers, summed, over the cells), extraction seconds per crossed
# cell `q`, stitch (merge + normals) seconds per triangle `s`, bytes per triangle of the
# pieces `b_p` and of the stitched surface `b_s` — and with `X`, `T` the crossed cells and
# triangles per value here (`n` cells), a volume of `N = 10⁹` cells on `W = 64` workers:
#
# * surfaces grow with area: `g = (N / n)^(2/3)`, so `X' = g X`, `T' = g T`;
# * preparation, each worker its own `N / W` cells, in parallel: `p N / W`;
# * extraction per value, spread evenly: `q X' / W`;
# * stitch per value, a tree of `log₂ W = 6` levels whose merge at level `l` handles
#   `2^l / W` of the surface: `s T' (2 − 2/W)` on the critical path;
# * network per value: `b_p T' log₂W / 2` between workers (half of each level moves), of which
#   `b_p T' (1 − 1/W)` on the critical path, and `b_s T'` to the client, at 10 Gb/s;
# * a sweep of `V = 20` values: the tree's merges spread over the workers, each value's root on
#   another worker, `s T' max(V log₂W / W, 2 − 2/W)`, where one client stitching every value
#   needs `s T' V` and takes in every piece (`V b_p T'`) through its one link.
#
# For one value the tree is no faster than a stitch on the client (its root merges the whole
# surface, after the levels below it); what it removes is the client as the place every value's
# stitch and every piece must pass through.
#
# Assumed: the same field shape on a finer mesh; one partition per worker, read where it lives
# (no volume moves); costs per cell as measured here on one thread, whatever the partition
# size; no imbalance between workers. The stitch rate `s` is this run's merge work per triangle
# (CPU time: this machine is shared) per triangle and per tree level (two levels for four partitions).

# %%
levels_p = int(np.log2(pvol.n_partitions))
rates = dict(n_cells=big.n_cells, crossed_per_value=sum(s.cells_intersected for s in stitched) / len(values_p),
             triangles_per_value=n_tri / len(values_p), prepare_s_per_cell=sum(on_dask.prepare_s) / big.n_cells,
             query_s_per_crossed_cell=sum(r["work s"] for r in rows_p) / sum(r["crossed"] for r in rows_p),
             stitch_s_per_triangle=sum(s.stitch_cpu_s for s in stitched) / n_tri / levels_p,
             piece_bytes_per_triangle=on_dask.bytes_pieces_last / n_tri,
             surface_bytes_per_triangle=on_dask.bytes_last / n_tri)
model = scale_model(**rates, target_cells=1e9, workers=64)
print(plotting.table([{"rate": k, "measured here": v} for k, v in rates.items()], ["rate", "measured here"]))
print(plotting.table([
    {"1e9 cells, 64 workers": "triangles per value", "predicted": model["triangles"]},
    {"1e9 cells, 64 workers": "preparation s (per worker, in parallel)", "predicted": model["prepare_s"]},
    {"1e9 cells, 64 workers": "extraction s per value", "predicted": model["extract_s"]},
    {"1e9 cells, 64 workers": "stitch s per value (critical path)", "predicted": model["stitch_s"]},
    {"1e9 cells, 64 workers": "transfer s per value (critical path + client)", "predicted": model["transfer_s"]},
    {"1e9 cells, 64 workers": "latency s per value", "predicted": model["latency_s"]},
    {"1e9 cells, 64 workers": "stitch s, sweep of 20: tree on the workers", "predicted": model["sweep_stitch_workers_s"]},
    {"1e9 cells, 64 workers": "stitch s, sweep of 20: one client", "predicted": model["sweep_stitch_client_s"]},
    {"1e9 cells, 64 workers": "MB between workers per value", "predicted": model["bytes_between_workers"] / 1e6},
    {"1e9 cells, 64 workers": "MB to the client per value", "predicted": model["bytes_to_client"] / 1e6},
], ["1e9 cells, 64 workers", "predicted"]))

# %%
on_dask.close()
client.close()
client.cluster.close()
