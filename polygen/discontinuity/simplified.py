"""Simplified discontinuity meshing of a whole scene (thesis Fig. 3.5): the discontinuity phase.

:func:`simplified_discontinuity` runs, for a scene, the shadow polyhedra of
every (light, occluder) pair and their sections on the receivers
(:func:`~polygen.discontinuity.shadow.scene_sections`), then per receiver
the receiver complex with its illumination states
(:func:`~polygen.discontinuity.states.receiver_complex`), and hands the
result to the mesh model: per polygon the discontinuity lines as
:class:`~polygen.radiosity.layout.Segments` (``mesh_scene(..., segments=)``)
and a :class:`~polygen.radiosity.layout.RegionSize` giving a smaller size in
the regions that are penumbra for at least one light (3.3.6, step 1).

The phases are timed as Table 3.2 names them: ``T_sdw`` shadow polyhedra;
``T_isr`` shadow polyhedra against receivers (the scene index, the sections
and the walk's own bookkeeping); ``T_idd`` discontinuity edges against
each other (the walk's segment-edge intersection kernel); ``T_lop`` loops;
``T_lit`` illumination states; ``T_div`` the division of the receivers into
regions (segments and region points for the mesh model).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from polygen.discontinuity.illumination import point_states
from polygen.discontinuity.shadow import ShadowError, scene_lights, scene_sections
from polygen.discontinuity.states import PENUMBRA, discontinuity_segments, receiver_complex, region_points

__all__ = ["SimplifiedDiscontinuity", "illumination", "simplified_discontinuity"]


@dataclass(frozen=True, eq=False)
class SimplifiedDiscontinuity:
    """The discontinuity phase of a scene.

    Attributes
    ----------
    scene : Scene
    complexes : dict {polygon index: ReceiverComplex}
        One per receiver that has sections.  Its state table has one column
        per light (:func:`~polygen.discontinuity.shadow.scene_lights` order);
        a two-sided receiver has twice as many, the back face's after the
        front face's (both faces share one mesh, so one complex holds the
        lines of both).
    segments : dict {polygon index: Segments}
        The discontinuity lines per receiver, in its (u, v) frame.
    penumbra_points : dict {polygon index: (R, 2) float64}
        A point inside every region that is penumbra for at least one light.
    other_points : dict {polygon index: (R', 2) float64}
        A point inside every other region.
    counters : dict
        The receivers' counters summed (``point_in_loop``, ``edge_tests``,
        ``splits``, ``loops_traced``, ``fallback`` ...), the shadow driver's
        (``polyhedra``, ``sections`` ...), ``receivers``, ``regions``,
        ``discontinuity_edges``.
    timings : dict
        Seconds per phase: ``T_sdw``, ``T_isr``, ``T_idd``, ``T_lop``,
        ``T_lit``, ``T_div``; and ``T_chk``, the verification of every
        complex (not a phase of the thesis).
    """

    scene: object
    complexes: dict
    segments: dict
    penumbra_points: dict
    other_points: dict
    counters: dict
    timings: dict

    def illumination(self, points, **kwargs):
        """Each point's state per light, and its visible fractions when asked:
        :func:`illumination` of this phase."""
        return point_states(self, points, **kwargs)

    def region_sizes(self, size, penumbra_size):
        """Per polygon the ``patch_size`` for :func:`~polygen.radiosity.mesh_scene`.

        Parameters
        ----------
        size, penumbra_size : number, callable or GridSize

        Returns
        -------
        list
            A :class:`~polygen.radiosity.layout.RegionSize` for receivers
            with a penumbra region (``penumbra_size`` there, ``size``
            elsewhere), ``size`` for the other polygons.
        """
        from polygen.radiosity.layout import RegionSize

        out = []
        for k in range(len(self.scene.polygons)):
            pen = self.penumbra_points.get(k)
            if pen is None or not len(pen):
                out.append(size)
            else:
                out.append(RegionSize([penumbra_size] * len(pen), at=pen, default=size))
        return out


def simplified_discontinuity(scene, *, solids=True, concave="exact", tol=1e-9, use_index=True,
                             margin=0.05, check=False, state_boundaries_only=False):
    """Shadow polyhedra, receiver complexes and illumination states for a whole scene.

    Parameters
    ----------
    scene : Scene
    solids : bool or sequence of sequence of int, keyword-only
        Closed convex solids as one occluder each (True: found from the
        geometry; a sequence: declared polygon groups; False: every polygon
        its own occluder).  Passed to
        :func:`~polygen.discontinuity.shadow.scene_sections`.
    concave : {"exact", "pieces"}, keyword-only
        A concave occluder's umbra under an area light: the whole
        polygon's (default, exact) or its convex pieces' (the thesis's
        3.3.1, which calls penumbra what the whole hides but no piece
        does).  Passed to :func:`~polygen.discontinuity.shadow.scene_sections`.
    tol : float, keyword-only
        Relative tolerance of the shadow polyhedra (to the scene's size) and
        of the receiver complexes (to each receiver's size).
    use_index : bool, keyword-only
        Find the receivers of each shadow polyhedron with the scene's
        bounding-volume hierarchy (False: every receiver, the thesis's O(n^2)).
    margin : float, keyword-only
        Passed to :func:`~polygen.discontinuity.shadow.scene_sections`.
    check : bool, keyword-only
        Verify every complex after each loop update (slow; for tests).
    state_boundaries_only : bool, keyword-only
        Hand the mesh model only the edges between regions of different
        states (:func:`~polygen.discontinuity.states.discontinuity_segments`);
        the regions keep their states, and a region's penumbra size reaches
        the mesh model through its point as before.

    Returns
    -------
    SimplifiedDiscontinuity
    """
    sh = scene_sections(scene, solids=solids, concave=concave, use_index=use_index, margin=margin,
                        tol=tol)
    n_lights = len(scene_lights(scene))
    timings = dict(T_sdw=sh.timings["t_sdw"], T_isr=sh.timings["t_isr"], T_idd=0.0, T_lop=0.0,
                   T_lit=0.0, T_div=0.0, T_chk=0.0)
    counters = dict(sh.counters)
    complexes, segments, pen_pts, other_pts = {}, {}, {}, {}
    for r in sorted(sh.sections):
        poly = scene.polygons[r]
        two = poly.two_sided
        secs = [(s.light + (n_lights if s.side < 0 else 0), s.umbra, s.penumbra, s.kind)
                for s in sh.sections[r]]
        cx = receiver_complex(poly.exterior_2d, poly.holes_2d, secs,
                              n_lights=n_lights * (2 if two else 1), tol=tol, check=check)
        for k in ("T_isr", "T_idd", "T_lop", "T_lit", "T_chk"):
            timings[k] += cx.timings[k]
        for k, v in cx.counters.items():
            counters[k] = counters.get(k, 0) + v
        t0 = time.perf_counter()
        segments[r] = discontinuity_segments(cx, state_boundaries_only=state_boundaries_only)
        pts = region_points(cx)
        pen = np.any(cx.face_states() == PENUMBRA, axis=1)
        pen_pts[r], other_pts[r] = pts[pen], pts[~pen]
        timings["T_div"] += time.perf_counter() - t0
        complexes[r] = cx
        counters["discontinuity_edges"] = counters.get("discontinuity_edges", 0) + len(segments[r])
        counters["regions"] = counters.get("regions", 0) + len(pts)
    counters["receivers"] = len(complexes)
    return SimplifiedDiscontinuity(scene, complexes, segments, pen_pts, other_pts, counters, timings)


def illumination(scene, points, *, discontinuity=None, polygons=None, sides=None, fraction=False,
                 concave="exact", tol=1e-9):
    """The illumination state of points on receivers, per light (umbra, penumbra or bright).

    Parameters
    ----------
    scene : Scene or SimplifiedDiscontinuity
        A scene (its discontinuity phase is computed, or ``discontinuity``
        used) or the phase itself.
    points : (N, 3) float64
    discontinuity : SimplifiedDiscontinuity, keyword-only, optional
    concave : {"exact", "pieces"}, keyword-only
        When the phase is computed here: passed to
        :func:`simplified_discontinuity` (a concave occluder's umbra exact, or
        its convex pieces' as the thesis).
    polygons, sides, fraction, tol : keyword-only
        See :func:`~polygen.discontinuity.illumination.point_states`.

    Returns
    -------
    states : (N, n_lights) int8
        ``UMBRA`` 3, ``PENUMBRA`` 2, ``BRIGHT`` 1; 0 where the light lies
        behind the point's face or the point is on no polygon.
    fractions : (N, n_lights) float64
        With ``fraction=True``: the visible part of each light (1 bright, 0 umbra).
    """
    if isinstance(scene, SimplifiedDiscontinuity):
        sd = scene
    else:
        sd = (discontinuity if discontinuity is not None
              else simplified_discontinuity(scene, concave=concave, tol=tol))
        if sd.scene is not scene:
            raise ShadowError("discontinuity must be simplified_discontinuity(scene) of this scene")
    return point_states(sd, points, polygons=polygons, sides=sides, fraction=fraction, tol=tol)
