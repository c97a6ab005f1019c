"""Bubble mesh (thesis 2.3.3; Shimada & Gossard 1995).

Bubbles (discs of diameter ``d = size(x)``) are packed on the domain in
order of dimension: first one fixed bubble on every polygon vertex, then
bubbles on the boundary edges, relaxed along their edges, then bubbles in
the face, relaxed in the plane with the boundary bubbles fixed. The relaxed
centres, triangulated by constrained Delaunay with the boundary chains as
constraints, are the mesh.

Inter-bubble force
------------------
Two bubbles of diameters ``d_i, d_j`` are stable at the distance
``r0 = 0.5 (d_i + d_j)`` (2.11). The thesis approximates the force by a
cubic satisfying the conditions printed (in the thesis text we have) as (2.12)::

    f(r0) = 0, f'(r0) = 0, f''(r0) = 0, f(r1) = 0, f(r) = 0 (r > r1)

Read literally these over-determine a cubic: ``f(r0) = f'(r0) = f''(r0) = 0``
leaves only ``a (r - r0)^3``, which cannot vanish again at ``r1 != r0``. So
the printed conditions cannot be the ones used; the text around it fixes
only the qualitative shape (repulsive below ``r0``, attractive above, zero
beyond ``r1``; Fig. 2.6 (d)). We therefore use Shimada & Gossard's cubic in
``w = r / r0``::

    f(w) = k0 (1.25 w^3 - 2.375 w^2 + 1.125)   for 0 <= w <= 1.5,   0 beyond

which satisfies ``f(1) = 0`` (stable at r0), ``f(1.5) = 0`` (r1 = 1.5 r0,
continuous cut-off), ``f'(0) = 0`` and ``f'(1) = -k0``; it is positive
(repulsive) on ``[0, 1)`` and negative (attractive) on ``(1, 1.5)``.
``tests/test_mesh2d.py`` checks these properties on :func:`bubble_force`.
We take ``k0 = r0`` so that the linearised stiffness ``k0 |f'(1)| / r0`` is
1 whatever the local size, and one time step suits every region of a
graded mesh.

Dynamics
--------
Each bubble obeys ``m x'' + c x' = f`` (2.13), summed over the neighbours
within ``1.5 r0``, found through a uniform grid of cells (of the smallest
interaction range) rebuilt every step; each pair is visited once, from its
larger bubble, so a graded field costs little more than a uniform one.
With ``neighbours="delaunay"`` a face bubble feels only its neighbours in the
Delaunay triangulation of the bubbles, made again after each population
control, as the thesis describes for the intensity-based bubble mesh (4.3.3).
Integration is semi-implicit Euler with the damping taken implicitly,
``v <- (v + dt f / m) / (1 + dt c / m)``, ``x <- x + dt v``, stable for any
damping. The size field is re-read at the moving bubbles every
``resize_every`` steps (it is a Python callable, so between kernel calls). Edge bubbles move only along their segment (force and velocity
projected on the tangent); a face bubble that leaves the domain is put back
just inside the nearest boundary point (or, failing that, where it was).

Population control
------------------
Between relaxation cycles, the bubbles are triangulated: a face bubble whose
Delaunay edge to another bubble is shorter than ``remove_below * r0`` is
removed (too much overlap), and a bubble is inserted at the circumcentre of
every triangle whose circumradius exceeds ``insert_above`` times the local
size (a gap: a missing bubble in a hexagonal packing leaves circumradius
``r0``, a perfect triangle ``r0 / sqrt(3)``).

The same machinery splits patches into elements
(:func:`bubble_subdivide_patches`): all patch nodes are vertex bubbles, all
patch edges carry edge bubbles, and the final triangulation keeps every
patch edge as a chain of constraints.

Initial placement of the face bubbles is a hexagonal lattice of spacing
``min size`` thinned with probability ``(min size / size)^2`` (seeded), or
uniform random points (``init="random"``, as in the upper left of Fig. 2.7),
or the centres of a size-driven quadtree's leaves (``init="quadtree"``, the
intensity-based bubble mesh of 4.3.3, :mod:`polygen.mesh2d.tree_placement`).
Edge bubbles start at equal quantiles of the integrated inverse size
(``edge_init="quantile"``), or at the ends of a binary tree's leaves
(``edge_init="tree"``, 4.3.3); the tree's start is then relaxed along the
edges, thinned or filled (per segment, to the nearest count of the relaxed
chain's ``sum of gap / r0``, re-spaced evenly in that measure where the count
changes), and relaxed again until the count holds.

Limitation: as in the thesis, every polygon vertex is a fixed bubble, so
vertices closer together than the local size give small elements there
(refine the size field near them or simplify the polygon).
"""

import math
from dataclasses import dataclass, field

import numpy as np
import shapely

from polygen._jit import njit, prange
from polygen.mesh2d.delaunay import constrained_delaunay
from polygen.mesh2d.domain import Domain, local_origin, validate_domain
from polygen.mesh2d.sizing import as_size_function
from polygen.mesh2d.subdivision import PatchElements, triangle_edges
from polygen.mesh2d.tree_placement import _edge_bubbles_tree, _quadtree_bubbles

__all__ = [
    "BubbleMesh",
    "bubble_mesh",
    "bubble_force",
    "edge_bubbles",
    "bubble_subdivide_patches",
    "locate_in_triangles",
    "BoundaryLocator",
    "SegmentIndex",
]

W_CUTOFF = 1.5  # r1 / r0


@njit
def _force_w(w):
    # Shimada & Gossard's cubic in w = r / r0, per unit k0 (see module docstring)
    if w >= W_CUTOFF:
        return 0.0
    return 1.25 * w * w * w - 2.375 * w * w + 1.125


def bubble_force(w, k0=1.0):
    """The inter-bubble force ``f(w)``, ``w = r / r0`` (positive = repulsive).

    Parameters
    ----------
    w : array_like float64
        Distances in units of the stable distance ``r0`` (2.11); ``w >= 0``.
    k0 : float
        Stiffness: ``f'(1) = -k0``.

    Returns
    -------
    f : ndarray float64, shape of ``w``
    """
    w = np.asarray(w, dtype=np.float64)
    f = k0 * (1.25 * w**3 - 2.375 * w**2 + 1.125)
    return np.where(w >= W_CUTOFF, 0.0, f)


# ---------------------------------------------------------------------------
# boundary location: inside test, distance and nearest boundary point
# ---------------------------------------------------------------------------

@njit
def _seg_bin_count(pts, seg, x0, y0, cs, nx, ny, counts, fill, starts, out):
    step = 0.25 * cs
    for k in range(seg.shape[0]):
        ax, ay = pts[seg[k, 0], 0], pts[seg[k, 0], 1]
        bx, by = pts[seg[k, 1], 0], pts[seg[k, 1], 1]
        ln = math.hypot(bx - ax, by - ay)
        ns = int(ln / step) + 1
        last = -1
        for s in range(ns + 1):
            t = s / ns
            cx = min(max(int((ax + t * (bx - ax) - x0) / cs), 0), nx - 1)
            cy = min(max(int((ay + t * (by - ay) - y0) / cs), 0), ny - 1)
            c = cy * nx + cx
            if c != last:
                if fill:
                    out[starts[c] + counts[c]] = k
                counts[c] += 1
                last = c


@njit
def _seg_point(px, py, ax, ay, bx, by):
    dx = bx - ax
    dy = by - ay
    l2 = dx * dx + dy * dy
    t = ((px - ax) * dx + (py - ay) * dy) / l2
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    qx = ax + t * dx
    qy = ay + t * dy
    return t, qx, qy, math.hypot(px - qx, py - qy)


@njit
def _left(px, py, ax, ay, bx, by):
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax) > 0.0


