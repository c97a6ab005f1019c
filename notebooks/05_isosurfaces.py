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
# # Chapter 5.3–5.4 — Isosurfaces
#
# An isosurface `S = C` of an unstructured volume is made cell by cell: **marching
# tetrahedra / hexahedra** (5.3.1) put one vertex on every cell edge whose end values lie on
# either side of `C`, at the crossing (5.2) `P = P_a + (C − S_a)/(S_b − S_a) (P_b − P_a)`,
# and join the vertices of each cell into triangles read off a case table. Vertices are shared
# between cells through their edge, so the surface is closed inside the volume.
#
# The cost is in *finding* the cells the surface crosses: testing every cell costs O(n) per
# value although only O(n^{2/3}) cells are crossed (assumption 5.1). Table 5.1 shows how few
# cells are intersected; Table 5.2 lists the search structures that find them faster; and
# **propagation** (5.4.2, Fig. 5.7) walks from a few crossed seed cells to their face
# neighbours so that only the crossed cells and their neighbours are ever tested.

# %%
import os
import timeit

FULL = os.environ.get("POLYGEN_FULL") == "1"   # thesis-scale sizes for everything when set

import ipywidgets
import numpy as np

from polygen import plotting
from polygen.plotting import volume as plot_volume
from polygen.volume import datasets, isovalues, marching, seeds
from polygen.volume.extrema_graph import find_extrema
from polygen.volume.isosurface import extract
from polygen.volume.propagate import Propagator

pv = plotting.setup_notebook()
TABLE_DATA = ["data1", "data2", "data3", "data4"]          # Table 5.1: always the thesis's sizes
FIG_DATA = "data2" if FULL else "data1"                    # the volume of Figs 5.5 and 5.7
SEARCH_N = [10_000, 30_000, 100_000, 300_000] + ([1_000_000, 2_000_000] if FULL else [])  # Table 5.2

# %% [markdown]
# ## Fig. 5.4 — the marching cases
#
# A tetrahedron has 2⁴ = 16 cases (bit *i* = node *i* above `C`): no crossing, one node cut
# off (one triangle) or two against two (a planar quadrilateral, split into two triangles).
# The tables are generated from the cell's local edges, not typed in.

# %%
tet_table, tet_count = marching.tet_case_table()
plot_volume.plot_marching_cases("tetra", [0, 1, 3, 7]).show()
# one node apart from the others -> 1 triangle, two against two -> 2, all on one side -> 0
above = np.array([bin(c).count("1") for c in range(16)])
expected = np.select([above % 4 == 0, above == 2], [0, 2], 1)
assert np.array_equal(tet_count, expected), tet_count

# %% [markdown]
# A hexahedron has 2⁸ = 256 node cases. A face whose above corners are diagonal to each
# other is **ambiguous**; polygen resolves it by the value at the face centre (the mean of
# its four nodes, Wyvill et al. [71] in the thesis), so the table is indexed by 8 node bits
# and 6 face-centre bits. Below: simple cases, and case 5 (nodes 0 and 2 above, bottom face
# ambiguous) with the centre below (two corners cut off) and above (the corners joined).

# %%
hex_table, hex_count = marching.hex_case_table()
bottom = marching.hex_ambiguous_faces(5)[0]
HEX_CASES = [1, 3, 15, 30, 5, 5 | 1 << (8 + bottom), 65, 165]
plot_volume.plot_marching_cases("hexa", HEX_CASES).show()
print({c: int(hex_count[c]) for c in HEX_CASES})

# %%
# every case's triangles are fans of closed polygons: a polygon of k crossed edges gives k - 2 triangles
for case in range(256):
    assert hex_count[case] == sum(len(p) - 2 for p in marching.hex_polygons(case)), case
# swapping above and below (nodes and face centres) changes no case's triangle count
case = np.arange(1 << 14)
swapped = (255 - (case & 255)) | ((63 - (case >> 8)) << 8)
assert np.array_equal(hex_count[case], hex_count[swapped])
# the face-centre rule matters: case 5 gives 2 separate triangles or one hexagon (4 triangles)
assert (hex_count[5], hex_count[5 | 1 << (8 + bottom)]) == (2, 4)

