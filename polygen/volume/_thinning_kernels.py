"""numba kernels of volume thinning (thesis 7.5, Fig. 7.5) and of 2D image thinning (7.3).

Arrays only; the Python driver is :mod:`polygen.volume.thinning`.

Cell classes (Def. 7.6) are ``int8``: ``-1`` marked (an extremum's cell),
``0`` removed, ``n > 0`` the number of non-removed face neighbours.
Node boundary-group numbers ``n_B`` (Def. 7.8) are ``int64``, 0 inside.
Faces are given by a bit mask of their local nodes, so one kernel serves
tetrahedra (4 faces of 3 nodes) and hexahedra (6 faces of 4 nodes).
"""

import numpy as np

from polygen._jit import njit, prange
from polygen.volume._intrinsics import _KCACHE, _prefetch_row

# slots of the ``stats`` array the thinning kernel fills
ST_PROCESSED = 0  # 8 slots: cells taken from the FIFO of class q (index q)
ST_REMOVED = 8  # 8 slots: cells removed from class q
ST_WALKS = 16  # walks around a triple-shared edge
ST_WALKS_OK = 17
ST_PRICKS = 18  # voids pricked open
ST_PRICK_FAILED = 19  # voids for which no layer cells could be found
ST_PRICK_CELLS = 20  # cells removed by pricking
ST_IMPLICIT = 21  # unmarked cells whose last non-removed neighbour was removed
ST_STALE = 22  # FIFO entries skipped because the cell had moved to a lower class
N_STATS = 24
#: how far ahead in a FIFO of :func:`_thin_half` the ``face_nb`` and ``cells`` rows of a cell are
#: fetched (a hint: no result changes). The removal tests of each cell taken read both rows, and the
#: FIFO's cells are scattered over arrays much larger than the caches; fetching them this far ahead
#: overlaps those misses. Measured on 2M (2 cores, A/B interleaved, medians, same skeleton): the
#: halves kernel alone 0.228 -> 0.214 s (-6 %, 15 runs each), ``T_halves`` inside ``thin_volume``
#: 0.489 -> 0.450 s (-8 %, 9 runs each; an earlier prototype: 0.209 -> 0.192 s). The serial FIFO of
#: :func:`thin_resume` has the same loop but was not measured, so it has no hint.
FIFO_LOOKAHEAD = 16


@njit
def face_masks(local_faces, n_nodes):
    """(F,) int64 bit mask of the local nodes of each local face."""
    out = np.zeros(local_faces.shape[0], np.int64)
    for f in range(local_faces.shape[0]):
        m = 0
        for j in range(local_faces.shape[1]):
            m |= 1 << local_faces[f, j]
        out[f] = m
    return out


@njit
def _popcount(m):
    n = 0
    while m:
        m &= m - 1
        n += 1
    return n


@njit
def _lowest_bit(m):
    i = 0
    while not (m >> i) & 1:
        i += 1
    return i


@njit
def _local_index(cells, c, node):
    for i in range(cells.shape[1]):
        if cells[c, i] == node:
            return i
    return -1


@njit
def initial_classes(face_nb, marked, cls):
    """Def. 7.6: class = number of face neighbours; -1 for marked cells."""
    m, nf = face_nb.shape
    for c in range(m):
        n = 0
        for f in range(nf):
            if face_nb[c, f] >= 0:
                n += 1
        cls[c] = n
    for i in range(marked.shape[0]):
        cls[marked[i]] = -1


@njit
def _walk(cells, face_nb, fmask, cls, e, start, goal, a, b):
    """Walk around the edge (a, b) from ``start`` away from ``e`` through non-removed cells.

    True when the walk reaches ``goal``: the edge shared by ``e``, ``start``
    and ``goal`` (a triple-shared edge, Def. 7.3) is then not on the boundary
    of the non-removed cells (Fig. 7.6 (a)).
    """
    prev = e
    cur = start
    for _ in range(100000):
        la = _local_index(cells, cur, a)
        lb = _local_index(cells, cur, b)
        if la < 0 or lb < 0:
            return False
        m = (1 << la) | (1 << lb)
        nxt = -2
        for f in range(fmask.shape[0]):
            if fmask[f] & m == m:
                n = face_nb[cur, f]
                if n != prev:
                    nxt = n
                    break
        if nxt == goal:
            return True
        if nxt < 0 or nxt == e or cls[nxt] == 0:
            return False
        prev = cur
        cur = nxt
    return False


