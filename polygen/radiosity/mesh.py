"""Patches, elements and nodes (thesis Defs 2.2-2.4) and the meshers that make them.

A :class:`RadiosityMesh` is what the solvers take: any triangulation of the
scene's polygons into *patches* (which shoot light), each patch subdivided
into *elements* (which gather light), with *nodes* shared between the
elements of one polygon (no T-vertices, Def. 2.5).  Nodes are not shared
between different polygons, so node intensities (2.8) never mix walls.

How patches are made is pluggable: :func:`mesh_scene` calls a *mesher*
``mesher(exterior, holes, size) -> (points, triangles)`` on each polygon in
its plane.  The default, :func:`lattice_delaunay_mesher`, is the simplest
thing that meets requirement 2.1 (concave polygons with holes): boundary
edges split to the target size, a triangular lattice of interior nodes, and
a constrained Delaunay triangulation (pythoncdt).  :func:`bubble_mesher`
plugs the bubble mesh of ``polygen.mesh2d`` (2.3.3) in at the same place.

Elements come from patches either by regular 1 -> 4 splitting (the default,
the "simple method" the thesis itself allows for this step, 3.3.6 step 6),
or by an *element mesher* ``element_mesher(points, patches, element_size)``
such as :func:`bubble_element_mesher`, a finer bubble mesh constrained by
the patch edges.  Either way the elements of one polygon share their nodes
across patch edges, so there are no T-vertices (Def. 2.5).
"""

from __future__ import annotations

import numpy as np

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


class MeshError(ValueError):
    """Inconsistent patch/element/node arrays."""


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

    Notes
    -----
    Derived arrays (areas, centroids, normals, per-element materials, the
    node -> element adjacency) are computed once, lazily.  Patch area and
    centroid are sums over the patch's elements, so they are consistent
    with the elements even if a mesher's patch triangles were not.
    """

    def __init__(self, scene, nodes, elements, element_patch, patches, patch_polygon):
        if not isinstance(scene, Scene):
            raise MeshError(f"scene must be a Scene, got {type(scene).__name__}")
        self.scene = scene
        self.nodes = np.ascontiguousarray(nodes, dtype=np.float64)
        self.elements = np.ascontiguousarray(elements, dtype=np.int64)
        self.element_patch = np.ascontiguousarray(element_patch, dtype=np.int64)
        self.patches = np.ascontiguousarray(patches, dtype=np.int64)
        self.patch_polygon = np.ascontiguousarray(patch_polygon, dtype=np.int64)
        n, m, p = len(self.nodes), len(self.elements), len(self.patches)
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

    @property
    def element_normal(self):
        """(M, 3) float64 unit normals: the normal of the element's polygon."""
        return self._cached("en", lambda: np.ascontiguousarray(
            self._polygon_array("normal")[self.element_polygon]))

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
        """(P, 3) float64 unit normals of the patches."""
        return self._cached("pn", lambda: np.ascontiguousarray(
            self._polygon_array("normal")[self.patch_polygon]))

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
    def polygon_elements(self, polygon):
        """The elements of one polygon as a planar mesh in the polygon's (u, v) frame.

        Parameters
        ----------
        polygon : int

        Returns
        -------
        xy : (n, 2) float64
            Plane coordinates of the polygon's nodes.
        triangles : (m, 3) int64
            Its elements in local node numbers, counter-clockwise.
        elements : (m,) int64
            Their indices in the mesh.
        nodes : (n,) int64
            The mesh indices of the local nodes.
        """
        poly = self.scene.polygons[polygon]
        el = np.flatnonzero(self.element_polygon == polygon)
        nodes = np.unique(self.elements[el])
        return poly.to_2d(self.nodes[nodes]), np.searchsorted(nodes, self.elements[el]), el, nodes

    def element_quality(self):
        """Smallest angle (degrees) and radius ratio ``2 r_in / R_circ`` of every element.

        Returns
        -------
        min_angle : (M,) float64
        q : (M,) float64
        """
        from polygen.mesh2d import triangle_quality

        ang = np.empty(self.n_elements)
        q = np.empty(self.n_elements)
        for k in range(len(self.scene.polygons)):
            xy, tris, el, _ = self.polygon_elements(k)
            ang[el], q[el] = triangle_quality(xy, tris)
        return ang, q

    def t_vertices(self):
        """Nodes that lie inside an edge of their polygon's element mesh (Def. 2.5).

        Returns
        -------
        (K,) int64
            Mesh node indices; empty for a conforming mesh.
        """
        from polygen.mesh2d import find_t_vertices

        out = [nodes[find_t_vertices(xy, tris)[0]]
               for xy, tris, _, nodes in map(self.polygon_elements, range(len(self.scene.polygons)))]
        return np.concatenate(out).astype(np.int64) if out else np.zeros(0, dtype=np.int64)

    def __repr__(self):
        return (f"RadiosityMesh(scene={self.scene.name!r}, n_nodes={self.n_nodes}, "
                f"n_elements={self.n_elements}, n_patches={self.n_patches})")


