"""Figures of chapter 2 (radiosity and 2-D meshing), with matplotlib.

Nothing in polygen's algorithms imports this module; matplotlib is
imported inside the functions.  Every function returns the matplotlib
Figure it drew on.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "show_images",
    "plot_hemicube",
    "plot_delta_form_factors",
    "plot_convergence",
    "plot_force",
    "plot_bubbles",
    "plot_mesh2d",
    "plot_quality_histograms",
    "plot_polygon_mesh",
]


def _axes(ax, figsize=(5, 5)):
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=figsize)
        return fig, ax
    return ax.figure, ax


def show_images(images, titles=None, *, exposure=None, ncols=None, size=3.2):
    """Radiosity images side by side, tone-mapped with one common exposure.

    Parameters
    ----------
    images : sequence of (H, W, 3) float64
        Linear radiosity images from :func:`polygen.radiosity.render`.
    titles : sequence of str, optional
    exposure : float, optional
        Common multiplier; default maps the 99th percentile of the last
        image to 1 (so a sequence converging to the last one shows its
        growth).
    ncols : int, optional
    size : float
        Inches per panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    from polygen.radiosity.raster import tone_map

    n = len(images)
    ncols = ncols or n
    nrows = -(-n // ncols)
    if exposure is None:
        p = np.percentile(images[-1], 99.0)
        exposure = 1.0 / p if p > 0 else 1.0
    fig, axes = plt.subplots(nrows, ncols, figsize=(size * ncols, size * nrows), squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        ax.axis("off")
        if k < n:
            ax.imshow(tone_map(images[k], exposure=exposure))
            if titles is not None:
                ax.set_title(titles[k], fontsize=9)
    fig.tight_layout()
    return fig


def _unfold(faces, res, fill):
    """The five hemicube buffers on a (2 res, 2 res) cross; row index grows upwards."""
    h = res // 2
    canvas = np.full((2 * res, 2 * res) + faces.shape[3:], fill, dtype=faces.dtype)
    canvas[h:h + res, h:h + res] = faces[0]
    side = faces[1:, :h]  # rows: height above the base, from the base up
    # +u (right of the top face): column index of the face runs along v
    canvas[h:h + res, h + res:] = np.swapaxes(side[0][::-1], 0, 1)
    canvas[h:h + res, :h] = np.swapaxes(side[1], 0, 1)
    # +v (above) and -v (below): column index runs along u
    canvas[h + res:, h:h + res] = side[2][::-1]
    canvas[:h, h:h + res] = side[3]
    return canvas


def plot_hemicube(items, *, colors=None, ax=None, title="hemicube item buffer"):
    """The five z-buffers of a hemicube unfolded into a cross (Cohen & Greenberg; thesis 2.2.1).

    Parameters
    ----------
    items : (5, res, res) int64
        From ``hemicube_form_factors(..., return_items=True)``: the triangle
        seen at each pixel (-1 nothing) on the top face and the four half
        side faces (+u, -u, +v, -v).
    colors : (T, 3) float64, optional
        RGB in [0, 1] of each triangle; default: a colour per id.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.patches import Rectangle

    items = np.asarray(items)
    res = items.shape[1]
    n_ids = int(items.max()) + 1 if items.max() >= 0 else 1
    if colors is None:
        rng = np.random.default_rng(0)
        colors = rng.uniform(0.2, 0.9, (n_ids, 3))
    colors = np.asarray(colors, dtype=np.float64)
    rgb = np.ones(items.shape + (3,))
    seen = items >= 0
    rgb[seen] = colors[items[seen]]
    canvas = _unfold(rgb, res, 1.0)
    fig, ax = _axes(ax)
    ax.imshow(canvas, origin="lower", interpolation="nearest")
    h = res // 2
    for x0, y0, w, hh in ((h, h, res, res), (h + res, h, h, res), (0, h, h, res),
                          (h, h + res, res, h), (h, 0, res, h)):
        ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), w, hh, fill=False, lw=0.8, color="k"))
    ax.set_title(title)
    ax.axis("off")
    return fig


def plot_delta_form_factors(top, side, *, ax=None, title="delta form factors"):
    """The delta form factors of the five hemicube faces, unfolded (log colour scale).

    Parameters
    ----------
    top : (res, res) float64
    side : (res // 2, res) float64
        From :func:`polygen.radiosity.delta_form_factors`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.colors import LogNorm

    res = top.shape[0]
    faces = np.zeros((5, res, res))
    faces[0] = top
    faces[1:, : res // 2] = side
    canvas = _unfold(faces, res, np.nan)
    fig, ax = _axes(ax)
    im = ax.imshow(canvas, origin="lower", interpolation="nearest", cmap="viridis",
                   norm=LogNorm(vmin=np.nanmin(canvas[canvas > 0]), vmax=np.nanmax(canvas)))
    fig.colorbar(im, ax=ax, shrink=0.7, label="delta form factor")
    ax.set_title(title)
    ax.axis("off")
    return fig


def plot_convergence(histories, *, ax=None, title="progressive refinement"):
    """Unshot energy / emitted energy against the number of shots (log scale).

    Parameters
    ----------
    histories : dict of label -> (k,) float64
        ``RadiosityResult.history`` of each run.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, figsize=(6, 4))
    for label, h in histories.items():
        ax.semilogy(np.arange(len(h)), h, label=label)
    ax.set_xlabel("shots")
    ax.set_ylabel("unshot / emitted")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title(title)
    return fig


def plot_force(*, ax=None):
    """The inter-bubble force (2.12) against the distance in units of r0 (Fig. 2.6 (d))."""
    from polygen.mesh2d import bubble_force

    fig, ax = _axes(ax, figsize=(5, 3.5))
    w = np.linspace(0.0, 1.8, 400)
    ax.plot(w, bubble_force(w), color="k")
    ax.axhline(0.0, color="0.6", lw=0.8)
    for x, name in ((1.0, "$r_0$"), (1.5, "$r_1$")):
        ax.axvline(x, color="tab:blue", ls="--", lw=0.8)
        ax.text(x, ax.get_ylim()[1] * 0.9, name, ha="center", va="top",
                backgroundcolor="white")
    ax.set_xlabel("distance $r / r_0$")
    ax.set_ylabel("force $f / k_0$ (> 0 repulsive)")
    ax.set_title("inter-bubble force (2.12)")
    fig.tight_layout()
    return fig


def plot_bubbles(centres, diameters, *, triangles=None, kind=None, ax=None, title=None):
    """Bubbles as circles, optionally over the triangles joining their centres (Fig. 2.7).

    Parameters
    ----------
    centres : (N, 2) float64
    diameters : (N,) float64 or float
    triangles : (T, 3) int64, optional
    kind : (N,) int8, optional
        0 vertex, 1 edge, 2 face bubble (colours).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.collections import EllipseCollection

    fig, ax = _axes(ax)
    c = np.asarray(centres, dtype=np.float64)
    d = np.broadcast_to(np.asarray(diameters, dtype=np.float64), (len(c),))
    if triangles is not None:
        ax.triplot(c[:, 0], c[:, 1], triangles, color="0.35", lw=0.5)
    palette = np.array([[0.85, 0.2, 0.2, 0.35], [0.2, 0.45, 0.85, 0.35], [0.3, 0.7, 0.3, 0.25]])
    fc = palette[np.asarray(kind, dtype=np.int64)] if kind is not None else palette[2]
    ax.add_collection(EllipseCollection(d, d, np.zeros(len(c)), units="xy", offsets=c,
                                        offset_transform=ax.transData, facecolors=fc,
                                        edgecolors="0.3", linewidths=0.3))
    ax.set_xlim(c[:, 0].min() - d.max(), c[:, 0].max() + d.max())
    ax.set_ylim(c[:, 1].min() - d.max(), c[:, 1].max() + d.max())
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=10)
    return fig


def plot_mesh2d(nodes, triangles, *, values=None, cmap="viridis", vmin=None, vmax=None,
                highlight=None, ax=None, title=None, lw=0.4):
    """A planar triangle mesh, optionally coloured per triangle (e.g. by quality).

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64
    values : (T,) float64, optional
        Face colours.
    highlight : (K,) int64, optional
        Nodes to mark (e.g. T-vertices).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax)
    n = np.asarray(nodes, dtype=np.float64)
    if values is not None:
        tpc = ax.tripcolor(n[:, 0], n[:, 1], triangles, facecolors=np.asarray(values),
                           cmap=cmap, vmin=vmin, vmax=vmax, edgecolors="0.25", linewidth=lw)
        fig.colorbar(tpc, ax=ax, shrink=0.7)
    else:
        ax.triplot(n[:, 0], n[:, 1], triangles, color="0.25", lw=lw)
    if highlight is not None and len(highlight):
        ax.plot(n[highlight, 0], n[highlight, 1], "o", color="crimson", ms=6, mfc="none", mew=1.5)
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=10)
    return fig


def plot_quality_histograms(qualities, *, kind="q", bins=20, ax=None, title=None):
    """Overlaid histograms of a triangle quality measure.

    Parameters
    ----------
    qualities : dict of label -> (T,) float64
        Radius ratios ``q`` (kind ``"q"``) or smallest angles in degrees
        (kind ``"angle"``), e.g. from :func:`polygen.mesh2d.triangle_quality`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from polygen.mesh2d import quality_histogram

    fig, ax = _axes(ax, figsize=(5, 3.5))
    for label, v in qualities.items():
        counts, edges = quality_histogram(v, kind=kind, bins=bins)
        frac = counts / max(len(v), 1)
        ax.stairs(frac, edges, label=f"{label} (mean {np.mean(v):.3f})", lw=1.5)
    ax.set_xlabel("radius ratio q = 2 r_in / R_circ" if kind == "q" else "smallest angle (deg)")
    ax.set_ylabel("fraction of triangles")
    ax.legend(fontsize=8, loc="upper left")
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_polygon_mesh(mesh, polygon, *, values=None, ax=None, title=None, cmap="gray",
                      vmin=None, vmax=None, lw=0.3):
    """The elements (thin) and patches (thick) of one scene polygon, in its plane.

    Parameters
    ----------
    mesh : RadiosityMesh
    polygon : int
        Index of the scene polygon.
    values : (M,) float64, optional
        Element values to colour by (e.g. radiosity); only this polygon's
        elements are used.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax)
    poly = mesh.scene.polygons[polygon]
    sel = np.flatnonzero(mesh.element_polygon == polygon)
    psel = np.flatnonzero(mesh.patch_polygon == polygon)
    used = np.unique(np.concatenate([mesh.elements[sel].ravel(), mesh.patches[psel].ravel()]))
    local = np.full(mesh.n_nodes, -1, dtype=np.int64)
    local[used] = np.arange(len(used))
    xy = poly.to_2d(mesh.nodes[used])
    tris = local[mesh.elements[sel]]
    if values is not None:
        v = np.asarray(values, dtype=np.float64)[sel]
        tpc = ax.tripcolor(xy[:, 0], xy[:, 1], tris, facecolors=v, cmap=cmap, vmin=vmin,
                           vmax=vmax, edgecolors="0.5", linewidth=lw)
        fig.colorbar(tpc, ax=ax, shrink=0.7)
    else:
        ax.triplot(xy[:, 0], xy[:, 1], tris, color="0.45", lw=lw)
    ax.triplot(xy[:, 0], xy[:, 1], local[mesh.patches[psel]], color="tab:blue", lw=3 * lw)
    ax.set_aspect("equal")
    ax.axis("off")
    ax.set_title(title or f"{poly.name}: {len(psel)} patches, {len(sel)} elements", fontsize=10)
    return fig
