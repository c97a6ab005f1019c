"""Analytic form factors (Lambert's contour integral) and ray-cast visibility.

The form factor from a differential area dA at x with unit normal n to a
polygon A is Lambert's contour integral (Hottel & Sarofim; Baum, Rushmeier
& Winget 1989)::

    F(dA -> A) = 1/(2 pi) * sum over edges (v_i, v_i+1) of  theta_i * n . g_i,
    r_i = v_i - x,  theta_i = angle(r_i, r_i+1),  g_i = unit(r_i x r_i+1)

summed over the outer ring and the holes (holes run the other way).  The
polygon is first clipped to the half-space in front of dA (Sutherland-
Hodgman on each ring; the edges this adds lie in the tangent plane and
count like the others).

Visibility between an element and a patch is estimated by casting segments
from the element centroid to sample points on the patch against the scene
polygons (not the mesh), so it does not depend on the mesh resolution.

This module gives the *element -> patch* factors F(e -> p) that the
progressive-refinement shooter needs (see :mod:`polygen.radiosity.solve`):
the element's radiosity gains ``rho_e * dB_p * F(e -> p)`` when patch p
shoots, which is (2.7) written with reciprocity (2.5).
"""

from __future__ import annotations

import math

import numpy as np

from polygen._jit import njit, prange

__all__ = [
    "FormFactorError",
    "PackedPolygons",
    "pack_polygons",
    "point_polygon_form_factor",
    "polygon_form_factor",
    "triangle_samples",
    "analytic_column",
    "segments_visible",
    "direct_irradiance",
]


class FormFactorError(ValueError):
    """Bad input to a form-factor routine."""


# ----------------------------------------------------------------------------
# kernels
# ----------------------------------------------------------------------------
@njit
def _edge_term(x, n, a0, a1, a2, b0, b1, b2):
    """theta * n . unit(ra x rb) for one edge a-b seen from x; 0 for a degenerate edge."""
    ra0, ra1, ra2 = a0 - x[0], a1 - x[1], a2 - x[2]
    rb0, rb1, rb2 = b0 - x[0], b1 - x[1], b2 - x[2]
    c0 = ra1 * rb2 - ra2 * rb1
    c1 = ra2 * rb0 - ra0 * rb2
    c2 = ra0 * rb1 - ra1 * rb0
    cn = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if cn == 0.0:
        return 0.0
    theta = math.atan2(cn, ra0 * rb0 + ra1 * rb1 + ra2 * rb2)
    return theta * (n[0] * c0 + n[1] * c1 + n[2] * c2) / cn


@njit
def _point_rings_ff(x, n, pts, ring_start, r0, r1):
    """Lambert's formula for rings r0..r1-1 of (pts, ring_start), clipped to n.(y-x) >= 0.

    Each ring is clipped by Sutherland-Hodgman, streamed: every output
    vertex closes an edge with the previous one.  The new edges lie in the
    tangent plane and do contribute (n . g = +-1 there).
    """
    total = 0.0
    for r in range(r0, r1):
        s, e = ring_start[r], ring_start[r + 1]
        k = e - s
        have = False
        f0 = f1 = f2 = 0.0
        p0 = p1 = p2 = 0.0
        for i in range(k + 1):
            ia = s + i % k
            ib = s + (i + 1) % k
            a0, a1, a2 = pts[ia, 0], pts[ia, 1], pts[ia, 2]
            b0, b1, b2 = pts[ib, 0], pts[ib, 1], pts[ib, 2]
            da = n[0] * (a0 - x[0]) + n[1] * (a1 - x[1]) + n[2] * (a2 - x[2])
            db = n[0] * (b0 - x[0]) + n[1] * (b1 - x[1]) + n[2] * (b2 - x[2])
            for out in range(2):
                if out == 0:
                    if i == k or da < 0.0:
                        continue
                    q0, q1, q2 = a0, a1, a2
                else:
                    if i == k or (da >= 0.0) == (db >= 0.0):
                        continue
                    t = da / (da - db)
                    q0, q1, q2 = a0 + t * (b0 - a0), a1 + t * (b1 - a1), a2 + t * (b2 - a2)
                if have:
                    total += _edge_term(x, n, p0, p1, p2, q0, q1, q2)
                else:
                    f0, f1, f2 = q0, q1, q2
                    have = True
                p0, p1, p2 = q0, q1, q2
        if have:
            total += _edge_term(x, n, p0, p1, p2, f0, f1, f2)
    return abs(total) / (2.0 * math.pi)


