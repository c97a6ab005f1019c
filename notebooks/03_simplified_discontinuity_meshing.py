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
# # Chapter 3 — simplified discontinuity meshing with shadow polyhedra
#
# Shadows make the sharpest changes of radiosity on a receiver. **Discontinuity meshing**
# (2.4.3) puts mesh edges where the radiance or its derivatives jump: on the EV and VE
# critical surfaces through a light vertex and an occluder edge, or a light edge and an
# occluder vertex — `2·Ns·No` of them per (light, occluder, receiver) — and splits the receiver
# by a 2-D BSP tree. Itoh's **simplified** method (3.3) keeps only the boundaries of two convex
# **shadow polyhedra** per light and occluder: the **umbra** polyhedron (per occluder edge the
# plane through the light vertex with the smallest angle, Fig. 3.6) and the **penumbra**
# polyhedron (the convex hull of all EV/VE planes by gift-wrapping, Fig. 3.7), `Ns + 2·No`
# edges. Their sections are walked into a **receiver complex** (3.3.2–3.3.3), whose loops are
# rebuilt (3.3.4) into regions with an **illumination state** per light (3.3.5: umbra 3,
# penumbra 2, bright 1); regions that are penumbra for some light get smaller patches and
# elements (3.3.6). This notebook draws Figs 2.9, 2.10, 3.1–3.4, 3.6, 3.7, 3.9, 3.10, 3.13,
# 3.14 from the code's records, renders the three example scenes (Figs 3.15–3.23), and puts
# Tables 3.1 and 3.2 beside ours. Everything calls `polygen.discontinuity`; figures come from
# `polygen.plotting.discontinuity`. Beyond the thesis, a closed convex solid (the sphere of
# example 2) is one occluder: its polyhedra come from its silhouette, not from each of its faces
# (`scene_sections(..., solids=True)`, the default; see "Better than the thesis" below).

# %%
import json
import os
import time
from pathlib import Path

FULL = os.environ.get("POLYGEN_FULL") == "1"   # thesis-like sizes when set

import matplotlib.pyplot as plt
import numpy as np

from polygen.discontinuity import (conventional_bsp, conventional_segments, discontinuity_mesh,
                                   ev_ve_planes, plane_roles, receiver_complex, scene_lights,
                                   scene_sections, section_segments, shadow_polyhedron,
                                   simplified_discontinuity, unique_planes)
from polygen.plotting import discontinuity as plot_dm, table
from polygen.plotting.radiosity import plot_polygon_mesh, show_images
from polygen.radiosity import Camera, mesh_scene, progressive_refinement, scenes
from polygen.radiosity.error import shade

# patch sizes outside / inside penumbra, and the solve: direct light + ambient by default
COARSE, FINE = (1.0, 0.25) if FULL else (2.5, 0.6)
# by default each light patch shoots once, an ambient term for the rest; FULL: to 1 % unshot
SOLVE = (dict(tol=0.01, ambient=True, visibility_samples=2) if FULL
         else dict(max_shots="lights", ambient=True, visibility_samples=2))
IMAGE = 256 if FULL else 128

# %% [markdown]
# ## Figs 3.6, 3.7 — the umbra and penumbra polyhedra
#
# The scene of Fig. 3.4: a square light above two tilted square occluders over a floor. For one
# occluder, the umbra polyhedron (black) is bounded by the occluder's plane and one plane per
# occluder edge; the penumbra polyhedron (orange) by the gift-wrapped hull of all `2·Ns·No`
# EV/VE planes.

# %%
sc34 = scenes.figure_3_4_scene()
lights34 = scene_lights(sc34)
occ = [k for k, p in enumerate(sc34.polygons) if p.name.startswith("occluder_a")][0]
ph = shadow_polyhedron(lights34[0][1], sc34.polygons[occ], bounds=sc34.bounds)
plot_dm.plot_polyhedra(ph)
plt.show()
print(f"EV/VE candidate planes {ph.candidate_planes} (2·Ns·No = {2 * 4 * 4}); "
      f"umbra planes {len(ph.umbra.planes)}, penumbra planes {len(ph.penumbra.planes)}, "
      f"gift-wrapping steps {ph.wrap_steps}")
assert len(ph.umbra.planes) == 1 + 4            # the occluder's plane and one per occluder edge

# %% [markdown]
# The gift-wrapping's faces, checked from scratch: a penumbra side separates light and occluder
# (Fig. 3.7: each light point on one side, the occluder on the other), an umbra side has both on
# one side (Fig. 3.6). So the wrapped hull must be exactly the separating EV/VE planes, found by
# testing all 2·Ns·No candidates directly (`ev_ve_planes`, none of the wrapping's code).

# %%
S, O = ph.light_vertices, ph.occluder_vertices
planes, role = ev_ve_planes(S, O)
separating = planes[role == 1]
wrapped = unique_planes(ph.penumbra.planes[1:])
print(f"distinct EV/VE planes {len(planes)}: separating {len(separating)}; "
      f"penumbra sides by gift-wrapping {len(wrapped)}")
assert len(wrapped) == len(separating) and all(
    any(np.allclose(w, q, atol=1e-7) for q in separating) for w in wrapped)
# each umbra side: light and occluder on one side of it
assert np.all(plane_roles(S, O, ph.umbra.planes[1:]) == 0)

# %% [markdown]
# ## Figs 2.9, 3.1, 3.3 — conventional against simplified discontinuity lines
#
# On the floor of Fig. 3.4's scene: every EV and VE critical segment (left, 2.4.3) and the
# simplified method's section edges (right). Fig. 3.3's count: `2·Ns·No` conventional surfaces
# per (light, occluder, receiver), against `Ns + 2·No` simplified edges.

# %%
sh34 = scene_sections(sc34)
floor = sc34.polygons[0]
conv = conventional_segments(sc34, 0, shadows=sh34)
simp, simp_kinds = section_segments(floor, sh34.of(0))
fig, axes = plt.subplots(1, 2, figsize=(9, 4.5))
plot_dm.plot_segments(floor, conv.segments, ax=axes[0],
                      title=f"conventional: {len(conv.segments)} EV/VE segments")
plot_dm.plot_segments(floor, simp, ax=axes[1], title=f"simplified: {len(simp)} section edges")
plt.show()
Ns = No = 4
pairs = len(conv.pairs)
print(f"pairs {pairs}: conventional surfaces {conv.surfaces} = {pairs} × 2·Ns·No; "
      f"simplified edges {len(simp)} = {pairs} × (Ns + 2·No)")
assert len(simp) == pairs * (Ns + 2 * No) < conv.surfaces
# Fig. 3.1: the simplified lines are some of the EV/VE lines -- every section edge lies along a
# conventional critical segment (checked on the floor, from the two methods' own outputs)
import shapely

ev_lines = shapely.union_all([shapely.LineString(q) for q in conv.segments]).buffer(1e-7 * floor.diameter)
on_ev = [bool(ev_lines.covers(shapely.LineString(q))) for q in simp]
print(f"section edges along an EV/VE segment: {sum(on_ev)} of {len(simp)}")
assert all(on_ev)

# %% [markdown]
# ## Figs 2.10, 3.4 — regions by BSP against regions by loops
#
# The thesis: the simplified lines split Fig. 3.4's receiver into **29** regions by a BSP tree
# and **6** by loops. The BSP count depends on an insertion order and a geometry the text does
# not give; the claim is the inequality. Six loops hold for the general position chosen here
# (occluders turned by 30° about the vertical: each casts `Ns + 2·No` = 12 edges, 24 in all). At
# angle 0 the occluders' edges are parallel to the light's, EV and VE planes coincide in pairs,
# and the same scene gives **5** loops from **16** section edges (asserted below): the count is a
# property of the configuration, not of the method.

# %%
sd34 = simplified_discontinuity(sc34)
cx34 = sd34.complexes[0]
bsp_s = conventional_bsp(floor, simp)
bsp_c = conventional_bsp(floor, conv.segments)
fig, axes = plt.subplots(1, 3, figsize=(13, 4.3))
plot_dm.plot_regions(bsp_c, receiver=floor, ax=axes[0],
                     title=f"BSP of the EV/VE lines: {bsp_c.n_regions} (Fig. 2.10)")