# %% [markdown]
# **Against VTK.** VTK's `vtkContourFilter` contours a hexahedron with the marching-cubes
# table of `vtkHexahedron`, which decides every ambiguous face one way: the above corners are
# cut off. That is our rule with the face centre below C. Contouring one cube per node case
# with VTK gives its triangle count per case: equal to ours on all 136 cases without an
# ambiguous face and on every ambiguous case decided that way; deciding the faces the other
# way changes the count on 88 of the 120 ambiguous cases. On hexahedral data 1 we split the
# crossed cells of each surface into three sets and let VTK contour each set alone:

# %%
hexa1 = datasets.load("hexa1")
grid_h, vtk_case = hexa1.to_pyvista(), np.zeros(256, int)
cube = pv.UnstructuredGrid(np.array([8, *range(8)]), np.array([pv.CellType.HEXAHEDRON]), marching.HEX_UNIT_CORNERS * 1.0)
for c in range(256):        # VTK's triangles per node case, one cube each
    cube.point_data["s"] = 0.1 + 0.8 * ((c >> np.arange(8)) & 1)
    vtk_case[c] = cube.contour([0.5], scalars="s").n_cells
n_vtk = lambda cells, v, f: grid_h.extract_cells(cells).contour([v], scalars=f).n_cells if cells.size else 0  # noqa: E731
hex_rows = []
for f in ["fem", "gaussians"]:
    for v in isovalues(hexa1.scalars(f), 20):
        ours = np.bincount(extract(hexa1, v, field=f).triangle_cells, minlength=hexa1.n_cells)
        node_case, n_amb, n_up, code = marching.hex_cell_cases(hexa1.cells, hexa1.scalars(f), v)
        crossed = (node_case % 255) != 0
        sets = {"no ambiguous face": crossed & (n_amb == 0), "centres below C": crossed & (n_amb > 0) & (n_up == 0),
                "a centre above C": crossed & (n_up > 0)}
        for k, m in sets.items():
            idx = np.flatnonzero(m)
            hex_rows.append({"field": f, "cells": k, "n": idx.size, "ours": int(ours[idx].sum()), "VTK": n_vtk(idx, v, f),
                             "VTK table": int(vtk_case[node_case[idx]].sum())})

# %%
summary = {}
for r in hex_rows:
    s_ = summary.setdefault((r["field"], r["cells"]), {"field": r["field"], "cells": r["cells"], "n": 0, "ours": 0, "VTK": 0})
    s_.update(n=s_["n"] + r["n"], ours=s_["ours"] + r["ours"], VTK=s_["VTK"] + r["VTK"])
print("hexa1, 20 values per field: crossed cells and their triangles, ours and VTK's")
print(plotting.table(list(summary.values()), ["field", "cells", "n", "ours", "VTK"]))
amb = np.array([len(marching.hex_ambiguous_faces(c)) for c in range(256)])
joined = np.array([hex_count[c | sum(1 << (8 + f) for f in marching.hex_ambiguous_faces(c))] for c in range(256)])
assert np.array_equal(hex_count[:256], vtk_case)        # every face centre below C: VTK's table, case for case
assert (amb == 0).sum() == 136 and np.count_nonzero(joined[amb > 0] != vtk_case[amb > 0]) == 88
for r in hex_rows:   # equal where the rules agree; where they do not, VTK makes exactly its table's triangles
    assert r["VTK"] == (r["ours"] if r["cells"] != "a centre above C" else r["VTK table"]), r

# %% [markdown]
# So every difference from VTK on a hexahedral mesh is a cell with an ambiguous face whose
# centre value is above C: there our rule joins the two above corners across the face (one
# polygon through the cell) and VTK's table cuts them off (two). On cells with no ambiguous
# face, and on those whose ambiguous faces both rules decide alike, the triangle counts are
# VTK's, surface for surface. On these smooth fields such cells are rare (the table: a few
# among tens of thousands of crossed cells). `tests/test_isosurface_vtk.py` runs the same
# comparison on hexahedral data 1–3.

