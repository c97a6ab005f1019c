"""The intensity-based bubble mesh (thesis chapter 4, Fig. 4.3).

A two-pass loop: a uniform mesh and a first radiosity solution; at every
node the intensity variation ``D`` (4.1); an element size ``f(D)``, linear
between ``size_min`` at the smallest ``D`` and ``size_max`` at the largest
(4.2-4.4; note the thesis's naming: ``size_max`` is the size at ``D_max``,
i.e. the *smallest* size); per polygon a rectangular size grid, assigned
by inverse-distance weights near the nodes and elsewhere by bending a thin
plate through them (4.5-4.10, :func:`polygen.mesh2d.element_size_grid`);
a second bubble mesh reading the grid by bilinear interpolation (4.12,
4.13); and a second solution.  Conventional adaptive subdivision
(:func:`~polygen.radiosity.adaptive_refine`) from the same first solution
is the comparison (Table 4.1).  With ``segments`` (discontinuity lines,
chapter 3) both meshes keep the lines and the size grids are built per
region: the thesis's future work (4.5),
:func:`polygen.discontinuity.combined.combined_bubble_mesh`.

Sizes here are *patch* sizes, the bubble diameter of the patch mesh; each
patch is split into ``4**element_levels`` elements, as the thesis makes
elements by dividing patches (4.3.3, Fig. 4.6).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from polygen.mesh2d import triangle_edges
from polygen.mesh2d.plate import PlateError
from polygen.mesh2d.size_grid import element_size_grid
from polygen.radiosity.adaptive import adaptive_refine, bright_scale
from polygen.radiosity.mesh import MeshError, RadiosityMesh, bubble_mesher, mesh_scene
from polygen.radiosity.raster import node_intensities
from polygen.radiosity.scene import Scene, SceneError
from polygen.radiosity.solve import progressive_refinement

__all__ = ["IntensityMesh", "intensity_variation", "size_function", "check_size_parameters",
           "polygon_size_grids", "intensity_bubble_mesh", "bright_scale", "PHASES",
           "remesh_polygon", "error_at_elements", "match_element_count", "width_capped_sizes"]

#: Table 4.2's five phases, the keys of :attr:`IntensityMesh.seconds`.
PHASES = ("first_mesh", "first_radiosity", "size_function", "second_mesh", "second_radiosity")


def _node_edges(mesh):
    """(E, 2) int64 node pairs joined by an element edge (Def. 4.1)."""
    edges, _ = triangle_edges(mesh.elements)
    return edges


def intensity_variation(mesh, node_values):
    """Intensity variation at every node, (4.1): ``D = max_i |I_i - I| / dist_i``.

    Parameters
    ----------
    mesh : RadiosityMesh
    node_values : (N,) or (N, C) float64
        Node intensities (e.g. :func:`~polygen.radiosity.node_intensities` of
        the element radiosities); with channels (RGB), ``D`` is the largest
        over them (4.3.1).

    Returns
    -------
    (N,) float64
        Over the nodes joined to each node by an element edge (Def. 4.1);
        0 for a node without neighbours.  Nodes of different polygons are
        never neighbours.
    """
    if not isinstance(mesh, RadiosityMesh):
        raise MeshError(f"mesh must be a RadiosityMesh, got {type(mesh).__name__}")
    v = np.asarray(node_values, dtype=np.float64)
    v = v.reshape(len(v), -1)
    if v.shape[0] != mesh.n_nodes:
        raise MeshError(f"node_values must have {mesh.n_nodes} rows, got {v.shape[0]}")
    if not np.all(np.isfinite(v)):
        raise MeshError("node_values contain NaN or inf")
    e = _node_edges(mesh)
    dist = np.linalg.norm(mesh.nodes[e[:, 0]] - mesh.nodes[e[:, 1]], axis=1)
    if np.any(dist <= 0):
        raise MeshError("two nodes joined by an element edge coincide")
    g = np.abs(v[e[:, 0]] - v[e[:, 1]]).max(axis=1) / dist
    out = np.zeros(mesh.n_nodes)
    np.maximum.at(out, e[:, 0], g)
    np.maximum.at(out, e[:, 1], g)
    return out


def check_size_parameters(size_initial, size_min, size_max):
    """Check (4.3): ``0 < size_max < size_initial < size_min``, all finite.

    Returns
    -------
    (size_initial, size_min, size_max) floats

    Raises
    ------
    MeshError
        Naming the parameter that breaks the order.
    """
    vals = {}
    for name, v in (("size_initial", size_initial), ("size_min", size_min), ("size_max", size_max)):
        try:
            vals[name] = float(v)
        except (TypeError, ValueError):
            raise MeshError(f"{name} must be a number, got {type(v).__name__}") from None
        if not (np.isfinite(vals[name]) and vals[name] > 0):
            raise MeshError(f"{name} must be finite and > 0, got {v}")
    si, smin, smax = vals["size_initial"], vals["size_min"], vals["size_max"]
    if not smax < si:
        raise MeshError(f"size_max ({smax}) must be smaller than size_initial ({si}): it is the "
                        "size where the intensity varies most (4.3)")
    if not si < smin:
        raise MeshError(f"size_min ({smin}) must be larger than size_initial ({si}): it is the "
                        "size where the intensity varies least (4.3)")
    return si, smin, smax


def size_function(variation, *, size_min, size_max):
    """Element size at each node from its intensity variation, (4.2)-(4.4).

    ``f(D) = a D + b`` with ``f(D_min) = size_min`` and ``f(D_max) =
    size_max`` over the given ``D``.

    Parameters
    ----------
    variation : (N,) float64
        ``D`` at the nodes (:func:`intensity_variation`), >= 0.
    size_min, size_max : float, keyword-only
        Sizes at the smallest and the largest ``D`` (``size_max <
        size_min``).

    Returns
    -------
    (N,) float64
        All ``size_min`` when ``D`` is constant (no variation anywhere).
    """
    d = np.asarray(variation, dtype=np.float64).reshape(-1)
    if len(d) == 0 or not np.all(np.isfinite(d)) or d.min() < 0:
        raise MeshError("variation must be a non-empty array of finite values >= 0")
    smin, smax = float(size_min), float(size_max)
    if not (np.isfinite(smax) and 0 < smax < smin and np.isfinite(smin)):
        raise MeshError(f"need 0 < size_max < size_min, got size_max={size_max}, "
                        f"size_min={size_min}")
    dmin, dmax = float(d.min()), float(d.max())
    if dmax == dmin:
        return np.full(len(d), smin)
    a = (smax - smin) / (dmax - dmin)  # (4.4)
    b = (smin * dmax - smax * dmin) / (dmax - dmin)
    return a * d + b


def _finest_per_site(xy, sizes):
    """Dedupe points at one (u, v) (both faces', both sides of a D0 line): the finer size."""
    key = np.round(xy / (1e-9 * max(1.0, np.abs(xy).max())))
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    finest = np.full(inv.max() + 1, np.inf)
    np.minimum.at(finest, inv, sizes)
    first = np.unique(inv, return_index=True)[1]
    return xy[first], finest


def _grid(xy, sizes, bounds, grid, nu, k, poly, where=""):
    try:
        return element_size_grid(xy, sizes, bounds, grid=grid, nu=nu)
    except (ValueError, PlateError) as exc:
        raise MeshError(f"polygon {k} ({poly.name!r}){where}: {exc}") from None


def polygon_size_grids(mesh, node_sizes, *, grid, nu=0.3, layouts=None):
    """One element-size grid per polygon of a mesh (4.3.2), per region where it has regions.

    Parameters
    ----------
    mesh : RadiosityMesh
    node_sizes : (N,) float64
        Sizes at the nodes (:func:`size_function`).
    grid : float or (m, n) ints, keyword-only
        Lattice step, or point counts, of every polygon's grid
        (:func:`polygen.mesh2d.grid_lattice`).
    nu : float, keyword-only
        The plate's Poisson ratio.
    layouts : list of (PlanarGraph or None) or None, keyword-only
        Build the grids per region of these layouts instead of the mesh's own (one per
        polygon, None: no regions), e.g. of a subset of the mesh's lines: each region of
        the mesh must lie in one region of these (the region holding its ``region_point``
        gets its nodes).

    Returns
    -------
    list of GridSize or RegionSize
        In each polygon's (u, v) frame, over its bounding box.  The two
        faces of a two-sided polygon share one grid: at each node position
        the smaller of the two faces' sizes counts.  A polygon that the
        mesh's constrained segments (discontinuity lines) cut into several
        regions gets a :class:`~polygen.radiosity.layout.RegionSize` of one
        grid per region, over the region's bounding box, built from the
        nodes of that region's elements only: the plate never smooths a
        size across a discontinuity line.  A region whose nodes cannot
        hold a plate (all on one line) gets the finest of their sizes.
    """
    from polygen.radiosity.layout import RegionSize

    s = np.asarray(node_sizes, dtype=np.float64).reshape(-1)
    if s.shape != (mesh.n_nodes,):
        raise MeshError(f"node_sizes must be ({mesh.n_nodes},), got {s.shape}")
    regions = mesh.element_region
    out = []
    for k, poly in enumerate(mesh.scene.polygons):
        xy, tris, el, nodes = mesh.polygon_elements(k)
        ext = poly.exterior_2d
        reg = None if regions is None else regions[el]
        lay = mesh.layouts[k] if mesh.layouts is not None else None
        if layouts is not None:
            if layouts[k] is None or reg is None:
                reg, lay = None, None
            else:
                reg = layouts[k].region_of(lay.region_point)[reg]
                lay = layouts[k]
        if reg is None or len(np.unique(reg)) == 1:
            p, f = _finest_per_site(xy, s[nodes])
            out.append(_grid(p, f, (*ext.min(axis=0), *ext.max(axis=0)), grid, nu, k, poly))
            continue
        sizes, at = [], []
        for r in np.unique(reg):
            loc = np.unique(tris[reg == r])
            p, f = _finest_per_site(xy[loc], s[nodes[loc]])
            bounds = (*p.min(axis=0), *p.max(axis=0))
            try:
                g = element_size_grid(p, f, bounds, grid=grid, nu=nu)
            except (ValueError, PlateError):
                g = float(f.min())
            sizes.append(g)
            at.append(lay.region_point[r])
        out.append(RegionSize(sizes, at=np.array(at)))
    return out


@dataclass(frozen=True, eq=False)
class IntensityMesh:
    """Result of :func:`intensity_bubble_mesh`.

    Attributes
    ----------
    first_mesh, second_mesh : RadiosityMesh
        The uniform mesh and the intensity-based bubble mesh.
    first_radiosity, second_radiosity : (M1, 3), (M2, 3) float64
        Display radiosities of the two solutions (ambient term included).
    first_result, second_result : RadiosityResult
    node_intensity : (N1, 3) float64
        The first solution's node intensities (2.8).
    variation : (N1,) float64
        ``D`` at the first mesh's nodes (4.1).
    node_size : (N1,) float64
        ``f(D)`` (4.4).
    size_grids : list of GridSize
        One per polygon (4.3.2).
    seconds : dict
        Wall time of Table 4.2's five phases (:data:`PHASES`), and of the
        adaptive re-mesh and its solution when asked for.
    cpu_seconds : dict
        The same phases' CPU time of this process (all its threads): on a
        shared machine, what the work cost rather than how long it waited.
    adaptive_mesh : RadiosityMesh or None
        Conventional adaptive subdivision of the first mesh by the first
        solution (Table 4.1's middle row); None unless asked for.
    adaptive_radiosity : (M3, 3) float64 or None
        Its solution, when asked for.
    parameters : dict
        The sizes and options used.
    """

    first_mesh: RadiosityMesh
    first_result: object
    first_radiosity: np.ndarray
    node_intensity: np.ndarray
    variation: np.ndarray
    node_size: np.ndarray
    size_grids: list
    second_mesh: RadiosityMesh
    second_result: object
    second_radiosity: np.ndarray
    seconds: dict
    cpu_seconds: dict
    adaptive_mesh: RadiosityMesh | None = None
    adaptive_radiosity: np.ndarray | None = None
    parameters: dict = field(default_factory=dict)

    @property
    def total_seconds(self):
        return float(sum(self.seconds[p] for p in PHASES))


class _Clock:
    """Wall and CPU seconds of named phases."""

    def __init__(self):
        self.wall, self.cpu = {}, {}

    def start(self):
        self._t, self._c = time.perf_counter(), time.process_time()

    def stop(self, name):
        self.wall[name] = time.perf_counter() - self._t
        self.cpu[name] = time.process_time() - self._c


def _solve(mesh, solve):
    result = progressive_refinement(mesh, **solve)
    return result, result.display_radiosity(mesh)


def intensity_bubble_mesh(scene, *, size_initial, size_min, size_max, grid=None,
                          element_levels=1, nu=0.3, seed=0, solve=None,
                          adaptive_threshold=None, solve_adaptive=False, first=None,
                          segments=None, improve=0, width_floor=None, second_segments=None):
    """The two-pass loop of Fig. 4.3.

    Parameters
    ----------
    scene : Scene
    size_initial : float, keyword-only
        Patch size of the first, uniform bubble mesh.
    size_min, size_max : float, keyword-only
        Patch sizes where the intensity varies least and most;
        ``size_max < size_initial < size_min`` (4.3).
    grid : float or (m, n) ints, keyword-only
        Size-grid lattice step or point counts per polygon; default
        ``size_max / 2**element_levels``, the finest element's size (the
        thesis gives no grid size): finer than the first mesh's nodes, so
        that the plate fills the grid points between them.
    element_levels : int, keyword-only
        Each patch is split into ``4**element_levels`` elements (both meshes).
    nu : float, keyword-only
        The plate's Poisson ratio.
    seed : int, keyword-only
        Seed of the bubble meshes.
    solve : dict, keyword-only
        Keywords of :func:`~polygen.radiosity.progressive_refinement`
        (default ``tol=0.01, ambient=True``).
    adaptive_threshold : float in (0, 1) or None, keyword-only
        Also refine the first mesh by conventional adaptive subdivision
        (:func:`~polygen.radiosity.adaptive_refine`): elements whose radiosity
        jumps from an edge neighbour's by more than this fraction of
        :func:`bright_scale`.
    solve_adaptive : bool, keyword-only
        Solve the adaptive mesh too.
    first : IntensityMesh or None, keyword-only
        Reuse this earlier run's first mesh and solution (and their timings)
        instead of computing them again, e.g. to try other ``size_min`` /
        ``size_max``; it must come from the same scene, ``size_initial``,
        ``element_levels``, ``seed``, ``solve`` and ``segments``.
    segments : mapping or sequence, keyword-only, optional
        Constrained segments per polygon (``mesh_scene(..., segments=)``),
        e.g. the discontinuity lines of
        :func:`polygen.discontinuity.simplified_discontinuity`: both meshes
        keep them as patch edges, and the size grids are built per region
        (:func:`polygon_size_grids`), so that no size is smoothed across a
        line.  :func:`polygen.discontinuity.combined.combined_bubble_mesh` is this
        with the scene's own lines (the thesis's future work, 4.5).
    improve : int, keyword-only
        Rounds of the bubble mesh's quality improvement on the second mesh
        (:func:`polygen.mesh2d.bubble_mesh`'s ``improve``: a bubble at the
        circumcentre of each triangle under 30 degrees, Laplacian smoothing
        of the face bubbles, a round kept only if it is better); 0 (the
        default) is the thesis's bubble mesh alone.
    width_floor : float or None, keyword-only
        With ``segments``: cap every region's size (both meshes) by the region's local
        width, never below this (:func:`width_capped_sizes`), so that a region narrower than
        its size is not meshed by skinny triangles; None (the default): no cap.
    second_segments : callable or None, keyword-only
        With ``segments``: ``second_segments(first_mesh, size_grids) -> segments`` chooses
        the second mesh's lines from the first mesh and its per-region size grids; they
        must be a subset of ``segments`` (every region of the first mesh inside one region
        of theirs), and the size grids are rebuilt per region of theirs
        (:func:`polygon_size_grids`'s ``layouts``).  None (the default): ``segments``.

    Returns
    -------
    IntensityMesh

    Raises
    ------
    SceneError
        ``scene`` is not a Scene.
    MeshError
        Sizes out of order (4.3), a bad grid or threshold.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a Scene, got {type(scene).__name__}")
    si, smin, smax = check_size_parameters(size_initial, size_min, size_max)
    grid = smax / 2 ** int(element_levels) if grid is None else grid
    if adaptive_threshold is not None and not 0 < adaptive_threshold < 1:
        raise MeshError(f"adaptive_threshold must be in (0, 1), got {adaptive_threshold}")
    solve = {"tol": 0.01, "ambient": True} if solve is None else dict(solve)
    mesher = bubble_mesher if seed == 0 else _seeded(seed)
    clock = _Clock()

    if width_floor is not None:
        width_floor = float(width_floor)
        if not (np.isfinite(width_floor) and width_floor > 0):
            raise MeshError(f"width_floor must be finite and > 0, got {width_floor}")
    if first is None:
        clock.start()
        spec = si
        if width_floor is not None and segments is not None:
            spec = width_capped_sizes(scene, [si] * len(scene.polygons), segments,
                                      floor=width_floor)
        first = mesh_scene(scene, spec, element_levels=element_levels, mesher=mesher,
                           segments=segments)
        clock.stop("first_mesh")
        clock.start()
        r1, b1 = _solve(first, solve)
        clock.stop("first_radiosity")
    else:
        if not isinstance(first, IntensityMesh):
            raise MeshError(f"first must be an IntensityMesh, got {type(first).__name__}")
        p = first.parameters
        same = (first.first_mesh.scene is scene and p["size_initial"] == si
                and p["element_levels"] == element_levels and p["seed"] == seed
                and p["solve"] == solve and p.get("segments") is segments
                and p.get("width_floor") == width_floor)
        if not same:
            raise MeshError("first: that run's scene, size_initial, element_levels, seed, "
                            "solve, segments or width_floor differ from these")
        r1, b1 = first.first_result, first.first_radiosity
        for k in PHASES[:2]:
            clock.wall[k], clock.cpu[k] = first.seconds[k], first.cpu_seconds[k]
        first = first.first_mesh

    clock.start()
    inten = node_intensities(first, b1)
    d = intensity_variation(first, inten)
    fsize = size_function(d, size_min=smin, size_max=smax)
    grids = polygon_size_grids(first, fsize, grid=grid, nu=nu)
    segments2, layouts2 = segments, first.layouts
    if second_segments is not None and segments is not None:
        from polygen.radiosity.layout import polygon_layout
        from polygen.radiosity.mesh import _segments_per_polygon

        segments2 = second_segments(first, grids)
        layouts2 = [None if sg is None or len(sg) == 0 else polygon_layout(poly, sg)
                    for poly, sg in zip(scene.polygons,
                                        _segments_per_polygon(segments2, scene))]
        grids = polygon_size_grids(first, fsize, grid=grid, nu=nu, layouts=layouts2)
        layouts2 = None
    clock.stop("size_function")

    clock.start()
    mesher2 = mesher if not improve else _seeded(seed, improve=int(improve))
    spec = grids
    if width_floor is not None and segments2 is not None:
        spec = width_capped_sizes(scene, grids, segments2, floor=width_floor,
                                  layouts=layouts2)
    second = mesh_scene(scene, spec, element_levels=element_levels, mesher=mesher2,
                        segments=segments2)
    clock.stop("second_mesh")

    clock.start()
    r2, b2 = _solve(second, solve)
    clock.stop("second_radiosity")

    ada = ada_b = None
    if adaptive_threshold is not None:
        clock.start()
        ada = adaptive_refine(first, b1, adaptive_threshold * bright_scale(first, b1)).mesh
        clock.stop("adaptive_mesh")
        if solve_adaptive:
            clock.start()
            _, ada_b = _solve(ada, solve)
            clock.stop("adaptive_radiosity")
    params = {"size_initial": si, "size_min": smin, "size_max": smax, "grid": grid,
              "element_levels": element_levels, "nu": nu, "seed": seed, "solve": solve,
              "adaptive_threshold": adaptive_threshold, "segments": segments,
              "improve": int(improve), "width_floor": width_floor,
              "second_segments": segments2}
    return IntensityMesh(first, r1, b1, inten, d, fsize, grids, second, r2, b2, clock.wall,
                         clock.cpu, ada, ada_b, params)


def width_capped_sizes(scene, sizes, segments, *, floor, beta=0.5, layouts=None):
    """Size specs with every cut region capped by its local width, graded across the scene.

    Two steps.  (1) Each region of a polygon with segments gets ``min(size, max(local width,
    floor))`` (:func:`polygen.mesh2d.region_width.width_capped_size`), so that a region
    narrower than its size is not meshed by skinny triangles.  (2) Where that cap binds, the
    capped sizes are sampled (a lattice of step ``floor`` and the region's boundary) and every
    polygon's size is limited to grow from them by at most ``beta`` per unit of 3-D distance
    (:func:`polygen.mesh2d.region_width.graded_minimum`): a fine strip along a shared edge
    makes that edge's nodes fine in the neighbouring polygon too, and without the limit the
    neighbour would jump from them to its own size in one element.

    Parameters
    ----------
    scene : Scene
    sizes : list
        One size spec per polygon (a number, a size field, a GridSize or a
        :class:`~polygen.radiosity.layout.RegionSize`), as ``mesh_scene`` takes.
    segments : mapping or sequence
        The constrained segments (``mesh_scene(..., segments=)``).
    floor : float, keyword-only
        The smallest cap, > 0.
    beta : float, keyword-only
        The largest slope of the size near a cap: neighbouring bubbles differ by at most
        ``1 + beta`` (0.5: Theorem 4.1's edge-length ratio at most 1.25).
    layouts : list of PlanarGraph or None, keyword-only
        The polygons' layouts (a mesh's ``layouts``); None: computed from ``segments``.

    Returns
    -------
    list
        One size spec per polygon: a ``RegionSize`` (one field per region of its layout)
        for polygons with segments, a size field for the others.
    """
    from polygen.mesh2d.region_width import region_boundary, width_capped_size
    from polygen.mesh2d.sizing import as_size_function
    from polygen.radiosity.layout import RegionSize, polygon_layout
    from polygen.radiosity.mesh import _segments_per_polygon

    floor = float(floor)
    if not (np.isfinite(floor) and floor > 0):
        raise MeshError(f"floor must be finite and > 0, got {floor}")
    segs = _segments_per_polygon(segments, scene)
    out = list(sizes)
    ys, cs = [], []
    for k, (poly, sg) in enumerate(zip(scene.polygons, segs)):
        if sg is None or len(sg) == 0:
            continue
        lay = polygon_layout(poly, sg) if layouts is None else layouts[k]
        spec = out[k]
        per = spec.resolve(poly, lay) if isinstance(spec, RegionSize) else [spec] * lay.n_regions
        fns = []
        for r, f in enumerate(per):
            capped = width_capped_size(f, lay, r, floor=floor)
            fns.append(capped)
            pts = _region_samples(lay, r, region_boundary(lay, r), floor)
            base, cap = as_size_function(f)(pts), capped(pts)
            bind = cap < base * (1 - 1e-9)
            ys.append(poly.to_3d(pts[bind]))
            cs.append(cap[bind])
        out[k] = RegionSize(fns, at=lay.region_point)
    if not ys or sum(len(c) for c in cs) == 0:
        return out
    y, c = np.concatenate(ys), np.concatenate(cs)
    # a sample that another one's cone already covers changes nothing: drop it
    o = np.argsort(c, kind="stable")
    y, c = y[o], c[o]
    keep = np.ones(len(c), dtype=bool)
    for j in range(1, len(c)):
        cover = c[:j][keep[:j]] + beta * np.linalg.norm(y[:j][keep[:j]] - y[j], axis=1)
        keep[j] = not np.any(cover <= c[j])
    y, c = y[keep], c[keep]
    graded = []
    for spec, given, poly in zip(out, sizes, scene.polygons):
        # samples whose cone stays above the polygon's largest size cannot cap it
        near = c + beta * _distance_to_polygon(poly, y) < _largest_size(given)
        graded.append(_graded_spec(spec, poly, y[near], c[near], beta) if near.any() else spec)
    return graded


def _largest_size(spec):
    """An upper bound of a size spec (inf for a callable, which may be anything)."""
    from polygen.mesh2d import GridSize
    from polygen.radiosity.layout import RegionSize

    if isinstance(spec, RegionSize):
        parts = [*spec.sizes, *([] if spec.default is None else [spec.default])]
        return max(_largest_size(f) for f in parts)
    if isinstance(spec, GridSize):
        return float(np.max(spec.values))
    if np.isscalar(spec):
        return float(spec)
    return np.inf


def _distance_to_polygon(poly, y):
    """A lower bound of the 3-D distance from points to a polygon: to its 2-D bounding box."""
    uv = poly.to_2d(y)
    back = poly.to_3d(uv)
    ext = poly.exterior_2d
    d2 = np.linalg.norm(uv - np.clip(uv, ext.min(axis=0), ext.max(axis=0)), axis=1)
    return np.hypot(d2, np.linalg.norm(y - back, axis=1))


def _region_samples(lay, r, seg, step):
    """Points of region r: a lattice of the given step inside it, and its boundary edges'."""
    ends = seg.reshape(-1, 2)
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    gx = np.arange(lo[0], hi[0] + 0.5 * step, step)
    gy = np.arange(lo[1], hi[1] + 0.5 * step, step)
    grid = np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2)
    grid = grid[lay.region_of(grid) == r]
    on = []
    for a, b in seg:
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / (0.5 * step))) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        on.append(a + t * (b - a))
    return np.concatenate([grid, *on])


