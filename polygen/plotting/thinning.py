"""Figures of chapter 7 (volume thinning): matplotlib for 2D and timings, pyvista in 3D.

Nothing in polygen's algorithms imports this module; pyvista and matplotlib
are imported inside the functions. 3D functions return a
``pyvista.Plotter`` (``.show()`` in a notebook); call
:func:`polygen.plotting.setup_notebook` first on a headless machine.
"""

from __future__ import annotations

import numpy as np

from polygen.plotting._common import EXTREMUM_COLOR as _EXTREMUM_COLOR
from polygen.plotting._common import _plotter, boundary_mesh

__all__ = [
    "plot_pixel_rule",
    "plot_image_thinning",
    "plot_skeleton",
    "plot_thinning_steps",
    "plot_skeleton_isosurfaces",
    "plot_fig_7_1",
    "plot_time_per_cell",
    "plot_removal_tests",
    "plot_parts_and_arcs",
]


# ------------------------------------------------------------------ 2D (Fig. 7.2)
def plot_pixel_rule(cases, removable, *, titles=None, size=1.7):
    """Fig. 7.2 (b)-(e): 3x3 neighbourhoods; the centre p is removable or not.

    Parameters
    ----------
    cases : sequence of (3, 3) bool
    removable : sequence of bool
        From :func:`polygen.volume.thinning.pixel_removable`.
    """
    import matplotlib.pyplot as plt

    n = len(cases)
    fig, axes = plt.subplots(1, n, figsize=(size * n, size * 1.25))
    axes = np.atleast_1d(axes)
    for i, (ax, patch, ok) in enumerate(zip(axes, cases, removable)):
        img = np.asarray(patch, float) * 0.55
        img[1, 1] = 1.0
        ax.imshow(img, cmap="Greys", vmin=0, vmax=1)
        ax.text(1, 1, "p", ha="center", va="center", color="w", fontsize=12, weight="bold")
        ax.set_xticks(np.arange(-0.5, 3), minor=True)
        ax.set_yticks(np.arange(-0.5, 3), minor=True)
        ax.grid(which="minor", color="0.5", lw=0.8)
        ax.tick_params(which="both", length=0, labelbottom=False, labelleft=False)
        label = titles[i] if titles else ""
        ax.set_title(f"{label}\n{'removed' if ok else 'kept'}", fontsize=9, color="seagreen" if ok else "crimson")
    return fig