# %% [markdown]
# ## Fig. 5.5 — isosurfaces at several values
#
# Isosurfaces of the heat-conduction field on data 1 at five values. Small values make
# closed surfaces around the cold spots, middle values surfaces that end on the volume's
# boundary.

# %%
vol = datasets.load(FIG_DATA)
s = vol.scalars()
strip_values = np.linspace(s.min(), s.max(), 7)[1:-1]
strip = [extract(vol, c) for c in strip_values]
plot_volume.plot_isosurface_strip(vol, strip).show()
for iso in strip:
    print(iso)

# %%
# vertices are shared: every surface edge is used by one triangle (on the volume boundary) or two
for iso in strip:
    t = iso.triangles
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, uses = np.unique(e, axis=0, return_counts=True)
    assert uses.max() == 2 and np.array_equal(np.unique(t), np.arange(iso.n_vertices)), iso
    assert iso.cells_intersected < iso.cells_tested == vol.n_cells

# %% [markdown]
# ## Fig. 5.3 — surface fitting against direct volume rendering
#
# The two ways to show a volume (5.3): fit polygons to isosurfaces and render them as any
# surface (left: the five surfaces above), or render the volume itself by sending rays through
# it and compositing the samples (right: VTK's ray caster over the same field sampled on a
# regular grid). The thesis's methods make the polygons of the left; the equi-distance
# surfaces of 7.8 make the right from polygons too.

# %%
plot_volume.plot_two_approaches(vol, strip).show()

# %% [markdown]
# With a kernel attached, the slider below extracts and draws the isosurface for any value
# (in a static rendering of the notebook it shows the middle value).

# %%
ipywidgets.interact(
    plot_volume.show_isosurface, vol=ipywidgets.fixed(vol), field=ipywidgets.fixed(None),
    method=ipywidgets.fixed("scan"),
    value=ipywidgets.FloatSlider(value=float(np.median(s)), min=float(s.min()), max=float(s.max()),
                                 step=float(np.ptp(s)) / 200, continuous_update=False),
);

# %% [markdown]
# ## Fig. 5.7 — propagation from a seed cell
#
# From one crossed seed cell, the FIFO queue registers the crossed face neighbours of each
# cell it takes out, marking every cell it tests. Colour = the FIFO step at which a
# triangle's cell was registered: the surface grows outwards from the seed in rings.

# %%
value = float(np.median(s))
scan = extract(vol, value)
seed = int(scan.triangle_cells[0])
prop = Propagator(vol)
grown = prop.extract(value, [seed])
order = prop.last_order
plot_volume.plot_propagation_order(vol, grown, order, seeds=[seed]).show()
print(f"scan: {scan.n_triangles} triangles after testing {scan.cells_tested} cells; "
      f"propagation from 1 seed: {grown.n_triangles} triangles after testing {grown.cells_tested} cells")

# %%
# breadth first: every registered cell after the seed has a face neighbour registered before it
rank = np.full(vol.n_cells, len(order))
rank[order] = np.arange(len(order))
nb = vol.face_neighbors[order]
earlier = np.where(nb >= 0, rank[np.maximum(nb, 0)], len(order)).min(axis=1)
assert order[0] == seed and np.all(earlier[1:] < np.arange(1, len(order)))
# the propagated triangles are the scan's (those of the seed's connected part), and only the seed, the crossed
# cells and their face neighbours are tested (5.4.2): at most that many, counted from this run's FIFO order
key = lambda iso: {tuple(sorted(t)) for t in iso.vertex_keys[iso.triangles].tolist()}  # noqa: E731
around = np.union1d(np.union1d(order, vol.face_neighbors[order].ravel()), [seed])
around = around[around >= 0]
print(f"tested {grown.cells_tested}; the seed, the {len(order)} crossed cells and their neighbours: {around.size}")
assert key(grown) <= key(scan) and grown.cells_tested <= around.size < scan.cells_tested

# %% [markdown]
# Propagation from one seed only reaches the part of the surface connected to it. Seeds in
# every part — here all the cells the scan found crossed — give the scan's surface exactly:

