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
# # Chapter 7 — volume thinning
#
# The extrema graph of chapter 6 needs sorted lists of the boundary cells, because a
# **through-hole** can cut an isosurface into parts that no arc crosses (Fig. 7.1, Thm 7.3).
# A graph that joins the extrema *and keeps the genus of the volume* — a loop around every
# through-hole — crosses every part, and needs no boundary lists. Itoh builds it as image
# thinning builds the skeleton of a picture (7.3): cells are removed from the outside, one at
# a time, as long as the cells marked at the extrema stay connected (Thm 7.4), the genus of
# the boundary stays (Thm 7.5) and voids stay apart from the outer boundary (Thm 7.6).
# The layers left around voids are then pricked open (7.5.3). The cells that remain — the
# skeleton — are put into value classes, and a query tests only the skeleton cells of the
# class of C and grows the surface from every hit (7.5.4–7.5.5).
#
# Everything here is `polygen.volume.thinning` (the kernels in `_thinning_kernels`); the
# figures come from `polygen.plotting.thinning`. `benchmarks/thinning.py` measures the same tables
# and the O(n) preprocessing from 20k to 10M cells.

# %%
import os
import time

FULL = os.environ.get("POLYGEN_FULL") == "1"   # every field of every data set in the theorem checks

import matplotlib.pyplot as plt
import numpy as np

from polygen import plotting
from polygen.plotting import thinning as plot_thinning
from polygen.volume import datasets, methods
from polygen.volume.analysis import (end_cells, first_removal_test, replay_tetra_decisions, side_regions,
                                     unseeded_parts)
from polygen.volume.extrema_graph import build_extrema_graph
from polygen.volume.isosurface import extract, same_surface
from polygen.volume.propagate import Propagator
from polygen.volume.thinning import pixel_removable, removal_test, thin_image, thin_volume

pv = plotting.setup_notebook()

# %%
TABLE_DATA = ["data1", "data2", "data3", "data4", "data5"]
THESIS = {  # Tables 7.1-7.5, data 1-5 (IBM RS/6000 model 560)
    "N_e": [20736, 61680, 346644, 557868, 458664], "N_n": [4002, 11624, 62107, 97473, 80468],
    "N_ep": [21, 46, 135, 540, 5986], "N_e1": [2516, 6480, 20158, 28086, 121492],
    "N_e2": [436, 1365, 3757, 10967, 55536],
    "T_sort": [1.15, 4.12, 47.95, 52.29, 63.60], "T_filt": [0.19, 0.52, 2.75, 4.76, 3.66],
    "T_egra": [0.58, 1.53, 7.46, 14.51, 76.78], "T_thin": [1.13, 3.22, 16.93, 26.86, 23.22],
    "C1": [21, 45, 124, 491, 3208], "C2": [397, 1259, 3453, 9552, 20574], "C3": [17, 61, 178, 875, 15312],
    "C4": [1, 0, 2, 49, 16436],
    "N_t": [67875, 80995, 135358, 1164616, 494480], "N_v": [34921, 43158, 71358, 588796, 251506],
    "Q_sort": [5.69, 6.85, 15.24, 100.92, 53.48], "Q_filt": [5.78, 8.36, 25.51, 107.89, 59.31],
    "Q_egra": [3.31, 4.18, 7.56, 57.72, 26.49], "Q_thin": [3.27, 3.96, 7.22, 57.12, 25.21],
    "t1_sort": [2.24, 2.86, 8.65, 42.65, 26.86], "t1_filt": [3.13, 5.95, 22.59, 65.08, 40.20],
    "t1_egra": [0.71, 0.98, 2.07, 12.14, 6.35], "t1_thin": [0.65, 0.74, 1.76, 11.58, 5.27],
    "N_sort": [51348, 61766, 101951, 879735, 378712], "N_filt": [89548, 179088, 786220, 1927026, 1278742],
    "N_egra": [54420, 66618, 115639, 907319, 550605], "N_thin": [51762, 63089, 105762, 890134, 436658],
}
MNAMES = [("scan", "all"), ("sorted-lists", "sort"), ("span-filter", "filt"), ("extrema-graph", "egra"),
          ("thinning", "thin")]
