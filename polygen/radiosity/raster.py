"""Display of radiosity results: node intensities (2.8), Gouraud and flat z-buffer images.

* :func:`node_intensities` -- (2.8): a node's intensity is the mean of the
  element radiosities around it (the thesis's plain mean; area weighting
  on request).
* :func:`render` -- our own scanline z-buffer rasteriser with a pinhole
  :class:`Camera`.  Gouraud shading interpolates node intensities along
  the triangle's edges and then along each scanline, (2.9) and (2.10);
  flat shading paints each element with its own radiosity.
* :func:`to_pyvista` -- a PolyData with per-vertex colours.

Printed (2.9) divides by (x13 - x12); the interpolation that reproduces
I12 at x = x12 and I13 at x = x13 divides by (x12 - x13), which is what is
implemented.
"""

from __future__ import annotations

import math

import numpy as np

from polygen._jit import njit

__all__ = ["RasterError", "Camera", "node_intensities", "render", "pixel_points", "auto_exposure",
           "tone_map", "to_pyvista"]


class RasterError(ValueError):
    """Bad input to the display routines."""


def node_intensities(mesh, element_values, *, weighting="mean"):
    """Node intensities from element values, (2.8).

    Parameters
    ----------
    mesh : RadiosityMesh
    element_values : (M,) or (M, C) float64
    weighting : {"mean", "area"}, keyword-only
        ``"mean"``: I = (1/n) sum_i I_Ei over the n adjacent elements, as
        (2.8); ``"area"``: weighted by element area.

    Returns
    -------
    (N,) or (N, C) float64
        Nodes that belong to no element get 0.
    """
    vals = np.asarray(element_values, dtype=np.float64)
    squeeze = vals.ndim == 1
    if squeeze:
        vals = vals[:, None]
    if vals.shape[0] != mesh.n_elements:
        raise RasterError(f"element_values must have {mesh.n_elements} rows, got {vals.shape[0]}")
    if weighting not in ("mean", "area"):
        raise RasterError(f"weighting must be 'mean' or 'area', got {weighting!r}")
    w = np.ones(mesh.n_elements) if weighting == "mean" else mesh.element_area
    flat = mesh.elements.ravel()
    ww = np.repeat(w, 3)
    den = np.bincount(flat, weights=ww, minlength=mesh.n_nodes)
    out = np.stack([np.bincount(flat, weights=ww * np.repeat(vals[:, c], 3),
                                minlength=mesh.n_nodes) for c in range(vals.shape[1])], axis=1)
    out /= np.where(den > 0, den, 1.0)[:, None]
    return out[:, 0] if squeeze else out


class Camera:
    """A pinhole camera.

    Parameters
    ----------
    position : (3,) float64
    look_at : (3,) float64
    up : (3,) float64
    fov : float
        Vertical field of view in degrees.
    width, height : int
        Image size in pixels.
    near : float
        Near clipping distance.
    """

    def __init__(self, position, look_at, *, up=(0.0, 1.0, 0.0), fov=40.0, width=256, height=256,
                 near=1e-3):
        self.position = np.asarray(position, dtype=np.float64).reshape(3)
        look_at = np.asarray(look_at, dtype=np.float64).reshape(3)
        f = look_at - self.position
        if np.linalg.norm(f) == 0:
            raise RasterError("camera position and look_at coincide")
        f /= np.linalg.norm(f)
        r = np.cross(f, np.asarray(up, dtype=np.float64))
        if np.linalg.norm(r) < 1e-12:
            raise RasterError("camera up is parallel to the view direction")
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        self.forward, self.right, self.up = f, r, u
        if not 0 < fov < 180:
            raise RasterError(f"fov must be in (0, 180) degrees, got {fov}")
        self.fov = float(fov)
        self.width, self.height = int(width), int(height)
        if self.width < 1 or self.height < 1:
            raise RasterError(f"image size must be positive, got {self.width} x {self.height}")
        self.near = float(near)
        # focal length in pixels
        self.focal = 0.5 * self.height / math.tan(math.radians(0.5 * self.fov))

    @classmethod
    def cornell(cls, *, width=256, height=256):
        """The published Cornell box camera (at z = -800 mm, 39.3 degrees)."""
        return cls([278.0, 273.0, -800.0], [278.0, 273.0, 0.0], fov=39.3, width=width,
                   height=height, near=1.0)

    def view_matrix(self):
        """(3, 3) rows right, up, forward."""
        return np.stack([self.right, self.up, self.forward])

    def project(self, points):
        """Screen coordinates (n, 2) (x right, y down, pixel centres at +0.5) and depth (n,)."""
        q = (np.asarray(points, dtype=np.float64) - self.position) @ self.view_matrix().T
        sx = 0.5 * self.width + self.focal * q[:, 0] / q[:, 2]
        sy = 0.5 * self.height - self.focal * q[:, 1] / q[:, 2]
        return np.stack([sx, sy], axis=1), q[:, 2]


