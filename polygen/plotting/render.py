"""Figures of thesis 7.8 (volume rendering), and VTK's unstructured-grid ray caster as a reference.

Nothing in polygen's algorithms imports this module; pyvista and matplotlib
are imported inside the functions. 3D functions return a ``pyvista.Plotter``.
"""

from __future__ import annotations

import time

import numpy as np

from polygen.plotting._common import EXTREMUM_COLOR as _EXTREMUM_COLOR
from polygen.plotting._common import _plotter, boundary_mesh

__all__ = ["VtkUgridRayCaster", "plot_fig_7_8", "plot_fig_7_9", "plot_comparison", "plot_transfer_function",
           "plot_shell_render", "show_shell_render"]


class VtkUgridRayCaster:
    """VTK's unstructured-grid ray caster on the same grid, transfer function and rays.

    The opacity table is given per ``tf.unit`` of length
    (``ScalarOpacityUnitDistance``), the colours are the reflectances, and
    shading is off (the mapper does not shade): compare with a
    :class:`~polygen.volume.render.Lighting` of ``shade=False`` and
    ``optical_model="attenuation"``, which is what VTK's integrators do
    (``vtkUnstructuredGridPreIntegration``, the default, and
    ``vtkUnstructuredGridPartialPreIntegration`` read ``opacity / unit`` as
    the attenuation coefficient). Full image resolution
    (``ImageSampleDistance = 1``, no automatic coarsening).

    The same rays: the Bunyk ray caster
    (``vtkUnstructuredGridVolumeRayCastMapper``) sends pixel ``(x, y)``'s ray
    through the pixel's lower left corner (it projects the points to
    ``(ndc + 1) / 2 * W`` and casts at whole ``x``), polygen through its
    centre; the VTK camera's window centre is moved by half a pixel
    (``SetWindowCenter(1 / W, 1 / H)``) so that both cast through the centres.
    Without it the images differ by half a pixel at every edge (data1, 128²,
    VTK's optical model: 32.1 dB over the foreground instead of 40.2).

    The Bunyk caster takes tetrahedra only: a hexahedral volume is cut into
    tetrahedra first by VTK (``vtkDataSetTriangleFilter``, six per
    hexahedron), so VTK interpolates linearly in each tetrahedron where
    polygen interpolates trilinearly in the hexahedron (``tetrahedralised``
    says so; ``n_cells`` is the cells VTK renders). VTK's ZSweep mapper takes
    hexahedra as they are, but casts with its own pixel convention, which
    is not matched here (hexa1, 128²: 29.8 dB over the foreground), so it is
    not offered.

    Parameters
    ----------
    vol : UnstructuredVolume
    camera : polygen.volume.render.View
    tf : polygen.volume.render.TransferFunction
    field : str, optional
    background : float or (3,) float
    """

    def __init__(self, vol, camera, tf, *, field=None, background=0.0):
        import pyvista as pv
        import vtk

        name = field or next(iter(vol.fields))
        grid = vol.to_pyvista()
        grid.set_active_scalars(name)
        self.tetrahedralised = False
        if vol.cell_type != "tetra":
            tet = vtk.vtkDataSetTriangleFilter()
            tet.SetInputData(grid)
            tet.TetrahedraOnlyOn()
            tet.Update()
            grid = pv.wrap(tet.GetOutput())
            grid.set_active_scalars(name)
            self.tetrahedralised = True
        self.n_cells = grid.n_cells
        ctf = vtk.vtkColorTransferFunction()
        otf = vtk.vtkPiecewiseFunction()
        for x, c, a in zip(tf.knots, tf.rgb, tf.opacity):
            ctf.AddRGBPoint(float(x), *map(float, c))
            otf.AddPoint(float(x), float(a))
        prop = vtk.vtkVolumeProperty()
        prop.SetColor(ctf)
        prop.SetScalarOpacity(otf)
        prop.SetScalarOpacityUnitDistance(tf.unit)
        prop.ShadeOff()
        prop.SetInterpolationTypeToLinear()
        m = vtk.vtkUnstructuredGridVolumeRayCastMapper()
        m.SetAutoAdjustSampleDistances(False)
        m.SetImageSampleDistance(1.0)
        m.SetInputData(grid)
        volume = vtk.vtkVolume()
        volume.SetMapper(m)
        volume.SetProperty(prop)
        w, h = camera.size
        self.plotter = pl = pv.Plotter(off_screen=True, window_size=(w, h))
        pl.set_background(np.broadcast_to(np.asarray(background, float), (3,)).tolist())
        pl.renderer.AddVolume(volume)
        pl.camera.position = camera.eye
        pl.camera.focal_point = camera.target
        pl.camera.up = camera.up
        if camera.ortho:
            pl.enable_parallel_projection()
            pl.camera.parallel_scale = camera.height / 2.0
        else:
            pl.camera.view_angle = camera.fov
        pl.camera.SetWindowCenter(1.0 / w, 1.0 / h)  # VTK's rays through the pixel centres, as ours
        pl.renderer.ResetCameraClippingRange()
        self.mapper = m

    def render(self):
        """``(image (H, W, 3) float64 in [0, 1], seconds)`` of one frame (render and read-back)."""
        t0 = time.perf_counter()
        self.plotter.render()
        img = self.plotter.screenshot(return_img=True)
        return np.asarray(img[..., :3], np.float64) / 255.0, time.perf_counter() - t0

    def close(self):
        self.plotter.close()


