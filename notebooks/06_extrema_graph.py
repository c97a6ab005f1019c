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
# # Chapter 6 — the extrema graph
#
# Itoh's first fast isosurface method. A **closed** isosurface encloses a local maximum or
# minimum on each side (Thm 6.1), so a graph whose arcs join all the extrema crosses it
# (Thm 6.2); an isosurface **with boundary** touches the volume's boundary. Preprocessing
# therefore (Fig. 6.4):
#
# 1. finds the extrema with per-cell "not-maximum / not-minimum" marks (6.3.1, Fig. 6.5),
# 2. joins them, nearest first, by arcs walked cell by cell through face neighbours — straight
#    segments, or polylines where the straight segment would leave the volume (6.3.2), each
#    arc keeping its cells and its value range [S_min, S_max],
# 3. sorts the boundary cells by S_min and by S_max (6.3.3).
#
# A query tests the cells of the arcs whose range holds C and the boundary cells on the near
# side of C, and grows the surface from every hit by propagation (6.3.4). Everything here is
# `polygen.volume.extrema_graph`; the figures come from `polygen.plotting.extrema`.

# %%
import os
import time

FULL = os.environ.get("POLYGEN_FULL") == "1"   # all data sets and the long sweep when set

import numpy as np
from scipy.spatial import Delaunay

from polygen import plotting
from polygen.plotting import extrema as plot_extrema
from polygen.volume import datasets, methods
from polygen.volume.extrema_graph import ARC_KINDS, build_extrema_graph, extrema_graph_2d, find_extrema
from polygen.volume.isosurface import extract

pv = plotting.setup_notebook()

# %%
TABLE_DATA = ["data1", "data2", "data3", "data4"]   # Tables 6.1-6.5: fits in the default run
NOISE = [0.003, 0.004, 0.005, 0.006, 0.008, 0.01, 0.012] if FULL else [0.004, 0.006]
THESIS = {  # Tables 6.1-6.5, data 1-4 (IBM RS/6000 model 560)
    "N_e": [20736, 61680, 346644, 557868], "N_b": [2048, 5432, 16908, 17876], "N_n": [4002, 11624, 62107, 97473],
    "T_sort": [1.228, 6.259, 38.027, 58.579], "T_filt": [0.285, 0.647, 4.084, 6.589],
    "T_egra": [0.684, 1.823, 8.028, 15.229],
    "T_pe": [0.541, 1.382, 6.290, 9.719], "T_pc": [0.062, 0.166, 0.600, 4.151], "T_pb": [0.081, 0.275, 1.138, 1.359],
    "extrema": [21, 46, 135, 540], "N_g": [468, 1048, 3250, 10210], "N_pa": [1, 0, 16, 36],
    "Q_all": [5.068, 11.416, 63.113, 103.072], "Q_sort": [2.696, 3.142, 12.125, 20.717],
    "Q_filt": [2.800, 3.945, 17.801, 22.153], "Q_egra": [2.065, 2.561, 6.524, 11.786],
    "T_mg": [0.008, 0.088, 0.248, 0.197], "T_mb": [0.019, 0.032, 0.091, 0.144],
    "T_mt": [1.471, 1.748, 4.495, 8.331], "T_mv": [0.567, 0.693, 1.690, 3.114],
    "N_cg": [3063, 4774, 15659, 14196], "N_ci": [51357, 62377, 148836, 277457],
}

# %% [markdown]
# ## Fig. 6.1 — closed isosurfaces and isosurfaces with boundary
#
# The method sorts isosurfaces into two kinds (6.2): **closed** surfaces, which enclose a
# region of the volume, and surfaces **with boundary**, which end on the volume's boundary.
# One isosurface of data 1's field can have parts of both kinds:

# %%
vol1 = datasets.load("data1")
s1 = vol1.scalars()
iso61 = extract(vol1, float(np.quantile(s1, 0.8)))
parts61 = iso61.components()
plot_extrema.plot_closed_and_open(vol1, iso61).show()
# a part is closed exactly when none of its edges is used by one triangle only, and an open edge lies on the boundary
t61 = iso61.triangles
e61 = np.sort(np.concatenate([t61[:, [0, 1]], t61[:, [1, 2]], t61[:, [2, 0]]]), axis=1)
u61, inv61, cnt61 = np.unique(e61, axis=0, return_inverse=True, return_counts=True)
has_open = np.zeros(parts61["closed"].size, bool)
has_open[np.tile(iso61.triangle_components(), 3)[cnt61[inv61.ravel()] == 1]] = True
assert np.array_equal(~has_open, parts61["closed"]) and parts61["closed"].any() and not parts61["closed"].all()

