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

Visibility between an element and a patch is estimated by casting k x k
segments from jittered strata of the element to jittered strata of the
patch against the scene polygons (not the mesh), so it does not depend on
the mesh resolution; the visible fraction multiplies the unoccluded factor,
which is integrated over the element where the element is near the patch
(:func:`analytic_column`).  Each ray walks a bounding-volume hierarchy over
the scene's possible occluders (:func:`box_tree`), so its cost grows with
the occluders near it rather than with their number; it gets the same
answer as a linear scan over the pair's candidate occluders, which is kept
as the reference (``index=False``; :func:`visibility_rays` lists the rays).

This module gives the *element -> patch* factors F(e -> p) that the
progressive-refinement shooter needs (see :mod:`polygen.radiosity.solve`):
the element's radiosity gains ``rho_e * dB_p * F(e -> p)`` when patch p
shoots, which is (2.7) written with reciprocity (2.5).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from polygen._jit import njit, prange

__all__ = [
    "FormFactorError",
    "BoxTree",
    "PackedPolygons",
    "box_tree",
    "pack_polygons",
    "point_polygon_form_factor",
    "polygon_form_factor",
    "triangle_samples",
    "analytic_column",
    "element_geometry",
    "segments_visible",
    "visibility_rays",
    "direct_irradiance",
]


class FormFactorError(ValueError):
    """Bad input to a form-factor routine."""


_TRI_RING_K = np.array([0, 3], dtype=np.int64)


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
def _crosses(a, b, k, origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start, eps):
    """True when the open segment a-b crosses the interior of scene polygon k."""
    da = 0.0
    db = 0.0
    for c in range(3):
        da += pn[k, c] * (a[c] - origin[k, c])
        db += pn[k, c] * (b[c] - origin[k, c])
    if (da > 0.0 and db > 0.0) or (da < 0.0 and db < 0.0) or da == db:
        return False
    t = da / (da - db)
    if t <= eps or t >= 1.0 - eps:
        return False
    qx = 0.0
    qy = 0.0
    for c in range(3):
        q = a[c] + t * (b[c] - a[c]) - origin[k, c]
        qx += q * pu[k, c]
        qy += q * pv[k, c]
    if qx < bbox[k, 0] or qx > bbox[k, 2] or qy < bbox[k, 1] or qy > bbox[k, 3]:
        return False
    return _point_in_rings(qx, qy, ring2d, ring_start, poly_ring_start[k], poly_ring_start[k + 1])


@njit
def _segment_blocked(a, b, skip1, skip2, origin, pu, pv, pn, bbox, ring2d, ring_start,
                     poly_ring_start, eps):
    """True when the open segment a-b crosses the interior of a scene polygon."""
    for k in range(origin.shape[0]):
        if k == skip1 or k == skip2:
            continue
        if _crosses(a, b, k, origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start, eps):
            return True
    return False


@njit(parallel=True)
def _visible_kernel(a, b, skip1, skip2, origin, pu, pv, pn, bbox, ring2d, ring_start,
                    poly_ring_start, eps, out):
    for i in prange(a.shape[0]):
        out[i] = not _segment_blocked(a[i], b[i], skip1[i], skip2[i], origin, pu, pv, pn, bbox,
                                      ring2d, ring_start, poly_ring_start, eps)


