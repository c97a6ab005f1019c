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
# # Chapter 4 — the intensity-based bubble mesh
#
# Adaptive subdivision (Def. 2.6) refines a first mesh where the first radiosity solution
# jumps: a fine first mesh costs many elements after refinement, a coarse one misses small
# shadows (4.1). Chapter 4 meshes **again** instead: from the first solution it computes at
# every node the **intensity variation** D (4.1), maps it linearly to an **element size**
# f(D) — `size_min` where D is smallest, `size_max` where it is largest (4.2–4.4; the naming
# is the thesis's: `size_max` is the *smallest* size) — spreads the sizes over a rectangular
# **size grid** per polygon (inverse-distance weights near the nodes (4.5), a **thin plate**
# bent through them elsewhere (4.6–4.10)), and runs the bubble mesh again, reading the grid
# by bilinear interpolation (4.12, 4.13). The loop is Fig. 4.3.
#
# This notebook validates the plate element on textbook plates, runs the loop on the scene of
# Fig. 4.8 (a box with three floating rectangles), shows the size function (Fig. 4.1), a
# size grid as an image and as the bent plate (Fig. 4.2), the three meshes and their
# renderings (Figs 4.8–4.13), Tables 4.1 and 4.2 beside the thesis's numbers, the meshes'
# quality, Theorem 4.1 on a family of size grids, the thesis's tree/quadtree placements
# against ours, the thesis's future work — this method combined with chapter 3's simplified
# discontinuity meshing — and the image error of all of them against element count.
# Algorithms are in `polygen.radiosity.intensity`, `polygen.discontinuity.combined`,
# `polygen.mesh2d.size_grid`, `polygen.mesh2d.plate` and `polygen.mesh2d.theorem41`; the
# figures in `polygen.plotting.intensity`.

# %%
import json
import os
from pathlib import Path

FULL = os.environ.get("POLYGEN_FULL") == "1"   # thesis-like sizes when set

import matplotlib.pyplot as plt
import numpy as np

from polygen.mesh2d import element_size_grid
from polygen.mesh2d.plate import square_plate_centre
from polygen.plotting import intensity as plot_intensity
from polygen.plotting import radiosity as plot_radiosity
from polygen.plotting import table
from polygen.radiosity import Camera, intensity_bubble_mesh, scenes
from polygen.radiosity.error import shade
from polygen.radiosity.intensity import PHASES, error_at_elements

# %%
SIZE_INITIAL = 1.7 if FULL else 2.4   # patch size of the first mesh (1.7: 2056 elements)
# (4.3); the thesis gives no values: size_min from the thesis's element ratio (below)
SIZE_MIN, SIZE_MAX = 2.2 / 1.7 * SIZE_INITIAL, SIZE_INITIAL / 2
IMPROVE = 3                           # the bubble mesh's quality rounds on the second mesh
ADAPTIVE = 0.1                        # adaptive subdivision: jump / bright radiosity
IMAGE = 256 if FULL else 160
TIMOSHENKO = {"simply_supported": 0.00406235, "clamped": 0.00126532}   # w q a^4 / D
THESIS_4_1 = {"first mesh": 1976, "adaptive re-mesh": 3205, "this method": 1396}
THESIS_4_2 = dict(zip(PHASES, (31.51, 277.31, 171.75, 42.23, 225.54)))   # seconds, RS/6000

# %% [markdown]
# ## The plate element (4.6–4.10) on textbook plates
#
# On each grid cell the deflection w is the 12-term polynomial (4.7), fixed by w and its two
# slopes at the four corners (4.8–4.10): the rectangular element of Adini–Clough and
# Melosh–Zienkiewicz (ACM). It is non-conforming (the normal slope jumps across cell edges),
# so its convergence is not guaranteed by the energy argument; it passes the patch test and
# converges as O(h²). A square plate of side a under uniform load q has its centre at
# 0.00406235 q a⁴/D simply supported and 0.00126532 q a⁴/D clamped (Timoshenko &
# Woinowsky-Krieger). Below: full plates of m × m elements, the quarter plate of 16 × 16 (by
# symmetry the full plate of 32 × 32, the way FE convergence tables usually count), and
# Richardson's extrapolation from 16 and 32.

# %%
ms = [4, 8, 16, 32]
w = {s: np.array([square_plate_centre(s, m) for m in ms]) for s in TIMOSHENKO}
rows = []
for s, ref in TIMOSHENKO.items():
    rich = (4 * w[s][-1] - w[s][-2]) / 3
    for label, v in [*((f"{m} x {m}", x) for m, x in zip(ms, w[s])), ("Richardson 16/32", rich)]:
        rows.append({"support": s, "mesh": label, "w / (q a^4 / D)": f"{v:.8f}",
                     "Timoshenko": ref, "error %": f"{100 * (v / ref - 1):+.3f}"})
print(table(rows, ["support", "mesh", "w / (q a^4 / D)", "Timoshenko", "error %"]))
err = {s: np.abs(w[s] / r - 1) for s, r in TIMOSHENKO.items()}
slopes = {s: np.polyfit(np.log(1 / np.array(ms)), np.log(e), 1)[0] for s, e in err.items()}
print("fitted convergence order:", {s: round(v, 3) for s, v in slopes.items()})
plot_intensity.plot_plate_convergence(1 / np.array(ms), err)
plt.show()
# O(h^2), and 16 x 16 on the quarter plate (32 x 32 on the full one) within 0.5 %
assert all(1.8 < v < 2.2 for v in slopes.values())
assert all(e[-1] < 0.005 for e in err.values())