plot_dm.plot_regions(bsp_s, receiver=floor, ax=axes[1],
                     title=f"BSP of the simplified lines: {bsp_s.n_regions} (thesis 29)")
plot_dm.plot_complex(cx34, ax=axes[2], title=f"loops: {len(cx34.alive_faces)} (thesis 6)")
plt.show()
assert len(cx34.alive_faces) == 6
assert len(cx34.alive_faces) <= bsp_s.n_regions <= bsp_c.n_regions
sc34_0 = scenes.figure_3_4_scene(angle=0.0)
simp_0, _ = section_segments(sc34_0.polygons[0], scene_sections(sc34_0).of(0))
loops_0 = len(simplified_discontinuity(sc34_0).complexes[0].alive_faces)
print(f"angle 0: {loops_0} loops from {len(simp_0)} section edges")
assert (loops_0, len(simp_0)) == (5, 16)

# %% [markdown]
# ## Figs 3.9, 3.10, 3.13 — the walk, the loops and the illumination states
#
# Each section is walked into the complex (3.3.3): the walk tracks the loop the current point is
# in and intersects only that loop's edges; new edges close new loops (3.3.4), and every face
# inside the section has its state raised (3.3.5). Labels: the face's state per light.

# %%
c = sd34.counters
print(f"sections walked {c['sections']}, point-in-loop tests {c['point_in_loop']}, "
      f"segment-edge tests {c['edge_tests']} (all against all: {c['edge_tests_all']}), "
      f"loops traced {c['loops_traced']}, deleted {c['loops_deleted']}")
plot_dm.plot_complex(cx34, labels=True, title="illumination states per region (Fig. 3.10)")
plt.show()
cx34.check()   # Euler characteristic, two loop sides per edge, outer loops CCW, holes CW

# %% [markdown]
# ### Fig. 3.9 step by step — the intersection walk
#
# The text fixes Fig. 3.9's configuration up to its coordinates: a receiver cut into three loops
# L1 | L2 | L3 by two lines E1, E2; a shadow section V1 V4 V5 whose first vertex V1 lies in L1,
# V4 beyond E2 and V5 back in L1. Here the unit square with E1 at x = 0.4, E2 at x = 0.7, and the
# triangle (0.2, 0.3), (0.9, 0.5), (0.2, 0.7) (`receiver_complex(..., record=True)` keeps every
# step). Each panel: the edges the step tests (blue: the current loop's only), the current point,
# the vertex aimed at (circle), the crossing found (cross) and the edges drawn (red). The titles
# name loops by the complex's own numbers: the thesis's L1, L2, L3 are its L3, L1, L2.

# %%
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
strip = np.array([[0.4, -1.0], [0.7, -1.0], [0.7, 2.0], [0.4, 2.0]])
tri = np.array([[0.2, 0.3], [0.9, 0.5], [0.2, 0.7]])
cx39 = receiver_complex(SQUARE, (), [(0, strip, strip, "point"), (0, np.zeros((0, 2)), tri, "area")],
                        record=True)
rec39 = cx39.records[-1]
plot_dm.plot_walk_steps(rec39)
plt.show()
pil = sum(len(s.loops_tested) for s in rec39.walk)
tests = sum(len(s.tested) for s in rec39.walk)
print(f"steps {len(rec39.walk)}: point-in-loop tests {pil}, edge tests {tests} "
      f"(counters {rec39.counters['point_in_loop']}, {rec39.counters['edge_tests']}; every edge "
      f"against every section edge: {rec39.counters['edge_tests_all']}), edges drawn "
      f"{len(rec39.new_edges)}, splits {rec39.counters['splits']}")
# 3.3.3: one point located by point-in-loop tests; each section edge tested only against the
# loops it passes through (hand count: 1 test, 4+4+5+5+5+7+6+6 = 42 edge tests)
assert (pil, tests) == (rec39.counters["point_in_loop"], rec39.counters["edge_tests"]) == (1, 42)
assert tests <= rec39.counters["edge_tests_all"]

# %% [markdown]
# ### Fig. 3.13 step by step — loop rebuilding
#
# The thesis's Fig. 3.13 (8 loops, 9 after O3) cannot be rebuilt from the text alone; this is the
# same operation on a configuration of the same kind: O1 and O2 leave two islands (penumbra
# square around an umbra square), then O3's penumbra rectangle cuts across both. One panel per
# loop traced (3.3.4 steps 3–5): the table cell it started from, its turns at junctions
# (circles: the smallest-angle turn), the old loops it deleted; green counter-clockwise (an outer
# loop), purple clockwise (a hole, step 7); the last panel is the left/right table.

# %%
u1, p1, u2, p2, p3 = [np.array([[a, b], [c, b], [c, d], [a, d]]) for a, b, c, d in
                      [(0.15, 0.15, 0.3, 0.3), (0.1, 0.1, 0.35, 0.35), (0.65, 0.65, 0.8, 0.8),
                       (0.6, 0.6, 0.85, 0.85), (0.2, 0.2, 0.75, 0.7)]]
o1, o2, o3 = (0, u1, p1, "area"), (0, u2, p2, "area"), (0, np.zeros((0, 2)), p3, "area")
cx313 = receiver_complex(SQUARE, (), [o1, o2, o3], record=True)
rec313 = cx313.records[-1]
plot_dm.plot_loop_steps(rec313)
plt.show()
n_before = len(cx313.alive_loops) - len(rec313.loops) + len(rec313.deleted)
print(f"loops before O3 {n_before}, traced {len(rec313.loops)}, deleted {len(rec313.deleted)}, "
      f"after {len(cx313.alive_loops)}; table rows {len(rec313.table)}, turns at junctions "
      f"{sum(len(s.turns) for s in rec313.loops)}")
# step 6: every cell of the table filled; step 4: only loops the new edges run through deleted
assert all(min(v) >= 0 for v in rec313.table.values())
assert len(rec313.loops) == rec313.counters["loops_traced"] and len(rec313.deleted) < n_before
cx313.check()

# %% [markdown]
# ## Figs 3.11, 3.14 — regions to patches and elements
#
# Regions that are penumbra for at least one light get the smaller patch size (3.3.6 step 1);
# nodes go on the regions' vertices, along their edges (the smaller size of the two sides) and
# inside; patches by Delaunay; elements by splitting patches 1 → 4. The conventional mesh takes
# the same sizes on its own (EV/VE) regions.

# %%
m_s = discontinuity_mesh(sc34, patch_size=2.0, penumbra_patch_size=0.5, method="simplified",
                         discontinuity=sd34)
m_c = discontinuity_mesh(sc34, patch_size=2.0, penumbra_patch_size=0.5, method="conventional")
m_u = mesh_scene(sc34, 0.5, element_levels=1)
fig, axes = plt.subplots(1, 3, figsize=(13, 4.5))
plot_polygon_mesh(m_c, 0, ax=axes[0], title=f"conventional DM: {m_c.n_elements} elements")
plot_polygon_mesh(m_s, 0, ax=axes[1], title=f"simplified DM: {m_s.n_elements} elements")
plot_polygon_mesh(m_u, 0, ax=axes[2], title=f"uniform fine: {m_u.n_elements} elements")
plt.show()
assert m_s.n_elements < m_u.n_elements

# %% [markdown]
# ## Which state is a point in? `illumination`
#
# The question a reader asks first of the discontinuity phase: for a point on a receiver, is it
# in umbra, penumbra or light, for each light -- and how much of the light does it see?
# `illumination(sd, points, fraction=True)` places each point on its polygon, finds its face in
# the receiver complex and returns the face's states (3.3.5), and in penumbra the visible part of
# the light (the occluders projected from the point onto the light's plane). On Fig. 3.4's floor;
# then 400 random floor points against 8 x 8 rays to the light: a point with some rays blocked
# and some not must be penumbra, an umbra point must have every ray blocked, a bright one none.

# %%
from polygen.discontinuity import BRIGHT, PENUMBRA, UMBRA, illumination
from polygen.radiosity.formfactor import pack_polygons, segments_visible

