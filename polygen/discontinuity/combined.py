"""Simplified discontinuity meshing and the intensity-based bubble mesh combined.

The thesis closes chapter 4 (4.5) with this as future work: mesh along the
discontinuity lines that simplified discontinuity meshing finds (chapter 3,
:func:`~polygen.discontinuity.simplified_discontinuity`), and size the
elements between them by the intensity variation of a first solution
(:func:`~polygen.radiosity.intensity_bubble_mesh`).  Both meshes of the
two-pass loop keep the lines as constrained segments (D0: nodes duplicated
across, D1: shared); the size grid is built per region, from the nodes of
that region only, so that the plate never carries the fine size of a shadow
boundary across a D0 line into the light or the umbra beside it.

Lines much closer to each other (or to the polygon's edge) than the finest
element are merged first (:func:`polygen.mesh2d.merge_close_segments`), as
the thesis proposes among its future work (chapter 8: delete discontinuity
lines lying much closer than the element size): the penumbra bands of the
Fig. 4.8 scene are 0.04 wide, and a band that narrow meshed at patch size
1.7-2.4 gives triangles of 2 degrees.  What merging leaves narrower than its
size (a line meeting a wall near a corner, a wedge between two lines) gets
its size capped by the region's local width
(:func:`polygen.mesh2d.region_width.region_width`), graded so that the
neighbours of a capped spot follow it.

The second mesh keeps fewer lines (``lines="single"``, the default): the D0 lines, the
stretches of D1 lines along a penumbra narrower than the element there (a wider one is a
smooth ramp that the size grid resolves, :func:`narrow_lines`), and of two such lines
closer than the largest element only the longer (:func:`single_lines`).  With every line
kept (``lines="all"``) the cap filled the strips between the two lines of each narrow
penumbra, and the cones graded out of them, with elements: on the scene of Fig. 4.8 half
of the second mesh's elements lay within 0.85 of a line, while away from the lines it was as
coarse as the intensity-based bubble mesh alone at the same settings, and that is where its
extra image error was (benchmarks/experiments/results/combination_error_zones.md).
"""

from __future__ import annotations

import numpy as np

from polygen.discontinuity.simplified import simplified_discontinuity
from polygen.mesh2d import merge_close_segments
from polygen.radiosity.intensity import intensity_bubble_mesh
from polygen.radiosity.layout import Segments
from polygen.radiosity.mesh import MeshError
from polygen.radiosity.scene import Scene, SceneError

__all__ = ["combined_bubble_mesh", "merged_lines", "narrow_lines", "single_lines"]

LINES = ("all", "narrow", "single")


def merged_lines(scene, segments, *, gap):
    """Every polygon's discontinuity lines with those closer than ``gap`` merged.

    Parameters
    ----------
    scene : Scene
    segments : mapping {polygon index: Segments}
        E.g. :attr:`SimplifiedDiscontinuity.segments`.
    gap : float, keyword-only
        :func:`polygen.mesh2d.merge_close_segments`'s distance, >= 0.

    Returns
    -------
    dict {polygon index: Segments}
        2-D segments in each polygon's frame; a polygon left without lines
        has no entry.
    """
    out = {}
    for k, sg in segments.items():
        poly = scene.polygons[k]
        ends, kinds = sg.in_plane(poly)
        ends, kinds, _ = merge_close_segments(poly.exterior_2d, poly.holes_2d, ends, kinds, gap=gap)
        if len(ends):
            out[k] = Segments(np.asarray(ends), kinds)
    return out


def _nearest_on_segments(p, seg):
    """Distance from each point to a set of segments, and the nearest point on them."""
    a, d = seg[:, 0], seg[:, 1] - seg[:, 0]                      # (E, 2)
    ll = np.maximum((d * d).sum(axis=1), 1e-300)
    t = np.clip(((p[:, None, :] - a[None]) * d[None]).sum(axis=2) / ll, 0.0, 1.0)  # (K, E)
    q = a[None] + t[..., None] * d[None]
    dist = np.linalg.norm(q - p[:, None, :], axis=2)
    j = np.argmin(dist, axis=1)
    i = np.arange(len(p))
    return dist[i, j], q[i, j]