@njit
def _removable(c, cells, face_nb, fmask, cls, nb_node, stats, fa):
    """The tests of 7.5.2 for an unmarked cell ``c`` of class >= 1 (tetrahedra and hexahedra).

    ``fa`` is scratch space for the faces towards non-removed neighbours (6 entries).
    """
    nf = face_nb.shape[1]
    q = cls[c]
    if q == 1:
        return True  # C1: no triple-shared edge, no quadruple-shared node
    k = 0
    for f in range(nf):
        n = face_nb[c, f]
        if n >= 0 and cls[n] != 0:
            fa[k] = f
            k += 1
    if q == 2:
        shared = fmask[fa[0]] & fmask[fa[1]]
        if _popcount(shared) != 2:
            return False  # hexahedron with opposite faces: no triple-shared edge (Fig. 7.13 (a))
        la = _lowest_bit(shared)
        lb = _lowest_bit(shared & ~(1 << la))
        stats[ST_WALKS] += 1
        ok = _walk(cells, face_nb, fmask, cls, c, face_nb[c, fa[0]], face_nb[c, fa[1]], cells[c, la], cells[c, lb])
        if ok:
            stats[ST_WALKS_OK] += 1
        return ok
    # quadruple-shared nodes: local nodes that lie on three of the non-removed faces
    n_quad = 0
    all_inside = True
    for i in range(cells.shape[1]):
        cnt = 0
        for j in range(k):
            if (fmask[fa[j]] >> i) & 1:
                cnt += 1
        if cnt >= 3:
            n_quad += 1
            if nb_node[cells[c, i]] != 0:
                all_inside = False
    if nf == 4:  # tetrahedron C3: one quadruple-shared node (Fig. 7.6 (b))
        return all_inside
    # hexahedra (7.5.2, Fig. 7.13)
    if q == 3:
        if n_quad == 1:
            return all_inside
        # two triple-shared edges: E_a-E_b and E_b-E_c, E_b adjacent to both
        for mid in range(3):
            o1 = (mid + 1) % 3
            o2 = (mid + 2) % 3
            s1 = fmask[fa[mid]] & fmask[fa[o1]]
            s2 = fmask[fa[mid]] & fmask[fa[o2]]
            if _popcount(s1) == 2 and _popcount(s2) == 2:
                eb = face_nb[c, fa[mid]]
                for side in range(2):
                    s = s1 if side == 0 else s2
                    other = face_nb[c, fa[o1]] if side == 0 else face_nb[c, fa[o2]]
                    la = _lowest_bit(s)
                    lb = _lowest_bit(s & ~(1 << la))
                    stats[ST_WALKS] += 1
                    if not _walk(cells, face_nb, fmask, cls, c, other, eb, cells[c, la], cells[c, lb]):
                        return False
                    stats[ST_WALKS_OK] += 1
                return True
        return False
    if q == 4:
        # two quadruple-shared nodes (adjacent open faces) or four triple-shared edges (opposite
        # open faces: removing E could open an unneeded loop, so E stays)
        return n_quad == 2 and all_inside
    if q == 5:
        return n_quad == 4 and all_inside
    return False