g = np.linspace(0.05, 9.95, 160)
gx, gz = np.meshgrid(g, g)
grid = np.c_[gx.ravel(), np.zeros(gx.size), gz.ravel()]
st34, fr34 = illumination(sd34, grid, fraction=True)
fig, axes = plt.subplots(1, 2, figsize=(9, 4.2))
axes[0].imshow(st34[:, 0].reshape(gx.shape), origin="lower", extent=[0, 10, 0, 10], cmap="viridis")
axes[0].set_title("state: bright 1, penumbra 2, umbra 3")
im = axes[1].imshow(fr34[:, 0].reshape(gx.shape), origin="lower", extent=[0, 10, 0, 10], cmap="gray")
axes[1].set_title("visible fraction of the light")
plt.colorbar(im, ax=axes[1])
plt.show()

# %%
rng = np.random.default_rng(0)
pts = np.c_[rng.uniform(0, 10, 400), np.zeros(400), rng.uniform(0, 10, 400)]
st = illumination(sd34, pts)[:, 0]
L34 = lights34[0][1]
t = (np.arange(8) + 0.5) / 8
lp = L34.to_3d(np.array([[u, v] for u in t for v in t]) * np.ptp(L34.exterior_2d, axis=0)
               + L34.exterior_2d.min(axis=0))
seen = segments_visible(np.repeat(pts, len(lp), 0), np.tile(lp, (len(pts), 1)),
                        np.zeros(len(pts) * len(lp), int), np.full(len(pts) * len(lp), lights34[0][2]),
                        packed=pack_polygons(sc34.polygons)).reshape(len(pts), len(lp))
part = seen.any(axis=1) & ~seen.all(axis=1)
print(f"states of 400 points: bright {np.sum(st == BRIGHT)}, penumbra {np.sum(st == PENUMBRA)}, "
      f"umbra {np.sum(st == UMBRA)}; partly seen by the rays {part.sum()}")
assert np.all(st[part] == PENUMBRA)
assert np.all(~seen[st == UMBRA]) and np.all(seen[st == BRIGHT])

# %% [markdown]
# ## Concave occluders, exact
#
# The thesis splits a concave occluder into convex pieces and builds shadow polyhedra per piece
# (3.3.1). For a point or a parallel light the pieces' shadows together are the occluder's
# shadow. For an area light they are not: a point that the whole polygon hides from the whole
# light, though no single piece does (its rays to the light pass behind one piece or another),
# is umbra, and the per-piece rule calls it penumbra. On an L-shaped occluder under a square
# light (`scenes.concave_occluder_scene("L")`) that loses about 11 % of the true umbra's area
# (measured below). `concave="exact"` (the default) adds the umbra of the whole polygon: a point is
# hidden from all of the light iff the light projected through it onto the occluder's plane lies
# inside the polygon, that is, the shadow from one light point less every boundary edge's
# penumbra (`umbra_region`), walked in as convex pieces (`umbra_pieces`: two for the L, one more
# line, umbra on both sides). `concave="pieces"` keeps the thesis's rule. The thesis's Table 3.1
# and 3.2 scenes have no concave occluder (the ceiling's hole for the light lies in the light's
# plane) and are unchanged; the chair's seat underside, notched around the legs, is one, so the
# chair's lines below are the exact ones (more of them than the per-piece rule's).

# %%
from polygen.discontinuity import light_fraction, state_areas

sc_L = scenes.concave_occluder_scene("L")
sd_L = {m: simplified_discontinuity(sc_L, concave=m) for m in ("pieces", "exact")}
umbra_area = {m: state_areas(sd.complexes[0])[0, UMBRA] for m, sd in sd_L.items()}
lost = 1.0 - umbra_area["pieces"] / umbra_area["exact"]
fig, axes = plt.subplots(1, 2, figsize=(10, 4.8))
for ax, (m, sd) in zip(axes, sd_L.items()):
    plot_dm.plot_complex(sd.complexes[0], ax=ax, light=0,
                         title=f'concave="{m}": umbra area {umbra_area[m]:.3f}')
    ax.set_xlim(-2.2, 2.2)
    ax.set_ylim(-2.2, 2.2)
plt.show()
print(f"the per-piece rule loses {lost:.1%} of the L's umbra")
assert lost > 0  # the whole polygon's umbra holds points that no piece's umbra does

# %% [markdown]
# Against an independent answer: 2000 random floor points, each with the visible fraction of
# the light from the occluder projected onto the light's plane (`light_fraction`, no shadow
# polyhedra): 0 is umbra, 1 bright. The exact mode must agree at every point, the per-piece mode
# disagrees at the points of the lost umbra.

# %%
rng = np.random.default_rng(1)
floor_L = sc_L.polygons[0]
lo, hi = floor_L.exterior_2d.min(axis=0), floor_L.exterior_2d.max(axis=0)
pts_L = floor_L.to_3d(lo + rng.random((2000, 2)) * (hi - lo))
on_floor = np.zeros(len(pts_L), np.int64)
frac_L = light_fraction(sc_L, 0, pts_L, on_floor)
truth = np.where(frac_L <= 1e-9, UMBRA, np.where(frac_L >= 1.0 - 1e-9, BRIGHT, PENUMBRA))
wrong = {m: int(np.sum(illumination(sd, pts_L, polygons=on_floor)[:, 0] != truth))
         for m, sd in sd_L.items()}
print(f"true umbra {np.sum(truth == UMBRA)}, penumbra {np.sum(truth == PENUMBRA)}, bright "
      f"{np.sum(truth == BRIGHT)} points; states disagreeing: {wrong}")
assert wrong["exact"] == 0 and wrong["pieces"] > 0

# %% [markdown]
# ## Figs 3.15–3.23 — the three examples rendered
#
# Example 1 (Figs 3.15–3.18): the box room with two floating rectangles; example 2 (Fig. 3.19):
# the 180-polygon sphere under a very small area light; the chair (Figs 3.20–3.23), simplified
# DM against adaptive subdivision. By default the solve is the light's direct shots plus the
# ambient term (`POLYGEN_FULL=1`: progressive refinement to 1 % unshot).

# %%
cam = Camera([5.0, 8.5, 0.3], [5.0, 0.0, 6.5], fov=80.0, width=IMAGE, height=IMAGE, near=0.01)
examples, table31 = {}, {}
for name in ["two_rectangles_room", "sphere_scene", "chair_scene"]:
    sc = getattr(scenes, name)()
    sd = simplified_discontinuity(sc)
    m = discontinuity_mesh(sc, patch_size=COARSE, penumbra_patch_size=FINE, discontinuity=sd)
    t0 = time.perf_counter()
    r = progressive_refinement(m, **SOLVE)
    t_rs = time.perf_counter() - t0
    examples[name] = (sc, sd, m, shade(m, r.display_radiosity(m), cam))
    n_e2 = mesh_scene(sc, FINE, element_levels=1).n_elements
    table31[name] = dict(N_f1=len(sc.polygons), N_f2=len(sc.polygons) - sd.counters["receivers"]
                         + sd.counters["regions"], N_d=sd.counters["discontinuity_edges"],
                         N_p=m.n_patches, N_e1=m.n_elements, N_e2=n_e2,
                         T_d=m.discontinuity.timings["T_d"], T_m=m.discontinuity.timings["T_m"],
                         T_rs=t_rs)
show_images([e[3] for e in examples.values()], list(examples), size=4.0)
plt.show()

# %%
fig, axes = plt.subplots(1, 3, figsize=(13, 4.5))
for ax, (name, (sc, sd, m, _)) in zip(axes, examples.items()):
    k = [i for i, p in enumerate(sc.polygons) if p.name == "room_y0"][0]
    plot_polygon_mesh(m, k, ax=ax, title=f"{name}: floor, {np.sum(m.element_polygon == k)} "
                      f"of {m.n_elements} elements")
plt.show()

# %% [markdown]
# Fig. 3.15: example 1's discontinuity lines on the floor: the receiver complex that the mesh
# above follows, its regions coloured by their darkest state.

# %%
sc1, sd1 = examples["two_rectangles_room"][:2]
k1 = [i for i, p in enumerate(sc1.polygons) if p.name == "room_y0"][0]
cx1 = sd1.complexes[k1]
plot_dm.plot_complex(cx1, title=f"two_rectangles_room: floor, {len(cx1.edges)} edges, "
                     f"{len(cx1.alive_faces)} regions")
