"""Patches into elements, adaptive subdivision, and T-vertex checks.

* :func:`subdivide_patches` splits every patch (Def. 2.2) into elements
  (Def. 2.3) by regular 1 -> 4 splitting, sharing the midpoint nodes
  (Def. 2.4) between neighbouring patches, so no T-vertex (Def. 2.5) arises.
* :func:`adaptive_subdivision` is the h-method of Def. 2.6 (Fig. 2.8):
  elements across which the value jumps by more than a threshold are split
  1 -> 4 ("red"); the closure marks every edge of a triangle that would get
  two split edges, and a triangle with one split edge is bisected ("green"),
  so the result is conforming.
* :func:`find_t_vertices` / :func:`is_t_vertex_free` check conformity.

Triangles are counter-clockwise ``(T, 3) int64``; local edge ``k`` of a
triangle runs from its vertex ``k`` to vertex ``k + 1 (mod 3)``.
"""

from dataclasses import dataclass

import numpy as np

from polygen._jit import njit

__all__ = [
    "triangle_edges",
    "refine_marked",
    "subdivide_patches",
    "PatchElements",
    "adaptive_subdivision",
    "AdaptiveSubdivision",
    "find_t_vertices",
    "is_t_vertex_free",
]


def _check_mesh(nodes, triangles):
    n = np.ascontiguousarray(nodes, dtype=np.float64)
    t = np.ascontiguousarray(triangles, dtype=np.int64)
    if n.ndim != 2 or n.shape[1] != 2:
        raise ValueError(f"nodes: expected shape (N, 2), got {n.shape}")
    if not np.all(np.isfinite(n)):
        raise ValueError("nodes: non-finite coordinates")
    if t.ndim != 2 or t.shape[1] != 3:
        raise ValueError(f"triangles: expected shape (T, 3), got {t.shape}")
    if t.size and (t.min() < 0 or t.max() >= len(n)):
        raise ValueError(f"triangles: node indices outside [0, {len(n)})")
    return n, t


def triangle_edges(triangles):
    """Unique edges and the triangle -> edge map.

    Returns
    -------
    edges : (E, 2) int64
        Sorted node pairs.
    tri_edge : (T, 3) int64
        ``tri_edge[t, k]`` is the edge from vertex ``k`` to vertex ``k + 1``.
    """
    t = np.asarray(triangles, dtype=np.int64)
    e = np.stack([t, np.roll(t, -1, axis=1)], axis=2).reshape(-1, 2)
    e.sort(axis=1)
    edges, inv = np.unique(e, axis=0, return_inverse=True)
    return edges, inv.reshape(len(t), 3)


@njit
def _closure_kernel(tri_edge, edge_marked):
    # a triangle with two split edges is split on all three (red), repeat
    changed = True
    while changed:
        changed = False
        for t in range(tri_edge.shape[0]):
            c = 0
            for k in range(3):
                if edge_marked[tri_edge[t, k]]:
                    c += 1
            if c == 2:
                for k in range(3):
                    edge_marked[tri_edge[t, k]] = True
                changed = True


@njit
def _count_children(tri_edge, edge_mid):
    n = 0
    for t in range(tri_edge.shape[0]):
        c = 0
        for k in range(3):
            if edge_mid[tri_edge[t, k]] >= 0:
                c += 1
        n += 4 if c == 3 else (2 if c == 1 else 1)
    return n