@njit
def _remove(c, cells, face_nb, cls, nb_node, queue, head, tail, order, n_removed, src, labelled, st, half, t):
    """Class C0 for ``c``; neighbours move one class down and into that class's FIFO (7.5.1).

    With ``src`` of length N (labels deferred, :func:`thin_resume`), each node that comes onto the
    boundary also records the node whose group it took (``src``) and is appended to ``labelled``
    (``st[ST_N_LABELLED]`` of them so far). With ``half`` of length M (:func:`thin_halves`), only the
    neighbours with ``half == t`` (cells interior to this thread's half) go into the FIFO.
    """
    nf = face_nb.shape[1]
    cls[c] = 0
    if order.shape[0] > 0:
        order[n_removed] = c
    # Def. 7.8: nodes of c with n_B = 0 come onto the boundary; they take the group of c's other nodes
    lab = 0
    from_node = -1
    for i in range(cells.shape[1]):
        v = nb_node[cells[c, i]]
        if v != 0:
            lab = v
            from_node = cells[c, i]
            break
    if lab != 0:
        for i in range(cells.shape[1]):
            x = cells[c, i]
            if nb_node[x] == 0:
                nb_node[x] = lab
                if src.shape[0] > 0:
                    src[x] = from_node
                    labelled[st[ST_N_LABELLED]] = x
                    st[ST_N_LABELLED] += 1
    implicit = 0
    for f in range(nf):
        n = face_nb[c, f]
        if n >= 0 and cls[n] > 0:
            cls[n] -= 1
            q = cls[n]
            if q > 0:
                if half.shape[0] == 0 or half[n] == t:
                    queue[q, tail[q]] = n
                    tail[q] += 1
            else:
                implicit += 1
    return implicit


@njit
def _out_side(lab, root, is_void):
    return lab > 0 and not is_void[root[lab]]


@njit
def _face_side(c, f, cells, local_faces, nb_node, root, is_void, g):
    """1 when every node of local face f of c is on an outer (or already pricked) group, 2 when on void g, else 0."""
    all_out = True
    all_in = True
    for j in range(local_faces.shape[1]):
        lab = nb_node[cells[c, local_faces[f, j]]]
        if not _out_side(lab, root, is_void):
            all_out = False
        if lab <= 0 or root[lab] != g:
            all_in = False
    if all_out:
        return 1
    if all_in:
        return 2
    return 0


@njit
def _open_sides(c, cells, face_nb, local_faces, cls, nb_node, root, is_void, g):
    """Bit 1: c has an open face on the outer side; bit 2: an open face on void g."""
    out = 0
    for f in range(face_nb.shape[1]):
        n = face_nb[c, f]
        if n < 0 or cls[n] == 0:
            out |= _face_side(c, f, cells, local_faces, nb_node, root, is_void, g)
    return out


@njit
def _side_counts(c, cells, nb_node, root, is_void, g):
    """Nodes of ``c`` on an outer (or pricked) group, and on void g."""
    n_out = 0
    n_in = 0
    for i in range(cells.shape[1]):
        lab = nb_node[cells[c, i]]
        if _out_side(lab, root, is_void):
            n_out += 1
        elif lab > 0 and root[lab] == g:
            n_in += 1
    return n_out, n_in


@njit
def _find_prick(cells, face_nb, local_faces, cls, nb_node, root, is_void, g, picked):
    """Cells whose removal joins void g's layer to the outer boundary (7.5.3, Fig. 7.7).

    A cell with open faces on both sides (hexahedra in a one-cell layer), else
    the thesis's three: E with nodes on both sides, a neighbour E_1 with an
    open face on the outer side and a neighbour E_2 with an open face on the
    void. E_1 and E_2 must themselves have nodes on both sides, as they do in
    the thesis's configuration (E with two nodes on each side, E_1 and E_2
    sharing three of them): a neighbour touching only the outer side may be
    a one-cell strand of the skeleton, whose removal would cut it off.
    Returns how many cells were written to ``picked``.
    """
    m = cells.shape[0]
    for c in range(m):
        if cls[c] > 0 and _open_sides(c, cells, face_nb, local_faces, cls, nb_node, root, is_void, g) == 3:
            picked[0] = c
            return 1
    for c in range(m):
        if cls[c] <= 0:
            continue
        n_out, n_in = _side_counts(c, cells, nb_node, root, is_void, g)
        if n_out == 0 or n_in == 0:
            continue
        e1 = -1
        e2 = -1
        for f in range(face_nb.shape[1]):
            n = face_nb[c, f]
            if n < 0 or cls[n] <= 0:
                continue
            n = np.int64(n)  # face_nb may be int32: one build of the helpers, for c's type
            a, b = _side_counts(n, cells, nb_node, root, is_void, g)
            if a == 0 or b == 0:
                continue
            sides = _open_sides(n, cells, face_nb, local_faces, cls, nb_node, root, is_void, g)
            if sides == 1 and e1 < 0:
                e1 = n
            elif sides == 2 and e2 < 0:
                e2 = n
        if e1 >= 0 and e2 >= 0:
            picked[0] = e1
            picked[1] = c
            picked[2] = e2
            return 3
    return 0