@njit
def _side_from_segment(px, py, k, t, pts, seg, seg_prev, seg_next):
    # Interior lies left of every segment; at a vertex, combine both segments.
    a = seg[k, 0]
    b = seg[k, 1]
    ax, ay, bx, by = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1]
    if 0.0 < t < 1.0:
        return _left(px, py, ax, ay, bx, by)
    if t <= 0.0:
        k1 = seg_prev[k]
        k2 = k
    else:
        k1 = k
        k2 = seg_next[k]
    ux, uy = pts[seg[k1, 0], 0], pts[seg[k1, 0], 1]
    vx, vy = pts[seg[k1, 1], 0], pts[seg[k1, 1], 1]
    wx, wy = pts[seg[k2, 1], 0], pts[seg[k2, 1], 1]
    l1 = _left(px, py, ux, uy, vx, vy)
    l2 = _left(px, py, vx, vy, wx, wy)
    convex = (vx - ux) * (wy - vy) - (vy - uy) * (wx - vx) > 0.0
    if convex:
        return l1 and l2
    return l1 or l2


@njit
def _even_odd(px, py, pts, seg):
    inside = False
    for k in range(seg.shape[0]):
        ax, ay = pts[seg[k, 0], 0], pts[seg[k, 0], 1]
        bx, by = pts[seg[k, 1], 0], pts[seg[k, 1], 1]
        if (ay > py) != (by > py):
            xc = ax + (py - ay) * (bx - ax) / (by - ay)
            if xc > px:
                inside = not inside
    return inside


@njit
def _nearest_segment(px, py, cx, cy, m, pts, seg, nx, ny, starts, segs):
    best = np.inf
    bk = -1
    bt = 0.0
    bqx = px
    bqy = py
    for jy in range(max(cy - m, 0), min(cy + m + 1, ny)):
        for jx in range(max(cx - m, 0), min(cx + m + 1, nx)):
            cc = jy * nx + jx
            for s in range(starts[cc], starts[cc + 1]):
                k = segs[s]
                a = seg[k, 0]
                b = seg[k, 1]
                t, qx, qy, d = _seg_point(px, py, pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1])
                if d < best:
                    best = d
                    bk = k
                    bt = t
                    bqx = qx
                    bqy = qy
    return best, bk, bt, bqx, bqy


@njit
def _locate(px, py, pts, seg, seg_prev, seg_next, x0, y0, cs, nx, ny, state, starts, segs):
    """(inside, distance, qx, qy); distance = inf when no boundary is within a cell."""
    fx = (px - x0) / cs
    fy = (py - y0) / cs
    if fx < 0.0 or fy < 0.0 or fx >= nx or fy >= ny:
        return False, np.inf, px, py
    cx = int(fx)
    cy = int(fy)
    c = cy * nx + cx
    if state[c] != 2:
        return state[c] == 1, np.inf, px, py
    best, bk, bt, bqx, bqy = _nearest_segment(px, py, cx, cy, 1, pts, seg, nx, ny, starts, segs)
    if best > cs:
        # a segment crosses the 3 x 3 block, so the nearest one is within
        # 2 sqrt(2) cells: a 7 x 7 block is sure to hold it
        best, bk, bt, bqx, bqy = _nearest_segment(px, py, cx, cy, 3, pts, seg, nx, ny, starts, segs)
    if bk < 0:
        return _even_odd(px, py, pts, seg), np.inf, px, py
    return _side_from_segment(px, py, bk, bt, pts, seg, seg_prev, seg_next), best, bqx, bqy


@njit(parallel=True)
def _locate_many(xy, pts, seg, seg_prev, seg_next, x0, y0, cs, nx, ny, state, starts, segs,
                 inside, dist):
    for i in prange(xy.shape[0]):
        ins, d, qx, qy = _locate(xy[i, 0], xy[i, 1], pts, seg, seg_prev, seg_next,
                                 x0, y0, cs, nx, ny, state, starts, segs)
        inside[i] = ins
        dist[i] = d


@dataclass(frozen=True, eq=False)
class BoundaryLocator:
    """Inside test and distance to the boundary, accelerated by a uniform grid.

    Build with :meth:`build`. Each cell is marked outside, inside, or near the
    boundary (a boundary segment crosses its 3 x 3 block); only points in
    near cells look at segments: the nearest one decides the side (at a
    vertex, both incident segments with the convex/reflex rule).
    """

    pts: np.ndarray
    seg: np.ndarray
    seg_prev: np.ndarray
    seg_next: np.ndarray
    x0: float
    y0: float
    cs: float
    nx: int
    ny: int
    state: np.ndarray
    starts: np.ndarray
    segs: np.ndarray

    @classmethod
    def build(cls, domain, cell):
        dom = validate_domain(domain)
        pts, seg, seg_prev = dom.segments()
        seg_next = np.empty_like(seg_prev)
        seg_next[seg_prev] = np.arange(len(seg_prev))
        lo = pts.min(axis=0) - cell
        hi = pts.max(axis=0) + cell
        nx, ny = (np.ceil((hi - lo) / cell).astype(np.int64) + 1).tolist()
        counts = np.zeros(nx * ny, np.int64)
        dummy = np.zeros(1, np.int64)
        _seg_bin_count(pts, seg, lo[0], lo[1], cell, nx, ny, counts, False, dummy, dummy)
        starts = np.zeros(nx * ny + 1, np.int64)
        np.cumsum(counts, out=starts[1:])
        segs = np.empty(starts[-1], np.int64)
        counts[:] = 0
        _seg_bin_count(pts, seg, lo[0], lo[1], cell, nx, ny, counts, True, starts, segs)
        has = (counts > 0).reshape(ny, nx)
        near = np.zeros_like(has)
        for dy in (-1, 0, 1):  # 3 x 3 dilation (9 array operations, not a loop over cells)
            for dx in (-1, 0, 1):
                near |= np.roll(np.roll(has, dy, axis=0), dx, axis=1)
        X, Y = np.meshgrid(lo[0] + (np.arange(nx) + 0.5) * cell, lo[1] + (np.arange(ny) + 0.5) * cell)
        inside = shapely.contains_xy(dom.polygon, X.ravel(), Y.ravel()).reshape(ny, nx)
        state = np.where(near, 2, inside.astype(np.int8)).astype(np.int8).ravel()
        return cls(pts, seg, seg_prev, seg_next, float(lo[0]), float(lo[1]), float(cell),
                   int(nx), int(ny), state, starts, segs)

    def args(self):
        return (self.pts, self.seg, self.seg_prev, self.seg_next, self.x0, self.y0, self.cs,
                self.nx, self.ny, self.state, self.starts, self.segs)

    def locate(self, xy):
        """Inside flags ``(K,) bool`` and boundary distances ``(K,) float64`` (inf when > one cell)."""
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        inside = np.empty(len(xy), np.bool_)
        dist = np.empty(len(xy))
        _locate_many(xy, *self.args(), inside, dist)
        return inside, dist


@njit(parallel=True)
def _seg_distance_many(xy, pts, seg, x0, y0, cs, nx, ny, starts, segs, dist):
    for i in prange(xy.shape[0]):
        px = xy[i, 0]
        py = xy[i, 1]
        fx = (px - x0) / cs
        fy = (py - y0) / cs
        if fx < 0.0 or fy < 0.0 or fx >= nx or fy >= ny:
            dist[i] = np.inf
            continue
        best, bk, bt, qx, qy = _nearest_segment(px, py, int(fx), int(fy), 1, pts, seg, nx, ny,
                                                starts, segs)
        dist[i] = best if best <= cs else np.inf


@dataclass(frozen=True, eq=False)
class SegmentIndex:
    """Distance to a set of segments (inf beyond one cell), through a uniform grid."""

    pts: np.ndarray
    seg: np.ndarray
    x0: float
    y0: float
    cs: float
    nx: int
    ny: int
    starts: np.ndarray
    segs: np.ndarray

    @classmethod
    def build(cls, pts, seg, cell):
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        seg = np.ascontiguousarray(seg, dtype=np.int64)
        lo = pts.min(axis=0) - cell
        hi = pts.max(axis=0) + cell
        nx, ny = (np.ceil((hi - lo) / cell).astype(np.int64) + 1).tolist()
        counts = np.zeros(nx * ny, np.int64)
        dummy = np.zeros(1, np.int64)
        _seg_bin_count(pts, seg, lo[0], lo[1], cell, nx, ny, counts, False, dummy, dummy)
        starts = np.zeros(nx * ny + 1, np.int64)
        np.cumsum(counts, out=starts[1:])
        segs = np.empty(starts[-1], np.int64)
        counts[:] = 0
        _seg_bin_count(pts, seg, lo[0], lo[1], cell, nx, ny, counts, True, starts, segs)
        return cls(pts, seg, float(lo[0]), float(lo[1]), float(cell), int(nx), int(ny), starts, segs)

    def distance(self, xy):
        """Distances ``(K,) float64`` to the nearest segment, inf when farther than one cell."""
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        out = np.empty(len(xy))
        _seg_distance_many(xy, self.pts, self.seg, self.x0, self.y0, self.cs, self.nx, self.ny,
                           self.starts, self.segs, out)
        return out