@njit(parallel=True)
def _points_ff_kernel(xs, ns, pts, ring_start, out):
    for i in prange(xs.shape[0]):
        out[i] = _point_rings_ff(xs[i], ns[i], pts, ring_start, 0, ring_start.shape[0] - 1)


@njit
def _point_in_rings(px, py, ring2d, ring_start, r0, r1):
    """Even-odd point-in-polygon over rings r0..r1-1 (outer ring and holes)."""
    inside = False
    for r in range(r0, r1):
        s, e = ring_start[r], ring_start[r + 1]
        k = e - s
        for i in range(k):
            x1, y1 = ring2d[s + i, 0], ring2d[s + i, 1]
            j = s + (i + 1) % k
            x2, y2 = ring2d[j, 0], ring2d[j, 1]
            if (y1 > py) != (y2 > py):
                xc = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
                if px < xc:
                    inside = not inside
    return inside


@njit
def _segment_blocked(a, b, skip1, skip2, origin, pu, pv, pn, bbox, ring2d, ring_start,
                     poly_ring_start, eps):
    """True when the open segment a-b crosses the interior of a scene polygon."""
    for k in range(origin.shape[0]):
        if k == skip1 or k == skip2:
            continue
        da = 0.0
        db = 0.0
        for c in range(3):
            da += pn[k, c] * (a[c] - origin[k, c])
            db += pn[k, c] * (b[c] - origin[k, c])
        if (da > 0.0 and db > 0.0) or (da < 0.0 and db < 0.0) or da == db:
            continue
        t = da / (da - db)
        if t <= eps or t >= 1.0 - eps:
            continue
        qx = 0.0
        qy = 0.0
        for c in range(3):
            q = a[c] + t * (b[c] - a[c]) - origin[k, c]
            qx += q * pu[k, c]
            qy += q * pv[k, c]
        if qx < bbox[k, 0] or qx > bbox[k, 2] or qy < bbox[k, 1] or qy > bbox[k, 3]:
            continue
        if _point_in_rings(qx, qy, ring2d, ring_start, poly_ring_start[k], poly_ring_start[k + 1]):
            return True
    return False


@njit
def _analytic_element(e, tri, ring, pnormal, pcentroid, ppoly, samples, xs, ns, epoly,
                      origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start, eps):
    """F(e -> patch): Lambert's formula at the element centroid times sampled visibility."""
    if epoly[e] == ppoly:
        return 0.0
    # the element must be in front of the patch (one-sided patches)
    side = 0.0
    for c in range(3):
        side += pnormal[c] * (xs[e, c] - pcentroid[c])
    if side <= 0.0:
        return 0.0
    f = _point_rings_ff(xs[e], ns[e], tri, ring, 0, 1)
    if f <= 0.0:
        return 0.0
    ns_ = samples.shape[0]
    seen = 0
    for s in range(ns_):
        if not _segment_blocked(xs[e], samples[s], epoly[e], ppoly, origin, pu, pv, pn, bbox,
                                ring2d, ring_start, poly_ring_start, eps):
            seen += 1
    return f * seen / ns_


@njit(parallel=True)
def _analytic_column_parallel(tri, ring, pnormal, pcentroid, ppoly, samples, xs, ns, epoly,
                              origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start, eps,
                              out):
    for e in prange(xs.shape[0]):
        out[e] = _analytic_element(e, tri, ring, pnormal, pcentroid, ppoly, samples, xs, ns, epoly,
                                   origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start,
                                   eps)


@njit
def _analytic_column_serial(tri, ring, pnormal, pcentroid, ppoly, samples, xs, ns, epoly,
                            origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start, eps,
                            out):
    for e in range(xs.shape[0]):
        out[e] = _analytic_element(e, tri, ring, pnormal, pcentroid, ppoly, samples, xs, ns, epoly,
                                   origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start,
                                   eps)