# %% [markdown]
# ## Fig. 6.2 — the idea in two dimensions
#
# A field on a triangulated square: its contours, its maxima (▲) and minima (▼), found with the
# same marks as in 3D (Fig. 6.5 works for any cell), and the graph that joins every extremum
# to the nearest one of another component (Fig. 6.6). The thick contours are closed curves:
# each has an extremum inside and outside, so some arc crosses it.

# %%
rng = np.random.default_rng(6)
pts2 = np.vstack([rng.random((900, 2)), [[0, 0], [1, 0], [0, 1], [1, 1]]])
tri2 = Delaunay(pts2).simplices.astype(np.int64)
f2 = (np.exp(-((pts2 - [0.3, 0.35]) ** 2).sum(1) / 0.02) - 0.8 * np.exp(-((pts2 - [0.7, 0.65]) ** 2).sum(1) / 0.03)
      + 0.5 * np.exp(-((pts2 - [0.75, 0.2]) ** 2).sum(1) / 0.01) + 0.3 * pts2[:, 1])
ext2, arcs2 = extrema_graph_2d(pts2, tri2, f2)
closed = [0.75, -0.35]
plot_extrema.plot_2d_graph(pts2, tri2, f2, ext2, arcs2, highlight=closed);

# %%
# Thm 6.2 on this picture: the region inside each thick contour -- the nodes on the extremum's side of it,
# joined through triangle edges -- touches no side of the square (the contour is closed), holds an
# extremum, and some arc has one end inside it and the other outside: the arc crosses that contour
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

print(f"{ext2.n} extrema ({len(ext2.maxima)} maxima, {len(ext2.minima)} minima), {len(arcs2)} arcs")
e2 = np.concatenate([tri2[:, [0, 1]], tri2[:, [1, 2]], tri2[:, [2, 0]]])
for c in closed:
    inside_side = f2 >= c if c > 0 else f2 <= c            # 0.75 rings a maximum, -0.35 a minimum
    keep = inside_side[e2[:, 0]] & inside_side[e2[:, 1]]
    _, lab = connected_components(coo_matrix((np.ones(keep.sum()), tuple(e2[keep].T)), shape=(len(f2),) * 2))
    centre = ext2.maxima[np.argmax(f2[ext2.maxima])] if c > 0 else ext2.minima[np.argmin(f2[ext2.minima])]
    region = inside_side & (lab == lab[centre])
    on_side = (pts2.min(axis=1) == 0) | (pts2.max(axis=1) == 1)
    assert not (region & on_side).any() and region[ext2.nodes].any(), c
    assert np.any(region[arcs2[:, 0]] != region[arcs2[:, 1]]), c

# %% [markdown]
# ## Fig. 6.5 — extrema by marks
#
# Every cell marks all its nodes but the largest "not-maximum" and all but the smallest
# "not-minimum"; ties at a cell's extreme get a "plural" mark. Unmarked nodes are extrema;
# a node with a plural mark stands for its flat group of tied nodes, which is then cleared, so
# each flat group (e.g. a Dirichlet patch held at one temperature) gives one extremum.
# Def. 6.3 compares a node with all nodes of its cells, so in hexahedra the face and body
# diagonals count too; `datasets.node_extrema` (strict, over edges) is printed beside.

# %%
rows = []
for name in ["data1", "hexa1"] + TABLE_DATA[1:]:
    vol = datasets.load(name)
    ext = find_extrema(vol)
    strict_max, strict_min = datasets.node_extrema(vol)
    rows.append({"data": name, "maxima": int(ext.is_max.sum()), "minima": int(ext.is_min.sum()),
                 "flat groups": ext.n_flat, "strict max": len(strict_max), "strict min": len(strict_min),
                 "not-max marks": int(ext.not_max.sum()), "plural-max marks": int(ext.plural_max.sum()),
                 "nodes": vol.n_points})
    if vol.cell_type == "tetra":  # cell-mates are edge neighbours: every strict extremum is one of ours
        assert np.isin(strict_max, ext.maxima).all() and np.isin(strict_min, ext.minima).all()