#: slots of the state array of :func:`thin_resume`
ST_N_REMOVED = 0
ST_N_PRICKS = 1
ST_N_DEC = 2
ST_N_LABELLED = 3
N_STATE = 4


@njit
def fifo_init(cls, nf):
    """The FIFOs of 7.5.1 filled from the initial classes: ``(queue (F, M) int32, head (F,), tail (F,))``."""
    m = cls.shape[0]
    queue = np.empty((nf, m), np.int32)  # one FIFO per class 1 .. F-1 (row 0 unused)
    head = np.zeros(nf, np.int64)
    tail = np.zeros(nf, np.int64)
    for c in range(m):
        q = cls[c]
        if 0 < q < nf:  # touches the boundary and has a neighbour
            queue[q, tail[q]] = c
            tail[q] += 1
    return queue, head, tail


@njit
def thin(cells, face_nb, local_faces, fmask, cls, nb_node, root, is_void, prick, order, prick_log, stats, decisions):
    """Volume thinning (Fig. 7.5) in place on ``cls`` (classes) and ``nb_node`` (n_B).

    Parameters
    ----------
    cells (M, k), face_nb (M, F), local_faces (F, 3|4), fmask (F,)
    cls : (M,) int8, from :func:`initial_classes`
    nb_node : (N,) int64, boundary-group number of each node (0 inside)
    root : (G+1,) int64, root[g] = g; a pricked void is joined to an outer group here
    is_void : (G+1,) bool, group g bounds a void
    prick : bool, open the layers around voids (7.5.3)
    order : (M,) int64 or (0,); removed cells in removal order are written here (the recorder)
    prick_log : (G+1, 3) int64; per prick: removals before it, the void's group, cells removed
    stats : (N_STATS,) int64 counters
    decisions : (D, 4) int64 or (0, 4); with ``order``, every cell taken from a FIFO is a row here:
        cell, its class, 1 if removed, removals before it (the recorder of Figs 7.4, 7.6, 7.13)

    Returns
    -------
    n_removed : int
    n_pricks : int
    n_decisions : int
    """
    queue, head, tail = fifo_init(cls, face_nb.shape[1])
    st = np.zeros(N_STATE, np.int64)
    none = np.empty(0, np.int32)
    thin_resume(cells, face_nb, local_faces, fmask, cls, nb_node, root, is_void, prick, order, prick_log, stats,
                decisions, queue, head, tail, np.zeros(is_void.shape[0], np.bool_), st, none, none)
    return st[ST_N_REMOVED], st[ST_N_PRICKS], st[ST_N_DEC]


