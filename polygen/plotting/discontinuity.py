"""Figures of chapter 3 (discontinuity meshing) drawn from the code's own records.

Everything here draws what :mod:`polygen.discontinuity` returns: shadow
polyhedra (Figs 3.6, 3.7), sections and discontinuity segments on a
receiver (Figs 2.9, 3.1, 3.3), receiver complexes with their illumination
states (Figs 3.9, 3.10, 3.13), BSP regions (Figs 2.10, 3.4) and the error
curves of ``benchmarks/discontinuity.py``.  matplotlib is imported inside
the functions.
"""

from __future__ import annotations

import numpy as np

from polygen.plotting.radiosity import _axes

__all__ = ["plot_polyhedra", "plot_sections", "plot_segments", "plot_complex", "plot_regions",
           "plot_error_curves", "plot_walk_steps", "plot_loop_steps", "plot_complex_with_light_at",
           "light_slider", "STATE_COLORS"]

# unprocessed, bright, penumbra, umbra (3.3.5)
STATE_COLORS = ["white", "#fff3b0", "#e0a040", "#505050"]


def _receiver_outline(ax, receiver, color="k", lw=1.2):
    for ring in [receiver.exterior_2d] + list(receiver.holes_2d):
        r = np.vstack([ring, ring[:1]])
        ax.plot(r[:, 0], r[:, 1], color=color, lw=lw)


def _finish(ax, title):
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=10)


def plot_polyhedra(polyhedra, *, ax=None, title=None, elev=20, azim=-60):
    """The umbra (dark) and penumbra (light) polyhedra of one light and occluder, in 3-D.

    Parameters
    ----------
    polyhedra : ShadowPolyhedra
    ax : mpl_toolkits.mplot3d.Axes3D, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=(5, 5))
        ax = fig.add_subplot(projection="3d")
    fig = ax.figure
    # the scenes' y is up: draw (x, z, y) so that it is up on the page
    up = [0, 2, 1]
    for poly, color, lw in ((polyhedra.penumbra, "tab:orange", 0.8), (polyhedra.umbra, "k", 1.4)):
        V = poly.vertices[:, up]
        for a, b in poly.edges:
            if poly.on_cap[a] and poly.on_cap[b]:
                continue
            ax.plot(*V[[a, b]].T, color=color, lw=lw)
    L = polyhedra.light_vertices[:, up]
    if len(L) > 1:
        r = np.vstack([L, L[:1]])
        ax.plot(*r.T, color="gold", lw=2.5)
    else:
        ax.scatter(*L.T, color="gold", s=40)
    O = polyhedra.occluder_vertices[:, up]
    O = np.vstack([O, O[:1]])
    ax.plot(*O.T, color="tab:blue", lw=2.5)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    ax.set_title(title or f"umbra (black, {len(polyhedra.umbra.planes)} planes) and penumbra "
                 f"(orange, {len(polyhedra.penumbra.planes)} planes)", fontsize=9)
    return fig


def plot_sections(receiver, sections, *, ax=None, title=None):
    """A receiver with the umbra and penumbra sections on it (its (u, v) frame).

    Parameters
    ----------
    receiver : Polygon
    sections : sequence of ShadowSection

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax)
    _receiver_outline(ax, receiver)
    for s in sections:
        for ring, fc in ((s.penumbra, STATE_COLORS[2]), (s.umbra, STATE_COLORS[3])):
            if len(ring) >= 3:
                ax.fill(ring[:, 0], ring[:, 1], fc=fc, ec="k", lw=0.6, alpha=0.6)
    lo, hi = receiver.exterior_2d.min(axis=0), receiver.exterior_2d.max(axis=0)
    pad = 0.03 * (hi - lo)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
    _finish(ax, title)
    return fig


