"""Numba kernels of the extrema graph (thesis 6.3); the API is :mod:`polygen.volume.extrema_graph`.

Kernels take arrays only and write into what they are given (or return
freshly grown buffers); they import nothing of polygen but the JIT options.
"""

import numpy as np

from polygen._jit import njit

# kinds of arcs (Table 6.3 counts the polyline ones as N_pa)
ARC_STRAIGHT = 0
ARC_POLYLINE = 1
ARC_SEARCH = 2  # breadth-first fallback when the polyline walk dead-ends (the thesis leaves this open)

# kinds of extrema (bits)
KIND_MAX = 1
KIND_MIN = 2


# ------------------------------------------------------------ 6.3.1 extrema
@njit
def _mark_cells(cells, s, not_max, not_min, plural_max, plural_min):
    """Fig. 6.5, first loop: per cell, mark every node but the largest "not-maximum"
    (every node but the smallest "not-minimum"); ties at the extreme get "plural" marks.

    Works for any number of nodes per cell (triangles, tetrahedra, hexahedra).
    Marks are never cleared here.
    """
    nn = cells.shape[1]
    for c in range(cells.shape[0]):
        n0 = cells[c, 0]
        hi = s[n0]
        lo = hi
        node_hi = n0
        node_lo = n0
        for i in range(1, nn):
            node = cells[c, i]
            v = s[node]
            if v > hi:
                hi = v
                node_hi = node
            if v < lo:
                lo = v
                node_lo = node
        n_hi = 0
        n_lo = 0
        for i in range(nn):
            v = s[cells[c, i]]
            n_hi += v == hi
            n_lo += v == lo
        if n_hi == 1 and n_lo == 1:
            # no tie (the common case): mark every node, then put the largest's "not-maximum" and the
            # smallest's "not-minimum" back as they were -- stores without a test per node (2M: 95 -> 60 ms,
            # 10M: 0.42 -> 0.23 s, benchmarks/experiments/extrema_marks_ab.py)
            keep_hi = not_max[node_hi]
            keep_lo = not_min[node_lo]
            for i in range(nn):
                node = cells[c, i]
                not_max[node] = True
                not_min[node] = True
            not_max[node_hi] = keep_hi
            not_min[node_lo] = keep_lo
            continue
        for i in range(nn):
            node = cells[c, i]
            v = s[node]
            if v < hi:
                not_max[node] = True
            elif n_hi > 1:
                plural_max[node] = True
            if v > lo:
                not_min[node] = True
            elif n_lo > 1:
                plural_min[node] = True


@njit
def _flood_equal(start, s, cells, node_off, node_cells, plural, stack, seen, stamp):
    """Clear ``plural`` on every node joined to ``start`` through cells by nodes of equal value."""
    value = s[start]
    seen[start] = stamp
    plural[start] = False
    top = 0
    stack[top] = start
    top += 1
    nn = cells.shape[1]
    while top > 0:
        top -= 1
        v = stack[top]
        for k in range(node_off[v], node_off[v + 1]):
            c = node_cells[k]
            for i in range(nn):
                w = cells[c, i]
                if seen[w] != stamp and s[w] == value:
                    seen[w] = stamp
                    plural[w] = False
                    stack[top] = w
                    top += 1


@njit
def _register_extrema(s, cells, node_off, node_cells, not_max, not_min, plural_max, plural_min, kind):
    """Fig. 6.5, second loop: ``kind[node]`` gets KIND_MAX / KIND_MIN bits; returns (n_flat_max, n_flat_min).

    A node never marked "not-maximum" is a maximum; if it also carries a
    "plural-maximums" mark it stands for its whole flat group, whose marks
    are then cleared (so the group gives one extremum). ``plural_*`` are
    consumed (pass copies).
    """
    n = s.shape[0]
    stack = np.empty(n, np.int64)
    seen = np.zeros(n, np.int64)
    stamp = 0
    n_flat_max = 0
    n_flat_min = 0
    for v in range(n):
        # a flat-group member whose mark was cleared by an earlier flood is not registered again
        if not not_max[v]:
            if plural_max[v]:
                kind[v] |= KIND_MAX
                n_flat_max += 1
                stamp += 1
                _flood_equal(v, s, cells, node_off, node_cells, plural_max, stack, seen, stamp)
        if not not_min[v]:
            if plural_min[v]:
                kind[v] |= KIND_MIN
                n_flat_min += 1
                stamp += 1
                _flood_equal(v, s, cells, node_off, node_cells, plural_min, stack, seen, stamp)
    return n_flat_max, n_flat_min