@njit
def thin_resume(cells, face_nb, local_faces, fmask, cls, nb_node, root, is_void, prick, order, prick_log, stats,
                decisions, queue, head, tail, tried, st, src, labelled):
    """:func:`thin` from a saved state: the FIFOs (:func:`fifo_init`), ``tried`` (G+1,) bool (voids
    pricked or tried), ``st`` (N_STATE,) int64 (removals, pricks, decisions, deferred labels so far).

    Labels may be deferred: the removal tests (7.5.2) ask only whether a node's ``n_B`` is 0, and the
    removal copies a group number from node to node; only pricking (7.5.3) reads the numbers. So with
    ``src`` (N,) int32 and ``labelled`` (N,) int32 (else empty) and ``prick=False``, ``nb_node`` may
    hold any non-zero placeholder on the boundary nodes: each node that comes onto the boundary
    records where its number came from (:func:`resolve_labels` puts in the real numbers afterwards),
    and the run stops when every FIFO is empty, before any pricking. A second call with the real
    numbers and ``prick`` resumes: the same removals, in the same order, as one call.
    """
    nf = face_nb.shape[1]
    n_removed = st[ST_N_REMOVED]
    n_pricks = st[ST_N_PRICKS]
    n_dec = st[ST_N_DEC]
    picked = np.empty(3, np.int64)
    fa = np.empty(6, np.int64)
    # _remove's filter off: every neighbour of class >= 1 is queued. A writable array, as
    # _thin_half's ``half``: a global one is read-only to numba, another build of _remove
    no_half = np.empty(0, np.int8)
    while True:
        q = 1
        c = -1
        while q < nf:  # the lowest class first (7.5.2)
            while head[q] < tail[q]:
                x = queue[q, head[q]]
                head[q] += 1
                if cls[x] == q:
                    c = x
                    break
                stats[ST_STALE] += 1
            if c >= 0:
                break
            q += 1
        if c >= 0:
            stats[ST_PROCESSED + q] += 1
            ok = _removable(c, cells, face_nb, fmask, cls, nb_node, stats, fa)
            if n_dec < decisions.shape[0]:
                decisions[n_dec, 0] = c
                decisions[n_dec, 1] = q
                decisions[n_dec, 2] = ok
                decisions[n_dec, 3] = n_removed
                n_dec += 1
            if ok:
                stats[ST_REMOVED + q] += 1
                stats[ST_IMPLICIT] += _remove(c, cells, face_nb, cls, nb_node, queue, head, tail, order, n_removed,
                                              src, labelled, st, no_half, 0)
                n_removed += 1
            continue
        if not prick:
            break
        # every FIFO is empty: prick one layer around a void and resume (7.5.3)
        g = -1
        for h in range(1, is_void.shape[0]):
            if is_void[h] and root[h] == h and not tried[h]:
                g = h
                break
        if g < 0:
            break
        tried[g] = True
        k = _find_prick(cells, face_nb, local_faces, cls, nb_node, root, is_void, g, picked)
        if k == 0:
            stats[ST_PRICK_FAILED] += 1
            continue
        # the void's group joins the outer group of the cells' outer side
        out_lab = 0
        for i in range(cells.shape[1]):
            lab = nb_node[cells[picked[0], i]]
            if _out_side(lab, root, is_void):
                out_lab = root[lab]
                break
        prick_log[n_pricks, 0] = n_removed
        prick_log[n_pricks, 1] = g
        prick_log[n_pricks, 2] = k
        n_pricks += 1
        for j in range(k):
            stats[ST_IMPLICIT] += _remove(picked[j], cells, face_nb, cls, nb_node, queue, head, tail, order,
                                          n_removed, src, labelled, st, no_half, 0)
            n_removed += 1
        root[g] = out_lab
        stats[ST_PRICKS] += 1
        stats[ST_PRICK_CELLS] += k
    st[ST_N_REMOVED] = n_removed
    st[ST_N_PRICKS] = n_pricks
    st[ST_N_DEC] = n_dec


@njit(parallel=True)
def cell_halves(cells, nc_off, nc, split):
    """(M,) int8: 0 for a cell interior to the half ``[0, split)`` of the cells, 1 to ``[split, M)``, -1
    for a band cell (one of its nodes is touched by cells of both halves).

    ``nc_off``, ``nc``: the node -> cells lists, ascending (a node is in both halves when its first
    cell is below ``split`` and its last is not). A cell interior to a half shares its faces, edges and
    nodes only with cells of that half (every cell touching one of its nodes is in the half), so its
    removal tests (7.5.2) read and its removal writes only that half's cells and nodes.
    """
    m, k = cells.shape
    out = np.empty(m, np.int8)
    for c in prange(m):
        h = 0 if c < split else 1
        for i in range(k):
            x = cells[c, i]
            if nc[nc_off[x]] < split <= nc[nc_off[x + 1] - 1]:
                h = -1
                break
        out[c] = h
    return out


