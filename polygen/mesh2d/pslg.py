"""Planar straight-line graphs: a polygon's rings plus constrained segments, and their faces.

Chapter 3 cuts every receiver polygon by discontinuity segments into
regions (3.3.2: loops, faces with holes, holes touching each other or the
outer ring at a vertex) and meshes the regions with nodes first on the
vertices, then on the edges with the smaller adjacent size, then in the
interiors (3.3.6).  :func:`planar_graph` builds that graph from the rings
and the segments (vertices merged within a tolerance, edges split where a
vertex lies on them, crossings without a common vertex rejected) and
finds its faces, the *regions*, as the connected components of a coarse
constrained triangulation (so a region may have holes, holes may touch,
and a dangling segment lies inside one region).  :func:`mesh_planar_graph`
meshes the whole graph at once -- the lattice + constrained Delaunay mesher
or the bubble mesh -- so that every graph edge is a chain of mesh edges and
two regions always share their nodes on a common edge.

Edge kinds: ``BOUNDARY`` (0, a ring edge), ``D0`` (1, a radiance
discontinuity: the radiosity layer duplicates its nodes) and ``D1`` (2, a
derivative discontinuity: nodes shared).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import shapely
import shapely.ops

from polygen.mesh2d.delaunay import constrained_delaunay
from polygen.mesh2d.domain import InvalidDomainError, local_origin, validate_domain
from polygen.mesh2d.sizing import as_size_function

__all__ = [
    "BOUNDARY",
    "D0",
    "D1",
    "PlanarGraph",
    "GraphMesh",
    "planar_graph",
    "mesh_planar_graph",
    "edge_node_parameters",
    "convex_partition",
    "merge_close_segments",
]

BOUNDARY, D0, D1 = 0, 1, 2
_KIND = {"D0": D0, "D1": D1, D0: D0, D1: D1}


def _union_find(n, pairs):
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(n)], dtype=np.int64)


def _drop_repeats(ring, eps):
    keep = np.ones(len(ring), dtype=bool)
    last = 0
    for i in range(1, len(ring)):
        if np.hypot(*(ring[i] - ring[last])) <= eps:
            keep[i] = False
        else:
            last = i
    out = ring[keep]
    while len(out) > 1 and np.hypot(*(out[-1] - out[0])) <= eps:
        out = out[:-1]
    return out


@dataclass(frozen=True, eq=False)
class PlanarGraph:
    """A polygon's rings and constrained segments, noded, with its faces (regions).

    Attributes
    ----------
    vertices : (V, 2) float64
        Distinct vertices (ring vertices first, in ring order, then segment
        end points and extra points not already present).
    edges : (E, 2) int64
        Edges between vertices, no vertex inside an edge, no two crossing.
    edge_kind : (E,) int8
        ``BOUNDARY``, ``D0`` or ``D1``.
    edge_segment : (E,) int64
        The input segment an edge comes from (-1 for ring edges).
    edge_regions : (E, 2) int64
        The regions on the two sides of each edge (-1 outside the polygon;
        both the same for a dangling segment).
    triangles : (T, 3) int64
        A coarse constrained triangulation of the vertices (no new nodes).
    triangle_region : (T,) int64
    region_point : (R, 2) float64
        A point inside each region (the centroid of its largest triangle).
    region_area : (R,) float64
    domain : shapely.Polygon
        The polygon (rings only).
    eps : float
        The merge tolerance used (absolute).
    """

    vertices: np.ndarray
    edges: np.ndarray
    edge_kind: np.ndarray
    edge_segment: np.ndarray
    edge_regions: np.ndarray
    triangles: np.ndarray
    triangle_region: np.ndarray
    region_point: np.ndarray
    region_area: np.ndarray
    domain: object
    eps: float

    @property
    def n_regions(self):
        return len(self.region_area)

    def region_of(self, xy):
        """Region index of each point, -1 outside the polygon.

        Parameters
        ----------
        xy : (K, 2) float64

        Returns
        -------
        (K,) int64
            A point on an edge between two regions gets one of them.
        """
        from polygen.mesh2d.bubble import locate_in_triangles

        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        t = locate_in_triangles(xy, self.vertices, self.triangles)
        out = np.where(t >= 0, self.triangle_region[np.maximum(t, 0)], -1)
        inside = shapely.dwithin(self.domain, shapely.points(xy), self.eps)
        return np.where(inside, out, -1).astype(np.int64)

    def region_polygon(self, r):
        """The region ``r`` as a shapely (Multi)Polygon (the union of its triangles)."""
        tri = self.triangles[self.triangle_region == r]
        return shapely.union_all(shapely.polygons(self.vertices[tri]))

    def region_size_function(self, sizes):
        """One size function over the polygon from one size (field) per region.

        Parameters
        ----------
        sizes : sequence of (number, callable or GridSize), length ``n_regions``

        Returns
        -------
        callable ``(K, 2) -> (K,)``
            The size of the region each point falls in (a point outside the
            polygon takes the smallest of the region sizes there).
        """
        fns = [as_size_function(s) for s in sizes]
        if len(fns) != self.n_regions:
            raise ValueError(f"need one size per region ({self.n_regions}), got {len(fns)}")
        consts = [f.constant for f in fns]
        if all(c is not None for c in consts) and len(set(consts)) == 1:
            return as_size_function(consts[0])

        def size(xy):
            xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
            reg = self.region_of(xy)
            out = np.empty(len(xy))
            lost = reg < 0
            if lost.any():
                out[lost] = np.min([f(xy[lost]) for f in fns], axis=0)
            for r, f in enumerate(fns):
                m = reg == r
                if m.any():
                    out[m] = f(xy[m])
            return out

        size.constant = None
        size.per_region = fns
        return size


def _point_segment(p, a, b):
    """Distances (K, E) and parameters (K, E) of points p (K, 2) to segments a-b (E, 2)."""
    d = b - a
    l2 = np.maximum((d * d).sum(axis=1), 1e-300)
    t = ((p[:, None, :] - a[None]) * d[None]).sum(axis=2) / l2
    q = a[None] + np.clip(t, 0.0, 1.0)[..., None] * d[None]
    return np.linalg.norm(p[:, None, :] - q, axis=2), t


def planar_graph(outer, holes=(), segments=None, kinds=None, *, points=None, tol=1e-9):
    """The planar straight-line graph of a polygon with holes and constrained segments.

    Parameters
    ----------
    outer : (K, 2) array_like
        Outer ring (either orientation).
    holes : sequence of (K_h, 2) array_like
        Holes; they may touch the outer ring or each other at vertices.
    segments : (S, 2, 2) array_like, optional
        Constrained segments ``segments[s] = (start, end)``, inside the
        polygon (on its boundary allowed).  They may meet at end points, end
        on another segment or on a ring (the edge is split there) or overlap
        collinearly, but not cross without a common vertex.
    kinds : str, int or sequence, optional
        ``"D0"``/``"D1"`` (or :data:`D0`/:data:`D1`) per segment or for all;
        default ``"D1"``.
    points : (P, 2) array_like, optional
        Extra vertices on the rings or segments (edges are split there), e.g.
        where a neighbouring polygon's edge ends.
    tol : float
        Merge tolerance relative to the polygon's extent.

    Returns
    -------
    PlanarGraph
        Built relative to :func:`~polygen.mesh2d.domain.local_origin` of the
        outer ring (an exact translation; none near the origin), so that a
        polygon far from the origin gives the graph of the same polygon near
        it, shifted.

    Raises
    ------
    InvalidDomainError
        Invalid polygon; a segment that is not finite, degenerate (shorter
        than the tolerance), outside the polygon, or crossing another
        segment without a common vertex.  The message names the segment.
    """
    origin = _origin_of(outer)
    if not origin.any():
        return _planar_graph_local(outer, holes, segments, kinds, points=points, tol=tol)
    g = _planar_graph_local(np.asarray(outer, dtype=np.float64) - origin,
                            [np.asarray(h, dtype=np.float64) - origin for h in holes],
                            None if segments is None else np.asarray(segments, dtype=np.float64) - origin,
                            kinds, points=None if points is None else np.asarray(points, dtype=np.float64) - origin,
                            tol=tol)
    return _shifted(g, origin)


def _origin_of(xy):
    """local_origin of well-formed coordinates; 0 for anything else (the builder's checks report it)."""
    try:
        a = np.asarray(xy, dtype=np.float64)
    except (TypeError, ValueError):
        return np.zeros(2)
    if a.ndim != 2 or a.shape[1] != 2 or not len(a) or not np.all(np.isfinite(a)):
        return np.zeros(2)
    return local_origin(a)


def _shifted(g, by):
    """The graph ``g`` translated by ``by`` (its topology, areas and tolerance unchanged)."""
    return replace(g, vertices=g.vertices + by, region_point=g.region_point + by,
                   domain=shapely.transform(g.domain, lambda c: c + by))


def _planar_graph_local(outer, holes=(), segments=None, kinds=None, *, points=None, tol=1e-9):
    o = np.asarray(outer, dtype=np.float64)
    if o.ndim != 2 or o.shape[1] != 2 or not np.all(np.isfinite(o)):
        raise InvalidDomainError(f"outer polygon: expected finite (K, 2) coordinates, got {o.shape}")
    scale = float(np.ptp(o, axis=0).max())
    eps = tol * scale
    rings = [_drop_repeats(o, eps)]
    for i, h in enumerate(holes):
        h = np.asarray(h, dtype=np.float64)
        if h.ndim != 2 or h.shape[1] != 2 or not np.all(np.isfinite(h)):
            raise InvalidDomainError(f"hole {i}: expected finite (K, 2) coordinates, got {h.shape}")
        rings.append(_drop_repeats(h, eps))
    for i, r in enumerate(rings):
        if len(r) < 3:
            raise InvalidDomainError(f"{'outer polygon' if i == 0 else f'hole {i - 1}'}: "
                                     "fewer than 3 distinct vertices")
    domain = shapely.Polygon(rings[0], rings[1:])
    if not domain.is_valid:
        raise InvalidDomainError(f"invalid polygon: {shapely.is_valid_reason(domain)}")
    if domain.area <= 1e-12 * scale * scale:
        raise InvalidDomainError("zero area")

    if segments is None:
        seg = np.zeros((0, 2, 2))
    else:
        seg = np.asarray(segments, dtype=np.float64)
        if seg.size == 0:
            seg = np.zeros((0, 2, 2))
        if seg.ndim != 3 or seg.shape[1:] != (2, 2):
            raise InvalidDomainError(f"segments: expected shape (S, 2, 2), got {seg.shape}")
    ns = len(seg)
    if kinds is None:
        kinds = "D1"
    if isinstance(kinds, (str, int, np.integer)):
        kinds = [kinds] * ns
    kinds = list(kinds)
    if len(kinds) != ns:
        raise InvalidDomainError(f"kinds: need one per segment ({ns}), got {len(kinds)}")
    kind_arr = np.empty(ns, np.int8)
    for s, k in enumerate(kinds):
        if k not in _KIND:
            raise InvalidDomainError(f"segment {s}: kind must be 'D0' or 'D1', got {k!r}")
        kind_arr[s] = _KIND[k]
    lines = []
    if ns:
        bad = np.flatnonzero(~np.all(np.isfinite(seg), axis=(1, 2)))
        if len(bad):
            raise InvalidDomainError(f"segment {bad[0]}: non-finite coordinates")
        ln = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
        bad = np.flatnonzero(ln <= eps)
        if len(bad):
            raise InvalidDomainError(f"segment {bad[0]}: degenerate (length {ln[bad[0]]:.3g})")
        lines = shapely.linestrings(seg)
        inside = shapely.covers(domain.buffer(eps, quad_segs=2), lines)
        bad = np.flatnonzero(~inside)
        if len(bad):
            raise InvalidDomainError(f"segment {bad[0]} {seg[bad[0]].tolist()}: outside the polygon")
        tree = shapely.STRtree(lines)
        i, j = tree.query(lines, predicate="crosses")
        for a, b in zip(i, j):
            if a >= b:
                continue
            x = shapely.intersection(lines[a], lines[b])
            p = np.asarray(shapely.get_coordinates(x))
            ends = np.concatenate([seg[a], seg[b]])
            if len(p) and np.min(np.linalg.norm(ends[:, None] - p[None], axis=2), axis=0).max() > eps:
                raise InvalidDomainError(
                    f"segments {a} and {b} cross without a common vertex at {p[0].round(12).tolist()}")

    # vertices: ring vertices, segment end points, extra points; merged within eps
    extra = np.zeros((0, 2)) if points is None else np.asarray(points, dtype=np.float64).reshape(-1, 2)
    raw = np.concatenate(rings + [seg.reshape(-1, 2), extra])
    from scipy.spatial import cKDTree

    pairs = cKDTree(raw).query_pairs(eps, output_type="ndarray") if eps > 0 else np.zeros((0, 2), int)
    root = _union_find(len(raw), pairs)
    uniq, vid = np.unique(root, return_inverse=True)
    verts = raw[uniq]
    # raw edges
    e_list, k_list, s_list = [], [], []
    off = 0
    for r in rings:
        idx = np.arange(len(r)) + off
        e_list.append(np.stack([idx, np.roll(idx, -1)], axis=1))
        k_list.append(np.full(len(r), BOUNDARY, np.int8))
        s_list.append(np.full(len(r), -1, np.int64))
        off += len(r)
    e_list.append(off + np.arange(2 * ns).reshape(ns, 2))
    k_list.append(kind_arr)
    s_list.append(np.arange(ns))
    redges = vid[np.concatenate(e_list)]
    rkind = np.concatenate(k_list)
    rseg = np.concatenate(s_list)
    # split each edge at the vertices lying inside it
    sub_e, sub_k, sub_s = [], [], []
    for e in range(len(redges)):
        a, b = redges[e]
        d, t = _point_segment(verts, verts[a:a + 1], verts[b:b + 1])
        ln = np.hypot(*(verts[b] - verts[a]))
        on = np.flatnonzero((d[:, 0] <= eps) & (t[:, 0] * ln > eps) & ((1 - t[:, 0]) * ln > eps))
        chain = np.concatenate([[a], on[np.argsort(t[on, 0])], [b]])
        sub_e.append(np.stack([chain[:-1], chain[1:]], axis=1))
        sub_k.append(np.full(len(chain) - 1, rkind[e], np.int8))
        sub_s.append(np.full(len(chain) - 1, rseg[e], np.int64))
    sub_e = np.concatenate(sub_e)
    sub_k = np.concatenate(sub_k)
    sub_s = np.concatenate(sub_s)
    # overlapping edges: one per vertex pair; a ring edge stays a ring edge, D0 beats D1
    key = np.sort(sub_e, axis=1)
    prio = np.where(sub_k == BOUNDARY, 0, np.where(sub_k == D0, 1, 2))
    order = np.lexsort((prio, key[:, 1], key[:, 0]))
    key, first = np.unique(key[order], axis=0, return_index=True)
    pick = order[first]
    edges = sub_e[pick]
    edge_kind = sub_k[pick]
    edge_segment = sub_s[pick]

    # regions: components of a coarse constrained triangulation, cut at every edge
    try:
        cdt = constrained_delaunay(verts, edges, erase_outside=False)
    except ValueError as exc:
        raise InvalidDomainError(f"the segments do not form a planar graph ({exc})") from None
    tri = cdt.triangles
    pts = cdt.nodes
    cen = pts[tri].mean(axis=1)
    a, b, c = (pts[tri[:, k]] for k in range(3))
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    keep = shapely.contains_xy(domain, cen[:, 0], cen[:, 1]) & (np.abs(area2) > 1e-12 * scale * scale)
    tri = tri[keep]
    area2 = area2[keep]
    # triangle adjacency across edges that are not graph edges
    te = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1)
    ekey = te[:, 0] * len(pts) + te[:, 1]
    gkey = np.sort(edges, axis=1)
    gkey = gkey[:, 0] * len(pts) + gkey[:, 1]
    constrained = np.isin(ekey, gkey)
    order = np.argsort(ekey, kind="stable")
    sk = ekey[order]
    same = np.flatnonzero((sk[1:] == sk[:-1]) & ~constrained[order[1:]])
    links = np.stack([order[same] // 3, order[same + 1] // 3], axis=1)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    nt = len(tri)
    g = coo_matrix((np.ones(len(links)), (links[:, 0], links[:, 1])), shape=(nt, nt))
    n_reg, lab = connected_components(g, directed=False)
    # number regions by their first triangle (deterministic)
    first_t = np.full(n_reg, nt)
    np.minimum.at(first_t, lab, np.arange(nt))
    renum = np.empty(n_reg, np.int64)
    renum[np.argsort(first_t)] = np.arange(n_reg)
    lab = renum[lab]
    region_area = np.bincount(lab, weights=0.5 * np.abs(area2), minlength=n_reg)
    if abs(region_area.sum() - domain.area) > 1e-9 * domain.area:
        raise InvalidDomainError("the segments do not form a planar graph (region areas do not add up)")
    big = np.full(n_reg, -1)
    best = np.full(n_reg, -1.0)
    for t_, (r, ar) in enumerate(zip(lab, np.abs(area2))):
        if ar > best[r]:
            best[r] = ar
            big[r] = t_
    region_point = cen[keep][big]
    # regions on the two sides of every graph edge
    tri_of_key = {}
    for idx in np.flatnonzero(np.isin(ekey, gkey)):
        tri_of_key.setdefault(ekey[idx], []).append(lab[idx // 3])
    edge_regions = np.full((len(edges), 2), -1, np.int64)
    for e, k in enumerate(gkey):
        rs = tri_of_key.get(k, [])
        if len(rs) == 1:
            edge_regions[e] = (rs[0], -1) if edge_kind[e] == BOUNDARY else (rs[0], rs[0])
        elif len(rs) >= 2:
            edge_regions[e] = rs[:2]
    return PlanarGraph(verts, edges.astype(np.int64), edge_kind, edge_segment, edge_regions,
                       tri.astype(np.int64), lab.astype(np.int64), region_point, region_area,
                       domain, float(eps))


def merge_close_segments(outer, holes, segments, kinds=None, *, gap):
    """Constrained segments closer than ``gap`` to each other or to the rings, merged.

    The thesis's answer to slivers along discontinuity lines (future work,
    chapter 8): delete lines that lie much closer to another line than the
    element size.  A band ``w`` wide between two lines (or a line and the
    polygon's edge), meshed with nodes ``h`` apart along it, has angles near
    ``atan(w / h)``: 2 degrees for the 0.04-wide penumbra bands of the Fig.
    4.8 scene at patch size 2.4.  Segments are taken D0 first, then longest
    first; each, against the rings and the segments kept before it:

    1. **end points snapped**: an end point within ``gap`` of a kept vertex
       (ring vertices included) moves onto it, else one within ``gap`` of a
       ring or a kept segment moves onto the nearest point of it (a
       T-junction);
    2. **near parts cut**: the parts of the segment within ``gap`` of the
       rings or the kept segments are removed -- except an end piece, at most
       ``2 gap`` long, whose end point lies on them: a junction at an angle
       of 30 degrees or more (``gap / sin 30 = 2 gap``), which stays joined.
       A short segment, a duplicate or a band narrower than ``gap`` thus
       vanishes, and a line converging on another at a smaller angle stops
       ``gap`` away from it (a dangling end: the region on its two sides is
       one).  The cuts are conservative by at most 0.5 % (the buffer's
       polygon circumscribes its circles).

    Parameters
    ----------
    outer : (K, 2) array_like
    holes : sequence of (K_h, 2) array_like
    segments : (S, 2, 2) array_like
    kinds : str or sequence of str, optional
        ``"D0"``/``"D1"`` per segment or for all (default ``"D1"``).
    gap : float, keyword-only
        Distance below which lines are merged, >= 0 (0: nothing changed).

    Returns
    -------
    segments : (S', 2, 2) float64
        The kept pieces (each a straight part of one input segment, its ends
        possibly snapped).
    kinds : list of str
        ``"D0"``/``"D1"``, one per kept piece.
    source : (S',) int64
        The input segment each kept piece comes from.

    Raises
    ------
    InvalidDomainError
        Bad shapes, a negative or non-finite ``gap``, unknown kinds.
    """
    gap = float(gap)
    if not (np.isfinite(gap) and gap >= 0):
        raise InvalidDomainError(f"gap must be finite and >= 0, got {gap}")
    seg = np.asarray(segments, dtype=np.float64)
    if seg.size == 0:
        seg = np.zeros((0, 2, 2))
    if seg.ndim != 3 or seg.shape[1:] != (2, 2) or not np.all(np.isfinite(seg)):
        raise InvalidDomainError(f"segments: expected finite (S, 2, 2), got {seg.shape}")
    ns = len(seg)
    kinds = "D1" if kinds is None else kinds
    if isinstance(kinds, (str, int, np.integer)):
        kinds = [kinds] * ns
    kinds = list(kinds)
    if len(kinds) != ns:
        raise InvalidDomainError(f"kinds: need one per segment ({ns}), got {len(kinds)}")
    for s, k in enumerate(kinds):
        if k not in _KIND:
            raise InvalidDomainError(f"segment {s}: kind must be 'D0' or 'D1', got {k!r}")
    names = ["D0" if _KIND[k] == D0 else "D1" for k in kinds]
    if gap == 0 or ns == 0:
        return seg.copy(), names, np.arange(ns, dtype=np.int64)
    rings = [np.asarray(outer, dtype=np.float64)] + [np.asarray(h, dtype=np.float64) for h in holes]
    scale = float(np.ptp(rings[0], axis=0).max())
    tiny = 1e-9 * scale
    kept_lines = [shapely.LineString(np.concatenate([r, r[:1]])) for r in rings]
    kept_pts = list(np.concatenate(rings))
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    prio = np.array([0 if n == "D0" else 1 for n in names])
    out, out_src = [], []
    for s in np.lexsort((-length, prio)):
        linework = shapely.MultiLineString(kept_lines)
        ends = seg[s].copy()
        for j in range(2):   # 1. snap the end points
            p = ends[j]
            k = np.asarray(kept_pts)
            d = np.hypot(k[:, 0] - p[0], k[:, 1] - p[1])
            i = int(np.argmin(d))
            if d[i] <= gap:
                ends[j] = k[i]
                continue
            pt = shapely.Point(p)
            if linework.distance(pt) <= gap:
                q = shapely.ops.nearest_points(linework, pt)[0]
                ends[j] = (q.x, q.y)
        if np.hypot(*(ends[1] - ends[0])) <= gap:
            continue
        line = shapely.LineString(ends)
        # the buffer's polygon circumscribes the circles: its chords are gap away, not less
        near = linework.buffer(gap / math.cos(math.pi / 32.0), quad_segs=8)
        keep = line.difference(near)
        # 2. end pieces on the linework, at most 2 gap long: a junction at >= 30 degrees
        for piece in shapely.get_parts(line.intersection(near)):
            if piece.is_empty or piece.geom_type != "LineString" or piece.length > 2 * gap:
                continue
            c = np.asarray(piece.coords)
            touches = any(np.hypot(*(c[m] - ends[j])) <= tiny and linework.distance(
                shapely.Point(ends[j])) <= tiny for m in (0, -1) for j in range(2))
            if touches:
                keep = keep.union(piece)
        keep = shapely.line_merge(keep) if not keep.is_empty else keep
        for piece in shapely.get_parts(keep):
            if piece.is_empty or piece.geom_type != "LineString" or piece.length <= tiny:
                continue
            c = np.asarray(piece.coords)
            a, b = c[0], c[-1]
            out.append(np.array([a, b]))
            out_src.append(s)
            kept_lines.append(shapely.LineString([a, b]))
            kept_pts.extend([a, b])
    order = np.argsort(out_src, kind="stable")
    res = np.array(out).reshape(-1, 2, 2)[order]
    src = np.asarray(out_src, dtype=np.int64)[order]
    return res, [names[s] for s in src], src


def edge_node_parameters(length, sizes, *, rounding="ceil"):
    """Parameters in (0, 1) of the nodes inside an edge, spaced by a size profile.

    The edge gets ``n`` intervals, ``n = ceil(I)`` (never longer than the
    size) or ``max(1, round(I))`` (the bubble mesh's count) with
    ``I = integral of ds / size``, and the nodes sit at equal quantiles of
    that integral (the 1-D equilibrium of a bubble chain when the size
    varies slowly).

    Parameters
    ----------
    length : float
    sizes : (m,) float64
        The size at ``m >= 2`` equally spaced parameters ``0 ... 1``.
    rounding : {"ceil", "round"}

    Returns
    -------
    (n - 1,) float64, increasing
    """
    h = np.asarray(sizes, dtype=np.float64)
    m = len(h)
    t = np.linspace(0.0, 1.0, m)
    inv = 1.0 / h
    cum = np.zeros(m)
    cum[1:] = np.cumsum(0.5 * (inv[1:] + inv[:-1])) * (length / (m - 1))
    total = cum[-1]
    if rounding == "ceil":
        n = max(1, int(math.ceil(total - 1e-9)))
    else:
        n = max(1, int(np.rint(total)))
    return np.interp(total * np.arange(1, n) / n, cum, t)


@dataclass(frozen=True, eq=False)
class GraphMesh:
    """Result of :func:`mesh_planar_graph`.

    Attributes
    ----------
    nodes : (N, 2) float64
        The graph's vertices (same indices), then the nodes inside its
        edges, then the face nodes.
    triangles : (T, 3) int64
        Counter-clockwise; no triangle crosses a graph edge.
    chains : list of (k_e,) int64
        For every graph edge, its nodes from ``edges[e, 0]`` to ``edges[e, 1]``.
    """

    nodes: np.ndarray
    triangles: np.ndarray
    chains: list

    def chain_edges(self, kind=None, graph=None):
        """(C, 2) int64 mesh edges along the graph edges (of one kind, given the graph)."""
        sel = range(len(self.chains)) if kind is None else np.flatnonzero(graph.edge_kind == kind)
        out = [np.stack([self.chains[e][:-1], self.chains[e][1:]], axis=1) for e in sel]
        return np.concatenate(out).astype(np.int64) if out else np.zeros((0, 2), np.int64)


def _hex(lo, hi, h):
    # a triangular lattice of spacing h centred in the box (symmetric shapes stay symmetric)
    dy = h * math.sqrt(3.0) / 2.0
    ny = int(math.floor((hi[1] - lo[1]) / dy)) + 1
    nx = int(math.floor((hi[0] - lo[0]) / h)) + 2
    jj, ii = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    x0 = lo[0] + 0.5 * ((hi[0] - lo[0]) - (nx - 1) * h)
    y0 = lo[1] + 0.5 * ((hi[1] - lo[1]) - (ny - 1) * dy)
    return np.stack([(x0 + ii * h + 0.5 * h * (jj % 2)).ravel(), (y0 + jj * dy).ravel()], axis=1)


def mesh_planar_graph(graph, sizes, *, method="lattice", edge_nodes=None, seed=0, samples=33,
                      **bubble_kwargs):
    """Mesh a planar graph: vertices, then edges with the smaller adjacent size, then faces.

    Parameters
    ----------
    graph : PlanarGraph
    sizes : number, callable, GridSize, or a sequence of those (one per region)
        Target edge length per region.
    method : {"lattice", "bubble"}, keyword-only
        Face nodes on a triangular lattice of the region's size (a varying
        size field: a lattice of the smallest size thinned with probability
        ``(h_min / h)^2``, seeded) kept half a size away from the edges; or
        relaxed bubbles (2.3.3) with the vertex and edge nodes fixed.
    edge_nodes : dict {edge index: (k,) float64 parameters}, optional
        Preset node parameters along some edges (from ``edges[e, 0]`` to
        ``edges[e, 1]``), e.g. shared with a neighbouring polygon.
    seed : int
    samples : int
        Size samples per edge for the node spacing.
    **bubble_kwargs
        Passed to the bubble relaxation (see :func:`polygen.mesh2d.bubble_mesh`).

    Returns
    -------
    GraphMesh
        Meshed relative to :func:`~polygen.mesh2d.domain.local_origin` of
        the graph's vertices (an exact translation; none near the origin);
        size fields are called with the caller's coordinates.
    """
    origin = local_origin(graph.vertices)
    if not origin.any():
        return _mesh_planar_graph_local(graph, sizes, method=method, edge_nodes=edge_nodes, seed=seed,
                                        samples=samples, **bubble_kwargs)
    if callable(sizes) or np.isscalar(sizes):
        sizes = [sizes] * graph.n_regions
    local_sizes = [_size_at(as_size_function(f), origin) for f in sizes]
    gm = _mesh_planar_graph_local(_shifted(graph, -origin), local_sizes, method=method, edge_nodes=edge_nodes,
                                  seed=seed, samples=samples, **bubble_kwargs)
    return GraphMesh(gm.nodes + origin, gm.triangles, gm.chains)


def _size_at(field, origin):
    """A size field of local coordinates from one of the caller's."""
    if field.constant is not None:
        return field.constant

    def size(q):
        return field(np.asarray(q, dtype=np.float64) + origin)

    size.constant = None
    return size


def _mesh_planar_graph_local(graph, sizes, *, method="lattice", edge_nodes=None, seed=0, samples=33,
                             **bubble_kwargs):
    from polygen.mesh2d.bubble import _bubble_core, _bubble_opts

    if method not in ("lattice", "bubble"):
        raise ValueError(f"method: expected 'lattice' or 'bubble', got {method!r}")
    if callable(sizes) or np.isscalar(sizes):
        sizes = [sizes] * graph.n_regions
    fns = [as_size_function(s) for s in sizes]
    sizef = graph.region_size_function(fns)
    v = graph.vertices
    edge_nodes = {} if edge_nodes is None else edge_nodes
    # nodes inside the edges: the smaller size of the two sides (3.3.6)
    t = np.linspace(0.0, 1.0, samples)
    chains, new, new_h = [], [], []
    n_next = len(v)
    rounding = "ceil" if method == "lattice" else "round"
    vert_h = np.full(len(v), np.inf)

    def smaller_side(e, q):
        regs = sorted({int(r) for r in graph.edge_regions[e] if r >= 0})
        return np.min([fns[r](q) for r in regs], axis=0) if regs else sizef(q)

    for e, (a, b) in enumerate(graph.edges):
        if e in edge_nodes:
            te = np.asarray(edge_nodes[e], dtype=np.float64).reshape(-1)
        else:
            sp = v[a] + t[:, None] * (v[b] - v[a])
            te = edge_node_parameters(float(np.hypot(*(v[b] - v[a]))), smaller_side(e, sp),
                                      rounding=rounding)
        p = v[a] + te[:, None] * (v[b] - v[a])
        new.append(p)
        # the node sizes on an edge (its vertices included): the smaller side's
        hp = smaller_side(e, np.concatenate([v[[a, b]], p]))
        vert_h[a] = min(vert_h[a], hp[0])
        vert_h[b] = min(vert_h[b], hp[1])
        new_h.append(hp[2:])
        chains.append(np.concatenate([[a], n_next + np.arange(len(p)), [b]]).astype(np.int64))
        n_next += len(p)
    fixed = np.concatenate([v] + new)
    fixed_h = np.concatenate([np.where(np.isfinite(vert_h), vert_h, sizef(v))] + new_h)
    cons = np.concatenate([np.stack([c[:-1], c[1:]], axis=1) for c in chains]).astype(np.int64)
    outer = np.asarray(graph.domain.exterior.coords)[:-1]
    holes = [np.asarray(r.coords)[:-1] for r in graph.domain.interiors]

    if method == "lattice":
        lines = shapely.multilinestrings([shapely.linestrings(v[graph.edges])]) \
            if len(graph.edges) else None
        rng = np.random.default_rng(seed)
        face = []
        for r, f in enumerate(fns):
            reg = graph.region_polygon(r)
            lo = np.array(reg.bounds[:2])
            hi = np.array(reg.bounds[2:])
            if f.constant is not None:
                h_min = f.constant
                cand = _hex(lo, hi, h_min)
            else:
                probe = _hex(lo, hi, float((hi - lo).max()) / 100.0)
                h_min = float(f(probe).min())
                cand = _hex(lo, hi, h_min)
            if not len(cand):
                continue
            cand = cand[graph.region_of(cand) == r]
            cand = cand[shapely.contains_xy(graph.domain, cand[:, 0], cand[:, 1])]
            if not len(cand):
                continue
            h = f(cand)
            far = shapely.distance(lines, shapely.points(cand)) > 0.5 * h
            if f.constant is None:
                far &= rng.random(len(cand)) < (h_min / h) ** 2
            face.append(cand[far])
        allp = np.concatenate([fixed] + face)
        mesh = constrained_delaunay(allp, cons, erase_outside=False, order="as_provided")
        tri = mesh.triangles
        nodes = mesh.nodes
    else:
        dom = validate_domain(outer, holes, allow_touching=True)
        # interior segments need the segment-distance index and the centroid
        # filter; rings alone are handled by the constraint parity, faster
        internal = bool(np.any(graph.edge_kind != BOUNDARY))
        bm = _bubble_core(dom, fixed, cons, sizef, internal, bare=True, seed=seed,
                          fixed_size=fixed_h,
                          regions=graph.region_of if graph.n_regions > 1 else None,
                          **_bubble_opts(bubble_kwargs))
        nodes, tri = bm.nodes, bm.triangles
    # keep the triangles inside the polygon; drop hull slivers along collinear boundary nodes
    cen = nodes[tri].mean(axis=1)
    a, b, c = (nodes[tri[:, k]] for k in range(3))
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    h_ref = float(sizef(cen).min()) if len(cen) else 1.0
    keep = shapely.contains_xy(graph.domain, cen[:, 0], cen[:, 1]) & (np.abs(area2) > 1e-8 * h_ref ** 2)
    return GraphMesh(nodes, np.ascontiguousarray(tri[keep]), chains)


def convex_partition(outer, holes=()):
    """Convex pieces of a polygon with holes (Hertel-Mehlhorn over a constrained triangulation).

    Parameters
    ----------
    outer : (K, 2) float64
    holes : sequence of (K_h, 2) float64

    Returns
    -------
    list of (k, 2) float64
        Counter-clockwise convex rings whose union is the polygon.
    """
    g = planar_graph(outer, holes)
    v = g.vertices
    tri = g.triangles
    scale = float(np.ptp(v, axis=0).max())
    pieces = {t: [int(i) for i in tri[t]] for t in range(len(tri))}
    owner = {}
    for t, ring in pieces.items():
        for k in range(3):
            owner[(ring[k], ring[(k + 1) % 3])] = t
    bset = {tuple(sorted(e)) for e in g.edges.tolist()}
    diag = [(a, b) for (a, b) in owner if a < b and (b, a) in owner and (a, b) not in bset]
    diag.sort(key=lambda e: -np.hypot(*(v[e[0]] - v[e[1]])))

    def convex_at(ring, i):
        p, q, r = v[ring[i - 1]], v[ring[i]], v[ring[(i + 1) % len(ring)]]
        return (q[0] - p[0]) * (r[1] - q[1]) - (q[1] - p[1]) * (r[0] - q[0]) >= -1e-12 * scale ** 2

    for a, b in diag:
        ta, tb = owner.get((a, b)), owner.get((b, a))
        if ta is None or tb is None or ta == tb:
            continue
        ra, rb = pieces[ta], pieces[tb]
        ia = ra.index(a)  # ra: ... a, b ...
        ib = rb.index(b)  # rb: ... b, a ...
        # walk ra from b round to a, then rb from a (exclusive) round to b (exclusive)
        merged = ra[ia + 1:] + ra[:ia + 1]
        rest = rb[ib + 1:] + rb[:ib + 1]  # starts at a, ends at b
        merged = merged + rest[1:-1]
        ja, jb = merged.index(a), merged.index(b)
        if not (convex_at(merged, ja) and convex_at(merged, jb)):
            continue
        pieces[ta] = merged
        del pieces[tb]
        for k in range(len(merged)):
            owner[(merged[k], merged[(k + 1) % len(merged)])] = ta
        owner.pop((a, b), None)
        owner.pop((b, a), None)
    return [v[r] for _, r in sorted(pieces.items())]