# ---------------------------------------------------------------------------
# relaxation
# ---------------------------------------------------------------------------

@njit
def _forces(xy, size, group, first_movable, gx0, gy0, gcs, gnx, gny, starts, order, force):
    # Each pair is found by its larger bubble i, within 1.5 d_i >= 0.75 (d_i + d_j)
    # = r1, so a uniform grid of the smallest size serves a graded field: small
    # bubbles look at few cells, the few large ones at more.
    # Serial on purpose: called every step, thread start-up (or a machine
    # shared with other jobs) costs more than it saves here.
    n = xy.shape[0]
    for i in range(n):
        force[i, 0] = 0.0
        force[i, 1] = 0.0
    for i in range(n):
        xi = xy[i, 0]
        yi = xy[i, 1]
        si = size[i]
        cx = min(max(int((xi - gx0) / gcs), 0), gnx - 1)
        cy = min(max(int((yi - gy0) / gcs), 0), gny - 1)
        m = int(math.ceil(W_CUTOFF * si / gcs))
        for jy in range(max(cy - m, 0), min(cy + m + 1, gny)):
            for jx in range(max(cx - m, 0), min(cx + m + 1, gnx)):
                c = jy * gnx + jx
                for s in range(starts[c], starts[c + 1]):
                    j = order[s]
                    sj = size[j]
                    if sj > si or (sj == si and j <= i):
                        continue  # the pair belongs to j
                    if i < first_movable and j < first_movable:
                        continue
                    if group[i] >= 0 and group[j] >= 0 and group[i] != group[j]:
                        continue  # edge stage: bubbles of different edges ignore each other
                    dx = xi - xy[j, 0]
                    dy = yi - xy[j, 1]
                    r2 = dx * dx + dy * dy
                    r0 = 0.5 * (si + sj)  # (2.11)
                    if r2 >= (W_CUTOFF * r0) ** 2 or r2 == 0.0:
                        continue  # beyond r1
                    r = math.sqrt(r2)
                    f = r0 * _force_w(r / r0) / r  # (2.12) with k0 = r0
                    force[i, 0] += f * dx
                    force[i, 1] += f * dy
                    force[j, 0] -= f * dx
                    force[j, 1] -= f * dy


@njit
def _forces_adjacent(xy, size, group, first_movable, adj_start, adj, force):
    # forces between Delaunay neighbours only (4.3.3, faces step 2-3): the pair
    # (i, j) is visited from its smaller index; beyond r1 the cubic is zero anyway
    n = xy.shape[0]
    for i in range(n):
        force[i, 0] = 0.0
        force[i, 1] = 0.0
    for i in range(n):
        for s in range(adj_start[i], adj_start[i + 1]):
            j = adj[s]
            if j <= i:
                continue
            if i < first_movable and j < first_movable:
                continue
            if group[i] >= 0 and group[j] >= 0 and group[i] != group[j]:
                continue
            dx = xy[i, 0] - xy[j, 0]
            dy = xy[i, 1] - xy[j, 1]
            r2 = dx * dx + dy * dy
            r0 = 0.5 * (size[i] + size[j])  # (2.11)
            if r2 >= (W_CUTOFF * r0) ** 2 or r2 == 0.0:
                continue
            r = math.sqrt(r2)
            f = r0 * _force_w(r / r0) / r  # (2.12) with k0 = r0
            force[i, 0] += f * dx
            force[i, 1] += f * dy
            force[j, 0] -= f * dx
            force[j, 1] -= f * dy


def _adjacency(n, tri):
    """CSR neighbour lists ``(start (n+1,), adj)`` of the edges of triangles ``tri``."""
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    e = np.unique(e, axis=0)
    start = np.searchsorted(e[:, 0], np.arange(n + 1)).astype(np.int64)
    return start, np.ascontiguousarray(e[:, 1], dtype=np.int64)


@njit
def _bin_points(xy, gx0, gy0, gcs, gnx, gny, starts, order, cell):
    n = xy.shape[0]
    nc = gnx * gny
    for c in range(nc + 1):
        starts[c] = 0
    for i in range(n):
        cx = min(max(int((xy[i, 0] - gx0) / gcs), 0), gnx - 1)
        cy = min(max(int((xy[i, 1] - gy0) / gcs), 0), gny - 1)
        cell[i] = cy * gnx + cx
        starts[cell[i] + 1] += 1
    for c in range(nc):
        starts[c + 1] += starts[c]
    fill = starts[:nc].copy()
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1


@njit
def _relax_kernel(xy, vel, size, group, n_fixed, n_edge, eab, pts, seg, seg_prev, seg_next,
                  bx0, by0, bcs, bnx, bny, bstate, bstarts, bsegs,
                  gx0, gy0, gcs, gnx, gny, n_steps, dt, mass, damping, tol, edge_margin,
                  adj_start, adj):
    """Relax bubbles ``n_fixed:`` for up to n_steps; returns (steps, last max |dx| / size).

    Neighbours are the bubbles within r1 (a grid search every step), or, when
    ``adj_start`` is not empty, the fixed lists ``adj`` (Delaunay neighbours).
    """
    n = xy.shape[0]
    starts = np.empty(gnx * gny + 1, np.int64)
    order = np.empty(n, np.int64)
    cell = np.empty(n, np.int64)
    force = np.zeros((n, 2))
    first_face = n_fixed + n_edge
    denom = 1.0 + dt * damping / mass
    step_max = 0.0
    for step in range(n_steps):
        if adj_start.shape[0] > 0:
            _forces_adjacent(xy, size, group, n_fixed, adj_start, adj, force)
        else:
            _bin_points(xy, gx0, gy0, gcs, gnx, gny, starts, order, cell)
            _forces(xy, size, group, n_fixed, gx0, gy0, gcs, gnx, gny, starts, order, force)
        step_max = 0.0
        # (2.13) m x'' + c x' = f, semi-implicit Euler with implicit damping
        for i in range(n_fixed, first_face):
            ax, ay, ex, ey = eab[i, 0], eab[i, 1], eab[i, 2], eab[i, 3]
            ln = math.hypot(ex - ax, ey - ay)
            tx = (ex - ax) / ln
            ty = (ey - ay) / ln
            ft = force[i, 0] * tx + force[i, 1] * ty
            v = (vel[i, 0] + dt * ft / mass) / denom
            s = (xy[i, 0] - ax) * tx + (xy[i, 1] - ay) * ty
            s_new = s + dt * v
            lo = min(edge_margin * size[i], 0.5 * ln)
            if s_new < lo:
                s_new = lo
                v = 0.0
            elif s_new > ln - lo:
                s_new = ln - lo
                v = 0.0
            vel[i, 0] = v
            vel[i, 1] = 0.0
            d = abs(s_new - s) / size[i]
            step_max = max(step_max, d)
            xy[i, 0] = ax + s_new * tx
            xy[i, 1] = ay + s_new * ty
        for i in range(first_face, n):
            vx = (vel[i, 0] + dt * force[i, 0] / mass) / denom
            vy = (vel[i, 1] + dt * force[i, 1] / mass) / denom
            nxp = xy[i, 0] + dt * vx
            nyp = xy[i, 1] + dt * vy
            ins, dist, qx, qy = _locate(nxp, nyp, pts, seg, seg_prev, seg_next,
                                        bx0, by0, bcs, bnx, bny, bstate, bstarts, bsegs)
            if not ins:
                # left the domain: put it back just inside the nearest boundary point
                dd = math.hypot(qx - nxp, qy - nyp)
                ok = False
                if dd > 0.0 and np.isfinite(dist):
                    px = qx + (qx - nxp) / dd * 0.25 * size[i]
                    py = qy + (qy - nyp) / dd * 0.25 * size[i]
                    ins2, d2, q2x, q2y = _locate(px, py, pts, seg, seg_prev, seg_next,
                                                 bx0, by0, bcs, bnx, bny, bstate, bstarts, bsegs)
                    if ins2:
                        nxp = px
                        nyp = py
                        ok = True
                if not ok:
                    nxp = xy[i, 0]
                    nyp = xy[i, 1]
                vx = 0.0
                vy = 0.0
            d = math.hypot(nxp - xy[i, 0], nyp - xy[i, 1]) / size[i]
            step_max = max(step_max, d)
            xy[i, 0] = nxp
            xy[i, 1] = nyp
            vel[i, 0] = vx
            vel[i, 1] = vy
        if step_max < tol:
            return step + 1, step_max
    return n_steps, step_max