def narrow_lines(polygon, found, lines, penumbra_points, size, *, step, near=0.0,
                 element_levels=1):
    """The lines worth meshing along: D0 always, D1 only where the penumbra is narrow.

    Under an area light a penumbra is a smooth ramp, which a size grid resolves where it is
    wider than the elements there; a D1 line only helps where the intensity changes over a
    distance shorter than the elements.  So every D0 line is kept whole, and every D1 line
    is cut into pieces about ``step`` long and kept on the pieces whose midpoint lies on the
    boundary of a penumbra region (of the lines as found) that is narrower there than the
    element the size field asks for: ``width < size / 2**element_levels``.  The width is
    the penumbra region's local width (:func:`polygen.mesh2d.region_width.region_width`)
    at the nearest point of its boundary, within ``near`` of the midpoint (the narrowest
    of such regions; none: the piece bounds no penumbra and is dropped); the size is the
    smaller of the size field's values in the two regions of ``lines`` beside the piece.

    Parameters
    ----------
    polygon : Polygon
    found : Segments
        The polygon's discontinuity lines as found (``SimplifiedDiscontinuity.segments``):
        the penumbra regions are measured among these.
    lines : Segments
        The lines to choose from (e.g. :func:`merged_lines`' for this polygon): each piece
        of them lies on (within ``near`` of) a line of ``found``.
    penumbra_points : (R, 2) float64
        A point in every penumbra region of ``found``
        (``SimplifiedDiscontinuity.penumbra_points``).
    size : number, callable, GridSize or RegionSize
        The patch size over the layout of ``lines`` (a RegionSize: per region of it).
    step : float, keyword-only
        Length of the pieces, > 0 (the finest element's size).
    near : float, keyword-only
        How far a piece may lie from the penumbra boundary it stands for, >= 0 (the merge
        gap: merging moves line ends by at most that).
    element_levels : int, keyword-only
        Elements per patch side, ``2**element_levels``.

    Returns
    -------
    Segments or None
        The kept pieces, 2-D in the polygon's frame (runs of consecutive kept pieces
        joined); None when nothing is kept.
    """
    from polygen.mesh2d import as_size_function
    from polygen.mesh2d.region_width import region_boundary, region_width
    from polygen.radiosity.layout import RegionSize, polygon_layout

    step, near = float(step), float(near)
    if not (np.isfinite(step) and step > 0):
        raise MeshError(f"step must be finite and > 0, got {step}")
    if not (np.isfinite(near) and near >= 0):
        raise MeshError(f"near must be finite and >= 0, got {near}")
    ends, kinds = lines.in_plane(polygon)
    ends = np.asarray(ends, dtype=np.float64).reshape(-1, 2, 2)
    kinds = list(np.broadcast_to(np.asarray(kinds), (len(ends),)))
    if len(ends) == 0:
        return None
    lay0 = polygon_layout(polygon, found)
    pp = np.asarray(penumbra_points, dtype=np.float64).reshape(-1, 2)
    pen = np.unique(lay0.region_of(pp)) if len(pp) else np.zeros(0, np.int64)
    pen = [int(r) for r in pen if r >= 0]
    bounds = [region_boundary(lay0, r) for r in pen]
    lay1 = polygon_layout(polygon, lines)
    per = (size.resolve(polygon, lay1) if isinstance(size, RegionSize)
           else [size] * lay1.n_regions)
    fields = [as_size_function(f) for f in per]
    tol = 1e-9 * max(1.0, float(np.abs(polygon.exterior_2d).max()))
    out, out_kinds = [], []
    for (a, b), kind in zip(ends, kinds):
        if kind == "D0":
            out.append((a, b))
            out_kinds.append("D0")
            continue
        length = float(np.linalg.norm(b - a))
        n = max(1, int(np.ceil(length / step - 1e-9)))
        t = np.linspace(0.0, 1.0, n + 1)
        mid = a + 0.5 * (t[:-1] + t[1:])[:, None] * (b - a)
        width = np.full(n, np.inf)
        for r, seg in zip(pen, bounds):
            dist, q = _nearest_on_segments(mid, seg)
            on = dist <= near + tol
            if on.any():
                width[on] = np.minimum(width[on], region_width(lay0, r, q[on]))
        nrm = np.array([-(b - a)[1], (b - a)[0]]) / max(length, 1e-300)
        eps = max(1e-6 * step, 10 * tol)
        sz = np.full(n, np.inf)
        for side in (1.0, -1.0):
            x = mid + side * eps * nrm
            reg = lay1.region_of(x)
            for r in np.unique(reg[reg >= 0]):
                m = reg == r
                sz[m] = np.minimum(sz[m], fields[r](x[m]))
        keep = width < sz / 2 ** int(element_levels)
        for piece in _runs(a, b, t, keep):
            out.append(piece)
            out_kinds.append("D1")
    if not out:
        return None
    return Segments(np.asarray(out, dtype=np.float64), out_kinds)