print(plotting.table(rows, list(rows[0])))

# %% [markdown]
# ## Figs 6.12 and 6.13 — extrema graphs
#
# Purple: the extrema; lines: the arcs through the centroids of their cells, coloured by value.

# %%
g1 = build_extrema_graph(vol1, record=True)   # record: every try of the construction, for Figs 6.6-6.10
plot_extrema.plot_graph(vol1, g1, title=f"data 1: {g1.stats['extrema']} extrema, {g1.n_arcs} arcs").show()

# %%
volh = datasets.load("hexa1")
gh = build_extrema_graph(volh)
plot_extrema.plot_graph(volh, gh, title=f"hexahedral data 1: {gh.stats['extrema']} extrema", show_cells=True).show()

# %% [markdown]
# ## Fig. 6.3 — the extrema graph and the boundary cell lists
#
# The two structures of preprocessing (Defs 6.6–6.9): the arcs, each with the cells it passes
# and their value range, and the boundary cells in two lists sorted by S_min and by S_max.
# For a value C the cells with S_min < C are a prefix of the first list, those with
# S_max ≥ C a suffix of the second; the query scans the shorter one (6.3.4).

# %%
plot_extrema.plot_graph_and_boundary(vol1, g1).show()
v63 = float(np.quantile(s1, 0.8))
plot_extrema.plot_boundary_lists(g1, v63);
bv = s1[vol1.cells[vol1.boundary_cells]]
n_lo, n_hi = int((bv.min(axis=1) < v63).sum()), int((bv.max(axis=1) >= v63).sum())
assert g1.boundary_candidates(v63)[0].size == min(n_lo, n_hi)   # the shorter side, counted from the cells

# %% [markdown]
# ## Figs 6.6–6.10 — how the arcs are made, from the construction's own record
#
# Fig. 6.10's loop: for each extremum in turn (the start point), the extrema with another
# number are sorted by distance and tried nearest first — a straight segment walked cell by
# cell (Fig. 6.7); if it leaves the volume, the next one (Fig. 6.8); if no straight segment
# reaches one, a polyline that always crosses the face nearest the goal (Fig. 6.9). When an
# arc is made, both ends take the smaller of their numbers, and so does every extremum that
# had the larger (Fig. 6.6). `build_extrema_graph(..., record=True)` logs every try; the trace
# of data 1 (its one failed try included), then the numbers replayed arc by arc:

# %%
rec1 = g1.record
shown = sorted(set(range(6)) | set(np.flatnonzero(~rec1.ok).tolist()))
print(plotting.table(plot_extrema.try_rows(g1, shown), ["try", "start", "goal", "walk", "reached", "cells"]))
numbers = rec1.components(g1.extrema.n)
plot_extrema.plot_numbering(rec1, g1.extrema.n);
# the replay ends in the kernel's own numbers; each arc joins two numbers into one; the arcs are the tries
# that reached their goal, cell for cell; the failed straight tries are those the stats count
assert np.array_equal(numbers[-1], g1.component) and len(np.unique(numbers[-1])) == 1
assert [len(np.unique(n)) for n in numbers] == list(range(g1.extrema.n, g1.extrema.n - g1.n_arcs - 1, -1))
assert all(np.array_equal(rec1.try_cells(k), g1.arc(a)) for a, k in enumerate(np.flatnonzero(rec1.ok)))
assert np.sum(~rec1.ok & (rec1.kind == 0)) == g1.stats["straight_failures"]

# %% [markdown]
# Data 1's arcs are all straight. A cube with a cubic void, the maximum and the minimum on
# either side of it, needs a polyline: the straight segment runs into the void. Left to
# right: data 1's longest straight arc (Fig. 6.7); the failed try of data 1, whose segment
# leaves through a bolt hole, and the next-nearest extremum it then reached (Fig. 6.8); the
# cube's failed segment and its polyline (Fig. 6.9). Reached: green; failed: red.

