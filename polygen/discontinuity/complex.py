"""The receiver complex of simplified discontinuity meshing (thesis 3.3.2, Defs 3.6-3.10).

A receiver polygon and the discontinuity lines drawn on it are held as a
non-manifold complex (Fig. 3.8):

* **vertices** (Def. 3.6): the polygon's vertices and the end points of
  discontinuity edges, with the edges that end there;
* **edges** (Def. 3.7): ring edges of the polygon (kind ``BOUNDARY``, one
  loop, Def. 3.10) and discontinuity edges (``D0``/``D1``, two loops);
* **loops** (Def. 3.8): closed chains of *signed edge uses* (half-edges,
  ``h = 2 * e + d``, ``d = 0`` from ``edges[e, 0]`` to ``edges[e, 1]``,
  ``d = 1`` the other way) with the region they bound on their left;
* **faces** (Def. 3.9): one counter-clockwise outer loop and any number of
  clockwise hole loops.

The complex stores its geometry in growing numpy arrays (read by the numba
kernels of :mod:`polygen.discontinuity.walk`) and its loops as lists of
half-edges.  It is built and updated by :func:`polygen.discontinuity.states.
receiver_complex`; :meth:`ReceiverComplex.check` verifies every topological
invariant the tests rely on.  Coordinates are held relative to the centre of
the receiver's bounding box (an exact shift back on output), so that a
receiver far from its frame's origin keeps its precision.

Not thread-safe: one complex is updated by one caller at a time.
"""

from __future__ import annotations

import numpy as np

from polygen._jit import njit
from polygen.mesh2d.domain import InvalidDomainError, validate_domain
from polygen.mesh2d.pslg import BOUNDARY, D0, D1

__all__ = ["ComplexError", "ReceiverComplex", "BOUNDARY", "D0", "D1", "UNPROCESSED", "BRIGHT", "PENUMBRA",
           "UMBRA"]

# illumination states (3.3.5, Fig. 3.10)
UNPROCESSED, BRIGHT, PENUMBRA, UMBRA = 0, 1, 2, 3


class ComplexError(ValueError):
    """A receiver or section the complex cannot take, or a broken invariant (says which)."""


def _grow(a, n):
    if n <= len(a):
        return a
    out = np.empty((max(n, 2 * len(a)),) + a.shape[1:], dtype=a.dtype)
    out[:len(a)] = a
    return out