# %%
labels, n_parts = scan.connected_components()
every = prop.extract(value, np.unique(scan.triangle_cells))
print(f"{n_parts} connected parts; from all crossed seeds: {every.n_triangles} triangles")
assert key(every) == key(scan) and every.n_triangles == scan.n_triangles

# %% [markdown]
# ## Table 5.1 — intersected and not-intersected cells
#
# Twenty isovalues `linspace(min, max, 22)[1:-1]` per volume; N_i = cells intersected
# (summed over the 20 values), N_n = cells tested in vain by a full scan, 20 N_c = all tests.
# The thesis's point: a full scan wastes most of its work, and more so on larger volumes,
# since a surface meets O(n^{2/3}) of n cells.

# %%
# Table 5.1 of the thesis: (N_i intersected, N_n not intersected) over 20 isovalues
T51 = {"data1": (51357, 363363), "data2": (62377, 1171223), "data3": (148836, 6784044), "data4": (277457, 10879903)}
rows = []
for name in TABLE_DATA:
    v, t = datasets.load(name), datasets.info(name).thesis
    sv = v.scalars()
    isos = [extract(v, c, normals=None) for c in np.linspace(sv.min(), sv.max(), 22)[1:-1]]
    ni = sum(iso.cells_intersected for iso in isos)
    rows.append({"data": name, "extrema": find_extrema(v).n, "closed parts": sum(int(i.components()["closed"].sum()) for i in isos),
                 "N_c": v.n_cells, "N_i": ni, "N_i thesis": T51[name][0],
                 "N_n": 20 * v.n_cells - ni, "N_n thesis": T51[name][1], "20 N_c": 20 * v.n_cells,
                 "20 N_c thesis": 20 * t["cells"], "N_i/20N_c": ni / (20 * v.n_cells),
                 "N_i/20N_c thesis": T51[name][0] / (20 * t["cells"])})
print(plotting.table(rows, list(rows[0])))

# %% [markdown]
# The thesis's claim: the larger the volume, the larger the share of cells not intersected,
# so a full scan wastes more of its work on larger volumes — and, first of all, an isosurface
# meets only a small part of the cells. Both are checked on the ratios computed above. The
# first holds from data 1 to data 3 and fails at data 4, for us as in the thesis's own table
# (0.021 then 0.025): data 4 is a part with many more extrema than data 3, and so its
# twenty surfaces have many more closed parts around them — more surface for its size. We
# check that reason on the counts of this run (extrema, closed parts).

# %%
r = [row["N_i/20N_c"] for row in rows]
assert all(x < 0.5 for x in r), r                 # most of the full scan's tests hit nothing
assert r[0] > r[1] > r[2], r                      # the share intersected falls with the size, data 1-3 ...
assert r[3] > r[2]                                # ... not at data 4 (as in the thesis), because it has
assert rows[3]["extrema"] > rows[2]["extrema"] and rows[3]["closed parts"] > rows[2]["closed parts"], rows

# %% [markdown]
# ## Fig. 5.6 — span space
#
# Livnat's view of the search (5.4.1): each cell is the point (S_min, S_max) of its node
# range, above the diagonal; the cells `S = C` may cross are the quadrant S_min ≤ C ≤ S_max
# (a). The span-space k-d tree splits the points at the median of S_min and S_max in turn (b),
# the ISSUE lattice into L × L classes of equally many cells each way (c). Data 1's cells, and
# the structures polygen builds over them (their own split values):

# %%
cv = s[vol.cells]
cmin, cmax = cv.min(axis=1), cv.max(axis=1)
span, lattice = seeds.get("span-space").build(cmin, cmax), seeds.get("issue-lattice").build(cmin, cmax)
plot_volume.plot_span_space(cmin, cmax, value, span, lattice);
# both structures hand over exactly the cells of the quadrant (a), found by testing every cell here
quadrant = np.flatnonzero((cmin <= value) & (value <= cmax))
assert all(np.array_equal(np.sort(st_.query(value).cells), quadrant) for st_ in (span, lattice))

