"""A 2-D BSP tree splitting a receiver by discontinuity segments (Figs 2.10, 3.4(b)).

The conventional discontinuity meshing of [9, 40] (thesis 2.4.3) keeps a
receiver's regions in a binary space partition: each segment, inserted in
turn, is pushed down the tree; every leaf region it crosses is split in two
by the segment's supporting line (across the whole leaf, not only along
the segment -- which is why the BSP makes more, and thinner, regions than
the loops of 3.3.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from polygen.discontinuity import _geometry as geo

__all__ = ["BSPRegions", "bsp_split"]


@dataclass(frozen=True, eq=False)
class BSPRegions:
    """The leaves of a 2-D BSP tree.

    Attributes
    ----------
    regions : list of (k, 2) float64
        Convex, counter-clockwise leaf regions.
    n_nodes : int
        Nodes of the tree (roots, inner nodes and leaves).
    splits : int
        Leaves split (each adds one region).
    cell_tests : int
        Segment-against-leaf tests made while inserting.
    """

    regions: list
    n_nodes: int
    splits: int
    cell_tests: int

    @property
    def n_regions(self):
        return len(self.regions)


def _clip_segment(a, b, cell, tol):
    """The part of segment a-b inside a convex CCW cell (Cyrus-Beck); None if shorter than tol."""
    t0, t1 = 0.0, 1.0
    d = b - a
    k = len(cell)
    for i in range(k):
        p, q = cell[i], cell[(i + 1) % k]
        e = q - p
        # inside: cross(e, x - p) >= 0
        num = e[0] * (a[1] - p[1]) - e[1] * (a[0] - p[0])
        den = e[0] * d[1] - e[1] * d[0]
        if abs(den) < 1e-300:
            if num < 0:
                return None
            continue
        t = -num / den
        if den > 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return None
    if (t1 - t0) * np.linalg.norm(d) <= tol:
        return None
    return a + t0 * d, a + t1 * d


def bsp_split(cells, segments, *, tol=1e-9):
    """Split convex cells by segments, BSP-style.

    Parameters
    ----------
    cells : sequence of (k, 2) float64
        The roots: convex, counter-clockwise (a receiver's convex pieces).
    segments : (S, 2, 2) float64
        Inserted in this order.
    tol : float, keyword-only
        Relative to the cells' extent: shorter crossings and thinner
        pieces are ignored.

    Returns
    -------
    BSPRegions
    """
    cells = [np.asarray(c, dtype=np.float64) for c in cells]
    segments = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    allp = np.vstack(cells) if cells else np.zeros((1, 2))
    size = float(np.max(np.ptp(allp, axis=0))) or 1.0
    atol = tol * size
    leaves = list(cells)
    # the leaves' boxes: a segment is tested only against leaves its box meets
    boxes = np.array([np.r_[c.min(axis=0), c.max(axis=0)] for c in leaves]).reshape(-1, 4)
    n_nodes = len(cells)
    splits = tests = 0
    for a, b in segments:
        d = b - a
        L = float(np.linalg.norm(d))
        if L <= atol:
            continue
        nrm = np.array([-d[1], d[0]]) / L
        c = float(nrm @ a)
        lo, hi = np.minimum(a, b) - atol, np.maximum(a, b) + atol
        near = np.flatnonzero((boxes[:, 0] <= hi[0]) & (boxes[:, 2] >= lo[0])
                              & (boxes[:, 1] <= hi[1]) & (boxes[:, 3] >= lo[1]))
        new_cells, drop = [], []
        for idx in near:
            cell = leaves[idx]
            tests += 1
            if _clip_segment(a, b, cell, atol) is None:
                continue
            s = cell @ nrm - c
            if s.max() <= atol or s.min() >= -atol:  # the segment runs along the cell's boundary
                continue
            left = geo.clean_ring(geo.clip_polygon_2d(cell, nrm, c), atol)
            right = geo.clean_ring(geo.clip_polygon_2d(cell, -nrm, -c), atol)
            if len(left) < 3 or len(right) < 3:
                continue
            drop.append(idx)
            new_cells += [left, right]
            splits += 1
            n_nodes += 2
        if drop:
            keep = np.ones(len(leaves), bool)
            keep[drop] = False
            leaves = [leaves[i] for i in np.flatnonzero(keep)] + new_cells
            boxes = np.vstack([boxes[keep]] + [np.r_[q.min(axis=0), q.max(axis=0)][None]
                                               for q in new_cells])
    return BSPRegions(regions=leaves, n_nodes=n_nodes, splits=splits, cell_tests=tests)