@njit
def _register_strict(not_max, not_min, plural_max_orig, plural_min_orig, kind):
    """Strict extrema: never marked "not-" and never tied at the extreme of a cell."""
    for v in range(kind.shape[0]):
        if not not_max[v] and not plural_max_orig[v]:
            kind[v] |= KIND_MAX
        if not not_min[v] and not plural_min_orig[v]:
            kind[v] |= KIND_MIN


# ------------------------------------------------------------ cell ranges
@njit
def _cell_min_max(cells, s, ids, lo, hi):
    """``lo[i], hi[i]`` = smallest / largest node value of cell ``ids[i]``."""
    nn = cells.shape[1]
    for i in range(ids.shape[0]):
        c = ids[i]
        a = s[cells[c, 0]]
        b = a
        for j in range(1, nn):
            v = s[cells[c, j]]
            if v < a:
                a = v
            if v > b:
                b = v
        lo[i] = a
        hi[i] = b


# ------------------------------------------------------------ 6.3.2 graph
@njit
def _grow(a):
    out = np.empty(max(16, 2 * a.shape[0]), a.dtype)
    out[: a.shape[0]] = a
    return out


@njit
def _has_node(cells, c, node):
    for i in range(cells.shape[1]):
        if cells[c, i] == node:
            return True
    return False


@njit
def _face_plane(points, cells, faces, c, f, n_out):
    """Outward normal (not unit) of local face ``f`` of cell ``c`` into ``n_out``; returns the offset n.x.

    Triangles: the cross product; quadrilaterals: the cross product of the
    diagonals (a plane for a slightly warped face). Oriented away from the
    cell centroid so that the node order of the tables does not matter.
    """
    k = faces.shape[1]
    fc0 = 0.0
    fc1 = 0.0
    fc2 = 0.0
    for j in range(k):
        p = cells[c, faces[f, j]]
        fc0 += points[p, 0]
        fc1 += points[p, 1]
        fc2 += points[p, 2]
    fc0 /= k
    fc1 /= k
    fc2 /= k
    a = cells[c, faces[f, 0]]
    if k == 3:
        b = cells[c, faces[f, 1]]
        d = cells[c, faces[f, 2]]
        u0 = points[b, 0] - points[a, 0]
        u1 = points[b, 1] - points[a, 1]
        u2 = points[b, 2] - points[a, 2]
        v0 = points[d, 0] - points[a, 0]
        v1 = points[d, 1] - points[a, 1]
        v2 = points[d, 2] - points[a, 2]
    else:
        b = cells[c, faces[f, 1]]
        d = cells[c, faces[f, 2]]
        e = cells[c, faces[f, 3]]
        u0 = points[d, 0] - points[a, 0]
        u1 = points[d, 1] - points[a, 1]
        u2 = points[d, 2] - points[a, 2]
        v0 = points[e, 0] - points[b, 0]
        v1 = points[e, 1] - points[b, 1]
        v2 = points[e, 2] - points[b, 2]
    n0 = u1 * v2 - u2 * v1
    n1 = u2 * v0 - u0 * v2
    n2 = u0 * v1 - u1 * v0
    # cell centroid
    nn = cells.shape[1]
    cc0 = 0.0
    cc1 = 0.0
    cc2 = 0.0
    for j in range(nn):
        p = cells[c, j]
        cc0 += points[p, 0]
        cc1 += points[p, 1]
        cc2 += points[p, 2]
    cc0 /= nn
    cc1 /= nn
    cc2 /= nn
    if n0 * (fc0 - cc0) + n1 * (fc1 - cc1) + n2 * (fc2 - cc2) < 0.0:
        n0 = -n0
        n1 = -n1
        n2 = -n2
    n_out[0] = n0
    n_out[1] = n1
    n_out[2] = n2
    return n0 * fc0 + n1 * fc1 + n2 * fc2


@njit
def _face_has_node(cells, faces, c, f, node):
    for j in range(faces.shape[1]):
        if cells[c, faces[f, j]] == node:
            return True
    return False


@njit
def _append(buf, n, c):
    if n == buf.shape[0]:
        buf = _grow(buf)
    buf[n] = c
    return buf, n + 1


