"""Patches, elements and nodes (thesis Defs 2.2-2.4) and the meshers that make them.

A :class:`RadiosityMesh` is what the solvers take: any triangulation of the
scene's polygons into *patches* (which shoot light), each patch subdivided
into *elements* (which gather light), with *nodes* shared between the
elements of one polygon (no T-vertices, Def. 2.5), except across a D0
line, where each side has its own copy (:attr:`RadiosityMesh.node_site`).
Nodes are not shared between different polygons, so node intensities
(2.8) never mix walls.

How patches are made is pluggable: :func:`mesh_scene` calls a *mesher*
``mesher(exterior, holes, size) -> (points, triangles)`` on each polygon in
its plane.  The default, :func:`lattice_delaunay_mesher`, is the simplest
thing that meets requirement 2.1 (concave polygons with holes): boundary
edges split to the target size, a triangular lattice of interior nodes, and
a constrained Delaunay triangulation (pythoncdt).  :func:`bubble_mesher`
plugs the bubble mesh of ``polygen.mesh2d`` (2.3.3) in at the same place.

With these two meshers a polygon may also carry constrained segments --
discontinuity lines of kind D0 or D1 (3.3.6) -- that cut it into regions,
each with its own size; edges shared by two polygons get the same nodes on
both; see :mod:`polygen.radiosity.layout` and :func:`mesh_scene`.  A
two-sided polygon (``Polygon(..., two_sided=True)``) is meshed on both
faces (:attr:`RadiosityMesh.patch_side`).

Elements come from patches either by regular 1 -> 4 splitting (the default,
the "simple method" the thesis itself allows for this step, 3.3.6 step 6),
or by an *element mesher* ``element_mesher(points, patches, element_size)``
such as :func:`bubble_element_mesher`, a finer bubble mesh constrained by
the patch edges.  Either way the elements of one polygon share their nodes
across patch edges, so there are no T-vertices (Def. 2.5).
"""

from __future__ import annotations

import numpy as np

from polygen._memory import check_fits
from polygen.radiosity import layout as lay
from polygen.radiosity._errors import MeshError
from polygen.radiosity.layout import RegionSize, _as_segments
from polygen.radiosity.scene import Scene, SceneError

__all__ = [
    "MeshError",
    "RadiosityMesh",
    "lattice_delaunay_mesher",
    "bubble_mesher",
    "bubble_element_mesher",
    "split_triangles",
    "mesh_scene",
    "assemble_mesh",
]