# ---------------------------------------------------------------------------
# placement and population control
# ---------------------------------------------------------------------------

@njit
def _place_edge_kernel(pts, seg, cum, counts, offsets, out_xy, out_seg):
    m = cum.shape[1]
    for k in range(seg.shape[0]):
        n = counts[k]
        ax, ay = pts[seg[k, 0], 0], pts[seg[k, 0], 1]
        bx, by = pts[seg[k, 1], 0], pts[seg[k, 1], 1]
        total = cum[k, m - 1]
        j = 0
        for q in range(1, n):
            target = total * q / n
            while j < m - 2 and cum[k, j + 1] < target:
                j += 1
            span = cum[k, j + 1] - cum[k, j]
            u = (target - cum[k, j]) / span if span > 0 else 0.0
            t = (j + u) / (m - 1)
            o = offsets[k] + q - 1
            out_xy[o, 0] = ax + t * (bx - ax)
            out_xy[o, 1] = ay + t * (by - ay)
            out_seg[o] = k


@njit
def _edge_control_kernel(pts, seg, bare, vsize, exy, eseg, esz, out_xy, out_seg):
    """Thinning/insertion of edge bubbles, segment by segment (4.3.3, edges step 3).

    ``exy`` are sorted by segment and along it. A segment's chain (vertex a,
    its bubbles, vertex b) has gaps ``g_i = d_i / r0_i`` (r0 from (2.11)) and
    a normalised length ``lam = sum g_i ~ integral ds / size``; its gap count
    goes to the nearest count ``n = max(1, round(lam))``. Where the count
    changes, the new chain is spaced at equal steps ``lam / n`` of the old
    chain's normalised length (interpolated along it): the fixed point of the
    1-D relaxation (every gap at its r0, up to the rounding of lam). Thinning
    or filling a chain locally instead leaves gaps beyond the force's cut-off
    r1 = 1.5 r0 (removing one bubble of a chain at 0.78 r0 makes a 1.56 r0
    gap), which the relaxation cannot close. Segments marked ``bare`` carry no
    bubbles and get none. Returns (count, inserted, removed); ``out_*`` hold
    ``2 M + S`` entries.
    """
    ns = seg.shape[0]
    m = 0
    n_ins = 0
    n_rem = 0
    first = 0
    ne = eseg.shape[0]
    for k in range(ns):
        last = first
        while last < ne and eseg[last] == k:
            last += 1
        nb = last - first
        if bare[k]:
            first = last
            continue
        # chain: vertex a, bubbles first..last-1, vertex b
        cx = np.empty(nb + 2)
        cy = np.empty(nb + 2)
        cs = np.empty(nb + 2)
        cx[0] = pts[seg[k, 0], 0]
        cy[0] = pts[seg[k, 0], 1]
        cs[0] = vsize[seg[k, 0]]
        for i in range(nb):
            cx[i + 1] = exy[first + i, 0]
            cy[i + 1] = exy[first + i, 1]
            cs[i + 1] = esz[first + i]
        cx[nb + 1] = pts[seg[k, 1], 0]
        cy[nb + 1] = pts[seg[k, 1], 1]
        cs[nb + 1] = vsize[seg[k, 1]]
        ng = nb + 1
        cum = np.zeros(ng + 1)
        for i in range(ng):
            g = math.hypot(cx[i + 1] - cx[i], cy[i + 1] - cy[i]) / (0.5 * (cs[i] + cs[i + 1]))
            cum[i + 1] = cum[i] + g
        lam = cum[ng]
        target = max(1, int(math.floor(lam + 0.5)))
        if target == ng:
            for i in range(1, nb + 1):
                out_xy[m, 0] = cx[i]
                out_xy[m, 1] = cy[i]
                out_seg[m] = k
                m += 1
        else:
            if target > ng:
                n_ins += target - ng
            else:
                n_rem += ng - target
            j = 0
            for q in range(1, target):
                want = lam * q / target
                while j < ng - 1 and cum[j + 1] < want:
                    j += 1
                span = cum[j + 1] - cum[j]
                u = (want - cum[j]) / span if span > 0 else 0.0
                out_xy[m, 0] = cx[j] + u * (cx[j + 1] - cx[j])
                out_xy[m, 1] = cy[j] + u * (cy[j + 1] - cy[j])
                out_seg[m] = k
                m += 1
        first = last
    return m, n_ins, n_rem


def edge_bubbles(domain, size, *, samples=33):
    """Initial bubbles on the boundary segments, spaced by the size field.

    Segment ``k`` gets ``n_k = max(1, round(integral of ds / size))``
    intervals, the bubbles at equal quantiles of that integral (the 1-D
    equilibrium of the chain when the size varies slowly).

    Returns
    -------
    xy : (M, 2) float64
    seg : (M,) int64
        The segment of each bubble, in segment order and along each segment.
    """
    dom = validate_domain(domain)
    pts, seg, _ = dom.segments()
    return _edge_bubbles(pts, seg, as_size_function(size), samples)


def _edge_bubbles(pts, seg, sizef, samples=33, bare=None):
    t = np.linspace(0.0, 1.0, samples)
    a = pts[seg[:, 0]]
    b = pts[seg[:, 1]]
    sp = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
    h = sizef(sp.reshape(-1, 2)).reshape(len(seg), samples)
    ln = np.linalg.norm(b - a, axis=1)
    inv = 1.0 / h
    cum = np.zeros_like(inv)
    cum[:, 1:] = np.cumsum(0.5 * (inv[:, 1:] + inv[:, :-1]), axis=1) * (ln / (samples - 1))[:, None]
    counts = np.maximum(1, np.rint(cum[:, -1])).astype(np.int64)
    if bare is not None:
        counts[bare] = 1
    offsets = np.zeros(len(seg), np.int64)
    offsets[1:] = np.cumsum(counts - 1)[:-1]
    total = int((counts - 1).sum())
    out_xy = np.empty((total, 2))
    out_seg = np.empty(total, np.int64)
    _place_edge_kernel(pts, seg, cum, counts, offsets, out_xy, out_seg)
    return out_xy, out_seg


@njit
def _removal_kernel(xy, size, tri, first_face, remove_below, removed, group):
    for t in range(tri.shape[0]):
        for e in range(3):
            i = tri[t, e]
            j = tri[t, (e + 1) % 3]
            if removed[i] or removed[j]:
                continue
            if i < first_face and j < first_face:
                continue
            if group[i] >= 0 and group[j] >= 0 and group[i] != group[j]:
                continue  # face bubbles of different regions do not crowd each other
            r = math.hypot(xy[i, 0] - xy[j, 0], xy[i, 1] - xy[j, 1])
            if r < remove_below * 0.5 * (size[i] + size[j]):
                # remove a face bubble, the later one when both are
                if j >= first_face and (i < first_face or j > i):
                    removed[j] = True
                else:
                    removed[i] = True


@njit
def _gap_kernel(xy, size, tri, insert_above, out):
    m = 0
    for t in range(tri.shape[0]):
        a = tri[t, 0]
        b = tri[t, 1]
        c = tri[t, 2]
        ax, ay = xy[a, 0], xy[a, 1]
        bx, by = xy[b, 0] - ax, xy[b, 1] - ay
        cx, cy = xy[c, 0] - ax, xy[c, 1] - ay
        d = 2.0 * (bx * cy - by * cx)
        if d <= 0.0:
            continue
        b2 = bx * bx + by * by
        c2 = cx * cx + cy * cy
        ux = (cy * b2 - by * c2) / d
        uy = (bx * c2 - cx * b2) / d
        rc = math.hypot(ux, uy)
        h = (size[a] + size[b] + size[c]) / 3.0
        if rc > insert_above * h:
            out[m, 0] = ax + ux
            out[m, 1] = ay + uy
            out[m, 2] = h
            m += 1
    return m