@njit
def _hash01(a, b, c):
    """A uniform number in [0, 1) from three integers (splitmix64 finaliser).

    The jitter of the visibility rays is a function of (element, patch,
    sample), so results do not depend on thread scheduling or call order.
    """
    x = np.uint64(a) * np.uint64(0x9E3779B97F4A7C15)
    x = x ^ (np.uint64(b) * np.uint64(0xC2B2AE3D27D4EB4F))
    x = x ^ (np.uint64(c) * np.uint64(0x165667B19E3779F9))
    x = x ^ (x >> np.uint64(30))
    x = x * np.uint64(0xBF58476D1CE4E5B9)
    x = x ^ (x >> np.uint64(27))
    x = x * np.uint64(0x94D049BB133111EB)
    x = x ^ (x >> np.uint64(31))
    return float(x >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit
def _stratum_point(tri, i, j, k, ju, jv, out):
    """Point of stratum (i, j) of a k x k grid on the unit square, jittered by (ju, jv),
    mapped to the triangle by the area-preserving map (sqrt(u) (1 - v), sqrt(u) v)."""
    u = (i + ju) / k
    v = (j + jv) / k
    su = math.sqrt(u)
    b1 = su * (1.0 - v)
    b2 = su * v
    b0 = 1.0 - b1 - b2
    for c in range(3):
        out[c] = b0 * tri[0, c] + b1 * tri[1, c] + b2 * tri[2, c]


@njit
def _segment_blocked_by(a, b, cand, ncand, origin, pu, pv, pn, bbox, ring2d, ring_start,
                        poly_ring_start, eps):
    """_segment_blocked over the polygons cand[:ncand] only."""
    for m in range(ncand):
        if _crosses(a, b, cand[m], origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start,
                    eps):
            return True
    return False


@njit
def _segment_meets_box(a, b, lo, hi):
    """Whether the segment a-b meets the box [lo, hi] (slabs; a NaN from a 0 * inf never prunes)."""
    t0 = 0.0
    t1 = 1.0
    for c in range(3):
        d = b[c] - a[c]
        if d == 0.0:
            if a[c] < lo[c] or a[c] > hi[c]:
                return False
            continue
        inv = 1.0 / d
        ta = (lo[c] - a[c]) * inv
        tb = (hi[c] - a[c]) * inv
        if ta > tb:
            ta, tb = tb, ta
        if ta > t0:
            t0 = ta
        if tb < t1:
            t1 = tb
        if t0 > t1:
            return False
    return True


@njit
def _pair_candidate(mm, o, ep, pp, se, sp, qbox, occ_box, occ_front):
    """The per-pair filters of the linear scan that need no geometry beyond boxes."""
    if o == ep or o == pp or not occ_front[se, ep, mm] or not occ_front[sp, pp, mm]:
        return False
    return not (occ_box[mm, 0] > qbox[3] or occ_box[mm, 3] < qbox[0] or occ_box[mm, 1] > qbox[4]
                or occ_box[mm, 4] < qbox[1] or occ_box[mm, 2] > qbox[5] or occ_box[mm, 5] < qbox[2])


@njit
def _plane_splits(o, tri, etri_e, origin, pn):
    """Whether occluder o's plane has corners of the element and of the patch strictly on both
    sides (otherwise no ray between them crosses it)."""
    dmin = np.inf
    dmax = -np.inf
    for v in range(6):
        dv = 0.0
        for c in range(3):
            q = tri[v - 3, c] if v >= 3 else etri_e[v, c]
            dv += pn[o, c] * (q - origin[o, c])
        dmin = min(dmin, dv)
        dmax = max(dmax, dv)
    return not (dmin >= 0.0 or dmax <= 0.0)


@njit
def _segment_blocked_tree(a, b, ep, pp, se, sp, qbox, tri, etri_e, occ, occ_box, occ_front,
                          node_lo, node_hi, child, start, count, order, origin, pu, pv, pn, bbox,
                          ring2d, ring_start, poly_ring_start, eps, stack):
    """The linear scan's answer (_segment_blocked_by over the pair's candidates), by a BVH.

    Only subtrees whose (slightly inflated) box the segment meets are visited, and of those only
    the ones whose box meets the pair's box ``qbox``; each occluder reached passes the linear
    scan's filters before its crossing counts, so the answer is the same boolean.
    """
    if node_lo.shape[0] == 0:
        return False
    top = 1
    stack[0] = 0
    while top > 0:
        top -= 1
        nd = stack[top]
        lo = node_lo[nd]
        hi = node_hi[nd]
        if (lo[0] > qbox[3] or hi[0] < qbox[0] or lo[1] > qbox[4] or hi[1] < qbox[1]
                or lo[2] > qbox[5] or hi[2] < qbox[2]):
            continue
        if not _segment_meets_box(a, b, lo, hi):
            continue
        if child[nd, 0] < 0:
            for j in range(start[nd], start[nd] + count[nd]):
                mm = order[j]
                o = occ[mm]
                if not _pair_candidate(mm, o, ep, pp, se, sp, qbox, occ_box, occ_front):
                    continue
                if (_crosses(a, b, o, origin, pu, pv, pn, bbox, ring2d, ring_start,
                             poly_ring_start, eps)
                        and _plane_splits(o, tri, etri_e, origin, pn)):
                    return True
        else:
            stack[top] = child[nd, 0]
            stack[top + 1] = child[nd, 1]
            top += 2
    return False


@njit
def _pair_setup(e, tri, etri, n, pnormal, pn, ep, pp, qbox):
    """The pair's box (into ``qbox``: min, max) and the sides its two ends receive on
    (0 in front of their polygon's normal, 1 behind it: two-sided polygons)."""
    for c in range(3):
        qbox[c] = min(tri[0, c], tri[1, c], tri[2, c], etri[e, 0, c], etri[e, 1, c], etri[e, 2, c])
        qbox[3 + c] = max(tri[0, c], tri[1, c], tri[2, c], etri[e, 0, c], etri[e, 1, c],
                          etri[e, 2, c])
    de = 0.0
    dp = 0.0
    for c in range(3):
        de += n[c] * pn[ep, c]
        dp += pnormal[c] * pn[pp, c]
    return (1 if de < 0.0 else 0), (1 if dp < 0.0 else 0)


@njit
def _pair_candidates(e, ep, pp, se, sp, qbox, tri, etri, occ, occ_box, occ_front, origin, pn,
                     cand):
    """The linear scan: the occluders that may block a ray of the pair, into ``cand``; how many."""
    ncand = 0
    for m in range(occ.shape[0]):
        o = occ[m]
        if not _pair_candidate(m, o, ep, pp, se, sp, qbox, occ_box, occ_front):
            continue
        # every ray joins a point of the element to a point of the patch: if their six
        # corners lie on one side of the occluder's plane, no ray crosses it
        if not _plane_splits(o, tri, etri[e], origin, pn):
            continue
        cand[ncand] = o
        ncand += 1
    return ncand


@njit
def _pair_ray(e, patch, s, k, tri, etri_e, n, pnormal, pa, pb):
    """Ray s of the k * k between element e and the patch: its ends into ``pa`` (on the element)
    and ``pb`` (on the patch); returns its weight, 0 when it carries no light."""
    i = s // k
    j = s - i * k
    _stratum_point(tri, i, j, k, _hash01(e, patch, 4 * s), _hash01(e, patch, 4 * s + 1), pb)
    # the element's strata are paired transposed, so the two grids do not move in step
    _stratum_point(etri_e, j, i, k, _hash01(e, patch, 4 * s + 2), _hash01(e, patch, 4 * s + 3),
                   pa)
    ca = 0.0
    cb = 0.0
    r2 = 0.0
    for c in range(3):
        dc = pb[c] - pa[c]
        ca += n[c] * dc
        cb -= pnormal[c] * dc
        r2 += dc * dc
    if ca <= 0.0 or cb <= 0.0:
        # a ray behind the element's or the patch's plane carries no light (Lambert's
        # formula has already left that part out): it must not count as blocked
        return 0.0
    # weighted by the point-to-point kernel cos cos / r^2 (r2 * r2: ca, cb are unnormalised),
    # the visible fraction estimates int int K V / int int K, the occluded factor's ratio
    return ca * cb / (r2 * r2)


@njit
def _area_element(e, patch, tri, pnormal, pcentroid, pradius, ppoly, etri, en, ec, ediam, epoly,
                  qbary, qw, rule_start, near, k, occ, occ_box, occ_front, node_lo, node_hi, child,
                  start, count, order, index, origin, pu, pv, pn, bbox, ring2d, ring_start,
                  poly_ring_start, eps, cand, qbox, stack, pa, pb):
    """F(e -> patch): Lambert's formula integrated over the element where it is near the
    patch, at its centroid elsewhere, times the kernel-weighted visible fraction of k * k
    jittered rays.

    ``index``: each ray walks the occluders' BVH (node_lo ... order); otherwise the pair's
    candidate occluders are listed by a linear scan first and each ray tests them all.  Both
    give the same answer for every ray.
    """
    if epoly[e] == ppoly:
        return 0.0
    x = ec[e]
    n = en[e]
    d = 0.0
    for c in range(3):
        d += (x[c] - pcentroid[c]) ** 2
    d = math.sqrt(d)
    f = 0.0
    # the rule: the point factor varies on the scale of the distance to the patch, so the
    # error of a degree-p rule on an element of diameter D at distance r is O((D / r)**(p+1));
    # the centroid (degree 1) far away, a 3-point degree-2 rule at middle distance, and a
    # collapsed Gauss rule near (adjacent walls: log singularity at the shared edge)
    r = (d - pradius) / ediam[e]
    rule = 0 if r > MID * near else (1 if r > near else 2)
    for q in range(rule_start[rule], rule_start[rule + 1]):
        for c in range(3):
            pa[c] = (qbary[q, 0] * etri[e, 0, c] + qbary[q, 1] * etri[e, 1, c]
                     + qbary[q, 2] * etri[e, 2, c])
        side = 0.0
        for c in range(3):
            side += pnormal[c] * (pa[c] - pcentroid[c])
        if side > 0.0:  # points behind the patch see its back: nothing
            f += qw[q] * _point_rings_ff(pa, n, tri, _TRI_RING_K, 0, 1)
    if f <= 0.0:
        return 0.0
    # occluders whose box meets the box of element and patch: only they can block a ray
    ep = epoly[e]
    se, sp = _pair_setup(e, tri, etri, n, pnormal, pn, ep, ppoly, qbox)
    ncand = 0
    if index:
        # no occluder's box meets the pair's box: the linear scan would find no candidate
        if (node_lo.shape[0] == 0 or node_lo[0, 0] > qbox[3] or node_hi[0, 0] < qbox[0]
                or node_lo[0, 1] > qbox[4] or node_hi[0, 1] < qbox[1]
                or node_lo[0, 2] > qbox[5] or node_hi[0, 2] < qbox[2]):
            return f
    else:
        ncand = _pair_candidates(e, ep, ppoly, se, sp, qbox, tri, etri, occ, occ_box, occ_front,
                                 origin, pn, cand)
        if ncand == 0:
            return f
    seen = 0.0
    total = 0.0
    for s in range(k * k):
        w = _pair_ray(e, patch, s, k, tri, etri[e], n, pnormal, pa, pb)
        if w == 0.0:
            continue
        total += w
        if index:
            blocked = _segment_blocked_tree(pa, pb, ep, ppoly, se, sp, qbox, tri, etri[e], occ,
                                            occ_box, occ_front, node_lo, node_hi, child, start,
                                            count, order, origin, pu, pv, pn, bbox, ring2d,
                                            ring_start, poly_ring_start, eps, stack)
        else:
            blocked = _segment_blocked_by(pa, pb, cand, ncand, origin, pu, pv, pn, bbox, ring2d,
                                          ring_start, poly_ring_start, eps)
        if not blocked:
            seen += w
    if total == 0.0:
        # no sampled ray carries light (the element barely in front of the patch, or the
        # reverse): nothing is known about blocking, so count the pair as visible -- as when
        # no occluder can block at all -- rather than as dark
        return f
    if seen == total:
        # no ray blocked (seen == total bit for bit): f itself, as when no occluder is a
        # candidate -- (f * seen) / total could be an ulp off, and then the indexed walk, which
        # does not know whether the pair had candidates, would not give the linear scan's f
        return f
    return f * seen / total


_STACK = 64
"""Traversal stack of the BVH kernels: enough for a median-split tree of 2**62 leaves."""


@njit(parallel=True)
def _area_column_parallel(patch, tri, pnormal, pcentroid, pradius, ppoly, etri, en, ec, ediam,
                          epoly, qbary, qw, rule_start, near, k, occ, occ_box, occ_front, node_lo,
                          node_hi, child, start, count, order, index, origin, pu, pv, pn, bbox,
                          ring2d, ring_start, poly_ring_start, eps, out):
    m = ec.shape[0]
    chunk = 256  # scratch arrays once per chunk, not per element
    for c in prange((m + chunk - 1) // chunk):
        cand = np.empty(occ.shape[0], dtype=np.int64)
        qbox = np.empty(6)
        stack = np.empty(_STACK, dtype=np.int64)
        pa = np.empty(3)
        pb = np.empty(3)
        for e in range(c * chunk, min(m, (c + 1) * chunk)):
            out[e] = _area_element(e, patch, tri, pnormal, pcentroid, pradius, ppoly, etri, en,
                                   ec, ediam, epoly, qbary, qw, rule_start, near, k, occ,
                                   occ_box, occ_front, node_lo, node_hi, child, start, count,
                                   order, index, origin, pu, pv, pn, bbox, ring2d, ring_start,
                                   poly_ring_start, eps, cand, qbox, stack, pa, pb)


@njit
def _area_column_serial(patch, tri, pnormal, pcentroid, pradius, ppoly, etri, en, ec, ediam,
                        epoly, qbary, qw, rule_start, near, k, occ, occ_box, occ_front, node_lo,
                        node_hi, child, start, count, order, index, origin, pu, pv, pn, bbox,
                        ring2d, ring_start, poly_ring_start, eps, out):
    cand = np.empty(occ.shape[0], dtype=np.int64)
    qbox = np.empty(6)
    stack = np.empty(_STACK, dtype=np.int64)
    pa = np.empty(3)
    pb = np.empty(3)
    for e in range(ec.shape[0]):
        out[e] = _area_element(e, patch, tri, pnormal, pcentroid, pradius, ppoly, etri, en, ec,
                               ediam, epoly, qbary, qw, rule_start, near, k, occ, occ_box,
                               occ_front, node_lo, node_hi, child, start, count, order, index,
                               origin, pu, pv, pn, bbox, ring2d, ring_start, poly_ring_start, eps,
                               cand, qbox, stack, pa, pb)


@njit
def _rays_kernel(patch, tri, pnormal, ppoly, etri, en, epoly, k, occ, occ_box, occ_front, node_lo,
                 node_hi, child, start, count, order, index, origin, pu, pv, pn, bbox, ring2d,
                 ring_start, poly_ring_start, eps, out_e, out_a, out_b, out_w, out_blocked):
    """Every light-carrying ray of every (element, patch) pair and whether it is blocked."""
    cand = np.empty(occ.shape[0], dtype=np.int64)
    qbox = np.empty(6)
    stack = np.empty(_STACK, dtype=np.int64)
    pa = np.empty(3)
    pb = np.empty(3)
    r = 0
    for e in range(etri.shape[0]):
        ep = epoly[e]
        if ep == ppoly:
            continue
        se, sp = _pair_setup(e, tri, etri, en[e], pnormal, pn, ep, ppoly, qbox)
        ncand = 0
        if not index:
            ncand = _pair_candidates(e, ep, ppoly, se, sp, qbox, tri, etri, occ, occ_box,
                                     occ_front, origin, pn, cand)
        for s in range(k * k):
            w = _pair_ray(e, patch, s, k, tri, etri[e], en[e], pnormal, pa, pb)
            if w == 0.0:
                continue
            if index:
                blocked = _segment_blocked_tree(pa, pb, ep, ppoly, se, sp, qbox, tri, etri[e],
                                                occ, occ_box, occ_front, node_lo, node_hi, child,
                                                start, count, order, origin, pu, pv, pn, bbox,
                                                ring2d, ring_start, poly_ring_start, eps, stack)
            else:
                blocked = ncand > 0 and _segment_blocked_by(pa, pb, cand, ncand, origin, pu, pv,
                                                            pn, bbox, ring2d, ring_start,
                                                            poly_ring_start, eps)
            out_e[r] = e
            out_w[r] = w
            out_blocked[r] = blocked
            for c in range(3):
                out_a[r, c] = pa[c]
                out_b[r, c] = pb[c]
            r += 1
    return r


# ----------------------------------------------------------------------------
# scene packing for the kernels
# ----------------------------------------------------------------------------
class BoxTree(NamedTuple):
    """A bounding-volume hierarchy over axis-aligned boxes, as flat arrays for the kernels.

    Node 0 is the root; a leaf has ``child[nd] == (-1, -1)`` and holds the items
    ``order[start[nd]:start[nd] + count[nd]]``.  Every node's box contains its items' boxes.
    """

    node_lo: np.ndarray  #: (N, 3) float64, node boxes' min corners
    node_hi: np.ndarray  #: (N, 3) float64, node boxes' max corners
    child: np.ndarray  #: (N, 2) int64, the two children, or -1
    start: np.ndarray  #: (N,) int64, first item slot of the node in ``order``
    count: np.ndarray  #: (N,) int64, number of item slots
    order: np.ndarray  #: (n,) int64, item index of each slot


def box_tree(boxes, *, leaf_size=4):
    """A BVH over boxes: median split of the box centres on their longest axis.

    Parameters
    ----------
    boxes : (n, 2, 3) float64
        Min and max corner of each item.
    leaf_size : int >= 1, keyword-only
        Largest number of items in a leaf.

    Returns
    -------
    BoxTree
        Depth at most ceil(log2(n)) + 1 (the median split halves every node).
    """
    boxes = np.asarray(boxes, dtype=np.float64)
    if boxes.ndim != 3 or boxes.shape[1:] != (2, 3):
        raise FormFactorError(f"box_tree: boxes must be (n, 2, 3), got {boxes.shape}")
    if isinstance(leaf_size, bool) or not isinstance(leaf_size, (int, np.integer)) or leaf_size < 1:
        raise FormFactorError(f"box_tree: leaf_size must be an integer >= 1, got {leaf_size!r}")
    centre = boxes.mean(axis=1)
    lo, hi, child, start, count = [], [], [], [], []
    order = np.arange(len(boxes))
    todo = [(0, len(boxes), -1, 0)] if len(boxes) else []
    while todo:  # depth first, left child first: node numbers as a recursive build gives them
        s, e, parent, side = todo.pop()
        nd = len(lo)
        if parent >= 0:
            child[parent][side] = nd
        idx = order[s:e]
        lo.append(boxes[idx, 0].min(axis=0))
        hi.append(boxes[idx, 1].max(axis=0))
        child.append([-1, -1])
        start.append(s)
        count.append(e - s)
        if e - s > leaf_size:
            c = centre[idx]
            axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
            order[s:e] = idx[np.argsort(c[:, axis], kind="stable")]
            mid = (s + e) // 2
            todo.append((mid, e, nd, 1))
            todo.append((s, mid, nd, 0))
    return BoxTree(np.asarray(lo, dtype=np.float64).reshape(-1, 3),
                   np.asarray(hi, dtype=np.float64).reshape(-1, 3),
                   np.asarray(child, dtype=np.int64).reshape(-1, 2),
                   np.asarray(start, dtype=np.int64), np.asarray(count, dtype=np.int64),
                   order.astype(np.int64))


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
    occluders : (J,) int64
        Polygons whose plane has scene vertices strictly on both sides: the
        only ones that can block a segment between two scene points.
    occluder_box : (J, 6) float64
        Their bounding boxes (xmin, ymin, zmin, xmax, ymax, zmax).
    occluder_front : (2, K, J) bool
        Whether occluder j has a vertex strictly in front of polygon k's
        plane ([0]) or strictly behind it ([1]).
    occluder_tree : BoxTree
        A BVH over the occluders' boxes (items are indices into ``occluders``),
        walked by each visibility ray.
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
        # a polygon can block a segment between two scene points only if its plane has scene
        # vertices strictly on both sides (the walls of a convex room never block anything)
        lo, hi = self.ring3d.min(axis=0), self.ring3d.max(axis=0)
        tol = 1e-9 * float(np.linalg.norm(hi - lo))
        dist = (self.normal @ self.ring3d.T
                - np.einsum("kc,kc->k", self.normal, self.origin)[:, None])  # (K, R)
        splits = (dist > tol).any(axis=1) & (dist < -tol).any(axis=1)
        self.occluders = np.flatnonzero(splits).astype(np.int64)
        box = []
        for k in self.occluders:
            r = self.ring3d[self.ring_start[self.poly_ring_start[k]]:
                            self.ring_start[self.poly_ring_start[k + 1]]]
            box.append(np.concatenate([r.min(axis=0), r.max(axis=0)]))
        self.occluder_box = np.asarray(box, dtype=np.float64).reshape(-1, 6)
        # a ray that carries light lies in front of the planes of both its ends' polygons, so an
        # occluder with no vertex strictly in front of either plane cannot block it
        # (the side is the receiving surface's: [0] in front of the polygon's normal, [1] behind
        # it, for the back of a two-sided polygon)
        occ_front = np.zeros((2, len(self.origin), len(self.occluders)), dtype=np.bool_)
        for m, k in enumerate(self.occluders):
            r = slice(self.ring_start[self.poly_ring_start[k]],
                      self.ring_start[self.poly_ring_start[k + 1]])
            occ_front[0, :, m] = (dist[:, r] > tol).any(axis=1)
            occ_front[1, :, m] = (dist[:, r] < -tol).any(axis=1)
        self.occluder_front = occ_front
        # the rays' BVH over the occluders' boxes, each grown by far more than the round-off of a
        # crossing point, so that a segment missing a node's box crosses none of its occluders
        grow = 1e-9 * max(float(np.linalg.norm(hi - lo)), float(np.abs(self.ring3d).max()))
        self.occluder_tree = box_tree(np.stack([self.occluder_box[:, :3] - grow,
                                                self.occluder_box[:, 3:] + grow], axis=1))

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


VISIBILITY_SAMPLES = 4
"""Default k of the k x k visibility rays per element-patch pair.

Chosen from the error-vs-cost curve of ``benchmarks/visibility.py``
(``benchmarks/results/visibility.md``; against k = 16 in the Fig 2.8 room
and the Cornell box): the smallest k whose largest element radiosity error
is under 3 % in both scenes (k = 3: 4.1-4.2 %, k = 4: 2.4-2.5 %; RMS 0.12-0.29
%), at 1.1-1.4 times the time per shot of k = 3."""

NEAR = 4.0
"""An element is *near* a patch when its centroid is closer to the patch's
bounding sphere than ``NEAR`` element diameters; there the point factor is
integrated over the element."""

NEAR_ORDER = 10
"""Collapsed Gauss order (``NEAR_ORDER**2`` points) of that integral."""


MID = 4.0
"""Between ``near`` and ``MID * near`` element diameters a 3-point rule is used."""


def _rules(order):
    """The three element rules, concatenated: centroid, 3-point (degree 2), Gauss ``order``.

    Returns bary (Q, 3), weights (Q,), starts (4,) int64.
    """
    g_bary, g_w = _gauss_triangle(order)
    three = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
    bary = np.vstack([np.full((1, 3), 1 / 3), three, g_bary])
    w = np.concatenate([[1.0], np.full(3, 1 / 3), g_w])
    start = np.array([0, 1, 4, 4 + len(g_w)], dtype=np.int64)
    return np.ascontiguousarray(bary), np.ascontiguousarray(w), start


def element_geometry(mesh):
    """Per-element arrays the form-factor kernels need, computed once per mesh.

    Returns
    -------
    etri : (M, 3, 3) float64
        Element corners.
    ediam : (M,) float64
        Longest element edge.
    """
    etri = np.ascontiguousarray(mesh.nodes[mesh.elements])
    edges = etri[:, [1, 2, 0]] - etri
    ediam = np.ascontiguousarray(np.linalg.norm(edges, axis=2).max(axis=1))
    return etri, ediam


def _check_tree(packed):
    """The occluders' BVH indexes ``packed.occluders``: both replaced together, or neither."""
    if len(packed.occluder_tree.order) != len(packed.occluders):
        raise FormFactorError(f"packed.occluder_tree holds {len(packed.occluder_tree.order)} "
                              f"occluders, packed.occluders {len(packed.occluders)}: rebuild both")


def _check_samples(visibility_samples):
    if isinstance(visibility_samples, bool) or not isinstance(visibility_samples,
                                                              (int, np.integer)):
        raise FormFactorError(f"visibility_samples must be an integer >= 1, got "
                              f"{visibility_samples!r}")
    if not 1 <= visibility_samples <= 64:
        raise FormFactorError(f"visibility_samples must be in [1, 64], got {visibility_samples}")
    return int(visibility_samples)


def analytic_column(mesh, patch, *, packed=None, geometry=None,
                    visibility_samples=VISIBILITY_SAMPLES, near=NEAR, order=NEAR_ORDER,
                    parallel=True, index=True):
    """Form factors F(e -> p) from every element to one patch (the default of the solvers).

    The unoccluded factor is Lambert's exact point-to-polygon formula,
    averaged over the element::

        F(e -> p) = 1/A_e  int_e F(dA_x -> p) dA_x

    by a collapsed Gauss rule of ``order**2`` points where the element is
    near the patch (closer than ``near`` element diameters to the patch's
    bounding sphere: adjacent walls have a log singularity at the shared
    edge), and by the centroid value elsewhere (error O((diameter /
    distance)**2)).  It is multiplied by the visible fraction of
    ``visibility_samples**2`` rays, each from a jittered stratum of the
    element to a jittered stratum of the patch (a k x k grid on the unit
    square mapped area-preservingly onto each triangle), each ray weighted
    by the point-to-point kernel cos(theta_e) cos(theta_p) / r**2, so that
    the fraction estimates int int K V / int int K (rays behind either
    plane weigh nothing: Lambert's formula has already clipped that part).
    The jitter is a hash of (element, patch, sample): deterministic
    whatever the threading.
    Rays are tested only against scene polygons whose plane separates
    scene vertices (the others -- the walls of a convex room -- cannot block
    anything), that lie partly in front of both ends' planes, whose
    bounding box meets the box of element and patch, and whose plane
    separates the corners of element and patch.  With ``index`` (the
    default) each ray walks a BVH over the occluders' boxes
    (:attr:`PackedPolygons.occluder_tree`) and applies those filters to the
    occluders it reaches; without, a linear scan lists the pair's
    candidates first and each ray tests them all (no ray is cast where none
    is left).  Both give the same answer for every ray, so the same column.

    Parameters
    ----------
    mesh : RadiosityMesh
    patch : int
    packed : PackedPolygons, optional
        ``pack_polygons(mesh.scene.polygons)``, reused across calls.
    geometry : tuple, optional
        ``element_geometry(mesh)``, reused across calls.
    visibility_samples : int in [1, 64], keyword-only
        k: k * k rays per element-patch pair.
    near : float >= 0, keyword-only
        Near criterion in element diameters; 0 uses the centroid everywhere
        except for elements overlapping the patch's bounding sphere.
    order : int >= 1, keyword-only
        Gauss order of the near integral.
    parallel : bool, keyword-only
        Use the multi-threaded kernel (worth it for many elements).
    index : bool, keyword-only
        Rays walk the occluders' BVH (sub-linear in the number of occluders)
        rather than a linearly scanned candidate list.

    Returns
    -------
    (M,) float64
    """
    if not 0 <= patch < mesh.n_patches:
        raise FormFactorError(f"patch {patch} outside [0, {mesh.n_patches})")
    k = _check_samples(visibility_samples)
    if not near >= 0.0:
        raise FormFactorError(f"near must be >= 0, got {near}")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
        raise FormFactorError(f"order must be an integer >= 1, got {order!r}")
    if packed is None:
        packed = pack_polygons(mesh.scene.polygons)
    if geometry is None:
        geometry = element_geometry(mesh)
    etri, ediam = geometry
    _check_tree(packed)
    qbary, qw, rule_start = _rules(int(order))
    tri = np.ascontiguousarray(mesh.nodes[mesh.patches[patch]])
    centre = np.ascontiguousarray(mesh.patch_centroid[patch])
    radius = float(np.linalg.norm(tri - centre, axis=1).max())
    out = np.empty(mesh.n_elements)
    kernel = _area_column_parallel if parallel else _area_column_serial
    kernel(int(patch), tri, np.ascontiguousarray(mesh.patch_normal[patch]), centre, radius,
           int(mesh.patch_polygon[patch]), etri, mesh.element_normal, mesh.element_centroid,
           ediam, mesh.element_polygon, qbary, qw, rule_start, float(near), k, packed.occluders,
           packed.occluder_box, packed.occluder_front, *packed.occluder_tree, bool(index),
           *packed.args(), out)
    return out


def visibility_rays(mesh, patch, *, packed=None, geometry=None,
                    visibility_samples=VISIBILITY_SAMPLES, index=True):
    """The visibility rays :func:`analytic_column` casts towards one patch, and their answers.

    The same rays (strata, jitter and weights) for every element not on the
    patch's polygon, whether or not its unoccluded factor is positive; only
    the rays that carry light (in front of both ends' planes) are listed.

    Parameters
    ----------
    mesh : RadiosityMesh
    patch : int
    packed, geometry : optional
        As for :func:`analytic_column`.
    visibility_samples : int in [1, 64], keyword-only
    index : bool, keyword-only
        Walk the occluders' BVH (True) or test the pair's linearly scanned
        candidates (False); the answers are the same.

    Returns
    -------
    element : (R,) int64
        The element of each ray.
    a, b : (R, 3) float64
        Its ends on the element and on the patch.
    weight : (R,) float64
        Its weight cos(theta_e) cos(theta_p) / r**2, up to a factor per pair.
    blocked : (R,) bool
        Whether a scene polygon blocks it.
    """
    if not 0 <= patch < mesh.n_patches:
        raise FormFactorError(f"patch {patch} outside [0, {mesh.n_patches})")
    k = _check_samples(visibility_samples)
    if packed is None:
        packed = pack_polygons(mesh.scene.polygons)
    _check_tree(packed)
    etri = (geometry if geometry is not None else element_geometry(mesh))[0]
    n = mesh.n_elements * k * k
    out_e = np.empty(n, np.int64)
    out_a = np.empty((n, 3))
    out_b = np.empty((n, 3))
    out_w = np.empty(n)
    out_blocked = np.empty(n, np.bool_)
    r = _rays_kernel(int(patch), np.ascontiguousarray(mesh.nodes[mesh.patches[patch]]),
                     np.ascontiguousarray(mesh.patch_normal[patch]), int(mesh.patch_polygon[patch]),
                     etri, mesh.element_normal, mesh.element_polygon, k, packed.occluders,
                     packed.occluder_box, packed.occluder_front, *packed.occluder_tree, bool(index),
                     *packed.args(), out_e, out_a, out_b, out_w, out_blocked)
    return out_e[:r], out_a[:r], out_b[:r], out_w[:r], out_blocked[:r]


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
