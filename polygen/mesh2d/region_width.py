"""The local width of a region of a planar graph, and a size field capped by it.

A region narrower than its element size (a discontinuity line meeting a wall
near a corner, a wedge between two lines) cannot be meshed at that size
without skinny triangles: the bubbles on its two sides are closer to each
other than to their neighbours along the sides.  Capping the size by the
local width makes the elements there no longer than the region is wide.

The width at a point is the length of the chord through it, perpendicular to
the nearest boundary edge, between the region's boundary edges: in a strip
of width ``w`` it is ``w`` everywhere; near a right-angled corner it is the
far side's distance (the chord runs parallel to the other edge); towards the
apex of a wedge of angle ``phi < 90`` degrees it shrinks as ``r tan(phi)``,
so a capped field needs a floor.  On a boundary edge itself the chord is the
one into the region (the shorter of the two directions: outwards the ray
leaves the region and meets no boundary of it, or a farther one).
"""

from __future__ import annotations

import numpy as np

from polygen._jit import njit, prange
from polygen.mesh2d.sizing import as_size_function

__all__ = ["region_boundary", "region_width", "width_capped_size", "graded_minimum"]


def region_boundary(graph, region):
    """(E, 2, 2) float64 end points of the graph edges with ``region`` on a side.

    Parameters
    ----------
    graph : PlanarGraph
    region : int
        A region index, ``0 <= region < graph.n_regions``.
    """
    if not 0 <= int(region) < graph.n_regions:
        raise ValueError(f"region must be in [0, {graph.n_regions}), got {region}")
    on = (graph.edge_regions == int(region)).any(axis=1)
    return np.ascontiguousarray(graph.vertices[graph.edges[on]], dtype=np.float64)


@njit(parallel=True)
def _chord_kernel(xy, seg, eps, out):
    for i in prange(xy.shape[0]):
        x, y = xy[i, 0], xy[i, 1]
        best, jb = np.inf, -1
        for j in range(seg.shape[0]):
            ax, ay = seg[j, 0, 0], seg[j, 0, 1]
            dx, dy = seg[j, 1, 0] - ax, seg[j, 1, 1] - ay
            ll = dx * dx + dy * dy
            t = ((x - ax) * dx + (y - ay) * dy) / ll
            t = min(max(t, 0.0), 1.0)
            ex, ey = ax + t * dx - x, ay + t * dy - y
            d = np.sqrt(ex * ex + ey * ey)
            if d < best:
                best, jb = d, j
        dx, dy = seg[jb, 1, 0] - seg[jb, 0, 0], seg[jb, 1, 1] - seg[jb, 0, 1]
        ln = np.sqrt(dx * dx + dy * dy)
        nx, ny = -dy / ln, dx / ln
        h0 = h1 = np.inf
        for s in range(2):
            rx, ry = (nx, ny) if s == 0 else (-nx, -ny)
            first = np.inf
            for k in range(seg.shape[0]):
                ax, ay = seg[k, 0, 0], seg[k, 0, 1]
                bx, by = seg[k, 1, 0] - ax, seg[k, 1, 1] - ay
                den = rx * by - ry * bx
                if abs(den) < 1e-14 * np.sqrt(bx * bx + by * by):
                    continue   # parallel: the chord runs along this edge, never through it
                wx, wy = ax - x, ay - y
                t = (wx * by - wy * bx) / den
                u = (wx * ry - wy * rx) / den
                if t > eps and -1e-12 <= u <= 1.0 + 1e-12 and t < first:
                    first = t
            if s == 0:
                h0 = first
            else:
                h1 = first
        out[i] = min(h0, h1) if best <= eps else h0 + h1


def region_width(graph, region, xy):
    """The local width of a region at points: the chord through each point (module docstring).

    Parameters
    ----------
    graph : PlanarGraph
        E.g. a :class:`~polygen.radiosity.RadiosityMesh`'s ``layouts[k]``.
    region : int
    xy : (K, 2) float64
        Points in the graph's frame, normally in the region or on its boundary.

    Returns
    -------
    (K,) float64
        ``inf`` where a chord leaves the region's boundary on one side (a point outside the
        region, or a ray that escapes through a gap).
    """
    seg = region_boundary(graph, region)
    q = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.empty(len(q))
    if len(seg) == 0:
        out[:] = np.inf
        return out
    scale = float(np.ptp(seg.reshape(-1, 2), axis=0).max())
    _chord_kernel(q, seg, 1e-9 * max(scale, 1.0), out)
    return out


def width_capped_size(size, graph, region, *, floor):
    """A region's size field capped by its local width: ``min(size, max(width, floor))``.

    Parameters
    ----------
    size : number, callable or GridSize
        The region's size field (in the graph's frame).
    graph : PlanarGraph
    region : int
    floor : float, keyword-only
        The smallest cap, > 0: towards an acute apex the width goes to 0, and the elements
        there cannot beat the apex's angle anyway.

    Returns
    -------
    callable ``(K, 2) -> (K,)``
    """
    floor = float(floor)
    if not (np.isfinite(floor) and floor > 0):
        raise ValueError(f"floor must be finite and > 0, got {floor}")
    field = as_size_function(size)
    seg = region_boundary(graph, region)
    scale = float(np.ptp(seg.reshape(-1, 2), axis=0).max()) if len(seg) else 1.0
    eps = 1e-9 * max(scale, 1.0)

    def capped(xy):
        q = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        s = field(q)
        if len(seg) == 0 or len(q) == 0:
            return s
        w = np.empty(len(q))
        _chord_kernel(q, seg, eps, w)
        return np.minimum(s, np.maximum(w, floor))

    capped.constant = None
    return capped


@njit(parallel=True)
def _graded_min_kernel(x, y, c, beta, out):
    for i in prange(x.shape[0]):
        best = np.inf
        for j in range(y.shape[0]):
            d = 0.0
            for k in range(x.shape[1]):
                t = x[i, k] - y[j, k]
                d += t * t
            v = c[j] + beta * np.sqrt(d)
            if v < best:
                best = v
        out[i] = best


def graded_minimum(points, sample_points, sample_sizes, *, beta):
    """``min_j (sample_sizes[j] + beta |points - sample_points[j]|)`` at every point.

    The smallest size field with slope at most ``beta`` that is no larger than the samples'
    sizes at the samples: a size grows from a fine spot by at most ``beta`` per unit length,
    so neighbouring bubbles differ by at most a factor ``1 + beta`` (Theorem 4.1 then bounds
    the edge-length ratio by ``(2 + beta) / 2``).

    Parameters
    ----------
    points : (K, D) float64
    sample_points : (J, D) float64
    sample_sizes : (J,) float64
    beta : float, keyword-only
        The slope, > 0.

    Returns
    -------
    (K,) float64
        ``inf`` everywhere when there are no samples.
    """
    x = np.ascontiguousarray(points, dtype=np.float64)
    y = np.ascontiguousarray(sample_points, dtype=np.float64).reshape(-1, x.shape[1])
    c = np.ascontiguousarray(sample_sizes, dtype=np.float64).reshape(-1)
    if len(c) != len(y):
        raise ValueError(f"sample_sizes must have one value per sample point ({len(y)}), "
                         f"got {len(c)}")
    if not (np.isfinite(beta) and beta > 0):
        raise ValueError(f"beta must be finite and > 0, got {beta}")
    out = np.empty(len(x))
    _graded_min_kernel(x, y, c, float(beta), out)
    return out