@njit
def _dedupe_kernel(cand, keep, frac):
    # greedy: drop a candidate closer than frac * size to an earlier kept one
    for i in range(cand.shape[0]):
        if not keep[i]:
            continue
        for j in range(i):
            if keep[j]:
                if math.hypot(cand[i, 0] - cand[j, 0], cand[i, 1] - cand[j, 1]) < frac * cand[i, 2]:
                    keep[i] = False
                    break


def _hex_lattice(lo, hi, h, offset):
    dy = h * math.sqrt(3.0) / 2.0
    ny = int(math.ceil((hi[1] - lo[1]) / dy)) + 2
    nx = int(math.ceil((hi[0] - lo[0]) / h)) + 2
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    x = lo[0] + offset[0] + (i + 0.5 * (j % 2)) * h
    y = lo[1] + offset[1] + j * dy
    return np.stack([x.ravel(), y.ravel()], axis=1)


@dataclass(frozen=True, eq=False)
class BubbleMesh:
    """Result of :func:`bubble_mesh`.

    Attributes
    ----------
    nodes : (N, 2) float64
        Vertex bubbles, then edge bubbles, then face bubbles.
    triangles : (T, 3) int64
        Constrained Delaunay of the nodes, counter-clockwise.
    kind : (N,) int8
        0 vertex, 1 edge, 2 face.
    sizes : (N,) float64
        Bubble diameters (the size field at each node).
    constrained_edges : (E, 2) int64
        The boundary chains imposed on the triangulation.
    initial : (N0, 2) float64
        Bubble centres before relaxation (for Fig. 2.7).
    n_steps : int
        Relaxation steps taken (all stages).
    n_inserted, n_removed : int
        Population control totals.
    """

    nodes: np.ndarray
    triangles: np.ndarray
    kind: np.ndarray
    sizes: np.ndarray
    constrained_edges: np.ndarray
    initial: np.ndarray
    n_steps: int = 0
    n_inserted: int = 0
    n_removed: int = 0
    history: list = field(default_factory=list)


def _boundary_edges(n_vertex, seg, eseg):
    """Constraint chains: vertex a_k, edge bubbles of k in order, vertex b_k."""
    ne = len(eseg)
    idx = n_vertex + np.arange(ne)
    counts = np.bincount(eseg, minlength=len(seg))
    # first / last edge bubble of each segment (eseg is sorted, bubbles in order)
    first = np.zeros(len(seg), np.int64)
    np.cumsum(counts[:-1], out=first[1:])
    inner = np.stack([idx[:-1], idx[1:]], axis=1)[eseg[:-1] == eseg[1:]] if ne > 1 else np.zeros((0, 2), np.int64)
    has = counts > 0
    start = np.where(has, n_vertex + first, seg[:, 1])
    head = np.stack([seg[:, 0], start], axis=1)
    tail = np.stack([n_vertex + first + counts - 1, seg[:, 1]], axis=1)[has]
    return np.concatenate([head, inner, tail]).astype(np.int64)


def _cdt_inside(xy, cons, internal, dom, h_min):
    """Triangles of the constrained Delaunay of ``xy`` inside the domain (as the final mesh)."""
    mesh = constrained_delaunay(xy, cons, erase_outside=not internal)
    tri = mesh.triangles
    if internal:
        cen = xy[tri].mean(axis=1)
        a, b, c = (xy[tri[:, k]] for k in range(3))
        area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        inside = shapely.contains_xy(dom.polygon, cen[:, 0], cen[:, 1])
        tri = tri[inside & (np.abs(area2) > 1e-8 * h_min * h_min)]
    return tri


def _circumcentres(xy, tri):
    """(T, 2) circumcentres and (T,) circumradii."""
    a, b, c = (xy[tri[:, k]] for k in range(3))
    b = b - a
    c = c - a
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    bb = (b * b).sum(axis=1)
    cc = (c * c).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (c[:, 1] * bb - b[:, 1] * cc) / d
        uy = (b[:, 0] * cc - c[:, 0] * bb) / d
    return a + np.stack([ux, uy], axis=1), np.hypot(ux, uy)


def _improve_packing(xy, n_fixed, triangulate, sizef, admissible, *, rounds, angle, groups=None):
    """Insertion at bad triangles and Laplacian smoothing of the face bubbles, kept only if better.

    Where the size field asks for bubbles larger than the domain's features (a hole or a
    channel narrower than the size), relaxation pushes the few face bubbles against the
    boundary and the Delaunay joins the boundary nodes by skinny triangles. Each round
    inserts a bubble at the circumcentre of every triangle with a smallest angle below
    ``angle`` (when admissible: inside, off the segments, in its region, and at least half
    its size from every node), then moves every face bubble to the mean of its Delaunay
    neighbours (three passes, reconnecting by Delaunay after each; a move that is not
    admissible is not made). A round is kept only if it raises the smallest angle, or
    keeps it at or above ``min(smallest, angle)`` and raises the mean radius ratio.

    Returns
    -------
    xy : (K, 2) float64
        The bubbles, the first ``n_fixed`` unchanged.
    n_inserted : int
    """
    from scipy.spatial import cKDTree

    from polygen.mesh2d.quality import triangle_quality

    def score(q):
        try:
            tri = triangulate(q)
        except ValueError:  # two bubbles met: not a candidate
            return (-np.inf, -np.inf), np.zeros((0, 3), np.int64)
        if not len(tri):
            return (-1.0, -1.0), tri
        ang, qq = triangle_quality(q, tri)
        return (float(ang.min()), float(qq.mean())), tri

    best, tri = score(xy)
    n_inserted = 0
    for _ in range(rounds):
        ang, _q = triangle_quality(xy, tri)
        cen, rad = _circumcentres(xy, tri[ang < angle])
        ok = np.isfinite(rad)
        cen, rad = cen[ok], rad[ok]
        add = np.zeros((0, 2))
        if len(cen):
            sz = sizef(cen)
            keep = admissible(cen, None) & (rad >= 0.5 * sz)
            cen, sz = cen[keep], sz[keep]
            if len(cen):
                gaps = np.concatenate([cen, sz[:, None]], axis=1)
                sel = np.ones(len(gaps), np.bool_)
                _dedupe_kernel(gaps, sel, 0.5)
                cen, sz = cen[sel], sz[sel]
                near, _ = cKDTree(xy).query(cen)
                add = cen[near >= 0.5 * sz]
        cand = np.concatenate([xy, add])
        for _pass in range(3):
            try:
                ctri = triangulate(cand)
            except ValueError:  # a move met another bubble: score() rejects this round
                break
            e, _ = triangle_edges(ctri)
            nb_sum = np.zeros_like(cand)
            nb_cnt = np.zeros(len(cand))
            np.add.at(nb_sum, e[:, 0], cand[e[:, 1]])
            np.add.at(nb_sum, e[:, 1], cand[e[:, 0]])
            np.add.at(nb_cnt, e[:, 0], 1.0)
            np.add.at(nb_cnt, e[:, 1], 1.0)
            mov = np.flatnonzero(nb_cnt[n_fixed:] > 0) + n_fixed
            if not len(mov):
                break
            target = nb_sum[mov] / nb_cnt[mov, None]
            ok = admissible(target, None if groups is None else groups(cand[mov]))
            cand = cand.copy()
            cand[mov[ok]] = target[ok]
        got, ctri = score(cand)
        # better: a larger smallest angle, or one still at or above min(smallest, angle) with a
        # larger mean radius ratio
        if got[0] > best[0] + 1e-9 or (got[0] >= min(best[0], angle) - 1e-9
                                         and got[1] > best[1] + 1e-12):
            xy, tri, best = cand, ctri, got
            n_inserted += len(add)
        else:
            break
    return xy, n_inserted