class ReceiverComplex:
    """Vertices, edges, loops and faces of one receiver polygon (Defs 3.6-3.9).

    Parameters
    ----------
    outer : (K, 2) array_like
        The receiver's outer ring in its own 2-D frame (either orientation).
    holes : sequence of (K_h, 2) array_like
        Its holes (they may touch each other or the outer ring at vertices).
    n_lights : int, keyword-only
        Number of lights: the width of the illumination-state table.
    tol : float, keyword-only
        Snapping tolerance relative to the receiver's extent: a point within
        ``tol * extent`` of a vertex is that vertex, of an edge lies on it.

    Attributes
    ----------
    eps : float
        The absolute tolerance.
    origin : (2,) float64
        The shift subtracted from every coordinate held.
    n_receiver_holes : int
    counters : dict
        ``point_in_loop`` (point-in-loop tests), ``edge_tests`` (segment-edge
        intersection tests), ``edge_tests_all`` (what testing every section
        edge against every edge of the receiver would have cost: the
        baseline the walk is measured against), ``state_tests`` (region-in-section tests),
        ``sections`` (sections inserted), ``splits`` (edges split),
        ``snaps`` (edges bent through a vertex closer than the tolerance),
        ``loops_traced``, ``loops_deleted``.
    """

    def __init__(self, outer, holes=(), *, n_lights=1, tol=1e-9):
        try:
            dom = validate_domain(outer, holes, allow_touching=True)
        except InvalidDomainError as exc:
            raise ComplexError(f"receiver: {exc}") from None
        if int(n_lights) != n_lights or n_lights < 0:
            raise ComplexError(f"n_lights must be a non-negative integer, got {n_lights!r}")
        if not (0 < tol < 1e-2):
            raise ComplexError(f"tol must be in (0, 1e-2), got {tol!r}")
        lo, hi = dom.outer.min(axis=0), dom.outer.max(axis=0)
        self.origin = 0.5 * (lo + hi)
        self.extent = float((hi - lo).max())
        self.eps = float(tol) * self.extent
        self.tol = float(tol)
        self.n_lights = int(n_lights)
        self.n_receiver_holes = len(dom.holes)
        self.t_idd = 0.0  # seconds spent intersecting section edges with existing edges (T_idd)
        self.counters = dict(point_in_loop=0, edge_tests=0, edge_tests_all=0, state_tests=0, sections=0,
                             splits=0, snaps=0, loops_traced=0, loops_deleted=0)
        # geometry (growing arrays)
        self.xy = np.empty((64, 2))
        self.nv = 0
        self.ev = np.empty((64, 2), np.int64)
        self.ekind = np.empty(64, np.int8)
        self.ne = 0
        self.hloop = []          # loop of each half-edge (-1: outside the receiver, or not yet traced)
        self.stars = {}          # per vertex, its outgoing half-edges in angular order (loops.py)
        self.vedges = []         # incident edges per vertex
        self.boundary_edges = []  # ring edges (their outside half has no loop)
        # loops and faces
        self.loops = []          # list of half-edge lists (None when deleted)
        self.loop_face = []
        self.loop_area = []
        self.loop_box = np.empty((64, 4))   # (xmin, ymin, xmax, ymax) per loop
        self.face_outer = np.empty(64, np.int64)  # outer loop per face (-1 when deleted)
        self.face_holes = []
        self.face_state = np.empty((64, self.n_lights), np.int8)
        self.nf = 0
        rings = [dom.outer - self.origin] + [h - self.origin for h in dom.holes]
        face = self._new_face(None)
        for r in rings:
            vs = [self.add_vertex(p) for p in r]
            hs = []
            for i in range(len(vs)):
                e = self.add_edge(vs[i], vs[(i + 1) % len(vs)], BOUNDARY)
                self.boundary_edges.append(e)
                hs.append(2 * e)
            loop = self._new_loop(hs, face)
            if loop == 0:
                self.face_outer[face] = loop
            else:
                self.face_holes[face].append(loop)
        self.receiver_area = float(sum(self.loop_area))

    def _reset(self):
        """Drop every vertex, edge, loop and face (for a rebuild from scratch)."""
        self.nv = self.ne = self.nf = 0
        self.hloop, self.vedges, self.boundary_edges, self.stars = [], [], [], {}
        self.loops, self.loop_face, self.loop_area = [], [], []
        self.face_holes = []

    # ------------------------------------------------------------------ growth
    def add_vertex(self, p):
        self.xy = _grow(self.xy, self.nv + 1)
        self.xy[self.nv] = p
        self.vedges.append([])
        self.nv += 1
        return self.nv - 1

    def add_edge(self, a, b, kind):
        self.ev = _grow(self.ev, self.ne + 1)
        self.ekind = _grow(self.ekind, self.ne + 1)
        self.ev[self.ne] = (a, b)
        self.ekind[self.ne] = kind
        self.hloop += [-1, -1]
        self.vedges[a].append(self.ne)
        self.vedges[b].append(self.ne)
        self.stars.pop(a, None)
        self.stars.pop(b, None)
        self.ne += 1
        return self.ne - 1

    def split_edge(self, e, p, *, vertex=-1):
        """Split edge ``e`` at a new vertex at ``p`` (or through the existing ``vertex``: a
        snap within the tolerance); the loops using it follow.  Returns the vertex."""
        a, b = (int(i) for i in self.ev[e])
        x = self.add_vertex(p) if vertex < 0 else vertex
        e2 = self.add_edge(x, b, int(self.ekind[e]))
        self.ev[e, 1] = x
        self.stars.pop(a, None)
        self.vedges[b].remove(e)
        self.vedges[x].insert(0, e)
        fwd, rev = self.hloop[2 * e], self.hloop[2 * e + 1]
        self.hloop[2 * e2], self.hloop[2 * e2 + 1] = fwd, rev
        if fwd >= 0:
            hs = self.loops[fwd]
            hs.insert(hs.index(2 * e) + 1, 2 * e2)
        if rev >= 0:
            hs = self.loops[rev]
            hs.insert(hs.index(2 * e + 1), 2 * e2 + 1)
        if self.ekind[e] == BOUNDARY:
            self.boundary_edges.append(e2)
        self.counters["splits"] += 1
        return x

    def _new_loop(self, hs, face):
        lid = len(self.loops)
        self.loops.append(hs)
        for h in hs:
            self.hloop[h] = lid
        ids = np.fromiter((self.origin_of(h) for h in hs), dtype=np.int64, count=len(hs))
        self.loop_box = _grow(self.loop_box, lid + 1)
        self.loop_area.append(_area_box(self.xy, ids, self.loop_box[lid]))
        self.loop_face.append(face)
        return lid

    def _new_face(self, state):
        f = self.nf
        self.face_outer = _grow(self.face_outer, f + 1)
        self.face_state = _grow(self.face_state, f + 1)
        self.face_outer[f] = -1
        self.face_state[f] = 0 if state is None else state
        self.face_holes.append([])
        self.nf += 1
        return f

    # ------------------------------------------------------------------ queries
    def origin_of(self, h):
        return int(self.ev[h >> 1, h & 1])

    def dest_of(self, h):
        return int(self.ev[h >> 1, 1 - (h & 1)])

    def face_edges(self, f):
        """Edge ids of face ``f``'s loops (``f = -1``: the receiver's ring edges)."""
        if f < 0:
            return list(self.boundary_edges)
        out = [h >> 1 for h in self.loops[self.face_outer[f]]]
        for lp in self.face_holes[f]:
            out.extend(h >> 1 for h in self.loops[lp])
        return out

    @property
    def alive_faces(self):
        """(F,) int64 ids of the faces not superseded."""
        return np.flatnonzero(self.face_outer[:self.nf] >= 0)

    @property
    def alive_loops(self):
        return [i for i, hs in enumerate(self.loops) if hs is not None]

    @property
    def vertices(self):
        """(V, 2) float64 vertex coordinates in the receiver's frame."""
        return self.xy[:self.nv] + self.origin

    @property
    def edges(self):
        """(E, 2) int64 vertex pairs."""
        return self.ev[:self.ne].copy()

    @property
    def edge_kind(self):
        """(E,) int8: ``BOUNDARY``, ``D0`` or ``D1``."""
        return self.ekind[:self.ne].copy()

    @property
    def edge_loops(self):
        """(E, 2) int64: the loop using each edge forwards and backwards (-1: none)."""
        return np.asarray(self.hloop, dtype=np.int64).reshape(-1, 2)

    def loop_vertices(self, lp):
        """(k, 2) float64 vertices of loop ``lp`` in order (receiver frame)."""
        return self.xy[[self.origin_of(h) for h in self.loops[lp]]] + self.origin

    def face_rings(self, f):
        """``(outer (k, 2), [holes (k_h, 2)])`` of face ``f`` in the receiver's frame."""
        return self.loop_vertices(self.face_outer[f]), [self.loop_vertices(h) for h in self.face_holes[f]]

    def face_states(self):
        """(F, n_lights) int8 states of the alive faces (in :attr:`alive_faces` order)."""
        return self.face_state[self.alive_faces].copy()

    def loop_states(self):
        """(L, n_lights) int8 per loop (all loops ever made): an outer loop carries its face's
        states (Fig. 3.10), a hole or a deleted loop 0."""
        out = np.zeros((len(self.loops), self.n_lights), np.int8)
        fs = self.alive_faces
        out[self.face_outer[fs]] = self.face_state[fs]
        return out

    def interior_points(self):
        """(F, 2) float64: a point inside each alive face (receiver frame), in ``alive_faces`` order."""
        import shapely

        out = []
        for f in self.alive_faces:
            outer, holes = self.face_rings(f)
            poly = shapely.Polygon(outer, holes)
            if not poly.is_valid:
                poly = shapely.make_valid(poly)
            out.append(shapely.get_coordinates(shapely.point_on_surface(poly))[0])
        return np.array(out, dtype=np.float64).reshape(-1, 2)

    def euler(self):
        """``(V, E, F, L)`` counts of the alive complex (vertices with an edge)."""
        V = sum(1 for v in range(self.nv) if self.vedges[v])
        return V, self.ne, len(self.alive_faces), len(self.alive_loops)

    # ------------------------------------------------------------------ invariants
    def check(self, *, geometry=True):
        """Verify the complex; raise :class:`ComplexError` naming the first broken invariant.

        * every loop is a closed chain of half-edges, each half-edge in the
          loop its table says;
        * a ring edge is used by exactly one loop side (the inside), a
          discontinuity edge by exactly two (Def. 3.10);
        * outer loops are counter-clockwise, holes clockwise (Def. 3.9), and
          a face's area (outer minus holes) is positive;
        * the face areas add up to the receiver's area;
        * Euler-Poincare for a planar complex whose faces have holes:
          ``V - E + F - H = 1 - (receiver holes)``, ``H`` the hole loops;
          and the connected components of the edge graph number ``1 + H``;
        * with ``geometry``: no two edges cross, touch away from a common
          vertex, or overlap.
        """
        alive = self.alive_loops
        for lp in alive:
            hs = self.loops[lp]
            for i, h in enumerate(hs):
                if self.hloop[h] != lp:
                    raise ComplexError(f"loop {lp}: half-edge {h} is recorded in loop {self.hloop[h]}")
                if self.dest_of(h) != self.origin_of(hs[(i + 1) % len(hs)]):
                    raise ComplexError(f"loop {lp}: not a closed chain at half-edge {h}")
        bset = set(self.boundary_edges)
        for e in range(self.ne):
            used = (self.hloop[2 * e] >= 0) + (self.hloop[2 * e + 1] >= 0)
            if e in bset:
                if self.ekind[e] != BOUNDARY or self.hloop[2 * e] < 0 or self.hloop[2 * e + 1] >= 0:
                    raise ComplexError(f"ring edge {e}: must be used forwards by exactly one loop")
            elif used != 2:
                raise ComplexError(f"discontinuity edge {e}: used by {used} loop sides, not 2")
            for h in (2 * e, 2 * e + 1):
                lp = self.hloop[h]
                if lp >= 0 and self.loops[lp] is None:
                    raise ComplexError(f"half-edge {h}: its loop {lp} is deleted")
        # every half-edge recorded in a loop is in it (the loops' members were checked above)
        if sum(len(self.loops[lp]) for lp in alive) != sum(1 for lp in self.hloop if lp >= 0):
            raise ComplexError("half-edges recorded in loops that do not hold them")
        total = 0.0
        n_holes = 0
        for f in self.alive_faces:
            o = self.face_outer[f]
            if self.loop_area[o] <= 0:
                raise ComplexError(f"face {f}: outer loop {o} is not counter-clockwise")
            a = self.loop_area[o]
            for h in self.face_holes[f]:
                if self.loop_area[h] >= 0:
                    raise ComplexError(f"face {f}: hole loop {h} is not clockwise")
                a += self.loop_area[h]
                n_holes += 1
            if a <= 0:
                raise ComplexError(f"face {f}: area {a:.3g} is not positive")
            total += a
        owned = sum(1 + len(self.face_holes[f]) for f in self.alive_faces)
        if owned != len(alive):
            raise ComplexError(f"{len(alive)} loops but faces hold {owned}")
        ref = self.receiver_area
        if abs(total - ref) > 1e-9 * abs(ref) + 10 * self.eps * self.extent:
            raise ComplexError(f"face areas add up to {total!r}, the receiver's is {ref!r}")
        V, E, F, L = self.euler()
        if V - E + F - n_holes != 1 - self.n_receiver_holes:
            raise ComplexError(f"Euler-Poincare: V - E + F - H = {V} - {E} + {F} - {n_holes} "
                               f"!= 1 - {self.n_receiver_holes}")
        if _components(self.ev[:self.ne], self.nv, [v for v in range(self.nv) if self.vedges[v]]) != 1 + n_holes:
            raise ComplexError("connected components of the edges != 1 + hole loops")
        if geometry:
            self._check_embedding()

    def _check_embedding(self):
        import shapely

        ev = self.ev[:self.ne]
        seg = self.xy[ev]
        lines = shapely.linestrings(seg)
        i, j = shapely.STRtree(lines).query(lines, predicate="intersects")
        m = i < j
        i, j = i[m], j[m]
        share = (ev[i, 0] == ev[j, 0]) | (ev[i, 0] == ev[j, 1]) | (ev[i, 1] == ev[j, 0]) | (ev[i, 1] == ev[j, 1])
        if np.any(~share):
            k = int(np.flatnonzero(~share)[0])
            raise ComplexError(f"edges {i[k]} and {j[k]} meet away from a common vertex")
        # edges at a common vertex must leave it in different directions
        i, j = i[share], j[share]
        same2 = (np.sort(ev[i], axis=1) == np.sort(ev[j], axis=1)).all(axis=1)
        if np.any(same2):
            k = int(np.flatnonzero(same2)[0])
            raise ComplexError(f"edges {i[k]} and {j[k]} join the same two vertices")
        v = np.where((ev[i, 0] == ev[j, 0]) | (ev[i, 0] == ev[j, 1]), ev[i, 0], ev[i, 1])
        pa = self.xy[np.where(ev[i, 0] == v, ev[i, 1], ev[i, 0])] - self.xy[v]
        pb = self.xy[np.where(ev[j, 0] == v, ev[j, 1], ev[j, 0])] - self.xy[v]
        cr = np.abs(pa[:, 0] * pb[:, 1] - pa[:, 1] * pb[:, 0])
        ln = np.maximum(np.hypot(pa[:, 0], pa[:, 1]), np.hypot(pb[:, 0], pb[:, 1]))
        bad = ((pa * pb).sum(axis=1) > 0) & (cr <= 1e-12 * self.extent * ln)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ComplexError(f"edges {i[k]} and {j[k]} overlap from vertex {v[k]}")


@njit
def _area_box(xy, ids, box):
    """Signed area of the ring through ``xy[ids]`` (shoelace, relative to its first vertex);
    its bounding box is written into ``box``."""
    x0 = xy[ids[0], 0]
    y0 = xy[ids[0], 1]
    box[0] = x0
    box[1] = y0
    box[2] = x0
    box[3] = y0
    a = 0.0
    n = ids.shape[0]
    for i in range(n):
        x1 = xy[ids[i], 0]
        y1 = xy[ids[i], 1]
        x2 = xy[ids[(i + 1) % n], 0] - x0
        y2 = xy[ids[(i + 1) % n], 1] - y0
        a += (x1 - x0) * y2 - (y1 - y0) * x2
        box[0] = min(box[0], x1)
        box[1] = min(box[1], y1)
        box[2] = max(box[2], x1)
        box[3] = max(box[3], y1)
    return 0.5 * a


def _components(ev, nv, used):
    parent = list(range(nv))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in ev:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[ra] = rb
    return len({find(v) for v in used})