plt.show()
assert len(cx1.alive_faces) > 1  # the floor is divided by the shadows of both rectangles

# %% [markdown]
# ### The chair: simplified DM against adaptive subdivision (Figs 3.20–3.23)
#
# Adaptive subdivision (Def. 2.6) starts from the coarse uniform mesh, solves, and refines
# where neighbouring elements differ by more than 10 % of the bright surfaces' radiosity.

# %%
from polygen.radiosity import adaptive_refine

sc, sd, m_dm, img_dm = examples["chair_scene"]
m_a = mesh_scene(sc, COARSE, element_levels=1)
for _ in range(2):
    b = progressive_refinement(m_a, **SOLVE).display_radiosity(m_a)
    scale = float(np.percentile(b.max(axis=1), 95.0))
    m_a = adaptive_refine(m_a, b, 0.1 * scale).mesh
img_a = shade(m_a, progressive_refinement(m_a, **SOLVE).display_radiosity(m_a), cam)
show_images([img_a, img_dm], [f"adaptive subdivision, {m_a.n_elements} elements",
                              f"simplified DM, {m_dm.n_elements} elements"], size=4.5)
plt.show()

# %% [markdown]
# Figs 3.21 and 3.20 side by side: the chair's floor meshed by adaptive subdivision (refined
# wherever neighbours differ, across the whole shadow) and by simplified DM (fine only in the
# penumbra regions, with edges on the lines).

# %%
kc = [i for i, p in enumerate(sc.polygons) if p.name == "room_y0"][0]
fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
chair_meshes = {"adaptive subdivision (Fig. 3.21)": m_a, "simplified DM (Fig. 3.20)": m_dm}
for ax, (label, mm) in zip(axes, chair_meshes.items()):
    plot_polygon_mesh(mm, kc, ax=ax, title=f"{label}: {np.sum(mm.element_polygon == kc)} floor elements")
plt.show()

# %% [markdown]
# ## Table 3.1 — meshing results
#
# N_f1 polygons before division, N_f2 after, N_d discontinuity edges, N_p patches, N_e1
# elements with the fine size in penumbra regions only, N_e2 with the fine size everywhere;
# T_d the discontinuity phase, T_m meshing, T_rs the radiosity solve of this run (seconds). The
# thesis's numbers (IBM RS/6000 560) in parentheses. Our polygon counts differ: our room's walls
# are single polygons and the sphere scene is 180 sphere faces in a 6-wall room (the thesis's 721
# faces include its room's subdivided walls). T_rs is this notebook's solve (by default the
# light's direct shots and the ambient term, `POLYGEN_FULL=1`: progressive refinement to 1 %
# unshot), so it is not the thesis's converged solve; both are printed as measured.
#
# Example 2 is asserted too (11230 < 17150 in the thesis): with the sphere one convex occluder
# its floor carries the umbra and penumbra rings of one shadow (33 discontinuity edges). Each of
# the 180 faces as its own occluder (`solids=False`, 3.3.1's rule for a polygon) follows below.

# %%
THESIS31 = {"two_rectangles_room": dict(N_f1=8, N_f2=20, N_d=40, N_p=486, N_e1=3485, N_e2=6090,
                                        T_d=0.12, T_m=1.77, T_rs=156.63),
            "sphere_scene": dict(N_f1=721, N_f2=2495, N_d=3116, N_p=6030, N_e1=11230,
                                 N_e2=17150, T_d=166.58, T_m=15.28, T_rs=289.02)}
keys = list(THESIS31["sphere_scene"])
print(f"{'scene':22s}" + "".join(f"{k:>18s}" for k in keys))
for name, row in table31.items():
    th = THESIS31.get(name, {})
    cells = [(f"{row[k]:.3g}" if isinstance(row[k], float) else str(row[k]))
             + (f" ({th[k]})" if k in th else "") for k in keys]
    print(f"{name:22s}" + "".join(f"{c:>18s}" for c in cells))
for name, row in table31.items():
    print(f"{name}: N_e1 < N_e2 {'holds' if row['N_e1'] < row['N_e2'] else 'does NOT hold'}")
# Table 3.1: N_e1 < N_e2 (3485 < 6090 in example 1); the chair likewise
assert table31["two_rectangles_room"]["N_e1"] < table31["two_rectangles_room"]["N_e2"]
assert table31["chair_scene"]["N_e1"] < table31["chair_scene"]["N_e2"]
assert table31["sphere_scene"]["N_e1"] < table31["sphere_scene"]["N_e2"]   # 11230 < 17150

# %% [markdown]
# ### Example 2 with the thesis's method: every sphere face its own occluder
#
# 3.3.1's rule takes each polygon as an occluder (`solids=False`). On the sphere's floor that
# gives 5137 discontinuity edges, and meshing along all of them took more elements than the
# uniform fine mesh (23,696 against 18,584 at 2.5/0.6): Table 3.1's N_e1 < N_e2 failed. Why:
# 3602 of those edges part two faces of the same state — 1441 between two faces' overlapping
# umbrae, 2161 between overlapping penumbrae — so they bound no change of illumination, yet
# each forced nodes along its length. The thesis generates only the boundaries between states
# (bright/penumbra, penumbra/umbra; 3.3, Def. 3.2–3.4), so such an edge is no discontinuity line
# of the simplified method: `state_boundaries_only=True` leaves them out of the mesh (the regions
# keep their states). The one-solid variant (ours, the default) beside it.

# %%
sc_sph = examples["sphere_scene"][0]
sd_faces = simplified_discontinuity(sc_sph, solids=False, state_boundaries_only=True)
m_faces = discontinuity_mesh(sc_sph, patch_size=COARSE, penumbra_patch_size=FINE, discontinuity=sd_faces)
n_e2_sph = table31["sphere_scene"]["N_e2"]
print(f"sphere, every face an occluder: N_d {sd_faces.counters['discontinuity_edges']}, "
      f"N_e1 {m_faces.n_elements}, N_e2 {n_e2_sph} (thesis 11230 < 17150); "
      f"one solid (ours): N_d {table31['sphere_scene']['N_d']}, N_e1 {table31['sphere_scene']['N_e1']}")
assert m_faces.n_elements < n_e2_sph            # Table 3.1, example 2, on the thesis's method

# %% [markdown]
# ## Table 3.2 — the discontinuity phase
#
# T_sdw shadow polyhedra, T_isr polyhedra against receivers, T_idd discontinuity edges against
# each other, T_lop loops, T_lit illumination states, T_div division into regions (seconds).
# The sphere twice: one solid (ours, the default) and every face its own occluder (the thesis's
# method, `solids=False`, as in Table 3.1's second sphere row above).
# The thesis's T_isr is quadratic in the polygon count (every polyhedron against every
# receiver); ours goes through a bounding-volume hierarchy (the benchmark measures the slope).

# %%
THESIS32 = {"two_rectangles_room": [0.03, 0.04, 0.02, 0.01, 0.01, 0.01],
            "sphere_scene": [0.21, 154.48, 3.76, 2.13, 5.50, 0.50]}
phases = ["T_sdw", "T_isr", "T_idd", "T_lop", "T_lit", "T_div"]
print(f"{'scene':22s}" + "".join(f"{k:>17s}" for k in phases))
rows32 = [(name, sd, THESIS32.get(name)) for name, (sc, sd, m, _) in examples.items()]
# example 2 with the thesis's method too: every sphere face its own occluder (above)
rows32.insert(2, ("sphere, per face", sd_faces, THESIS32["sphere_scene"]))
for name, sd, th in rows32:
    cells = [f"{sd.timings[k]:.3f}" + (f" ({th[i]})" if th else "") for i, k in enumerate(phases)]
    print(f"{name:22s}" + "".join(f"{c:>17s}" for c in cells))

