"""Figures for the notebooks: pyvista scenes and matplotlib plots.

Nothing in polygen's algorithms imports this module. pyvista and matplotlib
are imported inside the functions. Every 3D function returns a
``pyvista.Plotter`` (call ``.show()`` in a notebook, ``.screenshot(path)``
elsewhere); rendering is off-screen when there is no display.
"""

from __future__ import annotations

import os

import numpy as np

# Thesis's original values are printed beside ours in this column name.
ORIGINAL = "thesis"


def setup_notebook(*, window_size=(900, 600)):
    """Configure pyvista for notebooks and headless machines.

    Off-screen rendering through EGL when no display is attached (or when
    ``PYVISTA_OFF_SCREEN`` says so), static images in Jupyter.
    """
    headless = not os.environ.get("DISPLAY") or os.environ.get("PYVISTA_OFF_SCREEN", "").lower() == "true"
    if headless:
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = headless
    pv.global_theme.window_size = list(window_size)
    pv.global_theme.notebook = True
    try:
        pv.set_jupyter_backend("static")
    except Exception:  # outside Jupyter there is no backend to set
        pass
    return pv


def _plotter(shape=(1, 1), window_size=None):
    import pyvista as pv

    return pv.Plotter(shape=shape, off_screen=pv.OFF_SCREEN, window_size=window_size)


def boundary_surface(vol):
    """``pyvista.PolyData`` of the boundary faces with their group numbers as ``"group"``."""
    import pyvista as pv

    f = vol.boundary_face_nodes
    faces = np.hstack([np.full((len(f), 1), f.shape[1]), f]).ravel()
    surf = pv.PolyData(vol.points, faces)
    surf.cell_data["group"] = vol.boundary_groups
    return surf


def plot_boundary_groups(vol, *, cut_normal=(0, 1, 0), plotter=None, title=None):
    """Boundary-face groups coloured (1 = outer, 2.. = voids), with a cut-away half.

    The left view shows the outer group translucent with the voids inside;
    the right one the volume clipped by a plane through its centre, cells
    coloured by the first field.
    """
    import pyvista as pv

    surf = boundary_surface(vol)
    p = plotter or _plotter(shape=(1, 2), window_size=(1200, 500))
    p.subplot(0, 0)
    outer = surf.extract_cells(np.flatnonzero(surf.cell_data["group"] == 1))
    p.add_mesh(outer, color="lightgray", opacity=0.25, show_edges=False)
    if vol.n_boundary_groups > 1:
        inner = surf.extract_cells(np.flatnonzero(surf.cell_data["group"] > 1))
        p.add_mesh(inner, scalars="group", cmap="tab10", show_edges=True, show_scalar_bar=False)
    p.add_text(title or f"{vol.n_boundary_groups} boundary groups, genus {vol.n_through_holes}", font_size=10)
    p.subplot(0, 1)
    grid = vol.to_pyvista()
    centre = vol.points.mean(axis=0)
    clipped = grid.clip(normal=cut_normal, origin=centre, crinkle=True)
    kw = {"scalars": next(iter(vol.fields))} if vol.fields else {"color": "tan"}
    p.add_mesh(clipped, show_edges=vol.n_cells < 50_000, cmap="coolwarm", **kw)
    p.add_text("cut-away", font_size=10)
    p.link_views()
    p.view_isometric()
    return p


def plot_cell_and_neighbours(vol, cell, *, plotter=None):
    """One cell, its face neighbours and its nodes: the data structure of Fig. 5.1."""
    import pyvista as pv

    grid = vol.to_pyvista()
    nb = vol.face_neighbors[cell]
    p = plotter or _plotter()
    p.add_mesh(grid.extract_cells([cell]), color="tomato", show_edges=True, line_width=3)
    if np.any(nb >= 0):
        p.add_mesh(grid.extract_cells(nb[nb >= 0]), color="lightblue", opacity=0.5, show_edges=True)
    nodes = pv.PolyData(vol.points[vol.cells[cell]])
    p.add_point_labels(nodes, [f"N{i + 1}" for i in range(vol.cells.shape[1])], point_size=12, font_size=12)
    p.add_text(f"element {cell}: {np.sum(nb >= 0)} face neighbours, {np.sum(nb < 0)} boundary faces", font_size=10)
    return p


def plot_volume_kinds(rectangular, structured, unstructured, *, plotter=None):
    """Side by side: rectangular, structured and unstructured volumes (Fig. 5.2)."""
    p = plotter or _plotter(shape=(1, 3), window_size=(1200, 400))
    for i, (grid, name) in enumerate([(rectangular, "rectangular"), (structured, "structured"),
                                      (unstructured, "unstructured")]):
        p.subplot(0, i)
        p.add_mesh(grid, show_edges=True, color="wheat")
        p.add_text(name, font_size=10)
        p.view_isometric()
    return p


def table(rows, columns, *, floatfmt="{:.4g}"):
    """A plain-text table of dict rows, for printing in notebooks."""
    def fmt(v):
        return floatfmt.format(v) if isinstance(v, float) else str(v)

    cells = [[fmt(r.get(c, "")) for c in columns] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(columns)]
    out = ["  ".join(c.rjust(w) for c, w in zip(columns, widths)), "  ".join("-" * w for w in widths)]
    out += ["  ".join(v.rjust(w) for v, w in zip(row, widths)) for row in cells]
    return "\n".join(out)


def with_thesis(rows, columns, thesis, *, key="data", floatfmt="{:.4g}"):
    """Rows for :func:`table` with the thesis's value in parentheses after ours.

    ``thesis`` maps a column to the thesis's values for data 1, 2, ...; a
    row's data set number is the last character of ``row[key]`` ("data3").
    Columns the thesis does not give are shown alone.
    """
    out = []
    for r in rows:
        i = int(str(r[key])[-1]) - 1
        cells = {key: r[key]}
        for c in columns:
            v = floatfmt.format(r[c]) if isinstance(r[c], float) else str(r[c])
            cells[c] = v + (f" ({thesis[c][i]})" if c in thesis else "")
        out.append(cells)
    return out


def plot_isosurfaces(vol, surfaces, values=None, *, plotter=None, cmap="viridis", opacity=0.6):
    """Several isosurfaces coloured by value inside the volume's outline."""
    p = plotter or _plotter()
    p.add_mesh(boundary_surface(vol), color="lightgray", opacity=0.12)
    values = [s.value for s in surfaces] if values is None else list(values)
    lo, hi = (min(values), max(values)) if values else (0.0, 1.0)
    bar = True
    for iso, v in zip(surfaces, values):
        if iso.is_empty:
            continue
        poly = iso.to_pyvista()
        poly.point_data["isovalue"] = np.full(poly.n_points, v)
        p.add_mesh(poly, scalars="isovalue", clim=(lo, hi), cmap=cmap, opacity=opacity, smooth_shading=True,
                   show_scalar_bar=bar)
        bar = False
    p.view_isometric()
    return p
