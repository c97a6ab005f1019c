"""The mesh model of chapters 3 and 4: segments, regions, region sizes, conforming edges.

Per receiver polygon, chapter 3 hands constrained segments -- discontinuity
lines -- of two kinds (3.3.6, Fig. 3.11): **D0** (radiance discontinuity:
the mesh gets separate nodes on the two sides, node intensities (2.8)
never average across) and **D1** (derivative discontinuity: nodes shared).
The segments cut the polygon into *regions*; each region gets its own
patch size (smaller where it is penumbra), and chapter 4 hands a size grid
(:class:`polygen.mesh2d.GridSize`) per polygon.  This module turns those
into what :func:`polygen.radiosity.mesh.mesh_scene` meshes:

* :class:`Segments` -- segments on one polygon, 2-D in its (u, v) frame or
  3-D points on its plane, with their kinds;
* :func:`polygon_layout` -- the polygon's planar graph and regions (to
  label them before choosing sizes: ``layout.region_point``);
* :class:`RegionSize` -- a size per region, by region number or by a point
  inside it;
* conforming nodes between polygons: where edges of two polygons overlap
  in 3-D (a wall on the floor, a block's side on the floor's hole ring),
  both get the same vertices and the same nodes along the common part,
  spaced by the smaller size of the two sides (3.3.6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from polygen.mesh2d import InvalidDomainError, planar_graph
from polygen.mesh2d.pslg import BOUNDARY, D0, D1, _union_find, edge_node_parameters
from polygen.radiosity._errors import MeshError
from polygen.radiosity.scene import Polygon

__all__ = ["D0", "D1", "Segments", "RegionSize", "polygon_layout", "contact_segments"]

# merge tolerance relative to a polygon's / the scene's extent (above the
# plane-projection round-off of Polygon.to_3d, below any real feature)
LAYOUT_TOL = 1e-7


class _Error(ValueError):
    pass


@dataclass(frozen=True, eq=False)
class Segments:
    """Constrained segments on one polygon.

    Parameters
    ----------
    ends : (S, 2, 2) or (S, 2, 3) float64
        ``ends[s] = (start, end)``: 2-D in the polygon's (u, v) frame
        (``Polygon.to_2d``), or 3-D points on its plane.
    kinds : "D0", "D1" or a sequence of them, one per segment
        D0: radiance discontinuity (nodes duplicated across); D1:
        derivative discontinuity (nodes shared).  Default ``"D1"``.
    """

    ends: np.ndarray
    kinds: object = "D1"

    def __post_init__(self):
        e = np.asarray(self.ends, dtype=np.float64)
        if e.size == 0:
            e = np.zeros((0, 2, 2))
        if e.ndim != 3 or e.shape[1] != 2 or e.shape[2] not in (2, 3):
            raise ValueError(f"Segments.ends: expected shape (S, 2, 2) or (S, 2, 3), got {e.shape}")
        object.__setattr__(self, "ends", e)

    def __len__(self):
        return len(self.ends)

    def in_plane(self, polygon, *, index=None):
        """``(ends (S, 2, 2), kinds)`` in the polygon's frame; 3-D ends must lie on its plane."""
        e = self.ends
        if e.shape[2] == 3:
            d = np.abs((e.reshape(-1, 3) - polygon.origin) @ polygon.normal)
            tol = 1e-6 * polygon.diameter
            if len(d) and d.max() > tol:
                s = int(np.argmax(d)) // 2
                raise _Error(f"segment {s}: off the polygon's plane by {d.max():.3g} "
                             f"(tolerance {tol:.3g})")
            e = polygon.to_2d(e)
        return e, self.kinds


def _as_segments(spec):
    """A Segments from a Segments, an ``(ends (S, 2, d), kinds)`` pair or bare ends."""
    if spec is None or isinstance(spec, Segments):
        return spec
    if isinstance(spec, tuple) and len(spec) == 2 and np.ndim(spec[0]) == 3:
        return Segments(*spec)
    return Segments(spec)