def bubble_mesh(outer, holes=(), size=None, *, init="lattice", edge_init="quantile", neighbours="range",
                n_cycles=4, steps_per_cycle=150,
                final_steps=200, dt=0.3, mass=1.0, damping=1.5, tol=1e-3, remove_below=0.6,
                insert_above=0.85, resize_every=10, seed=0, progress=False, improve=0,
                improve_angle=30.0):
    """Bubble mesh of a polygon with holes (thesis 2.3.3).

    Parameters
    ----------
    outer : (K, 2) array_like or Domain
        Outer ring (any orientation; see :func:`validate_domain`).
    holes : sequence of (K_h, 2) array_like
    size : float, callable or GridSize
        Target element edge length: a number (uniform), or ``size(xy) -> (K,)``
        for a graded mesh. Bubble diameter = size at its centre, so two
        neighbours settle at ``r0 = 0.5 (d_i + d_j)`` (2.11).
    init : {"lattice", "random", "quadtree"}
        Initial face bubbles: thinned hexagonal lattice, seeded uniform
        random points with the same expected density, or the (jittered)
        centres of a size-driven quadtree's leaves (4.3.3, Fig. 4.7 (5)).
    edge_init : {"quantile", "tree"}
        Initial edge bubbles: equal quantiles of the integrated inverse size,
        or the leaf ends of a binary-tree bisection (4.3.3, Fig. 4.7 (3)),
        followed by relaxation and thinning/insertion along the edges.
    neighbours : {"range", "delaunay"}
        Face bubbles interact with every bubble within ``r1 = 1.5 r0`` (found
        again every step), or only with their neighbours in the Delaunay
        triangulation of the bubbles, made again after every population
        control (4.3.3, faces steps 2-4).
    n_cycles : int
        Relaxation + population-control cycles for the face bubbles.
    steps_per_cycle, final_steps : int
        Maximal time steps per cycle and in the final relaxation.
    dt, mass, damping : float
        Time step, ``m`` and ``c`` of (2.13) (unit linearised stiffness).
    tol : float
        A relaxation stops when no bubble moved more than ``tol * size`` in a step.
    remove_below, insert_above : float
        Population control: remove a face bubble closer than
        ``remove_below * r0`` to another; insert at circumcentres with
        circumradius above ``insert_above * size``.
    resize_every : int
        Steps between re-evaluations of the size field at the moving bubbles.
    seed : int
        Seed of the initial placement.
    progress : bool
        Show a tqdm bar over the cycles.
    improve : int
        Rounds of quality improvement after the relaxation (0: none, the default): a bubble
        at the circumcentre of each triangle with a smallest angle below ``improve_angle``,
        then Laplacian smoothing of the face bubbles with Delaunay reconnection; a round is
        kept only if it raises the smallest angle, or keeps it and raises the mean radius
        ratio. For size fields larger than the domain's features (a channel or a hole
        narrower than the size), where the packing alone leaves skinny triangles.
    improve_angle : float
        Smallest angle (degrees) below which a triangle gets a bubble at its circumcentre.

    Returns
    -------
    BubbleMesh

    Raises
    ------
    InvalidDomainError
        Invalid polygon or holes.
    ValueError
        Bad size field or parameters.
    """
    dom = validate_domain(outer, holes)
    pts, seg, _ = dom.segments()
    return _bubble_core(dom, pts, seg, size, False, init=init, edge_init=edge_init, neighbours=neighbours,
                        n_cycles=n_cycles,
                        steps_per_cycle=steps_per_cycle, final_steps=final_steps, dt=dt,
                        mass=mass, damping=damping, tol=tol, remove_below=remove_below,
                        insert_above=insert_above, resize_every=resize_every, seed=seed,
                        progress=progress, improve=improve, improve_angle=improve_angle)


def _bubble_core(dom, pts, seg, size, internal, *, regions=None, **kwargs):
    # Far from the origin the relaxation's small moves and the Delaunay predicates drown in the
    # coordinates' round-off (a unit square at 1e12 left 38 of 58 nodes in no triangle): mesh in
    # coordinates relative to local_origin (an exact translation; none near the origin) and shift
    # back. No scaling: the relaxation's step (dt^2 f) is in absolute units, and scaling would
    # change every mesh already made.
    origin = local_origin(pts)
    if not origin.any():
        return _bubble_core_local(dom, pts, seg, size, internal, regions=regions, **kwargs)
    if size is not None:
        field = as_size_function(size)

        def size(q):
            return field(q + origin)

        size.constant = field.constant
    local_regions = None if regions is None else (lambda q: regions(q + origin))
    local_dom = Domain(dom.outer - origin, tuple(h - origin for h in dom.holes))
    bm = _bubble_core_local(local_dom, pts - origin, seg, size, internal, regions=local_regions, **kwargs)
    return BubbleMesh(bm.nodes + origin, bm.triangles, bm.kind, bm.sizes, bm.constrained_edges,
                      bm.initial + origin, bm.n_steps, bm.n_inserted, bm.n_removed, bm.history)