# %% [markdown]
# ## Better than the thesis, measured
#
# `benchmarks/discontinuity.py` solves each scene with uniform meshes, adaptive subdivision,
# conventional DM and simplified DM at several sizes and compares images against a finer
# reference (the yardstick of chapter 2): the DM curves keep the coarse size and shrink the
# penumbra size, the `_scaled` ones shrink both (penumbra a third of the coarse size). The
# curves below are read from its results (every scene solved to 1 % unshot: the tolerance
# matters, see "The ≤ 60 % claim examined" below); the
# claim of the issue — the simplified method reaches the uniform mesh's error with at most 60 %
# of its elements — is printed as measured, not asserted (the sizes are the benchmark's).
#
# The sphere's curves are on Fig. 3.19's 12 × 15-face sphere (180 faces in a 6-wall room). The
# sphere is one closed convex solid, and a convex solid casts one shadow: its penumbra polyhedron
# is bounded by the planes that separate light and solid (a light vertex and a silhouette edge, or
# a light edge and a solid vertex) and by the solid's faces wholly facing the light; its umbra is
# the intersection of the light vertices' shadow volumes (a point sees none of a convex light when
# it sees none of its vertices). Both are exact (`tests/test_discontinuity_solids.py`: against a
# linear program per point, and on the floor against the projected silhouette), and only the
# silhouette enters: the floor gets 33 discontinuity lines. Taken face by face (`solids=False`)
# it got 5137, every simplified DM mesh had 22.5–23.4k elements whatever the penumbra size (3.3/1.6:
# 22,560 elements, 5640 patches, 5184 of them on the floor), and the per-face umbra was too small:
# of 10⁴ floor points, 428 hidden from the whole light by the sphere lay in no face's umbra. The
# history below is of those per-face meshes: until the sphere became one occluder the curves used a 6 × 8
# stand-in, because one solve of the 3.3/1.6 mesh to 1 % unshot (4459 shots) took 302 s at load 2.
# Profiled over its shots, 84 % of a form-factor column went to the visibility rays (47k rays a
# column, 38 crossing tests each on average against the 49 candidate occluders of their
# element–patch pair, listed by a linear scan of all 180), 9 % to that scan and 7 % to the
# unoccluded factors. The rays now walk a bounding-volume hierarchy over the occluders, with the
# same answer for every ray (same rays, same jitter: the columns are the same bit for bit,
# `tests/test_formfactor_index.py`; on the sphere family, 48 to 600 occluders, a ray costs 0.54 to
# 1.00 µs, log–log slope 0.24, against the linear scan's 1.4 to 16.4 µs, slope 0.98), and the
# solver keeps the column of a patch that shoots again
# (the 4459 shots are of 1470 patches; each wall patch shoots ~19 times). The same solve now
# takes 44 s wall / 33 s CPU at load ~6 (a column of its shots 37 ms CPU against 129 ms with the
# linear scan, measured interleaved; `benchmarks/results/discontinuity.md`). The whole sphere run — the reference (8664 elements),
# three uniform, three adaptive, two conventional and two simplified DM points, all solved to 1 %
# unshot — took about 22 minutes at load 4–7, 12 of them meshing the two conventional DM meshes
# (65.8k and 67.5k elements: 551 s and 182 s; their solves 67 s and 84 s; the simplified DM's
# meshes 20 s and 29 s, solves 60 s and 72 s). With the sphere one solid the simplified DM meshes
# have 2160 and 2608 elements and take 9.9 s and 7.0 s each, mesh and solve; the uniform,
# adaptive and conventional sphere curves (per polygon by definition: 2.4.3's method) are those
# of that run.

# %%
res_path = Path("..") / "benchmarks" / "results" / "discontinuity.json"
res = json.loads(res_path.read_text()) if res_path.exists() else {}
curves = res.get("curves", {})
if curves:
    fig, axes = plt.subplots(1, len(curves), figsize=(5 * len(curves), 3.8), squeeze=False)
    for ax, (name, cv) in zip(axes[0], curves.items()):
        kinds = ["uniform", "adaptive", "conventional", "simplified", "simplified_coarser",
                 "conventional_scaled", "simplified_scaled"]
        label = name + (" {n_lat}x{n_lon}".format(**cv["scene_kwargs"]) if cv.get("scene_kwargs") else "")
        plot_dm.plot_error_curves({k: cv[k] for k in kinds if k in cv}, ax=ax, title=label)
    plt.show()
    for name, cv in curves.items():
        for key in ("claim", "claim_scaled"):
            for q in cv.get(key, []):
                r = "not reached" if q["ratio"] is None else f"{q['ratio']:.2f} of its elements"
                print(f"{name} ({key}): uniform {q['uniform_elements']} elements, error "
                      f"{q['uniform_error']:.4f}: simplified DM {r}")

# %% [markdown]
# ### The ≤ 60 % claim examined
#
# The thesis makes no error claim: Table 3.1 compares element counts only, N_e1 (the fine size F
# in penumbra regions, coarse elsewhere) against N_e2 (F everywhere): 3485/6090 = 57 %,
# 11230/17150 = 65 %, which is where the issue's 60 % comes from. Read from the text, the fair
# comparison is therefore the DM mesh (coarse C outside penumbra, F inside, 3.3.6 step 1) against
# the uniform mesh **at the same F**, not against a uniform mesh at the coarse size (the curves
# above) nor with both sizes scaled; the error is the issue's yardstick, over the whole image.
# The benchmark's `paired` part does that (C = 3.3 fixed beforehand, F = 1.6, 1.1, 0.75) and
# splits each image's error into the pixels showing a penumbra region and the rest (both relative
# to the reference's RMS over the whole image).

# %%
paired = res.get("paired", {})
print(f"{'scene':20s}{'C/F':>9s}{'DM el':>7s}{'unif el':>8s}{'ratio':>6s}"
      f"{'DM err (pen/rest)':>26s}{'uniform err (pen/rest)':>27s}{'DM pen share':>13s}")
for name, rows in paired.items():
    for r in rows:
        print(f"{name:20s}{r['coarse']:>5g}/{r['fine']:<4g}{r['dm_elements']:>6d}"
              f"{r['uniform_elements']:>8d}{r['element_ratio']:>6.2f}"
              f"{r['dm_error']:>10.4f} ({r['dm_error_penumbra']:.4f}/{r['dm_error_rest']:.4f})"
              f"{r['uniform_error']:>10.4f} ({r['uniform_error_penumbra']:.4f}/"
              f"{r['uniform_error_rest']:.4f}){r['dm_penumbra_share']:>12.2f}")
# the claim, decided beforehand: at F, DM with <= 60 % of the uniform mesh's elements and no more error
for name, rows in paired.items():
    held = [r["fine"] for r in rows if r["element_ratio"] <= 0.6 and r["error_ratio"] <= 1.0]
    print(f"{name}: the claim holds at F = {held if held else 'none of'} {[r['fine'] for r in rows]}")