# %%
hc = datasets.load("hollow_cube")
f_hc = np.exp(-((hc.points - [0, 1, 1]) ** 2).sum(1)) - np.exp(-((hc.points - [3, 2, 2]) ** 2).sum(1))
g_hc = build_extrema_graph(hc, f_hc, record=True)
print(plotting.table(plot_extrema.try_rows(g_hc), ["try", "start", "goal", "walk", "reached", "cells"]))
straight = np.flatnonzero(rec1.ok & (rec1.kind == 0))
k67 = straight[np.argmax(np.diff(rec1.offsets)[straight])]
k68 = np.flatnonzero(~rec1.ok)[0]
k68b = np.flatnonzero(rec1.ok & (rec1.start == rec1.start[k68]))[0]
plot_extrema.plot_tries([(vol1, g1, [k67], "Fig. 6.7: a straight arc"),
                         (vol1, g1, [k68, k68b], "Fig. 6.8: the segment leaves; the next one"),
                         (hc, g_hc, list(range(g_hc.record.n_tries)), "Fig. 6.9: a polyline around the void")]).show()
assert [ARC_KINDS[k] for k in g_hc.record.kind] == ["straight", "polyline"] and g_hc.record.ok.tolist() == [False, True]
assert g_hc.stats["polyline_arcs"] == 1 and hc.n_voids == 1

# %% [markdown]
# ## Figs 6.14 and 6.15 — isosurfaces generated from the graph
#
# Five isosurfaces each, coloured by value, over the graph that found them.

# %%
m1 = methods.get("extrema-graph")(vol1)
s1 = vol1.scalars()
isos = [m1.extract(v) for v in np.linspace(s1.min(), s1.max(), 7)[1:-1]]
plot_extrema.plot_graph_isosurface(vol1, m1.graph, isos).show()
for iso in isos:  # the same triangles as testing every cell
    ref = extract(vol1, iso.value)
    assert np.array_equal(np.unique(np.sort(iso.vertex_keys[iso.triangles], 1), axis=0),
                          np.unique(np.sort(ref.vertex_keys[ref.triangles], 1), axis=0))

# %%
mh = methods.get("extrema-graph")(volh)
sh = volh.scalars()
isos_h = [mh.extract(v) for v in np.linspace(sh.min(), sh.max(), 7)[1:-1]]
plot_extrema.plot_graph_isosurface(volh, mh.graph, isos_h).show()

# %% [markdown]
# ## Fig. 6.11 — seeds on arcs and on the boundary
#
# A closed isosurface is found on an arc (red); a surface that ends on the boundary and
# misses every arc — here one cut by a through-hole of the ring-shaped volume — is found in the
# boundary lists (blue). (Chapter 7 starts from this: a graph that keeps the genus needs no
# boundary lists.)

# %%
ring = datasets.load("torus")
mr = methods.get("extrema-graph")(ring, "linear")
iso_r = mr.extract(1.5)
seeds_r = mr.stats["seeds"]
plot_extrema.plot_seeds(ring, mr.graph, iso_r, seeds_r).show()
print(f"{seeds_r.n_from_arcs} seeds on arcs, {len(seeds_r.cells) - seeds_r.n_from_arcs} from the boundary lists; "
      f"{iso_r.connected_components()[1]} surface parts")
assert seeds_r.n_from_arcs >= 1 and len(seeds_r.cells) > seeds_r.n_from_arcs

# %%
# the same on data 1: which seeds each of twenty surfaces came from
v1 = float(np.quantile(s1, 0.8))
iso1 = m1.extract(v1)
plot_extrema.plot_seeds(vol1, m1.graph, iso1, m1.stats["seeds"]).show()

# %% [markdown]
# ## Tables 6.1–6.5 — data 1–4
#
# Twenty isovalues `linspace(min, max, 22)[1:-1]` of the FEM field, one run, with the thesis's
# numbers beside ours. Timings come from this (shared) machine and only their ratios mean
# anything; the counts are machine-independent. Every method's isosurfaces are checked against
# the full scan's.