# %% [markdown]
# On the full plate with 16 × 16 elements the simply supported plate is within 0.41 % and the
# clamped one within 0.78 %; 0.5 % for both needs the 32 × 32 full plate (16 × 16 on a
# quarter). Richardson's extrapolation lands on Timoshenko's series to five digits, which is
# the check that the element (and its assembly) is right.
#
# ## The two-pass loop (Fig. 4.3) on the scene of Fig. 4.8
#
# First a uniform bubble mesh of patch size `size_initial` (4 elements per patch) and a
# progressive-refinement solution; then D, f(D), the size grids, a second bubble mesh and a
# second solution. The conventional adaptive subdivision (Def. 2.6) refines the same first
# mesh from the same first solution. Parameters (the thesis gives none): `size_max` =
# `size_initial` / 2, the grid step the finest element's size (`size_max` / 2), the adaptive
# threshold 0.1 of the bright surfaces' radiosity (as in chapter 2's yardstick), three
# rounds of the bubble mesh's quality improvement on the second mesh, and `size_min` =
# 2.2 / 1.7 `size_initial`, anchored to the thesis as the next paragraph says.
#
# **What the original says about Table 4.1's settings.** Re-read for this notebook (4.2–4.4,
# the caption "メッシュ生成結果におけるエレメント数とノード数" and its one paragraph): no value of
# `size_initial`, `size_min`, `size_max`, the grid's m × n, the scene's dimensions or the
# subdivision of patches is given; the table has element counts only (its caption names node
# counts, the table has none). Each reading that could shrink our second mesh against the
# thesis's was checked against the text:
#
# * *size = bubble diameter = edge length.* 4.3.3: the size value at a bubble's centre "is
#   the bubble's diameter" (直径); the appendix: a packed edge is 0.5 (r_a + r_b). Our bubble
#   mesh takes the size as the diameter, so a uniform mesh's edges are the size.
# * *patch or element size.* 4.2 and 4.3.3: the bubble mesh makes **patches**, which are then
#   divided into elements (pattern mapping or recursive division, 2.3); `size_initial` is "the
#   element size value of the first radiosity", and the first mesh is a bubble mesh too (4.4).
#   We use one convention in both passes (the size is the patch's, each patch 4 elements), and
#   with it our first mesh (2056) and the adaptive re-mesh (3109) are within 5 % of 1976 and
#   3205. Dividing patches to a *fixed* element size instead would make the second mesh's
#   element count independent of its patch sizes, so it could not fall below the first's as
#   the thesis reports: not the thesis's reading.
# * *D and its normalisation.* (4.1) D = max_i |I_i − I| / dist_i over the nodes joined by an
#   element edge, the largest over RGB; D_min and D_max over **all** nodes (4.3.1, "すべてのノード");
#   f linear in D (4.4, "一次関数"), not in log D. As implemented.
#
# So the reading stands, and the count of Table 4.1's second mesh follows from an unstated
# parameter: on our scene f is linear between D_min = 0 and a D_max set by the horizontal
# rectangle 3.5 below the light (the 1 % largest D all lie on it, below), so most of the
# scene is near `size_min`, and `size_min` decides how many elements the second mesh has.
#
# **Table 4.1 anchored to the thesis.** The one number the thesis gives for it is the
# proportion: its second mesh keeps 1396 / 1976 = 70.6 % of its first mesh's elements. The
# rule, fixed before any quality or error was measured at its result: with `size_initial`
# 1.7, `size_max` 0.85 and the improvement as in the tests, bisect `size_min` on (1.7, 3.4]
# until the second / first ratio is bracketed within 0.025, and round the midpoint to 0.05
# (`benchmarks/intensity_mesh.py --calibrate`, only element counts looked at). The steps
# are below: `size_min` **2.2** (1.29 `size_initial`), 1448 / 2056 = 70.4 %. This notebook
# uses the same ratio at its own `size_initial`.
#
# *Measured aside, the earlier setting.* Before this calibration `size_min` = 2
# `size_initial` (3.4) was fixed, also before measuring: its second mesh kept 632 / 2056 =
# 31 % of the first's elements (600 without the improvement), mean q 0.888 and 30.2°, image
# error 0.061 with 600 elements (benchmark before the calibration); its figures stay in the
# benchmark's size_min sweep (2×).

# %%
calib = json.loads((Path("..") / "benchmarks" / "results" /
                    "intensity_mesh_calibrate.json").read_text())["rows"]
print(table(calib, ["step", "size_min", "second", "first", "ratio", "lo", "hi"]))
print(f"thesis: {THESIS_4_1['this method']} / {THESIS_4_1['first mesh']} = "
      f"{THESIS_4_1['this method'] / THESIS_4_1['first mesh']:.4f}")

# %%
scene = scenes.three_rectangles_box()
run = intensity_bubble_mesh(scene, size_initial=SIZE_INITIAL, size_min=SIZE_MIN,
                            size_max=SIZE_MAX, adaptive_threshold=ADAPTIVE, solve_adaptive=True,
                            improve=IMPROVE)
counts = {"first mesh": run.first_mesh.n_elements,
          "adaptive re-mesh": run.adaptive_mesh.n_elements,
          "this method": run.second_mesh.n_elements}
print("Table 4.1 — elements")
print(table([{"mesh": k, "ours": v, "thesis": THESIS_4_1[k]} for k, v in counts.items()],
            ["mesh", "ours", "thesis"]))
print("\nTable 4.2 — seconds (thesis: IBM RS/6000 model 560; ours: wall and CPU, shared machine)")
rows = [{"phase": p, "wall": round(run.seconds[p], 2), "CPU": round(run.cpu_seconds[p], 2),
         "thesis": THESIS_4_2[p]} for p in PHASES]
rows.append({"phase": "total", "wall": round(run.total_seconds, 2),
             "CPU": round(sum(run.cpu_seconds[p] for p in PHASES), 2),
             "thesis": round(sum(THESIS_4_2.values()), 2)})
print(table(rows, ["phase", "wall", "CPU", "thesis"]))
# Table 4.1: this method's second mesh < the first mesh < the conventional adaptive re-mesh
assert counts["this method"] < counts["first mesh"] < counts["adaptive re-mesh"]