def plot_transfer_function(tf, *, ax=None, title=None):
    """The colour bar and opacity curve of a transfer function."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(5, 1.8))
    x = np.linspace(tf.knots[0], tf.knots[-1], 256)
    rgb, a = tf(x)
    ax.imshow(rgb[None], extent=(x[0], x[-1], 0, 1), aspect="auto")
    ax.plot(x, a / max(float(a.max()), 1e-12), color="white", lw=2)
    ax.plot(x, a / max(float(a.max()), 1e-12), color="black", lw=1)
    ax.set_yticks([])
    ax.set_xlabel("scalar S")
    ax.set_title(title or f"transfer function (opacity curve, max {a.max():.2f} per {tf.unit:.3g})")
    return ax


def plot_shell_render(renderer, tf, *, step, axes=None):
    """The image of ``renderer.render(tf, step=step)`` beside the transfer function.

    Parameters
    ----------
    renderer : polygen.volume.render.ShellRenderer
    tf : polygen.volume.render.TransferFunction
    step : float
        The spacing of the equi-distance surfaces.
    axes : (2,) matplotlib Axes, optional
        Image, transfer function; a new figure by default.

    Returns
    -------
    fig : matplotlib Figure
    result : RenderResult
    """
    import matplotlib.pyplot as plt

    res = renderer.render(tf, step=step)
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(9, 3.6), gridspec_kw={"width_ratios": [1, 1.4]})
    axes[0].imshow(np.clip(res.image, 0, 1))
    axes[0].axis("off")
    diag = float(np.linalg.norm(np.ptp(renderer.vol.points, axis=0)))
    # no timing in the figure: the same inputs draw the same figure (the time is in ``result.seconds``)
    axes[0].set_title(f"{diag / step:.0f} surfaces per diagonal")
    plot_transfer_function(tf, ax=axes[1])
    return axes[0].figure, res


def show_shell_render(renderer, cmap="viridis", opacity_low=0.0, opacity_high=0.6, surfaces=100):
    """The transfer-function editor's callback (7.8.3): re-render with a new colour map, opacity or count.

    A colour ramp over the renderer's field, the opacity linear from ``opacity_low`` to
    ``opacity_high`` per a twentieth of the volume's diagonal, ``surfaces`` equi-distance surfaces
    per diagonal; drawn by :func:`plot_shell_render` and shown. Meant for
    ``ipywidgets.interact(show_shell_render, renderer=fixed(renderer), cmap=[...], ...)``: the
    skeleton is built once per eye, so only a new count builds new surfaces.
    """
    import matplotlib.pyplot as plt

    from polygen.volume.render import TransferFunction

    s = renderer.values
    diag = float(np.linalg.norm(np.ptp(renderer.vol.points, axis=0)))
    tf = TransferFunction.ramp(s.min(), s.max(), cmap=cmap, opacity=(opacity_low, opacity_high), unit=diag / 20)
    plot_shell_render(renderer, tf, step=diag / surfaces)
    plt.tight_layout()
    plt.show()


def _slice_polys(vol, origin, normal):
    """Triangles of the slice of ``vol`` by a plane, in 2D plane coordinates, and the 2D basis."""
    grid = vol.to_pyvista()
    sl = grid.slice(normal=normal, origin=origin).triangulate()
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    ref = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    a = ref - (ref @ n) * n  # the x axis seen along the normal (x right, y up for a z slice)
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    sl = sl.clean()
    rel = np.asarray(sl.points) - origin
    xy = np.column_stack([rel @ a, rel @ b])
    tris = np.asarray(sl.faces).reshape(-1, 4)[:, 1:]
    e1, e2 = xy[tris[:, 1]] - xy[tris[:, 0]], xy[tris[:, 2]] - xy[tris[:, 0]]
    area = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    tris = tris[area > 1e-12 * float(np.ptp(xy)) ** 2]  # slivers where the plane grazes a cell
    return xy, tris, sl, (a, b)


def plot_fig_7_8(vol, *, field=None, eye_2d=(-1.5, 0.5), n_rays=7, step=0.25, spread=0.22, axes=None):
    """Fig. 7.8 on a slice of our data: (a) ray casting, (b) splatting, (c) equi-distance surfaces.

    The slice through the middle of ``vol`` (normal z) is drawn with its
    scalar; (a) samples at equal spacing along each ray, (b) the nodes
    splatted in data order (spacing along a line of sight uneven), (c) the
    circles of equal distance from the eye (isolines of (7.3) in the slice)
    and the samples where the rays cross them: the same as (a).
    """
    import matplotlib.pyplot as plt
    import matplotlib.tri as mtri

    lo, hi = vol.points.min(0), vol.points.max(0)
    centre = (lo + hi) / 2
    xy, tris, sl, (ax_a, ax_b) = _slice_polys(vol, centre, (0, 0, 1))
    s = np.asarray(sl.point_data[field or next(iter(vol.fields))])
    tri = mtri.Triangulation(xy[:, 0], xy[:, 1], tris)
    if axes is None:
        _, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    eye = np.array(eye_2d) * (hi - lo)[:2] / 2 + np.array([0.0, 0.0])
    far = np.abs(xy).max() * 2.5
    angles = np.linspace(-spread, spread, n_rays)

    def inside(p2):  # in material: the volume's own point location
        return vol.locate(centre + p2[:, :1] * ax_a + p2[:, 1:] * ax_b) >= 0

    dist = np.hypot(xy[:, 0] - eye[0], xy[:, 1] - eye[1])
    titles = ["(a) ray casting", "(b) splatting", "(c) equi-distance surfaces"]
    for k, ax in enumerate(axes):
        ax.tripcolor(tri, s, cmap="viridis", alpha=0.35, shading="gouraud")
        ax.triplot(tri, color="0.75", lw=0.2)
        ax.plot(*eye, "r^", ms=9)
        ax.set_aspect("equal")
        ax.set_title(titles[k])
        ax.set_xticks([])
        ax.set_yticks([])
        direction = -eye / np.linalg.norm(eye)
        base = np.arctan2(direction[1], direction[0])
        for a in angles:
            d = np.array([np.cos(base + a), np.sin(base + a)])
            if k != 1:
                ax.plot([eye[0], eye[0] + far * d[0]], [eye[1], eye[1] + far * d[1]], color="0.4", lw=0.6)
            if k in (0, 2):
                t = np.arange(0, far, step)
                p = eye + t[:, None] * d
                keep = inside(p)
                ax.plot(p[keep, 0], p[keep, 1], "o", ms=3, color="crimson" if k == 0 else "navy")
        if k == 1:
            ax.scatter(xy[:, 0], xy[:, 1], s=30, c=s, cmap="viridis", alpha=0.5, edgecolors="none")
            ax.plot(*np.stack([eye, eye + far * direction]).T, color="0.4", lw=0.6)
        if k == 2:
            ax.tricontour(tri, dist, levels=np.arange(0, dist.max() + step, step), colors="navy", linewidths=0.5)
        ax.set_xlim(xy[:, 0].min() - 0.1, xy[:, 0].max() + 0.1)
        ax.set_ylim(xy[:, 1].min() - 0.1, xy[:, 1].max() + 0.1)
    return axes


def plot_fig_7_9(vol, renderers, *, titles=None, window_size=(1300, 480)):
    """Fig. 7.9: extrema of the distance from the eye and the skeleton joining them, one panel per renderer.

    ``renderers``: :class:`~polygen.volume.render.ShellRenderer` objects (eye
    inside the volume, eye outside). The skeleton's cells are coloured by
    their distance from the eye, the extrema are purple, the eye red.
    """
    import pyvista as pv

    n = len(renderers)
    p = _plotter(shape=(1, n), window_size=window_size)
    for i, sr in enumerate(renderers):
        p.subplot(0, i)
        sk = sr.skeleton
        p.add_mesh(boundary_mesh(vol), color="lightgray", opacity=0.12)
        cells = vol.to_pyvista().extract_cells(sk.cells)
        # (not "distance": the data sets carry a point field of that name, which pyvista would pick)
        cells.cell_data["eye distance"] = sr.distance[vol.cells[sk.cells]].mean(axis=1)
        # a bar per panel, beside the picture, not over its lower extrema; pyvista keys bars by title,
        # so the titles differ by trailing spaces
        p.add_mesh(cells, scalars="eye distance", preference="cell", cmap="plasma", show_edges=False,
                   scalar_bar_args={"title": "distance" + " " * i, "vertical": True, "position_x": 0.88,
                                    "position_y": 0.12, "height": 0.7, "width": 0.05, "fmt": "%.2f"})
        p.add_mesh(pv.PolyData(vol.points[sk.extrema.nodes]), color=_EXTREMUM_COLOR, point_size=12,
                   render_points_as_spheres=True)
        eye = np.array(sr.camera.eye)
        size = float(np.ptp(vol.points, axis=0).max())
        p.add_mesh(pv.Sphere(radius=0.03 * size, center=eye), color="red")
        f = np.array(sr.camera.target) - eye
        p.add_mesh(pv.Arrow(start=eye, direction=f, scale=0.15 * size), color="red")
        label = (titles[i] if titles else
                 f"eye {'inside' if vol.locate(eye[None])[0] >= 0 else 'outside'}: {sk.extrema.n} extrema, "
                 f"{sk.n_cells} skeleton cells")
        p.add_text(label, font_size=10)
        p.view_isometric()
        p.reset_camera()
    return p


def plot_comparison(images, titles, *, diff_gain=10.0, axes=None):
    """Images side by side, then ``diff_gain`` times the absolute difference of the first two."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(1, len(images) + 1, figsize=(3.6 * (len(images) + 1), 3.6))
    for ax, img, t in zip(axes, images, titles):
        ax.imshow(np.clip(img, 0, 1))
        ax.set_title(t, fontsize=9)
        ax.axis("off")
    d = np.abs(np.asarray(images[0]) - np.asarray(images[1])).max(axis=-1)
    axes[-1].imshow(np.clip(d * diff_gain, 0, 1), cmap="gray")
    axes[-1].set_title(f"|difference| x {diff_gain:g} (max {d.max():.3f})", fontsize=9)
    axes[-1].axis("off")
    return axes
