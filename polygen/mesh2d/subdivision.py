"""Patches into elements, adaptive subdivision, and T-vertex checks.

* :func:`subdivide_patches` splits every patch (Def. 2.2) into elements
  (Def. 2.3) by regular 1 -> 4 splitting, sharing the midpoint nodes
  (Def. 2.4) between neighbouring patches, so no T-vertex (Def. 2.5) arises.
* :func:`adaptive_subdivision` is the h-method of Def. 2.6 (Fig. 2.8):
  elements across which the value jumps by more than a threshold are split,
  and "neighbouring elements are split at the same time so that no T-vertex
  arises".  The thesis does not say how; :func:`refine_marked` offers two
  conforming refinements.  The default, Rivara's longest-edge bisection
  (LEPP), bisects a marked element twice (about four times smaller, as a
  1 -> 4 split) and its neighbours along their longest edges; its angles
  never fall below half of the input's, however many levels are repeated.
  The classic red-green closure (marked elements 1 -> 4 "red", triangles
  with one split edge bisected "green") is kept as ``method="red-green"``;
  repeated, it bisects green triangles again and the smallest angle halves
  at every level (on a bubble mesh 37 -> 23 -> 12 -> 6 -> 3 -> 1.5 degrees
  over five levels).
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


# ---------------------------------------------------------------------------
# longest-edge bisection (Rivara's LEPP algorithm)
# ---------------------------------------------------------------------------

@njit
def _edge_after(nodes, a, b, c, d):
    """True when edge (a, b) comes after edge (c, d) in the strict total order
    (squared length, then the sorted node pair): ties never stall a LEPP walk."""
    dx = nodes[a, 0] - nodes[b, 0]
    dy = nodes[a, 1] - nodes[b, 1]
    l1 = dx * dx + dy * dy
    dx = nodes[c, 0] - nodes[d, 0]
    dy = nodes[c, 1] - nodes[d, 1]
    l2 = dx * dx + dy * dy
    if l1 != l2:
        return l1 > l2
    lo1, hi1 = min(a, b), max(a, b)
    lo2, hi2 = min(c, d), max(c, d)
    if lo1 != lo2:
        return lo1 > lo2
    return hi1 > hi2


@njit
def _longest_edge(nodes, tri, t):
    k = 0
    for q in range(1, 3):
        if _edge_after(nodes, tri[t, q], tri[t, (q + 1) % 3], tri[t, k], tri[t, (k + 1) % 3]):
            k = q
    return k


@njit
def _relink(nb, t, old, new):
    # the neighbour t (if any) pointed at `old` across the edge now owned by `new`
    if t >= 0:
        for q in range(3):
            if nb[t, q] == old:
                nb[t, q] = new
                return


@njit
def _bisect_half(tri, nb, parent, depth, need, t, k, m, s):
    """Split t = (a, b, c) (edge k from a to b) at m: t -> (a, m, c), s -> (m, b, c).

    The outer neighbours across (a, m) and (m, b) are left to the caller."""
    a = tri[t, k]
    b = tri[t, (k + 1) % 3]
    c = tri[t, (k + 2) % 3]
    n_bc = nb[t, (k + 1) % 3]
    n_ca = nb[t, (k + 2) % 3]
    tri[t, 0], tri[t, 1], tri[t, 2] = a, m, c
    tri[s, 0], tri[s, 1], tri[s, 2] = m, b, c
    nb[t, 1], nb[t, 2] = s, n_ca
    nb[s, 1], nb[s, 2] = n_bc, t
    _relink(nb, n_bc, t, s)
    parent[s] = parent[t]
    depth[t] += 1
    depth[s] = depth[t]
    need[s] = need[t]


@njit
def _lepp_kernel(nodes, tri, nb, parent, depth, need, halves, n_nodes, n_tri, start):
    """Bisect every triangle until ``depth >= need``, conformingly, by LEPP.

    Rivara's algorithm: from triangle i follow the longest-edge propagation
    path (to the neighbour across the longest edge while that neighbour's
    longest edge is longer) up to a terminal edge -- the longest edge of both
    triangles sharing it, or of a boundary triangle -- bisect the triangles
    sharing the terminal edge at its midpoint, and repeat until i itself is
    bisected.  Every triangle is so always a longest-edge bisection of the
    triangle it came from.  Stops early, returning the index to resume from,
    when the buffers are full (-1 when done).
    """
    cap_t = tri.shape[0]
    cap_n = nodes.shape[0]
    i = start
    while i < n_tri:
        while depth[i] < need[i]:
            if n_tri + 2 > cap_t or n_nodes + 1 > cap_n:
                return n_nodes, n_tri, i
            t = i
            k = _longest_edge(nodes, tri, t)
            u = -1
            j = -1
            while True:
                u = nb[t, k]
                if u < 0:
                    break
                a = tri[t, k]
                b = tri[t, (k + 1) % 3]
                for q in range(3):
                    if tri[u, q] == b and tri[u, (q + 1) % 3] == a:
                        j = q
                ju = _longest_edge(nodes, tri, u)
                if ju == j:
                    break
                t = u
                k = ju
            a = tri[t, k]
            b = tri[t, (k + 1) % 3]
            m = n_nodes
            nodes[m, 0] = 0.5 * (nodes[a, 0] + nodes[b, 0])
            nodes[m, 1] = 0.5 * (nodes[a, 1] + nodes[b, 1])
            halves[m, 0] = a
            halves[m, 1] = b
            n_nodes += 1
            s = n_tri
            _bisect_half(tri, nb, parent, depth, need, t, k, m, s)
            n_tri += 1
            if u < 0:
                nb[t, 0] = -1
                nb[s, 0] = -1
            else:
                # u = (b, a, d) -> u: (b, m, d), s2: (m, a, d)
                s2 = n_tri
                _bisect_half(tri, nb, parent, depth, need, u, j, m, s2)
                n_tri += 1
                nb[t, 0] = s2
                nb[s2, 0] = t
                nb[s, 0] = u
                nb[u, 0] = s
        i += 1
    return n_nodes, n_tri, -1


def _neighbours(t):
    """(T, 3) int64: the triangle across local edge k, or -1 on the boundary."""
    _, tri_edge = triangle_edges(t)
    flat = tri_edge.ravel()
    use = np.bincount(flat)
    if np.any(use > 2):
        raise ValueError("triangles: an edge is shared by more than two triangles")
    order = np.argsort(flat, kind="stable")
    fs = flat[order]
    pair = np.flatnonzero(fs[1:] == fs[:-1])
    h1 = order[pair]
    h2 = order[pair + 1]
    # neighbours must run along their common edge in opposite directions
    tt = t.ravel()
    nxt = t[:, [1, 2, 0]].ravel()
    if np.any(tt[h1] != nxt[h2]):
        raise ValueError("triangles: neighbours are not consistently oriented")
    nb = np.full(3 * len(t), -1, np.int64)
    nb[h1] = h2 // 3
    nb[h2] = h1 // 3
    return nb.reshape(-1, 3)


def _longest_edge_refine(n, t, marked, times, spare=None):
    nb = _neighbours(t)
    if spare is None:  # room for the triangles and nodes made, grown when short
        spare = 4 * times * int(marked.sum()) + 64
    cap_t = len(t) + spare
    cap_n = len(n) + spare
    nodes = np.empty((cap_n, 2))
    nodes[: len(n)] = n
    tri = np.empty((cap_t, 3), np.int64)
    tri[: len(t)] = t
    nbr = np.empty((cap_t, 3), np.int64)
    nbr[: len(t)] = nb
    parent = np.empty(cap_t, np.int64)
    parent[: len(t)] = np.arange(len(t))
    depth = np.zeros(cap_t, np.int64)
    need = np.zeros(cap_t, np.int64)
    need[: len(t)][marked] = times
    halves = np.empty((cap_n, 2), np.int64)
    n_nodes, n_tri, start = len(n), len(t), 0
    while True:
        n_nodes, n_tri, start = _lepp_kernel(nodes, tri, nbr, parent, depth, need, halves,
                                             n_nodes, n_tri, start)
        if start < 0:
            break
        # buffers full: double them and carry on where the kernel stopped
        nodes, halves = (np.concatenate([x, np.empty_like(x)]) for x in (nodes, halves))
        tri, nbr, parent, depth, need = (np.concatenate([x, np.empty_like(x)])
                                         for x in (tri, nbr, parent, depth, need))
    return (nodes[:n_nodes].copy(), tri[:n_tri].copy(), parent[:n_tri].copy(),
            halves[len(n):n_nodes].copy())


def refine_marked(nodes, triangles, marked, *, method="longest-edge", bisections=2):
    """Conforming local refinement of marked triangles (no T-vertex).

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64
        Consistently oriented (counter-clockwise).
    marked : (T,) bool
        Triangles to refine.
    method : {"longest-edge", "red-green"}, keyword-only
        ``"longest-edge"`` (default): Rivara's longest-edge bisection by
        longest-edge propagation paths (LEPP); every marked triangle is
        bisected ``bisections`` times (twice: about four times smaller, as a
        1 -> 4 split), and neighbours are bisected along their own longest
        edges until the mesh is conforming.  Every output triangle is a
        longest-edge bisection descendant of an input triangle, so its
        smallest angle is at least half the smallest angle of that input
        triangle (Rosenberg & Stenger, Math. Comp. 29, 1975), however often
        it is repeated.  ``"red-green"``: marked triangles split 1 -> 4 into
        similar triangles, the closure splits every triangle with two split
        edges 1 -> 4 and bisects triangles with one split edge; repeated, it
        bisects green triangles again and the angles degrade.  Marking every
        triangle gives the regular 1 -> 4 split.
    bisections : int, keyword-only
        Bisections of each marked triangle (``"longest-edge"`` only).

    Returns
    -------
    nodes : (N + M, 2) float64
        The old nodes unchanged, then the ``M`` edge midpoints.
    triangles : (T2, 3) int64
        Same orientation as the input.
    parent : (T2,) int64
        The input triangle each output triangle lies in.
    edge_nodes : (M, 2) int64
        The two end nodes of the edge each new node halves (for
        interpolating node values).  With ``"longest-edge"`` an end may be a
        node made earlier in the same call (``edge_nodes[i] < N + i``).

    Raises
    ------
    ValueError
        Bad shapes, indices or flags; an edge shared by more than two
        triangles or inconsistently oriented neighbours (``"longest-edge"``).

    References
    ----------
    M.-C. Rivara, "Algorithms for refining triangular grids suitable for
    adaptive and multigrid techniques", Int. J. Numer. Meth. Eng. 20 (1984);
    M.-C. Rivara, "New longest-edge algorithms for the refinement and/or
    improvement of unstructured triangulations", Int. J. Numer. Meth. Eng.
    40 (1997) (LEPP); I. G. Rosenberg and F. Stenger, "A lower bound on the
    angles of triangles constructed by bisecting the longest side", Math.
    Comp. 29 (1975).
    """
    n, t = _check_mesh(nodes, triangles)
    marked = np.asarray(marked, dtype=np.bool_).reshape(-1)
    if marked.shape[0] != len(t):
        raise ValueError(f"marked: expected {len(t)} flags, got {marked.shape[0]}")
    if method == "longest-edge":
        if int(bisections) != bisections or bisections < 1:
            raise ValueError(f"bisections: expected a positive integer, got {bisections}")
        return _longest_edge_refine(n, t, marked, int(bisections))
    if method != "red-green":
        raise ValueError(f"method: expected 'longest-edge' or 'red-green', got {method!r}")
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
        nn, el, parent, _ = refine_marked(nn, el, np.ones(len(el), np.bool_), method="red-green")
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
                         value_fn=None, method="longest-edge"):
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
    method : {"longest-edge", "red-green"}
        The conforming refinement of :func:`refine_marked`.

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
        n2, t2, par, halves = refine_marked(n, t, marked, method=method)
        if per == "node":
            if value_fn is not None and len(halves):
                new = np.asarray(value_fn(n2[len(n):]), dtype=np.float64).reshape(len(halves), -1)
                v = np.concatenate([v, new])
            else:
                v = np.concatenate([v, np.empty((len(halves), v.shape[1]))])
                _midpoint_values(v, halves, len(n))
        else:
            if value_fn is not None:
                cen = n2[t2].mean(axis=1)
                v = np.asarray(value_fn(cen), dtype=np.float64).reshape(len(t2), -1)
            else:
                v = v[par]
        n, t, parent = n2, t2, parent[par]
    return AdaptiveSubdivision(n, t, v[:, 0] if scalar else v, parent, n_marked)


@njit
def _midpoint_values(v, halves, n_old):
    # in creation order: an edge end may itself be a midpoint made earlier
    for i in range(halves.shape[0]):
        for c in range(v.shape[1]):
            v[n_old + i, c] = 0.5 * (v[halves[i, 0], c] + v[halves[i, 1], c])


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