# ----------------------------------------------------------------------------
# the placeholder mesher
# ----------------------------------------------------------------------------
def _split_ring(ring, size):
    """Points along a closed 2D ring (k, 2), every edge split into ceil(len/size) pieces."""
    nxt = np.roll(ring, -1, axis=0)
    lengths = np.linalg.norm(nxt - ring, axis=1)
    counts = np.maximum(1, np.ceil(lengths / size - 1e-9).astype(np.int64))
    edge = np.repeat(np.arange(len(ring)), counts)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    t = (np.arange(counts.sum()) - np.repeat(start, counts)) / np.repeat(counts, counts)
    return ring[edge] + t[:, None] * (nxt[edge] - ring[edge])


def lattice_delaunay_mesher(exterior, holes, size):
    """Triangulate a 2D polygon with holes into patches of about ``size``.

    The simplest mesher that handles concave polygons with holes
    (requirement 2.1): boundary edges are split into pieces no longer than
    ``size``, interior nodes are put on a triangular lattice of spacing
    ``size`` (kept at least ``size/2`` from the boundary), and the nodes are
    joined by a constrained Delaunay triangulation (pythoncdt).  A stand-in
    for the bubble mesh of ``polygen.mesh2d``, which has the same signature.

    Parameters
    ----------
    exterior : (n, 2) float64
        Outer ring, not closed.
    holes : list of (k, 2) float64
        Hole rings.
    size : float
        Target edge length.

    Returns
    -------
    points : (N, 2) float64
    triangles : (T, 3) int64
        Counter-clockwise.
    """
    import pythoncdt
    import shapely

    if not size > 0:
        raise MeshError(f"size must be > 0, got {size}")
    rings = [np.asarray(exterior, dtype=np.float64)] + [np.asarray(h, dtype=np.float64)
                                                        for h in holes]
    boundary = [_split_ring(r, size) for r in rings]
    edges = []
    offset = 0
    for b in boundary:
        k = len(b)
        idx = np.arange(k) + offset
        edges.append(np.stack([idx, np.roll(idx, -1)], axis=1))
        offset += k
    bpts = np.vstack(boundary)
    poly = shapely.Polygon(rings[0], rings[1:])
    lo, hi = rings[0].min(axis=0), rings[0].max(axis=0)
    dy = size * np.sqrt(3.0) / 2.0
    ny = int(np.floor((hi[1] - lo[1]) / dy)) + 1
    nx = int(np.floor((hi[0] - lo[0]) / size)) + 2
    jj, ii = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    # centre the lattice in the bounding box so that symmetric shapes stay symmetric
    x0 = lo[0] + 0.5 * ((hi[0] - lo[0]) - (nx - 1) * size)
    y0 = lo[1] + 0.5 * ((hi[1] - lo[1]) - (ny - 1) * dy)
    lx = (x0 + ii * size + 0.5 * size * (jj % 2)).ravel()
    ly = (y0 + jj * dy).ravel()
    inside = shapely.contains_xy(poly, lx, ly)
    lx, ly = lx[inside], ly[inside]
    if len(lx):
        far = shapely.distance(poly.boundary, shapely.points(lx, ly)) > 0.5 * size
        lx, ly = lx[far], ly[far]
    pts = np.vstack([bpts, np.stack([lx, ly], axis=1)])
    tri = pythoncdt.Triangulation(pythoncdt.VertexInsertionOrder.AS_PROVIDED,
                                  pythoncdt.IntersectingConstraintEdges.NOT_ALLOWED, 0.0)
    tri.insert_vertices(np.ascontiguousarray(pts))
    tri.insert_edges(np.ascontiguousarray(np.vstack(edges).astype(np.uint32)))
    tri.erase_outer_triangles_and_holes()
    verts = tri.vertices_array()
    points = np.stack([verts["x"], verts["y"]], axis=1)
    triangles = tri.triangles_array()["vertices"].astype(np.int64)
    a, b, c = (points[triangles[:, k]] for k in range(3))
    signed = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    triangles[signed < 0] = triangles[signed < 0][:, [0, 2, 1]]
    return points, triangles


