"""Discontinuity meshing end to end: the discontinuity phase, then patches and elements (3.3.6).

:func:`discontinuity_mesh` runs, for a scene, either

* ``method="simplified"`` -- the thesis's method (3.3):
  :func:`~polygen.discontinuity.simplified.simplified_discontinuity` (shadow
  polyhedra, receiver complexes, illumination states), whose section edges
  become the receivers' constrained segments (D0 for point and parallel
  lights, D1 for area lights) and whose penumbra regions get the smaller
  sizes; or
* ``method="conventional"`` -- the baseline of 2.4.3: every EV and VE
  critical segment on each receiver
  (:func:`~polygen.discontinuity.conventional.conventional_segments`),
  noded where they cross, as constrained segments; a region is penumbra
  when a point inside it lies in some light's penumbra section and in none
  of that light's umbra sections.

Either way the mesh model (:func:`polygen.radiosity.mesh_scene`) does the
rest, as 3.3.6's steps 2-6 say: nodes on the regions' vertices, along
their edges (the smaller size of the two sides) and inside them, patches by
Delaunay (or the bubble mesh: ``mesher=bubble_mesher``), elements by
subdividing the patches.  Nodes on a D0 segment are duplicated, one copy
per side; on a D1 segment shared (Fig. 3.11).

The conventional method's regions are those of its segments (the faces of
their arrangement), not the BSP tree's leaves: the mesh model takes
segments, and a BSP leaf boundary that is no critical segment (a
supporting line extended across a leaf, Fig. 2.10(b)) would only add
constrained edges.  :func:`~polygen.discontinuity.conventional.conventional_bsp`
gives the BSP regions for counting (Fig. 3.4).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from polygen.discontinuity.shadow import ShadowError, scene_lights, scene_sections
from polygen.discontinuity.simplified import SimplifiedDiscontinuity, simplified_discontinuity

__all__ = ["DiscontinuityRecord", "MeshingError", "conventional_discontinuity", "discontinuity_mesh",
           "element_states"]

METHODS = ("simplified", "conventional")


class MeshingError(ValueError):
    """Bad arguments to :func:`discontinuity_mesh` (naming the argument)."""


@dataclass(frozen=True, eq=False)
class DiscontinuityRecord:
    """What :func:`discontinuity_mesh` attaches to its mesh as ``mesh.discontinuity``.

    Attributes
    ----------
    method : str
        ``"simplified"`` or ``"conventional"``.
    segments : dict {polygon index: Segments}
        The constrained segments handed to the mesh model.
    penumbra_points : dict {polygon index: (R, 2) float64}
        A point inside each region meshed with the penumbra sizes.
    counters : dict
        ``receivers``, ``discontinuity_edges`` (segments handed over),
        ``penumbra_regions``; the simplified driver's counters with
        ``method="simplified"``; ``critical_surfaces`` and
        ``critical_segments`` (before noding) with ``"conventional"``.
    timings : dict
        Seconds: ``T_d`` the discontinuity phase (when reused, the sum of
        its recorded phases), ``T_m`` the meshing;
        the simplified method adds Table 3.2's phases.
    discontinuity : SimplifiedDiscontinuity or None
        The simplified method's records (complexes, states ...).
    """

    method: str
    segments: dict
    penumbra_points: dict
    counters: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    discontinuity: object = None


def _check_size(name, v):
    if callable(v) or hasattr(v, "values"):
        return v
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise MeshingError(f"{name} must be a positive number, a size field or a GridSize, "
                           f"got {type(v).__name__}") from None
    if not np.isfinite(f) or f <= 0:
        raise MeshingError(f"{name} must be positive and finite, got {v}")
    return f


def discontinuity_mesh(scene, *, patch_size, penumbra_patch_size=None, element_levels=1,
                       method="simplified", mesher=None, element_mesher=None, discontinuity=None,
                       tol=1e-9):
    """Discontinuity meshing of a scene (Figs 3.5, 3.14): lines, regions, patches, elements.

    Parameters
    ----------
    scene : Scene
    patch_size : number, callable or GridSize, keyword-only
        Patch edge length L_p outside penumbra regions (every polygon that
        is no receiver, every receiver region that is bright or umbra for
        every light).
    penumbra_patch_size : number, callable or GridSize, keyword-only, optional
        L_p in regions that are penumbra for at least one light (3.3.6,
        step 1).  Default ``patch_size`` (the lines only, no refinement).
    element_levels : int, keyword-only
        Elements are the patches split ``4**element_levels`` ways (so L_e
        is smaller in penumbra too), see :func:`~polygen.radiosity.mesh_scene`.
    method : {"simplified", "conventional"}, keyword-only
    mesher : callable, keyword-only, optional
        :func:`~polygen.radiosity.lattice_delaunay_mesher` (default) or
        :func:`~polygen.radiosity.bubble_mesher` (3.3.6: nodes by the bubble
        mesh), possibly a ``functools.partial`` with its ``seed``.
    element_mesher : callable, keyword-only, optional
        Passed to :func:`~polygen.radiosity.mesh_scene`.
    discontinuity : keyword-only, optional
        The scene's discontinuity phase, reused (e.g. for several sizes):
        ``simplified_discontinuity(scene)`` with ``method="simplified"``,
        ``conventional_discontinuity(scene)`` with ``"conventional"``.
    tol : float, keyword-only
        Relative tolerance of the discontinuity phase.

    Returns
    -------
    RadiosityMesh
        With ``mesh.discontinuity`` a :class:`DiscontinuityRecord`.

    Raises
    ------
    MeshingError
        An unknown method, a bad size, a ``discontinuity`` of another scene.
    MeshError, ShadowError, ComplexError
        From the mesh model and the discontinuity phase, naming the polygon.
    """
    from polygen.radiosity import mesh_scene
    from polygen.radiosity.layout import RegionSize
    from polygen.radiosity.mesh import lattice_delaunay_mesher

    if method not in METHODS:
        raise MeshingError(f"method must be one of {METHODS}, got {method!r}")
    size = _check_size("patch_size", patch_size)
    pen_size = size if penumbra_patch_size is None else _check_size("penumbra_patch_size",
                                                                   penumbra_patch_size)
    t0 = time.perf_counter()
    if method == "simplified":
        if discontinuity is None:
            discontinuity = simplified_discontinuity(scene, tol=tol)
        elif not isinstance(discontinuity, SimplifiedDiscontinuity) or discontinuity.scene is not scene:
            raise MeshingError("discontinuity must be simplified_discontinuity(scene) of this scene")
        sd = discontinuity
        segments, pen_pts = sd.segments, sd.penumbra_points
        counters = dict(sd.counters)
        timings = {k: v for k, v in sd.timings.items()}
    else:
        sd = None
        if discontinuity is None:
            discontinuity = conventional_discontinuity(scene, tol=tol)
        elif not (isinstance(discontinuity, tuple) and len(discontinuity) == 3):
            raise MeshingError("discontinuity must be conventional_discontinuity(scene) with "
                               "method='conventional'")
        segments, pen_pts, counters = discontinuity
        counters = dict(counters)
        timings = {}
    timings["T_d"] = time.perf_counter() - t0
    if method == "simplified" and timings["T_d"] < sum(sd.timings.values()):
        # reused: the phase's own time, not the time to hand it over
        timings["T_d"] = float(sum(sd.timings.values()))
    sizes = []
    n_pen = 0
    for k in range(len(scene.polygons)):
        pts = pen_pts.get(k)
        if pts is None or not len(pts) or pen_size is size:
            sizes.append(size)
        else:
            n_pen += len(pts)
            sizes.append(RegionSize([pen_size] * len(pts), at=pts, default=size))
    t0 = time.perf_counter()
    mesh = mesh_scene(scene, sizes, element_levels=element_levels,
                      mesher=lattice_delaunay_mesher if mesher is None else mesher,
                      element_mesher=element_mesher, segments=dict(segments))
    timings["T_m"] = time.perf_counter() - t0
    counters["penumbra_regions"] = sum(len(p) for p in pen_pts.values())
    counters["discontinuity_edges"] = sum(len(s) for s in segments.values())
    counters["receivers"] = len(segments)
    mesh.discontinuity = DiscontinuityRecord(method, dict(segments), dict(pen_pts), counters, timings, sd)
    return mesh


def element_states(mesh, discontinuity):
    """The illumination state (3.3.5) of the region each element's centroid lies in, per light.

    A mesh made by :func:`discontinuity_mesh` from ``discontinuity`` has no
    element across a region boundary (the region edges are constrained
    segments), so an element with a centroid in a ``BRIGHT`` region sees
    the whole light from every point and one in an ``UMBRA`` region sees
    none of it.

    Parameters
    ----------
    mesh : RadiosityMesh
        A mesh of ``discontinuity.scene``.
    discontinuity : SimplifiedDiscontinuity
        The scene's discontinuity phase.

    Returns
    -------
    (M, n_lights) int8
        ``BRIGHT``, ``PENUMBRA`` or ``UMBRA`` per element and light
        (:func:`~polygen.discontinuity.shadow.scene_lights` order);
        ``UNPROCESSED`` (0) on polygons that are no receiver (no complex),
        where a centroid falls in no face (it cannot, up to rounding) and
        where the light lies wholly behind the element's side (the
        complex's convention makes such a face bright; it receives nothing).
        On a two-sided receiver the element's side picks the columns.

    Raises
    ------
    MeshingError
        ``discontinuity`` not a :class:`SimplifiedDiscontinuity` of the mesh's scene.
    """
    import shapely

    if not isinstance(discontinuity, SimplifiedDiscontinuity) or discontinuity.scene is not mesh.scene:
        raise MeshingError("discontinuity must be simplified_discontinuity(scene) of the mesh's scene")
    n_lights = len(scene_lights(mesh.scene))
    out = np.zeros((mesh.n_elements, n_lights), np.int8)
    cen = mesh.element_centroid
    side = mesh.patch_side[mesh.element_patch]
    for k, cx in discontinuity.complexes.items():
        sel = np.flatnonzero(mesh.element_polygon == k)
        if not len(sel):
            continue
        uv = mesh.scene.polygons[k].to_2d(cen[sel])
        st = cx.face_states()
        back = cx.n_lights == 2 * n_lights
        for i, f in enumerate(cx.alive_faces):
            outer, holes = cx.face_rings(f)
            inside = shapely.contains_xy(shapely.Polygon(outer, holes), uv[:, 0], uv[:, 1])
            if not inside.any():
                continue
            rows = sel[inside]
            if back:
                out[rows] = np.where((side[rows] < 0)[:, None], st[i, n_lights:][None, :],
                                     st[i, :n_lights][None, :])
            else:
                out[rows] = st[i, :n_lights]
    # lights behind the element's side: no state
    nrm = mesh.element_normal
    for j, (kind, light, _) in enumerate(scene_lights(mesh.scene)):
        if kind == "area":
            d = np.einsum("ij,kj->ik", nrm, light.vertices) - np.einsum("ij,ij->i", nrm, cen)[:, None]
            behind = d.max(axis=1) <= 0.0
        elif kind == "point":
            behind = np.einsum("ij,ij->i", nrm, light.position - cen) <= 0.0
        else:
            behind = nrm @ light.direction >= 0.0
        out[behind, j] = 0
    return out


def conventional_discontinuity(scene, *, tol=1e-9, shadows=None):
    """The conventional method's segments and penumbra regions per receiver (2.4.3).

    Parameters
    ----------
    scene : Scene
    tol : float, keyword-only
        Relative tolerance (to the scene's size) of the shadow sections that
        choose each receiver's (light, occluder) pairs.
    shadows : SceneShadows, keyword-only, optional
        ``scene_sections(scene, solids=False)``, computed when not given.

    Returns
    -------
    segments : dict {polygon index: Segments}
        Every EV and VE critical segment on the receiver, split where two
        cross (the mesh model needs a planar graph), kinds D0 for point and
        parallel lights, D1 for area lights.
    penumbra_points : dict {polygon index: (R, 2) float64}
        A point in each region of those segments that lies in some light's
        penumbra section and in none of that light's umbra sections.
    counters : dict
        ``critical_surfaces`` generated, ``critical_segments`` before
        noding, ``regions`` of the segments.
    """
    import shapely

    from polygen.discontinuity.conventional import conventional_segments
    from polygen.radiosity._errors import MeshError
    from polygen.radiosity.layout import LAYOUT_TOL, polygon_layout

    if shadows is None:
        shadows = scene_sections(scene, solids=False, tol=tol)
    kinds_of_light = [kind for kind, _, _ in scene_lights(scene)]
    segments, pen_pts = {}, {}
    counters = dict(critical_surfaces=0, critical_segments=0, regions=0)
    for r in sorted(shadows.sections):
        R = scene.polygons[r]
        cs = conventional_segments(scene, r, shadows=shadows)
        counters["critical_surfaces"] += cs.surfaces
        counters["critical_segments"] += len(cs.segments)
        if not len(cs.segments):
            continue
        by_kind = {}
        for seg, (li, _, _) in zip(cs.segments, cs.sources):
            by_kind.setdefault("D1" if kinds_of_light[li] == "area" else "D0", []).append(seg)
        seg = lay = None
        failure = None
        # a segment ending a hair short of another (a T the mesh model sees as a crossing) is
        # retried with every segment extended by that hair, clipped to the receiver, and the
        # stubs the extension leaves dropped
        for ext in (0.0, 100.0, 1000.0):
            seg = _noded(by_kind, ext * LAYOUT_TOL * R.diameter, 10 * LAYOUT_TOL * R.diameter,
                         R._shape2d)
            if seg is None:
                break
            try:
                lay = polygon_layout(R, seg)
                break
            except MeshError as exc:
                failure = exc
        if seg is None:
            continue
        if lay is None:
            raise ShadowError(f"conventional segments on polygon {r} ({R.name!r}): {failure}") from None
        pts = lay.region_point
        counters["regions"] += len(pts)
        P = shapely.points(pts)
        pen = np.zeros(len(pts), bool)
        per_light = {}
        for s in shadows.of(r):
            if s.kind != "area":
                continue
            d = per_light.setdefault((s.light, s.side), [np.zeros(len(pts), bool), np.zeros(len(pts), bool)])
            for i, ring in enumerate((s.umbra, s.penumbra)):
                if len(ring) >= 3:
                    d[i] |= shapely.contains(shapely.Polygon(ring), P)
        for um, pn in per_light.values():
            pen |= pn & ~um
        segments[r] = seg
        pen_pts[r] = pts[pen]
    return segments, pen_pts, counters


def _noded(by_kind, ext, min_len, shape):
    """Segments split where they cross, shorter than ``min_len`` left out.

    With ``ext`` > 0 each segment is first extended by ``ext`` at both ends
    (then clipped to ``shape``), and pieces up to ``2 ext`` long dropped.

    Returns
    -------
    Segments or None
        None when nothing is left.
    """
    import shapely
    from shapely.ops import unary_union

    from polygen.radiosity.layout import Segments

    def line(s):
        s = np.asarray(s, dtype=np.float64)
        if ext > 0:
            d = s[1] - s[0]
            d = d / max(np.hypot(*d), 1e-300)
            s = np.array([s[0] - ext * d, s[1] + ext * d])
        return shapely.LineString(s)

    lines = [line(s) for v in by_kind.values() for s in v]
    noded = unary_union(lines)
    if ext > 0:
        noded = noded.intersection(shape)
        min_len = max(min_len, 2.0 * ext)
    d0 = by_kind.get("D0")
    d0 = unary_union([shapely.LineString(s) for s in d0]) if d0 else None
    ends, kinds = [], []
    for g in getattr(noded, "geoms", [noded]):
        if g.geom_type != "LineString":
            continue
        c = np.asarray(g.coords, dtype=np.float64)
        for a, b in zip(c[:-1], c[1:]):
            if np.hypot(*(b - a)) <= min_len:
                continue
            mid = shapely.Point(0.5 * (a + b))
            kinds.append("D0" if d0 is not None and d0.distance(mid) <= min_len else "D1")
            ends.append((a, b))
    if not ends:
        return None
    return Segments(np.asarray(ends).reshape(-1, 2, 2), kinds)