@njit
def _walk_straight(points, cells, faces, face_nb, node_off, node_cells, x1, x2, mark, stamp, buf, n0):
    """Fig. 6.7: the cells that the segment x1 -> x2 passes through, appended to ``buf`` from ``n0``.

    Starts in the cell around ``x1`` that the segment enters and crosses
    faces (the exit face is the nearest face plane the ray leaves through)
    until a cell has ``x2`` as a node. Returns ``(buf, n, ok, walked)``;
    ``ok`` is False when the segment leaves the volume through a boundary
    face (Fig. 6.8) or the walk cannot go on (a degenerate path that comes
    back to a cell of its own), and then ``n == n0``.
    """
    d0 = points[x2, 0] - points[x1, 0]
    d1 = points[x2, 1] - points[x1, 1]
    d2 = points[x2, 2] - points[x1, 2]
    length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if length == 0.0:
        return buf, n0, False, 0
    nrm = np.empty(3)
    # the cell around x1 that the ray enters: all faces through x1 face away from d
    best = -1
    best_score = -np.inf
    for k in range(node_off[x1], node_off[x1 + 1]):
        c = node_cells[k]
        score = np.inf
        for f in range(faces.shape[0]):
            if _face_has_node(cells, faces, c, f, x1):
                _face_plane(points, cells, faces, c, f, nrm)
                nl = np.sqrt(nrm[0] ** 2 + nrm[1] ** 2 + nrm[2] ** 2)
                sc = -(nrm[0] * d0 + nrm[1] * d1 + nrm[2] * d2) / (nl * length)
                if sc < score:
                    score = sc
        if score > best_score:
            best_score = score
            best = c
    c = best
    n = n0
    walked = 0
    tol = 1e-9
    max_steps = cells.shape[0]
    p0 = points[x1, 0]
    p1 = points[x1, 1]
    p2 = points[x1, 2]
    while walked < max_steps:
        walked += 1
        mark[c] = stamp
        buf, n = _append(buf, n, c)
        if _has_node(cells, c, x2):
            return buf, n, True, walked
        # exit face: the smallest ray parameter among the faces the ray leaves through
        t_best = np.inf
        nb_best = -2
        t_in = np.inf
        nb_in = -2
        for f in range(faces.shape[0]):
            off = _face_plane(points, cells, faces, c, f, nrm)
            nl = np.sqrt(nrm[0] ** 2 + nrm[1] ** 2 + nrm[2] ** 2)
            denom = nrm[0] * d0 + nrm[1] * d1 + nrm[2] * d2
            if denom <= tol * nl * length:
                continue
            tf = (off - (nrm[0] * p0 + nrm[1] * p1 + nrm[2] * p2)) / denom
            nb = face_nb[c, f]
            if nb >= 0 and mark[nb] == stamp:
                continue
            if tf < t_best:
                t_best = tf
                nb_best = nb
            if nb >= 0 and tf < t_in:
                t_in = tf
                nb_in = nb
        if nb_best == -2:
            break
        if nb_best < 0:
            # leaving through a boundary face, unless an interior face is crossed at the same point
            if nb_in >= 0 and t_in <= t_best + 1e-7:
                nb_best = nb_in
            else:
                break
        c = nb_best
    return buf, n0, False, walked


@njit
def _dist_sum(points, cells, faces, c, f, goal):
    acc = 0.0
    for j in range(faces.shape[1]):
        p = cells[c, faces[f, j]]
        a = points[p, 0] - points[goal, 0]
        b = points[p, 1] - points[goal, 1]
        e = points[p, 2] - points[goal, 2]
        acc += np.sqrt(a * a + b * b + e * e)
    return acc