# %%
rows = []
for name in TABLE_DATA:
    vol = datasets.load(name)
    vol.face_neighbors, vol.node_cells, vol.cell_edges, vol.cell_records   # topology, outside the clocks
    s = vol.scalars()
    values = np.linspace(s.min(), s.max(), 22)[1:-1]
    row = {"data": name, "N_e": vol.n_cells, "N_b": len(vol.boundary_cells), "N_n": vol.n_points}
    ref = [extract(vol, v) for v in values]
    for mname, key in [("scan", "all"), ("sorted-lists", "sort"), ("span-filter", "filt"),
                       ("extrema-graph-loops", "loops"), ("extrema-graph", "egra")]:
        m = methods.get(mname)(vol)
        sw = methods.sweep(m, values, reference=ref)   # the 20 values, one at a time, summed
        assert sw.same_as_reference, (name, mname)
        row.update({f"T_{key}": m.preprocess_s, f"Q_{key}": sw.query_s, f"t1_{key}": sw.t1,
                    f"tested_{key}": sw.seed_cells_tested})
        if key == "loops":   # ours, below: boundary loops in place of the boundary lists
            row.update({"loops": m.graph.stats["loops"], "loop cells": m.graph.stats["boundary_cells"]})
    g = m.graph.stats   # the extrema graph, last in the list
    row.update({"T_pe": g["T_pe"], "T_pc": g["T_pc"], "T_pb": g["T_pb"], "extrema": g["extrema"],
                "N_g": g["graph_cells"], "N_pa": g["polyline_arcs"], "search arcs": g["search_arcs"],
                "N_cg": sw.seed_cells_tested, "N_cg arcs": sum(x["seeds"].tested_arcs for x in sw.stats),
                **{k: sum(x[k] for x in sw.stats) for k in ("T_mg", "T_mb", "T_mt", "T_mv", "N_ci")}})
    rows.append(row)
    print(name, "done")

# %%
print("Table 6.1 - the data (thesis in parentheses)")
print(plotting.table([{"data": r["data"], **{k: f"{r[k]} ({THESIS[k][i]})" for k in ["N_e", "N_b", "N_n"]}}
                      for i, r in enumerate(rows)], ["data", "N_e", "N_b", "N_n"]))
print()
print("Table 6.2 - preprocessing, s (thesis in parentheses)")
print(plotting.table([{"data": r["data"], **{k: f"{r[k]:.4f} ({THESIS[k][i]})" for k in ["T_sort", "T_filt", "T_egra"]}}
                      for i, r in enumerate(rows)], ["data", "T_sort", "T_filt", "T_egra"]))

# %%
print("Table 6.3 - extrema graph preprocessing (thesis in parentheses)")
cols = ["T_pe", "T_pc", "T_pb", "extrema", "N_g", "N_pa"]
print(plotting.table([{"data": r["data"], "N_b": r["N_b"], "search arcs": r["search arcs"],
                       **{k: (f"{r[k]:.4f}" if k[0] == "T" else str(r[k])) + f" ({THESIS[k][i]})" for k in cols}}
                      for i, r in enumerate(rows)], ["data"] + cols + ["search arcs", "N_b"]))
for i, r in enumerate(rows):
    # 6.5: N_g is far below the boundary cells -- as far below as in the thesis's table for the same data set
    assert r["N_b"] / r["N_g"] >= THESIS["N_b"][i] / THESIS["N_g"][i], r

# %%
print("Table 6.4 - twenty isosurfaces, s (thesis in parentheses)")
cols = ["Q_all", "Q_sort", "Q_filt", "Q_egra"]
print(plotting.table([{"data": r["data"], **{k: f"{r[k]:.4f} ({THESIS[k][i]})" for k in cols}}
                      for i, r in enumerate(rows)], ["data"] + cols))
print()
print("finding the intersected cells alone (t1, s; cf. Table 7.4)")
cols = ["t1_all", "t1_sort", "t1_filt", "t1_egra"]
print(plotting.table([{"data": r["data"], **{k: f"{r[k]:.4f}" for k in cols}} for r in rows], ["data"] + cols))
print()
print("a cell test against building an intersected cell's triangles, ns (thesis: test at most T_all / 20 N_e)")
print(plotting.table([{"data": r["data"], "test": f"{1e9 * r['t1_all'] / (20 * r['N_e']):.1f}",
                       "build": f"{1e9 * r['T_mt'] / r['N_ci']:.0f}",
                       "thesis test": f"{1e9 * THESIS['Q_all'][i] / (20 * THESIS['N_e'][i]):.0f}",
                       "thesis build": f"{1e9 * THESIS['T_mt'][i] / THESIS['N_ci'][i]:.0f}"}
                      for i, r in enumerate(rows)], ["data", "test", "build", "thesis test", "thesis build"]))
print()
print("Table 6.5 - extrema graph stages, sums over the twenty (thesis in parentheses)")
cols = ["T_mg", "T_mb", "T_mt", "T_mv", "N_cg", "N_ci"]
print(plotting.table([{"data": r["data"], "N_cg arcs": r["N_cg arcs"], "sorted lists tested": r["tested_sort"],
                       **{k: (f"{r[k]:.4f}" if k[0] == "T" else str(r[k])) + f" ({THESIS[k][i]})" for k in cols}}
                      for i, r in enumerate(rows)], ["data"] + cols + ["N_cg arcs", "sorted lists tested"]))