@njit(parallel=True)
def _visible_kernel(a, b, skip1, skip2, origin, pu, pv, pn, bbox, ring2d, ring_start,
                    poly_ring_start, eps, out):
    for i in prange(a.shape[0]):
        out[i] = not _segment_blocked(a[i], b[i], skip1[i], skip2[i], origin, pu, pv, pn, bbox,
                                      ring2d, ring_start, poly_ring_start, eps)


# ----------------------------------------------------------------------------
# scene packing for the kernels
# ----------------------------------------------------------------------------
class PackedPolygons:
    """Scene polygons as flat arrays for the ray-casting kernels.

    Attributes
    ----------
    origin, u, v, normal : (K, 3) float64
        Plane frame of each polygon.
    bbox : (K, 4) float64
        (umin, vmin, umax, vmax) of each polygon in its plane.
    ring2d : (R, 2) float64
        All ring vertices in plane coordinates.
    ring_start : (n_rings + 1,) int64
        Offsets of the rings in ``ring2d``.
    poly_ring_start : (K + 1,) int64
        Offsets of each polygon's rings in ``ring_start``.
    ring3d : (R, 3) float64
        The same vertices in 3D.
    eps : float
        Segment-parameter tolerance for the end points.
    """

    def __init__(self, polygons, eps=1e-7):
        self.origin = np.array([p.origin for p in polygons], dtype=np.float64).reshape(-1, 3)
        self.u = np.array([p.u for p in polygons], dtype=np.float64).reshape(-1, 3)
        self.v = np.array([p.v for p in polygons], dtype=np.float64).reshape(-1, 3)
        self.normal = np.array([p.normal for p in polygons], dtype=np.float64).reshape(-1, 3)
        rings2, rings3, ring_start, prs = [], [], [0], [0]
        bbox = []
        for p in polygons:
            rs = [p.exterior_2d] + list(p.holes_2d)
            for r in rs:
                rings2.append(r)
                rings3.append(p.to_3d(r))
                ring_start.append(ring_start[-1] + len(r))
            prs.append(prs[-1] + len(rs))
            bbox.append(np.concatenate([p.exterior_2d.min(axis=0), p.exterior_2d.max(axis=0)]))
        self.ring2d = np.ascontiguousarray(np.vstack(rings2), dtype=np.float64)
        self.ring3d = np.ascontiguousarray(np.vstack(rings3), dtype=np.float64)
        self.ring_start = np.asarray(ring_start, dtype=np.int64)
        self.poly_ring_start = np.asarray(prs, dtype=np.int64)
        self.bbox = np.asarray(bbox, dtype=np.float64).reshape(-1, 4)
        self.eps = float(eps)

    def args(self):
        return (self.origin, self.u, self.v, self.normal, self.bbox, self.ring2d, self.ring_start,
                self.poly_ring_start, self.eps)


def pack_polygons(polygons, eps=1e-7):
    """Pack a sequence of :class:`~polygen.radiosity.scene.Polygon` for the kernels."""
    return PackedPolygons(list(polygons), eps=eps)


# ----------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------
def _rings_arrays(rings):
    rings = [np.ascontiguousarray(r, dtype=np.float64) for r in rings]
    for k, r in enumerate(rings):
        if r.ndim != 2 or r.shape[1] != 3 or r.shape[0] < 3:
            raise FormFactorError(f"ring {k} must have shape (k>=3, 3), got {r.shape}")
    start = np.concatenate([[0], np.cumsum([len(r) for r in rings])]).astype(np.int64)
    return np.vstack(rings), start