def _runs(a, b, t, keep):
    """The stretches ``[t[i], t[j + 1]]`` of segment ``a -> b`` over runs of kept pieces."""
    out, i, n = [], 0, len(keep)
    while i < n:
        if not keep[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and keep[j + 1]:
            j += 1
        out.append((a + t[i] * (b - a), a + t[j + 1] * (b - a)))
        i = j + 1
    return out


def single_lines(polygon, lines, *, gap, step):
    """The lines with, of any two closer than ``gap``, only the longer one kept.

    D0 lines are kept whole, first.  Then the D1 lines, longest first, are cut into pieces
    about ``step`` long, and a piece is dropped when its midpoint lies within ``gap`` of the
    polygon's edge (its rings) or of a line or piece kept before it.  No end point is moved:
    every kept piece is a stretch of one input line (runs of consecutive kept pieces joined).
    Used with ``gap`` the largest element: the two lines of a penumbra narrower than an
    element become one, and no strip narrower than an element is left between kept lines.

    Parameters
    ----------
    polygon : Polygon
    lines : Segments
        E.g. :func:`narrow_lines`' pieces for this polygon.
    gap : float, keyword-only
        Distance, >= 0 (0: the lines as given, D0 first then D1 longest first).
    step : float, keyword-only
        Length of the pieces, > 0.

    Returns
    -------
    Segments or None
        2-D in the polygon's frame; None when nothing is kept.
    """
    gap, step = float(gap), float(step)
    if not (np.isfinite(step) and step > 0):
        raise MeshError(f"step must be finite and > 0, got {step}")
    if not (np.isfinite(gap) and gap >= 0):
        raise MeshError(f"gap must be finite and >= 0, got {gap}")
    ends, kinds = lines.in_plane(polygon)
    ends = np.asarray(ends, dtype=np.float64).reshape(-1, 2, 2)
    kinds = np.asarray(np.broadcast_to(np.asarray(kinds), (len(ends),)))
    if len(ends) == 0:
        return None
    rings = []
    for ring in [polygon.exterior_2d, *polygon.holes_2d]:
        r = np.asarray(ring, dtype=np.float64)
        rings.append(np.stack([r, np.roll(r, -1, axis=0)], axis=1))
    near = list(rings)
    out, out_kinds = [], []
    for i in np.flatnonzero(kinds == "D0"):
        out.append((ends[i, 0], ends[i, 1]))
        out_kinds.append("D0")
        near.append(ends[i:i + 1])
    d1 = np.flatnonzero(kinds != "D0")
    length = np.linalg.norm(ends[d1, 1] - ends[d1, 0], axis=1)
    for i in d1[np.argsort(-length, kind="stable")]:
        a, b = ends[i]
        n = max(1, int(np.ceil(float(np.linalg.norm(b - a)) / step - 1e-9)))
        t = np.linspace(0.0, 1.0, n + 1)
        mid = a + 0.5 * (t[:-1] + t[1:])[:, None] * (b - a)
        dist, _ = _nearest_on_segments(mid, np.concatenate(near))
        kept = _runs(a, b, t, dist >= gap)
        out += kept
        out_kinds += ["D1"] * len(kept)
        if kept:
            near.append(np.asarray(kept, dtype=np.float64))
    if not out:
        return None
    return Segments(np.asarray(out, dtype=np.float64), out_kinds)


def combined_bubble_mesh(scene, *, size_initial, size_min, size_max, discontinuity=None,
                         merge_gap=None, width_cap=True, lines="single", **kwargs):
    """The two-pass loop of Fig. 4.3 on a mesh cut by the scene's discontinuity lines.

    Parameters
    ----------
    scene : Scene
    size_initial, size_min, size_max : float, keyword-only
        As :func:`~polygen.radiosity.intensity_bubble_mesh` (patch sizes;
        ``size_max < size_initial < size_min``).
    discontinuity : SimplifiedDiscontinuity or None, keyword-only
        The scene's discontinuity phase; None: computed here.
    merge_gap : float or None, keyword-only
        Lines closer than this to each other or to a polygon's edge are
        merged (:func:`merged_lines`); None: half the finest element's size,
        ``size_max / 2**element_levels / 2`` ("much closer than the element
        size", chapter 8); 0: the lines as found.
    width_cap : bool, keyword-only
        Cap every region's size by its local width, never below the finest element's size
        ``size_max / 2**element_levels`` (twice the default merge gap: elements of a strip
        as narrow as merging leaves are as long as it is wide), and let sizes grow from a
        cap by at most 0.5 per unit length
        (:func:`~polygen.radiosity.intensity.width_capped_sizes`), in both meshes; False:
        the size grids as they are (regions narrower than their size get slivers).  The cap
        costs elements: on the scene of Fig. 4.8 at ``size_initial`` 2.4 the first mesh has
        2440 elements instead of 1288 (smallest angle 12.3 degrees instead of 6.9), and the
        image error per element is worse (benchmarks/results/intensity_mesh.md).
    lines : {"all", "narrow", "single"}, keyword-only
        The second mesh's lines: "all" (the merged lines, as the first mesh), or "narrow":
        the D0 lines and the stretches of D1 lines along a penumbra narrower than the
        elements the first pass's size grids ask for there (:func:`narrow_lines`, pieces of
        the finest element's length, within the merge gap of the penumbra found), or
        "single": "narrow"'s lines of which, of two closer than the largest element
        ``size_min / 2**element_levels`` (to each other or to the polygon's edge), only the
        longer stays (:func:`single_lines`): a narrow penumbra is one line, and no strip
        narrower than an element is left between kept lines for the width cap to fill (the
        default: on the scene of Fig. 4.8 it is below both parents' error curves at every
        one of its points inside both, benchmarks/results/intensity_mesh_single.md); the
        first mesh keeps all the merged lines, and the second mesh's size grids are built
        per region of the kept lines.
    **kwargs
        Other keywords of :func:`~polygen.radiosity.intensity_bubble_mesh`
        (``grid``, ``element_levels``, ``seed``, ``solve``, ``first`` ...).

    Returns
    -------
    IntensityMesh
        Its ``parameters["segments"]`` are the first mesh's lines (after merging),
        ``parameters["second_segments"]`` the second mesh's; the first mesh has regions
        (``element_region``), the second where its lines cut the polygon.

    Raises
    ------
    SceneError
        ``scene`` is not a Scene, or ``discontinuity`` is of another scene.
    MeshError
        ``lines`` not one of "all", "narrow", "single"; as
        :func:`~polygen.radiosity.intensity_bubble_mesh`.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a Scene, got {type(scene).__name__}")
    if lines not in LINES:
        raise MeshError(f"lines must be one of {LINES}, got {lines!r}")
    lines_mode = lines
    if discontinuity is None:
        discontinuity = simplified_discontinuity(scene)
    elif discontinuity.scene is not scene:
        raise SceneError("discontinuity was computed for another scene")
    if "segments" in kwargs:
        raise TypeError("combined_bubble_mesh takes its segments from the discontinuity phase")
    if merge_gap is None:
        merge_gap = 0.5 * float(size_max) / 2 ** int(kwargs.get("element_levels", 1))
    lines = discontinuity.segments
    if merge_gap > 0:
        first = kwargs.get("first")
        if first is not None and first.parameters.get("merge_gap") == merge_gap:
            lines = first.parameters["segments"]   # the same merged lines, for `first=`
        else:
            lines = merged_lines(scene, discontinuity.segments, gap=merge_gap)
    levels = int(kwargs.get("element_levels", 1))
    finest = float(size_max) / 2 ** levels
    floor = finest if width_cap else None
    choose = None
    if lines_mode in ("narrow", "single"):
        found, pens = discontinuity.segments, discontinuity.penumbra_points
        largest = float(size_min) / 2 ** levels

        def choose(first_mesh, grids):
            out = {}
            for k, sg in lines.items():
                poly = scene.polygons[k]
                kept = narrow_lines(poly, found[k], sg, pens.get(k, np.zeros((0, 2))),
                                    grids[k], step=finest, near=merge_gap,
                                    element_levels=levels)
                if kept is not None and lines_mode == "single":
                    kept = single_lines(poly, kept, gap=largest, step=finest)
                if kept is not None:
                    out[k] = kept
            return out

    run = intensity_bubble_mesh(scene, size_initial=size_initial, size_min=size_min,
                                size_max=size_max, segments=lines, width_floor=floor,
                                second_segments=choose, **kwargs)
    run.parameters["merge_gap"] = float(merge_gap)
    run.parameters["lines"] = lines_mode
    return run