@njit
def _walk_polyline(points, cells, faces, face_nb, node_off, node_cells, x1, x2, mark, stamp, buf, n0):
    """Fig. 6.9: from a cell around x1, always cross the non-boundary face, to an unmarked cell,
    with the smallest sum of node distances to x2. Returns ``(buf, n, ok, walked)``."""
    nn = cells.shape[1]
    best = -1
    best_sum = np.inf
    for k in range(node_off[x1], node_off[x1 + 1]):
        c = node_cells[k]
        acc = 0.0
        for j in range(nn):
            p = cells[c, j]
            a = points[p, 0] - points[x2, 0]
            b = points[p, 1] - points[x2, 1]
            e = points[p, 2] - points[x2, 2]
            acc += np.sqrt(a * a + b * b + e * e)
        if acc < best_sum:
            best_sum = acc
            best = c
    c = best
    n = n0
    walked = 0
    while walked < cells.shape[0]:
        walked += 1
        mark[c] = stamp
        buf, n = _append(buf, n, c)
        if _has_node(cells, c, x2):
            return buf, n, True, walked
        nxt = -1
        smin = np.inf
        for f in range(faces.shape[0]):
            nb = face_nb[c, f]
            if nb < 0 or mark[nb] == stamp:
                continue
            sd = _dist_sum(points, cells, faces, c, f, x2)
            if sd < smin:
                smin = sd
                nxt = nb
        if nxt < 0:  # a dead end (e.g. a spiral into marked cells)
            break
        c = nxt
    return buf, n0, False, walked


@njit
def _walk_search(cells, face_nb, node_off, node_cells, x1, ext_index, comp, comp1, mark, stamp, parent,
                 queue, buf, n0):
    """Breadth-first search over face neighbours from the cells around x1 to the nearest cell
    (in face steps) holding an extremum numbered differently from ``comp1``.

    Returns ``(buf, n, goal_extremum or -1, visited)``; the path is appended.
    """
    head = 0
    tail = 0
    for k in range(node_off[x1], node_off[x1 + 1]):
        c = node_cells[k]
        if mark[c] != stamp:
            mark[c] = stamp
            parent[c] = -1
            queue[tail] = c
            tail += 1
    nn = cells.shape[1]
    while head < tail:
        c = queue[head]
        head += 1
        for i in range(nn):
            e = ext_index[cells[c, i]]
            if e >= 0 and comp[e] != comp1:
                # walk the parents back, then append in order from x1
                m = 0
                q = c
                while q >= 0:
                    m += 1
                    q = parent[q]
                n = n0 + m
                while buf.shape[0] < n:
                    buf = _grow(buf)
                q = c
                j = n - 1
                while q >= 0:
                    buf[j] = q
                    j -= 1
                    q = parent[q]
                return buf, n, e, head
        for f in range(face_nb.shape[1]):
            nb = face_nb[c, f]
            if nb >= 0 and mark[nb] != stamp:
                mark[nb] = stamp
                parent[nb] = c
                queue[tail] = nb
                tail += 1
    return buf, n0, -1, head


@njit
def _log_try(tries, n_tries, tcells, n_tc, i, j, kind, ok, buf, start, count):
    """Recorder of :func:`_build_graph`: one row (start, goal, kind, ok, cells, first cell) and its cells."""
    if n_tries == tries.shape[0]:
        grown = np.empty((2 * tries.shape[0], tries.shape[1]), np.int64)
        grown[:n_tries] = tries[:n_tries]
        tries = grown
    while tcells.shape[0] < n_tc + count:
        tcells = _grow(tcells)
    tries[n_tries, 0] = i
    tries[n_tries, 1] = j
    tries[n_tries, 2] = kind
    tries[n_tries, 3] = ok
    tries[n_tries, 4] = count
    tries[n_tries, 5] = n_tc
    for q in range(count):
        tcells[n_tc + q] = buf[start + q]
    return tries, n_tries + 1, tcells, n_tc + count


