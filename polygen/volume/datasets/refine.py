"""Uniform refinement of a tetrahedral volume: every tetrahedron into eight (for the data sets beyond 10M).

Each edge gets a node at its midpoint, shared by every cell around the
edge, so the refined volume is conforming wherever the coarse one was.
Each tetrahedron ``(v0, v1, v2, v3)`` becomes its four corner tetrahedra
(the cell shrunk by half towards each corner: same orientation) and the
inner octahedron cut along its shortest diagonal into four (Bey's "red"
refinement; the shortest diagonal keeps the children's shapes within a
bounded factor of the parent's). Volumes add up: the eight children of a
cell have an eighth of its volume each.

**Numbering.** A node keeps its place in the order of the coarse nodes,
and the midpoint of each edge comes right after the edge's smaller node
(edges by smaller node, then larger, as :attr:`UnstructuredVolume.edges`):
node ``a`` becomes ``a + (edges whose smaller node is below a)``, edge
``e`` of smaller node ``a`` becomes ``a + 1 + e``. The children of cell
``c`` are cells ``8c .. 8c+7``. A coarse volume in spatial (Morton) order
so gives a refined one in nearly that order, without a sort.
"""

from __future__ import annotations

import numpy as np

from polygen._jit import empty, njit, prange
from polygen.volume._cells import TET_EDGES
from polygen.volume.datasets._base import DatasetError

__all__ = ["refine_tetrahedra"]

#: children per parent cell
CHILDREN = 8
# local edge (i, j) of TET_EDGES -> its row, both ways
_EDGE_OF = np.full((4, 4), -1, np.int64)
for _r, (_i, _j) in enumerate(TET_EDGES):
    _EDGE_OF[_i, _j] = _EDGE_OF[_j, _i] = _r
del _r, _i, _j


@njit(parallel=True)
def _refined_points(points, edges, node_new, out):
    """The coarse nodes at their new ids, each edge's midpoint at ``edges[e, 0] + 1 + e``."""
    for a in prange(points.shape[0]):
        for d in range(3):
            out[node_new[a], d] = points[a, d]
    for e in prange(edges.shape[0]):
        a = edges[e, 0]
        b = edges[e, 1]
        for d in range(3):
            out[a + 1 + e, d] = 0.5 * (points[a, d] + points[b, d])


@njit
def _v6(p, a, b, c, d):
    ax = p[b, 0] - p[a, 0]
    ay = p[b, 1] - p[a, 1]
    az = p[b, 2] - p[a, 2]
    bx = p[c, 0] - p[a, 0]
    by = p[c, 1] - p[a, 1]
    bz = p[c, 2] - p[a, 2]
    dx = p[d, 0] - p[a, 0]
    dy = p[d, 1] - p[a, 1]
    dz = p[d, 2] - p[a, 2]
    return ax * (by * dz - bz * dy) - ay * (bx * dz - bz * dx) + az * (bx * dy - by * dx)


@njit
def _put(out, row, a, b, c, d, p):
    """Child ``row`` = (a, b, c, d), its last two nodes swapped if it is negative."""
    out[row, 0] = a
    out[row, 1] = b
    if _v6(p, a, b, c, d) < 0:
        out[row, 2] = d
        out[row, 3] = c
    else:
        out[row, 2] = c
        out[row, 3] = d