@njit(cache=_KCACHE)  # built with the prefetch intrinsic or its plain fallback (see _intrinsics)
def _thin_half(t, lo, hi, cells, face_nb, fmask, cls, nb_node, half, stats, order, decisions, st, src,
               labelled):
    """The FIFO of 7.5.2 (lowest class first, no pricking) over the cells ``half == t`` of ``[lo, hi)``.

    Each pop hints the rows of ``face_nb`` and ``cells`` of the cell :data:`FIFO_LOOKAHEAD` places
    further in the same FIFO, which the removal tests will read.
    """
    nf = face_nb.shape[1]
    queue = np.empty((nf, hi - lo), np.int32)  # a cell enters each class's FIFO at most once
    head = np.zeros(nf, np.int64)
    tail = np.zeros(nf, np.int64)
    for c in range(lo, hi):
        q = cls[c]
        if half[c] == t and 0 < q < nf:
            queue[q, tail[q]] = c
            tail[q] += 1
    n_removed = 0
    n_dec = 0
    fa = np.empty(6, np.int64)
    while True:
        q = 1
        c = -1
        while q < nf:
            while head[q] < tail[q]:
                h = head[q]
                if h + FIFO_LOOKAHEAD < tail[q]:
                    y = queue[q, h + FIFO_LOOKAHEAD]
                    _prefetch_row(face_nb, y)
                    _prefetch_row(cells, y)
                x = queue[q, h]
                head[q] = h + 1
                if cls[x] == q:
                    c = x
                    break
                stats[ST_STALE] += 1
            if c >= 0:
                break
            q += 1
        if c < 0:
            break
        stats[ST_PROCESSED + q] += 1
        ok = _removable(c, cells, face_nb, fmask, cls, nb_node, stats, fa)
        if n_dec < decisions.shape[0]:
            decisions[n_dec, 0] = c
            decisions[n_dec, 1] = q
            decisions[n_dec, 2] = ok
            decisions[n_dec, 3] = n_removed
            n_dec += 1
        if ok:
            stats[ST_REMOVED + q] += 1
            stats[ST_IMPLICIT] += _remove(c, cells, face_nb, cls, nb_node, queue, head, tail, order, n_removed,
                                          src, labelled, st, half, t)
            n_removed += 1
    st[ST_N_REMOVED] = n_removed
    st[ST_N_DEC] = n_dec


@njit(parallel=True, cache=_KCACHE)  # it compiles _thin_half in: the same cache rule
def thin_halves(cells, face_nb, fmask, cls, nb_node, half, split, stats2, order, decisions, dec_split, st2, src,
                labelled2):
    """The FIFO of 7.5.2 in the two halves of the cells at once, each over its interior cells only.

    Parameters
    ----------
    half : (M,) int8, from :func:`cell_halves` at ``split``
    stats2 : (2, N_STATS) int64, each half's counters
    order : (M,) int64 or (0,); half 0 writes its removals from 0, half 1 from ``split``
    decisions : (D, 4) int64 or (0, 4); half 0 from row 0, half 1 from row ``dec_split`` (``decided_after``
        counts the half's own removals)
    st2 : (2, N_STATE) int64, each half's removals, decisions and deferred labels
    src : (N,) int32 or (0,); with ``labelled2`` (2, N) int32: deferred labels as in :func:`thin_resume`,
        each half appending to its row

    A cell interior to a half reads and writes only cells and nodes of that half (:func:`cell_halves`),
    so the halves share nothing and run in either order or at once with the same result; the removals
    are those of a serial FIFO that ran half 0's, then half 1's. The cells left (the band and whatever
    the halves could not remove next to it) are for :func:`fifo_init` and :func:`thin_resume`.
    """
    m = cells.shape[0]
    rec = order.shape[0] > 0
    for t in prange(2):
        lo = 0 if t == 0 else split
        hi = split if t == 0 else m
        o = order[lo:hi] if rec else order
        if decisions.shape[0] > 0:
            d = decisions[:dec_split] if t == 0 else decisions[dec_split:]
        else:
            d = decisions
        lab = labelled2[t] if src.shape[0] > 0 else labelled2[0, :0]
        # t as int64: a prange index is uint64 in the parallel body and int64 where numba types the
        # kernel first, two builds of _thin_half (and _remove) otherwise
        _thin_half(np.int64(t), lo, hi, cells, face_nb, fmask, cls, nb_node, half, stats2[t], o, d, st2[t], src,
                   lab)


