"""Loop rebuilding after a section has been walked in (thesis 3.3.4, Fig. 3.13).

Every new discontinuity edge gets a two-column table, *left* and *right*,
empty at first (Fig. 3.13(2)).  While the table has an empty cell, a loop
is traced from that edge side: at each vertex the walk turns onto the edge
making the smallest angle with the edge it arrived on (the first edge
clockwise from the way back, so the region stays on the loop's left), until
it returns to the starting edge; the loop's number is written into the
table cells of the new edges it used, and every *existing* loop that held
one of the existing edges it traversed in the same direction is deleted
(step 4).  Loops that no new edge touches survive unchanged.  Finally the
orientation decides (step 7): a counter-clockwise loop is the outer loop of
a new face, a clockwise one a hole, given to the smallest outer loop around
it (by a point-in-loop test of a point on the hole's boundary).  A new face
inherits the illumination states of the face it was cut from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from polygen.discontinuity.complex import ComplexError
from polygen.discontinuity.walk import _in_ring, _ring, _segments

__all__ = ["rebuild_loops", "LoopStep"]


@dataclass(frozen=True)
class LoopStep:
    """One loop traced by :func:`rebuild_loops` (Fig. 3.13 steps 3-5), recorded with ``record=``.

    Coordinates are in the receiver's 2-D frame.

    Attributes
    ----------
    loop : int
        The new loop's number.
    seed : tuple (edge, side)
        The table cell it started from: a new edge and ``0`` (left: the edge
        traversed from its first vertex to its second) or ``1`` (right).
    path : (k, 2) float64
        The loop's vertices in tracing order.
    half_edges : tuple of int
        Its half-edges (``2 * edge + side``).
    turns : tuple of (vertex (2,), degree, options)
        At each vertex with three or more edges (a junction), where the
        trace turned: the vertex, its number of edges, and ``options`` the
        (k, 2) far ends of the edges it could have turned onto (the chosen
        one is the next point of ``path``).
    deleted : tuple of int
        Existing loops this trace superseded (an existing edge of theirs
        traversed in the same direction).
    table : dict {edge: [left, right]}
        The left/right table after this loop was written in (-1: empty).
    area : float
        Signed area: > 0 counter-clockwise (an outer loop), < 0 a hole.
    edges : (E, 2, 2) float64
        Every edge of the complex (for drawing).
    """

    loop: int
    seed: tuple
    path: np.ndarray
    half_edges: tuple
    turns: tuple
    deleted: tuple
    table: dict
    area: float
    edges: np.ndarray


def _next_half(cx, h, stars=None):
    """The half-edge after ``h`` in its loop: the smallest clockwise turn from the way back.

    ``stars`` caches, per vertex, its outgoing half-edges in counter-clockwise
    order (the complex drops a vertex's entry when an edge is added or split
    there): the next half-edge is the one before the way back in that order.
    """
    v = cx.dest_of(h)
    star = None if stars is None else stars.get(v)
    if star is None:
        px, py = cx.xy[v].tolist()
        outs = []
        for e in cx.vedges[v]:
            a, b = cx.ev[e].tolist()
            g, w = (2 * e, b) if a == v else (2 * e + 1, a)
            wx, wy = cx.xy[w].tolist()
            outs.append((math.atan2(wy - py, wx - px), g))
        outs.sort()
        order = [g for _, g in outs]
        star = (order, {g: i for i, g in enumerate(order)})
        if stars is not None:
            stars[v] = star
    order, pos = star
    return order[pos[h ^ 1] - 1]


def rebuild_loops(cx, new, edge_face, snapped=(), *, record=None):
    """Trace the loops through the new edges, delete the loops they supersede, sort out faces.

    Parameters
    ----------
    cx : ReceiverComplex
    new : list of int
        New discontinuity edges (from :func:`~polygen.discontinuity.walk.insert_section`).
    edge_face : dict {edge: face}
        The face each new edge was drawn in.
    snapped : sequence of int
        Existing edges bent through a vertex by the walk (snap rounding):
        a loop through them may be pinched in two, so they are retraced too.

    Returns
    -------
    table : dict {edge: [left loop, right loop]}
        The left/right table of Fig. 3.13.
    created : list of int
        The new loops.
    deleted : set of int
        The loops superseded.

    Other Parameters
    ----------------
    record : list, optional
        When given, one :class:`LoopStep` per traced loop is appended (off
        by default: no cost).
    """
    first_new = len(cx.loops)
    newset = set(new)
    table = {e: [-1, -1] for e in new}
    created, deleted, origin = [], set(), {}
    stars = cx.stars
    limit = 2 * cx.ne + 4
    seeds = [2 * e + d for e in new for d in (0, 1)] + [2 * e + d for e in snapped for d in (0, 1)]
    for h0 in seeds:
        e = h0 >> 1
        if cx.hloop[h0] >= first_new or (e not in newset and cx.hloop[h0] < 0):
            continue
        lid = len(cx.loops)
        cx.loops.append(None)
        h = h0
        hs = []
        src = -1
        gone = []
        while True:
            old = cx.hloop[h]
            if old >= first_new:
                raise ComplexError(f"loop rebuilding: half-edge {h} traced twice")
            if old >= 0:
                if record is not None and old not in deleted:
                    gone.append(int(old))
                deleted.add(old)
                if src < 0:
                    src = cx.loop_face[old]
            elif (h >> 1) not in newset:
                raise ComplexError(f"loop rebuilding: reached the outside of the receiver at edge {h >> 1}")
            else:
                table[h >> 1][h & 1] = lid
            cx.hloop[h] = lid
            hs.append(h)
            h = _next_half(cx, h, stars)
            if h == h0:
                break
            if len(hs) > limit:
                raise ComplexError("loop rebuilding: a loop does not close")
        cx.loops.pop()
        cx._new_loop(hs, -1)
        if record is not None:
            record.append(_loop_step(cx, lid, h0, hs, gone, table))
        created.append(lid)
        origin[lid] = src if src >= 0 else edge_face[e]
        cx.counters["loops_traced"] += 1
    if not created:
        return table, created, deleted
    # faces touched: those of the deleted loops and those the new edges were drawn in
    touched = {cx.loop_face[lp] for lp in deleted} | set(edge_face.values())
    pending, candidates = [], []
    for f in sorted(touched):
        if f < 0 or cx.face_outer[f] < 0:
            continue
        pending.extend(h for h in cx.face_holes[f] if h not in deleted)
        cx.face_holes[f] = []
        if cx.face_outer[f] in deleted:
            cx.face_outer[f] = -1
        else:
            candidates.append(f)
    for lp in deleted:
        cx.loops[lp] = None
        cx.counters["loops_deleted"] += 1
    for lp in created:
        if cx.loop_area[lp] > 0:
            f = cx._new_face(cx.face_state[origin[lp]])
            cx.face_outer[f] = lp
            cx.loop_face[lp] = f
            candidates.append(f)
        else:
            pending.append(lp)
    for lp in pending:
        h = cx.loops[lp][0]
        a, b = cx.xy[cx.origin_of(h)], cx.xy[cx.dest_of(h)]
        mx, my = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])
        other = cx.hloop[h ^ 1]
        best, best_a = -1, math.inf
        for f in candidates:
            o = cx.face_outer[f]
            if o == other or cx.loop_area[o] >= best_a:
                continue
            bx = cx.loop_box[o]
            if not (bx[0] <= mx <= bx[2] and bx[1] <= my <= bx[3]):
                continue
            cx.counters["point_in_loop"] += 1
            if _in_ring(cx.xy, _ring(cx, o), mx, my):
                best, best_a = f, cx.loop_area[o]
        if best < 0:
            raise ComplexError(f"loop rebuilding: no outer loop around hole loop {lp}")
        cx.face_holes[best].append(lp)
        cx.loop_face[lp] = best
    return table, created, deleted


def _loop_step(cx, lid, h0, hs, gone, table):
    path = np.array([cx.xy[cx.origin_of(h)] for h in hs]) + cx.origin
    turns = []
    for h in hs:
        v = cx.origin_of(h)
        if len(cx.vedges[v]) >= 3:
            far = [int(cx.ev[e, 1] if cx.ev[e, 0] == v else cx.ev[e, 0]) for e in cx.vedges[v]]
            turns.append((cx.xy[v] + cx.origin, len(cx.vedges[v]), cx.xy[far] + cx.origin))
    return LoopStep(loop=int(lid), seed=(int(h0 >> 1), int(h0 & 1)), path=path, half_edges=tuple(hs),
                    turns=tuple(turns), deleted=tuple(gone), table={e: list(v) for e, v in table.items()},
                    area=float(cx.loop_area[lid]), edges=_segments(cx))
