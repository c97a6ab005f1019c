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
# `polygen.plotting.discontinuity`.

# %%
import json
import os
from pathlib import Path

FULL = os.environ.get("POLYGEN_FULL") == "1"   # thesis-like sizes when set

import ipywidgets
import matplotlib.pyplot as plt
import numpy as np

from polygen.discontinuity import (conventional_bsp, conventional_segments, discontinuity_mesh,
                                   scene_lights, scene_sections, section_segments,
                                   shadow_polyhedron, simplified_discontinuity)
from polygen.plotting import discontinuity as plot_dm
from polygen.plotting.radiosity import plot_polygon_mesh, show_images
from polygen.radiosity import Camera, mesh_scene, progressive_refinement, scenes
from polygen.radiosity.error import shade
from polygen.radiosity.scene import AreaLight, Scene

# patch sizes outside / inside penumbra, and the solve: direct light + ambient by default
COARSE, FINE = (1.0, 0.25) if FULL else (2.5, 0.6)
SOLVE = dict(tol=0.01, ambient=True) if FULL else dict(max_shots=1, ambient=True, visibility_samples=2)
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
assert ph.candidate_planes == 2 * 4 * 4
assert len(ph.umbra.planes) == 1 + 4            # the occluder's plane and one per occluder edge

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
assert conv.surfaces == pairs * 2 * Ns * No
assert len(simp) == pairs * (Ns + 2 * No) < conv.surfaces

# %% [markdown]
# ## Figs 2.10, 3.4 — regions by BSP against regions by loops
#
# The thesis: the simplified lines split Fig. 3.4's receiver into **29** regions by a BSP tree
# and **6** by loops. The BSP count depends on an insertion order and a geometry the text does
# not give; the claim is the inequality.

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
# ## Figs 3.15–3.23 — the three examples rendered
#
# Example 1 (Figs 3.15–3.18): the box room with two floating rectangles; example 2 (Fig. 3.19):
# the 180-polygon sphere under a very small area light; the chair (Figs 3.20–3.23), simplified
# DM against adaptive subdivision. By default the solve is the light's direct shot plus the
# ambient term (`POLYGEN_FULL=1`: progressive refinement to 1 % unshot).

# %%
cam = Camera([5.0, 8.5, 0.3], [5.0, 0.0, 6.5], fov=80.0, width=IMAGE, height=IMAGE, near=0.01)
examples, table31 = {}, {}
for name in ["two_rectangles_room", "sphere_scene", "chair_scene"]:
    sc = getattr(scenes, name)()
    sd = simplified_discontinuity(sc)
    m = discontinuity_mesh(sc, patch_size=COARSE, penumbra_patch_size=FINE, discontinuity=sd)
    r = progressive_refinement(m, **SOLVE)
    examples[name] = (sc, sd, m, shade(m, r.display_radiosity(m), cam))
    n_e2 = mesh_scene(sc, FINE, element_levels=1).n_elements
    table31[name] = dict(N_f1=len(sc.polygons), N_f2=len(sc.polygons) - sd.counters["receivers"]
                         + sd.counters["regions"], N_d=sd.counters["discontinuity_edges"],
                         N_p=m.n_patches, N_e1=m.n_elements, N_e2=n_e2,
                         T_d=m.discontinuity.timings["T_d"], T_m=m.discontinuity.timings["T_m"])
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
# ## Table 3.1 — meshing results
#
# N_f1 polygons before division, N_f2 after, N_d discontinuity edges, N_p patches, N_e1
# elements with the fine size in penumbra regions only, N_e2 with the fine size everywhere;
# T_d the discontinuity phase, T_m meshing (seconds). The thesis's numbers (IBM RS/6000 560) in
# parentheses. Our polygon counts differ: our room's walls are single polygons and the sphere
# scene is 180 sphere faces in a 6-wall room (the thesis's 721 faces include its room's
# subdivided walls); T_rs, the radiosity solve, is in `benchmarks/results/discontinuity.md`.
#
# Example 2's N_e1 < N_e2 (11230 < 17150) is printed, not asserted: at the default sizes the
# sphere's floor carries some 5000 discontinuity edges and 2700 regions (180 occluders under a
# 0.2 light: narrow penumbrae everywhere), and meshing along that line network alone takes more
# elements than the uniform fine mesh; the refinement only pays where the fine size is much
# smaller than the lines' spacing (`POLYGEN_FULL=1`).

