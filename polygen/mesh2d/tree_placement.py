"""Initial bubble placement by recursive subdivision (thesis 4.3.3, Fig. 4.7 (3), (5)).

The intensity-based bubble mesh places its first bubbles by recursion
driven by the size grid: on each boundary edge a **binary tree** (an
interval is halved while it is too long for the size at its midpoint; the
bubbles go to the leaves' ends), and in the face a **quadtree** (a square
cell is split in four while it is too large for the size at its centre;
one bubble at the centre of every leaf cell inside the domain). The
relaxation and the thinning/insertion that follow (:mod:`polygen.mesh2d.bubble`)
correct the counts; the better the start, the fewer steps they take.

When to split
-------------
The thesis says only that the recursion refers to the size values. We split
when splitting brings the local bubble density closer to the target (the
nearest-count rule):

* an interval of length ``L`` holds one gap; halved, two gaps of ``L/2``.
  ``|L/2 - s| < |L - s|`` iff ``L > 4/3 s``, so an interval is halved while
  ``L > 4/3 size(midpoint)`` (:data:`EDGE_SPLIT`). Leaves lie in ``(2/3 s, 4/3 s]``.
* a square cell of side ``c`` holds one bubble, i.e. an area ``c^2`` per
  bubble; a hexagonal packing of edge ``s`` gives each bubble
  ``A* = (sqrt(3)/2) s^2``. Split in four, ``c^2/4``; ``|c^2/4 - A*| < |c^2 - A*|``
  iff ``c^2 > 8/5 A*``, i.e. ``c > sqrt(4 sqrt(3) / 5) s = 1.177 s``
  (:data:`FACE_SPLIT`).

Every level reads the size field once for all its intervals or cells (the
field is a Python callable, a :class:`~polygen.mesh2d.sizing.GridSize`
for chapter 4), so the recursion runs breadth first with numpy. A quadtree's
leaf centres form a square lattice, an equilibrium of the inter-bubble force
by symmetry (every force cancels), which relaxation would never leave; each
centre is therefore jittered by a seeded uniform offset of up to
``jitter * c`` in each coordinate.
"""

import math

import numpy as np
import shapely

from polygen.mesh2d.domain import validate_domain
from polygen.mesh2d.sizing import as_size_function

__all__ = ["EDGE_SPLIT", "FACE_SPLIT", "binary_tree_edge_bubbles", "quadtree_cells",
           "quadtree_face_bubbles"]

EDGE_SPLIT = 1.0 / math.log(2.0)  # halve an interval while L > 1.443 size
FACE_SPLIT = math.sqrt(math.sqrt(3.0) * 3.0 / (4.0 * math.log(2.0)))  # split a cell while c > 1.369 size
MAX_DEPTH = 40  # 2^-40 of a segment or of the domain: far below any size a mesh can use


def _tree_edge(pts, seg, sizef, split, max_depth):
    """Leaf-end parameters of the binary tree on each segment: (t (M,), seg (M,)), sorted."""
    a = pts[seg[:, 0]]
    d = pts[seg[:, 1]] - a
    ln = np.hypot(d[:, 0], d[:, 1])
    # active intervals: segment k, [t0, t0 + w]
    k = np.arange(len(seg))
    t0 = np.zeros(len(seg))
    w = np.ones(len(seg))
    ends_t, ends_k = [], []
    for _ in range(max_depth):
        if not len(k):
            break
        mid = a[k] + (t0 + 0.5 * w)[:, None] * d[k]
        s = sizef(mid)
        cut = w * ln[k] > split * s
        # a halved interval contributes its midpoint: a leaf end shared by its children
        ends_t.append(t0[cut] + 0.5 * w[cut])
        ends_k.append(k[cut])
        k = np.concatenate([k[cut], k[cut]])
        t0 = np.concatenate([t0[cut], t0[cut] + 0.5 * w[cut]])
        w = np.concatenate([0.5 * w[cut], 0.5 * w[cut]])
    t = np.concatenate(ends_t) if ends_t else np.zeros(0)
    kk = np.concatenate(ends_k).astype(np.int64) if ends_k else np.zeros(0, np.int64)
    o = np.lexsort((t, kk))
    return t[o], kk[o]


def binary_tree_edge_bubbles(domain, size, *, split=EDGE_SPLIT, max_depth=MAX_DEPTH):
    """Initial edge bubbles by binary-tree bisection of every boundary segment (Fig. 4.7 (3)).

    A segment is halved, and each half again, while an interval is longer
    than ``split * size`` at its midpoint; the bubbles are the interior ends
    of the leaf intervals (the segment's own ends are the vertex bubbles).

    Parameters
    ----------
    domain : Domain or (K, 2) array_like
        The polygon (see :func:`~polygen.mesh2d.domain.validate_domain`).
    size : float, callable or GridSize
        Target element edge length.
    split : float, keyword-only
        Halve while ``length > split * size(midpoint)`` (default 4/3, the
        nearest-count rule; see the module docstring).
    max_depth : int, keyword-only
        Deepest bisection level.

    Returns
    -------
    xy : (M, 2) float64
    seg : (M,) int64
        The segment of each bubble, in segment order and along each segment
        (as :func:`~polygen.mesh2d.bubble.edge_bubbles`).
    """
    dom = validate_domain(domain)
    pts, seg, _ = dom.segments()
    return _edge_bubbles_tree(pts, seg, as_size_function(size), split=split, max_depth=max_depth)


