"""What every figure module shares: the notebook set-up, the one plotter factory, boundary meshes, tables."""

from __future__ import annotations

import os

import numpy as np

# Thesis's original values are printed beside ours in this column name.
ORIGINAL = "thesis"
#: the thesis draws extrema as purple crosses
EXTREMUM_COLOR = "purple"


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
    """A ``pyvista.Plotter``, off-screen when :func:`setup_notebook` found no display."""
    import pyvista as pv

    return pv.Plotter(shape=shape, off_screen=pv.OFF_SCREEN, window_size=window_size)


def boundary_mesh(vol):
    """``pyvista.PolyData`` of the boundary faces of ``vol``."""
    import pyvista as pv

    f = vol.boundary_face_nodes
    return pv.PolyData(vol.points, np.hstack([np.full((len(f), 1), f.shape[1]), f]).ravel())


def boundary_surface(vol):
    """``pyvista.PolyData`` of the boundary faces with their group numbers as ``"group"``."""
    surf = boundary_mesh(vol)
    surf.cell_data["group"] = vol.boundary_groups
    return surf


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