def plot_image_thinning(image, skeleton, *, ax=None, title=None):
    """Fig. 7.2 (f)(g): an image (grey) and its skeleton (black)."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 4.7))
    else:
        fig = ax.figure
    img = np.where(skeleton, 1.0, np.where(image, 0.3, 0.0))
    ax.imshow(img, cmap="Greys", vmin=0, vmax=1, interpolation="nearest")
    ax.set_axis_off()
    ax.set_title(title or f"{int(image.sum())} black pixels, skeleton {int(skeleton.sum())}")
    return fig


# ------------------------------------------------------------------ 3D skeletons
def plot_skeleton(vol, skeleton, *, color="class", plotter=None, title=None, boundary_opacity=0.12):
    """Figs 7.14 / 7.15: the skeleton's cells inside the translucent boundary.

    Parameters
    ----------
    color : {"class", "value"}
        Number of non-removed face neighbours (Fig. 7.14) or the mean node
        value of each cell (Fig. 7.15).
    """
    import pyvista as pv

    if color not in ("class", "value"):
        raise ValueError(f"color must be 'class' or 'value'; got {color!r}")
    p = plotter or _plotter()
    p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=boundary_opacity)
    cells = vol.to_pyvista().extract_cells(skeleton.cells)
    if color == "class":
        cells.cell_data["neighbours"] = skeleton.neighbour_counts
        p.add_mesh(cells, scalars="neighbours", cmap="viridis", show_edges=True, clim=(0, vol.cells.shape[1] // 2 + 2),
                   scalar_bar_args={"title": "non-removed neighbours"})
    else:
        cells.cell_data["value"] = skeleton.s[vol.cells[skeleton.cells]].mean(axis=1)
        p.add_mesh(cells, scalars="value", cmap="jet", clim=(float(skeleton.s.min()), float(skeleton.s.max())),
                   show_edges=True)
    ext = pv.PolyData(vol.points[skeleton.extrema.nodes])
    p.add_mesh(ext, color=_EXTREMUM_COLOR, point_size=9, render_points_as_spheres=True)
    st = skeleton.stats
    p.add_text(title or f"skeleton: {skeleton.n_cells} of {vol.n_cells} cells, {st['extrema']} extrema",
               font_size=10)
    p.view_isometric()
    return p


def plot_thinning_steps(vol, record, steps, *, skeleton=None, window_size=(1400, 420), view="isometric"):
    """Figs 7.18-7.21: the cells left after ``steps`` removals, one panel each.

    ``view`` is ``"isometric"`` or one of pyvista's ``"xy"``, ``"xz"``, ``"yz"``.
    """
    steps = [int(k) for k in steps]
    p = _plotter(shape=(1, len(steps)), window_size=window_size)
    grid = vol.to_pyvista()
    s = vol.scalars() if skeleton is None else skeleton.s
    for i, k in enumerate(steps):
        p.subplot(0, i)
        keep = np.flatnonzero(record.remaining(k))
        p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.08)
        if keep.size:
            cells = grid.extract_cells(keep)
            cells.cell_data["value"] = s[vol.cells[keep]].mean(axis=1)
            p.add_mesh(cells, scalars="value", cmap="jet", clim=(float(s.min()), float(s.max())),
                       show_scalar_bar=False, show_edges=keep.size < 3000)
        p.add_text(f"after {k} removals: {keep.size} cells", font_size=9)
        getattr(p, f"view_{view}")()
    p.link_views()
    return p


def plot_skeleton_isosurfaces(vol, skeleton, isos, *, plotter=None, title=None):
    """Figs 7.16 / 7.17: isosurfaces made from the skeleton, coloured by their value."""
    import matplotlib

    p = plot_skeleton(vol, skeleton, color="value", plotter=plotter, title=title)
    smin, smax = float(skeleton.s.min()), float(skeleton.s.max())
    cmap = matplotlib.colormaps["jet"]
    for iso in isos:
        if not iso.is_empty:
            p.add_mesh(iso.to_pyvista(), color=cmap((iso.value - smin) / max(smax - smin, 1e-300))[:3],
                       opacity=0.55, smooth_shading=True)
    return p


def plot_fig_7_1(vol, graph, skeleton, iso_full, iso_from_arcs, *, window_size=(1300, 480)):
    """Fig. 7.1 made real: left, the extrema graph's arcs and the surface they reach (parts missed in red);
    right, the skeleton and the whole surface."""
    import pyvista as pv

    from polygen.plotting.extrema import _arc_lines

    p = _plotter(shape=(1, 2), window_size=window_size)
    smin, smax = float(skeleton.s.min()), float(skeleton.s.max())
    p.subplot(0, 0)
    p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.15)
    lines = _arc_lines(vol, graph)
    if lines.n_points:
        p.add_mesh(lines, scalars="value", cmap="jet", clim=(smin, smax), line_width=5, show_scalar_bar=False)
    reached = set(map(tuple, np.sort(iso_from_arcs.vertex_keys[iso_from_arcs.triangles], axis=1).tolist())) \
        if not iso_from_arcs.is_empty else set()
    full = np.sort(iso_full.vertex_keys[iso_full.triangles], axis=1)
    missed = np.array([tuple(t) not in reached for t in full.tolist()], bool)
    surf = iso_full.to_pyvista()
    surf.cell_data["missed"] = missed.astype(float)
    p.add_mesh(surf, scalars="missed", cmap=["wheat", "red"], clim=(0, 1), show_scalar_bar=False, opacity=0.9)
    p.add_mesh(pv.PolyData(vol.points[graph.extrema.nodes]), color=_EXTREMUM_COLOR, point_size=10,
               render_points_as_spheres=True)
    p.add_text(f"extrema graph, arcs only: {int(missed.sum())} of {missed.size} triangles missed (red)",
               font_size=9)
    p.view_xy()
    p.subplot(0, 1)
    plot_skeleton(vol, skeleton, color="value", plotter=p,
                  title=f"skeleton ({skeleton.n_cells} cells): the whole surface")
    p.add_mesh(surf, color="wheat", opacity=0.9)
    p.view_xy()
    p.link_views()
    return p


# ------------------------------------------------------------------ O(n)
def plot_time_per_cell(rows, *, ax=None, band=0.2):
    """Thinning's preprocessing time per cell against the number of cells (7.6: O(n)).

    Parameters
    ----------
    rows : list of dict
        With ``cells``, ``ns_per_cell``, ``ns_per_cell_with_topology`` and ``family``.
    band : float
        Draws ``+-band`` around the median of the first family.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 4))
    else:
        fig = ax.figure
    families = list(dict.fromkeys(r["family"] for r in rows))
    markers = ["o", "s", "^", "D"]
    for i, fam in enumerate(families):
        rr = sorted((r for r in rows if r["family"] == fam), key=lambda r: r["cells"])
        n = np.array([r["cells"] for r in rr])
        ax.plot(n, [r["ns_per_cell"] for r in rr], marker=markers[i % 4], ls="-" if i == 0 else "none",
                label=f"{fam}: thinning")
        ax.plot(n, [r["ns_per_cell_with_topology"] for r in rr], marker=markers[i % 4], ls=":" if i == 0 else "none",
                mfc="none", label=f"{fam}: + topology tables")
    first = [r["ns_per_cell"] for r in rows if r["family"] == families[0]]
    med = float(np.median(first))
    ax.axhspan(med * (1 - band), med * (1 + band), color="0.9", zorder=0, label=f"median +-{int(100 * band)} %")
    ax.set_xscale("log")
    ax.set_xlabel("cells n")
    ax.set_ylabel("preprocessing time per cell (ns)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    ax.set_title("volume thinning is O(n): time per cell against n")
    return fig


def plot_removal_tests(panels, *, context=2.5, window_size=None):
    """Figs 7.4, 7.6, 7.12, 7.13: cells taken from a FIFO and what the removal tests looked at.

    Parameters
    ----------
    panels : sequence of (vol, test, title)
        ``test`` a :class:`~polygen.volume.thinning.RemovalTest`. Drawn: E (red when
        removed, orange when kept), its non-removed neighbours (gold), the
        other non-removed cells around each triple-shared edge (cyan) and the
        edge (blue), the quadruple-shared nodes (purple on the boundary of the
        non-removed cells, n_B != 0; green inside), and the non-removed cells
        within ``context`` cell sizes of E (grey).
    """
    import pyvista as pv

    k = len(panels)
    p = _plotter(shape=(1, k), window_size=window_size or (420 * k, 420))
    for i, (vol, test, title) in enumerate(panels):
        p.subplot(0, i)
        grid = vol.to_pyvista()
        centres = vol.points[vol.cells].mean(axis=1)
        c = test.cell
        size = float(np.linalg.norm(vol.points[vol.cells[c]] - centres[c], axis=1).max())
        near = np.flatnonzero(test.remaining & (np.linalg.norm(centres - centres[c], axis=1) < context * 2 * size))
        shown = {c, *test.neighbours.tolist()}
        ring = set()
        for e in (test.shared_edges if not test.quad_nodes.size else []):  # the walks of C2 (and hexahedral C3)
            ring |= set(test.edge_ring(vol, e).tolist()) - shown
            p.add_mesh(pv.Line(vol.points[e[0]], vol.points[e[1]]), color="blue", line_width=7)
        rest = np.setdiff1d(near, list(shown | ring))
        if rest.size:
            p.add_mesh(grid.extract_cells(rest), color="lightgray", opacity=0.15, show_edges=True)
        if ring:
            p.add_mesh(grid.extract_cells(sorted(ring)), color="cyan", opacity=0.35, show_edges=True)
        if test.neighbours.size:
            p.add_mesh(grid.extract_cells(test.neighbours), color="gold", opacity=0.45, show_edges=True)
        p.add_mesh(grid.extract_cells([c]), color="red" if test.removed else "darkorange", opacity=0.9,
                   show_edges=True)
        q = test.quad_nodes
        if q.size:
            col = np.where(test.on_boundary[q], 1, 0)
            pts = pv.PolyData(vol.points[q])
            pts.point_data["n_B != 0"] = col
            p.add_mesh(pts, scalars="n_B != 0", cmap=["green", _EXTREMUM_COLOR], clim=(0, 1), point_size=16,
                       render_points_as_spheres=True, show_scalar_bar=False)
        p.add_text(title, font_size=9)
        p.camera_position = "iso"
        p.reset_camera(bounds=grid.extract_cells([c, *test.neighbours.tolist()]).bounds)
    return p


def plot_parts_and_arcs(panels, *, window_size=None):
    """Figs 7.10 / 7.11: the parts of an isosurface crossed by an arc of the extrema graph (green) or not (red).

    Parameters
    ----------
    panels : sequence of (vol, graph, iso, title)
        The parts are :meth:`IsoSurface.components`; a part is crossed when one
        of its cells is a seed the graph found on its arcs (``graph.seeds``).
    """
    k = len(panels)
    p = _plotter(shape=(1, k), window_size=window_size or (520 * k, 440))
    for i, (vol, graph, iso, title) in enumerate(panels):
        p.subplot(0, i)
        from polygen.plotting.extrema import _arc_lines

        p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.12)
        seeds = graph.seeds(iso.value)
        comp = iso.triangle_components()
        crossed = np.zeros(comp.max() + 1 if comp.size else 0, bool)
        on_arcs = np.isin(iso.triangle_cells, seeds.cells[:seeds.n_from_arcs])
        crossed[comp[on_arcs]] = True
        if not iso.is_empty:
            poly = iso.to_pyvista()
            poly.cell_data["crossed"] = crossed[comp].astype(np.int64)
            p.add_mesh(poly, scalars="crossed", cmap=["crimson", "seagreen"], clim=(0, 1), show_scalar_bar=False,
                       smooth_shading=True, opacity=0.8)
        lines = _arc_lines(vol, graph)
        if lines.n_points:
            p.add_mesh(lines, color="k", line_width=4)
        p.add_text(title, font_size=9)
        p.view_isometric()
    return p