class RegionSize:
    """A patch size (or size field) per region of a polygon.

    Parameters
    ----------
    sizes : sequence of (number, callable ``size(xy) -> (K,)`` or GridSize)
        One per region: in region order (:func:`polygon_layout`'s
        numbering) when ``at`` is None, else one per point of ``at``.
    at : (R, 2) or (R, 3) float64, keyword-only, optional
        A point inside each region, 2-D in the polygon's frame or 3-D on
        it: the region containing ``at[r]`` gets ``sizes[r]``.
    default : number, callable or GridSize, keyword-only, optional
        The size of regions no point of ``at`` falls in (required then).

    Notes
    -----
    Callables and grids are read in the polygon's (u, v) frame.
    """

    def __init__(self, sizes, *, at=None, default=None):
        self.sizes = list(sizes)
        self.at = None if at is None else np.asarray(at, dtype=np.float64)
        self.default = default
        if self.at is not None:
            if self.at.ndim != 2 or self.at.shape[1] not in (2, 3) or len(self.at) != len(self.sizes):
                raise ValueError(f"RegionSize: `at` must be (R, 2|3) with R = len(sizes) = "
                                 f"{len(self.sizes)}, got {self.at.shape}")

    def resolve(self, polygon, layout):
        """One size spec per region of ``layout`` (a :class:`polygen.mesh2d.PlanarGraph`)."""
        n = layout.n_regions
        if self.at is None:
            if len(self.sizes) != n:
                raise _Error(f"RegionSize: {len(self.sizes)} sizes for {n} regions")
            return list(self.sizes)
        pts = self.at if self.at.shape[1] == 2 else polygon.to_2d(self.at)
        reg = layout.region_of(pts)
        if np.any(reg < 0):
            raise _Error(f"RegionSize: point {int(np.flatnonzero(reg < 0)[0])} is outside the polygon")
        out = [None] * n
        for r, s in zip(reg, self.sizes):
            out[r] = s
        missing = [r for r in range(n) if out[r] is None]
        if missing:
            if self.default is None:
                raise _Error(f"RegionSize: no size for region {missing[0]} (point "
                             f"{layout.region_point[missing[0]].round(9).tolist()}) and no default")
            for r in missing:
                out[r] = self.default
        return out


def polygon_layout(polygon, segments=None, *, points=None, tol=LAYOUT_TOL):
    """The planar graph of a polygon and its segments, and its regions.

    Parameters
    ----------
    polygon : Polygon
    segments : Segments or (ends, kinds), optional
    points : (P, 2) float64, optional
        Extra vertices on its rings or segments (2-D frame).
    tol : float, keyword-only
        Merge tolerance relative to the polygon's extent.

    Returns
    -------
    polygen.mesh2d.PlanarGraph
        ``region_point`` (2-D; ``polygon.to_3d`` for 3-D) gives a point in
        each region, ``region_of(xy)`` the region of any point.

    Raises
    ------
    MeshError
        Naming the polygon and the offending segment.
    """
    if not isinstance(polygon, Polygon):
        raise MeshError(f"polygon must be a Polygon, got {type(polygon).__name__}")
    try:
        return _layout(polygon, _as_segments(segments), points, tol)
    except (InvalidDomainError, _Error) as exc:
        raise MeshError(f"polygon {polygon.name!r}: {exc}") from None


def _layout(polygon, seg, points, tol):
    ends, kinds = (None, None) if seg is None else seg.in_plane(polygon)
    return planar_graph(polygon.exterior_2d, polygon.holes_2d, ends, kinds, points=points, tol=tol)