# %% [markdown]
# Measured (also in `benchmarks/results/discontinuity.md`; solves to 1 % unshot): on the room the
# DM meshes have 51 %, 34 % and 23 % of the uniform meshes' elements at F = 1.6, 1.1, 0.75
# (Table 3.1's N_e1 < N_e2 holds), but 2.5×, 4.0× and 7.5× their image error; on the chair 124 %,
# 65 % and 33 % of the elements (the line network alone outweighs the uniform mesh at F = 1.6) for
# 1.1×, 1.8× and 4.3× the error. The reason is where the error lies: 94–97 % of the room
# DM's squared error, and ~95 % of the chair's, is in pixels outside the penumbra regions, on
# surfaces 3.3.6 leaves at the coarse size by design — on the room's difference image most of it
# lies on the brightly lit surfaces nearest the light, whose direct-light fall-off a 3.3 mesh
# cannot follow (that part's error, 0.073 on the room and 0.038 on the chair, is the same at
# every F). Refining the penumbra cannot reach it, and reaching the uniform mesh's error means
# shrinking the coarse size towards F, which removes the saving. So "the simplified method
# reaches the uniform mesh's error with ≤ 60 % of its elements" does **not** hold with the
# thesis's setting (the comparison above, fixed before the rerun: printed per F), for the reason
# measured; the text fixes no coarse size that would make it hold, and none was tuned. The
# uniform meshes' own error says the same: at F = 1.6, 1.1 and 0.75 the penumbra pixels carry
# 0.36, 0.41 and 0.39 of the uniform mesh's squared error on the room and 0.04, 0.04 and 0.07 on
# the chair; the rest lies where the DM keeps the coarse size (its error there 0.073 on the room
# against the uniform 0.024 → 0.008, 0.038–0.039 on the chair against 0.035 → 0.009), so no
# penumbra-only refinement reaches the uniform error with 60 % of its elements.
#
# On the 12 × 15 sphere (curves above), now one occluder, the simplified DM points
# (3.3/1.6: 2160 elements, error 0.0291; 3.3/0.75: 2608, 0.0290) are below every uniform point's
# error (0.0592, 0.0516, 0.0376 with 1920, 2056, 2920 elements): reaching each takes 1.13, 1.05
# and 0.74 of the uniform mesh's elements — better than the per-face meshes' 11.8, 11.0 and 7.7,
# but not ≤ 0.60. Against the two coarser points it cannot be at coarse size 3.3, which is the
# uniform 3.3 mesh's (1920 elements) before any penumbra refinement; so the benchmark's `coarser`
# part carries every scene's simplified curve to coarse sizes 4.36 and 5.75 (the uniform curve's
# own step 3.3/2.5, penumbra 1.6; fixed before measuring). The meshes hardly shrink — the lines
# and the regions they bound keep their elements: sphere 1896 and 1768 elements (errors 0.0435,
# 0.0652), room 968 and 864, chair 3192 and 3048 — and the ratios become 0.99, 0.92, 0.74 on the
# sphere, 1.57 / not reached / not reached on the room, 3.33, 2.75, 1.57 on the chair (the table
# printed above and in `discontinuity.md`). Adaptive subdivision reaches
# 0.0268 with 2403 elements. Paired at the same F (the table above, C = 3.3): the sphere's DM has
# 0.61 of the uniform mesh's elements at F = 1.6 with 0.90 of its error (2160 against 3552
# elements; 0.0291 against 0.0323), so the claim misses there by 0.008 in the ratio, and 0.22 at
# F = 0.75 with 2.1× its error (2608 against 11,624; 0.0290 against 0.0137), for the chair's
# reason: the penumbra pixels (1 % of the image under the 0.2 light) carry 0.02–0.03 of the
# uniform mesh's squared error.
#
# **Why the DM's penumbra error did not fall with F** (history: the section below
# finds the cause in the reference and in (2.8) at the lines; last run, solves to 10 % unshot: room
# 0.031 → 0.042 as F = 1.6 → 0.75, uniform 0.029 → 0.014). Measured on the room:
# * *not the visibility rays*: 4 × 4 or 8 × 8 rays per element–patch pair instead of 2 × 2 move
#   it by < 0.003 (0.0415 → 0.0387 → 0.0386 at F = 0.75). Elements in bright and umbra regions
#   see the light exactly: brute-force rays (10 points per element × 96 on the light) are all free
#   or all blocked, and the solver's factors there are the unoccluded factor or 0 whatever the
#   number of rays (`tests/test_discontinuity_visibility.py`, `element_states`).
# * *the unconverged solve*: at 10 % unshot the DM's leftover power sits in its many small
#   penumbra patches (29 % of it at F = 1.6, 59 % at 0.75; only 65 % → 38 % of those patches ever
#   shot, against every patch of the uniform meshes), replaced by a uniform ambient term. Solved
#   to 1 % unshot the DM's penumbra error falls 0.025 → 0.019 → 0.021 (uniform 0.025 → 0.017 →
#   0.009), and in direct light alone 0.023 → 0.016. The benchmark now solves to 1 %.
# * *the yardstick*: its reference (floor at 0.6) is itself 0.009–0.011 off in the penumbra
#   pixels against 0.25 references (uniform or DM, which agree to 0.007), and it favours the
#   uniform lattice: in direct light against the finer reference the DM's penumbra error is
#   0.027 → 0.020 → 0.019 against the uniform mesh's 0.038 → 0.024 → 0.016 (DM lower at F = 1.6
#   and 1.1 with a third to a half of the elements).
# * on the chair the penumbra regions are narrow strips along the legs' shadows, already meshed
#   finer than F by their lines (median longest edge 0.18 at F = 1.6; 23–27 % of those elements
#   slivers of quality < 0.2): F hardly changes them (380 → 492 penumbra elements), so their error
#   (0.083) stays.

# %% [markdown]
# ## The chapter's premise, measured true
#
# A mesh whose element edges lie on the discontinuity lines should interpolate a shadow better
# than one whose edges cross them at the same size. The `paired` table above said the opposite
# over the penumbra pixels. The candidates, each measured (benchmark part `exact`,
# `benchmarks/results/discontinuity.md`), in the order they matter:
#
# 1. **The reference's own penumbra error — it explains the reversed comparison.** The old
#    reference is a uniform mesh (floor 0.6) displayed by (2.8); against a reference whose area
#    light's direct part is exact at every pixel's surface point (the occluders projected onto
#    the light, `light_direct`), it is off by 0.117 (chair), 0.130 (sphere) and 0.009 (room) over
#    the penumbra pixels — more than every error compared under the chair's and sphere's 0.2
#    lights. It smears a narrow penumbra as the uniform meshes do, so it rewarded them and
#    charged DM for a sharp shadow. Against the exact reference the ordering flips: at F = 1.6 the
#    DM's error with the thesis's own display is 0.051 against the uniform mesh's 0.156 (chair),
#    0.064 against 0.163 (sphere), 0.029 against 0.031 (room).
# 2. **Gouraud interpolation across a line — the part of the realisation to fix.** (2.8) makes a
#    node on a discontinuity line the mean of the elements on both sides, so the coarse bright or
#    umbra elements beside the penumbra pull the line's nodes by an amount set by the values
#    across the line, not by F: the DM's (2.8) error stays flat (chair 0.051, 0.049, 0.050, 0.048
#    for F = 1.6, 1.1, 0.75, 0.5; sphere 0.064, 0.058, 0.062, 0.058). The fix evaluates each
#    area light's direct part at the node itself (`node_radiosity`; exact over the light's visible
#    part where rays find it partly hidden), keeping (2.8) for the reflected light: chair 0.024,
#    0.021, 0.025, 0.020; sphere 0.031, 0.030, 0.031, 0.030; room 0.0080, 0.0050, 0.0051, 0.0036.
# 3. **Visibility samples per element**: not it — 4 × 4 or 8 × 8 rays moved the DM's penumbra
#    error by < 0.003 (above), and the node values use the visible part exactly.
# 4. **Slivers, the coarse umbra and bright elements next to the penumbra**: the coarse elements
#    act only through (2.8)'s means at the line's nodes (item 2). Under the 0.2 lights the
#    penumbra is a band narrower than every F, one element across whatever F (the chair's DM mesh
#    grows only 3464 → 3936 elements from F = 1.6 to 0.5): F refines along the lines, not across.
# 5. **The penumbra mask**: the same pixels (the DM mesh's penumbra elements) for every image.
#
# So the DM mesh interpolates the shadow better than the uniform mesh at every pairing on the
# three scenes, by 4.2–6.6× on the small-light scenes (against the better of the uniform mesh's
# two displays), once the reference is right and the line's nodes carry their own direct light.
# **Not shown**: that its error falls at every step of F. On the room it falls from 1.6 to 1.1
# (0.0080 → 0.0050), not from 1.1 to 0.75 (0.0051, a step smaller than the room reference's own
# error, below), and again to 0.5 (0.0036); on the chair and the sphere it is flat at
# 0.020–0.025 and 0.030–0.031. Measured reason: F does not change the mesh across those narrow
# bands (item 4), so what is left is across them. In direct light alone,
# exact at the pixels and at the DM mesh's nodes (benchmark part `across`, chair at F = 1.6), the
# penumbra error is 0.043 with the elements as meshed, 0.0105 with each split in 4 and 0.0040 in
# 16, while F = 0.75 instead of 1.6 leaves it at 0.045: the thesis's F, an edge length, does not
# control the accuracy of a penumbra narrower than F; an element size across the band would.
#
# **The reference's own error.** Its direct part is exact; its reflected part differs from one
# solved on a mesh twice as coarse by D over the penumbra pixels, so its own error is about D/3.
# The criterion, fixed before from the issue, compares the reference's own error with the errors
# compared, so it must be stated in their units: relative to the reference image's RMS over all
# pixels (the reference with the coarse solve's reflected part, against the reference). The
# earlier check took D relative to the reflected part's own RMS, a unit mismatch (on the room the
# reflected part's RMS is 0.39 of the image's), corrected here. Measured (the exact part rerun),
# relative to the image's RMS: D = 0.0039 (chair), 0.0013 (sphere), 0.0018 (room), so D/3 =
# 0.0013, 0.0004 and 0.0006, against a third of the smallest error compared (0.0195, 0.0304,
# 0.0036: a third 0.0065, 0.0101, 0.0012). `REF_OK` holds on all three scenes. In the reflected
# part's units D is 0.0079, 0.0030 and 0.0046 (the numbers the earlier check used; it had failed
# the room). The references: 6,872 elements (chair) and 8,664 (sphere) at 0.6 on the floor and the
# occluders, 1.4 elsewhere; 35,208 on the room, 0.3 on every polygon that receives a penumbra.
# The room's reference needed that: in the reflected part's units, D had been set by the walls,
# not by the solve. One factor at a time (floor and occluders 0.6, walls 1.4, against 1.2/2.8; D = 0.0131),
# a solve to 0.1 % unshot gave 0.0135, no ambient term 0.0134, 4 × 4 rays 0.0129, while the walls
# alone (1.4 against 2.8) gave 0.0137 and the floor alone (0.6 against 1.2) 0.0052: 540 of the
# room's 2165 penumbra pixels lie on the walls x0 and z0, which the reference had left at the
# walls' size, so refining only the floor and the occluders to 0.3 had left D at 0.0143.
#
# The table: penumbra-pixel error against the exact-direct reference (old reference in
# parentheses), `mean` node values by (2.8), `node` with each area light's direct part at the
# node (`polygen.discontinuity.node_values.node_radiosity`). The claims, fixed before the run:
# simplified DM (`node`) at F no worse than the uniform mesh at F (by (2.8), the thesis's
# display, and by the same node rule) at every pairing; DM's error falls at every step
# F = 1.6 → 1.1 → 0.75 → 0.5; the reference's own penumbra error at most a third of the
# smallest error compared, both relative to the reference image's RMS.