# the thesis's serial FIFO (7.5.2) for the tables; by default volumes from 200k cells (data 4, 5)
# are thinned in two halves at once (`thin_volume(parallel=None)`): a slightly larger skeleton, sooner
PARAMS = {"thin": {"parallel": False}}

# %% [markdown]
# ## Fig. 7.1 made real — a through-hole hides part of an isosurface from the extrema graph
#
# Data 1 is a block with two bolt holes. Its `distance` field (the distance from an eye
# outside the volume: the equi-distance surfaces of 7.8) has one minimum and one maximum, and
# the extrema graph is a single arc. Where a bolt hole cuts an equi-distance surface in two,
# the arc crosses one part only; the other is found by the extrema graph only through its
# boundary lists. The skeleton keeps a loop around each hole and crosses both parts.

# %%
vol1 = datasets.load("data1")
d1 = vol1.scalars("distance")
graph_d = build_extrema_graph(vol1, d1)
skel_d = thin_volume(vol1, "distance")
prop_d = Propagator(vol1, "distance")
missed = []
for v in np.linspace(d1.min(), d1.max(), 62)[1:-1]:
    full = extract(vol1, v, field="distance")
    seeds = graph_d.seeds(v)
    from_arcs = prop_d.extract(v, seeds.cells[:seeds.n_from_arcs])
    from_skeleton = prop_d.extract(v, skel_d.seeds(v).cells)
    assert same_surface(from_skeleton, full, geometry=False)      # the skeleton alone finds every part
    if from_arcs.triangles.shape[0] < full.triangles.shape[0]:
        missed.append((full.triangles.shape[0] - from_arcs.triangles.shape[0], v))
print(f"extrema: {graph_d.extrema.n}, arcs: {graph_d.n_arcs}; skeleton: {skel_d.n_cells} cells, "
      f"genus of its boundary {skel_d.as_volume().n_through_holes} (volume: {vol1.n_through_holes})")
print(f"{len(missed)} of 60 equi-distance surfaces have parts that no arc crosses")
assert missed
v71 = max(missed)[1]
full = extract(vol1, v71, field="distance")
seeds = graph_d.seeds(v71)
from_arcs = prop_d.extract(v71, seeds.cells[:seeds.n_from_arcs])
print(f"C = {v71:.3f}: {full.connected_components()[1]} parts, {full.triangles.shape[0]} triangles; "
      f"from the arc alone {from_arcs.connected_components()[1]} part, {from_arcs.triangles.shape[0]} triangles")
plot_thinning.plot_fig_7_1(vol1, graph_d, skel_d, full, from_arcs).show()

# %% [markdown]
# ## Figs 7.10 and 7.11 — why only a through-hole hides a part from the graph
#
# Thm 7.2: in a volume without through-holes, every part of an isosurface separates it, so
# the regions on the two sides of the surface number one more than its parts (Fig. 7.10: two
# parts with boundary cannot bound the same two regions). Thm 7.3 follows: each part then has
# extrema on both sides, and a graph joining all extrema crosses it (Fig. 7.11 (a)). With g
# through-holes up to g parts may fail to separate (regions ≥ parts + 1 − g), and a part
# that does not separate can be missed by every arc (Fig. 7.11 (b)). Counted on 60 values
# of the hollow cube (a void, no through-hole) and of the ring (one through-hole): regions =
# connected groups of nodes on one side of C joined by volume edges (in a tetrahedron the
# nodes on one side are joined by its edges), parts = connected parts of the surface, and the
# parts no arc crosses (a part is crossed when one of its cells is a seed found on an arc):
# `side_regions` and `unseeded_parts` of `polygen.volume.analysis`.

# %%
count_rows, worst = [], {}
for name in ["hollow_cube", "torus"]:
    vol, s = datasets.load(name), datasets.load(name).scalars()
    graph = build_extrema_graph(vol, s)
    for v in np.linspace(s.min(), s.max(), 62)[1:-1]:
        iso, seeds = extract(vol, v), graph.seeds(v)
        r = {"data": name, "genus": vol.n_through_holes, "C": v, "regions": side_regions(vol, s, v),
             "parts": iso.connected_components()[1],
             "missed": unseeded_parts(iso, seeds.cells[:seeds.n_from_arcs]).size}
        count_rows.append(r)
        worst[name] = max(worst.get(name, r), r, key=lambda x: (x["missed"], x["parts"]))