def contact_segments(scene, *, kind="D0", segments=None):
    """Contact lines: edges of polygons lying inside other polygons, as segments of those.

    Where an object stands on a receiver (a block on the floor) its edges lie
    in the receiver's plane, inside it: the radiance jumps there (D0, 3.3.6),
    and the receiver's mesh must follow the line.  Edges on a receiver's
    boundary are left to the conforming edges of :func:`mesh_scene`.

    Parameters
    ----------
    scene : Scene
    kind : {"D0", "D1"}, keyword-only
    segments : mapping {polygon index: Segments}, keyword-only, optional
        Segments to add the contact lines to (3-D ends are kept 3-D, 2-D
        ones are converted).

    Returns
    -------
    dict {polygon index: Segments}
        3-D end points; only polygons that have segments.
    """
    import shapely

    tol = _scene_tol(scene)
    out = {}
    for k, seg in (segments or {}).items():
        seg = _as_segments(seg)
        e = seg.ends if seg.ends.shape[2] == 3 else scene.polygons[k].to_3d(seg.ends)
        kinds = seg.kinds if not isinstance(seg.kinds, (str, int)) else [seg.kinds] * len(e)
        out[k] = (list(e), list(kinds))
    A, B, own = _edges3d(scene, [None] * len(scene.polygons))
    for k, poly in enumerate(scene.polygons):
        da = (A - poly.origin) @ poly.normal
        db = (B - poly.origin) @ poly.normal
        cand = np.flatnonzero((own != k) & (np.abs(da) <= tol) & (np.abs(db) <= tol))
        if not len(cand):
            continue
        shp = poly._shape2d
        found = []
        for c in cand:
            line = shapely.LineString(poly.to_2d(np.stack([A[c], B[c]])))
            inter = shapely.intersection(shp, line)
            for part in getattr(inter, "geoms", [inter]):
                if part.geom_type != "LineString" or part.length <= tol:
                    continue
                p = np.asarray(part.coords)
                # pieces along the receiver's own boundary are conforming edges, not contacts
                if shapely.distance(shp.boundary, shapely.Point(p.mean(axis=0))) <= tol:
                    continue
                found.append(poly.to_3d(p[[0, -1]]))
        if found:
            e, kinds = out.setdefault(k, ([], []))
            e.extend(found)
            kinds.extend([kind] * len(found))
    return {k: Segments(np.array(e), kinds) for k, (e, kinds) in out.items() if len(e)}


# ----------------------------------------------------------------------------
# conforming nodes between polygons
# ----------------------------------------------------------------------------
def _scene_tol(scene):
    b = scene.bounds
    return LAYOUT_TOL * float(np.linalg.norm(b[1] - b[0]))


def _edges3d(scene, segs2d):
    """Ring edges and segments of every polygon in 3-D: A (E, 3), B (E, 3), owner (E,)."""
    A, B, own = [], [], []
    for k, poly in enumerate(scene.polygons):
        for r in [poly.exterior_2d] + list(poly.holes_2d):
            p = poly.to_3d(r)
            A.append(p)
            B.append(np.roll(p, -1, axis=0))
            own.append(np.full(len(p), k))
        if segs2d[k] is not None and len(segs2d[k][0]):
            e = poly.to_3d(segs2d[k][0])
            A.append(e[:, 0])
            B.append(e[:, 1])
            own.append(np.full(len(e), k))
    return np.concatenate(A), np.concatenate(B), np.concatenate(own)


def _overlapping_pairs(A, B, own, tol):
    """Pairs (i, j) of collinear edges of different polygons overlapping by more than tol."""
    import shapely

    lo = np.minimum(A, B) - tol
    hi = np.maximum(A, B) + tol
    boxes = shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])
    i, j = shapely.STRtree(boxes).query(boxes, predicate="intersects")
    m = (i < j) & (own[i] != own[j]) & (lo[i, 2] <= hi[j, 2]) & (lo[j, 2] <= hi[i, 2])
    i, j = i[m], j[m]
    d = B[i] - A[i]
    L = np.linalg.norm(d, axis=1)
    u = d / L[:, None]

    def off_line(P):
        w = P - A[i]
        return np.linalg.norm(w - np.einsum("ij,ij->i", w, u)[:, None] * u, axis=1)

    s1 = np.einsum("ij,ij->i", A[j] - A[i], u)
    s2 = np.einsum("ij,ij->i", B[j] - A[i], u)
    ov = np.minimum(np.maximum(s1, s2), L) - np.maximum(np.minimum(s1, s2), 0.0)
    ok = (off_line(A[j]) <= tol) & (off_line(B[j]) <= tol) & (ov > tol)
    return i[ok], j[ok]


def shared_split_points(scene, segs2d):
    """Per polygon, (P_k, 2) extra vertices where other polygons' overlapping edges end.

    Where an edge of polygon A overlaps an edge of polygon B in 3-D, the end
    points of each (and the segment end points lying on it) that fall
    inside the other become vertices of the other, so that after splitting
    the common part is one edge in both.
    """
    tol = _scene_tol(scene)
    A, B, own = _edges3d(scene, segs2d)
    i, j = _overlapping_pairs(A, B, own, tol)
    # per polygon: every vertex and segment end point (3-D), candidates for propagation
    cand = [np.concatenate([A[own == k], B[own == k]]) for k in range(len(scene.polygons))]
    extra = [[] for _ in scene.polygons]

    def inside(P, a, b):
        d = b - a
        L = np.linalg.norm(d)
        t = (P - a) @ d / (L * L)
        off = np.linalg.norm(P - (a + t[:, None] * d), axis=1)
        return (off <= tol) & (t * L > tol) & ((1 - t) * L > tol)

    def on(P, a, b):
        d = b - a
        L = np.linalg.norm(d)
        t = (P - a) @ d / (L * L)
        off = np.linalg.norm(P - (a + t[:, None] * d), axis=1)
        return (off <= tol) & (t * L >= -tol) & ((1 - t) * L >= -tol)

    for a, b in zip(i, j):
        for src, dst in ((a, b), (b, a)):
            P = cand[own[src]]
            P = P[on(P, A[src], B[src])]
            P = P[inside(P, A[dst], B[dst])]
            if len(P):
                extra[own[dst]].append(P)
    out = []
    for k, poly in enumerate(scene.polygons):
        out.append(poly.to_2d(np.concatenate(extra[k])) if extra[k] else None)
    return out