# %% [markdown]
# The ordering of Table 4.1 holds (asserted above), and at `size_initial` 1.7 so does its
# proportion, by construction: 1448 < 2056 < 3109 elements against the thesis's 1396 < 1976
# < 3205 (tests and benchmark; the first mesh and the adaptive re-mesh within 5 %, the second
# mesh 70.4 % of the first against 70.6 %). At this notebook's default `size_initial` 2.4
# the same ratio keeps 78 % (832 / 1064): the proportion depends on the scene's D at that
# resolution, so it is calibrated at Table 4.1's size only.
# Table 4.2: on this shared 2-core machine wall time is several times the CPU time; the
# size-function step is a fraction of a second (the thesis: 172 s, more than its meshing).
#
# ## Fig. 4.1 — the size function, and Fig. 4.2 — a size grid and its plate
#
# Every node's (D, f(D)) lies on the line of (4.4); the histogram shows how D is spread.
# The floor's size grid: an image (white dots: the grid points filled by the plate, or those
# assigned by (4.5) when they are the fewer; crosses: the first mesh's nodes). With the loop's grid (step: the finest element)
# nearly every grid point has a node in one of its four cells, so (4.5) fills it; on a grid
# of step 0.1 the plate fills most points, and its surface is drawn as well.

# %%
floor = next(k for k, p in enumerate(scene.polygons) if p.name == "box_y0")
xy, _, _, fnodes = run.first_mesh.polygon_elements(floor)
ext = scene.polygons[floor].exterior_2d
fine = element_size_grid(xy, run.node_size[fnodes], (*ext.min(axis=0), *ext.max(axis=0)),
                         grid=0.1)
fig, axes = plt.subplots(1, 3, figsize=(16, 4))
plot_intensity.plot_size_function(run.variation, run.node_size, ax=axes[0])
for ax, g, name in ((axes[1], run.size_grids[floor], "the loop's grid"), (axes[2], fine, "step 0.1")):
    plot_intensity.plot_size_grid(g, scene.polygons[floor], nodes=xy, ax=ax, vmin=SIZE_MAX,
                                  vmax=SIZE_MIN, title=f"floor, {name}: (4.5) + plate")
fig.tight_layout()
plt.show()
plot_intensity.plot_plate_surface(fine)
plt.show()
for name, g in (("loop", run.size_grids[floor]), ("step 0.1", fine)):
    print(f"floor grid ({name}) {g.values.shape[1]} x {g.values.shape[0]}: {g.assigned.sum()} "
          f"points by (4.5), {(~g.assigned).sum()} by the plate; sizes "
          f"{g.values.min():.2f}..{g.values.max():.2f}")