# %% [markdown]
# **What holds and what does not.** The cells tested *on the arcs* are a small fraction of the
# cells intersected, as the thesis reports. The boundary lists are another matter on our
# volumes. As 6.3.4 prescribes (and as the method does by default), the boundary cells are
# tested only after the propagation from the arc hits, and only those it has not reached;
# still, for a value in the middle of the range the near side of a sorted list holds many
# boundary cells whose range lies wholly below (or above) C, and those are tested too. Our
# parts have about three times the thesis's boundary cells (Table 6.1) and their boundary
# values span the whole range (heat sources next to the surface), so the boundary tests
# dominate N_cg and bring it to between a third (data 4) and nine tenths (data 2) of N_ci (the
# thesis: a twentieth to a tenth). So Table 6.5's claim — N_cg very small against N_ci — holds
# here for the tests on the arcs (the thesis's largest ratio, 0.105 on data 3, taken as what it
# calls very small) and not for the whole seed search; the checks below assert the claim on
# the arcs, and for the whole search assert the reason on this run's counters: the boundary
# tests outnumber the arc tests, on parts with more boundary cells than the thesis's.
# The whole seed search still tests fewer cells than sorted lists or span filtering over all
# cells, and the section after Table 6.5 shows that almost all of those boundary tests can go.
#
# **Table 6.4 on this machine.** Finding the intersected cells (t1) is several times faster
# with the extrema graph than with sorted lists or span filtering on data 3–4, as in the
# thesis. The totals are another matter: the cost of a cell test against that of building an
# intersected cell's triangles (the table above) has moved by a factor of about thirty since
# 1995. On the RS/6000 a test cost at least a third of a cell's construction, so the search
# was most of the time and the method that tests the fewest cells won; here a test is about a
# hundredth of a construction, the propagation (T_mt), which the three search methods share,
# is nearly all of it, and it runs faster from every intersected cell in cell order (sorted
# lists, span filtering) than breadth-first from the graph's few seeds, which touches memory
# less orderly. The full scan, which classifies the cells in parallel and numbers vertices
# without a hash table, is fastest in total. So the ordering of Table 6.4 is not reproduced
# with the thesis's construction; that of the seed search is. `benchmarks/results/extrema_graph.md`
# also builds the triangles by the 2001 paper's construction, whose cost depends little on the
# order of the cells (notebook 08): then the extrema graph is ahead of sorted lists and span
# filtering by about a tenth on data 3–4, well ahead of the full scan on one core (as the
# thesis's machine ran it), and level with the full scan spread over two cores.

# %%
VERY_SMALL = max(c / i for c, i in zip(THESIS["N_cg"], THESIS["N_ci"]))   # 0.105: the thesis's own largest
for i, r in enumerate(rows):
    assert r["N_cg arcs"] <= VERY_SMALL * r["N_ci"], r           # Table 6.5's claim, for the tests on the arcs
    assert r["N_cg"] - r["N_cg arcs"] > r["N_cg arcs"] and r["N_b"] > THESIS["N_b"][i], r   # why not for the rest
    assert r["N_cg"] < min(r["tested_sort"], r["tested_filt"], 20 * r["N_e"]), r  # fewer tests than the others

# %% [markdown]
# ## Beyond the thesis — boundary loops instead of boundary lists
#
# Which isosurfaces does the boundary list really catch? One that reaches the boundary and
# *separates* the volume has, like a closed one, an extremum on each side (the proof of
# Thm 6.1 only uses that the surface cuts the volume in two), so the arcs cross it already.
# Only a surface that does **not** separate the volume — a disk across a ring, possible only
# with through-holes (Fig. 7.1) — needs the boundary. Such a surface meets some closed curve
# of the volume exactly once, and since the volume sits in space, every closed curve is, up to
# homology, a sum of curves on its boundary (Mayer–Vietoris). So 2g edge loops on a boundary
# surface of genus g that generate its homology (tree-cotree: a spanning tree of the boundary's
# nodes, a spanning forest of its faces across the other edges, one loop per edge left over)
# meet every such surface, at an edge whose nodes lie on either side of C: the cells along the
# loops can replace the whole boundary list. `extrema-graph-loops` does that (same arcs, same
# order of the query); its surfaces were checked against the full scan's above. Chapter 7
# reaches the same goal another way, with a skeleton that keeps the genus. Data 1 (genus 2:
# four loops) and the seeds of the surface of Fig. 6.11 found on its arcs (red) and loops (blue):