for name in worst:
    rs = [r for r in count_rows if r["data"] == name]
    print(f"{name}: genus {rs[0]['genus']}; values where a part does not separate: "
          f"{sum(r['regions'] < r['parts'] + 1 for r in rs)}, where an arc misses a part: {sum(r['missed'] > 0 for r in rs)}")
cube_rows = [r for r in count_rows if r["data"] == "hollow_cube"]
ring_rows = [r for r in count_rows if r["data"] == "torus"]
assert all(r["regions"] == r["parts"] + 1 and r["missed"] == 0 for r in cube_rows)   # Thms 7.2, 7.3
assert all(r["regions"] >= r["parts"] for r in ring_rows)                            # one hole: at most one
assert any(r["missed"] > 0 for r in ring_rows) and all(r["regions"] < r["parts"] + 1 for r in ring_rows if r["missed"])

# %%
panels = []
for name, label in [("hollow_cube", "(a) no through-hole"), ("torus", "(b) a through-hole")]:
    vol = datasets.load(name)
    iso = extract(vol, worst[name]["C"])
    panels.append((vol, build_extrema_graph(vol), iso, f"{label}: C = {iso.value:.3g}, {worst[name]['parts']} parts, "
                   f"{worst[name]['regions']} regions, {worst[name]['missed']} missed (red)"))
plot_thinning.plot_parts_and_arcs(panels).show()

# %% [markdown]
# ## Fig. 7.2 — thinning a picture (7.3)
#
# A border pixel p goes when all its black edge neighbours can be visited in one sweep around
# it through black neighbours (b, c); otherwise removing p could disconnect them (d, e). The
# end of a line stays. Black regions (4-connected) and white ones (8-connected) keep their
# number: the skeleton keeps the picture's holes and branches (f, g).

# %%
cases = [[[0, 0, 0], [1, 1, 0], [1, 1, 0]], [[1, 1, 0], [1, 1, 0], [1, 1, 0]],
         [[0, 1, 0], [0, 1, 0], [0, 1, 0]], [[0, 1, 0], [1, 1, 0], [0, 0, 1]], [[0, 0, 0], [0, 1, 1], [0, 0, 0]]]
removable = [pixel_removable(c) for c in cases]
plot_thinning.plot_pixel_rule(cases, removable, titles=["(b)", "(c)", "(d)", "(e)", "end of a line"]);
assert removable == [True, True, False, False, False]

# %%
from scipy import ndimage

yy, xx = np.mgrid[:80, :120]
img = ((xx - 62) ** 2 / 48 ** 2 + (yy - 40) ** 2 / 30 ** 2) < 1
for cx, cy, r in [(40, 40, 8), (82, 35, 10)]:
    img &= (xx - cx) ** 2 + (yy - cy) ** 2 > r ** 2          # two holes
img |= (np.abs(xx - 6) < 4) & (yy > 8) & (yy < 72)           # a separate bar
img |= (np.abs(yy - 70) < 3) & (xx > 60) & (xx < 115)        # a branch
skel_img = thin_image(img)
plot_thinning.plot_image_thinning(img, skel_img);
four, eight = [[0, 1, 0], [1, 1, 1], [0, 1, 0]], np.ones((3, 3))
topo = lambda im: (ndimage.label(im, four)[1], ndimage.label(np.pad(~im, 1, constant_values=True), eight)[1])
print("black regions, white regions: picture", topo(img), "skeleton", topo(skel_img))
assert topo(skel_img) == topo(img) and np.array_equal(thin_image(skel_img), skel_img)

# %% [markdown]
# ## Fig. 7.3 — volume thinning, step by step
#
# A bar of 7 x 3 cubes with three holes (genus 3), 6 tetrahedra per cube, with a field of
# three Gaussian bumps, seen from above: one cell at each extremum is marked (C_-1) and never
# removed. Cells go, lowest class first, until every cell left is needed to keep the marked
# cells joined or a loop around a hole.