top = np.argsort(run.variation)[-len(run.variation) // 100:]   # the 1 % largest D
where = np.unique(run.first_mesh.element_polygon[run.first_mesh.node_elements[1][
    run.first_mesh.node_elements[0][top]]], return_counts=True)
print("nodes with the 1 % largest D, by polygon:",
      {scene.polygons[k].name: int(c) for k, c in zip(*where)})

# %% [markdown]
# ## Figs 4.8–4.10 — the first mesh, adaptive subdivision, and this method
#
# The floor of the three meshes (thin lines: elements; thick: patches).

# %%
fig, axes = plt.subplots(1, 3, figsize=(14, 4.8))
for ax, (name, m) in zip(axes, [("first mesh (Fig. 4.8)", run.first_mesh),
                                ("adaptive subdivision (Fig. 4.9)", run.adaptive_mesh),
                                ("this method (Fig. 4.10)", run.second_mesh)]):
    plot_radiosity.plot_polygon_mesh(m, floor, ax=ax)
    ax.set_title(f"{name}: {int((m.element_polygon == floor).sum())} floor elements",
                 fontsize=9)
fig.tight_layout()
plt.show()

# %% [markdown]
# ## Figs 4.11–4.13 — the renderings
#
# Gouraud-shaded images of the three solutions from one camera inside the box.

# %%
camera = Camera([5.0, 6.0, 0.3], [5.0, 3.5, 6.0], fov=75.0, width=IMAGE, height=IMAGE, near=0.01)
images = [np.nan_to_num(shade(m, b, camera)) for m, b in
          [(run.first_mesh, run.first_radiosity), (run.adaptive_mesh, run.adaptive_radiosity),
           (run.second_mesh, run.second_radiosity)]]
plot_radiosity.show_images(images, [f"Fig. 4.11: first ({counts['first mesh']} el.)",
                                    f"Fig. 4.12: adaptive ({counts['adaptive re-mesh']} el.)",
                                    f"Fig. 4.13: this method ({counts['this method']} el.)"],
                           size=4.0)
plt.show()

# %% [markdown]
# ## Mesh quality of the second mesh
#
# We ask for a mean radius ratio q ≥ 0.93 and a smallest angle ≥ 25° on the second
# mesh (the thesis says only that the smooth size function gives little distortion, 4.5).
# Each element is measured in its polygon's plane from its own face. At Table 4.1's
# parameters (`size_initial` 1.7, `size_min` 2.2, improvement on; `test_graded_mesh_quality`,
# measured only after `size_min` was fixed) the second mesh has **mean q 0.946 and 30.5°**:
# both of the thresholds hold (walls 0.951–0.961; the light and the small rectangles
# 0.77–0.87, fewer than their corners can beat). What was in the way before:
#
# * **The smallest angle: the ceiling.** Around the light (2 × 2) the ceiling is a channel 4
#   wide; at `size_min` 3.4 the size grid asked for 3.3 there, the light's sides got no edge
#   bubble and the Delaunay joined a light side to a wall node (24.4°, whatever the seed).
#   `improve=3` inserts a bubble at the circumcentre of every triangle under 30° and smooths
#   the face bubbles (Laplacian, with Delaunay reconnection), keeping a round only if it is
#   better: 30.2° there. It is opt-in (`bubble_mesh(improve=)`,
#   `intensity_bubble_mesh(improve=)`; it can lower q on some seeds, 0.822 → 0.795 on one
#   channel), and Table 4.1's setting uses it.
# * **The mean q: coarseness, not grading.** At `size_min` = 2 `size_initial` (the measured
#   aside) the walls had three patches across (every 90° wall corner a right triangle, q ≤
#   0.828) and the light, the tilted and the upright rectangle were two right triangles each
#   (q 0.828 / 0.828 / 0.774 = 2(a + b − c)/c, the best with their corners alone; test):
#   mean 0.888. A *uniform* bubble mesh of the walls' size (3.3) has 0.861.
#
# At this notebook's default `size_initial` 2.4 (the same ratios) the claim **does not hold**:
# the mean q is 0.9299 with the improvement (0.906 without), below 0.93; the smallest angle
# is 32.6° (28.1°). The reason is the coarseness above, measured polygon by polygon below: at
# this size the light (2 × 2), the tilted (2.5 × 2.5) and the upright (3 × 2) rectangle are
# about one patch size across and get 2, 4 and 4 patches, all of them right triangles of the
# rectangle's own shape (its halves, or the halves cut again from the right angle), split
# 1 → 4 into similar elements: every one of their 40 elements has q = 2(a + b − c)/c of its
# rectangle's sides a, b and diagonal c (0.828, 0.828, 0.774), far below 0.93, and a
# bubble mesh with so few bubbles has nothing better to offer. The ceiling, a channel around
# the light, comes next (0.912). So the default run asserts what
# it measures, on quantities that do not drift with the solution: the smallest angle ≥ 25°,
# every element of those three polygons at its rectangle's closed form, and the improvement
# raising the mean q. The claim itself, q ≥ 0.93
# at Table 4.1's parameters (measured 0.946), is asserted when `POLYGEN_FULL=1` and by the
# slow test `test_graded_mesh_quality` (about two minutes here).

# %%
plain = intensity_bubble_mesh(scene, size_initial=SIZE_INITIAL, size_min=SIZE_MIN,
                              size_max=SIZE_MAX, first=run)
quality = {}
for name, m in (("first mesh", run.first_mesh), ("adaptive re-mesh", run.adaptive_mesh),
                ("this method (improve=3)", run.second_mesh),
                ("this method, no improve", plain.second_mesh)):
    quality[name] = m.element_quality()
    ang, q = quality[name]
    print(f"{name:24s} {m.n_elements:5d} elements: mean q {q.mean():.4f}, "
          f"smallest angle {ang.min():.1f} deg, {100 * np.mean(ang < 25):.1f} % below 25 deg")
ang, q = quality["this method (improve=3)"]
second = run.second_mesh
by_polygon = []
for k, poly in enumerate(scene.polygons):
    sel = second.element_polygon == k
    by_polygon.append({"polygon": poly.name, "patches": len(np.unique(second.element_patch[sel])),
                       "elements": int(sel.sum()), "mean q": round(float(q[sel].mean()), 4)})
print(table(by_polygon, ["polygon", "patches", "elements", "mean q"]))

# %%
# smallest angle >= 25 deg on the second mesh; mean q >= 0.93 at Table 4.1's size
assert ang.min() >= 25.0
if FULL:
    assert q.mean() >= 0.93
else:
    # at 2.4 the three small rectangles are a few patches of their own right triangle: every
    # element at the closed form 2 (a + b - c) / c of its rectangle (sides from the scene)
    for name in ("light", "rect_tilted", "rect_upright"):
        k = next(j for j, p in enumerate(scene.polygons) if p.name == name)
        v = scene.polygons[k].vertices
        a, b = np.linalg.norm(v[1] - v[0]), np.linalg.norm(v[2] - v[1])
        assert len(v) == 4 and abs(np.dot(v[1] - v[0], v[2] - v[1])) < 1e-9 * a * b   # a rectangle
        c = np.hypot(a, b)
        sel = second.element_polygon == k
        np.testing.assert_allclose(q[sel], 2 * (a + b - c) / c, rtol=1e-9, err_msg=name)
    assert q.mean() > quality["this method, no improve"][1].mean()   # improve keeps better rounds

# %% [markdown]
# ## Theorem 4.1 — the sharper the size variation, the skinnier the triangles
#
# The appendix: in a relaxed packing two neighbours of diameters r_i, r_j sit 0.5 (r_i + r_j)
# apart, so a triangle with vertex sizes r_a ≤ r_b = s r_a ≤ r_c = t r_a has the edge-length
# ratio (s + t) / (1 + s), between 2t / (1 + t) and (1 + t) / 2 (`polygen.mesh2d.theorem41`).
# A family of size grids on the unit square: ramps from 0.02 to 0.16 (ratio 8) of increasing
# gradient; for the triangles meeting the ramp, the vertex size ratio t and the measured
# longest / shortest edge.

# %%
from polygen.mesh2d import GridSize, bubble_mesh, triangle_quality
from polygen.mesh2d.theorem41 import edge_length_ratio, packed_edge_ratio_bounds, vertex_size_ratio

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
family = {}
for slope in (0.15, 0.4, 1.0, 1.6):
    ramp = GridSize.from_function(lambda xy, g=slope: np.clip(
        0.02 + g * (xy[:, 0] - 0.5 + 0.07 / g), 0.02, 0.16), (0, 0, 1, 1), (65, 65))
    bm = bubble_mesh(SQUARE, (), ramp, seed=0)
    r = ramp(bm.nodes)[bm.triangles]
    on = r.max(axis=1) > r.min(axis=1) * (1 + 1e-9)
    family[slope] = (vertex_size_ratio(r[on]), edge_length_ratio(bm.nodes, bm.triangles)[on],
                     triangle_quality(bm.nodes, bm.triangles)[0][on])
print(table([{"slope |grad size|": g, "triangles": len(t), "median t": round(np.median(t), 3),
              "median edge ratio": round(np.median(e), 3), "smallest angle": round(a.min(), 1)}
             for g, (t, e, a) in family.items()],
            ["slope |grad size|", "triangles", "median t", "median edge ratio", "smallest angle"]))

# %%
fig, ax = plt.subplots(figsize=(6, 4))
for g, (t, e, _) in family.items():
    ax.scatter(t, e, s=4, alpha=0.5, label=f"slope {g}")
tt = np.linspace(1, 3, 50)
lo, hi = packed_edge_ratio_bounds(tt)
ax.plot(tt, lo, "k--", lw=1, label="2t/(1+t)")
ax.plot(tt, hi, "k-", lw=1, label="(1+t)/2")
ax.set(xlabel="vertex size ratio t", ylabel="longest / shortest edge", xlim=(1, 3), ylim=(1, 3),
       title="Theorem 4.1 on ramps of ratio 8")
ax.legend(fontsize=7)
plt.show()
med = [np.median(e) for _, e, _ in family.values()]
# the claim: sharper size variation -> skinnier triangles (median edge ratio grows with slope)
assert all(a < b for a, b in zip(med, med[1:]))

# %% [markdown]
# The packed ratio is a lower estimate of what relaxation leaves (the bubbles are not all
# touching), but the ordering is the theorem's: the median edge-length ratio grows with the
# gradient. `benchmarks/results/mesh2d_graded.md` has the full family for both placements
# (Spearman correlation of slope and median ratio 1.0 for each).
#
# ## Initial placements: the thesis's binary tree and quadtree against quantiles and a lattice
#
# The thesis places edge bubbles by a binary tree and face bubbles by a quadtree (4.3.3,
# Fig. 4.7); our default puts edge bubbles at quantiles of the size along the edge and face
# bubbles on a hexagonal lattice graded by the size. On four size fields of the unit square
# (ratio 8), from `benchmarks/mesh2d.py`, and one pair drawn on the steep field:

# %%
graded = json.loads((Path("..") / "benchmarks" / "results" / "mesh2d_graded.json").read_text())
cols = ["field", "face", "edge", "neighbours", "improve", "ideal", "final", "q_mean", "angle_min"]
print(table([{k: r.get(k, 0) for k in cols} for r in graded["rows"]], cols))
steep = GridSize.from_function(lambda xy: 0.0125 + 0.0875 * 0.5 * (
    1 + np.tanh((xy[:, 0] - 0.5) / 0.05)), (0, 0, 1, 1), (33, 33))
fig, axes = plt.subplots(1, 2, figsize=(11, 5))
for ax, (init, edge) in zip(axes, (("lattice", "quantile"), ("quadtree", "tree"))):
    bm = bubble_mesh(SQUARE, (), steep, init=init, edge_init=edge, seed=0)
    ang, q = triangle_quality(bm.nodes, bm.triangles)
    plot_radiosity.plot_mesh2d(bm.nodes, bm.triangles, values=q, vmin=0.5, vmax=1.0, ax=ax,
                               title=f"{init}/{edge}: {len(bm.nodes)} nodes, mean q "
                                     f"{q.mean():.3f}, min angle {ang.min():.1f}")
fig.tight_layout()
plt.show()

# %% [markdown]
# Neither placement wins everywhere: the quadtree/tree start is better on the linear field
# and the Gaussian dip (q 0.980 / 0.971 against 0.973 / 0.958), the lattice/quantile start on
# the uniform and steep fields (0.997 / 0.991 against 0.983 / 0.982); the smallest angle of
# the steep field is 23.9° from the lattice/quantile start and 25.1–28.3° from the others.
# Both are kept (`bubble_mesh(..., init=, edge_init=)`), the lattice the default.
#
# ## The thesis's future work: with simplified discontinuity meshing (4.5)
#
# The thesis ends chapter 4 proposing to combine this method with chapter 3's simplified
# discontinuity meshing. `polygen.discontinuity.combined.combined_bubble_mesh` does it: both
# meshes of the loop keep the scene's discontinuity lines as constrained segments (D0: nodes
# duplicated across, so the first solution's shadow jump does not enter D; D1: shared), and
# every region between the lines gets its own size grid, from the nodes of that region only,
# so that the plate never smooths a size across a line.
#
# Lines much closer to each other than the element size are merged first, as the thesis
# proposes among its future work (chapter 8: delete discontinuity lines lying much closer
# than the element size; `polygen.mesh2d.merge_close_segments`, at half the finest element,
# `size_max` / 4): the scene's penumbra bands are 0.036–0.042 wide, and meshed at patch size
# 1.7–2.4 they gave triangles of 2.05° (the combination's smallest angle before). Merged, the
# smallest angle of the combination's first mesh at `size_initial` 2.4 was 6.9°: left were
# regions narrower than their size (a line meeting a wall near a corner, a wedge between two
# lines). Now each region's size is **capped by its local width**
# (`polygen.mesh2d.region_width`: the chord through a point perpendicular to its nearest
# boundary edge, so a strip w wide is meshed at w, a right-angled corner is not narrow, and
# a wedge of angle φ narrows as r tan φ towards its apex), never below the finest element
# (`size_max` / 2), and the sizes grow from a capped spot by at most 0.5 per unit of 3-D
# distance, across polygons too (a fine strip along a wall makes that edge's nodes fine on
# the wall as well). On the first mesh at 2.4 the smallest angle goes 6.9° → 12.3° and the
# mean q 0.835 → 0.885, at a price in elements (1288 → 2440). The geometric bound, half the
# smallest angle between lines at a vertex (21.4°), is still not met (strict xfail in
# `tests/test_intensity_mesh.py`): the triangles left below it sit where a node that the
# neighbouring polygon puts on a shared edge falls next to a line's end on that edge.
#
# The second mesh keeps fewer lines (`lines="single"`, the default since the
# measurement below): the D0 lines; the stretches of D1 lines along a penumbra narrower than
# the element the first pass's size grid asks there (a wider penumbra is a smooth ramp that
# the size grid resolves; `narrow_lines`); and of two kept lines closer than the largest
# element (`size_min` / 2) only the longer (`single_lines`), so that a narrow penumbra is one
# line and no strip narrower than an element is left for the width cap to fill. Those lines are
# open (one per narrow penumbra) and close no region, so with `"single"` every polygon gets one
# size grid and the plate does smooth across them: the print below lists no polygon with grids
# per region (with `lines="all"` five polygons get them, the floor among them).
# %%
from polygen.discontinuity import simplified_discontinuity
from polygen.discontinuity.combined import combined_bubble_mesh
from polygen.radiosity.layout import RegionSize

sd = simplified_discontinuity(scene)
combo = combined_bubble_mesh(scene, size_initial=SIZE_INITIAL, size_min=SIZE_MIN,
                             size_max=SIZE_MAX, discontinuity=sd, improve=IMPROVE)
cut = [k for k, g in enumerate(combo.size_grids) if isinstance(g, RegionSize)]
merged = combo.parameters["segments"]
print(f"discontinuity lines: {sum(len(v) for v in sd.segments.values())} on "
      f"{len(sd.segments)} polygons, {sum(len(v) for v in merged.values())} on {len(merged)} "
      f"after merging at {combo.parameters['merge_gap']:g}; size grids per region on "
      f"{len(cut)}: {[scene.polygons[k].name for k in cut]}")
print(table([{"mesh": name, "elements": m.n_elements, "seconds": round(s, 1),
              "smallest angle": round(float(m.element_quality()[0].min()), 2),
              "mean q": round(float(m.element_quality()[1].mean()), 3)} for name, m, s in (
    ("this method", run.second_mesh, run.total_seconds),
    ("combination: first mesh (lines, uniform)", combo.first_mesh, 0.0),
    ("combination: second mesh", combo.second_mesh, combo.total_seconds))],
    ["mesh", "elements", "seconds", "smallest angle", "mean q"]))
# both meshes conform across their elements (no T-vertex, Def. 2.5)
assert len(combo.first_mesh.t_vertices()) == len(combo.second_mesh.t_vertices()) == 0

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 4.8))
for ax, (name, m) in zip(axes, [("this method", run.second_mesh),
                                ("combination", combo.second_mesh)]):
    plot_radiosity.plot_polygon_mesh(m, floor, ax=ax)
    ax.set_title(f"{name}: {int((m.element_polygon == floor).sum())} floor elements", fontsize=9)
