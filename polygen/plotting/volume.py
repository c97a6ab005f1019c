"""Figures of chapter 5: volumes, their boundary groups, marching cases and isosurfaces.

Notebooks ``05_volume_data`` and ``05_isosurfaces``. Nothing in polygen's
algorithms imports this module; pyvista and matplotlib are imported inside
the functions. 3D functions return a ``pyvista.Plotter``, 2D ones a
``matplotlib`` figure.
"""

from __future__ import annotations

import io

import numpy as np

from polygen.plotting._common import _plotter, boundary_surface
from polygen.volume._cells import HEX_UNIT_CORNERS, TET_UNIT_CORNERS

__all__ = [
    "plot_boundary_groups",
    "plot_cell_and_neighbours",
    "plot_volume_kinds",
    "plot_isosurfaces",
    "plot_marching_cases",
    "plot_isosurface_strip",
    "plot_isosurface_grid",
    "show_isosurface",
    "plot_propagation_order",
    "fifo_steps",
    "plot_two_approaches",
    "plot_span_space",
    "loglog_slope",
    "plot_loglog",
]

_TET_REF = TET_UNIT_CORNERS.astype(float)
_HEX_REF = HEX_UNIT_CORNERS.astype(float)


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


def plot_marching_cases(cell_type, cases, *, ncols=4, size=2.6):
    """Fig. 5.4: cells of the given cases with their triangles, read off the case tables.

    Parameters
    ----------
    cell_type : {'tetra', 'hexa'}
    cases : sequence of int
        Case indices of :func:`polygen.volume.marching.case_table` (4 node
        bits for a tetrahedron; 8 node bits + 6 face-centre bits for a
        hexahedron).

    Nodes above the isovalue are filled red, the others hollow; triangle
    corners sit at the edge midpoints (the crossing (5.2) for a value halfway
    between the nodes' values).
    """
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from polygen.volume import marching as m

    table, count = m.case_table(cell_type)
    ref, edges = (_TET_REF, m.TET_EDGES) if cell_type == "tetra" else (_HEX_REF, m.HEX_EDGES)
    n_nodes = ref.shape[0]
    mid = ref[edges].mean(axis=1)
    nrows = -(-len(cases) // ncols)
    fig = plt.figure(figsize=(size * ncols, size * nrows))
    for i, case in enumerate(cases):
        ax = fig.add_subplot(nrows, ncols, i + 1, projection="3d")
        for a, b in edges:
            ax.plot(*ref[[a, b]].T, color="0.4", lw=0.8)
        above = (int(case) >> np.arange(n_nodes)) & 1
        ax.scatter(*ref[above == 1].T, color="crimson", s=40, depthshade=False)
        ax.scatter(*ref[above == 0].T, facecolors="white", edgecolors="k", s=40, depthshade=False)
        k = int(count[case])
        tris = mid[table[case, : 3 * k].reshape(k, 3).astype(np.int64)]
        if k:
            ax.add_collection3d(Poly3DCollection(tris, facecolor="gold", edgecolor="darkorange", alpha=0.8))
        up = [f for f in range(6) if (int(case) >> (8 + f)) & 1]
        faces = f", centre of face {up} above" if up else ""
        ax.set_title(f"{cell_type} nodes {int(case) & 0xFF}{faces}: {k} triangle{'s' * (k != 1)}", fontsize=9)
        ax.set_axis_off()
        ax.view_init(elev=20, azim=-60)
    fig.tight_layout()
    return fig


def plot_isosurface_strip(vol, surfaces, *, window_size=None):
    """Fig. 5.5: one isosurface per panel, left to right, inside the volume's outline."""
    k = max(len(surfaces), 1)
    p = _plotter(shape=(1, k), window_size=window_size or (300 * k, 320))
    outline = boundary_surface(vol)
    lo = min(s.value for s in surfaces)
    hi = max(s.value for s in surfaces)
    for i, iso in enumerate(surfaces):
        p.subplot(0, i)
        p.add_mesh(outline, color="lightgray", opacity=0.1)
        if not iso.is_empty:
            poly = iso.to_pyvista()
            poly.point_data["isovalue"] = np.full(poly.n_points, iso.value)
            p.add_mesh(poly, scalars="isovalue", clim=(lo, hi), cmap="viridis", smooth_shading=True,
                       show_scalar_bar=False)
        p.add_text(f"C = {iso.value:.3g}\n{iso.n_triangles} triangles", font_size=8)
        p.view_isometric()
    p.link_views()
    return p


def plot_isosurface_grid(vol, surfaces, *, panels=6, ncols=3, panel_size=(420, 360), cmap="viridis"):
    """Small multiples: a few of ``surfaces``, evenly through the list, one opaque surface per panel.

    Each panel shows the part's boundary (translucent, for context), one
    surface coloured by its value on a colour map shared by all panels, and
    a label with the value and the triangle count. Stacking many translucent
    surfaces in one view hides them all; one per panel does not.

    Parameters
    ----------
    vol : UnstructuredVolume
    surfaces : sequence of IsoSurface
        In increasing value, typically (the panels keep their order).
    panels : int, keyword-only
        At most this many panels (all surfaces when fewer).
    ncols : int, keyword-only
    panel_size : (int, int), keyword-only
        Pixels per panel.

    Returns
    -------
    pyvista.Plotter
    """
    import matplotlib

    surfaces = list(surfaces)
    k = min(panels, len(surfaces))
    pick = np.unique(np.round(np.linspace(0, len(surfaces) - 1, k)).astype(int)) if k else np.array([], int)
    ncols = max(1, min(ncols, len(pick)))
    nrows = max(1, -(-len(pick) // ncols))
    p = _plotter(shape=(nrows, ncols), window_size=(panel_size[0] * ncols, panel_size[1] * nrows))
    outline = boundary_surface(vol)
    values = [s.value for s in surfaces]
    lo, hi = (min(values), max(values)) if values else (0.0, 1.0)
    colours = matplotlib.colormaps[cmap]
    for j, i in enumerate(pick):
        iso = surfaces[i]
        p.subplot(j // ncols, j % ncols)
        p.add_mesh(outline, color="lightgray", opacity=0.15)
        if not iso.is_empty:
            t = 0.5 if hi == lo else (iso.value - lo) / (hi - lo)
            p.add_mesh(iso.to_pyvista(), color=colours(0.1 + 0.8 * t)[:3], smooth_shading=True)
        p.add_text(f"#{i + 1} of {len(surfaces)}: C = {iso.value:.4g}\n{iso.n_triangles:,} triangles",
                   font_size=9)
        p.view_isometric()
    if len(pick):
        p.link_views()
    return p


def show_isosurface(vol, value, *, field=None, method="scan"):
    """Extract ``S = value`` and show it in the volume's outline (the slider of Fig. 5.5).

    Meant for ``ipywidgets.interact(show_isosurface, vol=fixed(vol), value=FloatSlider(...))``.
    The picture is drawn on the widgets' render thread (a slider's callback may run on a kernel
    subshell's thread) and shown as a PNG from the caller's thread, where the widget's
    output is captured.
    """
    from IPython.display import Image, display

    from polygen.plotting import _render_thread
    from polygen.volume.isosurface import extract

    iso = extract(vol, value, field=field, method=method)

    def draw():
        from PIL import Image as PILImage

        p = plot_isosurfaces(vol, [iso], [value])
        try:
            p.add_text(f"C = {value:.4g}: {iso.n_triangles} triangles, {iso.cells_intersected} cells", font_size=9)
            buf = io.BytesIO()
            PILImage.fromarray(np.asarray(p.screenshot(return_img=True))).save(buf, format="PNG")
            return buf.getvalue()
        finally:
            p.close()

    display(Image(data=_render_thread.call(draw)))
    return iso


def fifo_steps(order, triangle_cells, n_cells):
    """(T,) int64: the FIFO position of each triangle's cell in ``order`` (-1 if not in it)."""
    rank = np.full(n_cells, -1, np.int64)
    rank[np.asarray(order, np.int64)] = np.arange(len(order))
    return rank[np.asarray(triangle_cells, np.int64)]


def plot_propagation_order(vol, iso, order, *, seeds=(), cmap="plasma"):
    """Fig. 5.7: the isosurface coloured by the FIFO step at which its cell was registered.

    Parameters
    ----------
    iso : IsoSurface
        A propagated isosurface.
    order : (K,) int64
        The cells in FIFO order (``Propagator.last_order``).
    seeds : sequence of int
        Seed cells, drawn in red.
    """
    import pyvista as pv

    p = _plotter()
    p.add_mesh(boundary_surface(vol), color="lightgray", opacity=0.1)
    poly = iso.to_pyvista()
    poly.cell_data["FIFO step"] = fifo_steps(order, iso.triangle_cells, vol.n_cells)
    p.add_mesh(poly, scalars="FIFO step", cmap=cmap, show_edges=False)
    seeds = np.asarray(seeds, np.int64)
    if seeds.size:
        centres = vol.points[vol.cells[seeds]].mean(axis=1)
        p.add_mesh(pv.PolyData(centres), color="red", point_size=14, render_points_as_spheres=True)
    p.add_text(f"propagation from {seeds.size} seed(s): {len(order)} cells in FIFO order", font_size=9)
    p.view_isometric()
    return p


def loglog_slope(n, y, *, n_from=0):
    """Least-squares slope of ``log y`` on ``log n`` over ``n >= n_from`` and ``y > 0`` (None if < 2 points)."""
    n = np.asarray(n, float)
    y = np.asarray(y, float)
    keep = (n >= n_from) & (y > 0)
    if keep.sum() < 2:
        return None
    return float(np.polyfit(np.log(n[keep]), np.log(y[keep]), 1)[0])


def plot_loglog(rows, ys, *, x="n", group="method", n_from=0, titles=None):
    """Log-log panels of ``rows[y]`` against ``rows[x]``, one line per ``group``, slopes in the legend.

    Returns ``(figure, slopes)`` with ``slopes[y][group]`` the fitted slope.
    """
    import matplotlib.pyplot as plt

    ncols = min(len(ys), 2)
    nrows = -(-len(ys) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6 * ncols, 4 * nrows), squeeze=False)
    groups = list(dict.fromkeys(r[group] for r in rows))
    slopes = {}
    for ax, y in zip(axes.ravel(), ys):
        slopes[y] = {}
        for g in groups:
            rs = [r for r in rows if r[group] == g]
            xs, vs = [r[x] for r in rs], [r[y] for r in rs]
            b = loglog_slope(xs, vs, n_from=n_from)
            slopes[y][g] = b
            pos = [(a, v) for a, v in zip(xs, vs) if v > 0]
            if pos:
                ax.loglog(*zip(*pos), "o-", label=f"{g} (slope {b:.2f})" if b is not None else g)
        ax.set_xlabel(x)
        ax.set_title((titles or {}).get(y, y))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig, slopes


def plot_two_approaches(vol, surfaces, *, field=None, resolution=64, window_size=(1200, 440)):
    """Fig. 5.3: the two ways to show a volume -- polygons fitted to isosurfaces, and direct volume rendering.

    Left, the isosurfaces (triangles, drawn by ordinary surface rendering);
    right, the same field sampled onto a regular grid inside the volume and
    ray-cast by VTK (no polygons; points outside the volume are transparent).

    Parameters
    ----------
    vol : UnstructuredVolume
    surfaces : sequence of IsoSurface
    field : str, optional
    resolution : int
        Samples along the longest side of the bounding box for the ray-cast panel.
    """
    import pyvista as pv

    name = field or next(iter(vol.fields))
    grid = vol.to_pyvista()
    lo, hi = vol.points.min(axis=0), vol.points.max(axis=0)
    h = float((hi - lo).max()) / (resolution - 1)
    dims = np.maximum(2, np.ceil((hi - lo) / h).astype(int) + 1)
    img = pv.ImageData(dimensions=tuple(int(d) for d in dims), spacing=(h, h, h), origin=tuple(lo))
    sampled = img.sample(grid)
    s = np.asarray(sampled.point_data[name], float)
    smin, smax = float(vol.scalars(name).min()), float(vol.scalars(name).max())
    s[np.asarray(sampled.point_data["vtkValidPointMask"]) == 0] = smin  # outside: fully transparent
    sampled.point_data["S"] = s
    p = _plotter(shape=(1, 2), window_size=window_size)
    p.subplot(0, 0)
    p.add_mesh(boundary_surface(vol), color="lightgray", opacity=0.1)
    for iso in surfaces:
        if not iso.is_empty:
            poly = iso.to_pyvista()
            poly.point_data["S"] = np.full(poly.n_points, iso.value)
            p.add_mesh(poly, scalars="S", clim=(smin, smax), cmap="jet", smooth_shading=True, show_scalar_bar=False)
    n_tri = sum(iso.n_triangles for iso in surfaces)
    p.add_text(f"surface fitting: {len(surfaces)} isosurfaces, {n_tri} triangles", font_size=9)
    p.view_isometric()
    p.subplot(0, 1)
    p.add_volume(sampled, scalars="S", clim=(smin, smax), cmap="jet", opacity="sigmoid", show_scalar_bar=False)
    p.add_text(f"direct volume rendering: ray casting over {sampled.n_points} samples", font_size=9)
    p.view_isometric()
    p.link_views()
    return p


def _kd_lines(pts, lo, hi, depth, box, out):
    """Split lines of the pointerless k-d tree of :class:`~polygen.volume.seeds.span_space.SpanSpace`."""
    if hi - lo < 1 or depth < 0:
        return
    mid = (lo + hi) // 2
    dim = box[4]
    key = pts[mid, dim]
    x0, x1, y0, y1 = box[:4]
    if dim == 0:
        out.append(((key, key), (y0, y1)))
        _kd_lines(pts, lo, mid, depth - 1, (x0, key, y0, y1, 1), out)
        _kd_lines(pts, mid + 1, hi, depth - 1, (key, x1, y0, y1, 1), out)
    else:
        out.append(((x0, x1), (key, key)))
        _kd_lines(pts, lo, mid, depth - 1, (x0, x1, y0, key, 0), out)
        _kd_lines(pts, mid + 1, hi, depth - 1, (x0, x1, key, y1, 0), out)


def plot_span_space(cmin, cmax, value, span_space, lattice, *, kd_depth=5, max_points=6000, seed=0):
    """Fig. 5.6: the cells as points (S_min, S_max); the active ones; the k-d tree; the ISSUE lattice.

    Parameters
    ----------
    cmin, cmax : (M,) float64
        Each cell's smallest and largest node value.
    value : float
        The isovalue C: the active cells are the quadrant S_min <= C <= S_max.
    span_space : polygen.volume.seeds.span_space.SpanSpace
        Built over ``cmin, cmax``; its split keys are drawn to ``kd_depth`` levels (panel b).
    lattice : polygen.volume.seeds.issue_lattice.IssueLattice
        Built over ``cmin, cmax``; its class boundaries are drawn (panel c).
    max_points : int
        Points drawn (a seeded random subset when there are more cells).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    cmin, cmax = np.asarray(cmin, float), np.asarray(cmax, float)
    pick = np.arange(cmin.size)
    if cmin.size > max_points:
        pick = np.sort(np.random.default_rng(seed).choice(cmin.size, max_points, replace=False))
    active = (cmin[pick] <= value) & (value <= cmax[pick])
    lo, hi = float(cmin.min()), float(cmax.max())
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.8), sharex=True, sharey=True)
    for ax in axes:
        ax.plot(cmin[pick][~active], cmax[pick][~active], ".", ms=1.5, color="0.6")
        ax.plot(cmin[pick][active], cmax[pick][active], ".", ms=2, color="crimson")
        ax.plot([lo, value, value], [value, value, hi], "k--", lw=1)
        ax.set_xlabel("S_min")
        ax.set_aspect("equal")
    axes[0].set_ylabel("S_max")
    n_act = int(np.count_nonzero((cmin <= value) & (value <= cmax)))
    axes[0].set_title(f"(a) span space: {n_act} of {cmin.size} cells active at C = {value:.3g}", fontsize=9)
    segs = []
    _kd_lines(span_space.pts, 0, span_space.pts.shape[0], kd_depth, (lo, hi, lo, hi, 0), segs)
    for xs, ys in segs:
        axes[1].plot(xs, ys, color="steelblue", lw=0.8)
    axes[1].set_title(f"(b) k-d tree: the first {kd_depth + 1} levels of splits", fontsize=9)
    for x in lattice.msplit:
        axes[2].axvline(x, color="seagreen", lw=0.6)
    for y in lattice.xsplit:
        axes[2].axhline(y, color="seagreen", lw=0.6)
    axes[2].set_title(f"(c) ISSUE lattice: {lattice.L} x {lattice.L} classes", fontsize=9)
    axes[0].set_xlim(lo, hi)
    axes[0].set_ylim(lo, hi)
    fig.tight_layout()
    return fig


def plot_partitions(vol, iso, cell_partition, *, cmap="tab10"):
    """A stitched isosurface coloured by the partition that made each triangle, over the volume's outline.

    Parameters
    ----------
    iso : IsoSurface
        A surface whose ``triangle_cells`` are global cell ids.
    cell_partition : (n_cells,) int
        The partition of each cell (``PartitionedVolume.partition_of_cells()``).
    """
    p = _plotter()
    p.add_mesh(boundary_surface(vol), color="lightgray", opacity=0.1)
    poly = iso.to_pyvista()
    part = np.asarray(cell_partition)[iso.triangle_cells]
    poly.cell_data["partition"] = part
    k = int(np.max(cell_partition)) + 1
    p.add_mesh(poly, scalars="partition", cmap=cmap, n_colors=k, clim=(-0.5, k - 0.5), show_edges=False)
    p.add_text(f"C = {iso.value:.4g}: {iso.n_triangles} triangles from {k} partitions", font_size=9)
    p.view_isometric()
    return p
