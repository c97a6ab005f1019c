"""The intersection walk of a shadow section through the receiver complex (thesis 3.3.3, Fig. 3.9).

A section's boundary (a convex polygon in the receiver's frame, the
intersection of a shadow polyhedron with the receiver's plane) is walked
edge by edge.  Its first vertex is located once by point-in-loop tests;
from then on the walk knows which face (outer loop and holes) the current
point lies in and intersects the current section edge with **that face's
edges only**: where it leaves the face across an edge, the edge is split,
a new discontinuity edge ends there and the walk continues in the face on
the other side (Fig. 3.9, steps 3-4); where the next section vertex lies in
the same face, the edge is drawn directly (step 5).  Through an existing
vertex the next face is the angular sector the section edge enters; along
an existing edge (a section edge lying on a ring edge or on an earlier
discontinuity edge) no edge is added, the existing one is followed (and a
D1 edge becomes D0 when a D0 line runs along it).  Outside the receiver
the walk tests the ring edges and adds nothing.

The loops are not rebuilt during the walk (the new edges of one convex
section never cross each other); :func:`polygen.discontinuity.loops.
rebuild_loops` does that afterwards (3.3.4).  Hot loops (segment against a
face's edges, point in loop) are numba kernels.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from polygen._jit import njit
from polygen.discontinuity.complex import BOUNDARY, D0, ComplexError

__all__ = ["insert_section", "locate_point", "clean_ring", "WalkStep"]

_NONE, _VERTEX, _EDGE, _SNAP, _NEAR_VERTEX = 0, 1, 2, 3, 4
_HIT_NAMES = {_NONE: "none", _VERTEX: "vertex", _EDGE: "edge", _SNAP: "snap", _NEAR_VERTEX: "near-vertex"}


@dataclass(frozen=True)
class WalkStep:
    """One step of the intersection walk (Fig. 3.9), recorded with ``record=``.

    Coordinates are in the receiver's 2-D frame (``cx.vertices``'s).

    Attributes
    ----------
    kind : str
        ``"locate"`` (the section's first vertex located by point-in-loop
        tests), ``"segment"`` (the current section edge intersected with the
        current face's edges) or ``"follow"`` (the section edge runs along an
        existing edge: no test, the edge is followed).
    point : (2,) float64
        The current point (where the step starts).
    target : (2,) float64
        The section vertex the walk heads for (``kind="locate"``: the point).
    face : int
        The face the current point lies in (its outer loop: ``loop``);
        -1 outside the receiver.
    loop : int
        That face's outer loop (-1 outside).
    loops_tested : tuple of int
        Loops tested by point-in-loop tests in this step (one count each in
        ``counters["point_in_loop"]``).
    tested : (k,) int64
        Edges intersected with the section edge in this step (``k`` counted
        in ``counters["edge_tests"]``).
    tested_segments : (k, 2, 2) float64
        Their end points at the time of the test.
    hit : str
        What the nearest hit was: ``"none"`` (the section vertex lies in the
        face), ``"vertex"``, ``"edge"`` (an edge crossed and split),
        ``"snap"``, ``"follow"``; for ``"locate"``: ``"face"``, ``"vertex"``,
        ``"edge"`` or ``"outside"``.
    crossing : (2,) float64 or None
        The crossing (or vertex) found.
    drawn : (2, 2) float64 or None
        The discontinuity edge drawn in this step.
    edges : (E, 2, 2) float64
        Every edge of the complex when the step began (for drawing).
    """

    kind: str
    point: np.ndarray
    target: np.ndarray
    face: int
    loop: int
    loops_tested: tuple
    tested: np.ndarray
    tested_segments: np.ndarray
    hit: str
    crossing: np.ndarray | None
    drawn: np.ndarray | None
    edges: np.ndarray


def _segments(cx, ids=None):
    ev = cx.ev[:cx.ne] if ids is None else cx.ev[np.asarray(ids, dtype=np.int64)]
    return cx.xy[ev] + cx.origin


def _step(cx, kind, point, target, face, loops_tested, tested, hit, crossing, drawn, edges):
    tested = np.asarray(tested, dtype=np.int64)
    loop = int(cx.face_outer[face]) if face >= 0 else -1
    return WalkStep(kind=kind, point=np.asarray(point, float) + cx.origin,
                    target=np.asarray(target, float) + cx.origin, face=int(face), loop=loop,
                    loops_tested=tuple(loops_tested), tested=tested,
                    tested_segments=_segments(cx, tested) if len(tested) else np.zeros((0, 2, 2)),
                    hit=hit, crossing=None if crossing is None else np.asarray(crossing, float) + cx.origin,
                    drawn=None if drawn is None else np.asarray(drawn, float) + cx.origin, edges=edges)


@njit
def _nearest_hit(xy, ev, edges, cur_v, cx, cy, qx, qy, eps):
    """Nearest feature met by the segment c -> q among ``edges``: (kind, index, s, px, py).

    kind 0: none; 1: a vertex at distance ``s`` along the segment; 2: the
    interior of an edge, crossed (or touched by q) at (px, py).
    """
    dx = qx - cx
    dy = qy - cy
    L = math.sqrt(dx * dx + dy * dy)
    ux = dx / L
    uy = dy / L
    bv_s = np.inf
    bv = -1
    be_s = np.inf
    be = -1
    bex = 0.0
    bey = 0.0
    for k in range(edges.shape[0]):
        e = edges[k]
        a = ev[e, 0]
        b = ev[e, 1]
        if a == cur_v or b == cur_v:
            continue
        ax = xy[a, 0]
        ay = xy[a, 1]
        bx = xy[b, 0]
        by = xy[b, 1]
        if cur_v >= 0:
            # an edge passing within eps of the current vertex: it must go through it first
            if (ax - cx) ** 2 + (ay - cy) ** 2 <= eps * eps:
                return _NEAR_VERTEX, a, 0.0, ax, ay
            if (bx - cx) ** 2 + (by - cy) ** 2 <= eps * eps:
                return _NEAR_VERTEX, b, 0.0, bx, by
            ex = bx - ax
            ey = by - ay
            t = ((cx - ax) * ex + (cy - ay) * ey) / (ex * ex + ey * ey)
            if 0.0 < t < 1.0 and (ax + t * ex - cx) ** 2 + (ay + t * ey - cy) ** 2 <= eps * eps:
                return _SNAP, e, 0.0, cx, cy
        da = ux * (ay - cy) - uy * (ax - cx)
        sa = ux * (ax - cx) + uy * (ay - cy)
        db = ux * (by - cy) - uy * (bx - cx)
        sb = ux * (bx - cx) + uy * (by - cy)
        # a vertex within eps of the segment
        if abs(da) <= eps and sa > eps and sa <= L + eps and sa < bv_s:
            bv_s = sa
            bv = a
        if abs(db) <= eps and sb > eps and sb <= L + eps and sb < bv_s:
            bv_s = sb
            bv = b
        if (da > eps and db < -eps) or (da < -eps and db > eps):
            # a proper crossing of the edge's interior
            t = da / (da - db)
            px = ax + t * (bx - ax)
            py = ay + t * (by - ay)
            s = ux * (px - cx) + uy * (py - cy)
            if s > eps and s <= L + eps and s < be_s:
                if (px - ax) ** 2 + (py - ay) ** 2 <= eps * eps:
                    if s < bv_s:
                        bv_s = s
                        bv = a
                elif (px - bx) ** 2 + (py - by) ** 2 <= eps * eps:
                    if s < bv_s:
                        bv_s = s
                        bv = b
                else:
                    be_s = s
                    be = e
                    bex = px
                    bey = py
        if L < be_s:
            # q itself within eps of the edge's interior (also when the lines cross past q)
            ex = bx - ax
            ey = by - ay
            le2 = ex * ex + ey * ey
            t = ((qx - ax) * ex + (qy - ay) * ey) / le2
            le = math.sqrt(le2)
            if t * le > eps and (1.0 - t) * le > eps:
                px = ax + t * ex
                py = ay + t * ey
                if (qx - px) ** 2 + (qy - py) ** 2 <= eps * eps and L < be_s:
                    be_s = L
                    be = e
                    bex = px
                    bey = py
    if bv >= 0 and bv_s <= be_s + eps:
        return _VERTEX, bv, bv_s, xy[bv, 0], xy[bv, 1]
    if be >= 0:
        return _EDGE, be, be_s, bex, bey
    return _NONE, -1, 0.0, 0.0, 0.0


@njit
def _nearest_feature(xy, ev, edges, px, py, eps):
    """A vertex or an edge interior within eps of p among ``edges``: (kind, index, x, y)."""
    best_e = -1
    bx_ = 0.0
    by_ = 0.0
    best_d = np.inf
    for k in range(edges.shape[0]):
        e = edges[k]
        for j in range(2):
            v = ev[e, j]
            d = (xy[v, 0] - px) ** 2 + (xy[v, 1] - py) ** 2
            if d <= eps * eps:
                return _VERTEX, v, xy[v, 0], xy[v, 1]
        a = ev[e, 0]
        b = ev[e, 1]
        ex = xy[b, 0] - xy[a, 0]
        ey = xy[b, 1] - xy[a, 1]
        le2 = ex * ex + ey * ey
        t = ((px - xy[a, 0]) * ex + (py - xy[a, 1]) * ey) / le2
        if 0.0 < t < 1.0:
            qx = xy[a, 0] + t * ex
            qy = xy[a, 1] + t * ey
            d = (qx - px) ** 2 + (qy - py) ** 2
            if d <= eps * eps and d < best_d:
                best_d = d
                best_e = e
                bx_ = qx
                by_ = qy
    if best_e >= 0:
        return _EDGE, best_e, bx_, by_
    return _NONE, -1, 0.0, 0.0


@njit
def _in_ring(xy, ring, px, py):
    """Crossing-number test of p against the polygon through ``xy[ring]``."""
    inside = False
    n = ring.shape[0]
    j = n - 1
    for i in range(n):
        xi = xy[ring[i], 0]
        yi = xy[ring[i], 1]
        xj = xy[ring[j], 0]
        yj = xy[ring[j], 1]
        if (yi > py) != (yj > py):
            x = xi + (py - yi) * (xj - xi) / (yj - yi)
            if px < x:
                inside = not inside
        j = i
    return inside


def clean_ring(ring, eps):
    """A convex ring without repeated or collinear vertices (counter-clockwise), or None if degenerate.

    Raises
    ------
    ComplexError
        Not finite, or not convex.
    """
    r = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(r)):
        raise ComplexError("section: non-finite coordinates")
    if len(r) < 3:
        return None
    x, y = r[:, 0] - r[0, 0], r[:, 1] - r[0, 1]
    if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:
        r = r[::-1]
    changed = True
    while changed and len(r) >= 3:
        changed = False
        n = len(r)
        keep = np.ones(n, bool)
        for i in range(n):
            p, q, s = r[i - 1], r[i], r[(i + 1) % n]
            d = s - p
            ln = math.hypot(*d)
            if math.hypot(*(q - p)) <= eps or (ln > 0 and abs(d[0] * (q[1] - p[1]) - d[1] * (q[0] - p[0])) / ln <= eps
                                               and np.dot(q - p, s - q) >= 0):
                keep[i] = False
                changed = True
                break
        r = r[keep]
    if len(r) < 3:
        return None
    d1 = np.roll(r, -1, axis=0) - r
    cr = d1[:, 0] * np.roll(d1, -1, axis=0)[:, 1] - d1[:, 1] * np.roll(d1, -1, axis=0)[:, 0]
    ln = np.hypot(d1[:, 0], d1[:, 1])
    # reflex by more than round-off (1e-6 of the ring's size) is not convex; less is tolerated
    slack = max(eps, 1e-6 * float(np.ptp(r, axis=0).max()))
    if np.any(cr < -slack * (ln + np.roll(ln, -1))):
        raise ComplexError("section: not a convex polygon")
    return np.ascontiguousarray(r)


def locate_point(cx, p, *, record=None):
    """Where point ``p`` (held coordinates) lies: ``("v", v)``, ``("e", e, (x, y))``, ``("f", f)`` or ``("o",)``.

    Faces are tried by point-in-loop tests on their outer loops and holes
    (each test counted in ``cx.counters["point_in_loop"]``), skipping loops
    whose bounding box misses the point; then the face's edges are checked
    for a vertex or edge within ``eps``.  With ``record`` (a list) a
    ``"locate"`` :class:`WalkStep` is appended.
    """
    snap = _segments(cx) if record is not None else None
    tested_loops = []
    px, py = float(p[0]), float(p[1])
    eps = cx.eps
    found = -1
    fs = cx.alive_faces
    bx = cx.loop_box[cx.face_outer[fs]]
    fs = fs[(bx[:, 0] - eps <= px) & (px <= bx[:, 2] + eps) & (bx[:, 1] - eps <= py) & (py <= bx[:, 3] + eps)]
    for f in fs:
        o = int(cx.face_outer[f])
        cx.counters["point_in_loop"] += 1
        tested_loops.append(o)
        if not _in_ring(cx.xy, _ring(cx, o), px, py):
            continue
        in_hole = False
        for h in cx.face_holes[f]:
            hb = cx.loop_box[h]
            if not (hb[0] <= px <= hb[2] and hb[1] <= py <= hb[3]):
                continue
            cx.counters["point_in_loop"] += 1
            tested_loops.append(int(h))
            if _in_ring(cx.xy, _ring(cx, h), px, py):
                in_hole = True
                break
        if not in_hole:
            found = int(f)
            break
    edges = np.asarray(cx.face_edges(found), dtype=np.int64)
    cx.counters["edge_tests"] += len(edges)
    kind, idx, x, y = _nearest_feature(cx.xy, cx.ev, edges, px, py, eps)
    if record is not None:
        hit = {_VERTEX: "vertex", _EDGE: "edge"}.get(kind, "face" if found >= 0 else "outside")
        cross = None if kind == _NONE else (x, y)
        record.append(_step(cx, "locate", p, p, found, tested_loops, edges, hit, cross, None, snap))
    if kind == _VERTEX:
        return ("v", int(idx))
    if kind == _EDGE:
        return ("e", int(idx), (x, y))
    return ("f", found) if found >= 0 else ("o",)


def _ring(cx, lp):
    return np.fromiter((cx.origin_of(h) for h in cx.loops[lp]), dtype=np.int64)


def _upgrade(cx, e, kind):
    if cx.ekind[e] != BOUNDARY and kind == D0:
        cx.ekind[e] = D0


def _sector(cx, v, q, new):
    """At vertex v heading for q: ("follow", e, w) along an old edge, ("face", f), or ("none",)."""
    p = cx.xy[v]
    dx, dy = q[0] - p[0], q[1] - p[1]
    L = math.hypot(dx, dy)
    eps = cx.eps
    best_h, best_cw = -1, 10.0
    follow, follow_l = None, np.inf
    ang_d = math.atan2(dy, dx)
    for e in cx.vedges[v]:
        if e in new:
            continue
        h = 2 * e if cx.ev[e, 0] == v else 2 * e + 1
        w = cx.dest_of(h)
        wx, wy = cx.xy[w, 0] - p[0], cx.xy[w, 1] - p[1]
        lw = math.hypot(wx, wy)
        if wx * dx + wy * dy > 0:
            dist = abs(dx * wy - dy * wx) / (L if lw <= L else lw)
            if dist <= eps and lw < follow_l:
                follow, follow_l = (e, w), lw
        cw = (ang_d - math.atan2(wy, wx)) % (2 * math.pi)
        if cw < best_cw:
            best_cw, best_h = cw, h
    if follow is not None:
        return ("follow",) + follow
    if best_h < 0:
        return ("none",)
    lp = cx.hloop[best_h]
    return ("face", cx.loop_face[lp] if lp >= 0 else -1)


def insert_section(cx, ring, kind, *, record=None):
    """Walk one convex section (held coordinates, counter-clockwise) into the complex.

    Parameters
    ----------
    cx : ReceiverComplex
    ring : (k, 2) float64
        From :func:`clean_ring`, relative to ``cx.origin``.
    kind : int
        ``D0`` or ``D1``: the kind of the edges drawn.

    Returns
    -------
    new : list of int
        The new discontinuity edges, in walk order.
    edge_face : dict {edge: face}
        The face each new edge was drawn in.
    snapped : list of int
        Existing edges bent through the walk's current vertex because they
        passed within the tolerance of it (snap rounding); the loops through
        them are retraced with the new ones.

    Other Parameters
    ----------------
    record : list, optional
        When given, one :class:`WalkStep` per step of the walk is appended
        (off by default: no cost).
    """
    new, edge_face, snapped = [], {}, []
    newset = set()
    loc = locate_point(cx, ring[0], record=record)
    if loc[0] == "v":
        cur_v, cur_f = loc[1], None
    elif loc[0] == "e":
        cur_v, cur_f = cx.split_edge(loc[1], loc[2]), None
    elif loc[0] == "f":
        cur_v, cur_f = cx.add_vertex(ring[0]), loc[1]
    else:
        cur_v, cur_f = -1, -1
    start_v = cur_v
    cur_p = ring[0]
    n = len(ring)
    for i in range(n):
        q = ring[(i + 1) % n]
        q_v = start_v if i == n - 1 else -1
        cur_v, cur_f, cur_p = _walk_segment(cx, cur_v, cur_f, cur_p, q, q_v, kind, new, newset, edge_face,
                                            snapped, record)
    return new, edge_face, snapped


def _draw(cx, a, b, kind, f, new, newset, edge_face):
    if a == b:
        raise ComplexError(f"walk: degenerate edge at vertex {a}")
    e = cx.add_edge(a, b, kind)
    new.append(e)
    newset.add(e)
    edge_face[e] = f


def _walk_segment(cx, cur_v, cur_f, cur_p, q, q_v, kind, new, newset, edge_face, snapped, record=None):
    eps = cx.eps
    # what testing the section edge against every edge of the receiver would cost
    cx.counters["edge_tests_all"] += cx.ne
    for _ in range(10 * cx.ne + 100):
        f = cur_f
        if cur_v >= 0:
            sec = _sector(cx, cur_v, q, newset)
            if sec[0] == "follow":
                e, w = sec[1], sec[2]
                p = cx.xy[cur_v]
                L = math.hypot(q[0] - p[0], q[1] - p[1])
                lw = math.hypot(*(cx.xy[w] - p))
                if record is not None:
                    end = cx.xy[w] if lw <= L + eps else q
                    record.append(_step(cx, "follow", p, q, -1, (), (), "follow", end, None, _segments(cx)))
                if lw <= L + eps:
                    _upgrade(cx, e, kind)
                    cur_v, cur_f = w, None
                    if lw >= L - eps:
                        return w, None, cx.xy[w].copy()
                    continue
                # q lies inside the old edge: split it there
                a = int(cx.ev[e, 0])
                d = cx.xy[w] - p
                x = p + d * (np.dot(q - p, d) / np.dot(d, d))
                xv = cx.split_edge(e, x)
                _upgrade(cx, e if a == cur_v else cx.ne - 1, kind)
                return xv, None, x
            if sec[0] == "face":
                f = sec[1]
        cp = cx.xy[cur_v] if cur_v >= 0 else cur_p
        edges = np.asarray(cx.face_edges(f), dtype=np.int64)
        snap = _segments(cx) if record is not None else None
        cx.counters["edge_tests"] += len(edges)
        t0 = time.perf_counter()
        hk, idx, s, px, py = _nearest_hit(cx.xy, cx.ev, edges, cur_v, float(cp[0]), float(cp[1]),
                                          float(q[0]), float(q[1]), eps)
        cx.t_idd += time.perf_counter() - t0
        L = math.hypot(q[0] - cp[0], q[1] - cp[1])
        if record is not None:
            cross = None if hk == _NONE else ((px, py) if hk != _VERTEX else tuple(cx.xy[int(idx)]))
            end = q if hk == _NONE else cross
            drawn = None if (f < 0 or hk in (_SNAP, _NEAR_VERTEX)) else (tuple(cp), tuple(end))
            record.append(_step(cx, "segment", cp, q, f, (), edges, _HIT_NAMES[int(hk)], cross, drawn, snap))
        if hk == _SNAP:
            # snap rounding: the edge is bent through the current vertex (by less than eps)
            cx.split_edge(int(idx), cx.xy[cur_v], vertex=cur_v)
            snapped.extend((int(idx), cx.ne - 1))
            cx.counters["snaps"] += 1
            continue
        if hk == _NEAR_VERTEX:
            raise ComplexError(f"walk: vertices {cur_v} and {int(idx)} closer than the tolerance")
        if hk == _NONE:
            if f >= 0:
                v = q_v if q_v >= 0 else cx.add_vertex(q)
                _draw(cx, cur_v, v, kind, f, new, newset, edge_face)
                return v, f, q
            return -1, -1, q
        if hk == _VERTEX:
            w = int(idx)
        else:
            w = cx.split_edge(int(idx), (px, py))
        if f >= 0:
            _draw(cx, cur_v, w, kind, f, new, newset, edge_face)
        cur_v, cur_f = w, None
        if s >= L - eps:
            return w, None, cx.xy[w].copy()
    raise ComplexError("walk: no progress along a section edge")