fig.tight_layout()
plt.show()
plot_radiosity.show_images(
    [images[2], np.nan_to_num(shade(combo.second_mesh, combo.second_radiosity, camera))],
    [f"this method ({run.second_mesh.n_elements} el.)",
     f"combination ({combo.second_mesh.n_elements} el.)"], size=4.0)
plt.show()

# %% [markdown]
# ## Image error against element count
#
# The yardstick of chapter 2 (`polygen.radiosity.error`): relative RMS difference of the
# Gouraud image from the image of a much finer uniform mesh (19328 elements). The curves come
# from `benchmarks/intensity_mesh.py` (its results file, as last run; nothing is asserted on
# a stored file), one per method, each along its own size parameter, fixed before measuring:
# uniform bubble meshes (patch size 2.4, 1.7, 1.2); adaptive subdivision repeated on the
# coarsest, and the adaptive re-mesh of Table 4.1; this method from first meshes of 2.4 and
# 1.7 at Table 4.1's ratios and, from the first solution of 1.7, `size_min` 2 (the earlier
# setting) and 1.5 `size_initial`; simplified discontinuity meshing with patch size 3.4,
# 2.4, 1.7 and half that in the penumbra regions; the combination (width-capped) with
# exactly this method's parameters, with every line in both meshes (`lines="all"`, the full
# run) and with the default `lines="single"` (`--only single`).
#
# What the last run says:
#
# * **Does the comparison follow the thesis?** Both re-meshes start from the same first mesh
#   and solution (`first=`; the adaptive one refines that mesh by that solution), the sizes
#   are (4.2)–(4.4)'s, and both errors are measured alike. The grid step barely matters: from
#   the first solution of 1.7, steps 0.85 / 0.425 / 0.2 gave 624 / 600 / 600 elements (1544 /
#   1520 / 1552 at `size_min` 1.25×): f(D) fixes the sizes at the nodes, the grid only
#   interpolates. `size_min` is now the thesis's proportion (above).
# * **"This method reaches adaptive subdivision's error with fewer elements" — from a fine
#   first mesh, yes, narrowly; from Table 4.1's first mesh, no.** Requirement 4.1 asks for a
#   *fine* first mesh (small shadows found), coarsened where the intensity varies little.
#   From the first mesh of 1.2 (3832 elements; `--fine-first`, `size_min` 1.25×) this method
#   has **3088 elements with error 0.0145 against the adaptive re-mesh's 3109 with 0.0148**:
#   fewer elements and less error, by 1–2 %. This is asserted, computed in the run, by the
#   slow test `test_fewer_elements_than_adaptive_subdivision_for_its_error`. Against its
#   *own* adaptive re-mesh (4872 elements, 0.0098) neither dominates. From Table 4.1's
#   first mesh (1.7) it has 1448 elements with 0.0297: below the uniform and the adaptive
#   curves at that count (printed below), but far from the adaptive re-mesh's 0.0148, which
#   has twice its elements.
# * **With every line kept (`lines="all"`, the earlier default) the combination does not beat
#   both parents at equal element count** (the comparison, fixed before the run: at each of its
#   points, its error against each parent's curve interpolated in log-log at its element count
#   where that curve reaches, `error_at_elements`; this method's curve with every point of it,
#   the fine first mesh's included). With the width cap its meshes cost many more elements for
#   the same sizes (2352–3648), and at those counts it is worse than both: 0.040 with 2352
#   elements against 0.019 for this method and 0.026 for simplified DM; beyond this method's
#   last point (3088) it stays above simplified DM, at best 0.0181 with 3648 elements against
#   0.0179 (1 % above; its best point) — the elements that the cap puts into the thin strips
#   along the lines buy angles (smallest 12.3° at 2.4 and 20.5° at 1.7, against 4–6° before)
#   but hardly any image accuracy. Before the cap (merged lines only, the same parameters
#   otherwise with `size_min` 2×): 1328 elements with 0.0341 against this method's 0.0339 (a
#   tie) and simplified DM's 0.040; 1720 with 0.029 against simplified DM's 0.033. So the
#   combination beat simplified DM but not this method without the cap, and beats neither with
#   it; `combined_bubble_mesh(width_cap=False)` gives the uncapped meshes.
# * **Keeping only the lines of narrow penumbrae does not change that.** The hypothesis and its
#   criterion, fixed before measuring: under an area light a penumbra wider than the elements
#   is a smooth ramp that the size grid resolves, so `combined_bubble_mesh(lines="narrow")`
#   keeps the D0 lines, and the D1 lines only on the stretches where the penumbra they bound is
#   narrower than the element the first pass's size grid asks there (`narrow_lines`). At the
#   same settings it saves 11–23 % of the elements at about the same error or a little more
#   (width-capped: 2096 elements with 0.0399 instead of 2352 with 0.0400; 2808 with 0.0196
#   instead of 3648 with 0.0181) and beats simplified DM at 4 of its 6 points within that curve
#   (2808: 0.0196 against 0.0224; uncapped, 1736: 0.0307 against 0.0331), but this method at
#   none of its 8 (2808: 0.0196 against 0.0158; uncapped, 1400: 0.0348 against 0.0310), so the
#   default stayed `lines="all"` (`benchmarks/results/intensity_mesh_narrow.md`).
# * **Where the extra error was** (`benchmarks/experiments/combination_error_zones.py`, zones fixed before
#   measuring, taken from the combination's mesh): narrow lines at 1.7 (2808 elements, 0.0196)
#   against this method from the fine first mesh (3088, 0.0145), per pixel. In skinny
#   triangles (< 20°), in strips under two elements wide between kept lines and within one
#   element of a line the combination has *less* squared error than this method; the extra
#   error is away from the lines: there its RMS is 0.0200 against 0.0123, 43 % of its
#   squared error (all lines, 3648 elements: 48 %). The elements went to the lines: 1421 of
#   the 2808 lie within 0.85 of a line (this method: 741 of 3088; at 1.7 alone, 342 of 1448),
#   with a quarter of the area the size grid asks there (mean 0.110 against 0.456), while
#   away from the lines the mesh is as coarse as this method's at 1.7 (mean area 0.39 against
#   0.44; from the fine first mesh 0.20). The size grid does not ask for them (median size
#   near the lines 2.09, size_min 2.2): the width cap does, in the strips between the two
#   kept lines of each narrow penumbra and in the cones graded out of them (without the cap
#   the same second mesh has 1752 elements).
# * **Keeping one line per narrow penumbra, the combination beats both parents** by the same
#   comparison, fixed (with the variant) before measuring it. `lines="single"`: `"narrow"`'s
#   lines, and of two closer than the largest element only the longer. At the combination's
#   settings it has 856 / 1576 elements (2.4 / 1.7) and 728 / 1216 in the `size_min` sweep,
#   with errors 0.0495 / 0.0270 / 0.0479 / 0.0383. Two of its points lie within both curves
#   and it is below both at each: **1576 elements with 0.0270 against this method's 0.0274
#   and simplified DM's 0.0354; 1216 with 0.0383 against 0.0399 and 0.0425**. Below simplified
#   DM's range it is level with this method at 856 (0.04948 against 0.04951) and below it at
#   728 (0.0479 against 0.0537). The margins over this method are small (1.6 % and 4 %), and
#   they depend on its curve: without the fine first mesh's points only 1216 lies within both
#   curves, and there this method's 1.7 points give 0.0374 (the combination 2.5 % above), the
#   fine first mesh's `size_min` 2× point (1240, 0.0394) 0.0399; 1576 lies beyond the
#   1.7 points (1448) and is compared along the segment to the fine first mesh's 3088. So
#   `lines="single"` is now the default (`benchmarks/results/intensity_mesh_single.md`;
#   smallest angle 13.3° at 1.7, mean q 0.925).
# * **Measured at equal element counts instead of interpolated, the single-lines combination
#   is below both parents at all four of its points.** Protocol, committed before any of its
#   errors was computed (`--only equal`): at each combination point, this method's `size_min`
#   (from its own uniform first pass at the same `size_initial`, 2056 / 1064 elements, reused
#   by `first=`; the combination's first mesh is cut by its lines, which `first=` refuses
#   for a run without them) and simplified DM's patch size `s` are bisected on element
#   counts alone until within 2 % of the combination's; the matched meshes are then solved
#   and measured with the benchmark's yardstick; the claim holds only if the combination is
#   below both at every point where both parents were matched. Both were matched at all four
#   (combination / this method / simplified DM, elements in brackets): **1576: 0.0270 /
#   0.0279 (1568) / 0.0365 (1592); 1216: 0.0383 / 0.0405 (1192) / 0.0431 (1200); 856: 0.0495
#   / 0.0506 (864) / 0.0535 (872); 728: 0.0479 / 0.0561 (728) / 0.0768 (720)**. The margins
#   over this method stay small at the two larger-size points (3.3 % at 1576, 2.2 % at 856;
#   5.4 % at 1216, 15 % at 728), and at 1576 and 1216 this method has 0.5 % and 2.0 % fewer
#   elements than the combination (inside the tolerance fixed beforehand). At 1216 the
#   direct value (0.0405) is above both interpolations of this method's curve (0.0374 from
#   its 1.7 points, 0.0399 with the fine first mesh's): the curve's straight segments were
#   optimistic there. The combination's smallest angle is 8–14°, this method's 32–34°,
#   simplified DM's 2–3° (`benchmarks/results/intensity_mesh_equal.md`). The slow test
#   `test_combination_beats_both_parents_at_equal_element_count` redoes this protocol in the
#   run (about 4 minutes) and asserts the claim at all four points
#   (`polygen.radiosity.intensity.match_element_count` does the bisection).
# * **Against the plainest rival, a uniform bubble mesh at the same count, over three seeds,
#   on two scenes: on the box of Fig. 4.8 the uniform mesh wins; on chapter 3's
#   room this method beats it, and the combination beats both parents on the box only.** Protocol, committed before any of its
#   errors was computed (`--only matched`): the single-lines combination at `size_initial`
#   2.4 sets the count at each seed (0, 1, 2, the bubble mesher's seed, the same for all four
#   curves); the uniform bubble mesh's patch size, this method's `size_min` and simplified
#   DM's `s` are bisected on counts alone to within 2 %; the yardstick is `--only equal`'s
#   (each scene against its own uniform reference at patch size 1.1, 16 elements per patch:
#   19328 elements on the box, 18880 on the room). *a beats b* only if a is below b at every
#   seed. Mean ± sample std of the error (n seeds), 800–856 elements:
#
#   | scene | uniform | this method | simplified DM | combination |
#   |---|---|---|---|---|
#   | box (Fig. 4.8) | 0.0484 ± 0.0010 (2) | 0.0505 ± 0.0001 (3) | 0.0636 ± 0.0086 (3) | 0.0493 ± 0.0002 (3) |
#   | room (Fig. 3.15) | 0.0610 ± 0.0020 (2) | 0.0551 ± 0.0020 (3) | 0.0598 (1) | 0.0554 ± 0.0022 (3) |
#
#   Paired margins (same seed): on the box this method is **above** the uniform mesh by
#   +4.7 % ± 2.3 and the combination by +1.9 % ± 1.5 (both at each of the 2 seeds where the
#   uniform mesh was matched): chapter 4's claim does not hold there at this count, and the
#   combination's margin over this method (−2.3 % ± 0.6, below at all 3 seeds) does not make
#   up for it. On the room, the scene not used to choose the lines variant, this method is
#   below the uniform mesh by −10.5 % ± 7.0 and the combination by −7.2 % ± 1.4 (every
#   matched seed), so chapter 4's claim holds there; but the combination against this method
#   is **mixed** (+0.6 % ± 7.3: above at seed 0, below at 1 and 2), a margin inside its own
#   spread, so its win over this method on the box does not carry over. Simplified DM is the
#   worst curve on the box (−21 % ± 12 for the combination against it) and its single
#   matched seed on the room is above the combination by 11 %. Not every curve could be
#   matched: a uniform mesh's and simplified DM's counts jump in steps wider than 2 % (box,
#   seed 1: uniform 808 or 952 against 856; room, seeds 0 and 2: DM 768 or 856 against 824
#   and 800), reported as *not matched* as the protocol says, and the table counts each curve
#   over the seeds where it was (the protocol's table, over seeds where all four were, has
#   the box's seeds 0 and 2 only and no room row; `benchmarks/results/intensity_mesh_matched.md`).
#   At the second count (`size_initial` 1.7, 1376–1576 elements) the same picture, sharper:
#
#   | scene | uniform | this method | simplified DM | combination |
#   |---|---|---|---|---|
#   | box | 0.0272 ± 0.0003 (2) | 0.0289 ± 0.0013 (3) | 0.0385 ± 0.0021 (3) | 0.0263 ± 0.0014 (3) |
#   | room | 0.0502 (1) | 0.0362 ± 0.0022 (3) | 0.0364 ± 0.0007 (3) | 0.0384 ± 0.0009 (3) |
#
#   On the box this method is above the uniform mesh at every matched seed (+8.3 % ± 6.1),
#   the combination against it is mixed (−4.4 % ± 7.9), and the combination is below this
#   method (−9.0 % ± 5.1) and simplified DM (−32 % ± 7) at every seed. On the room this
#   method is far below the uniform mesh (−32 %, one matched seed), and the combination is
#   **above both parents at every seed** (+6.1 % ± 4.5 over this method, +5.5 % ± 1.9 over
#   simplified DM): the single-lines variant, chosen on the box, does not carry over to the
#   room. In short: chapter 4's claim holds on the room and not on the box at our sizes; the
#   combination beats both parents on the box only, and never the uniform mesh there.
# * **What the default run shows**: nothing about error. This notebook's run solves the meshes
#   at `size_initial` 2.4 but has no reference solution (the benchmark's, 19328 elements, took
#   3 minutes in its last run here, at a load of 5–8 on the two cores), so the curves are the
#   benchmark's stored ones, and no claim about error is asserted here: the fewer-elements
#   claim and the combination's are the slow tests'. Neither is the comparison with the uniform
#   mesh above: it needs the reference and four bisected meshes per seed (about 20 minutes here
#   at 2.4), so it is the benchmark's, and its numbers above are quoted from the results file,
#   not asserted.