def point_polygon_form_factor(points, normals, rings):
    """Unoccluded form factor from differential areas to a polygon (Lambert's formula).

    Parameters
    ----------
    points : (3,) or (n, 3) float64
        Positions of the differential areas.
    normals : (3,) or (n, 3) float64
        Their unit normals (the hemisphere they see).
    rings : sequence of (k, 3) float64, or a Polygon
        The polygon: outer ring first, then holes with opposite orientation
        (as :attr:`Polygon.rings` gives them).  Either side may face the
        point; the part behind the point's tangent plane is clipped away.

    Returns
    -------
    float or (n,) float64
        F(dA -> polygon), in [0, 1].
    """
    if hasattr(rings, "rings"):
        rings = rings.rings
    pts, start = _rings_arrays(rings)
    x = np.asarray(points, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    single = x.ndim == 1
    x = np.ascontiguousarray(np.atleast_2d(x))
    n = np.ascontiguousarray(np.broadcast_to(np.atleast_2d(n), x.shape))
    if x.shape[1] != 3:
        raise FormFactorError(f"points must be (n, 3), got {x.shape}")
    nn = np.linalg.norm(n, axis=1)
    if np.any(np.abs(nn - 1.0) > 1e-9):
        raise FormFactorError("normals must be unit vectors")
    out = np.empty(len(x))
    _points_ff_kernel(x, n, pts, start, out)
    return float(out[0]) if single else out


def _gauss_triangle(order):
    """Collapsed (Duffy) Gauss-Legendre rule on the unit triangle: (barycentric (q, 3), weights)."""
    g, w = np.polynomial.legendre.leggauss(int(order))
    g = 0.5 * (g + 1.0)
    w = 0.5 * w
    s, t = np.meshgrid(g, g, indexing="ij")
    ws, wt = np.meshgrid(w, w, indexing="ij")
    # (s, t) in the unit square -> (x, y) = (s, t (1 - s)) in the triangle, Jacobian (1 - s)
    xs = s.ravel()
    ys = (t * (1.0 - s)).ravel()
    wts = (ws * wt * (1.0 - s)).ravel() * 2.0  # weights sum to 1 over the triangle
    bary = np.stack([1.0 - xs - ys, xs, ys], axis=1)
    return bary, wts


def polygon_form_factor(emitter, receiver, *, order=12):
    """Unoccluded area-to-area form factor F(emitter -> receiver) by quadrature.

    Lambert's point formula integrated over the emitter (triangulated) with
    a collapsed Gauss-Legendre rule of ``order**2`` points per triangle::

        F(A_i -> A_j) = 1/A_i  int_{A_i} F(dA -> A_j) dA

    Smooth cases (disjoint polygons) converge very fast; polygons sharing
    an edge have a log singularity there and need a higher ``order``.

    Parameters
    ----------
    emitter, receiver : Polygon
    order : int, keyword-only

    Returns
    -------
    float
    """
    from polygen.radiosity.mesh import lattice_delaunay_mesher

    pts2, tris = lattice_delaunay_mesher(emitter.exterior_2d, emitter.holes_2d,
                                         10.0 * emitter.diameter)
    p3 = emitter.to_3d(pts2)
    bary, w = _gauss_triangle(order)
    tp = p3[tris]  # (T, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(tp[:, 1] - tp[:, 0], tp[:, 2] - tp[:, 0]), axis=1)
    qp = np.einsum("qk,tkc->tqc", bary, tp).reshape(-1, 3)
    qw = (area[:, None] * w[None, :]).ravel()
    # only the front of the receiver receives: seen from behind, the factor is 0
    f = point_polygon_form_factor(qp, np.broadcast_to(emitter.normal, qp.shape), receiver.rings)
    front = (qp - receiver.origin) @ receiver.normal > 0.0
    return float(np.sum(qw * f * front) / emitter.area)


def triangle_samples(level):
    """Barycentric sample points of a triangle: centroids of its 4**level sub-triangles.

    Parameters
    ----------
    level : int >= 0

    Returns
    -------
    (4**level, 3) float64
    """
    from polygen.radiosity.mesh import split_triangles

    pts, tris = split_triangles(np.eye(3), np.array([[0, 1, 2]]), int(level))
    return pts[tris].mean(axis=1)


_TRI_RING = np.array([0, 3], dtype=np.int64)


def analytic_column(mesh, patch, *, packed=None, visibility_level=0, samples=None,
                    parallel=True):
    """Form factors F(e -> p) from every element centroid to one patch.

    Lambert's formula at the element centroid (its hemisphere), times the
    fraction of segments from the centroid to sample points on the patch
    that no scene polygon blocks.

    Parameters
    ----------
    mesh : RadiosityMesh
    patch : int
    packed : PackedPolygons, optional
        ``pack_polygons(mesh.scene.polygons)``, reused across calls.
    visibility_level : int, keyword-only
        The patch carries ``4**visibility_level`` visibility sample points
        (centroids of its regular subdivision); 0 is the patch centroid.
    samples : (S, 3) float64, keyword-only
        ``triangle_samples(visibility_level)``, reused across calls.
    parallel : bool, keyword-only
        Use the multi-threaded kernel (worth it for many elements).

    Returns
    -------
    (M,) float64
    """
    if not 0 <= patch < mesh.n_patches:
        raise FormFactorError(f"patch {patch} outside [0, {mesh.n_patches})")
    if packed is None:
        packed = pack_polygons(mesh.scene.polygons)
    tri = np.ascontiguousarray(mesh.nodes[mesh.patches[patch]])
    if samples is None:
        samples = triangle_samples(visibility_level)
    samples = np.ascontiguousarray(samples @ tri)
    out = np.empty(mesh.n_elements)
    kernel = _analytic_column_parallel if parallel else _analytic_column_serial
    kernel(tri, _TRI_RING, mesh.patch_normal[patch], mesh.patch_centroid[patch],
                            int(mesh.patch_polygon[patch]), samples, mesh.element_centroid,
                            mesh.element_normal, mesh.element_polygon, *packed.args(), out)
    return out


def segments_visible(a, b, skip_a=None, skip_b=None, *, packed):
    """Whether the open segments a-b cross no scene polygon.

    Parameters
    ----------
    a, b : (n, 3) float64
    skip_a, skip_b : (n,) int64, optional
        Polygon index to ignore for each end (the surfaces the ends lie on); -1 for none.
    packed : PackedPolygons

    Returns
    -------
    (n,) bool
    """
    a = np.ascontiguousarray(np.atleast_2d(a), dtype=np.float64)
    b = np.ascontiguousarray(np.broadcast_to(np.atleast_2d(b), a.shape), dtype=np.float64)
    n = len(a)
    sa = np.full(n, -1, np.int64) if skip_a is None else np.ascontiguousarray(
        np.broadcast_to(skip_a, (n,)), dtype=np.int64)
    sb = np.full(n, -1, np.int64) if skip_b is None else np.ascontiguousarray(
        np.broadcast_to(skip_b, (n,)), dtype=np.int64)
    out = np.empty(n, dtype=np.bool_)
    _visible_kernel(a, b, sa, sb, *packed.args(), out)
    return out


def direct_irradiance(mesh, *, packed=None):
    """Irradiance on each element from the scene's point and parallel lights.

    Point light: ``I cos(theta) / r**2``; parallel light: ``E0 cos(theta)``;
    each times the visibility of the light from the element centroid.

    Returns
    -------
    (M, 3) float64
    """
    scene = mesh.scene
    out = np.zeros((mesh.n_elements, 3))
    if not scene.lights:
        return out
    if packed is None:
        packed = pack_polygons(scene.polygons)
    x = mesh.element_centroid
    n = mesh.element_normal
    poly = mesh.element_polygon
    lo, hi = scene.bounds
    far = 4.0 * float(np.linalg.norm(hi - lo)) + 1.0
    for light in scene.point_lights:
        d = light.position - x
        r2 = np.einsum("ij,ij->i", d, d)
        cos = np.einsum("ij,ij->i", d, n) / np.sqrt(r2)
        ok = cos > 0
        vis = np.zeros(len(x), dtype=bool)
        if np.any(ok):
            pos = np.broadcast_to(light.position, x[ok].shape)
            vis[ok] = segments_visible(x[ok], pos, poly[ok], None, packed=packed)
        out += (np.where(ok & vis, cos / r2, 0.0))[:, None] * light.intensity
    for light in scene.parallel_lights:
        cos = -(n @ light.direction)
        ok = cos > 0
        vis = np.zeros(len(x), dtype=bool)
        if np.any(ok):
            vis[ok] = segments_visible(x[ok], x[ok] - far * light.direction, poly[ok], None,
                                       packed=packed)
        out += (np.where(ok & vis, cos, 0.0))[:, None] * light.irradiance
    return out