# %%
exact = res.get("exact", {})
FALLS, REF_OK = {}, {}
for name, e in exact.items():
    # D: the reflected part against one solved twice as coarse, in the errors' units (relative to the
    # reference image's RMS) and in the reflected part's own (relative to its RMS)
    d_image, d_rest = (e[k]["error_penumbra"] for k in ("reference_vs_coarse_rest", "reference_rest_vs_coarse"))
    print(f"{name}: reference {e['reference_elements']} elements; old reference's own penumbra error "
          f"{e['old_reference_vs_exact']['error_penumbra']:.4f}; this reference's D {d_image:.4f} relative to the "
          f"image's RMS (D/3 {d_image / 3:.4f}), {d_rest:.4f} relative to the reflected part's RMS")
    cols = {"dm_mean": "DM mean", "dm_node": "DM node", "uniform_mean": "unif mean", "uniform_node": "unif node"}
    rows_e = [{"F": r["fine"], "DM el": r["dm_elements"], "unif el": r.get("uniform_elements", ""),
               **{lab: f"{r[k]['error_penumbra']:.4f} ({r[k + '_old_reference']['error_penumbra']:.4f})"
                  for k, lab in cols.items() if k in r}} for r in e["rows"]]
    print(table(rows_e, ["F", "DM el", "DM mean", "DM node", "unif el", "unif mean", "unif node"], floatfmt="{:g}"))

# %%
for name, e in exact.items():
    rows = e["rows"]
    dm = [r["dm_node"]["error_penumbra"] for r in rows]
    paired_rows = [r for r in rows if "uniform_mean" in r]
    # DM at F no worse than uniform at F, at every pairing (printed: the results file is not asserted on;
    # the same comparison is measured in this run and asserted below)
    HOLDS = all(r["dm_node"]["error_penumbra"] <= min(r["uniform_mean"]["error_penumbra"],
                                                      r["uniform_node"]["error_penumbra"]) for r in paired_rows)
    print(f"{name}: simplified DM (node) <= uniform at every pairing: {HOLDS}")
    FALLS[name] = all(b < a for a, b in zip(dm, dm[1:]))
    compared = min(min(r[k]["error_penumbra"] for k in ("dm_node", "uniform_mean", "uniform_node") if k in r)
                   for r in rows)
    # the reference's own error (D/3) against a third of the smallest error compared, both relative to
    # the reference image's RMS
    REF_OK[name] = e["reference_vs_coarse_rest"]["error_penumbra"] / 3.0 <= compared / 3.0
    print(f"{name}: DM node error by F {[round(x, 4) for x in dm]}: falls at every step {FALLS[name]}; "
          f"reference's own error (D/3, image's RMS) <= 1/3 of the smallest compared ({compared:.4f}): {REF_OK[name]}")

# %% [markdown]
# ### The premise, measured in this run
#
# The table above is the benchmark's full-size run, read from `benchmarks/results/`: printed, not
# asserted, since a committed file is not a measurement of this run. The same comparison is made
# here at this notebook's sizes (`COARSE`/`FINE`, its solve, camera and image) on the three
# examples, fixed before the run: simplified DM with the light's direct part at its nodes, at
# `FINE` in its penumbra regions, against the uniform mesh at `FINE` in both displays, over the
# penumbra pixels. A penumbra pixel is one whose surface point some light leaves partly visible
# (`illumination` at each pixel's surface point: the true penumbra, not a mesh's elements). The
# reference's direct light is exact at every pixel (`exact_direct_image`); its reflected light
# and ambient term come from a mesh of half `FINE` on the floor and the occluders and half `COARSE`
# elsewhere (the chair's reference serves claim (c) below too).

# %%
from polygen.discontinuity.node_values import exact_direct_image, node_image, pixel_states
from polygen.radiosity.error import adaptive_at_count, image_error

refs = {}   # each example's reference image and the lights' states at its pixels
for name in ["two_rectangles_room", "sphere_scene", "chair_scene"]:
    sc, sd, m = examples[name][:3]
    rm = mesh_scene(sc, [FINE / 2 if (p.name == "room_y0" or not p.name.startswith("room")) else COARSE / 2
                         for p in sc.polygons], element_levels=1)
    refs[name] = (exact_direct_image(rm, progressive_refinement(rm, **SOLVE), cam)[0], pixel_states(rm, sd, cam))

# %%
premise = {}
for name, (ref, states) in refs.items():
    sc, sd, m = examples[name][:3]
    pen = (states == PENUMBRA).any(axis=-1)
    u = mesh_scene(sc, FINE, element_levels=1)
    err = {}
    for label, mm in (("simplified DM", m), ("uniform", u)):
        rr = progressive_refinement(mm, **SOLVE)
        err[label, "(2.8)"] = image_error(shade(mm, rr.display_radiosity(mm), cam), ref, mask=pen)
        err[label, "node"] = image_error(node_image(mm, rr, cam), ref, mask=pen)
    premise[name] = err
    print(f"{name}: {int(pen.sum())} penumbra pixels; simplified DM {m.n_elements} elements, error (2.8) "
          f"{err['simplified DM', '(2.8)']:.4f}, node {err['simplified DM', 'node']:.4f}; uniform at F = {FINE:g} "
          f"{u.n_elements} elements, (2.8) {err['uniform', '(2.8)']:.4f}, node {err['uniform', 'node']:.4f}")
for name, err in premise.items():   # the premise: at F, no worse than the uniform mesh at F, either display
    assert err["simplified DM", "node"] <= min(err["uniform", "(2.8)"], err["uniform", "node"]), name

# %% [markdown]
# Measured at this size: simplified DM's penumbra error with node values is below the uniform
# mesh's in both displays on the three scenes, with a fifth to a quarter of its elements (room
# 0.0011 against 0.0017 and 0.0044; sphere 0.032 against 0.124 and 0.129; chair 0.022 against 0.136
# and 0.137). In the thesis's display (2.8) the DM mesh is below on the sphere and the chair and
# above on the room (0.0133 against 0.0044), for item 2's reason: the line's nodes take the mean of
# the elements on both sides, and the room's wide penumbra has many of them.