# %%
res = json.loads((Path("..") / "benchmarks" / "results" / "intensity_mesh.json").read_text())
METHODS = {"uniform": ["uniform"], "adaptive subdivision": ["adaptive"],
           "this method": ["intensity", "intensity, other size_min"],
           "simplified DM": ["simplified DM"],
           "combination, all lines": ["combination", "combination, other size_min"]}
curves = {m: sorted((p["n_elements"], p["error"]) for k in keys for p in res["curves"].get(k, []))
          for m, keys in METHODS.items()}
fine = json.loads((Path("..") / "benchmarks" / "results" /
                   "intensity_mesh_fine_first.json").read_text())["rows"]
curves["this method, fine first mesh"] = sorted(
    (r["elements"], r["rms_error"]) for r in fine if r["mesh"].startswith("this method"))
curves["adaptive subdivision"] = sorted(curves["adaptive subdivision"] + [
    (r["elements"], r["rms_error"]) for r in fine if r["mesh"] == "adaptive re-mesh"])
single = json.loads((Path("..") / "benchmarks" / "results" /
                     "intensity_mesh_single.json").read_text())["rows"]
curves["combination, single lines (default)"] = sorted(
    (r["elements"], r["rms_error"]) for r in single)
plot_intensity.plot_error_curves(
    curves, title=f"Fig. 4.8 scene (reference: {res['reference_elements']} elements)")