def _graded_spec(spec, poly, y, c, beta):
    from polygen.mesh2d.region_width import graded_minimum
    from polygen.mesh2d.sizing import as_size_function
    from polygen.radiosity.layout import RegionSize

    def wrap(f):
        field = as_size_function(f)

        def size(xy):
            q = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
            return np.minimum(field(q), graded_minimum(poly.to_3d(q), y, c, beta=beta))

        size.constant = None
        return size

    if isinstance(spec, RegionSize):
        return RegionSize([wrap(f) for f in spec.sizes], at=spec.at,
                          default=None if spec.default is None else wrap(spec.default))
    return wrap(spec)


def _seeded(seed, **kwargs):
    import functools

    return functools.partial(bubble_mesher, seed=int(seed), **kwargs)


def remesh_polygon(run, polygon, *, size_min, size_max, grid=None):
    """One polygon's second mesh for other sizes, from an earlier run's first solution.

    The size function (4.4) with these sizes, the polygon's size grid
    (4.3.2) and its bubble mesh alone (the rest of the scene is not
    meshed): what the notebook's sliders show.

    Parameters
    ----------
    run : IntensityMesh
    polygon : int
        Index of the polygon in the run's scene.
    size_min, size_max : float, keyword-only
        As :func:`intensity_bubble_mesh`; checked against the run's
        ``size_initial`` by (4.3).
    grid : float or (m, n) ints, keyword-only
        Size-grid step; default ``size_max / 2**element_levels`` as the loop's.

    Returns
    -------
    size_grid : GridSize or RegionSize
        The polygon's size grid.
    mesh : RadiosityMesh
        The polygon meshed alone (a scene of that one polygon, index 0), with
        the run's ``element_levels`` and ``seed``.

    Raises
    ------
    MeshError
        Sizes out of the order (4.3), a bad polygon index or run.
    """
    if not isinstance(run, IntensityMesh):
        raise MeshError(f"run must be an IntensityMesh, got {type(run).__name__}")
    p = run.parameters
    check_size_parameters(p["size_initial"], size_min, size_max)
    scene = run.first_mesh.scene
    if not (isinstance(polygon, (int, np.integer)) and 0 <= polygon < len(scene.polygons)):
        raise MeshError(f"polygon must be an index in [0, {len(scene.polygons)}), got {polygon!r}")
    levels = p["element_levels"]
    grid = float(size_max) / 2 ** int(levels) if grid is None else grid
    sizes = size_function(run.variation, size_min=size_min, size_max=size_max)
    grids = polygon_size_grids(run.first_mesh, sizes, grid=grid, nu=p["nu"])
    mesher = bubble_mesher if p["seed"] == 0 else _seeded(p["seed"])
    mesh = mesh_scene(Scene([scene.polygons[polygon]]), [grids[polygon]], element_levels=levels,
                      mesher=mesher)
    return grids[polygon], mesh


