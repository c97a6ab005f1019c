"""A robust rebuild of a receiver complex from all its sections at once (the walk's safety net).

The intersection walk (:mod:`polygen.discontinuity.walk`) decides every
incidence with a tolerance, one section at a time.  Inputs that are
degenerate *at the scale of that tolerance* -- two shadow lines closer than
it over a stretch but not coincident, crossings at angles of the order of
tolerance / length -- can make those decisions inconsistent, and the
complex then fails :meth:`ReceiverComplex.check`.  For such a receiver
:func:`arrangement_complex` builds the same complex another way: the
receiver's rings and all section boundaries are noded together by GEOS
with snap rounding to a grid of the tolerance (``shapely.union_all(...,
grid_size=eps)``, a robust noding), the loops are traced with the same
smallest-angle rule as :func:`~polygen.discontinuity.loops.rebuild_loops`,
and each face's states are found by testing a point inside it against
every section.  The result has the same structure and invariants; the
walk's counters are kept and ``counters["fallback"]`` is set to 1.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from polygen.discontinuity.complex import BOUNDARY, BRIGHT, D0, D1, ComplexError, ReceiverComplex
from polygen.discontinuity.loops import _next_half
from polygen.discontinuity.walk import _in_ring, _ring

__all__ = ["arrangement_complex"]


def arrangement_complex(outer, holes, rings, *, n_lights, tol):
    """The receiver complex of ``rings`` built by snap-rounded noding (no walk).

    Parameters
    ----------
    outer, holes
        The receiver, as for :class:`ReceiverComplex`.
    rings : list of (light, value, ring (k, 2) float64, kind)
        Every section polygon (receiver frame, cleaned), its state value
        (umbra 3 / penumbra 2) and edge kind (``D0``/``D1``).
    n_lights : int
    tol : float

    Returns
    -------
    ReceiverComplex
        States filled (bright where no section covers a face).
    """
    cx = ReceiverComplex(outer, holes, n_lights=n_lights, tol=tol)
    g = cx.eps
    rec_rings = [cx.xy[_ring(cx, lp)] for lp in range(len(cx.loops))]
    rec = shapely.Polygon(rec_rings[0], rec_rings[1:])
    held = [(light, value, np.asarray(r, dtype=np.float64) - cx.origin, kind) for light, value, r, kind in rings]
    lines = [shapely.LinearRing(r) for r in rec_rings]
    d0_lines = []
    for _, _, r, kind in held:
        ring = shapely.LinearRing(r)
        part = shapely.intersection(ring, rec)
        if not part.is_empty:
            lines.append(part)
            if kind == D0:
                d0_lines.append(ring)
    noded = shapely.union_all(lines, grid_size=g)
    coords = []
    for ln in getattr(noded, "geoms", [noded]):
        if ln.geom_type == "LineString":
            c = np.asarray(ln.coords)
            coords.append(np.stack([c[:-1], c[1:]], axis=1))
    seg = np.concatenate(coords) if coords else np.zeros((0, 2, 2))
    pts, inv = np.unique(seg.reshape(-1, 2), axis=0, return_inverse=True)
    ev = inv.reshape(-1, 2)
    ev = ev[ev[:, 0] != ev[:, 1]]
    ev = np.unique(np.sort(ev, axis=1), axis=0)
    mid = 0.5 * (pts[ev[:, 0]] + pts[ev[:, 1]])
    d0 = shapely.dwithin(shapely.multilinestrings(d0_lines), shapely.points(mid), g) if d0_lines \
        else np.zeros(len(ev), bool)
    kinds = np.where(d0, D0, D1).astype(np.int8)
    for _ in range(3):
        cx._reset()
        for p in pts:
            cx.add_vertex(p)
        for (a, b), k in zip(ev, kinds):
            cx.add_edge(int(a), int(b), int(k))
        out, inner = _trace_all(cx, rec)
        if not len(out):
            break
        # snap-rounded slivers or stubs outside the receiver: drop them, trace again
        keep = np.ones(len(ev), bool)
        keep[out] = False
        ev, kinds = ev[keep], kinds[keep]
    else:
        raise ComplexError("arrangement: edges outside the receiver remain")
    _states(cx, held, inner)
    cx.counters["fallback"] = 1
    return cx


def _trace_all(cx, rec):
    """Trace every loop of the edge graph; CCW loops become faces, CW loops their holes; the
    faces outside the receiver (the unbounded one, those in its holes) are dropped and the
    edges along them become its ring edges."""
    holes = []
    stars = {}
    for h0 in range(2 * cx.ne):
        if cx.hloop[h0] >= 0:
            continue
        lid = len(cx.loops)
        hs = []
        h = h0
        while True:
            if cx.hloop[h] >= 0:
                raise ComplexError(f"arrangement: half-edge {h} traced twice")
            cx.hloop[h] = lid
            hs.append(h)
            h = _next_half(cx, h, stars)
            if h == h0:
                break
        cx._new_loop(hs, -1)
        if cx.loop_area[lid] > 0:
            f = cx._new_face(None)
            cx.face_outer[f] = lid
            cx.loop_face[lid] = f
        else:
            holes.append(lid)
    faces = cx.alive_faces
    drop = []
    for lp in holes:
        h = cx.loops[lp][0]
        a, b = cx.xy[cx.origin_of(h)], cx.xy[cx.dest_of(h)]
        mx, my = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])
        other = cx.hloop[h ^ 1]
        best, best_a = -1, math.inf
        for f in faces:
            o = int(cx.face_outer[f])
            bx = cx.loop_box[o]
            if o == other or cx.loop_area[o] >= best_a or not (bx[0] <= mx <= bx[2] and bx[1] <= my <= bx[3]):
                continue
            if _in_ring(cx.xy, _ring(cx, o), mx, my):
                best, best_a = int(f), cx.loop_area[o]
        if best < 0:
            drop.append(lp)  # the unbounded face's boundary
            continue
        cx.face_holes[best].append(lp)
        cx.loop_face[lp] = best
    pts = cx.interior_points() - cx.origin
    outside = ~shapely.contains_xy(rec, pts[:, 0], pts[:, 1])
    inner = pts[~outside]
    for f in faces[outside]:
        drop.append(int(cx.face_outer[f]))
        drop.extend(cx.face_holes[f])
        cx.face_outer[f] = -1
        cx.face_holes[f] = []
    for lp in drop:
        for h in cx.loops[lp]:
            cx.hloop[h] = -1
        cx.loops[lp] = None
    # ring edges: the inside half forwards
    out = [e for e in range(cx.ne) if cx.hloop[2 * e] < 0 and cx.hloop[2 * e + 1] < 0]
    if out:
        return out, inner
    for e in range(cx.ne):
        fwd, rev = cx.hloop[2 * e], cx.hloop[2 * e + 1]
        if fwd >= 0 and rev >= 0:
            continue
        cx.ekind[e] = BOUNDARY
        cx.boundary_edges.append(e)
        if fwd < 0:
            hs = cx.loops[rev]
            hs[hs.index(2 * e + 1)] = 2 * e
            cx.hloop[2 * e], cx.hloop[2 * e + 1] = rev, -1
            cx.ev[e] = cx.ev[e, ::-1].copy()
    return [], inner


def _states(cx, held, inner):
    """Each face's states from a point inside it (``inner``, held coordinates) against every section."""
    fs = cx.alive_faces
    st = np.full((len(fs), cx.n_lights), BRIGHT, np.int8)
    if len(held) and len(fs):
        polys = np.array([shapely.Polygon(r) for _, _, r, _ in held], dtype=object)
        ri, pi = shapely.STRtree(shapely.points(inner)).query(polys, predicate="contains")
        light = np.array([h[0] for h in held])[ri]
        value = np.array([h[1] for h in held], dtype=np.int8)[ri]
        np.maximum.at(st, (pi, light), value)
    cx.face_state[fs] = st