plt.show()

# %%
print(table([{"method": name, "mesh": p["label"], "elements": p["n_elements"],
              "error": round(p["error"], 4)} for name, pts in res["curves"].items() for p in pts],
            ["method", "mesh", "elements", "error"]))
print("at this method's Table 4.1 point:", {m: None if (e := error_at_elements(
    curves[m], res["table_4_1"]["this method"])) is None else round(e, 4)
    for m in ("uniform", "adaptive subdivision")})
print("\nfrom a fine first mesh (size_initial 1.2; --fine-first)")
print(table(fine, ["mesh", "elements", "rms_error", "mean_q", "min_angle"]))

# %%
# this method's curve for the comparison: all its points, the fine first mesh's included
ours_all = sorted(curves["this method"] + curves["this method, fine first mesh"])
rows = []
for lines, pts in (("all", curves["combination, all lines"]),
                   ("single (default)", curves["combination, single lines (default)"])):
    for n, e in pts:
        ours = error_at_elements(ours_all, n)
        dm = error_at_elements(curves["simplified DM"], n)
        rows.append({"lines": lines, "elements": n, "combination": round(e, 4),
                     "this method": "-" if ours is None else round(ours, 4),
                     "simplified DM": "-" if dm is None else round(dm, 4)})
print("at the combination's element counts (interpolated; '-': outside that curve's range)")
print(table(rows, ["lines", "elements", "combination", "this method", "simplified DM"]))

# %% [markdown]
# ## Try other sizes
#
# With a kernel attached, the sliders recompute f(D), the size grids and the floor's bubble
# mesh from the first solution above (the floor alone, for speed); a static rendering of the
# notebook shows the defaults.

# %%
plot_intensity.remesh_sliders(run, floor)