def plot_segments(receiver, segments, *, ax=None, title=None, color="tab:red", lw=0.8):
    """Discontinuity segments on a receiver.

    Parameters
    ----------
    receiver : Polygon
    segments : (S, 2, 2) float64 or Segments
        In the receiver's frame.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.collections import LineCollection

    fig, ax = _axes(ax)
    ends = getattr(segments, "ends", segments)
    _receiver_outline(ax, receiver)
    ax.add_collection(LineCollection(np.asarray(ends).reshape(-1, 2, 2), colors=color, lw=lw))
    _finish(ax, title)
    return fig


def plot_complex(cx, *, ax=None, title=None, light=None, labels=False):
    """A receiver complex: faces coloured by illumination state, D0/D1 edges (Figs 3.10, 3.13).

    Parameters
    ----------
    cx : ReceiverComplex
    light : int, optional
        Colour by this light's state; default the darkest over all lights
        (penumbra wins over umbra only when some light is penumbra and none
        umbra -- as the mesher reads it, any penumbra is drawn penumbra).
    labels : bool
        Write each face's states at a point inside it.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path

    from polygen.discontinuity.complex import D0, D1

    fig, ax = _axes(ax)
    st = cx.face_states()
    pts = cx.interior_points()
    for i, f in enumerate(cx.alive_faces):
        s = st[i]
        if light is not None:
            v = int(s[light])
        else:
            v = 2 if np.any(s == 2) else int(s.max(initial=1))
        outer, holes = cx.face_rings(f)
        verts, codes = [], []
        for ring in [outer] + list(holes):
            verts += list(ring) + [ring[0]]
            codes += [Path.MOVETO] + [Path.LINETO] * (len(ring) - 1) + [Path.CLOSEPOLY]
        ax.add_patch(PathPatch(Path(verts, codes), fc=STATE_COLORS[v], ec="none"))
        if labels:
            ax.text(*pts[i], "".join(str(int(x)) for x in s), fontsize=7, ha="center", va="center")
    V = cx.vertices
    kinds = cx.edge_kind
    for e, (a, b) in enumerate(cx.edges):
        c, w = {D0: ("tab:red", 1.2), D1: ("tab:blue", 0.8)}.get(int(kinds[e]), ("k", 1.2))
        ax.plot(*V[[a, b]].T, color=c, lw=w)
    ax.autoscale_view()
    _finish(ax, title or f"{len(cx.alive_faces)} regions")
    handles = [plt.Rectangle((0, 0), 1, 1, fc=STATE_COLORS[k], ec="k") for k in (1, 2, 3)]
    ax.legend(handles, ["bright", "penumbra", "umbra"], fontsize=7, loc="upper right")
    return fig