@njit
def _build_graph(points, cells, s, faces, face_nb, node_off, node_cells, ext_nodes, use_polyline, record):
    """Fig. 6.10: join every extremum to the nearest differently numbered one it can reach.

    For each extremum in turn (the start point) the differently numbered
    extrema are sorted by distance; the first that a straight segment
    reaches inside the volume is joined; failing that, the first that the
    polyline walk reaches; failing that (the thesis leaves this case open),
    the nearest one in face steps by a breadth-first search. The numbers
    of the two sides are merged by the smaller one (Fig. 6.6).

    Returns ``(arc_ends (A, 2) extremum indices, arc_off (A+1,), arc_cells,
    arc_kind (A,), comp (m,), counters (4,), tries (T, 6), try_cells)`` with
    counters = straight tries that left the volume, polyline tries that
    dead-ended, cells walked in failed tries, sorts done. With ``record``,
    every try in order is a row of ``tries`` (start extremum, goal extremum
    or -1, kind, 1 if it reached the goal, cells walked, offset of those
    cells in ``try_cells``); a failed breadth-first search logs no cells.
    Without it both are empty.
    """
    m = ext_nodes.shape[0]
    n_nodes = s.shape[0]
    n_cells = cells.shape[0]
    ext_index = np.full(n_nodes, -1, np.int64)
    for i in range(m):
        ext_index[ext_nodes[i]] = i
    comp = np.arange(m)
    mark = np.zeros(n_cells, np.int64)
    parent = np.empty(n_cells, np.int64)
    queue = np.empty(n_cells, np.int64)
    stamp = 0
    arc_ends = np.empty((max(1, m), 2), np.int64)
    arc_kind = np.empty(max(1, m), np.int64)
    arc_off = np.zeros(max(1, m) + 1, np.int64)
    buf = np.empty(1024, np.int64)
    n_buf = 0
    n_arcs = 0
    counters = np.zeros(4, np.int64)
    tries = np.empty((64 if record else 0, 6), np.int64)
    tcells = np.empty(1024 if record else 0, np.int64)
    n_tries = 0
    n_tc = 0
    d2 = np.empty(m)
    cand = np.empty(m, np.int64)
    for i in range(m):
        x1 = ext_nodes[i]
        k = 0
        for j in range(m):
            if comp[j] != comp[i]:
                a = points[ext_nodes[j], 0] - points[x1, 0]
                b = points[ext_nodes[j], 1] - points[x1, 1]
                e = points[ext_nodes[j], 2] - points[x1, 2]
                d2[k] = a * a + b * b + e * e
                cand[k] = j
                k += 1
        if k == 0:
            continue
        counters[3] += 1
        order = np.argsort(d2[:k], kind="mergesort")  # the O(m log m) sort of 6.4, per start point
        goal = -1
        kind = -1
        for q in range(k):
            j = cand[order[q]]
            stamp += 1
            buf, n_new, ok, walked = _walk_straight(points, cells, faces, face_nb, node_off, node_cells, x1,
                                                     ext_nodes[j], mark, stamp, buf, n_buf)
            if record:  # a failed walk's cells are still in buf from n_buf
                tries, n_tries, tcells, n_tc = _log_try(tries, n_tries, tcells, n_tc, i, j, ARC_STRAIGHT, int(ok),
                                                        buf, n_buf, walked)
            if ok:
                goal = j
                kind = ARC_STRAIGHT
                n_buf = n_new
                break
            counters[0] += 1
            counters[2] += walked
        if goal < 0 and use_polyline:
            for q in range(k):
                j = cand[order[q]]
                stamp += 1
                buf, n_new, ok, walked = _walk_polyline(points, cells, faces, face_nb, node_off, node_cells, x1,
                                                         ext_nodes[j], mark, stamp, buf, n_buf)
                if record:
                    tries, n_tries, tcells, n_tc = _log_try(tries, n_tries, tcells, n_tc, i, j, ARC_POLYLINE,
                                                            int(ok), buf, n_buf, walked)
                if ok:
                    goal = j
                    kind = ARC_POLYLINE
                    n_buf = n_new
                    break
                counters[1] += 1
                counters[2] += walked
        if goal < 0:
            stamp += 1
            buf, n_new, j, walked = _walk_search(cells, face_nb, node_off, node_cells, x1, ext_index, comp, comp[i],
                                                 mark, stamp, parent, queue, buf, n_buf)
            if record:
                tries, n_tries, tcells, n_tc = _log_try(tries, n_tries, tcells, n_tc, i, j, ARC_SEARCH, int(j >= 0),
                                                        buf, n_buf, n_new - n_buf)
            if j < 0:
                counters[2] += walked
                continue  # nothing reachable: another part of a disconnected volume
            goal = j
            kind = ARC_SEARCH
            n_buf = n_new
        arc_ends[n_arcs, 0] = i
        arc_ends[n_arcs, 1] = goal
        arc_kind[n_arcs] = kind
        arc_off[n_arcs + 1] = n_buf
        n_arcs += 1
        # Fig. 6.6: both sides take the smaller number
        lo = min(comp[i], comp[goal])
        hi = max(comp[i], comp[goal])
        for j in range(m):
            if comp[j] == hi:
                comp[j] = lo
    return (arc_ends[:n_arcs].copy(), arc_off[: n_arcs + 1].copy(), buf[:n_buf].copy(), arc_kind[:n_arcs].copy(),
            comp, counters, tries[:n_tries].copy(), tcells[:n_tc].copy())