@njit
def _refine_kernel(tri, tri_edge, edge_mid, out, parent):
    m = 0
    for t in range(tri.shape[0]):
        c = 0
        kk = -1
        for k in range(3):
            if edge_mid[tri_edge[t, k]] >= 0:
                c += 1
                kk = k
        a, b, d = tri[t, 0], tri[t, 1], tri[t, 2]
        if c == 0:
            out[m, 0], out[m, 1], out[m, 2] = a, b, d
            parent[m] = t
            m += 1
        elif c == 3:  # red: 1 -> 4
            mab = edge_mid[tri_edge[t, 0]]
            mbc = edge_mid[tri_edge[t, 1]]
            mca = edge_mid[tri_edge[t, 2]]
            out[m, 0], out[m, 1], out[m, 2] = a, mab, mca
            out[m + 1, 0], out[m + 1, 1], out[m + 1, 2] = mab, b, mbc
            out[m + 2, 0], out[m + 2, 1], out[m + 2, 2] = mca, mbc, d
            out[m + 3, 0], out[m + 3, 1], out[m + 3, 2] = mab, mbc, mca
            for q in range(4):
                parent[m + q] = t
            m += 4
        else:  # green: bisect the one split edge (c == 1 after the closure)
            v0 = tri[t, kk]
            v1 = tri[t, (kk + 1) % 3]
            v2 = tri[t, (kk + 2) % 3]
            mid = edge_mid[tri_edge[t, kk]]
            out[m, 0], out[m, 1], out[m, 2] = v0, mid, v2
            out[m + 1, 0], out[m + 1, 1], out[m + 1, 2] = mid, v1, v2
            parent[m] = t
            parent[m + 1] = t
            m += 2


def refine_marked(nodes, triangles, marked):
    """Red-green refinement of marked triangles, conforming (no T-vertex).

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64
    marked : (T,) bool
        Triangles to split 1 -> 4.

    Returns
    -------
    nodes : (N + M, 2) float64
        The old nodes unchanged, then the ``M`` edge midpoints.
    triangles : (T2, 3) int64
    parent : (T2,) int64
        The input triangle each output triangle lies in.
    edge_nodes : (M, 2) int64
        The two end nodes of the edge each new node halves (for
        interpolating node values).
    """
    n, t = _check_mesh(nodes, triangles)
    marked = np.asarray(marked, dtype=np.bool_).reshape(-1)
    if marked.shape[0] != len(t):
        raise ValueError(f"marked: expected {len(t)} flags, got {marked.shape[0]}")
    edges, tri_edge = triangle_edges(t)
    edge_marked = np.zeros(len(edges), np.bool_)
    edge_marked[tri_edge[marked].ravel()] = True
    _closure_kernel(tri_edge, edge_marked)
    split = np.flatnonzero(edge_marked)
    edge_mid = np.full(len(edges), -1, np.int64)
    edge_mid[split] = len(n) + np.arange(len(split))
    new_nodes = np.concatenate([n, 0.5 * (n[edges[split, 0]] + n[edges[split, 1]])])
    n_out = _count_children(tri_edge, edge_mid)
    out = np.empty((n_out, 3), np.int64)
    parent = np.empty(n_out, np.int64)
    _refine_kernel(t, tri_edge, edge_mid, out, parent)
    return new_nodes, out, parent, edges[split]


@dataclass(frozen=True, eq=False)
class PatchElements:
    """Patches (Def. 2.2) split into elements (Def. 2.3) sharing nodes (Def. 2.4).

    Attributes
    ----------
    nodes : (N, 2) float64
        The patch nodes first (same indices as in ``patches``), then the new ones.
    patches : (P, 3) int64
    elements : (M, 3) int64
        Counter-clockwise.
    element_patch : (M,) int64
        The patch each element belongs to.
    """

    nodes: np.ndarray
    patches: np.ndarray
    elements: np.ndarray
    element_patch: np.ndarray

    def patch_elements(self, p):
        """Indices of the elements of patch ``p``."""
        return np.flatnonzero(self.element_patch == p)


def subdivide_patches(nodes, patches, *, levels=1):
    """Split every patch into ``4**levels`` elements by regular 1 -> 4 splitting.

    Parameters
    ----------
    nodes : (N, 2) float64
    patches : (P, 3) int64
        Counter-clockwise triangles.
    levels : int
        Number of 1 -> 4 splittings (0 gives one element per patch).

    Returns
    -------
    PatchElements
    """
    n, p = _check_mesh(nodes, patches)
    if int(levels) != levels or levels < 0:
        raise ValueError(f"levels: expected a non-negative integer, got {levels}")
    nn, el = n, p
    owner = np.arange(len(p))
    for _ in range(int(levels)):
        nn, el, parent, _ = refine_marked(nn, el, np.ones(len(el), np.bool_))
        owner = owner[parent]
    return PatchElements(nn, p.copy(), el, owner)


