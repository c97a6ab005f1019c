"""The hemicube (thesis 2.2.1; Cohen & Greenberg 1985).

Five z-buffers -- the top face (res x res) and four half side faces
(res x res/2) of a unit hemicube around a point -- receive the projections
of all triangles.  Each pixel carries a *delta form factor*; the form factor
from the point to a triangle is the sum over the pixels where it is the
nearest surface:

    top face  (x, y, 1):      dF = dA / (pi (x^2 + y^2 + 1)^2)
    side face (x, 1, z):      dF = z dA / (pi (x^2 + z^2 + 1)^2)

The delta form factors are normalised to sum to 1, so a closed scene
conserves energy exactly.  Rasterisation is a numba z-buffer kernel with
one thread per face.  Triangles seen from behind occlude but receive
nothing; at equal depth a front face wins over a back face, so two-sided
objects made of back-to-back polygons behave.
"""

from __future__ import annotations

import math

import numpy as np

from polygen._jit import njit, prange

__all__ = ["HemicubeError", "delta_form_factors", "hemicube_form_factors", "hemicube_column",
           "hemicube_polygon_form_factor", "plane_frame"]


class HemicubeError(ValueError):
    """Bad input to the hemicube."""


@njit
def _delta_kernel(res, top, side):
    d = 2.0 / res
    for j in range(res):
        y = -1.0 + (j + 0.5) * d
        for i in range(res):
            x = -1.0 + (i + 0.5) * d
            r2 = x * x + y * y + 1.0
            top[j, i] = d * d / (math.pi * r2 * r2)
    for j in range(res // 2):
        z = (j + 0.5) * d
        for i in range(res):
            x = -1.0 + (i + 0.5) * d
            r2 = x * x + z * z + 1.0
            side[j, i] = z * d * d / (math.pi * r2 * r2)


def delta_form_factors(res, *, normalise=True):
    """Delta form factors of the hemicube faces.

    Parameters
    ----------
    res : int
        Even resolution of the top face.
    normalise : bool, keyword-only
        Scale so that all five faces sum to exactly 1.

    Returns
    -------
    top : (res, res) float64
    side : (res // 2, res) float64
        One side face; rows go up from the base plane.
    """
    res = int(res)
    if res < 2 or res % 2:
        raise HemicubeError(f"hemicube resolution must be an even integer >= 2, got {res}")
    top = np.empty((res, res))
    side = np.empty((res // 2, res))
    _delta_kernel(res, top, side)
    if normalise:
        s = top.sum() + 4.0 * side.sum()
        top /= s
        side /= s
    return top, side


@njit
def _raster_tri(ax, ay, aw, bx, by, bw, cx, cy, cw, rows, res, e, zbuf, ids):
    area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    if area == 0.0:
        return
    if area < 0.0:
        bx, by, bw, cx, cy, cw = cx, cy, cw, bx, by, bw
        area = -area
    i0 = max(int(math.floor(min(ax, bx, cx) - 0.5)), 0)
    i1 = min(int(math.ceil(max(ax, bx, cx) - 0.5)), res - 1)
    j0 = max(int(math.floor(min(ay, by, cy) - 0.5)), 0)
    j1 = min(int(math.ceil(max(ay, by, cy) - 0.5)), rows - 1)
    inv = 1.0 / area
    # pixel centres on a shared edge (room corners seen from a symmetric point) must not fall
    # between both triangles through round-off: accept 1e-7 pixel outside each edge
    t0 = -1e-7 * math.hypot(cx - bx, cy - by)
    t1 = -1e-7 * math.hypot(ax - cx, ay - cy)
    t2 = -1e-7 * math.hypot(bx - ax, by - ay)
    for j in range(j0, j1 + 1):
        py = j + 0.5
        for i in range(i0, i1 + 1):
            px = i + 0.5
            w0 = (bx - px) * (cy - py) - (by - py) * (cx - px)
            if w0 < t0:
                continue
            w1 = (cx - px) * (ay - py) - (cy - py) * (ax - px)
            if w1 < t1:
                continue
            w2 = (ax - px) * (by - py) - (ay - py) * (bx - px)
            if w2 < t2:
                continue
            w = (w0 * aw + w1 * bw + w2 * cw) * inv  # 1/depth is affine on the screen
            if w > zbuf[j, i]:
                zbuf[j, i] = w
                ids[j, i] = e


@njit(parallel=True)
def _hemicube_parallel(centre, frame, nodes, tris, tri_normal, tri_centroid, skip, near, res,
                       dtop, dside, out, items):
    for f in prange(5):
        _hemicube_face(f, centre, frame, nodes, tris, tri_normal, tri_centroid, skip, near, res,
                       dtop, dside, out, items)


@njit
def _hemicube_serial(centre, frame, nodes, tris, tri_normal, tri_centroid, skip, near, res,
                     dtop, dside, out, items):
    for f in range(5):
        _hemicube_face(f, centre, frame, nodes, tris, tri_normal, tri_centroid, skip, near, res,
                       dtop, dside, out, items)


@njit
def _hemicube_face(f, centre, frame, nodes, tris, tri_normal, tri_centroid, skip, near, res,
                   dtop, dside, out, items):
    """out[f, t]: summed delta form factors of triangle t on face f (5, T);
    items[f]: the item buffer of face f (5, res, res), -1 where nothing is seen."""
    nt = tris.shape[0]
    if f == 0:
        right, up, fwd = frame[0], frame[1], frame[2]
    elif f == 1:
        right, up, fwd = frame[1], frame[2], frame[0]
    elif f == 2:
        right, up, fwd = frame[1], frame[2], -frame[0]
    elif f == 3:
        right, up, fwd = frame[0], frame[2], frame[1]
    else:
        right, up, fwd = frame[0], frame[2], -frame[1]
    rows = res if f == 0 else res // 2
    zbuf = np.zeros((rows, res))
    ids = items[f]
    ids[:] = -1
    q = np.empty((3, 3))
    clip = np.empty((4, 3))
    for t in range(nt):
        if skip[t]:
            continue
        for k in range(3):
            p = tris[t, k]
            d0 = nodes[p, 0] - centre[0]
            d1 = nodes[p, 1] - centre[1]
            d2 = nodes[p, 2] - centre[2]
            q[k, 0] = d0 * right[0] + d1 * right[1] + d2 * right[2]
            q[k, 1] = d0 * up[0] + d1 * up[1] + d2 * up[2]
            q[k, 2] = d0 * fwd[0] + d1 * fwd[1] + d2 * fwd[2]
        # reject by the planes of the face's frustum (valid for any depth sign)
        if q[0, 2] < near and q[1, 2] < near and q[2, 2] < near:
            continue
        if q[0, 0] > q[0, 2] and q[1, 0] > q[1, 2] and q[2, 0] > q[2, 2]:
            continue
        if q[0, 0] < -q[0, 2] and q[1, 0] < -q[1, 2] and q[2, 0] < -q[2, 2]:
            continue
        if q[0, 1] > q[0, 2] and q[1, 1] > q[1, 2] and q[2, 1] > q[2, 2]:
            continue
        if f == 0:
            if q[0, 1] < -q[0, 2] and q[1, 1] < -q[1, 2] and q[2, 1] < -q[2, 2]:
                continue
        elif q[0, 1] <= 0.0 and q[1, 1] <= 0.0 and q[2, 1] <= 0.0:
            continue
        # clip against the near plane fwd >= near (Sutherland-Hodgman, one plane)
        nc = 0
        for k in range(3):
            k2 = (k + 1) % 3
            za, zb = q[k, 2], q[k2, 2]
            if za >= near:
                clip[nc, 0] = q[k, 0]
                clip[nc, 1] = q[k, 1]
                clip[nc, 2] = za
                nc += 1
            if (za >= near) != (zb >= near):
                s = (near - za) / (zb - za)
                clip[nc, 0] = q[k, 0] + s * (q[k2, 0] - q[k, 0])
                clip[nc, 1] = q[k, 1] + s * (q[k2, 1] - q[k, 1])
                clip[nc, 2] = near
                nc += 1
        if nc < 3:
            continue
        # a triangle seen from its back occludes, but loses depth ties to front faces
        facing = 0.0
        for c in range(3):
            facing += tri_normal[t, c] * (centre[c] - tri_centroid[t, c])
        bias = 1.0 if facing > 0.0 else 1.0 - 1e-9
        half = 0.5 * res
        for k in range(nc):
            w = 1.0 / clip[k, 2]
            clip[k, 0] = (clip[k, 0] * w + 1.0) * half
            if f == 0:
                clip[k, 1] = (clip[k, 1] * w + 1.0) * half
            else:
                clip[k, 1] = clip[k, 1] * w * half
            clip[k, 2] = w * bias
        for k in range(1, nc - 1):
            _raster_tri(clip[0, 0], clip[0, 1], clip[0, 2], clip[k, 0], clip[k, 1], clip[k, 2],
                        clip[k + 1, 0], clip[k + 1, 1], clip[k + 1, 2], rows, res, t, zbuf, ids)
    dff = dtop if f == 0 else dside
    for j in range(rows):
        for i in range(res):
            t = ids[j, i]
            if t < 0:
                continue
            facing = 0.0
            for c in range(3):
                facing += tri_normal[t, c] * (centre[c] - tri_centroid[t, c])
            if facing > 0.0:
                out[f, t] += dff[j, i]


def plane_frame(normal):
    """An orthonormal frame (3, 3): rows u, v, n with n = normal."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(a, n)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u), n])


def hemicube_form_factors(centre, normal, nodes, triangles, *, resolution=100, frame=None,
                          skip=None, normalise=True, near=None, delta=None, return_items=False):
    """Form factors from a point to triangles by the hemicube.

    Parameters
    ----------
    centre : (3,) float64
        Where the hemicube stands.
    normal : (3,) float64
        Its axis (the surface normal at ``centre``).
    nodes : (N, 3) float64
    triangles : (T, 3) int64
        The front of a triangle is counter-clockwise (right-hand normal);
        triangles seen from behind occlude but get no form factor.
    resolution : int, keyword-only
        Even top-face resolution.
    frame : (3, 3) float64, keyword-only
        Rows u, v, n of the hemicube; default from :func:`plane_frame`.
    skip : (T,) bool, keyword-only
        Triangles to leave out (the surface the hemicube stands on).
    normalise : bool, keyword-only
        Normalise the delta form factors to sum to 1.
    near : float, keyword-only
        Near-plane distance; default 1e-7 of the scene's extent.
    delta : (top, side), keyword-only
        Precomputed :func:`delta_form_factors`.
    return_items : bool, keyword-only
        Also return the item buffers.

    Returns
    -------
    (T,) float64
        F(point -> triangle).
    items : (5, res, res) int64, only with ``return_items``
        Triangle seen at each pixel (-1: nothing) on the top face (0) and the
        side faces +u, -u, +v, -v (1-4; only the first res/2 rows, from the
        base upwards, are used).
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    tris = np.ascontiguousarray(triangles, dtype=np.int64)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise HemicubeError(f"nodes must be (N, 3), got {nodes.shape}")
    if tris.ndim != 2 or tris.shape[1] != 3:
        raise HemicubeError(f"triangles must be (T, 3), got {tris.shape}")
    if tris.size and (tris.min() < 0 or tris.max() >= len(nodes)):
        raise HemicubeError("triangles index nodes out of range")
    if frame is None:
        frame = plane_frame(normal)
    frame = np.ascontiguousarray(frame, dtype=np.float64)
    if delta is None:
        delta = delta_form_factors(resolution, normalise=normalise)
    dtop, dside = delta
    res = dtop.shape[0]
    t = nodes[tris]
    cr = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    nrm = np.linalg.norm(cr, axis=1)
    tri_normal = np.ascontiguousarray(cr / np.where(nrm > 0, nrm, 1.0)[:, None])
    return _hemicube_raw(np.asarray(centre, dtype=np.float64), frame, nodes, tris, tri_normal,
                         np.ascontiguousarray(t.mean(axis=1)), skip, near, dtop, dside, res,
                         return_items)


def hemicube_polygon_form_factor(emitter, receiver, *, resolution=100, order=4):
    """Area-to-area form factor F(emitter -> receiver) by hemicubes on the emitter.

    The hemicube gives point-to-polygon factors; averaging them over the
    emitter (hemicubes at the points of a collapsed Gauss rule of
    ``order**2`` points per emitter triangle) gives the area factor, the
    quantity Howell's catalogue tabulates.  Compare with
    :func:`polygen.radiosity.formfactor.polygon_form_factor` (the same
    average of exact point factors).

    Parameters
    ----------
    emitter, receiver : Polygon
    resolution : int, keyword-only
        Even top-face resolution.
    order : int, keyword-only

    Returns
    -------
    float
    """
    from polygen.radiosity.formfactor import _gauss_triangle
    from polygen.radiosity.mesh import lattice_delaunay_mesher

    def triangulated(poly):
        pts2, tris = lattice_delaunay_mesher(poly.exterior_2d, poly.holes_2d, 10.0 * poly.diameter)
        return poly.to_3d(pts2), tris

    e3, etris = triangulated(emitter)
    r3, rtris = triangulated(receiver)
    bary, w = _gauss_triangle(order)
    tp = e3[etris]
    area = 0.5 * np.linalg.norm(np.cross(tp[:, 1] - tp[:, 0], tp[:, 2] - tp[:, 0]), axis=1)
    qp = np.einsum("qk,tkc->tqc", bary, tp).reshape(-1, 3)
    qw = (area[:, None] * w[None, :]).ravel()
    frame = np.ascontiguousarray(np.stack([emitter.u, emitter.v, emitter.normal]))
    delta = delta_form_factors(resolution)
    f = np.array([hemicube_form_factors(x, emitter.normal, r3, rtris, frame=frame,
                                        delta=delta).sum() for x in qp])
    return float(np.sum(qw * f) / emitter.area)


def _hemicube_raw(centre, frame, nodes, tris, tri_normal, tri_centroid, skip, near, dtop, dside,
                  res, return_items=False, parallel=True):
    if skip is None:
        skip = np.zeros(len(tris), dtype=np.bool_)
    if near is None:
        ext = float(np.ptp(nodes, axis=0).max()) if len(nodes) else 1.0
        near = 1e-7 * ext
    out = np.zeros((5, len(tris)))
    items = np.empty((5, res, res), dtype=np.int64)
    kernel = _hemicube_parallel if parallel else _hemicube_serial
    kernel(np.ascontiguousarray(centre), frame, nodes, tris, tri_normal, tri_centroid,
                     np.ascontiguousarray(skip, dtype=np.bool_), float(near), int(res), dtop, dside,
                     out, items)
    if return_items:
        return out.sum(axis=0), items
    return out.sum(axis=0)


def hemicube_column(mesh, patch, *, delta, near=None, parallel=True):
    """Form factors F(e -> p) of every element to one patch, by a hemicube at the patch centroid.

    The hemicube gives F(p -> e) (from the shooting patch, as in
    progressive refinement, 2.2.2 step 2); reciprocity (2.5) turns it into
    F(e -> p) = A_p F(p -> e) / A_e.

    Parameters
    ----------
    mesh : RadiosityMesh
    patch : int
    delta : (top, side)
        :func:`delta_form_factors` of the wanted resolution.
    parallel : bool, keyword-only
        One thread per hemicube face.

    Returns
    -------
    (M,) float64
    """
    poly = mesh.scene.polygons[int(mesh.patch_polygon[patch])]
    n = mesh.patch_normal[patch]
    # the patch's own normal (the back of a two-sided polygon faces the other way); the
    # polygon's (u, v) keep the pixel grid aligned with its edges, swapped to stay right-handed
    u, v = (poly.u, poly.v) if n @ poly.normal > 0 else (poly.v, poly.u)
    frame = np.ascontiguousarray(np.stack([u, v, n]))
    skip = mesh.element_polygon == mesh.patch_polygon[patch]
    f_pe = _hemicube_raw(mesh.patch_centroid[patch], frame, mesh.nodes, mesh.elements,
                         mesh.element_normal, mesh.element_centroid, skip, near, delta[0], delta[1],
                         delta[0].shape[0], False, parallel)
    return f_pe * (mesh.patch_area[patch] / mesh.element_area)