# %%
bar = datasets.load("genus3")
sk_bar = thin_volume(bar, "gaussians", record=True)
rec = sk_bar.record
plot_thinning.plot_thinning_steps(bar, rec, rec.steps(4), skeleton=sk_bar, view="xy").show()
print(f"{rec.n_removed} removals; skeleton {sk_bar.n_cells} of {bar.n_cells} cells, marked cells "
      f"{sk_bar.marked.tolist()}; genus {sk_bar.as_volume().n_through_holes}")
assert sk_bar.as_volume().n_through_holes == bar.n_through_holes == 3

# %% [markdown]
# ## Figs 7.6 and 7.13 — the removal tests, counted
#
# Per class, how many cells were taken from the FIFOs and how many went: every C_1 goes; a C_2
# goes when the walk around its triple-shared edge reaches the other neighbour; a tetrahedral
# C_3 goes when its quadruple-shared node is inside (n_B = 0); hexahedra add C_4 and C_5
# (two and four quadruple-shared nodes) and keep C_2/C_4 cells whose open faces are opposite.

# %%
rows_r = []
for name in ["data1", "hexa1"]:
    st = thin_volume(datasets.load(name)).stats
    for q, n in st["processed"].items():
        rows_r.append({"data": name, "class": f"C{q}", "taken": n, "removed": st["removed_by_class"][q]})
    rows_r.append({"data": name, "class": "walks", "taken": st["walks"], "removed": st["walks_reached"]})
print(plotting.table(rows_r, ["data", "class", "taken", "removed"]))

# %% [markdown]
# The record of data 1's thinning keeps every cell taken from a FIFO, its class and the
# decision. Replayed from scratch on the state each test saw (the cells removed before it;
# n_B ≠ 0 for a node on the volume's boundary or on a removed cell), every decision is the
# thesis's tetrahedral rule: C1 goes; C2 goes when its triple-shared edge is inside the
# volume and every cell around it is still there (the walk from E_a reaches E_b); C3 goes
# when its quadruple-shared node has n_B = 0 (the replay, in plain Python apart from the
# kernels: `analysis.replay_tetra_decisions`).

# %%
sk1r = thin_volume(vol1, record=True)
rec1 = sk1r.record
agree = replay_tetra_decisions(vol1, rec1)
print(f"{agree.sum()} of {agree.size} decisions replayed alike")
assert agree.all() and rec1.decided_removed.sum() == rec1.n_removed - sk1r.stats["prick_cells"]

# %% [markdown]
# Four of those tests, drawn from the record (E red when removed, orange when kept; its
# non-removed neighbours gold; the cells around a triple-shared edge cyan, the edge blue; a
# quadruple-shared node purple when n_B ≠ 0, green when 0). A C2 cell whose walk closes
# around the edge goes (Fig. 7.6 (a)): the cells around the edge stay joined in a ring of
# faces, so E_a and E_b stay connected and the genus does not change (Fig. 7.12 (a)). A C2
# cell whose edge is open stays. A C3 cell whose quadruple-shared node is inside goes (Fig.
# 7.6 (b)): the three faces it uncovers join the boundary faces around the face it had open,
# and nothing else (Fig. 7.12 (b)). A C3 cell whose node is already on the boundary stays:
# removing it would open an incidental loop around the node (Fig. 7.4).

# %%
picks = [(2, True, "Fig. 7.6 (a): C2, the walk closes: removed"), (2, False, "C2, the edge is open: kept"),
         (3, True, "Fig. 7.6 (b): C3, n_B = 0: removed"), (3, False, "Fig. 7.4: C3, n_B != 0: kept")]
tests = [first_removal_test(vol1, rec1, q, r) for q, r, _ in picks]
plot_thinning.plot_removal_tests([(vol1, tst, title) for tst, (_, _, title) in zip(tests, picks)]).show()
assert [t_.removed for t_ in tests] == [True, False, True, False]
assert [bool(t_.on_boundary[t_.quad_nodes].any()) for t_ in tests[2:]] == [False, True]

# %% [markdown]
# Hexahedra (Fig. 7.13): a C2 cell whose two neighbours are across opposite faces has no
# triple-shared edge and stays (a); C3 with one quadruple-shared node goes when it is inside;
# C4 with two inside goes, C4 whose open faces are opposite stays. From hexahedral data 1's
# record:

# %%
volh1 = datasets.load("hexa1")
rech = thin_volume(volh1, record=True).record
c2 = [removal_test(volh1, rech, k) for k in np.flatnonzero(rech.decided_class == 2)]
opposite = [t_ for t_ in c2 if t_.shared_edges.shape[0] == 0]
print(f"{len(c2)} C2 tests on hexa1, {len(opposite)} with the neighbours across opposite faces, all kept")
assert opposite and not any(t_.removed for t_ in opposite)      # no triple-shared edge: E stays
tests_h = [(opposite[0], "(a) C2, opposite faces: kept"),
           (first_removal_test(volh1, rech, 3, True, n_quad=1), "(b) C3, n_B = 0: removed"),
           (first_removal_test(volh1, rech, 4, True, n_quad=2), "(c) C4, two inner nodes: removed"),
           (first_removal_test(volh1, rech, 4, False, n_quad=0), "C4, opposite open faces: kept")]
plot_thinning.plot_removal_tests([(volh1, t_, title) for t_, title in tests_h]).show()

# %% [markdown]
# ## Figs 7.14 and 7.15 — skeletons
#
# Data 1, coloured by each cell's number of non-removed neighbours (the class of Table 7.2;
# purple: the extrema), and data 2 coloured by value.

# %%
sk1 = thin_volume(vol1)
plot_thinning.plot_skeleton(vol1, sk1, color="class").show()

# %%
vol2 = datasets.load("data2")
sk2 = thin_volume(vol2, record=True)
plot_thinning.plot_skeleton(vol2, sk2, color="value").show()

# %% [markdown]
# ## Figs 7.16 and 7.17 — isosurfaces made from the skeletons

# %%
m1 = methods.get("thinning")(vol1)
s1 = vol1.scalars()
isos1 = [m1.extract(v) for v in np.linspace(s1.min(), s1.max(), 7)[1:-1]]
plot_thinning.plot_skeleton_isosurfaces(vol1, m1.skeleton, isos1).show()
for iso in isos1:  # the same triangles as testing every cell
    assert same_surface(iso, extract(vol1, iso.value), geometry=False)

# %%
m2 = methods.get("thinning")(vol2)
s2 = vol2.scalars()
isos2 = [m2.extract(v) for v in np.linspace(s2.min(), s2.max(), 7)[1:-1]]
plot_thinning.plot_skeleton_isosurfaces(vol2, m2.skeleton, isos2).show()
for iso in isos2:
    assert same_surface(iso, extract(vol2, iso.value), geometry=False)

# %% [markdown]
# ## Figs 7.18–7.21 — thinning data 2
#
# The cells left at the start, half-way, when the FIFOs first run dry — every cell left is
# needed, and a layer of cells still wraps each of the flange's two voids (Fig. 7.7) — and at
# the end, after the layers were pricked open and thinning resumed (the skeleton of Fig. 7.15).