@dataclass(frozen=True, eq=False)
class AdaptiveSubdivision:
    """Result of :func:`adaptive_subdivision`.

    Attributes
    ----------
    nodes : (N2, 2) float64
    triangles : (T2, 3) int64
    values : (N2, ...) or (T2, ...) float64
        Values carried to the new mesh (interpolated at new nodes, or inherited
        by child elements), or evaluated by ``value_fn``.
    parent : (T2,) int64
        The input triangle containing each output triangle.
    n_marked : list of int
        Triangles marked at each level.
    """

    nodes: np.ndarray
    triangles: np.ndarray
    values: np.ndarray
    parent: np.ndarray
    n_marked: list


@njit
def _mark_node_jumps(tri, v, threshold, marked):
    # v: (N, C); a triangle is marked when two of its nodes differ by > threshold
    for t in range(tri.shape[0]):
        for k in range(3):
            i = tri[t, k]
            j = tri[t, (k + 1) % 3]
            for c in range(v.shape[1]):
                if abs(v[i, c] - v[j, c]) > threshold:
                    marked[t] = True


@njit
def _mark_element_jumps(tri_edge, n_edges, v, threshold, marked):
    # v: (T, C); elements sharing an edge whose values differ by > threshold
    first = np.full(n_edges, -1, np.int64)
    for t in range(tri_edge.shape[0]):
        for k in range(3):
            e = tri_edge[t, k]
            o = first[e]
            if o < 0:
                first[e] = t
                continue
            for c in range(v.shape[1]):
                if abs(v[t, c] - v[o, c]) > threshold:
                    marked[t] = True
                    marked[o] = True


def adaptive_subdivision(nodes, triangles, values, threshold, *, levels=1, per="node",
                         value_fn=None):
    """Adaptive subdivision (Def. 2.6): split where neighbouring values jump.

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64
    values : (N,) or (N, C) float64 if ``per="node"``; (T,) or (T, C) if ``per="element"``
        E.g. node intensities (RGB as C = 3); the largest channel difference counts.
    threshold : float
        Split an element when the value difference between two of its nodes
        (``per="node"``) or between it and an edge neighbour
        (``per="element"``) exceeds this.
    levels : int
        Rounds of marking and splitting.
    per : {"node", "element"}
    value_fn : callable, optional
        ``value_fn(xy) -> values`` evaluated at new nodes (``per="node"``) or
        element centroids (``per="element"``); without it, new node values are
        the mean of the edge ends and child elements inherit the parent's value.

    Returns
    -------
    AdaptiveSubdivision
        Conforming (no T-vertices); triangles keep their orientation.
    """
    n, t = _check_mesh(nodes, triangles)
    if per not in ("node", "element"):
        raise ValueError(f"per: expected 'node' or 'element', got {per!r}")
    if not (np.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"threshold: must be finite and >= 0, got {threshold}")
    v = np.asarray(values, dtype=np.float64)
    scalar = v.ndim == 1
    v = v.reshape(len(v), -1)
    expect = len(n) if per == "node" else len(t)
    if len(v) != expect:
        raise ValueError(f"values: expected {expect} rows for per={per!r}, got {len(v)}")
    if not np.all(np.isfinite(v)):
        raise ValueError("values: non-finite entries")
    parent = np.arange(len(t))
    n_marked = []
    for _ in range(int(levels)):
        marked = np.zeros(len(t), np.bool_)
        if per == "node":
            _mark_node_jumps(t, np.ascontiguousarray(v), float(threshold), marked)
        else:
            edges, tri_edge = triangle_edges(t)
            _mark_element_jumps(tri_edge, len(edges), np.ascontiguousarray(v), float(threshold), marked)
        n_marked.append(int(marked.sum()))
        if not marked.any():
            break
        n2, t2, par, halves = refine_marked(n, t, marked)
        if per == "node":
            if value_fn is not None and len(halves):
                new = np.asarray(value_fn(n2[len(n):]), dtype=np.float64).reshape(len(halves), -1)
            else:
                new = 0.5 * (v[halves[:, 0]] + v[halves[:, 1]])
            v = np.concatenate([v, new])
        else:
            if value_fn is not None:
                cen = n2[t2].mean(axis=1)
                v = np.asarray(value_fn(cen), dtype=np.float64).reshape(len(t2), -1)
            else:
                v = v[par]
        n, t, parent = n2, t2, parent[par]
    return AdaptiveSubdivision(n, t, v[:, 0] if scalar else v, parent, n_marked)