@njit(parallel=True)
def _refined_cells(cells, cell_edges, edges, node_new, edge_of, new_points, out):
    """The eight children of each cell (row ``i`` of ``cells``, ``cell_edges``) into rows
    ``8i .. 8i+7`` of ``out``."""
    for i in prange(cells.shape[0]):
        v = np.empty(4, np.int64)
        mid = np.empty((4, 4), np.int64)
        for k in range(4):
            v[k] = node_new[cells[i, k]]
        for x in range(4):
            for y in range(4):
                if x != y:
                    e = cell_edges[i, edge_of[x, y]]
                    mid[x, y] = edges[e, 0] + 1 + e
        r = 8 * i
        # the corner tetrahedra: the parent shrunk by half towards each corner (same orientation)
        out[r, 0] = v[0]
        out[r, 1] = mid[0, 1]
        out[r, 2] = mid[0, 2]
        out[r, 3] = mid[0, 3]
        out[r + 1, 0] = mid[0, 1]
        out[r + 1, 1] = v[1]
        out[r + 1, 2] = mid[1, 2]
        out[r + 1, 3] = mid[1, 3]
        out[r + 2, 0] = mid[0, 2]
        out[r + 2, 1] = mid[1, 2]
        out[r + 2, 2] = v[2]
        out[r + 2, 3] = mid[2, 3]
        out[r + 3, 0] = mid[0, 3]
        out[r + 3, 1] = mid[1, 3]
        out[r + 3, 2] = mid[2, 3]
        out[r + 3, 3] = v[3]
        # the octahedron's three diagonals join opposite midpoints: (01, 23), (02, 13), (03, 12); the shortest
        best = 0
        best_len = np.inf
        for k in range(3):
            p = mid[0, k + 1]
            q = mid[(k + 1) % 3 + 1, (k + 2) % 3 + 1]  # the edge of the two other nodes
            s = 0.0
            for d in range(3):
                t = new_points[p, d] - new_points[q, d]
                s += t * t
            if s < best_len:
                best_len = s
                best = k
        j = best + 1
        u = (best + 1) % 3 + 1
        w = (best + 2) % 3 + 1
        p = mid[0, j]
        q = mid[u, w]
        # the equator: the two other pairs of opposite midpoints, (0u, jw) and (0w, ju), in a cycle
        a0 = mid[0, u]
        a1 = mid[j, w]
        b0 = mid[0, w]
        b1 = mid[j, u]
        _put(out, r + 4, p, q, a0, b0, new_points)
        _put(out, r + 5, p, q, b0, a1, new_points)
        _put(out, r + 6, p, q, a1, b1, new_points)
        _put(out, r + 7, p, q, b1, a0, new_points)


def refine_tetrahedra(vol, *, fields="interpolate", block=1 << 20, progress=None):
    """Split every tetrahedron of ``vol`` into eight, with a new node at every edge's midpoint.

    Parameters
    ----------
    vol : UnstructuredVolume
        Tetrahedra only.
    fields : {"interpolate", None}, keyword-only
        ``"interpolate"``: each field at a midpoint is the mean of its
        values at the edge's ends (the linear interpolation of Def. 5.5;
        unchanged at the coarse nodes). ``None``: no fields (the caller
        evaluates its own on the new points).
    block : int, keyword-only
        Parent cells per call of the kernel: the unit of the progress bar.
        The children are written in place, so no temporary grows with the
        volume beyond the volume's edge table.
    progress : tqdm-like, optional
        Updated by the number of parent cells done.

    Returns
    -------
    points : (N + E, 3) float64
    cells : (8M, 4) int32 (int64 from 2**31 nodes)
        Positive in VTK order, children of cell ``c`` at rows ``8c .. 8c+7``.
    fields : dict of str -> (N + E,) float64
    node_new : (N,) int64
        The new id of each coarse node.
    """
    if vol.cell_type != "tetra":
        raise DatasetError(f"refine_tetrahedra splits tetrahedra; got a volume of {vol.cell_type} cells")
    if fields not in ("interpolate", None):
        raise DatasetError(f"fields must be 'interpolate' or None; got {fields!r}")
    if isinstance(block, bool) or not (isinstance(block, (int, np.integer)) and block >= 1):
        raise DatasetError(f"block must be a positive integer; got {block!r}")
    edges = vol.edges
    cell_edges = vol.cell_edges
    n, m, n_edges = vol.n_points, vol.n_cells, edges.shape[0]
    # node a's new id: a + the edges whose smaller node is below a (their midpoints come before it)
    node_new = np.arange(n, dtype=np.int64) + np.searchsorted(edges[:, 0], np.arange(n), side="left")
    n_new = n + n_edges
    points = empty((n_new, 3))
    _refined_points(vol.points, edges, node_new, points)
    out = {}
    if fields == "interpolate":
        for name, values in vol.fields.items():
            f = empty(n_new)
            f[node_new] = values
            f[edges[:, 0] + 1 + np.arange(n_edges)] = 0.5 * (values[edges[:, 0]] + values[edges[:, 1]])
            out[name] = f
    cells = empty((CHILDREN * m, 4), np.int32 if n_new < np.iinfo(np.int32).max else np.int64)
    for a in range(0, m, int(block)):
        b = min(m, a + int(block))
        _refined_cells(vol.cells[a:b], cell_edges[a:b], edges, node_new, _EDGE_OF, points,
                       cells[CHILDREN * a:CHILDREN * b])
        if progress is not None:
            progress.update(b - a)
    return points, cells, out, node_new