def _edge_bubbles_tree(pts, seg, sizef, bare=None, *, split=EDGE_SPLIT, max_depth=MAX_DEPTH):
    if not (np.isfinite(split) and split > 0):
        raise ValueError(f"split: must be positive, got {split}")
    if int(max_depth) < 0:
        raise ValueError(f"max_depth: must be >= 0, got {max_depth}")
    use = np.arange(len(seg)) if bare is None else np.flatnonzero(~np.asarray(bare))
    t, k = _tree_edge(pts, seg[use], sizef, float(split), int(max_depth))
    k = use[k]
    a = pts[seg[k, 0]]
    xy = a + t[:, None] * (pts[seg[k, 1]] - a)
    return xy, k.astype(np.int64)


def quadtree_cells(domain, size, *, split=FACE_SPLIT, max_depth=MAX_DEPTH):
    """Leaf cells of the size-driven quadtree over a polygon (Fig. 4.7 (5)).

    The root is the square on the polygon's bounding box (lower-left corner
    at the box's); a cell that meets the polygon is split in four while its
    side exceeds ``split * size`` at its centre. Cells that miss the polygon
    are dropped.

    Parameters
    ----------
    domain : Domain or (K, 2) array_like
    size : float, callable or GridSize
    split : float, keyword-only
        Split while ``side > split * size(centre)`` (default 1.177, the
        nearest-count rule for a hexagonal packing; see the module docstring).
    max_depth : int, keyword-only

    Returns
    -------
    cells : (C, 3) float64
        ``(x0, y0, side)`` of each leaf meeting the polygon.
    """
    dom = validate_domain(domain)
    return _quadtree(dom, as_size_function(size), float(split), int(max_depth))


def _quadtree(dom, sizef, split, max_depth):
    if not (np.isfinite(split) and split > 0):
        raise ValueError(f"split: must be positive, got {split}")
    if max_depth < 0:
        raise ValueError(f"max_depth: must be >= 0, got {max_depth}")
    lo = dom.outer.min(axis=0)
    hi = dom.outer.max(axis=0)
    side = float((hi - lo).max())
    cells = np.array([[lo[0], lo[1], side]])
    leaves = []
    poly = dom.polygon
    shapely.prepare(poly)
    for depth in range(max_depth + 1):
        if not len(cells):
            break
        x0, y0, c = cells[:, 0], cells[:, 1], cells[:, 2]
        meets = shapely.intersects(poly, shapely.box(x0, y0, x0 + c, y0 + c))
        cells = cells[meets]
        c = cells[:, 2]
        centre = cells[:, :2] + 0.5 * c[:, None]
        cut = c > split * sizef(centre)
        if depth == max_depth:
            cut[:] = False
        leaves.append(cells[~cut])
        p = cells[cut]
        h = 0.5 * p[:, 2]
        cells = np.concatenate([
            np.stack([p[:, 0] + dx * h, p[:, 1] + dy * h, h], axis=1)
            for dy in (0, 1) for dx in (0, 1)]) if len(p) else np.zeros((0, 3))
    return np.concatenate(leaves) if leaves else np.zeros((0, 3))


def quadtree_face_bubbles(domain, size, *, split=FACE_SPLIT, jitter=0.25, seed=0,
                          max_depth=MAX_DEPTH):
    """Initial face bubbles at the centres of the quadtree's leaf cells (Fig. 4.7 (5)).

    Parameters
    ----------
    domain : Domain or (K, 2) array_like
    size : float, callable or GridSize
    split : float, keyword-only
        See :func:`quadtree_cells`.
    jitter : float, keyword-only
        Each centre moves by a uniform offset in ``[-jitter c, jitter c]`` per
        coordinate (``c`` the leaf's side), to leave the square lattice's
        symmetric equilibrium; ``0 <= jitter < 0.5`` keeps it in its cell.
    seed : int, keyword-only
    max_depth : int, keyword-only

    Returns
    -------
    xy : (K, 2) float64
        The (jittered) leaf centres strictly inside the polygon.
    cell_side : (K,) float64
        The side of each bubble's leaf.
    """
    dom = validate_domain(domain)
    return _quadtree_bubbles(dom, as_size_function(size), split=split, jitter=jitter, seed=seed,
                             max_depth=max_depth)


def _quadtree_bubbles(dom, sizef, *, split=FACE_SPLIT, jitter=0.25, seed=0, max_depth=MAX_DEPTH):
    if not (np.isfinite(jitter) and 0.0 <= jitter < 0.5):
        raise ValueError(f"jitter: expected 0 <= jitter < 0.5, got {jitter}")
    cells = _quadtree(dom, sizef, float(split), int(max_depth))
    rng = np.random.default_rng(seed)
    c = cells[:, 2]
    xy = cells[:, :2] + c[:, None] * (0.5 + jitter * rng.uniform(-1.0, 1.0, (len(cells), 2)))
    inside = shapely.contains_xy(dom.polygon, xy[:, 0], xy[:, 1])
    return xy[inside], c[inside]
