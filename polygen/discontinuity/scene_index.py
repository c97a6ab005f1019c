"""A bounding-volume hierarchy over polygons, queried with convex polyhedra.

The thesis's T_isr (Table 3.2) tests every shadow polyhedron against every
receiver, O(n^2) in the polygon count.  Here the receivers' axis-aligned
boxes are kept in a binary tree (median split on the longest axis); a
polyhedron visits only the nodes whose box it may meet: a box entirely
outside one of its planes, or outside its own capped bounding box, is
skipped with its subtree.

The tree is built once per scene from copies of the boxes and vertices
and only read afterwards: one :class:`PolygonIndex` may be queried from
several threads (only its work counters, ``node_tests`` and
``item_tests``, are then not exact).  A moved polygon needs a new index.
"""

from __future__ import annotations

import numpy as np

from polygen._jit import njit
from polygen.radiosity.formfactor import box_tree

__all__ = ["PolygonIndex"]


@njit
def _box_outside(lo, hi, planes, nplanes, qlo, qhi):
    """Whether the box [lo, hi] misses the query's box or lies outside one of its planes."""
    for a in range(3):
        if lo[a] > qhi[a] or hi[a] < qlo[a]:
            return True
    for p in range(nplanes):
        # the box corner furthest along -n: if even it is beyond the plane, all is
        s = 0.0
        for a in range(3):
            n = planes[p, a]
            s += n * (lo[a] if n > 0.0 else hi[a])
        if s > planes[p, 3]:
            return True
    return False


@njit
def _points_outside(pts, planes, nplanes):
    """Whether all points lie strictly outside one of the planes (a separating face)."""
    for p in range(nplanes):
        out = True
        for i in range(len(pts)):
            s = planes[p, 0] * pts[i, 0] + planes[p, 1] * pts[i, 1] + planes[p, 2] * pts[i, 2]
            if s <= planes[p, 3]:
                out = False
                break
        if out:
            return True
    return False


@njit
def _query_kernel(node_lo, node_hi, child, start, count, order, points, point_start, planes,
                  plane_start, qlo, qhi, tol, out_q, out_item, counters):
    """All (query, item) pairs whose boxes and points survive the plane tests; returns how many.

    ``counters[0]``: node boxes tested; ``counters[1]``: items tested against the planes.
    """
    k = 0
    nq = len(plane_start) - 1
    stack = np.empty(128, np.int64)
    for q in range(nq):
        pl = planes[plane_start[q]:plane_start[q + 1]].copy()
        for p in range(len(pl)):
            pl[p, 3] += tol
        top = 0
        stack[top] = 0
        top += 1
        while top > 0:
            top -= 1
            nd = stack[top]
            counters[0] += 1
            if _box_outside(node_lo[nd], node_hi[nd], pl, len(pl), qlo[q], qhi[q]):
                continue
            if child[nd, 0] < 0:
                for j in range(start[nd], start[nd] + count[nd]):
                    it = order[j]
                    counters[1] += 1
                    if _points_outside(points[point_start[it]:point_start[it + 1]], pl, len(pl)):
                        continue
                    if k < len(out_q):
                        out_q[k] = q
                        out_item[k] = it
                    k += 1
            else:
                stack[top] = child[nd, 0]
                stack[top + 1] = child[nd, 1]
                top += 2
    return k


class PolygonIndex:
    """A BVH over the axis-aligned boxes of polygons.

    Parameters
    ----------
    boxes : (N, 2, 3) float64
        Min and max corner of each polygon.
    points : list of (k_i, 3) float64, keyword-only, optional
        Each polygon's vertices: a polygon whose vertices all lie outside
        one face of a query is not returned (a separating plane).
    leaf_size : int, keyword-only
        Largest number of polygons in a leaf.

    Attributes
    ----------
    node_tests : int
        Node boxes tested by all queries so far (a work counter).
    item_tests : int
        Polygons tested against a query's faces so far.
    """

    def __init__(self, boxes, *, points=None, leaf_size=4):
        boxes = np.asarray(boxes, dtype=np.float64)
        if boxes.ndim != 3 or boxes.shape[1:] != (2, 3):
            raise ValueError(f"PolygonIndex: boxes must be (N, 2, 3), got {boxes.shape}")
        self.boxes = boxes.copy()
        if points is None:  # the box corners stand for the polygon
            points = [np.array([[x, y, z] for x in b[0] for y in b[1] for z in b[2]])
                      for b in boxes.transpose(0, 2, 1)]
        if len(points) != len(boxes):
            raise ValueError(f"PolygonIndex: {len(points)} point sets for {len(boxes)} boxes")
        self.point_start = np.zeros(len(points) + 1, np.int64)
        self.point_start[1:] = np.cumsum([len(p) for p in points])
        self.points = np.ascontiguousarray(np.vstack([np.asarray(p, float).reshape(-1, 3) for p in points])
                                           if len(points) else np.zeros((0, 3)))
        # the same median-split tree the visibility rays walk (node 0 the root, depth first)
        tree = box_tree(boxes, leaf_size=leaf_size)
        self.node_lo, self.node_hi = tree.node_lo, tree.node_hi
        self.child, self.start, self.count, self.order = tree.child, tree.start, tree.count, tree.order
        self.node_tests = 0
        self.item_tests = 0

    def query(self, planes, boxes, *, tol=0.0):
        """Polygons whose boxes may meet each convex query.

        Parameters
        ----------
        planes : list of (P_q, 4) float64
            Each query's half-spaces ``n . x <= d``.
        boxes : (Q, 2, 3) float64
            Each query's bounding box (its capped vertices' box).
        tol : float, keyword-only
            Slack added to every plane offset.

        Returns
        -------
        (K, 2) int64
            Rows ``(query, polygon)``: the box meets the query's box and no
            face of the query separates the polygon's points from it.
        """
        Q = len(planes)
        if Q == 0 or len(self.boxes) == 0:
            return np.zeros((0, 2), np.int64)
        ps = np.zeros(Q + 1, np.int64)
        ps[1:] = np.cumsum([len(p) for p in planes])
        P = np.ascontiguousarray(np.vstack([np.asarray(p, float).reshape(-1, 4) for p in planes]))
        boxes = np.asarray(boxes, dtype=np.float64)
        qlo = np.ascontiguousarray(boxes[:, 0])
        qhi = np.ascontiguousarray(boxes[:, 1])
        cap = 4 * len(self.boxes) + 16
        while True:
            oq = np.empty(cap, np.int64)
            oi = np.empty(cap, np.int64)
            nt = np.zeros(2, np.int64)
            k = _query_kernel(self.node_lo, self.node_hi, self.child, self.start, self.count,
                              self.order, self.points, self.point_start, P, ps, qlo, qhi,
                              float(tol), oq, oi, nt)
            if k <= cap:
                break
            cap = k
        self.node_tests += int(nt[0])
        self.item_tests += int(nt[1])
        return np.stack([oq[:k], oi[:k]], axis=1)