@njit
def resolve_labels(nb_node, src, labelled, n_labelled):
    """The deferred group numbers of :func:`thin_resume`: each node labelled there takes the number
    of the node it recorded, in the order they were labelled (that node has its number by then)."""
    for i in range(n_labelled):
        x = labelled[i]
        nb_node[x] = nb_node[src[x]]


@njit
def neighbour_counts(face_nb, cls, cells_of_interest, out):
    """Non-removed face neighbours of each listed cell (the classes of Table 7.2)."""
    for i in range(cells_of_interest.shape[0]):
        c = cells_of_interest[i]
        n = 0
        for f in range(face_nb.shape[1]):
            nb = face_nb[c, f]
            if nb >= 0 and cls[nb] != 0:
                n += 1
        out[i] = n


@njit
def query(skel_cells, skel_min, skel_max, offsets, ids, lo, hi, width, nb, value, hits):
    """Test the skeleton cells of the value class of ``value`` (7.5.4, 7.5.5 step 4 (a)).

    A cell is crossed when ``S_min < C <= S_max`` (the marching cases'
    "node >= C" convention). Returns ``(n_hits, n_tested)``.
    """
    if not (lo <= value <= hi):
        return 0, 0
    if width <= 0.0:
        b = 0
    else:
        t = (value - lo) / width
        # never an index from NaN (inf / inf when hi - lo overflows float64): NaN goes to class 0
        if t >= nb - 1:
            b = nb - 1
        elif t > 0.0:
            b = int(t)
        else:
            b = 0
    k = 0
    for j in range(offsets[b], offsets[b + 1]):
        i = ids[j]
        if skel_min[i] < value <= skel_max[i]:
            hits[k] = skel_cells[i]
            k += 1
    return k, offsets[b + 1] - offsets[b]


# ------------------------------------------------------------------ 2D image thinning (7.3)
# the 8 neighbours of a pixel in cyclic order, starting east, counter-clockwise (Fig. 7.2 numbering)
_DI = np.array([0, -1, -1, -1, 0, 1, 1, 1], np.int64)
_DJ = np.array([1, 1, 0, -1, -1, -1, 0, 1], np.int64)


@njit
def _pixel(img, i, j):
    if i < 0 or j < 0 or i >= img.shape[0] or j >= img.shape[1]:
        return False
    return img[i, j]


@njit
def _pixel_removable(img, i, j):
    """The two conditions of 7.3 for a border pixel (Fig. 7.2 (b)-(e))."""
    nb = np.zeros(8, np.bool_)
    n_edge = 0
    n_all = 0
    for k in range(8):
        nb[k] = _pixel(img, i + _DI[k], j + _DJ[k])
        if nb[k]:
            n_all += 1
            if k % 2 == 0:
                n_edge += 1
    if n_edge == 0:
        return False  # an isolated pixel or one joined by corners only: keep it
    if n_edge == 1 and n_all == 1:
        return False  # the end of a line: removing it would shorten the skeleton
    # the remaining pixels around p must form one run that holds every edge neighbour
    start = -1
    for k in range(8):
        if not nb[k]:
            start = k
            break
    if start < 0:
        return False  # an interior pixel
    runs = 0
    edge_runs = 0
    k = 0
    while k < 8:
        idx = (start + k) % 8
        if nb[idx]:
            runs += 1
            has_edge = False
            while k < 8 and nb[(start + k) % 8]:
                if (start + k) % 2 == 0:
                    has_edge = True
                k += 1
            if has_edge:
                edge_runs += 1
        else:
            k += 1
    return edge_runs == 1