def _bubble_core_local(dom, pts, seg, size, internal, *, init, edge_init, neighbours, n_cycles,
                       steps_per_cycle, final_steps,
                       dt, mass, damping, tol, remove_below, insert_above, resize_every, seed, progress,
                       near_segment=0.35, bare=False, fixed_size=None, regions=None, improve=0,
                       improve_angle=30.0):
    # pts: fixed vertex bubbles; seg: segments carrying edge bubbles (the domain
    # boundary, plus internal segments when `internal`); `bare` (bool or (S,)
    # mask): segments whose nodes are already all in `pts` (no edge bubbles);
    # `fixed_size`: sizes of the `pts` bubbles (else read from the field);
    # `regions`: xy -> (K,) region labels: face bubbles of different regions
    # ignore each other (each region is packed against its own boundary)
    if size is None:
        raise ValueError("size: required (a number, a GridSize or a callable)")
    if init not in ("lattice", "random", "quadtree"):
        raise ValueError(f"init: expected 'lattice', 'random' or 'quadtree', got {init!r}")
    if edge_init not in ("quantile", "tree"):
        raise ValueError(f"edge_init: expected 'quantile' or 'tree', got {edge_init!r}")
    if neighbours not in ("range", "delaunay"):
        raise ValueError(f"neighbours: expected 'range' or 'delaunay', got {neighbours!r}")
    for name, v in (("dt", dt), ("mass", mass), ("tol", tol)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name}: must be positive, got {v}")
    field = as_size_function(size)
    n_pts = len(pts)

    sizef = field

    def sizes_of(q):
        # the bubbles array: the fixed vertex bubbles come first
        out = field(q)
        if fixed_size is not None:
            out[:n_pts] = fixed_size
        return out

    def groups_of(q, first):
        g = np.full(len(q), -1, np.int64)
        if regions is not None and len(q) > first:
            g[first:] = regions(q[first:])
        return g

    rng = np.random.default_rng(seed)
    lo = pts.min(axis=0)
    hi = pts.max(axis=0)
    # the size range decides the grids: neighbours within 1.5 * the largest r0
    probe = _hex_lattice(lo, hi, max(np.ptp(pts, axis=0).max() / 200.0, 1e-12), (0.0, 0.0))
    hs = np.concatenate([sizef(pts), sizef(probe)])
    h_min, h_max = float(hs.min()), float(hs.max())
    loc = BoundaryLocator.build(dom, W_CUTOFF * h_max * 1.0001)
    largs = loc.args()
    seg_index = SegmentIndex.build(pts, seg, W_CUTOFF * h_max * 1.0001) if internal else None
    # neighbour grid: cells of the smallest interaction range (capped at ~4M cells)
    gcs = max(W_CUTOFF * h_min, math.sqrt(float(np.prod(hi - lo + 2 * h_max)) / 4.0e6))
    gx0, gy0 = (lo - h_max).tolist()
    gnx, gny = (np.ceil((hi - lo + 2 * h_max) / gcs).astype(np.int64) + 1).tolist()
    gargs = (gx0, gy0, gcs, gnx, gny)

    # vertex and edge bubbles
    bare = np.broadcast_to(np.asarray(bare, dtype=np.bool_), (len(seg),))
    if bare.all():
        exy, eseg = np.zeros((0, 2)), np.zeros(0, np.int64)
    elif edge_init == "tree":
        exy, eseg = _edge_bubbles_tree(pts, seg, sizef, bare=bare)
    else:
        exy, eseg = _edge_bubbles(pts, seg, sizef, bare=bare)
    n_vertex = len(pts)
    total_steps = 0
    history = []
    n_ins = n_rem = 0
    no_adj = (np.zeros(0, np.int64), np.zeros(0, np.int64))

    def relax_edges(exy, eseg, n_steps):
        # 1-D relaxation (thesis 2.3.3): bubbles on an edge feel that edge's bubbles and the vertices
        bxy = np.concatenate([pts, exy])
        bsz = sizes_of(bxy)
        eab = np.zeros((len(bxy), 4))
        eab[n_vertex:, :2] = pts[seg[eseg, 0]]
        eab[n_vertex:, 2:] = pts[seg[eseg, 1]]
        vel = np.zeros((len(bxy), 2))
        group = np.concatenate([np.full(n_vertex, -1, np.int64), eseg])
        steps, mx = _relax_kernel(bxy, vel, bsz, group, n_vertex, len(exy), eab, *largs,
                                  *gargs, n_steps, dt, mass, damping, tol, 0.25, *no_adj)
        history.append(("edges", steps, float(mx)))
        # keep every segment's bubbles in order along it (for the constraint chains)
        a = pts[seg[eseg, 0]]
        s_along = np.einsum("ij,ij->i", bxy[n_vertex:] - a, pts[seg[eseg, 1]] - a)
        o = np.lexsort((s_along, eseg))
        return steps, bxy[n_vertex:][o], eseg[o]

    if len(exy) and edge_init == "tree":
        # relaxation, then thinning/insertion until the counts hold (4.3.3, edges 2-3)
        vsz = sizes_of(pts)
        for cyc in range(n_cycles + 1):
            steps, exy, eseg = relax_edges(exy, eseg, steps_per_cycle)
            total_steps += steps
            cap = 2 * len(exy) + 2 * int(np.ceil(np.sum(np.linalg.norm(
                pts[seg[:, 1]] - pts[seg[:, 0]], axis=1)) / h_min)) + len(seg)
            out_xy = np.empty((cap, 2))
            out_seg = np.empty(cap, np.int64)
            m, ni, nr = _edge_control_kernel(pts, seg, np.ascontiguousarray(bare), vsz, exy, eseg,
                                             sizes_of(exy), out_xy, out_seg)
            history.append(("edge_control", cyc, int(ni), int(nr)))
            n_ins += int(ni)
            n_rem += int(nr)
            exy, eseg = out_xy[:m], out_seg[:m]
            if ni == 0 and nr == 0:
                break
    if len(exy):
        steps, exy, eseg = relax_edges(exy, eseg, final_steps)
        total_steps += steps
    n_edge = len(exy)
    bxy = np.concatenate([pts, exy])
    eab = np.zeros((len(bxy), 4))
    eab[n_vertex:, :2] = pts[seg[eseg, 0]]
    eab[n_vertex:, 2:] = pts[seg[eseg, 1]]
    n_fixed = n_vertex + n_edge

    # initial face bubbles
    thin = True
    if init == "lattice":
        cand = _hex_lattice(lo - h_min, hi + h_min, h_min, rng.random(2) * h_min)
    elif init == "quadtree":
        cand, _ = _quadtree_bubbles(dom, sizef, seed=int(rng.integers(2**62)))
        thin = False  # the tree already follows the size field
    else:
        area_box = float(np.prod(hi - lo))
        n_cand = int(rng.poisson(area_box * 2.0 / (math.sqrt(3.0) * h_min**2)))
        cand = lo + rng.random((n_cand, 2)) * (hi - lo)
    inside, dist = loc.locate(cand)
    cand = cand[inside]
    dist = dist[inside]
    if internal:
        dist = np.minimum(dist, seg_index.distance(cand))
    csz = sizef(cand)
    keep = dist > 0.5 * csz
    if thin:
        keep &= rng.random(len(cand)) < (h_min / csz) ** 2
    fxy = cand[keep]
    initial = np.concatenate([bxy, fxy])

    xy = initial.copy()
    cycles = range(n_cycles + 1)
    if progress:
        from tqdm.auto import tqdm

        cycles = tqdm(cycles, desc="bubble mesh")
    vel = np.zeros_like(xy)
    cons = _boundary_edges(n_vertex, seg, eseg)
    tri = None
    for cyc in cycles:
        adjacency = no_adj
        if neighbours == "delaunay":
            # neighbours: the Delaunay edges, fixed for the cycle (4.3.3, faces 2 and 4)
            if tri is None:
                tri = constrained_delaunay(xy, cons, erase_outside=not internal).triangles
            adjacency = _adjacency(len(xy), tri)
        budget = final_steps if cyc == n_cycles else steps_per_cycle
        done = 0
        while done < budget:
            sz = sizes_of(xy)
            chunk = min(resize_every, budget - done)
            steps, mx = _relax_kernel(xy, vel, sz, groups_of(xy, n_fixed), n_fixed, 0, eab,
                                      *largs, *gargs, chunk, dt, mass, damping, tol, 0.25, *adjacency)
            done += steps
            total_steps += steps
            if steps < chunk:
                break
        history.append(("faces", cyc, done, float(mx)))
        # a face bubble squeezed against a constraint segment between two edge
        # bubbles would make a sliver; in a hexagonal packing the first row
        # sits 0.87 size away
        sz = sizes_of(xy)
        _, dseg = loc.locate(xy)
        if internal:
            dseg = np.minimum(dseg, seg_index.distance(xy))
        near = dseg < near_segment * sz
        near[:n_fixed] = False
        if cyc == n_cycles:
            n_rem += int(near.sum())
            xy = xy[~near]
            break
        # population control on the Delaunay of the bubble centres
        tri = constrained_delaunay(xy, cons, erase_outside=not internal).triangles
        removed = near.copy()
        _removal_kernel(xy, sz, tri, n_fixed, remove_below, removed, groups_of(xy, n_fixed))
        gaps = np.empty((len(tri), 3))
        m = _gap_kernel(xy, sz, tri, insert_above, gaps)
        gaps = gaps[:m]
        if m:
            ins, dd = loc.locate(gaps[:, :2])
            if internal:
                dd = np.minimum(dd, seg_index.distance(gaps[:, :2]))
            gsz = sizef(gaps[:, :2])
            gaps = gaps[ins & (dd > 0.5 * gsz)]
            gaps[:, 2] = sizef(gaps[:, :2]) if len(gaps) else gaps[:, 2]
            keep = np.ones(len(gaps), np.bool_)
            _dedupe_kernel(gaps, keep, 0.5)
            gaps = gaps[keep]
        n_rem += int(removed.sum())
        n_ins += len(gaps)
        xy = np.concatenate([xy[~removed], gaps[:, :2]])
        vel = np.concatenate([vel[~removed], np.zeros((len(gaps), 2))])
        tri = None  # the population changed: triangulate again

    if improve:
        def admissible(q, first_group):
            sz = sizef(q)
            ok, d = loc.locate(q)
            if internal:
                d = np.minimum(d, seg_index.distance(q))
            ok &= d >= near_segment * sz
            if regions is not None and first_group is not None:
                ok &= regions(q) == first_group
            return ok

        xy, n_imp = _improve_packing(
            xy, n_fixed, lambda q: _cdt_inside(q, cons, internal, dom, h_min), sizef, admissible,
            rounds=int(improve), angle=float(improve_angle),
            groups=None if regions is None else (lambda q: regions(q)))
        n_ins += n_imp
        history.append(("improve", int(improve), n_imp))
    mesh = constrained_delaunay(xy, cons, erase_outside=not internal)
    if internal:
        # internal constraints defeat the parity rule: keep triangles by centroid.
        # Between boundary nodes that are collinear up to round-off (a slanted
        # edge split into patch nodes) the convex hull leaves zero-area slivers
        # whose centroids sit on the boundary; no element can be that flat, so
        # drop them (they would be T-vertices along the boundary).
        tri = mesh.triangles
        cen = mesh.nodes[tri].mean(axis=1)
        a, b, c = (mesh.nodes[tri[:, k]] for k in range(3))
        area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        flat = np.abs(area2) <= 1e-8 * h_min * h_min
        # shapely's exact test, not the grid locator: robust where holes touch
        inside = shapely.contains_xy(dom.polygon, cen[:, 0], cen[:, 1])
        mesh = mesh._replace(triangles=tri[inside & ~flat])
    kind = np.full(len(xy), 2, np.int8)
    kind[:n_vertex] = 0
    kind[n_vertex:n_fixed] = 1
    return BubbleMesh(mesh.nodes, mesh.triangles, kind, sizes_of(xy), cons, initial,
                      total_steps, n_ins, n_rem, history)