# %%
THESIS31 = {"two_rectangles_room": dict(N_f1=8, N_f2=20, N_d=40, N_p=486, N_e1=3485, N_e2=6090,
                                        T_d=0.12, T_m=1.77),
            "sphere_scene": dict(N_f1=721, N_f2=2495, N_d=3116, N_p=6030, N_e1=11230,
                                 N_e2=17150, T_d=166.58, T_m=15.28)}
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

# %% [markdown]
# ## Table 3.2 — the discontinuity phase
#
# T_sdw shadow polyhedra, T_isr polyhedra against receivers, T_idd discontinuity edges against
# each other, T_lop loops, T_lit illumination states, T_div division into regions (seconds).
# The thesis's T_isr is quadratic in the polygon count (every polyhedron against every
# receiver); ours goes through a bounding-volume hierarchy (the benchmark measures the slope).

# %%
THESIS32 = {"two_rectangles_room": [0.03, 0.04, 0.02, 0.01, 0.01, 0.01],
            "sphere_scene": [0.21, 154.48, 3.76, 2.13, 5.50, 0.50]}
phases = ["T_sdw", "T_isr", "T_idd", "T_lop", "T_lit", "T_div"]
print(f"{'scene':22s}" + "".join(f"{k:>17s}" for k in phases))
for name, (sc, sd, m, _) in examples.items():
    th = THESIS32.get(name)
    cells = [f"{sd.timings[k]:.3f}" + (f" ({th[i]})" if th else "") for i, k in enumerate(phases)]
    print(f"{name:22s}" + "".join(f"{c:>17s}" for c in cells))

# %% [markdown]
# ## Better than the thesis, measured
#
# `benchmarks/discontinuity.py` solves each scene with uniform meshes, adaptive subdivision,
# conventional DM and simplified DM at several sizes and compares images against a finer
# reference (the yardstick of chapter 2): the DM curves keep the coarse size and shrink the
# penumbra size, the `_scaled` ones shrink both (penumbra a third of the coarse size). The
# curves below are read from its results; the
# claim of the issue — the simplified method reaches the uniform mesh's error with at most 60 %
# of its elements — is printed as measured, not asserted (the sizes are the benchmark's).

# %%
res_path = Path("..") / "benchmarks" / "results" / "discontinuity.json"
res = json.loads(res_path.read_text()) if res_path.exists() else {}
curves = res.get("curves", {})
if curves:
    fig, axes = plt.subplots(1, len(curves), figsize=(5 * len(curves), 3.8), squeeze=False)
    for ax, (name, cv) in zip(axes[0], curves.items()):
        kinds = ["uniform", "adaptive", "conventional", "simplified", "conventional_scaled",
                 "simplified_scaled"]
        plot_dm.plot_error_curves({k: cv[k] for k in kinds if k in cv}, ax=ax, title=name)
    plt.show()
    for name, cv in curves.items():
        for key in ("claim", "claim_scaled"):
            for q in cv.get(key, []):
                r = "not reached" if q["ratio"] is None else f"{q['ratio']:.2f} of its elements"
                print(f"{name} ({key}): uniform {q['uniform_elements']} elements, error "
                      f"{q['uniform_error']:.4f}: simplified DM {r}")

# %% [markdown]
# ## Moving the light
#
# With a kernel attached, the slider moves the light of Fig. 3.4's scene along x and redraws the
# receiver complex (in a static rendering it shows the light at the centre).

# %%
def complex_with_light_at(dx=0.0):
    polys = [AreaLight(p.vertices + [dx, 0.0, 0.0], emission=10.0, name=p.name)
             if p.name == "light" else p for p in sc34.polygons]
    cx = simplified_discontinuity(Scene(polys)).complexes[0]
    plot_dm.plot_complex(cx, title=f"light moved by {dx:+.1f}: {len(cx.alive_faces)} regions")
    plt.show()


ipywidgets.interact(complex_with_light_at,
                    dx=ipywidgets.FloatSlider(value=0.0, min=-3.0, max=3.0, step=0.5,
                                              continuous_update=False));
