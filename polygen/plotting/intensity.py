"""Figures of chapter 4 (the intensity-based bubble mesh), with matplotlib.

Nothing in polygen's algorithms imports this module; matplotlib is
imported inside the functions.  Every function returns the matplotlib
Figure it drew on.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_size_function", "plot_size_grid", "plot_plate_surface", "plot_error_curves",
           "plot_plate_convergence", "plot_polygon_remesh", "remesh_sliders"]


def _axes(ax, figsize=(5, 4), **kw):
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=figsize)
        ax = fig.add_subplot(1, 1, 1, **kw)
        return fig, ax
    return ax.figure, ax


def plot_size_function(variation, sizes, *, ax=None, title="size function f(D) (Fig. 4.1)"):
    """The nodes' (D, f(D)) on the line of (4.4), with D's histogram underneath."""
    fig, ax = _axes(ax)
    d = np.asarray(variation)
    order = np.argsort(d)
    ax.plot(d[order], np.asarray(sizes)[order], color="tab:blue", lw=2, label="f(D)")
    ax.set_xlabel("intensity variation D (4.1)")
    ax.set_ylabel("element size f(D)")
    twin = ax.twinx()
    twin.hist(d, bins=40, color="0.7", alpha=0.6)
    twin.set_ylabel("nodes")
    ax.set_zorder(twin.get_zorder() + 1)
    ax.patch.set_visible(False)
    ax.set_title(title, fontsize=10)
    return fig


def plot_size_grid(grid, polygon=None, *, nodes=None, ax=None, title=None, vmin=None, vmax=None):
    """A size grid as an image, the polygon outlined.

    White dots mark the grid points filled by the plate, or those assigned by
    (4.5) when they are the fewer.

    Parameters
    ----------
    grid : GridSize
        With ``assigned`` from :func:`polygen.mesh2d.element_size_grid`.
    polygon : Polygon, optional
        Its outline (in the grid's frame) is drawn.
    nodes : (K, 2) float64, optional
        The first mesh's nodes, drawn as small crosses.
    """
    fig, ax = _axes(ax)
    ny, nx = grid.values.shape
    x0, y0 = grid.origin
    x1, y1 = grid.origin + grid.spacing * [nx - 1, ny - 1]
    im = ax.imshow(grid.values, origin="lower", extent=(x0, x1, y0, y1), cmap="viridis",
                   vmin=vmin, vmax=vmax, interpolation="bilinear")
    fig.colorbar(im, ax=ax, shrink=0.75, label="size")
    a = getattr(grid, "assigned", None)
    if a is not None and (~a).any():
        # mark the rarer kind of grid point, so that neither floods the image
        mark, label = ((~a, "from the plate") if (~a).sum() <= a.sum() else (a, "by (4.5)"))
        j, i = np.nonzero(mark)
        ax.plot(x0 + i * grid.spacing[0], y0 + j * grid.spacing[1], ".", color="w", ms=2,
                label=label)
        ax.legend(loc="upper right", fontsize=7)
    if nodes is not None:
        ax.plot(nodes[:, 0], nodes[:, 1], "+", color="k", ms=3, mew=0.5)
    if polygon is not None:
        ring = np.vstack([polygon.exterior_2d, polygon.exterior_2d[:1]])
        ax.plot(ring[:, 0], ring[:, 1], color="k", lw=1)
    ax.set_aspect("equal")
    ax.set_title(title or f"size grid {nx} x {ny}", fontsize=10)
    return fig


def plot_plate_surface(grid, *, ax=None, title="the bent plate: size as height (Fig. 4.2 (c))"):
    """A size grid as a 3-D surface, the assigned points as dots (Fig. 4.2 (b)-(c))."""
    fig, ax = _axes(ax, figsize=(6, 4.5), projection="3d")
    ny, nx = grid.values.shape
    x = grid.origin[0] + grid.spacing[0] * np.arange(nx)
    y = grid.origin[1] + grid.spacing[1] * np.arange(ny)
    X, Y = np.meshgrid(x, y)
    ax.plot_surface(X, Y, grid.values, cmap="viridis", linewidth=0, antialiased=True, alpha=0.85)
    a = getattr(grid, "assigned", None)
    if a is not None:
        ax.scatter(X[a], Y[a], grid.values[a], s=2, color="k", depthshade=False)
    ax.set_zlabel("size")
    ax.set_title(title, fontsize=10)
    return fig


def plot_error_curves(curves, *, ax=None, title="image error against elements"):
    """Curves ``{name: [(elements, error), ...]}`` on log-log axes."""
    fig, ax = _axes(ax)
    for name, pts in curves.items():
        pts = sorted(pts)
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=name)
    ax.set_xlabel("elements")
    ax.set_ylabel("relative RMS image error")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(title, fontsize=10)
    return fig


def plot_plate_convergence(h, errors, *, ax=None, title="ACM plate element: centre deflection"):
    """Relative errors against the element size, with an h^2 guide; ``errors``: {label: (K,)}."""
    fig, ax = _axes(ax)
    h = np.asarray(h, dtype=np.float64)
    for label, e in errors.items():
        ax.loglog(h, e, "o-", label=label)
    e0 = max(float(np.max(e)) for e in errors.values())
    ax.loglog(h, e0 * (h / h.max()) ** 2, "k--", lw=1, label="h²")
    ax.set_xlabel("element size h / a")
    ax.set_ylabel("|w / w_Timoshenko - 1|")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(title, fontsize=10)
    return fig


def plot_polygon_remesh(run, polygon, size_min, size_max, *, figsize=(10, 4)):
    """The size grid and the bubble mesh of one polygon for other sizes (the notebook's sliders).

    Calls :func:`polygen.radiosity.intensity.remesh_polygon`; sizes that break (4.3) draw the
    message instead of the mesh.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    from polygen.plotting.radiosity import plot_polygon_mesh
    from polygen.radiosity.intensity import remesh_polygon
    from polygen.radiosity.mesh import MeshError

    fig, axes = plt.subplots(1, 2, figsize=figsize)
    try:
        grid, mesh = remesh_polygon(run, polygon, size_min=size_min, size_max=size_max)
    except MeshError as exc:
        for ax in axes:
            ax.set_axis_off()
        axes[0].text(0.0, 0.5, str(exc), wrap=True, fontsize=9)
        return fig
    poly = run.first_mesh.scene.polygons[polygon]
    plot_size_grid(grid, poly, ax=axes[0], title=f"size grid, {size_max:.2f}..{size_min:.2f}")
    plot_polygon_mesh(mesh, 0, ax=axes[1])
    axes[1].set_title(f"{mesh.n_elements} elements", fontsize=9)
    return fig


def remesh_sliders(run, polygon):
    """Sliders for ``size_min`` / ``size_max`` redrawing :func:`plot_polygon_remesh`.

    Ranges around the run's ``size_initial`` (``size_min`` 1.1-4 times it, ``size_max``
    0.25-0.9 times), starting at the run's sizes; the drawing happens once at once, so a
    static rendering of a notebook shows the run's sizes.

    Returns
    -------
    ipywidgets.Widget
    """
    import ipywidgets
    import matplotlib.pyplot as plt

    p = run.parameters
    si = p["size_initial"]

    def draw(size_min, size_max):
        plot_polygon_remesh(run, polygon, size_min, size_max)
        plt.show()

    return ipywidgets.interactive(
        draw,
        size_min=ipywidgets.FloatSlider(value=p["size_min"], min=si * 1.1, max=si * 4, step=0.1,
                                        continuous_update=False),
        size_max=ipywidgets.FloatSlider(value=p["size_max"], min=si / 4, max=si * 0.9,
                                        step=0.05, continuous_update=False))