@njit
def _scan_triangle(x1, y1, z1, i1, x2, y2, z2, i2, x3, y3, z3, i3, width, height, tri,
                   zbuf, image, ids):
    """Scanline fill of one screen triangle with Gouraud interpolation, (2.9) and (2.10).

    (x, y): screen position with y growing upwards (so y1 >= y2 >= y3 as in
    the thesis); z: 1/depth, affine on the screen, for the z-buffer;
    i*: (C,) intensities.
    """
    # sort so that y1 >= y2 >= y3
    if y1 < y2:
        x1, y1, z1, i1, x2, y2, z2, i2 = x2, y2, z2, i2, x1, y1, z1, i1
    if y2 < y3:
        x2, y2, z2, i2, x3, y3, z3, i3 = x3, y3, z3, i3, x2, y2, z2, i2
    if y1 < y2:
        x1, y1, z1, i1, x2, y2, z2, i2 = x2, y2, z2, i2, x1, y1, z1, i1
    if y1 == y3:
        return
    nc = i1.shape[0]
    i13 = np.empty(nc)
    ie = np.empty(nc)
    # rows whose centre (row index r, y = height - r - 0.5) is in [y3, y1)
    r_lo = max(int(math.ceil(height - y1 - 0.5)), 0)
    r_hi = min(int(math.floor(height - y3 - 0.5)), height - 1)
    for r in range(r_lo, r_hi + 1):
        y = height - r - 0.5
        if y >= y1 or y < y3:
            continue
        # long edge 1-3
        x13 = ((y1 - y) * x3 + (y - y3) * x1) / (y1 - y3)
        z13 = ((y1 - y) * z3 + (y - y3) * z1) / (y1 - y3)
        for c in range(nc):
            i13[c] = ((y1 - y) * i3[c] + (y - y3) * i1[c]) / (y1 - y3)
        if y > y2:  # (2.9): short edge 1-2
            xe = ((y1 - y) * x2 + (y - y2) * x1) / (y1 - y2)
            ze = ((y1 - y) * z2 + (y - y2) * z1) / (y1 - y2)
            for c in range(nc):
                ie[c] = ((y1 - y) * i2[c] + (y - y2) * i1[c]) / (y1 - y2)
        else:  # (2.10): short edge 2-3
            if y2 == y3:
                continue
            xe = ((y2 - y) * x3 + (y - y3) * x2) / (y2 - y3)
            ze = ((y2 - y) * z3 + (y - y3) * z2) / (y2 - y3)
            for c in range(nc):
                ie[c] = ((y2 - y) * i3[c] + (y - y3) * i2[c]) / (y2 - y3)
        if xe == x13:
            continue
        xl = min(xe, x13)
        xr = max(xe, x13)
        # pixel centres x = col + 0.5 in [xl, xr)
        c_lo = max(int(math.ceil(xl - 0.5)), 0)
        c_hi = min(int(math.ceil(xr - 0.5)) - 1, width - 1)
        inv = 1.0 / (xe - x13)
        for col in range(c_lo, c_hi + 1):
            x = col + 0.5
            # I = ((xe - x) I13 + (x - x13) Ie) / (xe - x13)
            a = (xe - x) * inv
            b = (x - x13) * inv
            z = a * z13 + b * ze
            if z > zbuf[r, col]:
                zbuf[r, col] = z
                ids[r, col] = tri
                for c in range(nc):
                    image[r, col, c] = a * i13[c] + b * ie[c]