# %% [markdown]
# ## The thesis's claims, measured: slivers, elements, and the chair against adaptive subdivision
#
# Three of the chapter's claims, restated so that a count decides them, with the sizes and the
# protocol fixed before the run (this notebook's `COARSE`/`FINE`, solve and camera):
#
# * **(a) fewer slivers** than conventional DM (3.5): at the same sizes, fewer elements of
#   radius ratio < 0.2, and a larger smallest angle, on Fig. 3.4's scene and the three examples
#   (the sphere 4 × 6 by default, Fig. 3.19's 12 × 15 with `POLYGEN_FULL=1`: conventional DM
#   along every EV/VE line of its 180 faces takes 8 minutes to mesh);
# * **(b) fewer elements for the same image** (Table 3.1's saving, against conventional DM):
#   simplified DM reaches conventional DM's whole-image error with ≤ 60 % of conventional's
#   elements, conventional at `COARSE`/`FINE` and simplified at coarse sizes `COARSE` × 1.74,
#   1.32, 1, 0.76, 0.57 (coarser and finer), `FINE` in the penumbra regions, on the three
#   examples (the sphere 12 × 15);
# * **(c) sharper shadows than adaptive subdivision** (Figs 3.22/3.23): over the pixels of the
#   chair's shadow (umbra or penumbra of its light, by `illumination` at each pixel's surface
#   point), simplified DM's image error is below adaptive subdivision's at an equal element
#   count (± 2 %: `adaptive_at_count` runs Def. 2.6's rounds at 10 % and raises the last round's
#   threshold until the count lands).
#
# Images are compared with a reference whose direct light is exact at every pixel
# (`exact_direct_image`: the light's visible part from the pixel's surface point), the reflected
# light and the ambient term from a mesh of half `FINE` on the floor and the occluders and half
# `COARSE` elsewhere. Each mesh is shown both by (2.8), the thesis's display, and with the
# light's direct part at its nodes (`node_radiosity`).

# %%
claim_scenes = {"figure_3_4_scene": sc34, "two_rectangles_room": examples["two_rectangles_room"][0],
                "sphere_scene": sc_sph if FULL else scenes.sphere_scene(n_lat=4, n_lon=6),
                "chair_scene": examples["chair_scene"][0]}
slivers = {}
for name, sc in claim_scenes.items():
    for method in ("simplified", "conventional"):
        mm = discontinuity_mesh(sc, patch_size=COARSE, penumbra_patch_size=FINE, method=method)
        ang, q = mm.element_quality()
        slivers[name, method] = (mm.n_elements, int(np.sum(q < 0.2)), float(ang.min()))
print(f"{'scene':22s}{'method':>14s}{'elements':>10s}{'q < 0.2':>9s}{'share':>7s}{'min angle':>11s}")
for (name, method), (n, ns, amin) in slivers.items():
    print(f"{name:22s}{method:>14s}{n:>10d}{ns:>9d}{ns / n:>7.3f}{amin:>10.2f}°")
for name in claim_scenes:   # (a): fewer slivers and a larger smallest angle, at the same sizes
    s_, c_ = slivers[name, "simplified"], slivers[name, "conventional"]
    assert s_[1] < c_[1] and s_[2] > c_[2], name

# %%
sc, sd, m_dm = examples["chair_scene"][:3]
ref_chair, states = refs["chair_scene"]
shadow = (states >= PENUMBRA).any(axis=-1)   # the chair's shadow: penumbra or umbra of its light

# %%
m_ad, r_ad = adaptive_at_count(sc, m_dm.n_elements, patch_size=COARSE, solve=SOLVE)
chair_err = {}
for label, mm, rr in (("simplified DM", m_dm, progressive_refinement(m_dm, **SOLVE)),
                      ("adaptive subdivision", m_ad, r_ad)):
    chair_err[label, "(2.8)"] = image_error(shade(mm, rr.display_radiosity(mm), cam), ref_chair, mask=shadow)
    chair_err[label, "node"] = image_error(node_image(mm, rr, cam), ref_chair, mask=shadow)
print(f"chair: simplified DM {m_dm.n_elements} elements, adaptive subdivision {m_ad.n_elements} "
      f"({m_ad.n_elements / m_dm.n_elements - 1:+.1%}); {int(shadow.sum())} shadow pixels")
for (label, disp), v in chair_err.items():
    print(f"  {label:22s} {disp:6s} error over the shadow {v:.4f}")
assert abs(m_ad.n_elements - m_dm.n_elements) <= 0.02 * m_dm.n_elements
for disp in ("(2.8)", "node"):   # (c): sharper shadows at an equal count, either display
    assert chair_err["simplified DM", disp] < chair_err["adaptive subdivision", disp]

# %% [markdown]
# (b) needs a solve and two images of every mesh of a family on each scene (conventional DM on
# Fig. 3.19's sphere alone has 68,200 elements and takes 8 minutes to mesh), so it is measured by
# `benchmarks/discontinuity.py --parts conventional` at this notebook's sizes, solve, camera and
# image (`benchmarks/results/discontinuity_conventional.md`), and printed here as measured.

# %%
conv_path = Path("..") / "benchmarks" / "results" / "discontinuity_conventional.json"
conv_res = json.loads(conv_path.read_text()) if conv_path.exists() else {"scenes": {}}
for name, e in conv_res["scenes"].items():
    for k, c in e["claim"].items():
        same = [r["elements"] for r in e["rows"] if r["method"] == "simplified" and r["coarse"] == COARSE]
        print(f"{name} {'(2.8)' if k == 'error_mean' else 'node '}: conventional {c['conventional_elements']} "
              f"elements, error {c['conventional_error']:.4f}; simplified reaches it with "
              + ("none of its meshes" if c["ratio"] is None else
                 f"{c['simplified_elements']} = {c['ratio']:.2f} of them")
              + (f" (same sizes: {same[0] / c['conventional_elements']:.2f} of the elements)" if same else ""))

# %% [markdown]
# Measured:
#
# * **(a) holds** on all four scenes: fewer slivers and a larger smallest angle. Conventional DM
#   draws every EV/VE line, and lines that cross at small angles or end near each other cut the
#   patches into needles (on the chair 48 % of its elements have q < 0.2, against 19 % for
#   simplified DM, whose narrow penumbra strips along the legs' shadows are its own slivers).
# * **(c) holds**: over the chair's shadow, at an equal element count, simplified DM's error is
#   below adaptive subdivision's in both displays, by 2–5×: adaptive subdivision spends its
#   elements wherever neighbours differ and still lays edges across the penumbra; the DM's
#   edges lie along it.
# * **(b) holds only on the sphere, in the thesis's display** (results file, 12 × 15 sphere):
#   conventional DM meshes 68,200 elements there, simplified DM reaches its (2.8) error with
#   3544, 0.05 of them. On the room (0.90 by (2.8), 1.11 with node values) and the chair (0.78)
#   it does not. The measured reason: at the same sizes the two meshes have the same image error
#   (room 0.0382 against 0.0383, chair 0.0268 against 0.0266 by (2.8)), because most of the
#   error lies on the coarse regions, meshed alike by both (see "The ≤ 60 % claim examined"); the
#   simplified mesh saves only the elements of the lines it leaves out — 10 % of conventional's
#   on the room, whose two rectangles cast few extra EV/VE lines, 37 % on the chair — and to go
#   below conventional's error it must shrink its coarse size, which costs more than that. With
#   the light's direct part at the nodes, conventional's extra lines inside the penumbra carry
#   information the simplified mesh lacks (the sphere: 0.0034 against ≥ 0.0036 for every
#   simplified mesh of the family, whose penumbra size is fixed).

# %% [markdown]
# ## Moving the light
#
# With a kernel attached, the slider moves the light of Fig. 3.4's scene along x and redraws the
# receiver complex (in a static rendering it shows the light at the centre).

# %%
plot_dm.light_slider(sc34, dx_max=3.0, step=0.5);