def match_element_count(count, lo, hi, target, *, tol=0.02, steps=16):
    """Bisect a coarsening parameter on ``[lo, hi]`` until ``count(x)`` is within ``tol`` of ``target``.

    For comparing two meshing methods at equal element count by measuring both
    (rather than interpolating a curve, :func:`error_at_elements`): ``count(x)``
    gives the element count of one method's mesh at its size parameter ``x``
    (larger ``x``, fewer elements); only counts are looked at. A midpoint
    with more elements than the target moves the lower end up, else the upper
    end down.

    Returns
    -------
    (x, n, trail)
        The parameter and its count, both None when none of ``steps`` midpoints
        came within ``tol * target``; ``trail`` lists every ``(x, count)`` tried.
    """
    if not (lo < hi and target > 0 and tol >= 0 and steps >= 1):
        raise MeshError(f"need lo < hi, target > 0, tol >= 0, steps >= 1; got {lo}, {hi}, {target}, {tol}, {steps}")
    trail = []
    for _ in range(int(steps)):
        mid = 0.5 * (lo + hi)
        n = int(count(mid))
        trail.append((round(mid, 6), n))
        if abs(n - target) <= tol * target:
            return mid, n, trail
        if n > target:
            lo = mid
        else:
            hi = mid
    return None, None, trail


def error_at_elements(curve, n):
    """An error curve's value at ``n`` elements, interpolated linearly in log-log.

    Parameters
    ----------
    curve : (K, 2) array_like
        ``(elements, error)`` points, elements increasing, all > 0.
    n : float
        Element count.

    Returns
    -------
    float or None
        None when ``n`` lies outside the curve's element range (no extrapolation).
    """
    c = np.asarray(curve, dtype=np.float64).reshape(-1, 2)
    if len(c) == 0 or np.any(c <= 0) or np.any(np.diff(c[:, 0]) < 0):
        raise MeshError("curve must be (elements, error) pairs, elements increasing, all > 0")
    if not c[0, 0] <= n <= c[-1, 0]:
        return None
    return float(np.exp(np.interp(np.log(n), np.log(c[:, 0]), np.log(c[:, 1]))))