class RadiosityMesh:
    """Patches, elements and nodes of a scene (Defs 2.2-2.4).

    Parameters
    ----------
    scene : Scene
        The scene the mesh discretises; materials come from its polygons.
    nodes : (N, 3) float64
        Node coordinates.
    elements : (M, 3) int64
        Node indices of each triangular element, counter-clockwise seen from
        the front of its polygon.
    element_patch : (M,) int64
        Patch that owns each element.
    patches : (P, 3) int64
        Node indices of each triangular patch (Def. 2.2).
    patch_polygon : (P,) int64
        Scene polygon that each patch lies on.
    patch_side : (P,) int8, optional
        +1 for patches on the front of their polygon (default), -1 on the
        back of a two-sided polygon (normal ``-polygon.normal``; its
        elements are counter-clockwise seen from the back).
    node_site : (N,) int64, optional
        Nodes with the same site are copies of one point on a D0 line
        (separate nodes on its two sides, 3.3.6); default ``arange(N)``.

    Attributes
    ----------
    layouts : list of PlanarGraph or None
        Set by :func:`mesh_scene` (our meshers): each polygon's planar graph
        -- its segments and regions (:func:`polygen.radiosity.polygon_layout`).
    patch_region : (P,) int64 or None
        Set with ``layouts``: the region (within its polygon) of each patch.

    Notes
    -----
    Derived arrays (areas, centroids, normals, per-element materials, the
    node -> element adjacency) are computed once, lazily.  Patch area and
    centroid are sums over the patch's elements, so they are consistent
    with the elements even if a mesher's patch triangles were not.
    """

    def __init__(self, scene, nodes, elements, element_patch, patches, patch_polygon,
                 patch_side=None, node_site=None):
        if not isinstance(scene, Scene):
            raise MeshError(f"scene must be a Scene, got {type(scene).__name__}")
        self.scene = scene
        self.nodes = np.ascontiguousarray(nodes, dtype=np.float64)
        self.elements = np.ascontiguousarray(elements, dtype=np.int64)
        self.element_patch = np.ascontiguousarray(element_patch, dtype=np.int64)
        self.patches = np.ascontiguousarray(patches, dtype=np.int64)
        self.patch_polygon = np.ascontiguousarray(patch_polygon, dtype=np.int64)
        n, m, p = len(self.nodes), len(self.elements), len(self.patches)
        self.patch_side = (np.ones(p, dtype=np.int8) if patch_side is None
                           else np.ascontiguousarray(patch_side, dtype=np.int8))
        self.node_site = (np.arange(n, dtype=np.int64) if node_site is None
                          else np.ascontiguousarray(node_site, dtype=np.int64))
        if self.patch_side.shape != (p,) or not np.all(np.abs(self.patch_side) == 1):
            raise MeshError(f"patch_side must be ({p},) of +1/-1, got shape {self.patch_side.shape}")
        if self.node_site.shape != (n,) or (n and (self.node_site.min() < 0
                                                    or self.node_site.max() >= n)):
            raise MeshError(f"node_site must be ({n},) node indices")
        if self.nodes.ndim != 2 or self.nodes.shape[1] != 3:
            raise MeshError(f"nodes must be (N, 3), got {self.nodes.shape}")
        if self.elements.ndim != 2 or self.elements.shape[1] != 3:
            raise MeshError(f"elements must be (M, 3), got {self.elements.shape}")
        if self.patches.ndim != 2 or self.patches.shape[1] != 3:
            raise MeshError(f"patches must be (P, 3), got {self.patches.shape}")
        if self.element_patch.shape != (m,):
            raise MeshError(f"element_patch must be ({m},), got {self.element_patch.shape}")
        if self.patch_polygon.shape != (p,):
            raise MeshError(f"patch_polygon must be ({p},), got {self.patch_polygon.shape}")
        if m and (self.elements.min() < 0 or self.elements.max() >= n):
            raise MeshError(f"elements index nodes outside [0, {n})")
        if p and (self.patches.min() < 0 or self.patches.max() >= n):
            raise MeshError(f"patches index nodes outside [0, {n})")
        if m and (self.element_patch.min() < 0 or self.element_patch.max() >= p):
            raise MeshError(f"element_patch outside [0, {p})")
        if p and (self.patch_polygon.min() < 0 or self.patch_polygon.max() >= len(scene.polygons)):
            raise MeshError(f"patch_polygon outside [0, {len(scene.polygons)})")
        if np.any(np.bincount(self.element_patch, minlength=p) == 0):
            bad = int(np.flatnonzero(np.bincount(self.element_patch, minlength=p) == 0)[0])
            raise MeshError(f"patch {bad} owns no element")
        self._cache = {}

    # -- sizes ---------------------------------------------------------------
    @property
    def n_nodes(self):
        return len(self.nodes)

    @property
    def n_elements(self):
        return len(self.elements)

    @property
    def n_patches(self):
        return len(self.patches)

    def _cached(self, key, fn):
        if key not in self._cache:
            self._cache[key] = fn()
        return self._cache[key]

    def _polygon_array(self, attr):
        return np.array([getattr(p, attr) for p in self.scene.polygons], dtype=np.float64)

    # -- element geometry ------------------------------------------------------
    def _element_cross(self):
        t = self.nodes[self.elements]
        return np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])

    @property
    def element_area(self):
        """(M,) float64 element areas."""
        return self._cached("ea", lambda: 0.5 * np.linalg.norm(self._element_cross(), axis=1))

    @property
    def element_centroid(self):
        """(M, 3) float64 element centroids."""
        return self._cached("ec", lambda: self.nodes[self.elements].mean(axis=1))

    @property
    def element_polygon(self):
        """(M,) int64 scene polygon of each element."""
        return self._cached("epoly", lambda: self.patch_polygon[self.element_patch])

    layouts = None
    patch_region = None

    @property
    def element_region(self):
        """(M,) int64 region (within its polygon) of each element; None without layouts."""
        if self.patch_region is None:
            return None
        return self._cached("ereg", lambda: self.patch_region[self.element_patch])

    @property
    def element_side(self):
        """(M,) int8: +1 front, -1 back face of a two-sided polygon."""
        return self._cached("eside", lambda: self.patch_side[self.element_patch])

    @property
    def element_normal(self):
        """(M, 3) float64 unit normals: the normal of the element's polygon (negated on a back face)."""
        return self._cached("en", lambda: np.ascontiguousarray(
            self._polygon_array("normal")[self.element_polygon] * self.element_side[:, None]))

    @property
    def element_reflectance(self):
        """(M, 3) float64 RGB reflectance rho of each element."""
        return self._cached("erho", lambda: np.ascontiguousarray(
            self._polygon_array("reflectance")[self.element_polygon]))

    @property
    def element_emission(self):
        """(M, 3) float64 RGB self-emitted radiosity E of each element."""
        return self._cached("eem", lambda: np.ascontiguousarray(
            self._polygon_array("emission")[self.element_polygon]))

    # -- patch geometry --------------------------------------------------------
    @property
    def patch_area(self):
        """(P,) float64 patch areas (sum of their elements)."""
        return self._cached("pa", lambda: np.bincount(self.element_patch, weights=self.element_area,
                                                      minlength=self.n_patches))

    @property
    def patch_centroid(self):
        """(P, 3) float64 area centroids of the patches."""
        def f():
            w = self.element_area[:, None] * self.element_centroid
            c = np.stack([np.bincount(self.element_patch, weights=w[:, k], minlength=self.n_patches)
                          for k in range(3)], axis=1)
            return c / self.patch_area[:, None]
        return self._cached("pc", f)

    @property
    def patch_normal(self):
        """(P, 3) float64 unit normals of the patches (negated on a back face)."""
        return self._cached("pn", lambda: np.ascontiguousarray(
            self._polygon_array("normal")[self.patch_polygon] * self.patch_side[:, None]))

    @property
    def patch_frame(self):
        """(P, 3, 3) float64 right-handed frames ``(u, v, normal)`` of the patches' faces.

        The polygon's frame on the front; ``(u, -v, -normal)`` on the back
        face of a two-sided polygon (a hemicube on a patch must use this,
        not the polygon's own frame).
        """
        def f():
            u = self._polygon_array("u")[self.patch_polygon]
            v = self._polygon_array("v")[self.patch_polygon] * self.patch_side[:, None]
            return np.ascontiguousarray(np.stack([u, v, self.patch_normal], axis=1))
        return self._cached("pframe", f)

    @property
    def patch_elements(self):
        """(offsets (P+1,) int64, elements (M,) int64): CSR list of each patch's elements."""
        def f():
            order = np.argsort(self.element_patch, kind="stable")
            counts = np.bincount(self.element_patch, minlength=self.n_patches)
            return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64), order.astype(np.int64)
        return self._cached("pe", f)

    @property
    def node_elements(self):
        """(offsets (N+1,) int64, elements (3M,) int64): CSR list of elements around each node."""
        def f():
            flat = self.elements.ravel()
            order = np.argsort(flat, kind="stable")
            counts = np.bincount(flat, minlength=self.n_nodes)
            return (np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
                    (order // 3).astype(np.int64))
        return self._cached("ne", f)

    # -- per-polygon views -----------------------------------------------------
    def polygon_elements(self, polygon, side=None):
        """The elements of one polygon as a planar mesh in the polygon's (u, v) frame.

        Parameters
        ----------
        polygon : int
        side : {None, 1, -1}
            Only the front (1) or back (-1) face's elements; None: all.

        Returns
        -------
        xy : (n, 2) float64
            Plane coordinates of the polygon's nodes.
        triangles : (m, 3) int64
            Its elements in local node numbers: counter-clockwise on the
            front face, clockwise on a back face (seen from the front).
        elements : (m,) int64
            Their indices in the mesh.
        nodes : (n,) int64
            The mesh indices of the local nodes.
        """
        poly = self.scene.polygons[polygon]
        sel = self.element_polygon == polygon
        if side is not None:
            sel &= self.element_side == side
        el = np.flatnonzero(sel)
        nodes = np.unique(self.elements[el])
        return poly.to_2d(self.nodes[nodes]), np.searchsorted(nodes, self.elements[el]), el, nodes

    def element_quality(self):
        """Smallest angle (degrees) and radius ratio ``2 r_in / R_circ`` of every element.

        Each element is measured in its polygon's (u, v) frame as seen from
        its own face: a back face's elements (clockwise in that frame, their
        normal being the negated polygon normal) are reversed first, so that
        both faces of a two-sided polygon score alike and only a truly
        inverted or degenerate element scores 0.

        Returns
        -------
        min_angle : (M,) float64
        q : (M,) float64
        """
        from polygen.mesh2d import triangle_quality

        ang = np.empty(self.n_elements)
        q = np.empty(self.n_elements)
        for k in range(len(self.scene.polygons)):
            for side in (1, -1):
                xy, tris, el, _ = self.polygon_elements(k, side)
                if len(el):
                    ang[el], q[el] = triangle_quality(xy, tris if side == 1 else tris[:, ::-1])
        return ang, q

    def t_vertices(self):
        """Nodes that lie inside an edge of their polygon's element mesh (Def. 2.5).

        Each face of each polygon is checked on its own, and within it each
        part bounded by D0 lines (the elements joined through shared nodes):
        across a D0 line each side has its own nodes and values, so one
        side's nodes on the line are no T-vertices of the other.  (Near the
        interior end of a dangling D0 line the two sides share the end node
        and are checked together.)

        Returns
        -------
        (K,) int64
            Mesh node indices; empty for a conforming mesh.
        """
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        from polygen.mesh2d import find_t_vertices

        out = []
        for k in range(len(self.scene.polygons)):
            for side in (1, -1):
                xy, tris, _, nodes = self.polygon_elements(k, side)
                if not len(tris):
                    continue
                # elements joined through shared nodes (the two sides of a D0 line share none)
                m_, n_ = len(tris), len(nodes)
                g = coo_matrix((np.ones(3 * m_), (np.repeat(np.arange(m_), 3), m_ + tris.ravel())),
                               shape=(m_ + n_, m_ + n_))
                n_comp, comp = connected_components(g, directed=False)
                comp = comp[:m_]
                n_comp = len(np.unique(comp))
                for c in np.unique(comp):
                    hit = find_t_vertices(xy, tris if n_comp == 1 else tris[comp == c])[0]
                    out.append(nodes[hit])
        return np.unique(np.concatenate(out)).astype(np.int64) if out else np.zeros(0, np.int64)

    def __repr__(self):
        return (f"RadiosityMesh(scene={self.scene.name!r}, n_nodes={self.n_nodes}, "
                f"n_elements={self.n_elements}, n_patches={self.n_patches})")


# ----------------------------------------------------------------------------
# patch meshers: a polygon (with its segments) -> patches
# ----------------------------------------------------------------------------
def _graph_mesher(method, exterior, holes, size, segments, kinds, seed, kwargs, what):
    from polygen.mesh2d import InvalidDomainError, mesh_planar_graph, planar_graph

    if np.isscalar(size) and not size > 0:
        raise MeshError(f"size must be > 0, got {size}")
    try:
        g = planar_graph(exterior, holes, segments, kinds)
        gm = mesh_planar_graph(g, size, method=method, seed=seed, **kwargs)
    except InvalidDomainError as exc:
        raise MeshError(f"{what}: {exc}") from None
    return gm.nodes, gm.triangles


def lattice_delaunay_mesher(exterior, holes, size, *, segments=None, kinds=None):
    """Triangulate a 2D polygon with holes into patches of about ``size``.

    The simplest mesher that handles concave polygons with holes
    (requirement 2.1): boundary edges (and constrained segments) are split
    into pieces no longer than ``size``, interior nodes are put on a
    triangular lattice of spacing ``size`` (kept at least ``size/2`` from
    every edge), and the nodes are joined by a constrained Delaunay
    triangulation (pythoncdt); see :func:`polygen.mesh2d.mesh_planar_graph`.
    Holes may touch the outer ring or each other at a vertex.

    Parameters
    ----------
    exterior : (n, 2) float64
        Outer ring, not closed.
    holes : list of (k, 2) float64
        Hole rings.
    size : float or callable
        Target edge length (a size field: a thinned lattice).
    segments : (S, 2, 2) float64, keyword-only, optional
        Constrained segments (patch edges follow them).
    kinds : keyword-only
        Their kinds (only the radiosity layer uses them).

    Returns
    -------
    points : (N, 2) float64
    triangles : (T, 3) int64
        Counter-clockwise.
    """
    return _graph_mesher("lattice", exterior, holes, size, segments, kinds, 0, {},
                         "lattice Delaunay mesh")


def bubble_mesher(exterior, holes, size, *, seed=0, segments=None, kinds=None, **kwargs):
    """Triangulate a 2D polygon with holes into patches by the bubble mesh (2.3.3).

    Bubbles of diameter ``size`` on the polygon's vertices, then on its
    edges (and constrained segments), then inside, relaxed by the damped
    dynamics (2.13) with the cubic inter-bubble force (2.12), and joined by
    constrained Delaunay; see :func:`polygen.mesh2d.mesh_planar_graph`.
    Edge bubbles sit at the quantiles of ``integral ds / size`` (the 1-D
    equilibrium), fixed, so that neighbouring polygons can share them.
    Same signature as :func:`lattice_delaunay_mesher`, so it plugs into
    :func:`mesh_scene` (use ``functools.partial`` to change ``seed`` or the
    relaxation).

    Parameters
    ----------
    exterior : (n, 2) float64
        Outer ring, not closed.
    holes : list of (k, 2) float64
        Hole rings.
    size : float or callable
        Target patch edge length, or a size field ``size(xy) -> (K,)``.
    seed : int, keyword-only
        Seed of the initial bubble placement.
    segments, kinds : keyword-only, optional
        Constrained segments, as for :func:`lattice_delaunay_mesher`.
    **kwargs
        Passed on to the relaxation (see :func:`polygen.mesh2d.bubble_mesh`).

    Returns
    -------
    points : (N, 2) float64
        The polygon's vertices, then edge, then face bubbles.
    triangles : (T, 3) int64
        Counter-clockwise.
    """
    return _graph_mesher("bubble", exterior, holes, size, segments, kinds, seed, kwargs,
                         "bubble mesh")


def _graph_method(mesher):
    """("lattice" | "bubble", keyword arguments) for our meshers (or partials), else None."""
    import functools

    kw = {}
    f = mesher
    while isinstance(f, functools.partial):
        if f.args:
            return None
        kw = {**f.keywords, **kw}
        f = f.func
    if f is lattice_delaunay_mesher:
        return "lattice", {}
    if f is bubble_mesher:
        return "bubble", kw
    return None


def _is_bubble_element_mesher(em):
    import functools

    while isinstance(em, functools.partial):
        em = em.func
    return em is bubble_element_mesher


def bubble_element_mesher(points, patches, element_size, *, seed=0, edge_nodes=None, **kwargs):
    """Split the patches of one polygon into elements by a finer bubble mesh.

    Every patch node is a fixed bubble, every patch edge carries edge
    bubbles shared by the two patches on it, and face bubbles fill each
    patch; the constrained Delaunay of all bubbles keeps every patch edge,
    so each element lies in one patch and neighbouring patches share their
    element nodes (no T-vertex, Def. 2.5).  See
    :func:`polygen.mesh2d.bubble_subdivide_patches`.

    Parameters
    ----------
    points : (N, 2) float64
        Patch nodes.
    patches : (P, 3) int64
        Counter-clockwise patch triangles of one polygon.
    element_size : float or callable
        Target element edge length (or a size field).
    seed : int, keyword-only
    edge_nodes : dict {(i, j): (k, 2) float64}, optional
        Preset element nodes inside patch edges (``mesh_scene`` passes the
        nodes shared with a neighbouring polygon along a common 3-D edge).
    **kwargs
        Passed on to the relaxation.

    Returns
    -------
    points : (N', 2) float64
        The patch nodes first (same indices), then the new nodes.
    elements : (M, 3) int64
        Counter-clockwise.
    element_patch : (M,) int64
        The patch of each element.
    """
    from polygen.mesh2d import bubble_subdivide_patches

    if np.isscalar(element_size) and not element_size > 0:
        raise MeshError(f"element_size must be > 0, got {element_size}")
    pe = bubble_subdivide_patches(points, patches, element_size, seed=seed, edge_nodes=edge_nodes,
                                  **kwargs)
    return pe.nodes, pe.elements, pe.element_patch


def split_triangles(points, triangles, levels):
    """Regular 1 -> 4 splitting of a conforming triangulation, ``levels`` times.

    Edge midpoints are shared by the two triangles of an edge, so the result
    has no T-vertices (Def. 2.5).

    Parameters
    ----------
    points : (N, d) float64
    triangles : (T, 3) int64
    levels : int >= 0

    Returns
    -------
    points : (N', d) float64
        The input points first, then the new midpoints.
    triangles : (T * 4**levels, 3) int64
        Children of triangle ``t`` are rows ``t * 4**levels ... (t+1) * 4**levels - 1``.
    """
    pts = np.asarray(points, dtype=np.float64)
    tris = np.asarray(triangles, dtype=np.int64)
    if levels < 0:
        raise MeshError(f"levels must be >= 0, got {levels}")
    for _ in range(int(levels)):
        e = np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1)  # (T, 3, 2)
        key = np.sort(e.reshape(-1, 2), axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        mid = (len(pts) + inv.reshape(-1, 3))
        pts = np.vstack([pts, 0.5 * (pts[uniq[:, 0]] + pts[uniq[:, 1]])])
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        mab, mbc, mca = mid[:, 0], mid[:, 1], mid[:, 2]
        tris = np.stack([np.stack([a, mab, mca], 1), np.stack([mab, b, mbc], 1),
                         np.stack([mca, mbc, c], 1), np.stack([mab, mbc, mca], 1)],
                        axis=1).reshape(-1, 3)
    return pts, tris


def assemble_mesh(scene, pieces):
    """Build a :class:`RadiosityMesh` from per-polygon 2D meshes.

    This is the interface for external meshers (the bubble mesh of
    ``polygen.mesh2d``, the discontinuity meshes of chapter 3): mesh each
    polygon in its own (u, v) plane frame (``Polygon.exterior_2d`` /
    ``Polygon.holes_2d``), then hand the pieces here.  A two-sided polygon
    gets its back face here: the same patches and elements, reversed, on
    copies of the nodes -- or, when its piece is a pair ``(front, back)``
    of pieces (both in the (u, v) frame, e.g. refined differently), each
    face its own.

    Parameters
    ----------
    scene : Scene
    pieces : sequence, one per polygon, of (points, patches, elements, element_patch[, node_site])
        points : (N, 2) float64 in the polygon's plane frame;
        patches : (P, 3) int64 node indices of the patch triangles;
        elements : (M, 3) int64 node indices of the element triangles;
        element_patch : (M,) int64 local patch index of each element;
        node_site : (N,) int64, optional: local node each node copies
        (separate nodes on the two sides of a D0 line).
        Triangles are re-oriented counter-clockwise (front side) here.

    Returns
    -------
    RadiosityMesh
    """
    if len(pieces) != len(scene.polygons):
        raise MeshError(f"need one piece per polygon ({len(scene.polygons)}), got {len(pieces)}")
    nodes, elements, element_patch, patches, patch_polygon, sides, sites = [], [], [], [], [], [], []
    n_off = 0
    p_off = 0
    for k, (poly, piece) in enumerate(zip(scene.polygons, pieces)):
        pair = len(piece) == 2 and all(isinstance(q, (tuple, list)) for q in piece)
        if pair and not poly.two_sided:
            raise MeshError(f"polygon {k} ({poly.name}): a (front, back) pair of pieces needs a "
                            "two-sided polygon")
        for face, pc in enumerate(piece if pair else (piece,)):
            side = -1 if face else 1
            mirror = poly.two_sided and not pair
            n_off, p_off = _add_piece(k, poly, pc, side, mirror, n_off, p_off, nodes, elements,
                                      element_patch, patches, patch_polygon, sides, sites)
    return RadiosityMesh(scene, np.vstack(nodes), np.vstack(elements), np.concatenate(element_patch),
                         np.vstack(patches), np.concatenate(patch_polygon),
                         patch_side=np.concatenate(sides), node_site=np.concatenate(sites))


def _add_piece(k, poly, piece, side, mirror, n_off, p_off, nodes, elements, element_patch,
               patches, patch_polygon, sides, sites):
    """Append one face of one polygon (two when ``mirror``) to the assembly lists."""
    if len(piece) not in (4, 5):
        raise MeshError(f"polygon {k} ({poly.name}): a piece is (points, patches, elements, "
                        f"element_patch[, node_site]), got {len(piece)} items")
    pts2, ptris, etris, epatch = piece[:4]
    pts2 = np.asarray(pts2, dtype=np.float64)
    if pts2.ndim != 2 or pts2.shape[1] != 2:
        raise MeshError(f"polygon {k} ({poly.name}): points must be (N, 2), got {pts2.shape}")
    site = (np.arange(len(pts2)) if len(piece) == 4 or piece[4] is None
            else np.asarray(piece[4], dtype=np.int64))
    if site.shape != (len(pts2),):
        raise MeshError(f"polygon {k} ({poly.name}): node_site must be ({len(pts2)},)")
    ptris = _ccw(pts2, np.asarray(ptris, dtype=np.int64).reshape(-1, 3))
    etris = _ccw(pts2, np.asarray(etris, dtype=np.int64).reshape(-1, 3))
    epatch = np.asarray(epatch, dtype=np.int64)
    if len(ptris) == 0 or len(etris) == 0:
        raise MeshError(f"polygon {k} ({poly.name}): no patches or no elements")
    if side == 1:
        faces = [(1, ptris, etris)] + ([(-1, ptris[:, ::-1], etris[:, ::-1])] if mirror else [])
    else:
        faces = [(-1, ptris[:, ::-1], etris[:, ::-1])]
    for side, pt, et in faces:
        nodes.append(poly.to_3d(pts2))
        elements.append(et + n_off)
        patches.append(pt + n_off)
        element_patch.append(epatch + p_off)
        patch_polygon.append(np.full(len(pt), k, dtype=np.int64))
        sides.append(np.full(len(pt), side, dtype=np.int8))
        sites.append(site + n_off)
        n_off += len(pts2)
        p_off += len(pt)
    return n_off, p_off


def _ccw(pts2, tris):
    if len(tris) == 0:
        return tris
    a, b, c = (pts2[tris[:, j]] for j in range(3))
    signed = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    return np.where((signed < 0)[:, None], tris[:, [0, 2, 1]], tris)


def _per_polygon(value, n, what):
    """One entry per polygon: a sequence of length n, or one value for all."""

    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1):
        if len(value) != n:
            raise MeshError(f"{what}: need one entry per polygon ({n}), got {len(value)}")
        return list(value)
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = float(value)
    if np.isscalar(value) or callable(value) or isinstance(value, RegionSize):
        return [value] * n
    raise MeshError(f"{what}: expected a number, a size field, a RegionSize or one per polygon, "
                    f"got {type(value).__name__}")


def _check_size(spec, k, poly):

    if isinstance(spec, RegionSize) or callable(spec):
        return spec
    try:
        v = float(spec)
    except (TypeError, ValueError):
        raise MeshError(f"patch_size for polygon {k} ({poly.name}): expected a number, a size "
                        f"field or a RegionSize, got {type(spec).__name__}") from None
    if not (np.isfinite(v) and v > 0):
        raise MeshError(f"patch_size must be > 0, got {spec} (polygon {k}, {poly.name})")
    return v


#: bytes per element a RadiosityMesh holds at least: its three node ids and its patch (int64), and half a
#: node (a triangle mesh has about M / 2 nodes: xyz float64 and node_site int64)
_ELEMENT_BYTES = 48


def _check_memory(scene, specs, patch_size, levels):
    """Refuse (MeshError) a mesh whose elements cannot fit in memory, before meshing anything.

    The estimate: a polygon of area A meshed at patch size h has about A / (sqrt(3)/4 h**2) patches
    (triangles of edge h), each split into 4**levels elements of :data:`_ELEMENT_BYTES`; a size field
    or a RegionSize counts one patch per polygon (a lower bound).
    """
    patches = 0.0
    for poly, spec in zip(scene.polygons, specs):
        h = spec if isinstance(spec, float) else None
        patches += max(1.0, poly.area / (np.sqrt(3.0) / 4.0 * h * h)) if h else 1.0
    what = f"patch_size={patch_size!r}, element_levels={levels}" if not callable(patch_size) else \
        f"element_levels={levels}"
    check_fits(patches * 4.0**levels * _ELEMENT_BYTES, f"mesh_scene({what}): about {patches * 4.0**levels:.3g} "
               "elements", MeshError)


def _segments_per_polygon(segments, scene):

    n = len(scene.polygons)
    out = [None] * n
    if segments is None:
        return out
    if isinstance(segments, dict):
        names = {p.name: k for k, p in enumerate(scene.polygons)}
        for key, spec in segments.items():
            k = names.get(key, key) if isinstance(key, str) else key
            if not isinstance(k, (int, np.integer)) or not 0 <= k < n:
                raise MeshError(f"segments: no polygon {key!r} in the scene")
            out[int(k)] = _as_segments(spec)
        return out
    segments = list(segments)
    if len(segments) != n:
        raise MeshError(f"segments: need a mapping or one entry per polygon ({n}), got {len(segments)}")
    return [_as_segments(s) for s in segments]


def _scaled(spec, factor):
    if np.isscalar(spec):
        return float(spec) * factor
    from polygen.mesh2d import as_size_function

    f = as_size_function(spec)

    def g(xy):
        return f(xy) * factor

    g.constant = None if f.constant is None else f.constant * factor
    return g


def mesh_scene(scene, patch_size, *, element_levels=1, mesher=lattice_delaunay_mesher,
               element_mesher=None, segments=None, conforming=True):
    """Mesh every polygon of a scene into patches and elements.

    With the two meshers of this module (or ``functools.partial`` of them)
    every polygon is meshed as a planar graph (:mod:`polygen.mesh2d.pslg`):
    nodes on its vertices, then along its edges and constrained segments
    with the smaller size of the two sides, then inside its regions (3.3.6).
    Segments become patch edges, so no element crosses them; nodes on a
    **D0** segment are duplicated, one copy per side (no interpolation
    across), nodes on a **D1** segment shared.  With ``conforming``, edges
    of different polygons that overlap in 3-D (a wall on the floor) get the
    same vertices and the same nodes, spaced by the smaller of the two
    polygons' sizes; nodes stay separate per polygon.

    Parameters
    ----------
    scene : Scene
    patch_size : number, callable, GridSize, RegionSize, or a sequence of them
        Target patch edge length, one for all polygons or one per polygon: a
        number, a size field ``size(xy) -> (K,)`` or
        :class:`polygen.mesh2d.GridSize` in the polygon's (u, v) frame, or
        a :class:`~polygen.radiosity.layout.RegionSize` (one size or field
        per region of the polygon's segments).
    element_levels : int, keyword-only
        Element size is ``patch_size / 2**element_levels``: without an
        ``element_mesher`` each patch is split 1 -> 4 this many times
        (``4**element_levels`` elements per patch); with one, that is the
        element size it is asked for (about ``4**element_levels`` elements
        per patch on average).
    mesher : callable, keyword-only
        :func:`lattice_delaunay_mesher` (default) or :func:`bubble_mesher`;
        or any ``mesher(exterior (n, 2), holes [(k, 2)], size) -> (points
        (N, 2), triangles (T, 3))`` in the polygon's (u, v) frame (no
        segments, no conforming edges then).
    element_mesher : callable or None, keyword-only
        ``element_mesher(points (N, 2), patches (P, 3), element_size) ->
        (points (N', 2), elements (M, 3), element_patch (M,))`` with the
        patch nodes first, e.g. :func:`bubble_element_mesher` (which is
        handed the element nodes shared with neighbouring polygons).  None:
        regular 1 -> 4 splitting (:func:`split_triangles`).
    segments : mapping or sequence, keyword-only, optional
        Constrained segments per polygon: ``{polygon index or name:
        Segments}`` or one entry (or None) per polygon; an entry may also be
        ``(ends, kinds)``.  See :class:`~polygen.radiosity.layout.Segments`.
    conforming : bool, keyword-only
        Share vertices and boundary nodes along edges common to two polygons
        (element nodes too with 1 -> 4 splitting or :func:`bubble_element_mesher`;
        another element mesher is not told of them).  An edge lying inside
        another polygon (a block on an uncut floor) is not an edge of that
        polygon: hand it as a segment (:func:`~polygen.radiosity.contact_segments`).

    Returns
    -------
    RadiosityMesh

    Raises
    ------
    SceneError
        ``scene`` is not a Scene.
    MeshError
        Bad sizes or levels; a segment that is degenerate, outside its
        polygon, off its plane or crossing another one without a common
        vertex (the message names the polygon and the segment).
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a Scene, got {type(scene).__name__}")
    n = len(scene.polygons)
    specs = [_check_size(s, k, p) for k, (s, p) in
             enumerate(zip(_per_polygon(patch_size, n, "patch_size"), scene.polygons))]
    if int(element_levels) != element_levels or element_levels < 0:
        raise MeshError(f"element_levels must be a non-negative integer, got {element_levels}")
    levels = int(element_levels)
    per = 4 ** levels
    _check_memory(scene, specs, patch_size, levels)
    segs = _segments_per_polygon(segments, scene)
    method = _graph_method(mesher)
    if method is None:
        if any(s is not None for s in segs) or any(isinstance(s, lay.RegionSize) for s in specs):
            raise MeshError("segments and RegionSize need lattice_delaunay_mesher or bubble_mesher")
        return _mesh_scene_custom(scene, specs, levels, per, mesher, element_mesher)
    kind, mkw = method
    seed = mkw.pop("seed", 0)

    from polygen.mesh2d import InvalidDomainError, as_size_function, mesh_planar_graph

    # segments in each polygon's frame
    segs2d = []
    for k, (poly, sg) in enumerate(zip(scene.polygons, segs)):
        try:
            segs2d.append(None if sg is None else sg.in_plane(poly))
        except lay._Error as exc:
            raise MeshError(f"polygon {k} ({poly.name!r}): {exc}") from None
    extra = lay.shared_split_points(scene, segs2d) if conforming else [None] * n
    layouts = []
    for k, poly in enumerate(scene.polygons):
        sg = None if segs2d[k] is None else lay.Segments(*segs2d[k])
        try:
            layouts.append(lay._layout(poly, sg, extra[k], lay.LAYOUT_TOL))
        except (InvalidDomainError, lay._Error) as exc:
            raise MeshError(f"polygon {k} ({poly.name!r}): {exc}") from None
    fns = []
    for k, (poly, g, spec) in enumerate(zip(scene.polygons, layouts, specs)):
        try:
            if not isinstance(spec, lay.RegionSize):
                per_region = [spec] * g.n_regions
            elif extra[k] is None:
                per_region = spec.resolve(poly, g)
            else:
                # regions are numbered as polygon_layout(polygon, segments) numbers
                # them, without the vertices added for the neighbouring polygons
                ref = lay._layout(poly, None if segs2d[k] is None else lay.Segments(*segs2d[k]),
                                  None, lay.LAYOUT_TOL)
                sizes_ref = spec.resolve(poly, ref)
                per_region = [sizes_ref[r] for r in ref.region_of(g.region_point)]
            fns.append([as_size_function(_check_size(r, k, poly)) for r in per_region])
        except (lay._Error, ValueError) as exc:
            if isinstance(exc, MeshError):
                raise
            raise MeshError(f"polygon {k} ({poly.name!r}): {exc}") from None
    rounding = "ceil" if kind == "lattice" else "round"
    if conforming:
        groups = lay.shared_edge_groups(scene, layouts)
        presets, canon = lay.shared_edge_nodes(groups, layouts, fns, rounding=rounding)
    else:
        groups, presets, canon = [], [dict() for _ in layouts], []

    meshes = []
    for k, (poly, g) in enumerate(zip(scene.polygons, layouts)):
        try:
            gm = mesh_planar_graph(g, fns[k], method=kind, edge_nodes=presets[k], seed=seed, **mkw)
        except (InvalidDomainError, ValueError) as exc:
            raise MeshError(f"polygon {k} ({poly.name!r}): {exc}") from None
        if len(gm.triangles) == 0:
            raise MeshError(f"mesher returned no triangles for polygon {k} ({poly.name})")
        meshes.append(gm)
    efns = [[_scaled(f, 0.5 ** levels) for f in fk] for fk in fns]
    eshared = [dict() for _ in layouts]
    if element_mesher is not None and conforming and _is_bubble_element_mesher(element_mesher):
        eshared = lay.shared_element_nodes(groups, canon, layouts, [m.chains for m in meshes],
                                           [[as_size_function(f) for f in fk] for fk in efns])
    pieces = []
    for k, (poly, g, gm) in enumerate(zip(scene.polygons, layouts, meshes)):
        pts2 = gm.nodes
        tris = _ccw(pts2, gm.triangles)
        if element_mesher is None:
            epts, etris = split_triangles(pts2, tris, levels)
            epatch = np.repeat(np.arange(len(tris)), per)
        else:
            esize = g.region_size_function(efns[k])
            esize = esize.constant if getattr(esize, "constant", None) is not None else esize
            kw = {"edge_nodes": eshared[k]} if eshared[k] else {}
            epts, etris, epatch = _run_element_mesher(element_mesher, pts2, tris, esize, k, poly, kw)
        site = None
        cut = lay.d0_cut(g, epts)
        if cut is not None:
            epts, etris, site = lay.duplicate_across(epts, etris, cut)
            tris = _patch_corners(tris, etris, epatch, site)
        pieces.append((epts, tris, etris, epatch, site))
    mesh = assemble_mesh(scene, pieces)
    mesh.layouts = layouts
    # a patch lies in one region (the segments are patch edges): locate its centroid
    reg = np.empty(mesh.n_patches, np.int64)
    for k, (poly, g) in enumerate(zip(scene.polygons, layouts)):
        sel = np.flatnonzero(mesh.patch_polygon == k)
        reg[sel] = g.region_of(poly.to_2d(mesh.nodes[mesh.patches[sel]].mean(axis=1)))
    mesh.patch_region = reg
    return mesh


def _patch_corners(patches, elements, element_patch, site):
    """Patch corners renamed to the node copy their own elements use (after D0 duplication)."""
    ns = int(site.max()) + 1
    key = (np.repeat(element_patch, 3) * ns + site[elements.ravel()]).astype(np.int64)
    uk, first = np.unique(key, return_index=True)
    want = (np.arange(len(patches))[:, None] * ns + patches).ravel()
    pos = np.minimum(np.searchsorted(uk, want), len(uk) - 1)
    hit = uk[pos] == want
    out = patches.ravel().copy()
    out[hit] = elements.ravel()[first[pos[hit]]]
    return out.reshape(patches.shape)


def _run_element_mesher(element_mesher, pts2, tris, esize, k, poly, kw):
    epts, etris, epatch = element_mesher(pts2, tris, esize, **kw)
    epts = np.asarray(epts, dtype=np.float64)
    if len(epts) < len(pts2) or not np.array_equal(epts[:len(pts2)], pts2):
        raise MeshError(f"element mesher must keep the patch nodes first "
                        f"(polygon {k}, {poly.name})")
    epatch = np.asarray(epatch, dtype=np.int64)
    if len(epatch) != len(etris) or (len(epatch) and (epatch.min() < 0
                                                     or epatch.max() >= len(tris))):
        raise MeshError(f"element mesher returned a bad element -> patch map "
                        f"(polygon {k}, {poly.name})")
    return epts, etris, epatch


def _mesh_scene_custom(scene, specs, levels, per, mesher, element_mesher):
    pieces = []
    for k, poly in enumerate(scene.polygons):
        size = specs[k]
        pts2, tris = mesher(poly.exterior_2d, poly.holes_2d, size)
        pts2 = np.asarray(pts2, dtype=np.float64)
        tris = _ccw(pts2, np.asarray(tris, dtype=np.int64).reshape(-1, 3))
        if len(tris) == 0:
            raise MeshError(f"mesher returned no triangles for polygon {k} ({poly.name})")
        if element_mesher is None:
            epts, etris = split_triangles(pts2, tris, levels)
            epatch = np.repeat(np.arange(len(tris)), per)
        else:
            epts, etris, epatch = _run_element_mesher(element_mesher, pts2, tris,
                                                      _scaled(size, 0.5 ** levels), k, poly, {})
        pieces.append((epts, tris, etris, epatch))
    return assemble_mesh(scene, pieces)