@njit
def _render_kernel(q, tris, skip, colors, flat, focal, width, height, near, zbuf, image, ids):
    """q: (N, 3) camera coordinates; colors: node colours (N, C) or element colours (M, C)."""
    nc = colors.shape[1]
    cq = np.empty((4, 3))
    cc = np.empty((4, nc))
    sx = np.empty(4)
    sy = np.empty(4)
    sz = np.empty(4)
    for t in range(tris.shape[0]):
        if skip[t]:
            continue
        a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
        if q[a, 2] < near and q[b, 2] < near and q[c, 2] < near:
            continue
        # clip against the near plane, carrying the intensities (Gouraud is linear in 3D too)
        n = 0
        for k in range(3):
            p0 = tris[t, k]
            p1 = tris[t, (k + 1) % 3]
            za, zb = q[p0, 2], q[p1, 2]
            if za >= near:
                for d in range(3):
                    cq[n, d] = q[p0, d]
                for d in range(nc):
                    cc[n, d] = colors[t, d] if flat else colors[p0, d]
                n += 1
            if (za >= near) != (zb >= near):
                s = (near - za) / (zb - za)
                for d in range(3):
                    cq[n, d] = q[p0, d] + s * (q[p1, d] - q[p0, d])
                for d in range(nc):
                    if flat:
                        cc[n, d] = colors[t, d]
                    else:
                        cc[n, d] = colors[p0, d] + s * (colors[p1, d] - colors[p0, d])
                n += 1
        for k in range(n):
            w = 1.0 / cq[k, 2]
            sx[k] = 0.5 * width + focal * cq[k, 0] * w
            sy[k] = 0.5 * height + focal * cq[k, 1] * w  # y up, as in (2.9)
            sz[k] = w
        for k in range(1, n - 1):
            _scan_triangle(sx[0], sy[0], sz[0], cc[0], sx[k], sy[k], sz[k], cc[k],
                           sx[k + 1], sy[k + 1], sz[k + 1], cc[k + 1], width, height, t,
                           zbuf, image, ids)