def bubble_mesher(exterior, holes, size, *, seed=0, **kwargs):
    """Triangulate a 2D polygon with holes into patches by the bubble mesh (2.3.3).

    Bubbles of diameter ``size`` on the polygon's vertices, then on its
    edges, then inside, relaxed by the damped dynamics (2.13) with the cubic
    inter-bubble force (2.12), and joined by constrained Delaunay; see
    :func:`polygen.mesh2d.bubble_mesh`.  Same signature as
    :func:`lattice_delaunay_mesher`, so it plugs into :func:`mesh_scene`
    (use ``functools.partial`` to change ``seed`` or the relaxation).

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
    **kwargs
        Passed on to :func:`polygen.mesh2d.bubble_mesh`.

    Returns
    -------
    points : (N, 2) float64
        Vertex bubbles (the polygon's vertices), then edge, then face bubbles.
    triangles : (T, 3) int64
        Counter-clockwise.
    """
    from polygen.mesh2d import InvalidDomainError, bubble_mesh

    if np.isscalar(size) and not size > 0:
        raise MeshError(f"size must be > 0, got {size}")
    try:
        bm = bubble_mesh(np.asarray(exterior, dtype=np.float64),
                         [np.asarray(h, dtype=np.float64) for h in holes], size, seed=seed,
                         **kwargs)
    except InvalidDomainError as exc:
        raise MeshError(f"bubble mesh: {exc}") from None
    return bm.nodes, bm.triangles