@njit
def _point_in_triangles_kernel(xy, nodes, tri, x0, y0, cs, nx, ny, starts, order, out):
    for i in range(xy.shape[0]):
        px = xy[i, 0]
        py = xy[i, 1]
        cx = min(max(int((px - x0) / cs), 0), nx - 1)
        cy = min(max(int((py - y0) / cs), 0), ny - 1)
        c = cy * nx + cx
        best = -np.inf
        out[i] = -1
        for s in range(starts[c], starts[c + 1]):
            t = order[s]
            # smallest barycentric coordinate (scaled): >= 0 inside; keep the best
            w = np.inf
            for k in range(3):
                a = tri[t, k]
                b = tri[t, (k + 1) % 3]
                cr = (nodes[b, 0] - nodes[a, 0]) * (py - nodes[a, 1]) - (
                    nodes[b, 1] - nodes[a, 1]) * (px - nodes[a, 0])
                ln = math.hypot(nodes[b, 0] - nodes[a, 0], nodes[b, 1] - nodes[a, 1])
                w = min(w, cr / ln)
            if w > best:
                best = w
                out[i] = t


def locate_in_triangles(xy, nodes, triangles):
    """Index of the triangle containing each point (the nearest to containing it near edges).

    Parameters
    ----------
    xy : (K, 2) float64
    nodes : (N, 2) float64
    triangles : (T, 3) int64
        Counter-clockwise.

    Returns
    -------
    tri : (K,) int64
        -1 for points whose grid cell meets no triangle.
    """
    xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    tri = np.ascontiguousarray(triangles, dtype=np.int64)
    lo = nodes.min(axis=0)
    hi = nodes.max(axis=0)
    cs = max(float(np.sqrt(np.prod(hi - lo) / max(len(tri), 1))), 1e-300)
    nx, ny = (np.floor((hi - lo) / cs).astype(np.int64) + 1).tolist()
    # each triangle goes to every cell its bounding box meets (vectorised CSR build)
    tmin = np.floor((nodes[tri].min(axis=1) - lo) / cs).astype(np.int64)
    tmax = np.floor((nodes[tri].max(axis=1) - lo) / cs).astype(np.int64)
    tmin = np.clip(tmin, 0, [nx - 1, ny - 1])
    tmax = np.clip(tmax, 0, [nx - 1, ny - 1])
    span = tmax - tmin + 1
    reps = span[:, 0] * span[:, 1]
    owner = np.repeat(np.arange(len(tri)), reps)
    local = np.arange(reps.sum()) - np.repeat(np.cumsum(reps) - reps, reps)
    cx = tmin[owner, 0] + local % span[owner, 0]
    cy = tmin[owner, 1] + local // span[owner, 0]
    cell = cy * nx + cx
    order_ = np.argsort(cell, kind="stable")
    starts = np.searchsorted(cell[order_], np.arange(nx * ny + 1))
    out = np.empty(len(xy), np.int64)
    _point_in_triangles_kernel(xy, nodes, tri, float(lo[0]), float(lo[1]), cs, nx, ny, starts,
                               owner[order_], out)
    return out


def bubble_subdivide_patches(nodes, patches, element_size, *, seed=0, edge_nodes=None, **kwargs):
    """Patches split into elements by a finer bubble mesh constrained by the patch edges.

    Every patch node is a fixed vertex bubble, every patch edge carries edge
    bubbles (shared by the two patches on it, so neighbouring patches share
    their element nodes: no T-vertex), and face bubbles fill the patches.
    The constrained Delaunay of all bubbles, with every patch edge as a
    chain of constraints, gives elements that each lie in one patch.

    Parameters
    ----------
    nodes : (N, 2) float64
        Patch nodes (all used by ``patches``).
    patches : (P, 3) int64
        Counter-clockwise patch triangles forming one connected region.
    element_size : float, callable or GridSize
        Target element edge length (smaller than the patch size).
    seed : int
    edge_nodes : dict {(i, j): (k, 2) float64}, optional
        Preset element nodes inside some patch edges ``i < j``, in order
        from node ``i`` to node ``j`` (e.g. shared with the neighbouring
        polygon along a common 3-D edge); those edges get no other bubbles.
    **kwargs
        Passed on to the relaxation (see :func:`bubble_mesh`).

    Returns
    -------
    PatchElements
        ``nodes`` start with the patch nodes (same indices), then the preset
        edge nodes in the order of ``edge_nodes``.
    """
    n = np.ascontiguousarray(nodes, dtype=np.float64)
    p = np.ascontiguousarray(patches, dtype=np.int64)
    if n.ndim != 2 or n.shape[1] != 2 or not np.all(np.isfinite(n)):
        raise ValueError(f"nodes: expected finite (N, 2) coordinates, got shape {n.shape}")
    if p.ndim != 2 or p.shape[1] != 3 or p.size == 0 or p.min() < 0 or p.max() >= len(n):
        raise ValueError(f"patches: expected (P, 3) indices into {len(n)} nodes")
    if len(np.unique(p)) != len(n):
        raise ValueError("nodes: some nodes are used by no patch")
    region = shapely.union_all(shapely.polygons(n[p]))
    if region.geom_type != "Polygon":
        raise ValueError(f"patches: must form one connected region, got a {region.geom_type}")
    dom = validate_domain(np.asarray(region.exterior.coords), [np.asarray(r.coords) for r in region.interiors],
                          allow_touching=True)
    edges, _ = triangle_edges(p)
    bare = np.zeros(len(edges), np.bool_)
    if edge_nodes:
        # a preset edge becomes a chain of bare segments through its preset nodes
        pos = {(int(a), int(b)): k for k, (a, b) in enumerate(np.sort(edges, axis=1))}
        extra, chains, drop = [], [], []
        m = len(n)
        for (i, j), q in edge_nodes.items():
            q = np.asarray(q, dtype=np.float64).reshape(-1, 2)
            k = pos.get((min(i, j), max(i, j)))
            if k is None:
                raise ValueError(f"edge_nodes: ({i}, {j}) is not a patch edge")
            if i > j:
                q = q[::-1]
                i, j = j, i
            idx = np.concatenate([[i], m + np.arange(len(q)), [j]])
            chains.append(np.stack([idx[:-1], idx[1:]], axis=1))
            extra.append(q)
            drop.append(k)
            m += len(q)
        keep = np.ones(len(edges), np.bool_)
        keep[drop] = False
        edges = np.concatenate([edges[keep]] + chains).astype(np.int64)
        bare = np.concatenate([bare[keep], np.ones(sum(len(c) for c in chains), np.bool_)])
        n = np.concatenate([n] + extra)
    bm = _bubble_core(dom, n, edges, element_size, True, seed=seed, bare=bare,
                      **_bubble_opts(kwargs))
    cen = bm.nodes[bm.triangles].mean(axis=1)
    owner = locate_in_triangles(cen, n[:len(nodes)], p)
    return PatchElements(bm.nodes, p.copy(), bm.triangles, owner)


def _bubble_opts(kwargs):
    """The relaxation's keyword arguments with their defaults; unknown names raise TypeError."""
    opts = dict(init="lattice", edge_init="quantile", neighbours="range", n_cycles=4, steps_per_cycle=150,
                final_steps=200, dt=0.3, mass=1.0,
                damping=1.5, tol=1e-3, remove_below=0.6, insert_above=0.85, resize_every=10,
                progress=False, improve=0, improve_angle=30.0)
    unknown = set(kwargs) - set(opts)
    if unknown:
        raise TypeError(f"unexpected keyword arguments {sorted(unknown)}")
    opts.update(kwargs)
    return opts