# %%
rec2 = sk2.record
steps2 = [0, rec2.n_removed // 2, int(rec2.pricks[0, 0]), rec2.n_removed]
plot_thinning.plot_thinning_steps(vol2, rec2, steps2, skeleton=sk2).show()
print(f"{rec2.n_removed} removals; voids pricked after removals {rec2.pricks[:, 0].tolist()} "
      f"(groups {rec2.pricks[:, 1].tolist()}, {rec2.pricks[:, 2].tolist()} cells each)")

# %% [markdown]
# ## Theorems 7.4–7.6 on the data sets
#
# For each skeleton, computed from scratch: the marked cells lie in one face-connected piece
# (Thm 7.4); the genus of the skeleton's boundary — the sum over its boundary groups of
# 1 − (V + F − E)/2 — equals the volume's (Thm 7.5); after pricking no void is left (each was
# kept apart until pricked, Thm 7.6; the tests check that after every removal on small
# volumes). `FULL` runs every field of every data set.

# %%
names = TABLE_DATA + ["hexa1", "hexa2", "hexa3"]
rows_t = []
for name in names:
    vol = datasets.load(name)
    for field in (vol.fields if FULL else [None]):
        sk = thin_volume(vol, field)
        sub = sk.as_volume()
        mask = sk.mask()
        rows_t.append({"data": name, "field": field or next(iter(vol.fields)), "cells": vol.n_cells,
                       "skeleton": sk.n_cells, "genus (volume)": vol.n_through_holes,
                       "genus (skeleton)": sub.n_through_holes, "voids (volume)": vol.n_voids,
                       "voids (skeleton)": sub.n_voids, "pricks": sk.stats["pricks"],
                       "skeleton parts": sub.cell_components[1],
                       "marked in one part": bool(np.isin(sk.marked, sk.cells).all() and sub.cell_components[1] == 1)})
print(plotting.table(rows_t, list(rows_t[0])))
for r in rows_t:
    assert r["genus (skeleton)"] == r["genus (volume)"] and r["voids (skeleton)"] == 0
    assert r["pricks"] == r["voids (volume)"] and r["marked in one part"]

# %% [markdown]
# ## Tables 7.1–7.5 — data 1–5
#
# Twenty isovalues `linspace(min, max, 22)[1:-1]` of the FEM field, one run, thesis in
# parentheses. Timings are from this shared 2-core machine and only their ratios mean
# anything; the counts are machine-independent. Every method's surfaces are checked against
# the full scan's. N_e1 counts the cells on the extrema graph's arcs plus the boundary cells
# (as in the thesis: 468 + 2048 = 2516 for its data 1); Table 7.5 counts as the thesis did:
# the cells the search tested plus, for the extrema graph and thinning, the cells intersected
# that propagation registered. The skeleton's ends (Table 7.2) are counted from scratch:
# the skeleton cells with exactly one skeleton cell across a face (`analysis.end_cells`).

# %%
rows = []
for name in TABLE_DATA:
    vol = datasets.load(name)
    vol.face_neighbors, vol.node_cells, vol.cell_edges, vol.cell_records, vol.boundary_groups, vol.cell_components
    s = vol.scalars()
    values = np.linspace(s.min(), s.max(), 22)[1:-1]
    ref = [extract(vol, v) for v in values]
    row = {"data": name, "N_e": vol.n_cells, "N_n": vol.n_points,
           "N_t": sum(r.triangles.shape[0] for r in ref), "N_v": sum(r.vertices.shape[0] for r in ref)}
    for mname, key in MNAMES:
        m = methods.get(mname)(vol, **PARAMS.get(key, {}))
        sw = methods.sweep(m, values, reference=ref)   # the 20 values, one at a time, summed
        assert sw.same_as_reference, (name, mname)
        n_ci = sw.cells_intersected
        row.update({f"T_{key}": m.preprocess_s, f"Q_{key}": sw.query_s, f"t1_{key}": sw.t1,
                    f"N_{key}": sw.seed_cells_tested + (n_ci if key in ("egra", "thin") else 0)})
        if key == "egra":
            row.update(N_ep=m.graph.stats["extrema"], N_e1=m.graph.stats["graph_cells"] + m.graph.stats["boundary_cells"])
    st, ends = m.skeleton.stats, end_cells(vol, m.skeleton.cells)   # m: thinning, the last method
    row.update({"N_e2": st["skeleton_cells"], **{f"C{q}": st[f"C{q}"] for q in range(1, 5)}, "N_ci": n_ci,
                "ns/cell": 1e9 * st["T_total"] / vol.n_cells, "ends": ends.size,
                "ends marked": int(np.isin(ends, m.skeleton.marked).sum())})
    rows.append(row)
    print(name, "done")

# %%
cols = ["N_e", "N_n", "N_ep", "N_e1", "N_e2", "T_sort", "T_filt", "T_egra", "T_thin"]
print("Table 7.1 - registered cells and preprocessing (s), thesis in parentheses")
print(plotting.table(plotting.with_thesis(rows, cols, THESIS, floatfmt="{:.4f}"), ["data", *cols]))
cols = ["C1", "C2", "C3", "C4"]
print("Table 7.2 - skeleton cells by class, thesis in parentheses")
print(plotting.table(plotting.with_thesis(rows, cols, THESIS), ["data", *cols]))
print("thinning preprocessing per cell (ns):", ", ".join(f"{r['ns/cell']:.0f}" for r in rows))
# Table 7.1: N_e2 far below N_e1 -- taken as at least the thesis's own ratio on the same data set
ratio = [r["N_e1"] / r["N_e2"] for r in rows]
ratio_thesis = [a / b for a, b in zip(THESIS["N_e1"], THESIS["N_e2"])]
print("N_e1 / N_e2:", ", ".join(f"{a:.1f} ({b:.1f})" for a, b in zip(ratio, ratio_thesis)))
assert [a >= b for a, b in zip(ratio, ratio_thesis)] == [True] * 4 + [False], ratio   # not on data 5: see below
r5 = rows[4]
assert r5["N_e2"] < min(r5["N_e1"], THESIS["N_e2"][4]) and r5["N_e1"] < THESIS["N_e1"][4], r5   # the reason
for r in rows:
    # Table 7.2: C1 about the number of extrema, because the skeleton's ends are marked cells (counted from scratch)
    assert r["ends"] == r["C1"] == r["ends marked"] and r["C1"] <= r["N_ep"], r
    assert r["C2"] > r["C3"] + r["C4"], r     # mostly chains of C2 cells

# %%
for title, cols, fmt in [("Table 7.3 - twenty isosurfaces (s)",
                          ["N_t", "N_v", "Q_all", "Q_sort", "Q_filt", "Q_egra", "Q_thin"], "{:.4f}"),
                         ("Table 7.4 - finding the intersected cells, t1 (s)",
                          ["t1_sort", "t1_filt", "t1_egra", "t1_thin"], "{:.4f}"),
                         ("Table 7.5 - cells tested", ["N_sort", "N_filt", "N_egra", "N_thin", "N_ci"], "{}")]:
    print(title + ", thesis in parentheses")
    print(plotting.table(plotting.with_thesis(rows, cols, THESIS, floatfmt=fmt), ["data", *cols]))
for r in rows:
    # Table 7.5: thinning tests fewer cells than every other method
    assert r["N_thin"] < min(r["N_egra"], r["N_sort"], r["N_filt"]), r

# %% [markdown]
# **What holds and what does not.**
#
# * *Table 7.1.* The skeleton is much smaller than what the extrema graph registers (N_e2 ≪
#   N_e1) on data 1–4, by at least the thesis's ratio; ours is larger there because our parts
#   have about three times the thesis's boundary cells. Data 5's thousands of extrema (5958
#   here, 5986 there) give the largest skeleton, and the smallest ratio — below the thesis's
#   (printed above: about 1.6 against 2.2), so the claim as the thesis's table quantifies it
#   does not hold on data 5. The shortfall is not in the skeleton, which is smaller than the
#   thesis's, but in N_e1: our extrema graph and boundary lists register far fewer cells on
#   data 5 than the thesis's (the check above asserts both on this run's counts). Thinning's preprocessing grows with the cells, not with the extrema: per cell it
#   costs at most about twice as much on data 5 as on data 1–4, while the extrema graph's
#   grows by well over an order of magnitude (the O(m² log m) of chapter 6) — the thesis's
#   argument for thinning. The
#   absolute times are ~100x below the thesis's 1990s machine, and our sorted lists (numba
#   `argsort`) are not the slowest preprocessing.
# * *Table 7.2.* As in the thesis, C1 cells are about as many as the extrema, and for the
#   reason it gives: counted from scratch on each skeleton, every cell with one non-removed
#   neighbour is a marked cell (an extremum's). C2 cells form most of the skeleton. Data 5's
#   C3/C4 cells are fewer than the thesis's.
# * *Tables 7.3–7.5.* Thinning tests fewer cells than every other method (N_thin below N_egra,
#   N_sort and N_filt) and finds the intersected cells fastest (t1). The thesis's N_sort ≈ N_ci came from sorted
#   lists that touch only the active cells; ours (`seeds/sorted_lists.py`) scan the near list
#   up to the value, so N_sort is larger here, and our span filter with 64 replicated classes
#   tests fewer cells than the thesis's. The totals (Table 7.3) are dominated by building the
#   triangles, which every method shares; on this machine the full scan's parallel passes are
#   competitive (see chapter 6's notebook), so the thesis's ordering of totals is not a
#   property of this implementation. See `benchmarks/results/thinning.md` for the O(n) plot
#   (time per cell from 20k to 10M cells).
