"""Illumination states of the receiver's regions and the receiver's output to the mesh model.

(thesis 3.3.5, Fig. 3.10; 3.3.6, Figs 3.11, 3.14)

Every face of the receiver complex keeps one state per light: umbra 3,
penumbra 2, bright 1, unprocessed 0 (the thesis keeps the table on the
face's outer loop).  After a section is walked in and the loops rebuilt,
each face is tested against the section (its outer loop's vertices all
inside or on the convex section: the section's boundary is in the complex,
so a face is either wholly inside or wholly outside) and its state for the
section's light raised to umbra (an umbra section) or penumbra (a penumbra
section).  Unlike the thesis, which tests only the newly created outer
loops, every face whose bounding box fits in the section's is tested: a
face nested in a hole of a new face can lie inside a section without any
new edge touching it.

Combining the occluders of one light is the thesis's per-occluder rule: a
region inside *any* occluder's umbra is umbra; inside some penumbra and no
umbra it is penumbra.  Two occluders whose penumbrae overlap can hide the
whole light together where neither hides it alone: that region is umbra
in truth, and this rule calls it penumbra (the thesis's simplification;
it errs on the side of finer meshing).  One concave polygon is one occluder, not the
convex pieces it is split into: under an area light its umbra is the whole polygon's
(:mod:`~polygen.discontinuity.concave`, walked in as convex umbra-only sections), exact.

:func:`receiver_complex` runs the whole per-receiver phase and
:func:`discontinuity_segments` / :func:`region_size` hand the result to
:func:`polygen.radiosity.mesh_scene` (``segments=``, ``patch_size=``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from polygen.discontinuity.arrangement import arrangement_complex
from polygen.discontinuity.complex import (BOUNDARY, BRIGHT, D0, D1, PENUMBRA, UMBRA, UNPROCESSED, ComplexError,
                                           ReceiverComplex)
from polygen.discontinuity.loops import rebuild_loops
from polygen.discontinuity.walk import clean_ring, insert_section

__all__ = ["UNPROCESSED", "BRIGHT", "PENUMBRA", "UMBRA", "receiver_complex", "discontinuity_segments",
           "region_points", "region_size", "state_areas", "update_states", "SectionRecord"]


@dataclass(frozen=True)
class SectionRecord:
    """What happened when one section ring was walked in (``receiver_complex(record=True)``).

    Attributes
    ----------
    section : int
        Index of the section in ``sections``.
    light : int
    value : int
        ``UMBRA`` or ``PENUMBRA``: which ring of the section.
    ring : (k, 2) float64
        The ring walked (receiver frame, counter-clockwise).
    walk : list of WalkStep
        The intersection walk step by step (3.3.3, Fig. 3.9).
    loops : list of LoopStep
        The loops traced (3.3.4, Fig. 3.13).
    new_edges : list of int
        The discontinuity edges drawn, in walk order.
    table : dict {edge: [left loop, right loop]}
        The final left/right table.
    deleted : tuple of int
        The loops superseded.
    counters : dict
        The complex's counters spent on this ring (walk and loops).
    """

    section: int
    light: int
    value: int
    ring: np.ndarray
    walk: list
    loops: list
    new_edges: list
    table: dict
    deleted: tuple
    counters: dict

_D0_KINDS = ("point", "parallel")


def update_states(cx, ring, light, value):
    """Raise to ``value`` the state for ``light`` of every face inside the convex ``ring``.

    Parameters
    ----------
    cx : ReceiverComplex
    ring : (k, 2) float64
        Counter-clockwise, held coordinates (relative to ``cx.origin``).
    light : int
    value : int
        ``UMBRA`` or ``PENUMBRA``.

    Returns
    -------
    int
        Faces found inside.
    """
    eps = cx.eps
    lo = ring.min(axis=0) - eps
    hi = ring.max(axis=0) + eps
    fs = cx.alive_faces
    box = cx.loop_box[cx.face_outer[fs]]
    # faces already at least this dark for the light need no test
    fs = fs[(box[:, 0] >= lo[0]) & (box[:, 1] >= lo[1]) & (box[:, 2] <= hi[0]) & (box[:, 3] <= hi[1])
            & (cx.face_state[fs, light] < value)]
    n_in = 0
    for f in fs:
        cx.counters["state_tests"] += 1
        if _face_inside(cx, int(cx.face_outer[f]), ring, eps):
            cx.face_state[f, light] = value
            n_in += 1
    return n_in


def _face_inside(cx, o, ring, eps):
    """Whether the face with outer loop ``o`` lies inside the convex ``ring``.

    The section's boundary is in the complex, so a face is wholly inside or
    wholly outside: the first outer-loop vertex strictly inside or strictly
    outside decides; a loop with every vertex on the ring's boundary lies
    inside (its vertices are on a convex curve).
    """
    n = len(ring)
    for h in cx.loops[o]:
        v = cx.origin_of(h)
        px, py = cx.xy[v, 0], cx.xy[v, 1]
        worst = np.inf
        for i in range(n):
            ax, ay = ring[i]
            bx, by = ring[(i + 1) % n]
            dx, dy = bx - ax, by - ay
            d = (dx * (py - ay) - dy * (px - ax)) / math.hypot(dx, dy)
            if d < worst:
                worst = d
        if worst < -eps:
            return False
        if worst > eps:
            return True
    return True


def _as_section(s, i):
    if hasattr(s, "umbra") and hasattr(s, "penumbra"):
        return int(s.light), s.umbra, s.penumbra, getattr(s, "kind", "area")
    try:
        s = tuple(s)
    except TypeError:
        raise ComplexError(f"section {i}: expected (light, umbra, penumbra[, kind]) "
                           f"or a ShadowSection, got {type(s).__name__}") from None
    if len(s) not in (3, 4):
        raise ComplexError(f"section {i}: expected (light, umbra, penumbra[, kind]), got {len(s)} items")
    return int(s[0]), s[1], s[2], s[3] if len(s) == 4 else "area"


def receiver_complex(outer, holes=(), sections=(), *, n_lights=None, tol=1e-9, check=False, record=False):
    """The receiver complex of one polygon cut by its shadow sections, with illumination states.

    For each section in turn, its umbra and then its penumbra polygon is
    walked into the complex (3.3.3), the loops are rebuilt (3.3.4) and the
    faces' states updated (3.3.5); at the end a face still unprocessed for a
    light is bright for it.

    Parameters
    ----------
    outer : (K, 2) array_like
        The receiver's outer ring in its 2-D frame.
    holes : sequence of (K_h, 2) array_like
    sections : iterable
        :class:`~polygen.discontinuity.ShadowSection` objects or tuples
        ``(light, umbra (k, 2), penumbra (k', 2)[, kind])``: convex polygons
        in the receiver's frame, counter-clockwise, ``umbra`` inside
        ``penumbra``, either possibly empty (``(0, 2)``).  ``kind``
        ``"point"`` or ``"parallel"`` makes the edges D0 (Theorem 3.1),
        ``"area"`` (default) D1 (Theorem 3.2).
    n_lights : int, keyword-only, optional
        Width of the state table; default one more than the largest light index.
    tol : float, keyword-only
        Snapping tolerance relative to the receiver's extent.
    check : bool, keyword-only
        Verify every invariant (:meth:`ReceiverComplex.check`) after each
        loop update (slow; for tests).
    record : bool, keyword-only
        Keep every walk step and traced loop (``cx.records``: one
        :class:`SectionRecord` per ring walked in); off by default (no cost).

    Returns
    -------
    ReceiverComplex
        With ``timings`` (seconds: ``T_isr`` the walk less ``T_idd`` the
        segment-edge intersections inside it, ``T_lop`` loops, ``T_lit``
        states, ``T_chk`` the final verification) and ``counters``
        (``fallback`` 1 when the walk's complex failed its verification and
        the receiver was rebuilt by :func:`~polygen.discontinuity.arrangement.
        arrangement_complex`; ``fallback_reason`` then says why).

    Raises
    ------
    ComplexError
        A bad receiver (naming the ring), a section that is not a convex
        polygon or names a light outside ``n_lights`` (naming the section).
    """
    secs = [_as_section(s, i) for i, s in enumerate(sections)]
    if n_lights is None:
        n_lights = 1 + max((s[0] for s in secs), default=-1)
    cx = ReceiverComplex(outer, holes, n_lights=n_lights, tol=tol)
    timings = dict(T_isr=0.0, T_idd=0.0, T_lop=0.0, T_lit=0.0)
    box = np.array(cx.loop_box[0])
    rings = []
    failed = None
    cx.records = [] if record else None
    for i, (light, umbra, penumbra, kind) in enumerate(secs):
        if not 0 <= light < n_lights:
            raise ComplexError(f"section {i}: light {light} outside 0..{n_lights - 1}")
        ekind = D0 if kind in _D0_KINDS else D1
        for ring, value in ((umbra, UMBRA), (penumbra, PENUMBRA)):
            try:
                r = clean_ring(np.asarray(ring, dtype=np.float64).reshape(-1, 2) - cx.origin, cx.eps)
            except ComplexError as exc:
                raise ComplexError(f"section {i} ({'umbra' if value == UMBRA else 'penumbra'}): "
                                   f"{str(exc).removeprefix('section: ')}") from None
            if r is None:
                continue
            lo, hi = r.min(axis=0), r.max(axis=0)
            if np.any(lo > box[2:] + cx.eps) or np.any(hi < box[:2] - cx.eps):
                continue
            rings.append((light, value, r + cx.origin, ekind))
            if failed is not None:
                continue
            try:
                walk, traced = ([], []) if record else (None, None)
                c0 = dict(cx.counters)
                t0 = time.perf_counter()
                new, edge_face, snapped = insert_section(cx, r, ekind, record=walk)
                t1 = time.perf_counter()
                table, _, deleted = rebuild_loops(cx, new, edge_face, snapped, record=traced)
                t2 = time.perf_counter()
                if record:
                    cx.records.append(SectionRecord(
                        section=i, light=light, value=value, ring=r + cx.origin, walk=walk, loops=traced,
                        new_edges=list(new), table=table, deleted=tuple(sorted(deleted)),
                        counters={k: cx.counters[k] - c0[k] for k in c0}))
                update_states(cx, r, light, value)
                t3 = time.perf_counter()
                if check:
                    cx.check()
            except ComplexError as exc:
                failed = exc
                continue
            timings["T_isr"] += t1 - t0
            timings["T_lop"] += t2 - t1
            timings["T_lit"] += t3 - t2
            cx.counters["sections"] += 1
    t0 = time.perf_counter()
    if failed is None and not check:
        try:
            cx.check()
        except ComplexError as exc:
            failed = exc
    timings["T_chk"] = time.perf_counter() - t0
    if failed is not None:
        # degenerate at the tolerance's scale: rebuild from all sections at once
        t0 = time.perf_counter()
        counters, t_idd = dict(cx.counters), cx.t_idd
        cx = arrangement_complex(outer, holes, rings, n_lights=n_lights, tol=tol)
        cx.counters.update({k: v for k, v in counters.items() if k != "fallback"}, fallback=1)
        cx.t_idd = t_idd
        cx.fallback_reason = str(failed)
        cx.records = None  # the walk's records described the complex just discarded
        timings["T_lop"] += time.perf_counter() - t0
    fs = cx.face_state[:cx.nf]
    fs[fs == UNPROCESSED] = BRIGHT
    # the walk interleaves both: T_idd is the time in the segment-edge intersection kernel
    timings["T_idd"] = cx.t_idd
    timings["T_isr"] -= cx.t_idd
    cx.timings = timings
    return cx


def discontinuity_segments(cx, *, min_length=None, state_boundaries_only=False):
    """The complex's discontinuity edges as :class:`~polygen.radiosity.layout.Segments`.

    Parameters
    ----------
    cx : ReceiverComplex
    min_length : float, keyword-only, optional
        Edges this short or shorter are left out.  Default: the mesh model's
        own tolerance (:data:`polygen.radiosity.layout.LAYOUT_TOL` times the
        polygon's extent), below which it rejects a segment and merges its
        end points anyway, so leaving it out changes nothing there.
    state_boundaries_only : bool, keyword-only
        Only edges between faces whose states differ for some light (the
        boundaries 3.3 names: bright/penumbra, penumbra/umbra, bright/umbra);
        an edge with the same states on both sides -- two occluders' umbrae
        or penumbrae overlapping, as the 180 faces of a sphere taken one by
        one make by the thousand -- is left out.

    Returns
    -------
    Segments
        ``ends (S, 2, 2)`` in the receiver's frame (every discontinuity edge,
        split at every vertex, so that no two cross), ``kinds`` "D0" for the
        boundaries of point and parallel lights' shadows, "D1" otherwise.
    """
    from polygen.radiosity.layout import LAYOUT_TOL, Segments

    if min_length is None:
        min_length = LAYOUT_TOL * cx.extent
    k = cx.ekind[:cx.ne]
    ev = cx.ev[:cx.ne]
    xy = cx.vertices
    d = xy[ev[:, 1]] - xy[ev[:, 0]]
    keep = (k != BOUNDARY) & (np.hypot(d[:, 0], d[:, 1]) > min_length)
    if state_boundaries_only:
        lp = cx.edge_loops
        lf = np.asarray(cx.loop_face, dtype=np.int64)
        both = (lp >= 0).all(axis=1)
        f = np.where(lp >= 0, lf[np.maximum(lp, 0)], -1)
        same = both & np.all(cx.face_state[f[:, 0]] == cx.face_state[f[:, 1]], axis=1)
        keep &= ~same
    sel = np.flatnonzero(keep)
    ends = xy[ev[sel]].reshape(-1, 2, 2)
    return Segments(ends, ["D0" if k[e] == D0 else "D1" for e in sel])


def region_points(cx):
    """(F, 2) float64: a point inside each alive face (receiver frame), in ``alive_faces`` order."""
    return cx.interior_points()


def state_areas(cx):
    """The area of the receiver in each state, per light column.

    Returns
    -------
    (n_lights, 4) float64
        ``[light, state]``: the summed area of the faces in ``state``
        (``UNPROCESSED``, ``BRIGHT``, ``PENUMBRA``, ``UMBRA``) for that
        column of the state table.
    """
    import shapely

    st = cx.face_states()
    out = np.zeros((st.shape[1], 4))
    for i, f in enumerate(cx.alive_faces):
        outer, holes = cx.face_rings(f)
        a = shapely.Polygon(outer, holes).area
        out[np.arange(st.shape[1]), st[i]] += a
    return out


def region_size(cx, size, penumbra_size):
    """A :class:`~polygen.radiosity.layout.RegionSize`: ``penumbra_size`` in faces that are
    penumbra for at least one light, ``size`` elsewhere (3.3.6, step 1).

    Parameters
    ----------
    cx : ReceiverComplex
    size, penumbra_size : number, callable or GridSize

    Returns
    -------
    RegionSize
        Keyed on a point inside each face (``at=``), so it resolves against
        :func:`~polygen.radiosity.polygon_layout`'s own region numbering.
    """
    from polygen.radiosity.layout import RegionSize

    st = cx.face_states()
    pen = np.any(st == PENUMBRA, axis=1) if st.size else np.zeros(len(st), bool)
    return RegionSize([penumbra_size if p else size for p in pen], at=region_points(cx), default=size)
