"""Initial bubble placement by recursive subdivision (thesis 4.3.3, Fig. 4.7 (3), (5)).

The intensity-based bubble mesh places its first bubbles by recursion
driven by the size grid: on each boundary edge a **binary tree** (an
interval is halved while it is too long for the size at its midpoint; the
bubbles go to the leaves' ends), and in the face a **quadtree** (a square
cell is split in four while it is larger than the local size; bubbles at
leaf centres inside the domain). The relaxation and the thinning/insertion
that follow (:mod:`polygen.mesh2d.bubble`) correct the counts; the better
the start, the fewer steps they take.

How far to split, and where the face bubbles go
-----------------------------------------------
The thesis says only that the recursion refers to the size values.

* Edges: a leaf interval holds one gap. Halving whenever ``L > tau s`` leaves
  ``L / s`` in ``(tau/2, tau]``; where the size varies, ``log2(L / s)`` is
  spread evenly over that range, and the mean gaps per unit length,
  ``E[1/L] = 1 / (tau s ln 2)``, is the target ``1/s`` for ``tau = 1/ln 2 = 1.443``
  (:data:`EDGE_SPLIT`). Where the size is uniform the count is off by up to
  a factor 1.44 (a power of two per edge); the edge thinning/insertion fixes it.
* Faces: one bubble per leaf would put the density off by up to a factor 2
  where the size is uniform (the leaves are powers of two), and the
  population control, which only removes bubbles overlapping by 40 %, cannot
  undo a 40 % excess: measured, a uniform size of 0.02 on the unit square
  gave mean q 0.84 that way. So the cells are split while their side exceeds
  the side of a hexagonal packing's cell, ``c > sqrt(sqrt(3)/2) s = 0.931 s``
  (:data:`FACE_SPLIT`; the leaves are then never too coarse), and each leaf
  carries a share ``c^2 / ((sqrt(3)/2) s^2) <= 1`` of a bubble; walking the
  leaves in Z order (Morton order, which visits every quadtree block in one
  stretch) a bubble goes to the leaf where the running sum of shares passes
  an integer (error diffusion, seeded offset). Any block of the quadtree so
  gets its expected count of bubbles to within one.

Every level reads the size field once for all its intervals or cells (the
field is a Python callable, a :class:`~polygen.mesh2d.sizing.GridSize`
for chapter 4), so the recursion runs breadth first with numpy. Leaf
centres of equal leaves form a square lattice, an equilibrium of the
inter-bubble force by symmetry, which relaxation would leave only slowly;
each centre is jittered by a seeded uniform offset of up to ``jitter * c``
per coordinate.
"""

import math

import numpy as np
import shapely

from polygen.mesh2d.domain import validate_domain
from polygen.mesh2d.sizing import as_size_function

__all__ = ["EDGE_SPLIT", "FACE_SPLIT", "binary_tree_edge_bubbles", "quadtree_cells",
           "quadtree_face_bubbles"]

EDGE_SPLIT = 1.0 / math.log(2.0)  # halve an interval while L > 1.443 size
HEX_CELL = math.sqrt(3.0) / 2.0  # area per bubble of a hexagonal packing of edge 1
FACE_SPLIT = math.sqrt(HEX_CELL)  # split a cell while c > 0.931 size: c^2 > the hexagonal cell
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
        Halve while ``length > split * size(midpoint)`` (default 1/ln 2 = 1.443:
        the right number of gaps on average where the size varies; see the
        module docstring).
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
        Split while ``side > split * size(centre)`` (default 0.931: a leaf is
        never larger than a hexagonal packing's cell; see the module docstring).
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
    """Initial face bubbles at quadtree leaf centres, one per hexagonal cell's area (Fig. 4.7 (5)).

    The leaves of :func:`quadtree_cells` are walked in Z order, each adding
    its share ``side^2 / ((sqrt(3)/2) size^2)`` of a bubble; a leaf gets a
    bubble where the running sum passes an integer (see the module docstring).

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
        The (jittered) centres of the chosen leaves, strictly inside the polygon.
    cells : (K, 3) float64
        ``(x0, y0, side)`` of each bubble's leaf.
    """
    dom = validate_domain(domain)
    return _quadtree_bubbles(dom, as_size_function(size), split=split, jitter=jitter, seed=seed,
                             max_depth=max_depth)


def _morton(cells, lo, side):
    """Z-order keys of leaf cells (their lower-left corners on the finest level's lattice)."""
    depth = int(np.ceil(np.log2(side / cells[:, 2].min()))) if len(cells) else 0
    depth = min(depth, 31)
    ij = np.floor((cells[:, :2] - lo) / side * (1 << depth) + 0.5).astype(np.int64)
    key = np.zeros(len(cells), np.int64)
    for b in range(depth):
        key |= ((ij[:, 0] >> b) & 1) << (2 * b)
        key |= ((ij[:, 1] >> b) & 1) << (2 * b + 1)
    return key


def _quadtree_bubbles(dom, sizef, *, split=FACE_SPLIT, jitter=0.25, seed=0, max_depth=MAX_DEPTH):
    if not (np.isfinite(jitter) and 0.0 <= jitter < 0.5):
        raise ValueError(f"jitter: expected 0 <= jitter < 0.5, got {jitter}")
    rng = np.random.default_rng(seed)
    cells = _quadtree(dom, sizef, float(split), int(max_depth))
    c = cells[:, 2]
    # a leaf's share of a bubble: its area over a hexagonal cell's, at most 1
    share = np.minimum(1.0, c * c / (HEX_CELL * sizef(cells[:, :2] + 0.5 * c[:, None]) ** 2))
    # error diffusion along the Z order: a bubble wherever the running sum of
    # shares passes an integer, so every stretch of the curve (a block of the
    # quadtree) gets its expected count to within one
    lo = dom.outer.min(axis=0)
    side = float((dom.outer.max(axis=0) - lo).max())
    order = np.argsort(_morton(cells, lo, side), kind="stable")
    acc = np.floor(rng.random() + np.concatenate([[0.0], np.cumsum(share[order])]))
    pick = order[np.diff(acc) > 0]
    cells = cells[pick]
    c = c[pick]
    xy = cells[:, :2] + c[:, None] * (0.5 + jitter * rng.uniform(-1.0, 1.0, (len(cells), 2)))
    inside = shapely.contains_xy(dom.polygon, xy[:, 0], xy[:, 1])
    return xy[inside], cells[inside]