# %%
m1_loops = methods.get("extrema-graph-loops")(vol1)
plot_extrema.plot_loops(vol1, m1_loops.graph.loops).show()
iso1_loops = m1_loops.extract(v1)
plot_extrema.plot_seeds(vol1, m1_loops.graph, iso1_loops, m1_loops.stats["seeds"]).show()
assert m1_loops.graph.loops.n_loops == 2 * vol1.n_through_holes
assert np.array_equal(np.sort(iso1_loops.triangle_cells), np.sort(iso1.triangle_cells))

# %%
print("Seed tests (Table 6.5's N_cg) with boundary lists (the thesis) and with boundary loops (ours)")
print(plotting.table([{"data": r["data"], "N_b": r["N_b"], "loops": r["loops"], "loop cells": r["loop cells"],
                       "N_cg lists": r["N_cg"], "N_cg loops": r["tested_loops"], "N_ci": r["N_ci"],
                       "N_cg/N_ci lists": f"{r['N_cg'] / r['N_ci']:.3f}",
                       "N_cg/N_ci loops": f"{r['tested_loops'] / r['N_ci']:.3f}",
                       "thesis": f"{THESIS['N_cg'][i] / THESIS['N_ci'][i]:.3f}"} for i, r in enumerate(rows)],
                     ["data", "N_b", "loops", "loop cells", "N_cg lists", "N_cg loops", "N_ci", "N_cg/N_ci lists",
                      "N_cg/N_ci loops", "thesis"]))
for r in rows:
    assert r["loop cells"] < r["N_b"] and r["tested_loops"] < r["N_cg"], r   # fewer cells stand for the boundary
    # the loops' tests are those of the arcs plus at most every loop cell once per value
    assert r["tested_loops"] <= r["N_cg arcs"] + 20 * r["loop cells"], r

# %% [markdown]
# ## 6.4 — preprocessing grows like O(m² log m) in the number of extrema
#
# Each extremum sorts the others by distance, so the graph costs O(m² log m): negligible for
# tens of extrema, dominant for thousands (Table 7.1 names data 5, with 5986 extrema, as the
# extrema graph's weak point). Data 5's mesh with its FEM field and with a smooth field plus
# seeded noise of growing amplitude:

# %%
vol5 = datasets.load("data5")
vol5.face_neighbors, vol5.node_cells
base = vol5.scalars("distance")
noise = np.random.default_rng(0).standard_normal(vol5.n_points) * np.ptp(base)
grow = []
for label, f in [("fem", vol5.scalars("fem"))] + [(f"distance + {a:g} noise", base + a * noise) for a in NOISE]:
    st = build_extrema_graph(vol5, f).stats
    grow.append({"field": label, "m": st["extrema"], "arcs": st["arcs"],
                 "T_pe": st["T_pe"], "T_pc": st["T_pc"], "T_pb": st["T_pb"],
                 "T_pc/(m^2 log2 m) ns": 1e9 * st["T_pc"] / (st["extrema"] ** 2 * np.log2(st["extrema"]))})
grow.sort(key=lambda r: r["m"])
print(plotting.table(grow, list(grow[0])))

# %%
import matplotlib.pyplot as plt

m_ = np.array([r["m"] for r in grow], float)
t_ = np.array([r["T_pc"] for r in grow])
fig, ax = plt.subplots(figsize=(5, 4))
ax.loglog(m_, t_, "o-", label="T_pc (graph)")
ax.loglog(m_, [r["T_pe"] for r in grow], "s-", label="T_pe (extrema)")
ax.loglog(m_, t_[-1] * (m_ ** 2 * np.log(m_)) / (m_[-1] ** 2 * np.log(m_[-1])), "k--", label="m² log m")
ax.set_xlabel("extrema m"); ax.set_ylabel("s"); ax.legend();
# machine-independent: one sort per joined extremum, m - 1 arcs in this connected volume
assert grow[-1]["m"] > 1000 and all(r["arcs"] == r["m"] - 1 for r in grow)