# %% [markdown]
# ## Table 5.2 — active-cell searches, measured
#
# Each structure is built once over the cells' intervals `[S_min, S_max]` and answers "which
# cells contain `C`?". Synthetic intervals shaped like an FEM field on n cells (`S_min`
# uniform, span ~ n^{-1/3}, so k ~ n^{2/3} hits per value); 20 values per size. Besides the
# times we count the **cells tested** — the work that Table 5.2's query costs describe — and
# fit log–log slopes.

# %%
T52 = {"full-scan": ("-", "O(n)"), "sorted-lists": ("O(n log n)", "O(n)"), "span-filter": ("O(n)", "O(n)"),
       "span-space": ("O(n log n)", "O(√n + k)"), "issue-lattice": ("O(n log n)", "O(log(n/L) + √n/L + k)"),
       "interval-tree": ("O(n log n)", "O(log n + k)")}
for name in T52:                       # compile every kernel before timing
    seeds.get(name).build(np.arange(100.0), np.arange(100.0) + 3).query(50.0)
rng = np.random.default_rng(0)
search_rows = []
for n in SEARCH_N:
    lo = rng.random(n)
    hi = lo + rng.exponential(0.5 * n ** (-1 / 3), n)
    values = np.linspace(lo.min(), hi.max(), 22)[1:-1]
    for name in T52:
        st = seeds.get(name).build(lo, hi)
        res = [st.query(c) for c in values]
        query_s = min(timeit.repeat(lambda: [st.query(c) for c in values], number=1, repeat=3))  # noqa: B023
        k = sum(r.n_hits for r in res)
        search_rows.append({"method": name, "n": n, "preprocess s": st.preprocess_s, "query s (20)": query_s,
                            "cells tested": sum(r.n_tested for r in res), "hits k": k,
                            "tested - k": sum(r.n_tested for r in res) - k})

# %%
fig, slopes = plot_volume.plot_loglog(search_rows, ["preprocess s", "query s (20)", "cells tested", "tested - k"],
                                      titles={"tested - k": "tested - k (the search term)"})
print(plotting.table([{"method": m, "Table 5.2 pre": T52[m][0], "Table 5.2 query": T52[m][1],
                       **{f"slope {y}": slopes[y][m] for y in slopes}} for m in T52],
                     ["method", "Table 5.2 pre", "Table 5.2 query", "slope preprocess s",
                      "slope query s (20)", "slope cells tested", "slope tested - k"], floatfmt="{:.2f}"))

# %% [markdown]
# Times on a small shared machine are noisy and are not asserted; the counts are exact. What
# Table 5.2 claims about the query, checked on the counts: the full scan, the sorted lists
# and span filtering test O(n) cells (slope ≈ 1); the span-space k-d tree's search term grows
# like √n (slope ≈ ½); the ISSUE lattice's and the interval tree's are far below that, the
# tree's nearly constant (log n). Every sublinear structure tests about as many cells as it
# finds (k ~ n^{2/3} here).

# %%
st, ov = slopes["cells tested"], slopes["tested - k"]
k_slope = plot_volume.loglog_slope([r["n"] for r in search_rows if r["method"] == "full-scan"],
                                   [r["hits k"] for r in search_rows if r["method"] == "full-scan"])
assert all(ov[m] > 0.9 for m in ["full-scan", "sorted-lists", "span-filter"]), ov
assert 0.35 < ov["span-space"] < 0.65, ov
assert ov["interval-tree"] < 0.25 and ov["issue-lattice"] < ov["span-space"], ov
assert all(abs(st[m] - k_slope) < 0.1 for m in ["span-space", "issue-lattice", "interval-tree"]), (st, k_slope)

# %% [markdown]
# ## Explorer
#
# `polygen.widgets.isosurface_explorer` puts the whole chapter in one panel: an isovalue
# slider, a field and a method picker, the counters (triangles, cells tested and intersected,
# extraction and drawing times) and the surface. With a kernel attached every slider move
# extracts with `vol.isosurface` (the method is prepared once per field) and draws; a static
# rendering of the notebook shows the first state. The surface it shows is the full scan's.

# %%
from polygen.volume.surface import same_surface
from polygen.widgets import isosurface_explorer

explorer = isosurface_explorer(vol, window_size=(640, 400))
assert same_surface(explorer.surface, extract(vol, explorer.value, field=explorer.field))
explorer