def render(nodes, triangles, colors, camera, *, shading="gouraud", background=0.0,
           cull_back_faces=True, return_ids=False):
    """Rasterise triangles with a z-buffer: Gouraud (2.9, 2.10) or flat shading.

    Parameters
    ----------
    nodes : (N, 3) float64
    triangles : (M, 3) int64
    colors : (N, C) float64 for ``"gouraud"`` (node intensities) or
        (M, C) float64 for ``"flat"`` (element values); (N,)/(M,) is C = 1.
    camera : Camera
    shading : {"gouraud", "flat"}, keyword-only
    background : float or (C,), keyword-only
    cull_back_faces : bool, keyword-only
        Skip triangles seen from behind (their front is counter-clockwise,
        as in a RadiosityMesh).  Radiosity polygons are one-sided, so this
        shows each side of a two-sided object with its own radiosity, and
        makes room walls transparent from outside (a cut-away view).
    return_ids : bool, keyword-only
        Also return the (H, W) int64 index of the triangle seen at each
        pixel (-1 for background).

    Returns
    -------
    image : (H, W, C) float64
        Row 0 is the top of the image.  Values are not tone-mapped.
    ids : (H, W) int64, only with ``return_ids``
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    tris = np.ascontiguousarray(triangles, dtype=np.int64)
    cols = np.asarray(colors, dtype=np.float64)
    if cols.ndim == 1:
        cols = cols[:, None]
    cols = np.ascontiguousarray(cols)
    if shading not in ("gouraud", "flat"):
        raise RasterError(f"shading must be 'gouraud' or 'flat', got {shading!r}")
    flat = shading == "flat"
    want = len(tris) if flat else len(nodes)
    if cols.shape[0] != want:
        raise RasterError(f"{shading} shading needs {want} colour rows "
                          f"({'elements' if flat else 'nodes'}), got {cols.shape[0]}")
    if tris.size and (tris.min() < 0 or tris.max() >= len(nodes)):
        raise RasterError("triangles index nodes out of range")
    q = np.ascontiguousarray((nodes - camera.position) @ camera.view_matrix().T)
    h, w = camera.height, camera.width
    zbuf = np.zeros((h, w))
    image = np.empty((h, w, cols.shape[1]))
    image[:] = np.broadcast_to(np.asarray(background, dtype=np.float64), (cols.shape[1],))
    ids = np.full((h, w), -1, dtype=np.int64)
    if cull_back_faces and len(tris):
        t = nodes[tris]
        nrm = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        skip = np.einsum("ij,ij->i", nrm, camera.position - t[:, 0]) <= 0.0
    else:
        skip = np.zeros(len(tris), dtype=np.bool_)
    _render_kernel(q, tris, np.ascontiguousarray(skip), cols, flat, camera.focal, w, h,
                   camera.near, zbuf, image, ids)
    return (image, ids) if return_ids else image


def pixel_points(mesh, camera):
    """The surface point each pixel shows, for evaluating a quantity exactly per pixel.

    Each pixel centre's ray is intersected with the plane of the element
    that :func:`render` shows there (back faces culled, as it does).

    Parameters
    ----------
    mesh : RadiosityMesh
    camera : Camera

    Returns
    -------
    covered : (H, W) bool
        Pixels showing an element.
    element : (P,) int64
        The element seen at each covered pixel, in row-major pixel order.
    point : (P, 3) float64
        The point on that element's plane.
    """
    _, ids = render(mesh.nodes, mesh.elements, np.zeros(mesh.n_nodes), camera, return_ids=True)
    h, w = ids.shape
    r, c = np.mgrid[0:h, 0:w]
    q = np.stack([(c + 0.5 - 0.5 * w) / camera.focal, (0.5 * h - (r + 0.5)) / camera.focal,
                  np.ones((h, w))], -1)
    covered = ids >= 0
    e, d = ids[covered], (q @ camera.view_matrix())[covered]
    n, x0 = mesh.element_normal[e], mesh.element_centroid[e]
    t = ((x0 - camera.position) * n).sum(1) / (d * n).sum(1)
    return covered, e, camera.position + t[:, None] * d


def auto_exposure(image, *, percentile=99.0):
    """The exposure that maps the ``percentile`` of an image's finite values to 1.

    Parameters
    ----------
    image : array_like of float64
        Linear radiosity (an image, or node colours); NaN (background) ignored.
    percentile : float, keyword-only

    Returns
    -------
    float
        1 for an image that is black everywhere.
    """
    img = np.asarray(image, dtype=np.float64)
    img = img[np.isfinite(img)]
    p = float(np.percentile(img, percentile)) if img.size else 0.0
    return 1.0 / p if p > 0 else 1.0


def tone_map(image, *, exposure=None, gamma="srgb"):
    """Map linear radiosity to displayable [0, 1] values.

    Parameters
    ----------
    image : (H, W, C) float64
    exposure : float, keyword-only
        Multiplier; default :func:`auto_exposure` (the 99th percentile to 1).
    gamma : "srgb" or float, keyword-only
        ``"srgb"``: the sRGB transfer function (IEC 61966-2-1: linear below
        0.0031308, then ``1.055 x**(1/2.4) - 0.055``); a number: ``x**(1/gamma)``.

    Returns
    -------
    (H, W, C) float64 in [0, 1]
        NaN (background) stays NaN.
    """
    img = np.asarray(image, dtype=np.float64)
    if exposure is None:
        exposure = auto_exposure(img)
    x = np.clip(img * exposure, 0.0, 1.0)
    if isinstance(gamma, str):
        if gamma != "srgb":
            raise RasterError(f"gamma must be 'srgb' or a number, got {gamma!r}")
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    if not gamma > 0:
        raise RasterError(f"gamma must be > 0, got {gamma}")
    return x ** (1.0 / gamma)


def to_pyvista(mesh, node_colors, *, name="radiosity", exposure=None):
    """A pyvista PolyData of the elements with per-vertex colours.

    Parameters
    ----------
    mesh : RadiosityMesh
    node_colors : (N, 3) float64
        Node intensities, e.g. from :func:`node_intensities`.
    exposure : float, keyword-only
        Exposure of the tone-mapped colours (default :func:`auto_exposure`
        of the node colours); pass the exposure of a rendered image to
        make both look alike.

    Returns
    -------
    pyvista.PolyData
        ``point_data[name]`` holds the colours, ``point_data["rgb"]`` the
        tone-mapped uint8 sRGB colours, and
        ``cell_data["patch"]`` the owning patch.  Radiosity is the light
        leaving a surface already: show it unlit, ``add_mesh(pd,
        scalars="rgb", rgb=True, lighting=False)``, or VTK's lights darken
        it a second time.
    """
    import pyvista as pv

    c = np.asarray(node_colors, dtype=np.float64)
    if c.shape[0] != mesh.n_nodes:
        raise RasterError(f"node_colors must have {mesh.n_nodes} rows, got {c.shape[0]}")
    faces = np.hstack([np.full((mesh.n_elements, 1), 3, dtype=np.int64), mesh.elements]).ravel()
    pd = pv.PolyData(mesh.nodes.copy(), faces)
    pd.point_data[name] = c
    if c.ndim == 2 and c.shape[1] == 3:
        pd.point_data["rgb"] = (tone_map(c[None], exposure=exposure)[0] * 255.0 + 0.5).astype(np.uint8)
    pd.cell_data["patch"] = mesh.element_patch
    return pd