@njit
def _arc_ranges(cells, s, arc_off, arc_cells, smin, smax):
    """Def. 6.8: S_min / S_max of each arc over the nodes of all its cells."""
    nn = cells.shape[1]
    for a in range(arc_off.shape[0] - 1):
        lo = np.inf
        hi = -np.inf
        for k in range(arc_off[a], arc_off[a + 1]):
            c = arc_cells[k]
            for j in range(nn):
                v = s[cells[c, j]]
                if v < lo:
                    lo = v
                if v > hi:
                    hi = v
        smin[a] = lo
        smax[a] = hi


# ------------------------------------------------------------ 6.3.4 query
@njit
def _crossed(cells, s, c, value):
    """The marching convention: a cell is intersected when it has nodes S >= C and S < C."""
    above = False
    below = False
    for j in range(cells.shape[1]):
        if s[cells[c, j]] >= value:
            above = True
        else:
            below = True
    return above and below


@njit
def _query_arcs(cells, s, arc_off, arc_cells, arc_smin, arc_smax, value, mark, stamp, hits, n_hits):
    """Step 3: skip arcs with C outside [S_min, S_max]; test their unmarked cells once each.

    Returns ``(n_hits, tested, arcs_tested)``; the intersected cells are appended to ``hits``.
    """
    tested = 0
    arcs = 0
    for a in range(arc_off.shape[0] - 1):
        # no cell of the arc can have a node >= C and one < C
        if arc_smax[a] < value or arc_smin[a] >= value:
            continue
        arcs += 1
        for k in range(arc_off[a], arc_off[a + 1]):
            c = arc_cells[k]
            if mark[c] == stamp:
                continue
            mark[c] = stamp
            tested += 1
            if _crossed(cells, s, c, value):
                hits[n_hits] = c
                n_hits += 1
    return n_hits, tested, arcs


@njit
def _query_boundary(by_min, min_sorted, max_by_min, by_max, max_sorted, min_by_max, value, mark, stamp, hits, n_hits):
    """Step 4: boundary cells from the list on the near side of the range.

    Cells with ``S_min < C`` are a prefix of the list by S_min, cells with
    ``S_max >= C`` a suffix of the list by S_max (both ascending); the
    shorter one is scanned, each unmarked cell tested against the other
    bound. Returns ``(n_hits, tested, used_max_list)``.
    """
    nb = by_min.shape[0]
    k_lo = np.searchsorted(min_sorted, value, side="left")  # S_min < C
    k_hi = nb - np.searchsorted(max_sorted, value, side="left")  # S_max >= C
    tested = 0
    if k_lo <= k_hi:
        for i in range(k_lo):
            c = by_min[i]
            if mark[c] == stamp:
                continue
            mark[c] = stamp
            tested += 1
            if max_by_min[i] >= value:
                hits[n_hits] = c
                n_hits += 1
        return n_hits, tested, False
    for i in range(nb - k_hi, nb):
        c = by_max[i]
        if mark[c] == stamp:
            continue
        mark[c] = stamp
        tested += 1
        if min_by_max[i] < value:
            hits[n_hits] = c
            n_hits += 1
    return n_hits, tested, True


@njit
def _join_nearest(points, ext_nodes):
    """Fig. 6.6 without the walk: each extremum joined to the nearest differently numbered one.

    Returns (A, 2) extremum indices.
    """
    m = ext_nodes.shape[0]
    comp = np.arange(m)
    arcs = np.empty((max(1, m), 2), np.int64)
    n_arcs = 0
    d2 = np.empty(m)
    cand = np.empty(m, np.int64)
    for i in range(m):
        k = 0
        for j in range(m):
            if comp[j] != comp[i]:
                acc = 0.0
                for q in range(points.shape[1]):
                    t = points[ext_nodes[j], q] - points[ext_nodes[i], q]
                    acc += t * t
                d2[k] = acc
                cand[k] = j
                k += 1
        if k == 0:
            continue
        goal = cand[np.argsort(d2[:k], kind="mergesort")[0]]
        arcs[n_arcs, 0] = i
        arcs[n_arcs, 1] = goal
        n_arcs += 1
        lo = min(comp[i], comp[goal])
        hi = max(comp[i], comp[goal])
        for j in range(m):
            if comp[j] == hi:
                comp[j] = lo
    return arcs[:n_arcs].copy()
