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

__all__ = ["plot_2d_graph", "plot_graph", "plot_graph_isosurface", "plot_seeds", "plot_loops", "plot_closed_and_open",
           "plot_graph_and_boundary", "plot_boundary_lists", "plot_numbering", "try_rows", "plot_tries"]


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


def plot_closed_and_open(vol, iso, *, plotter=None, title=None):
    """Fig. 6.1: the parts of one isosurface, closed (blue) or with a boundary on the volume's boundary (orange).

    The parts and whether each is closed come from :meth:`IsoSurface.components`.
    """
    p = plotter or _plotter()
    p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.12)
    comp = iso.components()
    poly = iso.to_pyvista()
    closed = comp["closed"][iso.triangle_components()]
    poly.cell_data["closed"] = closed.astype(np.int64)
    p.add_mesh(poly, scalars="closed", cmap=["darkorange", "royalblue"], clim=(0, 1), show_scalar_bar=False,
               smooth_shading=True)
    n_closed = int(comp["closed"].sum())
    p.add_text(title or f"C = {iso.value:.3g}: {n_closed} closed parts (blue), "
               f"{comp['closed'].size - n_closed} with boundary (orange)", font_size=10)
    p.view_isometric()
    return p


def plot_graph_and_boundary(vol, graph, *, plotter=None, title=None):
    """Fig. 6.3: the extrema graph's arcs and the boundary cells of the sorted lists (translucent, by S_min)."""
    p = plot_graph(vol, graph, plotter=plotter, title=title)
    cells = graph.blist_min
    if cells.size:
        sub = vol.to_pyvista().extract_cells(cells)
        sub.cell_data["S_min"] = graph.blist_min_values
        p.add_mesh(sub, scalars="S_min", cmap="jet", opacity=0.25, show_scalar_bar=False)
    p.add_text(f"\n\n{cells.size} boundary cells in the lists", font_size=9)
    return p


def plot_boundary_lists(graph, value, *, ax=None):
    """Fig. 6.3 (right) and 6.3.4 step 4: the two sorted boundary lists and the side scanned for ``value``.

    The list by S_min (ascending) holds the cells with S_min < C as a prefix,
    the list by S_max the cells with S_max >= C as a suffix; the query scans
    the shorter of the two (:meth:`ExtremaGraph.boundary_candidates`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 3.6))
    else:
        fig = ax.figure
    kb = graph.blist_min.size
    k_lo = int(np.searchsorted(graph.blist_min_values, value, side="left"))
    k_hi = kb - int(np.searchsorted(graph.blist_max_values, value, side="left"))
    cand, used_max = graph.boundary_candidates(value)
    x = np.arange(kb)
    ax.plot(x, graph.blist_min_values, color="navy", lw=1.2, label="S_min, list by S_min")
    ax.plot(x, graph.blist_max_values, color="crimson", lw=1.2, label="S_max, list by S_max")
    ax.axhline(value, color="k", ls="--", lw=0.8)
    ax.axvspan(0, k_lo, color="navy", alpha=0.12 if used_max else 0.3, lw=0)
    ax.axvspan(kb - k_hi, kb, color="crimson", alpha=0.3 if used_max else 0.12, lw=0)
    ax.set_xlabel("position in the list")
    ax.set_ylabel("S")
    ax.set_title(f"C = {value:.3g}: S_min < C in {k_lo}, S_max >= C in {k_hi} of {kb} boundary cells\n"
                 f"the list by {'S_max' if used_max else 'S_min'} is scanned ({cand.size} cells)", fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig


def plot_numbering(record, m, *, ax=None, title=None):
    """Fig. 6.6: the number C_i of every extremum before the first arc and after each, replayed from the record.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    comp = record.components(m)
    if ax is None:
        fig, ax = plt.subplots(figsize=(min(12, 2 + 0.35 * m), min(8, 1.5 + 0.3 * comp.shape[0])))
    else:
        fig = ax.figure
    ax.imshow(comp, cmap="tab20", aspect="auto", interpolation="nearest")
    if comp.size <= 900:
        for (r, c), v in np.ndenumerate(comp):
            ax.text(c, r, str(v), ha="center", va="center", fontsize=6)
    ax.set_xlabel("extremum i")
    ax.set_ylabel("arcs made")
    ax.set_title(title or "the number C_i of each extremum: both ends of an arc take the smaller one", fontsize=9)
    fig.tight_layout()
    return fig


def try_rows(graph, tries=None):
    """Fig. 6.10 as a trace: one row per try of the construction (start, goal, walk, reached, cells)."""
    from polygen.volume.extrema_graph import ARC_KINDS

    r = graph.record
    ks = range(r.n_tries) if tries is None else tries
    return [{"try": int(k), "start": int(r.start[k]), "goal": int(r.goal[k]), "walk": ARC_KINDS[r.kind[k]],
             "reached": bool(r.ok[k]), "cells": int(r.offsets[k + 1] - r.offsets[k])} for k in ks]


def plot_tries(panels, *, window_size=None):
    """Figs 6.7-6.9: tries of the construction from the record: the cells each walked (reached: green, failed: red).

    Parameters
    ----------
    panels : sequence of (vol, graph, tries, title)
        ``tries`` are indices into ``graph.record``; a straight try also
        draws its segment from start to goal.
    """
    import pyvista as pv

    from polygen.volume.extrema_graph import ARC_KINDS

    k = len(panels)
    p = _plotter(shape=(1, k), window_size=window_size or (460 * k, 440))
    for i, (vol, graph, tries, title) in enumerate(panels):
        p.subplot(0, i)
        r = graph.record
        grid = vol.to_pyvista()
        p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.12)
        for t in tries:
            cells = r.try_cells(t)
            color = "seagreen" if r.ok[t] else "crimson"
            if cells.size:
                p.add_mesh(grid.extract_cells(cells), color=color, opacity=0.55, show_edges=True)
            a, b = graph.extrema.nodes[r.start[t]], graph.extrema.nodes[r.goal[t]]
            if ARC_KINDS[r.kind[t]] == "straight" and r.goal[t] >= 0:
                p.add_mesh(pv.Line(vol.points[a], vol.points[b]), color=color, line_width=4)
        ext = pv.PolyData(vol.points[graph.extrema.nodes])
        p.add_mesh(ext, color=_EXTREMUM_COLOR, point_size=12, render_points_as_spheres=True)
        p.add_text(title, font_size=9)
        p.view_isometric()
    return p