def shared_edge_groups(scene, layouts):
    """Graph edges of different polygons that coincide in 3-D.

    Returns
    -------
    list of (P (3,), Q (3,), members)
        ``members``: list of (polygon, edge, reversed) -- ``reversed`` when the
        edge runs from Q to P.
    """
    tol = _scene_tol(scene)
    ends, owner = [], []
    for k, (poly, g) in enumerate(zip(scene.polygons, layouts)):
        e3 = poly.to_3d(g.vertices[g.edges])  # (E, 2, 3)
        ends.append(e3)
        owner.append(np.stack([np.full(len(e3), k), np.arange(len(e3))], axis=1))
    ends = np.concatenate(ends)
    owner = np.concatenate(owner)
    pts = ends.reshape(-1, 3)
    from scipy.spatial import cKDTree

    pairs = cKDTree(pts).query_pairs(tol, output_type="ndarray")
    root = _union_find(len(pts), pairs).reshape(-1, 2)
    key = np.sort(root, axis=1)
    order = np.lexsort((owner[:, 1], owner[:, 0], key[:, 1], key[:, 0]))
    groups = []
    s = 0
    while s < len(order):
        t = s
        while t + 1 < len(order) and np.array_equal(key[order[t + 1]], key[order[s]]):
            t += 1
        mem = order[s:t + 1]
        if len(set(owner[mem, 0].tolist())) > 1:
            P = pts[key[mem[0], 0]]
            Q = pts[key[mem[0], 1]]
            groups.append((P, Q, [(int(owner[m, 0]), int(owner[m, 1]),
                                   bool(root[m, 0] != key[m, 0])) for m in mem]))
        s = t + 1
    return groups


def edge_sizes(layout, fns, e, t):
    """The smaller adjacent region size along graph edge ``e`` at parameters ``t`` (3.3.6)."""
    v = layout.vertices
    a, b = layout.edges[e]
    sp = v[a] + np.asarray(t)[:, None] * (v[b] - v[a])
    regs = sorted({int(r) for r in layout.edge_regions[e] if r >= 0})
    return np.min([fns[r](sp) for r in regs], axis=0)


def shared_edge_nodes(groups, layouts, fns, *, rounding, samples=33):
    """Preset node parameters per polygon: ``[{edge: t (k,)}]`` plus per group the canonical t."""
    presets = [dict() for _ in layouts]
    canon = []
    t = np.linspace(0.0, 1.0, samples)
    for P, Q, mem in groups:
        h = np.min([edge_sizes(layouts[k], fns[k], e, (1 - t) if rev else t)
                    for k, e, rev in mem], axis=0)
        te = edge_node_parameters(float(np.linalg.norm(Q - P)), h, rounding=rounding)
        canon.append(te)
        for k, e, rev in mem:
            presets[k][e] = (1.0 - te)[::-1] if rev else te
    return presets, canon


def shared_element_nodes(groups, canon, layouts, chains, efns, *, samples=17):
    """Preset element nodes on the shared patch edges: ``[{(i, j): (k, 2)}]`` per polygon."""
    out = [dict() for _ in layouts]
    for (P, Q, mem), te in zip(groups, canon):
        knots = np.concatenate([[0.0], te, [1.0]])
        L = float(np.linalg.norm(Q - P))
        for m in range(len(knots) - 1):
            t0, t1 = knots[m], knots[m + 1]
            s = np.linspace(t0, t1, samples)
            h = np.min([edge_sizes(layouts[k], efns[k], e, (1 - s) if rev else s)
                        for k, e, rev in mem], axis=0)
            sub = t0 + (t1 - t0) * edge_node_parameters(L * (t1 - t0), h, rounding="round")
            for k, e, rev in mem:
                g = layouts[k]
                a, b = g.edges[e]
                ch = chains[k][e]
                loc = sub if not rev else (1.0 - sub)[::-1]
                lo_i = m if not rev else len(knots) - 2 - m
                i, j = int(ch[lo_i]), int(ch[lo_i + 1])
                xy = g.vertices[a] + loc[:, None] * (g.vertices[b] - g.vertices[a])
                out[k][(i, j)] = xy
    return out


