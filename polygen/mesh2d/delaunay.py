"""Constrained Delaunay triangulation of polygons with holes (thesis 2.3.2).

A thin layer over ``pythoncdt`` (the CDT library): boundary segments are
inserted as constraint edges, the triangles outside the outer ring and
inside the holes are erased by depth parity, and the result comes back as
plain arrays with counter-clockwise triangles.
"""

from typing import NamedTuple

import numpy as np
import pythoncdt

from polygen._jit import njit
from polygen.mesh2d.domain import InvalidDomainError, local_origin, points_in_domain, validate_domain

__all__ = ["Mesh2D", "constrained_delaunay", "triangulate_domain", "boundary_chain_edges"]


class Mesh2D(NamedTuple):
    """A planar triangle mesh.

    Attributes
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64
        Counter-clockwise node indices.
    constrained_edges : (E, 2) int64
        The constraint (boundary or feature) edges that were imposed.
    """

    nodes: np.ndarray
    triangles: np.ndarray
    constrained_edges: np.ndarray


@njit
def _orient_ccw_kernel(nodes, tri):
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        cr = (nodes[b, 0] - nodes[a, 0]) * (nodes[c, 1] - nodes[a, 1]) - (
            nodes[b, 1] - nodes[a, 1]) * (nodes[c, 0] - nodes[a, 0])
        if cr < 0.0:
            tri[t, 1] = c
            tri[t, 2] = b


def constrained_delaunay(points, edges=None, *, erase_outside=True, order="auto"):
    """Constrained Delaunay triangulation of points with constraint edges.

    Parameters
    ----------
    points : (N, 2) float64
        Distinct, finite points.
    edges : (E, 2) int, optional
        Constraint edges (pairs of indices into ``points``); they must not
        cross each other. With ``erase_outside`` they must form closed loops:
        triangles are kept where the loops are crossed an odd number of times
        from infinity (outside of the outer loop and inside holes erased).
    erase_outside : bool
        Erase triangles outside the loops (True) or only the convex-hull
        super-triangle (False).
    order : {"auto", "as_provided"}
        Vertex insertion order of the CDT library (it decides between
        co-circular alternatives).

    Returns
    -------
    Mesh2D
        ``nodes`` are ``points`` in the same order (no node is added or
        merged), ``triangles`` are counter-clockwise. Points far from the
        origin are triangulated relative to :func:`~polygen.mesh2d.domain.local_origin`
        (the same triangles as the points shifted near 0).

    Raises
    ------
    ValueError
        Non-finite or duplicate points, bad edge indices, or crossing constraints.
    """
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise ValueError(f"points: expected shape (N >= 3, 2), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points: non-finite coordinates")
    if len(np.unique(pts, axis=0)) != len(pts):
        raise ValueError("points: duplicate points (CDT would merge them and renumber)")
    if edges is None:
        e = np.zeros((0, 2), dtype=np.int64)
    else:
        e = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
        if e.size and (e.min() < 0 or e.max() >= len(pts)):
            raise ValueError(f"edges: indices outside [0, {len(pts)})")
        if np.any(e[:, 0] == e[:, 1]):
            raise ValueError("edges: degenerate edge (same node twice)")
    if order not in ("auto", "as_provided"):
        raise ValueError(f"order: expected 'auto' or 'as_provided', got {order!r}")
    cdt = pythoncdt.Triangulation(
        pythoncdt.VertexInsertionOrder.AUTO if order == "auto"
        else pythoncdt.VertexInsertionOrder.AS_PROVIDED,
        pythoncdt.IntersectingConstraintEdges.NOT_ALLOWED,
        0.0,
    )
    local = pts - local_origin(pts)  # exact; pts itself when near the origin
    cdt.insert_vertices(np.ascontiguousarray(local))
    if len(e):
        try:
            cdt.insert_edges(np.ascontiguousarray(e, dtype=np.uint32))
        except Exception as exc:  # the library raises its own error types
            raise ValueError(f"edges: constraint edges could not be inserted ({exc})") from None
    if erase_outside and len(e):
        cdt.erase_outer_triangles_and_holes()
    else:
        cdt.erase_super_triangle()
    if cdt.vertices_count() != len(pts):
        raise ValueError("constraint edges intersect or touch a point: the triangulation added nodes")
    tri = cdt.triangles_array()["vertices"].astype(np.int64)
    _orient_ccw_kernel(local, tri)
    return Mesh2D(pts.copy(), np.ascontiguousarray(tri), e.copy())


def boundary_chain_edges(ring_sizes):
    """Edges closing consecutive runs of nodes into loops.

    Parameters
    ----------
    ring_sizes : sequence of int
        Ring ``r`` holds nodes ``off_r ... off_r + ring_sizes[r] - 1``.

    Returns
    -------
    edges : (sum(ring_sizes), 2) int64
    """
    out, off = [], 0
    for k in ring_sizes:
        idx = np.arange(off, off + k)
        out.append(np.stack([idx, np.roll(idx, -1)], axis=1))
        off += k
    return np.concatenate(out).astype(np.int64) if out else np.zeros((0, 2), np.int64)


def triangulate_domain(outer, holes=(), *, interior=None):
    """Constrained Delaunay of a polygon with holes and extra interior nodes.

    Parameters
    ----------
    outer : (K, 2) array_like or Domain
        Outer ring (see :func:`validate_domain`).
    holes : sequence of (K_h, 2) array_like
    interior : (M, 2) float64, optional
        Nodes strictly inside the domain (not in a hole, not on the boundary).

    Returns
    -------
    Mesh2D
        Nodes: the ring vertices (outer ring first, then each hole, in the
        order of :meth:`Domain.segments`) followed by ``interior``. Every
        boundary segment is an edge of the mesh.

    Raises
    ------
    InvalidDomainError
        Invalid domain, or interior nodes outside it / on its boundary.
    """
    dom = validate_domain(outer, holes)
    ring_pts, seg, _ = dom.segments()
    if interior is None:
        interior = np.zeros((0, 2))
    inner = np.asarray(interior, dtype=np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(inner)):
        raise InvalidDomainError("interior: non-finite coordinates")
    ok = points_in_domain(inner, dom)
    if not np.all(ok):
        raise InvalidDomainError(
            f"interior: {int((~ok).sum())} nodes outside the domain or on its boundary "
            f"(first at index {int(np.flatnonzero(~ok)[0])})")
    return constrained_delaunay(np.concatenate([ring_pts, inner]), seg)