@njit
def _t_vertex_kernel(nodes, edges, x0, y0, cs, nx, ny, starts, order, tol, hit):
    for e in range(edges.shape[0]):
        a = edges[e, 0]
        b = edges[e, 1]
        ax, ay = nodes[a, 0], nodes[a, 1]
        bx, by = nodes[b, 0], nodes[b, 1]
        dx = bx - ax
        dy = by - ay
        l2 = dx * dx + dy * dy
        if l2 == 0.0:
            continue
        ln = np.sqrt(l2)
        i0 = min(max(int((min(ax, bx) - x0) / cs), 0), nx - 1)
        i1 = min(max(int((max(ax, bx) - x0) / cs), 0), nx - 1)
        j0 = min(max(int((min(ay, by) - y0) / cs), 0), ny - 1)
        j1 = min(max(int((max(ay, by) - y0) / cs), 0), ny - 1)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                c = j * nx + i
                for s in range(starts[c], starts[c + 1]):
                    p = order[s]
                    if p == a or p == b:
                        continue
                    t = ((nodes[p, 0] - ax) * dx + (nodes[p, 1] - ay) * dy) / l2
                    if t <= 0.0 or t >= 1.0:
                        continue
                    dist = abs(dx * (nodes[p, 1] - ay) - dy * (nodes[p, 0] - ax)) / ln
                    if dist <= tol * ln:
                        hit[p] = True


def find_t_vertices(nodes, triangles, *, tol=1e-9):
    """Nodes lying inside another edge, and edges shared by more than two triangles.

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64
    tol : float
        A node counts as on an edge when its distance to it is at most
        ``tol * edge length`` (and it projects strictly inside the edge).

    Returns
    -------
    t_vertices : (K,) int64
        Nodes lying in the interior of some mesh edge (Def. 2.5).
    overshared : (L, 2) int64
        Edges used by more than two triangles.
    """
    n, t = _check_mesh(nodes, triangles)
    edges, tri_edge = triangle_edges(t)
    use = np.bincount(tri_edge.ravel(), minlength=len(edges))
    used = np.zeros(len(n), np.bool_)
    used[t.ravel()] = True
    lo = n.min(axis=0)
    hi = n.max(axis=0)
    ln = np.linalg.norm(n[edges[:, 0]] - n[edges[:, 1]], axis=1)
    cs = max(float(np.median(ln)) if len(ln) else 1.0, 1e-12 * max(np.ptp(n, axis=0).max(), 1.0))
    nx, ny = (np.floor((hi - lo) / cs).astype(np.int64) + 1).tolist()
    cell = (np.minimum(((n[:, 0] - lo[0]) / cs).astype(np.int64), nx - 1)
            + nx * np.minimum(((n[:, 1] - lo[1]) / cs).astype(np.int64), ny - 1))
    cell = np.where(used, cell, nx * ny)  # unused nodes go to a sentinel cell never scanned
    order = np.argsort(cell, kind="stable")
    starts = np.searchsorted(cell[order], np.arange(nx * ny + 1))
    hit = np.zeros(len(n), np.bool_)
    _t_vertex_kernel(n, edges, float(lo[0]), float(lo[1]), cs, nx, ny, starts, order, tol, hit)
    return np.flatnonzero(hit), edges[use > 2]


def is_t_vertex_free(nodes, triangles, *, tol=1e-9):
    """True when no node lies inside an edge and no edge has more than two triangles."""
    tv, over = find_t_vertices(nodes, triangles, tol=tol)
    return len(tv) == 0 and len(over) == 0
