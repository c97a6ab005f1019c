"""Figures of chapter 6 (the extrema graph): matplotlib for the 2D illustration, pyvista in 3D.

Nothing in polygen's algorithms imports this module; pyvista and matplotlib
are imported inside the functions. 3D functions return a
``pyvista.Plotter`` (``.show()`` in a notebook); call
:func:`polygen.plotting.setup_notebook` first on a headless machine.
"""

from __future__ import annotations

import numpy as np

from polygen.plotting._common import EXTREMUM_COLOR as _EXTREMUM_COLOR
from polygen.plotting._common import _plotter, boundary_mesh

__all__ = ["plot_2d_graph", "plot_graph", "plot_graph_isosurface", "plot_seeds"]


def plot_2d_graph(points, triangles, values, extrema, arcs, *, highlight=(), n_levels=14, ax=None, title=None):
    """Fig. 6.2: contours of a field on a triangulation, its extrema, and the graph joining them.

    Parameters
    ----------
    points : (N, 2) float64
    triangles : (T, 3) int64
    values : (N,) float64
    extrema : Extrema
        From :func:`polygen.volume.extrema_graph.extrema_graph_2d`.
    arcs : (A, 2) int64
        Node ids of the joined extrema.
    highlight : sequence of float
        Contour values drawn thick (the closed curves of Fig. 6.2).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt
    import matplotlib.tri as mtri

    if ax is None:
        fig, ax = plt.subplots(figsize=(6, 6))
    else:
        fig = ax.figure
    tri = mtri.Triangulation(points[:, 0], points[:, 1], triangles)
    ax.triplot(tri, color="0.88", lw=0.4)
    ax.tricontour(tri, values, levels=n_levels, cmap="coolwarm", linewidths=0.8)
    if len(highlight):
        ax.tricontour(tri, values, levels=sorted(highlight), colors="k", linewidths=2.2)
    for a, b in arcs:
        ax.plot(points[[a, b], 0], points[[a, b], 1], color="seagreen", lw=1.8)
    mx, mn = extrema.maxima, extrema.minima
    ax.plot(points[mx, 0], points[mx, 1], "^", color="crimson", ms=8, label=f"maxima ({len(mx)})")
    ax.plot(points[mn, 0], points[mn, 1], "v", color="navy", ms=8, label=f"minima ({len(mn)})")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title or "contours, extrema and the graph joining them")
    return fig


def _arc_lines(vol, graph):
    """pyvista PolyData of the arcs: start point, centroids of the arc cells, goal point."""
    import pyvista as pv

    pts = []
    lines = []
    vals = []
    centroids = vol.points[vol.cells].mean(axis=1)
    s = graph.s
    k = 0
    for a in range(graph.n_arcs):
        x1, x2 = graph.arc_ends[a]
        p = np.vstack([vol.points[x1], centroids[graph.arc(a)], vol.points[x2]])
        v = np.concatenate([[s[x1]], s[vol.cells[graph.arc(a)]].mean(axis=1), [s[x2]]])
        pts.append(p)
        vals.append(v)
        lines.append(np.concatenate([[len(p)], np.arange(k, k + len(p))]))
        k += len(p)
    if not pts:
        return pv.PolyData()
    poly = pv.PolyData(np.vstack(pts), lines=np.concatenate(lines))
    poly.point_data["value"] = np.concatenate(vals)
    return poly


def plot_graph(vol, graph, *, plotter=None, title=None, show_cells=False):
    """Figs 6.12/6.13: the volume's boundary, the extrema (purple) and the arcs coloured by value.

    ``show_cells`` also draws the cells registered on the arcs.
    """
    import pyvista as pv

    p = plotter or _plotter()
    p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.15)
    lines = _arc_lines(vol, graph)
    smin, smax = float(graph.s.min()), float(graph.s.max())
    if lines.n_points:
        p.add_mesh(lines, scalars="value", cmap="jet", clim=(smin, smax), line_width=4, show_scalar_bar=True)
    if show_cells and graph.n_arcs:
        cells = vol.to_pyvista().extract_cells(graph.graph_cells())
        p.add_mesh(cells, color="gold", opacity=0.5, show_edges=True)
    ext = pv.PolyData(vol.points[graph.extrema.nodes])
    p.add_mesh(ext, color=_EXTREMUM_COLOR, point_size=12, render_points_as_spheres=True)
    st = graph.stats
    p.add_text(title or f"{st['extrema']} extrema, {graph.n_arcs} arcs, {st['graph_cells']} graph cells",
               font_size=10)
    p.view_isometric()
    return p


def plot_graph_isosurface(vol, graph, isos, *, plotter=None, title=None):
    """Figs 6.14/6.15: isosurfaces (coloured by their value) over the extrema graph."""
    import matplotlib

    p = plot_graph(vol, graph, plotter=plotter, title=title)
    smin, smax = float(graph.s.min()), float(graph.s.max())
    cmap = matplotlib.colormaps["jet"]
    for iso in isos:
        if not iso.is_empty:
            color = cmap((iso.value - smin) / max(smax - smin, 1e-300))[:3]
            p.add_mesh(iso.to_pyvista(), color=color, opacity=0.6, smooth_shading=True)
    return p


def plot_seeds(vol, graph, iso, seeds, *, plotter=None, title=None):
    """Fig. 6.11: an isosurface with the seed cells found on arcs (red) and on the boundary (blue)."""
    p = plot_graph(vol, graph, plotter=plotter, title=title)
    grid = vol.to_pyvista()
    if not iso.is_empty:
        p.add_mesh(iso.to_pyvista(), color="wheat", opacity=0.45)
    on_arcs = seeds.cells[:seeds.n_from_arcs]
    on_boundary = seeds.cells[seeds.n_from_arcs:]
    if on_arcs.size:
        p.add_mesh(grid.extract_cells(on_arcs), color="red", show_edges=True)
    if on_boundary.size:
        p.add_mesh(grid.extract_cells(on_boundary), color="royalblue", show_edges=True)
    p.add_text(f"\n\nseeds: {on_arcs.size} on arcs (red), {on_boundary.size} on the boundary (blue)",
               font_size=9)
    return p


def plot_loops(vol, loops, *, plotter=None, title=None):
    """The boundary loops that can stand for the boundary cell lists (ours, notebook 06): 2g per surface of genus g."""
    import matplotlib
    import pyvista as pv

    p = plotter or _plotter()
    p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.2)
    cmap = matplotlib.colormaps["tab10"]
    for i in range(loops.n_loops):
        nodes = loops.loop(i)
        line = pv.PolyData(vol.points[nodes], lines=np.concatenate([[nodes.size + 1], np.arange(nodes.size), [0]]))
        p.add_mesh(line, color=cmap(i % 10)[:3], line_width=5)
    p.add_text(title or f"{loops.n_loops} boundary loops, {loops.unique_cells().size} cells "
               f"(of {vol.boundary_cells.size} boundary cells)", font_size=10)
    p.view_isometric()
    return p
