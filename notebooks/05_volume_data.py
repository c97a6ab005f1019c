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
# # Chapter 5.2 — Volume data
#
# Itoh's isosurface methods (chapters 5–7) work on **unstructured volumes** made only of
# tetrahedra or only of hexahedra (Def. 5.4). Each element knows its nodes and its face
# neighbours — cells that touch through faces with *different* nodes are not neighbours
# (Def. 5.1); faces owned by one element are boundary faces (Def. 5.3); connected groups of
# boundary faces bound the volume or its voids (Def. 5.6), and the Euler number
# V + F − E of a group gives its genus G = 1 − E/2, the number of through-holes (Defs 5.7, 5.8).
#
# This notebook shows that data structure on polygen's generated volumes — gmsh meshes of
# mechanical parts with a scikit-fem heat-conduction field — and reproduces Table 6.1
# (cells, boundary cells, nodes of data 1–4) beside the thesis's numbers.

# %%
import os

FULL = os.environ.get("POLYGEN_FULL") == "1"   # thesis sizes for everything when set

from polygen import plotting
from polygen.volume import UnstructuredVolume, datasets

pv = plotting.setup_notebook()
TABLE_DATA = ["data1", "data2", "data3", "data4"]          # Table 6.1: always the thesis's sizes
SHOW = ["data1", "hexa1"] + (["data2", "data3", "data4", "data5", "hexa2", "hexa3"] if FULL else [])

# %% [markdown]
# ## Fig. 5.1 — elements, nodes, face neighbours
#
# An element (here a tetrahedron of data 1) stores its node ids and, lazily computed, the
# element across each of its faces; `-1` marks a boundary face.

# %%
vol = datasets.load("data1")
print(vol)
cell = int(vol.boundary_cells[len(vol.boundary_cells) // 2])
print("nodes     :", vol.cells[cell])
print("neighbours:", vol.face_neighbors[cell], "(-1 = boundary face)")
print("field at nodes:", vol.scalars()[vol.cells[cell]].round(4))
plotting.plot_cell_and_neighbours(vol, cell).show()

# %%
# Def. 5.1: face neighbours are symmetric, and every face is either shared by two cells or a boundary face
import numpy as np

a, f = np.nonzero(vol.face_neighbors >= 0)
b = vol.face_neighbors[a, f]
assert np.all((vol.face_neighbors[b] == a[:, None]).any(axis=1))
assert (vol.face_neighbors >= 0).sum() + len(vol.boundary_faces) == 4 * vol.n_cells

# %% [markdown]
# ## Fig. 5.2 — rectangular, structured and unstructured volumes
#
# Rectangular and structured volumes index their elements by a 3D array; unstructured ones
# do not, which is why the thesis's methods walk face neighbours instead.

# %%
rect = pv.ImageData(dimensions=(6, 6, 6))
structured = rect.cast_to_structured_grid()
structured.points = structured.points + 0.2 * np.sin(structured.points[:, [1, 2, 0]])
tiny = datasets.load("genus3")
plotting.plot_volume_kinds(rect, structured, tiny.to_pyvista()).show()

# %% [markdown]
# ## Boundary groups, voids and through-holes (Defs 5.6–5.10)
#
# Group 1 is the outer surface; groups 2, … bound voids (their outward faces point into
# the empty region, so they enclose negative volume). The genus of each group is what the
# part's CAD construction implies: bolt holes and bores are through-holes, spheres cut out
# of the inside are voids.

# %%
rows = []
for name in SHOW:
    v = datasets.load(name)
    inf = datasets.info(name)
    rows.append({"data": name, "type": v.cell_type, "cells": v.n_cells, "groups": v.n_boundary_groups,
                 "genus per group": tuple(int(g) for g in v.group_genus), "CAD genus": inf.genus,
                 "voids": v.n_voids, "CAD voids": inf.n_voids, "through-holes": v.n_through_holes})
print(plotting.table(rows, list(rows[0])))
for r in rows:
    assert r["genus per group"] == r["CAD genus"] and r["voids"] == r["CAD voids"], r

# %%
plotting.plot_boundary_groups(datasets.load("data1"), title="data 1: outer surface and void").show()

# %%
plotting.plot_boundary_groups(datasets.load("hexa1"), title="hexahedral data 1").show()

# %%
# the hand-checkable volumes used by the tests: a ring, a hollow cube, a block with three holes
for name in ["torus", "hollow_cube", "genus3", "torus_hex", "hollow_cube_hex", "genus3_hex"]:
    v = datasets.load(name)
    print(f"{name:16s} {v.cell_type:5s} cells={v.n_cells:4d} euler={v.group_euler.tolist()} "
          f"genus={v.group_genus.tolist()} voids={v.n_voids}")
    assert tuple(v.group_genus) == datasets.info(name).genus and v.n_voids == datasets.info(name).n_voids

# %% [markdown]
# ## Table 6.1 — the data sets
#
# The thesis's volumes were FEM results of 20k–560k tetrahedra. Ours are generated with the
# same cell counts (within ±5 %); boundary cells and nodes depend on the part's shape and are
# printed for comparison only. What matters for chapters 6 and 7 is that boundary cells are a
# small fraction of the volume, falling as the mesh is refined.

# %%
rows = []
for name in TABLE_DATA:
    v, t = datasets.load(name), datasets.info(name).thesis
    rows.append({"data": name, "N_e": v.n_cells, "N_e thesis": t["cells"],
                 "N_b": len(v.boundary_cells), "N_b thesis": t["boundary_cells"],
                 "N_n": v.n_points, "N_n thesis": t["nodes"],
                 "N_b/N_e": len(v.boundary_cells) / v.n_cells, "N_b/N_e thesis": t["boundary_cells"] / t["cells"]})
print(plotting.table(rows, list(rows[0])))

# %%
for r in rows:
    assert abs(r["N_e"] / r["N_e thesis"] - 1) <= 0.05, r          # same sizes as the thesis
# as in the thesis, the boundary fraction falls as the volumes grow: checked on the volumes loaded above
frac = [r["N_b"] / r["N_e"] for r in rows]
assert all(a > b for a, b in zip(frac, frac[1:])), frac