def plot_regions(regions, *, ax=None, title=None, receiver=None):
    """Convex regions (e.g. BSP leaves, :class:`~polygen.discontinuity.BSPRegions`), outlined.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax)
    rs = getattr(regions, "regions", regions)
    import matplotlib

    cmap = matplotlib.colormaps["tab20"]
    for k, r in enumerate(rs):
        ax.fill(r[:, 0], r[:, 1], fc=cmap(k % 20), ec="k", lw=0.5, alpha=0.7)
    if receiver is not None:
        _receiver_outline(ax, receiver)
    _finish(ax, title or f"{len(rs)} regions")
    return fig


def plot_error_curves(curves, *, ax=None, title=None):
    """Image error against element count, one line per meshing method.

    Parameters
    ----------
    curves : dict {name: list of dict with "n_elements", "error"}

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, figsize=(5, 3.6))
    for name, pts in curves.items():
        n = [p["n_elements"] for p in pts]
        e = [p["error"] for p in pts]
        ax.loglog(n, e, "o-", label=name)
    lo, hi = ax.get_xlim()
    if hi > 10.0 * lo:  # over more than a decade the minor tick labels run into each other
        from matplotlib.ticker import NullFormatter

        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("elements")
    ax.set_ylabel("relative RMS image error")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def _grid(n, ncols, size):
    import matplotlib.pyplot as plt

    ncols = max(1, min(ncols, n))
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(size * ncols, size * nrows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.axis("off")
    return fig, axes.flat


def _draw_edges(ax, segs, **kw):
    from matplotlib.collections import LineCollection

    if len(segs):
        ax.add_collection(LineCollection(np.asarray(segs), **kw))


def plot_walk_steps(record, *, ncols=4, size=2.6):
    """The intersection walk of one section ring step by step (Fig. 3.9), one panel per step.

    Each panel: the complex's edges when the step began (grey), the section
    ring (dashed), the edges this step tested (blue: the current loop's
    edges only), the current point (black), the vertex aimed at (open
    circle), the crossing found (red cross), and the edges drawn so far (red).

    Parameters
    ----------
    record : SectionRecord
        From ``receiver_complex(..., record=True).records``.
    ncols : int, keyword-only
    size : float, keyword-only
        Panel size in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    steps = record.walk
    fig, axes = _grid(len(steps), ncols, size)
    ring = np.vstack([record.ring, record.ring[:1]])
    drawn = []
    for i, (ax, st) in enumerate(zip(axes, steps)):
        _draw_edges(ax, st.edges, colors="0.6", linewidths=0.8)
        ax.plot(ring[:, 0], ring[:, 1], "--", color="0.3", lw=0.7)
        _draw_edges(ax, st.tested_segments, colors="tab:blue", linewidths=2.0)
        _draw_edges(ax, drawn, colors="tab:red", linewidths=1.6)
        if st.drawn is not None:
            _draw_edges(ax, [st.drawn], colors="tab:red", linewidths=2.4)
            drawn.append(st.drawn)
        ax.plot(*st.point, "ko", ms=4)
        if st.kind != "locate":
            ax.plot(*st.target, "o", mfc="none", mec="k", ms=6)
        if st.crossing is not None:
            ax.plot(*st.crossing, "x", color="tab:red", ms=7, mew=2)
        where = f"L{st.loop}" if st.loop >= 0 else "outside"
        if st.kind == "locate":
            head = f"locate in {where}: {len(st.loops_tested)} PIL, {len(st.tested)} edges"
        elif st.kind == "follow":
            head = "along an existing edge"
        else:
            head = f"in {where}: {len(st.tested)} edges -> {st.hit}"
        ax.autoscale_view()
        _finish(ax, f"{i}: {head}")
        ax.title.set_fontsize(8)
    return fig


def plot_loop_steps(record, *, ncols=4, size=2.6):
    """Loop rebuilding of one section ring step by step (Fig. 3.13), one panel per loop traced.

    Each panel: the complex (grey; the ring's new edges red), the loop
    traced (green when counter-clockwise, an outer loop; purple when
    clockwise, a hole) with an arrow per edge, its junction turns (circles),
    and in the title the table cell it started from and the old loops it
    deleted.  A last panel prints the left/right table.

    Parameters
    ----------
    record : SectionRecord
        From ``receiver_complex(..., record=True).records``.
    ncols : int, keyword-only
    size : float, keyword-only

    Returns
    -------
    matplotlib.figure.Figure
    """
    loops = record.loops
    fig, axes = _grid(len(loops) + 1, ncols, size)
    axes = list(axes)
    new = set(record.new_edges)
    for ax, st in zip(axes, loops):
        segs = st.edges
        is_new = np.array([e in new for e in range(len(segs))])
        _draw_edges(ax, segs[~is_new], colors="0.6", linewidths=0.8)
        _draw_edges(ax, segs[is_new], colors="tab:red", linewidths=0.8)
        c = "tab:green" if st.area > 0 else "tab:purple"
        ax.fill(st.path[:, 0], st.path[:, 1], color=c, alpha=0.25, lw=0)
        p, q = st.path, np.roll(st.path, -1, axis=0)
        ax.quiver(p[:, 0], p[:, 1], 0.85 * (q - p)[:, 0], 0.85 * (q - p)[:, 1], color=c, angles="xy",
                  scale_units="xy", scale=1.0, width=0.012)
        for v, _, _ in st.turns:
            ax.plot(*v, "o", mfc="none", mec="k", ms=6)
        side = "left" if st.seed[1] == 0 else "right"
        gone = ",".join(f"L{d}" for d in st.deleted) or "none"
        ax.autoscale_view()
        _finish(ax, f"L{st.loop} from e{st.seed[0]} {side} ({'CCW' if st.area > 0 else 'CW'})\n"
                    f"{len(st.turns)} turns, deletes {gone}")
        ax.title.set_fontsize(7)
    ax = axes[len(loops)]
    ax.axis("off")
    rows = [[f"e{e}", f"L{lr[0]}", f"L{lr[1]}"] for e, lr in record.table.items()]
    if rows:
        tab = ax.table(cellText=rows, colLabels=["edge", "left", "right"], bbox=[0.0, 0.0, 1.0, 0.93])
        tab.auto_set_font_size(False)
        tab.set_fontsize(6)
    ax.set_title("left/right table", fontsize=8)
    return fig


def plot_complex_with_light_at(scene, dx=0.0, *, receiver=0, ax=None, show=False):
    """Redraw a receiver's complex with the scene's lights moved by ``dx`` along x (the notebook's slider).

    Parameters
    ----------
    scene : polygen.radiosity.scene.Scene
    dx : float
        Shift of every light polygon along x (scene units).
    receiver : int, keyword-only
        The receiver complex drawn (index into the method's complexes).
    show : bool, keyword-only
        Show the figure and return None (for an ``ipywidgets.interact``
        callback, which would otherwise display the returned figure again).

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    from polygen.discontinuity import simplified_discontinuity
    from polygen.radiosity.scene import AreaLight, Scene

    polys = [AreaLight(p.vertices + [dx, 0.0, 0.0], emission=p.emission, reflectance=p.reflectance,
                       name=p.name) if isinstance(p, AreaLight) else p for p in scene.polygons]
    cx = simplified_discontinuity(Scene(polys)).complexes[receiver]
    fig = plot_complex(cx, ax=ax, title=f"light moved by {dx:+.1f}: {len(cx.alive_faces)} regions")
    if show:
        import matplotlib.pyplot as plt

        plt.show()
        return None
    return fig


def light_slider(scene, *, dx_max=3.0, step=0.5, receiver=0):
    """An ipywidgets slider moving the scene's lights along x, redrawing a receiver complex.

    The callback is :func:`plot_complex_with_light_at` bound to ``scene``;
    without a kernel the notebook shows what it first drew (``dx = 0``).

    Parameters
    ----------
    scene : polygen.radiosity.scene.Scene
    dx_max : float, keyword-only
        The slider runs over ``[-dx_max, dx_max]``.
    step : float, keyword-only
    receiver : int, keyword-only

    Returns
    -------
    The ``ipywidgets.interact`` result.
    """
    import functools

    import ipywidgets

    callback = functools.partial(plot_complex_with_light_at, scene)
    callback.__name__ = "plot_complex_with_light_at"   # interact names its widget after it
    slider = ipywidgets.FloatSlider(value=0.0, min=-dx_max, max=dx_max, step=step, continuous_update=False)
    return ipywidgets.interact(callback, dx=slider, receiver=ipywidgets.fixed(receiver),
                               ax=ipywidgets.fixed(None), show=ipywidgets.fixed(True))