def bubble_element_mesher(points, patches, element_size, *, seed=0, **kwargs):
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
    pe = bubble_subdivide_patches(points, patches, element_size, seed=seed, **kwargs)
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
    ``Polygon.holes_2d``), then hand the pieces here.

    Parameters
    ----------
    scene : Scene
    pieces : sequence, one per polygon, of (points, patches, elements, element_patch)
        points : (N, 2) float64 in the polygon's plane frame;
        patches : (P, 3) int64 node indices of the patch triangles;
        elements : (M, 3) int64 node indices of the element triangles;
        element_patch : (M,) int64 local patch index of each element.
        Triangles are re-oriented counter-clockwise (front side) here.

    Returns
    -------
    RadiosityMesh
    """
    if len(pieces) != len(scene.polygons):
        raise MeshError(f"need one piece per polygon ({len(scene.polygons)}), got {len(pieces)}")
    nodes, elements, element_patch, patches, patch_polygon = [], [], [], [], []
    n_off = 0
    p_off = 0
    for k, (poly, piece) in enumerate(zip(scene.polygons, pieces)):
        pts2, ptris, etris, epatch = piece
        pts2 = np.asarray(pts2, dtype=np.float64)
        if pts2.ndim != 2 or pts2.shape[1] != 2:
            raise MeshError(f"polygon {k} ({poly.name}): points must be (N, 2), got {pts2.shape}")
        ptris = _ccw(pts2, np.asarray(ptris, dtype=np.int64).reshape(-1, 3))
        etris = _ccw(pts2, np.asarray(etris, dtype=np.int64).reshape(-1, 3))
        epatch = np.asarray(epatch, dtype=np.int64)
        if len(ptris) == 0 or len(etris) == 0:
            raise MeshError(f"polygon {k} ({poly.name}): no patches or no elements")
        nodes.append(poly.to_3d(pts2))
        elements.append(etris + n_off)
        patches.append(ptris + n_off)
        element_patch.append(epatch + p_off)
        patch_polygon.append(np.full(len(ptris), k, dtype=np.int64))
        n_off += len(pts2)
        p_off += len(ptris)
    return RadiosityMesh(scene, np.vstack(nodes), np.vstack(elements), np.concatenate(element_patch),
                         np.vstack(patches), np.concatenate(patch_polygon))


def _ccw(pts2, tris):
    if len(tris) == 0:
        return tris
    a, b, c = (pts2[tris[:, j]] for j in range(3))
    signed = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    return np.where((signed < 0)[:, None], tris[:, [0, 2, 1]], tris)


def mesh_scene(scene, patch_size, *, element_levels=1, mesher=lattice_delaunay_mesher,
               element_mesher=None):
    """Mesh every polygon of a scene into patches and elements.

    Parameters
    ----------
    scene : Scene
    patch_size : float or sequence of float
        Target patch edge length, one for all polygons or one per polygon.
    element_levels : int, keyword-only
        Element size is ``patch_size / 2**element_levels``: without an
        ``element_mesher`` each patch is split 1 -> 4 this many times
        (``4**element_levels`` elements per patch); with one, that is the
        element size it is asked for (about ``4**element_levels`` elements
        per patch on average).
    mesher : callable, keyword-only
        ``mesher(exterior (n, 2), holes [(k, 2)], size) -> (points (N, 2),
        triangles (T, 3))`` in the polygon's (u, v) plane frame: the
        patches.  The default is :func:`lattice_delaunay_mesher`; the bubble
        mesh is :func:`bubble_mesher`.
    element_mesher : callable or None, keyword-only
        ``element_mesher(points (N, 2), patches (P, 3), element_size) ->
        (points (N', 2), elements (M, 3), element_patch (M,))`` with the
        patch nodes first, e.g. :func:`bubble_element_mesher`.  None: regular
        1 -> 4 splitting (:func:`split_triangles`).

    Returns
    -------
    RadiosityMesh
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a Scene, got {type(scene).__name__}")
    sizes = np.broadcast_to(np.asarray(patch_size, dtype=np.float64), (len(scene.polygons),))
    if np.any(~(sizes > 0)):
        raise MeshError(f"patch_size must be > 0, got {patch_size}")
    if int(element_levels) != element_levels or element_levels < 0:
        raise MeshError(f"element_levels must be a non-negative integer, got {element_levels}")
    per = 4 ** int(element_levels)
    pieces = []
    for k, poly in enumerate(scene.polygons):
        pts2, tris = mesher(poly.exterior_2d, poly.holes_2d, float(sizes[k]))
        pts2 = np.asarray(pts2, dtype=np.float64)
        tris = _ccw(pts2, np.asarray(tris, dtype=np.int64).reshape(-1, 3))
        if len(tris) == 0:
            raise MeshError(f"mesher returned no triangles for polygon {k} ({poly.name})")
        if element_mesher is None:
            epts, etris = split_triangles(pts2, tris, element_levels)
            epatch = np.repeat(np.arange(len(tris)), per)
        else:
            epts, etris, epatch = element_mesher(pts2, tris, float(sizes[k]) / 2 ** int(element_levels))
            epts = np.asarray(epts, dtype=np.float64)
            if len(epts) < len(pts2) or not np.array_equal(epts[:len(pts2)], pts2):
                raise MeshError(f"element mesher must keep the patch nodes first "
                                f"(polygon {k}, {poly.name})")
            epatch = np.asarray(epatch, dtype=np.int64)
            if len(epatch) != len(etris) or (len(epatch) and (epatch.min() < 0
                                                             or epatch.max() >= len(tris))):
                raise MeshError(f"element mesher returned a bad element -> patch map "
                                f"(polygon {k}, {poly.name})")
        pieces.append((epts, tris, etris, epatch))
    return assemble_mesh(scene, pieces)