@njit
def thin_image(img, order):
    """Remove border pixels, layer by layer, until no pixel can go (7.3). Returns removals."""
    n = 0
    h, w = img.shape
    border = np.empty((h * w, 2), np.int64)
    while True:
        nb_ = 0
        for i in range(h):
            for j in range(w):
                if img[i, j] and (not _pixel(img, i - 1, j) or not _pixel(img, i + 1, j)
                                  or not _pixel(img, i, j - 1) or not _pixel(img, i, j + 1)):
                    border[nb_, 0] = i
                    border[nb_, 1] = j
                    nb_ += 1
        removed = 0
        for t in range(nb_):
            i = border[t, 0]
            j = border[t, 1]
            if _pixel_removable(img, i, j):
                img[i, j] = False
                if order.shape[0] > 0:
                    order[n, 0] = i
                    order[n, 1] = j
                n += 1
                removed += 1
        if removed == 0:
            return n


# ------------------------------------------------------------------ is the boundary a 2-manifold?
@njit
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit
def _join(parent, a, b):
    """Union of the sets of a and b; the root is the smaller one, so each set's root is its smallest item."""
    a = _find(parent, a)
    b = _find(parent, b)
    if a != b:
        parent[max(a, b)] = min(a, b)


@njit
def _lower_corner(face_nodes, f, j):
    """The corners (face * k + local node) of the edge from local node j to j+1 of face f, lower node first."""
    k = face_nodes.shape[1]
    j1 = j + 1 if j + 1 < k else 0
    if face_nodes[f, j] > face_nodes[f, j1]:
        return f * k + j1, f * k + j
    return f * k + j, f * k + j1


@njit
def boundary_defects(face_nodes, edge_ids, n_edges, n_nodes):
    """Non-manifold edges and nodes of a boundary surface, in O(faces + nodes) without a sort.

    ``face_nodes`` (F, k) the boundary faces; ``edge_ids`` (F*k,) the edge
    (numbered by lower node, then higher) from corner j to j+1 of each face.
    An edge on exactly two faces joins its lower-node corners in both faces
    and its higher-node corners (union-find over the F*k corners); the
    corners of a node in one set form one fan of faces around it, and a
    set's root is its smallest corner, so counting the roots of each node
    counts its fans. Returns ``(edge numbers on other than two faces,
    ascending; nodes with more than one fan, ascending)``, both int64.
    """
    nbf, k = face_nodes.shape
    count = np.zeros(n_edges, np.int32)
    first = np.empty(n_edges, np.int64)
    for i in range(nbf * k):
        e = edge_ids[i]
        if count[e] == 0:
            first[e] = i
        count[e] += 1
    n_bad = 0
    for e in range(n_edges):
        n_bad += count[e] != 2
    bad_edges = np.empty(n_bad, np.int64)
    n_bad = 0
    for e in range(n_edges):
        if count[e] != 2:
            bad_edges[n_bad] = e
            n_bad += 1
    parent = np.arange(nbf * k)
    for f in range(nbf):
        for j in range(k):
            i = f * k + j
            e = edge_ids[i]
            if count[e] != 2 or first[e] == i:
                continue
            g = first[e] // k
            lo_a, hi_a = _lower_corner(face_nodes, f, j)
            lo_b, hi_b = _lower_corner(face_nodes, g, first[e] - g * k)
            _join(parent, lo_a, lo_b)
            _join(parent, hi_a, hi_b)
    fans = np.zeros(n_nodes, np.int32)
    for f in range(nbf):
        for j in range(k):
            if parent[f * k + j] == f * k + j:
                fans[face_nodes[f, j]] += 1
    n_bad = 0
    for v in range(n_nodes):
        n_bad += fans[v] > 1
    bad_nodes = np.empty(n_bad, np.int64)
    n_bad = 0
    for v in range(n_nodes):
        if fans[v] > 1:
            bad_nodes[n_bad] = v
            n_bad += 1
    return bad_edges, bad_nodes