# ----------------------------------------------------------------------------
# D0 lines: duplicated nodes
# ----------------------------------------------------------------------------
def duplicate_across(points, elements, cut_edge):
    """Separate node copies on the two sides of cut edges.

    The elements around a node are joined through the edges they share
    unless the edge is cut; each group gets its own copy of the node.  A
    node on a D0 line gets one copy per side; the interior end of a
    dangling D0 line keeps one node (the elements around it stay joined).

    Parameters
    ----------
    points : (N, d) float64
    elements : (M, 3) int64
    cut_edge : callable ``(a (K,), b (K,)) -> (K,) bool``
        Whether the mesh edge between nodes a and b lies on a D0 line.

    Returns
    -------
    points : (N', d) float64
        The input points, then the extra copies.
    elements : (M, 3) int64
    site : (N',) int64
        The input node each node copies (``arange(N)`` for the first N).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    el = np.asarray(elements, dtype=np.int64)
    m = len(el)
    ks = np.array([[0, 1], [1, 2], [2, 0]])
    a = el[:, ks[:, 0]].ravel()
    b = el[:, ks[:, 1]].ravel()
    ca = (3 * np.arange(m)[:, None] + ks[:, 0]).ravel()
    cb = (3 * np.arange(m)[:, None] + ks[:, 1]).ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.lexsort((hi, lo))
    same = np.flatnonzero((lo[order[1:]] == lo[order[:-1]]) & (hi[order[1:]] == hi[order[:-1]]))
    o1, o2 = order[same], order[same + 1]
    keep = ~cut_edge(a[o1], b[o1]) if len(o1) else np.zeros(0, bool)
    o1, o2 = o1[keep], o2[keep]
    # corner of node a in o1 with the corner of the same node in o2
    s1 = np.where(a[o1] == a[o2], ca[o2], cb[o2])
    s2 = np.where(b[o1] == b[o2], cb[o2], ca[o2])
    rows = np.concatenate([ca[o1], cb[o1]])
    cols = np.concatenate([s1, s2])
    g = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * m, 3 * m))
    _, comp = connected_components(g, directed=False)
    corner_node = el.ravel()
    # the first component met at a node keeps its index, the others become copies
    n = len(points)
    uc, first = np.unique(comp, return_index=True)
    comp_node = corner_node[first]
    order_c = np.lexsort((first, comp_node))
    sorted_node = comp_node[order_c]
    keeps = np.ones(len(order_c), bool)
    keeps[1:] = sorted_node[1:] != sorted_node[:-1]
    new_id = np.empty(len(uc), np.int64)
    new_id[order_c[keeps]] = sorted_node[keeps]
    extra = sorted_node[~keeps].astype(np.int64)
    new_id[order_c[~keeps]] = n + np.arange(len(extra))
    lut = np.empty(comp.max() + 1, np.int64)
    lut[uc] = new_id
    new_el = lut[comp].reshape(m, 3)
    pts = np.concatenate([points, np.asarray(points)[extra]]) if len(extra) else np.asarray(points)
    site = np.concatenate([np.arange(n), extra]).astype(np.int64)
    return pts, new_el, site


def d0_cut(layout, points):
    """``cut_edge(a, b)`` for :func:`duplicate_across`: the edge's midpoint lies on a D0 edge."""
    import shapely

    g = layout
    d0 = g.edges[g.edge_kind == D0]
    if not len(d0):
        return None
    lines = shapely.multilinestrings(shapely.linestrings(g.vertices[d0]))

    def cut(a, b):
        mid = 0.5 * (points[a] + points[b])
        return shapely.dwithin(lines, shapely.points(mid), 4 * g.eps + 1e-12)

    return cut


__all__ += ["BOUNDARY", "LAYOUT_TOL"]
