"""Numba kernels of the cell-edge-centred polygon construction (2001 paper, Fig. 5).

Arrays in, arrays out; the only polygen imports are the marching kernels,
the intrinsics (:mod:`polygen.volume._intrinsics`) and the JIT options. See
:mod:`polygen.volume.edge_centred` for the algorithm.

Everything a query needs to know about a cell sits in one *record*, a row
of ``rec`` (M, R) int32 in whole 64-byte cache lines (R = 16 for
tetrahedra: 64 bytes, one line; 48 for hexahedra), so that visiting a cell
touches one line (tetrahedra):

``rec[c, R_GEN]``
    generation stamp: the query that last touched the cell;
``rec[c, R_STATE]``
    its state in that query: ``NOT_CROSSED``, ``QUEUED`` (a crossed seed
    whose polygon is not constructed yet) or, ``>= 0``, the constructed
    polygon: marching case ``| exact << 16`` (bit ``i`` of ``exact``: node
    ``i`` lies exactly at the isovalue), and for tetrahedra ``| mask <<
    MASK_SHIFT``, the polygon's vertex codes as bits (see below);
``rec[c, R_NODES:R_NODES+nn]``
    the node ids;
``rec[c, os:os+W]`` with ``os = R_NODES + nn``
    the polygon's vertex slots. A vertex *code* is ``e`` for the vertex on
    local edge ``e`` and ``n_local_edges + i`` for the vertex that is node
    ``i`` itself (a crossing exactly on a node). Hexahedra keep one slot per
    code (``W = 12 + 8``); a tetrahedron's polygon has at most four
    vertices, so it keeps four slots (``W = 4``) and code ``w`` lives in slot
    ``popcount(mask & ((1 << w) - 1))`` (:func:`_slot`). The slots are
    cleared when the polygon is constructed, so they are valid only in the
    query that constructed it;
``rec[c, ost:ost+ne]`` with ``ost = os + W``
    per local edge, where the list of the cells around it starts in ``ec``,
    so that creating a vertex goes from the cell straight to its
    neighbours. The edge ids themselves (the vertex keys, needed once per
    vertex) are read from the volume's ``cell_edges``, which it keeps.

The stamp, state and slots are the only fields a query writes. A second
builder on the same records (:meth:`EdgeCentredTable.copy`, one per thread
of ``extract_many``) reads the shared records and keeps those three fields
in its own array ``dyn`` (M, 2 + W) int32: every kernel takes ``dyn`` and
the column ``ds`` of its slots (``dyn = rec, ds = os`` for the builder
that owns the records).

The cells around an edge (``ec``) and around a node (``nc``, built at the
first query that meets a crossing exactly on a node) are stored
as ``cell << 5 | last << 4 | local``: the cell, whether it ends the list,
and the local index of the edge (node) in that cell. Registering a vertex
into a polygon is one store into the slot of that local index; nothing is
ever looked up by key.

The construction is a chain of dependent loads into arrays much larger
than the caches (record -> list of cells -> their records). The kernels ask
the processor to fetch the lines they are about to need a little early
(``llvm.prefetch``, which changes no result), so that those misses overlap
instead of waiting one after the other.
"""

import numpy as np

from polygen._jit import njit, prange
from polygen.volume import _intrinsics
from polygen.volume import marching as _m
from polygen.volume._intrinsics import (  # noqa: F401 - re-exported: tests and callers use them from here
    _KCACHE,
    ATOMICS,
    PREFETCH,
    _ctz,
    _ctz_plain,
    _prefetch_item,
    _prefetch_item_plain,
    _prefetch_row,
    _prefetch_row_plain,
)

if _intrinsics.intrinsic is not None:  # defined only where numba's internals are there (as before the move)
    from polygen.volume._intrinsics import _cas, _cas_row, _fetch_add  # noqa: F401

NOT_CROSSED = -1
QUEUED = -2
#: kernel status codes: 0 done, 1-3 the buffer that overflowed, 4 the cells around the nodes are needed
OK, FULL_QUEUE, FULL_TRIANGLES, FULL_VERTICES, NEED_NODE_CELLS = 0, 1, 2, 3, 4
#: :func:`_flood` stopped after its budget of cells (a test interleaves two threads' work this way)
PAUSED = 5
#: counters written by :func:`construct` (indices into ``counters``)
#: ``C_SLOT_READS``: reads of a registered vertex id from a cell's slot as its triangles are written, one
#: per triangle corner (these kernels read no vertex by a key: a vertex is only ever read from its slot)
C_POPS, C_VISITS, C_TOUCHED, C_CONSTRUCTED, C_NODE_TESTS, C_NODE_VERTICES, C_SLOT_READS = 0, 1, 2, 3, 4, 5, 6
N_COUNTERS = 7
#: how far ahead in a FIFO the next cells' records are fetched
LOOKAHEAD = 16
#: record fields
R_GEN, R_STATE, R_NODES = 0, 1, 2
#: incidence packing: ``cell << CELL_SHIFT | LAST | local``
CELL_SHIFT = 5
LAST = 16
LOCAL = 15
#: where a tetrahedron's state keeps the bits of its polygon's vertex codes
MASK_SHIFT = 20
#: bits set in each 10-bit number (a tetrahedron's slot of code ``w``: the codes below ``w`` in its mask)
_POPCOUNT = np.array([bin(i).count("1") for i in range(1 << 10)], np.int32)


def record_layout(n_nodes, n_local_edges):
    """``(os, n_slots, ost, width)``: where the slots and the edge-list starts are, and the record length in int32.

    Stamp, state, nodes, slots (four for a tetrahedron, one per vertex code
    otherwise), edge-list starts, in whole 64-byte lines.
    """
    n_slots = 4 if n_nodes == 4 else n_local_edges + n_nodes
    os_ = R_NODES + n_nodes
    ost = os_ + n_slots
    return os_, n_slots, ost, -(-(ost + n_local_edges) // 16) * 16


def case_masks(tri_table, tri_count):
    """(n_cases,) int32: the local edges the triangles of each case use, as bits."""
    out = np.zeros(tri_count.shape[0], np.int32)
    for case in range(tri_count.shape[0]):
        for e in tri_table[case, :3 * tri_count[case]]:
            out[case] |= 1 << int(e)
    return out


# ------------------------------------------------------------------ intrinsics
# The prefetch hints, the count of trailing zeros and the atomics (with ``PREFETCH``, ``ATOMICS``
# and ``_KCACHE``) live in :mod:`polygen.volume._intrinsics`, shared with the thinning kernels.


# ------------------------------------------------------------------ preprocessing
@njit
def pack_incidence(offsets, order, width):
    """CSR values ``order`` (flat positions ``cell * width + local``) packed as ``cell << 5 | last << 4 | local``."""
    out = np.empty(order.shape[0], np.int32)
    for k in range(offsets.shape[0] - 1):
        for q in range(offsets[k], offsets[k + 1]):
            flat = order[q]
            last = LAST if q == offsets[k + 1] - 1 else 0
            out[q] = np.int32(((flat // width) << CELL_SHIFT) | last | (flat % width))
    return out


@njit(parallel=True)
def edge_lists_and_records(cells, cell_edges, n_edges, n_threads, rec, os_, ost):
    """The cells around each edge, packed, and the records of every cell, in one parallel pass each.

    Returns ``(ec, starts)`` (int32): the list of edge ``e`` is
    ``ec[starts[e]:]`` up to the entry with ``LAST`` set, each entry
    ``cell << CELL_SHIFT | last | local`` with the cells in increasing
    order, and ``ec[starts[e] - 1] == e``, on the same cache line as the
    list's first entry most of the time, so the vertex key costs no extra
    memory access. A stable counting sort of the flat positions
    ``cell * L + local`` by edge id: the cells are cut into slabs (one per
    thread, at most 8), each counted and scattered by one thread, slab
    ``t`` of edge ``e`` after every slab ``< t``; so the result does not
    depend on the number of threads.

    When ``rec`` has rows, each gets its node ids and, per local edge, where
    that edge's list starts (stamps and states zeroed, slots ``os_:ost``
    cleared to -1); ``rec`` is left alone when it has none (layout
    ``"volume"``). Offsets are int32: the caller checks that
    ``M * L + n_edges`` fits.
    """
    m, ne = cell_edges.shape
    nn = cells.shape[1]
    n_slabs = max(1, min(n_threads, 8, (m * ne) // 65536))
    bounds = np.empty(n_slabs + 1, np.int64)
    for t in range(n_slabs + 1):
        bounds[t] = (m * t) // n_slabs
    counts = np.zeros((n_slabs, n_edges), np.int32)
    for t in prange(n_slabs):
        for c in range(bounds[t], bounds[t + 1]):
            for w in range(ne):
                counts[t, cell_edges[c, w]] += 1
    starts = np.empty(n_edges, np.int32)
    h = 0
    for e in range(n_edges):  # each list after its edge's id
        h += 1
        starts[e] = h
        for t in range(n_slabs):
            k = counts[t, e]
            counts[t, e] = h
            h += k
    ec = np.empty(h, np.int32)
    for t in prange(n_slabs):
        for c in range(bounds[t], bounds[t + 1]):
            for w in range(ne):
                e = cell_edges[c, w]
                q = counts[t, e]
                counts[t, e] = q + 1
                ec[q] = np.int32((c << CELL_SHIFT) | w)
    for e in prange(n_edges):
        first = starts[e]
        ec[first - 1] = e
        end = starts[e + 1] - 1 if e + 1 < n_edges else h  # the next edge's id, or the end
        if end > first:
            ec[end - 1] |= LAST
    if rec.shape[0] > 0:
        for c in prange(m):
            for w in range(rec.shape[1]):
                rec[c, w] = 0
            for i in range(nn):
                rec[c, R_NODES + i] = cells[c, i]
            for w in range(os_, ost):
                rec[c, w] = -1
            for w in range(ne):
                rec[c, ost + w] = starts[cell_edges[c, w]]
    return ec, starts


# ------------------------------------------------------------------ cells
@njit(inline="always")
def _face_bits(case, exact, nn, vals, value, faces):
    """``(case, exact)`` from the corner bits: -1 when not crossed, else with the ambiguous faces' bits."""
    if case == 0 or case == (1 << nn) - 1:
        return -1, exact
    for f in range(faces.shape[0]):
        a = vals[faces[f, 0]]
        b = vals[faces[f, 1]]
        d = vals[faces[f, 2]]
        e = vals[faces[f, 3]]
        ua, ub, ud, ue = a >= value, b >= value, d >= value, e >= value
        if ua == ud and ub == ue and ua != ub:
            # face-centre value [71]: the mean of the four corners (as marching._cell_case)
            if _m._sorted_sum4(a, b, d, e) * 0.25 >= value:
                case |= 1 << (8 + f)
    return case, exact


@njit(inline="always")
def _values_of(nodes, c, nn, s, value, faces, vals):
    """Node values of cell ``c`` (nodes ``nodes[c]``) into ``vals``; returns ``(case, exact)``.

    ``case`` is :func:`polygen.volume.marching._cell_case`'s (-1: not
    crossed), from values read once; bit ``i`` of ``exact``: node ``i`` is
    exactly at ``value``.
    """
    case = 0
    exact = 0
    for i in range(nn):
        x = s[nodes[c, i]]
        vals[i] = x
        if x >= value:
            case |= 1 << i
        if x == value:
            exact |= 1 << i
    return _face_bits(case, exact, nn, vals, value, faces)


@njit(inline="always")
def _node_values(rec, c, nn, s, value, faces, vals):
    """:func:`_values_of` with the nodes in a record (``rec[c, R_NODES:R_NODES+nn]``)."""
    case = 0
    exact = 0
    for i in range(nn):
        x = s[rec[c, R_NODES + i]]
        vals[i] = x
        if x >= value:
            case |= 1 << i
        if x == value:
            exact |= 1 << i
    return _face_bits(case, exact, nn, vals, value, faces)


@njit(inline="always")
def _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, out):
    """Triangles of a polygon with a node at the isovalue, as slots.

    ``marching._cell_codes`` with node codes ``n_local_edges + i``; returns
    ``(k, mask)``: the triangles kept (zero-area ones are dropped) and the
    slots of the whole polygon, dropped triangles included. A polygon that
    collapses onto its nodes has no triangle, but its vertices must still be
    registered: for-loop (3) of a node vertex is what reaches the cells
    around the node, one of which may hold a real triangle (a boundary face
    exactly at ``C``); vertices no triangle uses are dropped afterwards
    (``surface.drop_unreferenced``).
    """
    ne = local_edges.shape[0]
    k = 0
    mask = 0
    for t in range(tri_count[case]):
        for j in range(3):
            e = tri_table[case, 3 * t + j]
            a = local_edges[e, 0]
            hi = a if vals[a] >= value else local_edges[e, 1]
            out[k, j] = ne + hi if (exact >> hi) & 1 else e
            mask |= 1 << out[k, j]
        if out[k, 0] != out[k, 1] and out[k, 0] != out[k, 2] and out[k, 1] != out[k, 2]:
            k += 1
    return k, mask


@njit(inline="always")
def _make_polygon(rec, c, case, exact, n_slots, os_):
    """Construct P_c in its record: its state, its vertex slots cleared."""
    rec[c, R_STATE] = case | (exact << 16)
    for w in range(n_slots):
        rec[c, os_ + w] = -1


@njit(inline="always")
def _slot(st, w, nn):
    """The slot of vertex code ``w`` in a polygon of state ``st`` (tetrahedra: its rank in the mask)."""
    if nn == 4:
        return _POPCOUNT[(st >> MASK_SHIFT) & ((1 << w) - 1)]
    return w


@njit(inline="always")
def _uses(st, w, nn):
    """Whether the polygon of state ``st`` has vertex code ``w`` (always, for a polygon with a slot per code)."""
    if nn == 4:
        return (st >> (MASK_SHIFT + w)) & 1 == 1
    return True


@njit(inline="always")
def _exact_of(st, nn):
    return (st >> 16) & ((1 << nn) - 1)


@njit(inline="always")
def _construct_polygon(dyn, ds, c, case, exact, nn, n_slots, vals, value, tri_table, tri_count, case_mask,
                       local_edges, codes):
    """Construct P_c: its state (tetrahedra: with its vertex codes), its vertex slots cleared.

    ``vals`` holds the cell's node values (:func:`_node_values`); ``codes``
    is scratch, overwritten for a polygon with a node at the isovalue.
    """
    st = case | (exact << 16)
    if nn == 4:
        if exact == 0:
            mask = case_mask[case]
        else:
            _, mask = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
        st |= mask << MASK_SHIFT
    dyn[c, R_STATE] = st
    for w in range(n_slots):
        dyn[c, ds + w] = -1


# Why construct's hot loop writes _construct_polygon, _register and the edge-list start out instead of
# calling them: an ``inline="always"`` helper is inlined in numba IR, where every array argument becomes
# a new reference (NRT_incref at the call, NRT_decref after), and numba's refcount pruning removes such
# pairs only when they are not split by branches. Those helpers branch (tetrahedron or not, a node at the
# isovalue or not), so each call cost up to ~14 atomic reference-count updates per cell: on data 4 the
# construction went from 56 to 84 ms for 20 surfaces (the records and slots themselves cost nothing).
# Written out (the rare path, a node at the isovalue, in the non-inlined _exact_mask), it is 52 ms.
@njit
def _exact_mask(case, exact, vals, value, tri_table, tri_count, local_edges, codes):
    """The vertex codes (bits) of a polygon with a node at the isovalue (the rare path, not inlined)."""
    _, mask = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
    return mask


@njit(inline="always")
def _register(dyn, ds, j, w, v, nn):
    """Register vertex ``v`` into P_j as its vertex code ``w`` (a code P_j does not use is skipped)."""
    st = dyn[j, R_STATE]
    if _uses(st, w, nn):
        dyn[j, ds + _slot(st, w, nn)] = v


@njit
def test_seeds(nodes, dyn, nn, s, value, faces, seeds, gen, queue):
    """t1: test each seed once, queue the crossed ones. Returns ``(tested, queued)``.

    A crossed seed is ``QUEUED``: its polygon is constructed when it is taken
    from the FIFO or reached from a neighbour, whichever comes first.
    """
    vals = np.empty(8, np.float64)
    tested = 0
    n = 0
    for i in range(seeds.shape[0]):
        c = seeds[i]
        if dyn[c, R_GEN] == gen:
            continue
        dyn[c, R_GEN] = gen
        tested += 1
        case, _ = _values_of(nodes, c, nn, s, value, faces, vals)
        if case >= 0:
            dyn[c, R_STATE] = QUEUED
            queue[n] = c
            n += 1
        else:
            dyn[c, R_STATE] = NOT_CROSSED
    return tested, n


@njit
def _node_vertex(nodes, dyn, ds, nn, n_slots, s, value, faces, tri_table, tri_count, case_mask, local_edges, ne,
                 nc_off, nc, node, v, gen, queue, tail):
    """For-loop (3) for a vertex that is ``node`` itself: register it in every crossed cell around the node.

    A cell around the node may lie wholly above the isovalue, so each cell
    seen for the first time is tested. Returns ``(status, tail, tested,
    constructed)``.
    """
    vals = np.empty(8, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    tested = 0
    made = 0
    for q in range(nc_off[node], nc_off[node + 1]):
        packed = nc[q]
        j = packed >> CELL_SHIFT
        if dyn[j, R_GEN] != gen:
            dyn[j, R_GEN] = gen
            tested += 1
            cj, xj = _values_of(nodes, j, nn, s, value, faces, vals)
            if cj < 0:
                dyn[j, R_STATE] = NOT_CROSSED
                continue
            if tail == queue.shape[0]:
                return FULL_QUEUE, tail, tested, made
            _construct_polygon(dyn, ds, j, cj, xj, nn, n_slots, vals, value, tri_table, tri_count, case_mask,
                               local_edges, codes)
            made += 1
            queue[tail] = j
            tail += 1
        else:
            sj = dyn[j, R_STATE]
            if sj == NOT_CROSSED:
                continue
            if sj == QUEUED:
                cj, xj = _values_of(nodes, j, nn, s, value, faces, vals)
                _construct_polygon(dyn, ds, j, cj, xj, nn, n_slots, vals, value, tri_table, tri_count, case_mask,
                                   local_edges, codes)
                made += 1
        _register(dyn, ds, j, ne + (packed & LOCAL), v, nn)
    return OK, tail, tested, made


# ------------------------------------------------------------------ the construction
@njit(cache=_KCACHE)
def construct(nodes, ids, starts, dyn, ds, nn, s, value, faces, tri_table, tri_count, case_mask, local_edges, n_edges,
              ec_off, ec, nc_off, nc, gen, queue, n_queued, lifo, tris, tri_cell, vkey, vend, counters):
    """t2: the cell-edge-centred construction (Fig. 5, for-loops (1)-(3)).

    ``queue`` holds the ``n_queued`` crossed seeds (marked ``QUEUED``);
    ``lifo`` takes the most recent cell first instead of the oldest (the
    same surface; better cache reuse). A cell's triangles are written, as
    vertex ids, when it is taken from the queue: by then every vertex of
    its polygon has been registered. Vertex ``v`` gets its key ``vkey[v]``
    and the ends of its edge ``vend[v]`` (smaller node id first; the node
    twice for a crossing on a node). A cell's nodes are ``nodes[c]``, its
    edge ids ``ids[c]``, its edge-list starts ``starts[c]`` (or, ``starts``
    empty, ``ec_off[ids[c]]``; an edge's id is the entry before its list:
    :func:`pack_edge_lists`): all read only; stamps, states and slots are
    written into ``dyn`` (slots from column ``ds``).

    Returns ``(status, n_polygons, n_triangles, n_vertices,
    any_node_vertex)``; ``status != OK`` names the buffer that was too
    small, or asks for the cells around the nodes (``nc_off`` empty: not
    built yet); the caller grows or builds it and starts the query again
    under a new generation.
    """
    ne = local_edges.shape[0]
    n_slots = 4 if nn == 4 else ne + nn
    cap_t = tris.shape[0] - _m.MAX_TRIANGLES
    cap_v = vkey.shape[0]
    cap_q = queue.shape[0]
    vals = np.empty(8, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)  # the polygon of the cell taken
    codes_j = np.empty((_m.MAX_TRIANGLES, 3), np.int64)  # scratch for the polygons constructed around it
    n_p = 0
    n_t = 0
    n_v = 0
    head = 0
    tail = n_queued
    pops = 0
    visits = 0
    touched = 0
    node_tests = 0
    node_vertices = 0
    slot_reads = 0  # triangle corners read from their cell's vertex slots
    while head < tail:  # for-loop (1): cells taken from the FIFO
        if lifo:
            tail -= 1
            c = queue[tail]
        else:
            c = queue[head]
            head += 1
            if head + LOOKAHEAD < tail:
                _prefetch_row(nodes, queue[head + LOOKAHEAD])
                _prefetch_row(dyn, queue[head + LOOKAHEAD])
        pops += 1
        st = dyn[c, R_STATE]
        if st == QUEUED:  # a seed nobody reached before: construct P_i
            case, exact = _values_of(nodes, c, nn, s, value, faces, vals)
            _construct_polygon(dyn, ds, c, case, exact, nn, n_slots, vals, value, tri_table, tri_count, case_mask,
                               local_edges, codes)
            n_p += 1
            st = dyn[c, R_STATE]
        case = st & 0xFFFF
        exact = _exact_of(st, nn)
        if exact == 0:
            k = tri_count[case]
            todo = case_mask[case]
        else:  # a node at the isovalue: node codes, zero-area triangles dropped
            for i in range(nn):
                vals[i] = s[nodes[c, i]]
            k, todo = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
        # the cell lists of its open edges, fetched together before for-loop (2) walks them one by one
        # (without records: first where each list starts, then the lists)
        if starts.shape[0] == 0:
            pre = todo & ((1 << ne) - 1)
            while pre:
                w = _ctz(pre)
                pre &= pre - 1
                if dyn[c, ds + _slot(st, w, nn)] < 0:
                    _prefetch_item(ec_off, ids[c, w])
        pre = todo & ((1 << ne) - 1)
        while pre:
            w = _ctz(pre)
            pre &= pre - 1
            if dyn[c, ds + _slot(st, w, nn)] < 0:
                _prefetch_item(ec, (starts[c, w] if starts.shape[0] > 0 else ec_off[ids[c, w]]))
        # for-loop (2): the vertices of P_i not registered yet
        while todo:
            w = _ctz(todo)
            todo &= todo - 1
            if dyn[c, ds + _slot(st, w, nn)] >= 0:
                continue
            if n_v == cap_v:
                return FULL_VERTICES, n_p, n_t, n_v, node_vertices > 0
            if w >= ne and nc_off.shape[0] == 0:
                return NEED_NODE_CELLS, n_p, n_t, n_v, True
            v = n_v
            n_v += 1
            if w < ne:  # a vertex on cell edge E_n: its cells, straight from the edge's list
                lo = (starts[c, w] if starts.shape[0] > 0 else ec_off[ids[c, w]])
                vkey[v] = ec[lo - 1]  # the edge's id, just before its list
                x = nodes[c, local_edges[w, 0]]
                y = nodes[c, local_edges[w, 1]]
                vend[v, 0] = min(x, y)
                vend[v, 1] = max(x, y)
                q = lo
                while True:  # their rows, fetched together before the stamps are read
                    packed = ec[q]
                    _prefetch_row(nodes, packed >> CELL_SHIFT)
                    _prefetch_row(dyn, packed >> CELL_SHIFT)
                    q += 1
                    if packed & LAST:
                        break
                end = q
                visits += end - lo
                # for-loop (3): every cell C_j sharing E_n; all are crossed, since E_n is
                for q in range(lo, end):
                    packed = ec[q]
                    j = packed >> CELL_SHIFT
                    if dyn[j, R_GEN] != gen:
                        dyn[j, R_GEN] = gen
                        touched += 1
                        if starts.shape[0] == 0:
                            _prefetch_row(ids, j)  # read when P_j is taken from the queue
                        cj, xj = _values_of(nodes, j, nn, s, value, faces, vals)
                        if tail == cap_q:
                            return FULL_QUEUE, n_p, n_t, n_v, node_vertices > 0
                        stj = cj | (xj << 16)  # construct P_j (_construct_polygon, written out)
                        if nn == 4:
                            if xj == 0:
                                stj |= case_mask[cj] << MASK_SHIFT
                            else:
                                stj |= _exact_mask(cj, xj, vals, value, tri_table, tri_count, local_edges,
                                                   codes_j) << MASK_SHIFT
                        dyn[j, R_STATE] = stj
                        for w2 in range(n_slots):
                            dyn[j, ds + w2] = -1
                        n_p += 1
                        queue[tail] = j  # insert C_j into the FIFO
                        tail += 1
                    elif dyn[j, R_STATE] == QUEUED:  # a seed still in the FIFO: construct P_j, it is queued
                        cj, xj = _values_of(nodes, j, nn, s, value, faces, vals)
                        stj = cj | (xj << 16)
                        if nn == 4:
                            if xj == 0:
                                stj |= case_mask[cj] << MASK_SHIFT
                            else:
                                stj |= _exact_mask(cj, xj, vals, value, tri_table, tri_count, local_edges,
                                                   codes_j) << MASK_SHIFT
                        dyn[j, R_STATE] = stj
                        for w2 in range(n_slots):
                            dyn[j, ds + w2] = -1
                        n_p += 1
                    lw = packed & LOCAL  # register V_n into P_j (_register, written out)
                    stj = dyn[j, R_STATE]
                    if nn != 4:
                        dyn[j, ds + lw] = v
                    elif (stj >> (MASK_SHIFT + lw)) & 1 == 1:
                        dyn[j, ds + _POPCOUNT[(stj >> MASK_SHIFT) & ((1 << lw) - 1)]] = v
            else:  # a crossing exactly on a node: shared by every cell around the node
                node = nodes[c, w - ne]
                vkey[v] = n_edges + node
                vend[v, 0] = node
                vend[v, 1] = node
                node_vertices += 1
                visits += nc_off[node + 1] - nc_off[node]
                status, tail, tested, made = _node_vertex(nodes, dyn, ds, nn, n_slots, s, value, faces, tri_table,
                                                          tri_count, case_mask, local_edges, ne, nc_off, nc, node,
                                                          v, gen, queue, tail)
                node_tests += tested
                touched += tested
                n_p += made
                if status != OK:
                    return status, n_p, n_t, n_v, True
        # every vertex of P_i is registered: its triangles, as vertex ids
        if n_t > cap_t:
            return FULL_TRIANGLES, n_p, n_t, n_v, node_vertices > 0
        if exact == 0:
            for t in range(k):
                for jj in range(3):
                    tris[n_t, jj] = dyn[c, ds + _slot(st, tri_table[case, 3 * t + jj], nn)]
                    slot_reads += 1
                tri_cell[n_t] = c
                n_t += 1
        else:
            for t in range(k):
                for jj in range(3):
                    tris[n_t, jj] = dyn[c, ds + _slot(st, codes[t, jj], nn)]
                    slot_reads += 1
                tri_cell[n_t] = c
                n_t += 1
    counters[C_POPS] = pops
    counters[C_VISITS] = visits
    counters[C_TOUCHED] = touched
    counters[C_CONSTRUCTED] = n_p
    counters[C_NODE_TESTS] = node_tests
    counters[C_NODE_VERTICES] = node_vertices
    counters[C_SLOT_READS] = slot_reads
    return OK, n_p, n_t, n_v, node_vertices > 0


# ------------------------------------------------------------------ the construction, tetrahedra with records
def tet_triangle_slots(tri_table, tri_count, case_mask):
    """(n_cases, 6) int32: the slot of each triangle corner of each tetrahedron case (no node at the isovalue).

    A tetrahedron's polygon keeps its vertex of code ``w`` in slot
    ``popcount(mask & ((1 << w) - 1))`` (:func:`_slot`); for the polygons
    without a node at the isovalue the mask is ``case_mask[case]``, so the
    slot of every corner of the case table is known in advance.
    """
    out = np.full(tri_table.shape, -1, np.int32)
    for case in range(tri_table.shape[0]):
        for i in range(3 * int(tri_count[case])):
            out[case, i] = bin(int(case_mask[case]) & ((1 << int(tri_table[case, i])) - 1)).count("1")
    return out


@njit(inline="always")
def _u(x):
    """``x`` as an unsigned 32-bit number: an index the compiler knows is not negative (no wraparound test)."""
    return np.uint32(x)


@njit(inline="always")
def _tet_bits(x0, x1, x2, x3, value):
    """``(case, exact)`` of a tetrahedron from its four node values (nodes ``>= value`` / ``== value`` as bits)."""
    case = (1 if x0 >= value else 0) | (2 if x1 >= value else 0) | (4 if x2 >= value else 0) | (
        8 if x3 >= value else 0)
    exact = (1 if x0 == value else 0) | (2 if x1 == value else 0) | (4 if x2 == value else 0) | (
        8 if x3 == value else 0)
    return case, exact


@njit(cache=_KCACHE, error_model="numpy")
def construct_tet(rec, dyn, dw, ds, nodes2, dyn2, s, value, faces, tri_table, tri_count, case_mask, tri_slots,
                  local_edges, n_edges, ec, nc_off, nc, gen, queue, n_queued, tris, tri_cell, vkey, vend, counters,
                  points, pos, acc, mean):
    """:func:`construct` for tetrahedra with records, LIFO: the same cells, polygons, vertices and triangles, in
    the same order.

    ``rec`` is the records flattened ((M * 16,) int32: a cell's nodes at
    ``16 c + R_NODES``, its edge-list starts at ``16 c + 10``); ``dyn`` the
    stamps, states and slots flattened, ``dw`` int32 per cell, slots from
    column ``ds`` (the records themselves, ``dw = 16, ds = 6``, or a copy's own
    array, ``dw = 6, ds = 2``); ``nodes2`` and ``dyn2`` the same as 2-D
    arrays for the rare crossing exactly on a node (:func:`_node_vertex`).
    ``tri_slots``: :func:`tet_triangle_slots`. The outputs are flat too:
    ``tris`` (3 T,), ``vend`` (2 V,), ``pos`` and ``acc`` (3 V,), and
    ``points`` (3 N,). Returns as :func:`construct`.

    Stage 3 rides along: each vertex's position (5.2) goes into ``pos[v]``
    when it is created (:func:`polygen.volume.marching.crossing_points`'s
    formula: the same bits), and with ``mean`` each triangle's area-weighted
    normal is added into ``acc`` at its three vertices when it is written
    (``marching._mean_normals``'s sums, in its order: the same bits), so the
    vertices' ends, which were just read, are not fetched again by two more
    passes. ``pos`` and ``acc`` have at least ``vkey``'s rows; ``acc`` is
    only written with ``mean``.

    Where the time goes on 2M (20 values, 1.1 M triangles): about 60 ns per
    triangle of work (on data 2, whose records fit in the caches) and as
    much again waiting for memory: the cell lists of the edges (in 4 KiB
    pages: a TLB miss too), the records of the cells first reached and
    their nodes' values, one after the other. So the lists of a cell's
    crossed edges and its nodes' positions are fetched as soon as the cell is
    first reached (they are read when it is taken from the stack, later), and
    the records of all the cells around a taken cell's open edges are fetched
    before the first one is read.

    Why a kernel of its own: :func:`construct` serves tetrahedra and
    hexahedra, records or not, FIFO or LIFO, through runtime arguments, so
    its loops over the nodes and slots are not unrolled, a row's address is
    a multiplication by a stride read from memory, and every index loaded
    from an array (a cell, a node) gets numba's negative-index wraparound
    test. Here the node count, the record width and the queue order are
    constants, indices are unsigned and arrays flat, the slot of a triangle
    corner comes from a table, and the slot of the polygon's own vertex is
    its rank among the polygon's vertex codes, counted while they are
    walked. ``error_model="numpy"``: the one division, (5.2), is by ``C2 -
    C1 != 0`` on a crossed edge, so the check numba would add is dead code.
    """
    cap_t = tris.shape[0] // 3 - _m.MAX_TRIANGLES
    cap_v = vkey.shape[0]
    cap_q = queue.shape[0]
    sep = dw != 16  # the stamps, states and slots in a line of their own (a copy of the builder)
    vals = np.empty(8, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    codes_j = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    n_p = 0
    n_t = 0
    n_v = 0
    tail = n_queued
    pops = 0
    visits = 0
    touched = 0
    slot_reads = 0  # triangle corners read from their cell's vertex slots
    node_tests = 0
    node_vertices = 0
    while tail > 0:  # for-loop (1): the newest cell first
        tail -= 1
        c = _u(queue[_u(tail)])
        rb = c * 16
        db = c * dw
        pops += 1
        st = dyn[db + R_STATE]
        if st == QUEUED:  # a seed nobody reached before: construct P_i
            x0 = s[_u(rec[rb + 2])]
            x1 = s[_u(rec[rb + 3])]
            x2 = s[_u(rec[rb + 4])]
            x3 = s[_u(rec[rb + 5])]
            case, exact = _tet_bits(x0, x1, x2, x3, value)
            if exact == 0:
                mask = case_mask[case]
            else:
                vals[0], vals[1], vals[2], vals[3] = x0, x1, x2, x3
                mask = _exact_mask(case, exact, vals, value, tri_table, tri_count, local_edges, codes_j)
            st = case | (exact << 16) | (mask << MASK_SHIFT)
            dyn[db + R_STATE] = st
            for w2 in range(4):
                dyn[db + ds + w2] = -1
            n_p += 1
        case = st & 0xFFFF
        exact = (st >> 16) & 15
        todo = (st >> MASK_SHIFT) & 0x3FF
        if exact == 0:
            k = tri_count[case]
        else:  # a node at the isovalue: node codes, zero-area triangles dropped
            for i in range(4):
                vals[i] = s[_u(rec[rb + R_NODES + i])]
            k, _ = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
        # the cell lists of its open edges, fetched together, then the records of the cells on all those
        # lists, before for-loop (2) walks them one by one: the records' misses overlap across the edges,
        # not only within one edge's list (3-4 % on 2M). A polygon's vertex codes come in increasing
        # order, so a code's slot is its rank (edges come before nodes)
        pre = todo & 63
        sl = 0
        while pre:
            w = _ctz(pre)
            pre &= pre - 1
            if dyn[db + ds + sl] < 0:
                _prefetch_item(ec, _u(rec[rb + 10 + w]))
            sl += 1
        pre = todo & 63
        sl = 0
        while pre:
            w = _ctz(pre)
            pre &= pre - 1
            if dyn[db + ds + sl] < 0:
                q = _u(rec[rb + 10 + w])
                while True:
                    packed = _u(ec[q])
                    _prefetch_item(rec, (packed >> CELL_SHIFT) * 16)
                    if sep:
                        _prefetch_item(dyn, (packed >> CELL_SHIFT) * dw)
                    q += 1
                    if packed & LAST:
                        break
            sl += 1
        # for-loop (2): the vertices of P_i not registered yet
        sl = -1
        while todo:
            w = _ctz(todo)
            todo &= todo - 1
            sl += 1
            if dyn[db + ds + sl] >= 0:
                continue
            if n_v == cap_v:
                return FULL_VERTICES, n_p, n_t, n_v, node_vertices > 0
            if w >= 6 and nc_off.shape[0] == 0:
                return NEED_NODE_CELLS, n_p, n_t, n_v, True
            v = n_v
            n_v += 1
            if w < 6:  # a vertex on cell edge E_n: its cells, straight from the edge's list
                lo = _u(rec[rb + 10 + w])
                vkey[_u(v)] = ec[lo - 1]  # the edge's id, just before its list
                x = rec[rb + R_NODES + local_edges[w, 0]]
                y = rec[rb + R_NODES + local_edges[w, 1]]
                na = _u(min(x, y))
                nb = _u(max(x, y))
                vend[_u(v) * 2] = na
                vend[_u(v) * 2 + 1] = nb
                c1 = s[na]
                c2 = s[nb]
                # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
                for d in range(3):
                    pos[_u(v) * 3 + d] = ((value - c1) * points[nb * 3 + d]
                                          - (value - c2) * points[na * 3 + d]) / (c2 - c1)
                if mean:
                    for d in range(3):
                        acc[_u(v) * 3 + d] = 0.0
                q = lo
                # for-loop (3): every cell C_j sharing E_n; all are crossed, since E_n is
                while True:
                    packed = _u(ec[q])
                    q += 1
                    j = packed >> CELL_SHIFT
                    jb = j * dw
                    g = dyn[jb + R_GEN]
                    if g != gen or dyn[jb + R_STATE] == QUEUED:  # construct P_j
                        rj = j * 16
                        x0 = s[_u(rec[rj + 2])]
                        x1 = s[_u(rec[rj + 3])]
                        x2 = s[_u(rec[rj + 4])]
                        x3 = s[_u(rec[rj + 5])]
                        cj, xj = _tet_bits(x0, x1, x2, x3, value)
                        if g != gen:
                            dyn[jb + R_GEN] = gen
                            touched += 1
                            if tail == cap_q:
                                return FULL_QUEUE, n_p, n_t, n_v, node_vertices > 0
                            queue[_u(tail)] = j  # insert C_j into the FIFO
                            tail += 1
                        if xj == 0:
                            mj = case_mask[cj]
                        else:
                            vals[0], vals[1], vals[2], vals[3] = x0, x1, x2, x3
                            mj = _exact_mask(cj, xj, vals, value, tri_table, tri_count, local_edges, codes_j)
                        stj = cj | (xj << 16) | (mj << MASK_SHIFT)
                        if g != gen:  # its edges' cell lists, long before C_j is taken from the stack
                            pm = mj & 63
                            while pm:
                                w3 = _ctz(pm)
                                pm &= pm - 1
                                _prefetch_item(ec, _u(rec[rj + 10 + w3]))
                            # and its nodes' positions, read when its vertices are created (3-6 % on 2M)
                            _prefetch_item(points, _u(rec[rj + 2]) * 3)
                            _prefetch_item(points, _u(rec[rj + 3]) * 3)
                            _prefetch_item(points, _u(rec[rj + 4]) * 3)
                            _prefetch_item(points, _u(rec[rj + 5]) * 3)
                        dyn[jb + R_STATE] = stj
                        for w2 in range(4):
                            dyn[jb + ds + w2] = -1
                        n_p += 1
                    else:
                        stj = dyn[jb + R_STATE]
                    lw = packed & LOCAL  # register V_n into P_j
                    if (stj >> (MASK_SHIFT + lw)) & 1 == 1:
                        dyn[jb + ds + _POPCOUNT[(stj >> MASK_SHIFT) & ((1 << lw) - 1)]] = v
                    if packed & LAST:
                        break
                visits += q - lo
            else:  # a crossing exactly on a node: shared by every cell around the node
                node = rec[rb + R_NODES + w - 6]
                vkey[_u(v)] = n_edges + node
                vend[_u(v) * 2] = node
                vend[_u(v) * 2 + 1] = node
                for d in range(3):
                    pos[_u(v) * 3 + d] = points[_u(node) * 3 + d]
                    if mean:
                        acc[_u(v) * 3 + d] = 0.0
                node_vertices += 1
                visits += nc_off[node + 1] - nc_off[node]
                status, tail, tested, made = _node_vertex(nodes2, dyn2, ds, 4, 4, s, value, faces, tri_table,
                                                          tri_count, case_mask, local_edges, 6, nc_off, nc, node, v,
                                                          gen, queue, tail)
                node_tests += tested
                touched += tested
                n_p += made
                if status != OK:
                    return status, n_p, n_t, n_v, True
        # every vertex of P_i is registered: its triangles, as vertex ids
        if n_t > cap_t:
            return FULL_TRIANGLES, n_p, n_t, n_v, node_vertices > 0
        m = (st >> MASK_SHIFT) & 0x3FF
        for t in range(k):
            if exact == 0:
                i0 = dyn[db + ds + tri_slots[case, 3 * t]]
                i1 = dyn[db + ds + tri_slots[case, 3 * t + 1]]
                i2 = dyn[db + ds + tri_slots[case, 3 * t + 2]]
            else:
                i0 = dyn[db + ds + _POPCOUNT[m & ((1 << codes[t, 0]) - 1)]]
                i1 = dyn[db + ds + _POPCOUNT[m & ((1 << codes[t, 1]) - 1)]]
                i2 = dyn[db + ds + _POPCOUNT[m & ((1 << codes[t, 2]) - 1)]]
            slot_reads += 3  # the three corners just read
            tris[_u(n_t) * 3 + 0] = i0
            tris[_u(n_t) * 3 + 1] = i1
            tris[_u(n_t) * 3 + 2] = i2
            tri_cell[_u(n_t)] = c
            n_t += 1
            if mean:  # marching._mean_normals, triangle by triangle in the same order
                u0 = _u(i0)
                u1 = _u(i1)
                u2 = _u(i2)
                ux = pos[u1 * 3 + 0] - pos[u0 * 3 + 0]
                uy = pos[u1 * 3 + 1] - pos[u0 * 3 + 1]
                uz = pos[u1 * 3 + 2] - pos[u0 * 3 + 2]
                wx = pos[u2 * 3 + 0] - pos[u0 * 3 + 0]
                wy = pos[u2 * 3 + 1] - pos[u0 * 3 + 1]
                wz = pos[u2 * 3 + 2] - pos[u0 * 3 + 2]
                nx = uy * wz - uz * wy
                ny = uz * wx - ux * wz
                nz = ux * wy - uy * wx
                acc[u0 * 3 + 0] += nx
                acc[u0 * 3 + 1] += ny
                acc[u0 * 3 + 2] += nz
                acc[u1 * 3 + 0] += nx
                acc[u1 * 3 + 1] += ny
                acc[u1 * 3 + 2] += nz
                acc[u2 * 3 + 0] += nx
                acc[u2 * 3 + 1] += ny
                acc[u2 * 3 + 2] += nz
    counters[C_POPS] = pops
    counters[C_VISITS] = visits
    counters[C_TOUCHED] = touched
    counters[C_CONSTRUCTED] = n_p
    counters[C_NODE_TESTS] = node_tests
    counters[C_NODE_VERTICES] = node_vertices
    counters[C_SLOT_READS] = slot_reads
    return OK, n_p, n_t, n_v, node_vertices > 0


# (5.2) crossing points from the edge ends: the one kernel of marching, serial stage 3
positions = _m.crossing_points


# ------------------------------------------------------------------ the parallel construction
# The claims, the vertex ids and the memory ordering: see construct_parallel's docstring.


@njit(cache=_KCACHE)
def _flood(t, nodes, ids, starts, dyn, ds, nn, s, value, faces, tri_table, tri_count, case_mask, local_edges, n_edges,
           ec_off, ec, nc_off, nc, gen, seeds, next_seed, ev, stack, tris, tri_cell, vkey, vend, counters, budget):
    """Thread ``t``'s share of :func:`construct_parallel`; returns its status, fills ``counters[t]``.

    Resumes from ``counters[t]`` (zeros: from the start; ``counters[t, 2]``
    is the depth of its stack). ``budget > 0``: returns ``PAUSED`` after
    that many cells taken from its stack, to be called again (a test runs
    two threads' shares interleaved, one cell at a time, on one thread: a
    deterministic race); 0: no limit.
    """
    n_thr = stack.shape[0]
    me = gen + t
    top = gen + n_thr
    ne = local_edges.shape[0]
    n_slots = 4 if nn == 4 else ne + nn
    cap_t = tris.shape[1] - _m.MAX_TRIANGLES
    cap_v = vkey.shape[1]
    cap_q = stack.shape[1]
    n_seeds = seeds.shape[0]
    vals = np.empty(8, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    codes_j = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    n_t = counters[t, 0]
    n_v = counters[t, 1]
    sp = counters[t, 2]
    n_p = counters[t, 3]
    pops = counters[t, 4]
    tested = counters[t, 5]
    contested = counters[t, 6]
    node_vertices = counters[t, 7]
    stop = pops + budget if budget > 0 else -1
    status = OK
    while status == OK:
        if pops == stop:
            status = PAUSED
            break
        if sp == 0:  # flooded: the next seed nobody has claimed
            i = _fetch_add(next_seed, 0, 1)
            if i >= n_seeds:
                break
            c = seeds[i]
            o = dyn[c, R_GEN]
            if o >= gen and o < top:
                continue
            if _cas_row(dyn, c, R_GEN, o, me) != o:
                continue
            tested += 1
            case, exact = _values_of(nodes, c, nn, s, value, faces, vals)
            if case < 0:
                dyn[c, R_STATE] = NOT_CROSSED
                continue
            stc = case | (exact << 16)
            if nn == 4:
                if exact == 0:
                    stc |= case_mask[case] << MASK_SHIFT
                else:
                    stc |= _exact_mask(case, exact, vals, value, tri_table, tri_count, local_edges,
                                       codes_j) << MASK_SHIFT
            dyn[c, R_STATE] = stc
            for w2 in range(n_slots):
                dyn[c, ds + w2] = -1
            n_p += 1
            stack[t, 0] = c
            sp = 1
        sp -= 1
        c = stack[t, sp]
        pops += 1
        st = dyn[c, R_STATE]
        case = st & 0xFFFF
        exact = _exact_of(st, nn)
        if exact == 0:
            k = tri_count[case]
            todo = case_mask[case]
        else:
            for i in range(nn):
                vals[i] = s[nodes[c, i]]
            k, todo = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
        if starts.shape[0] == 0:
            pre = todo & ((1 << ne) - 1)
            while pre:
                w = _ctz(pre)
                pre &= pre - 1
                if dyn[c, ds + _slot(st, w, nn)] < 0:
                    _prefetch_item(ec_off, ids[c, w])
        pre = todo & ((1 << ne) - 1)
        while pre:
            w = _ctz(pre)
            pre &= pre - 1
            if dyn[c, ds + _slot(st, w, nn)] < 0:
                _prefetch_item(ec, (starts[c, w] if starts.shape[0] > 0 else ec_off[ids[c, w]]))
        if sp > 0:
            _prefetch_row(nodes, stack[t, sp - 1])
            _prefetch_row(dyn, stack[t, sp - 1])
        while todo:
            w = _ctz(todo)
            todo &= todo - 1
            if dyn[c, ds + _slot(st, w, nn)] >= 0:
                continue
            if n_v == cap_v:
                status = FULL_VERTICES
                break
            if w >= ne and nc_off.shape[0] == 0:
                status = NEED_NODE_CELLS
                break
            other = False
            node = -1
            v = n_v * n_thr + t  # this thread's next vertex, unless another thread made it first
            if w < ne:
                lo = (starts[c, w] if starts.shape[0] > 0 else ec_off[ids[c, w]])
                key = ec[lo - 1]
                q = lo
                while True:
                    packed = ec[q]
                    _prefetch_row(nodes, packed >> CELL_SHIFT)
                    _prefetch_row(dyn, packed >> CELL_SHIFT)
                    q += 1
                    if packed & LAST:
                        break
                end = q
                for q in range(lo, end):  # pass 1: claim the unclaimed cells around E, register v in mine
                    packed = ec[q]
                    j = packed >> CELL_SHIFT
                    o = dyn[j, R_GEN]
                    if o < gen or o >= top:
                        o2 = _cas_row(dyn, j, R_GEN, o, me)
                        if o2 == o:
                            if sp == cap_q:
                                status = FULL_QUEUE
                                break
                            cj, xj = _values_of(nodes, j, nn, s, value, faces, vals)
                            stj = cj | (xj << 16)
                            if nn == 4:
                                if xj == 0:
                                    stj |= case_mask[cj] << MASK_SHIFT
                                else:
                                    stj |= _exact_mask(cj, xj, vals, value, tri_table, tri_count, local_edges,
                                                       codes_j) << MASK_SHIFT
                            dyn[j, R_STATE] = stj
                            for w2 in range(n_slots):
                                dyn[j, ds + w2] = -1
                            if nn == 4 and starts.shape[0] > 0:  # its crossed edges' cell lists, early
                                pm = (stj >> MASK_SHIFT) & 63     # (as construct_tet: walked when it is popped)
                                while pm:
                                    w3 = _ctz(pm)
                                    pm &= pm - 1
                                    _prefetch_item(ec, starts[j, w3])
                            n_p += 1
                            stack[t, sp] = j
                            sp += 1
                            o = me
                        else:
                            o = o2
                    if o != me:
                        other = True
                        continue
                    lw = packed & LOCAL  # register v (this thread's new vertex, unless a CAS below says not)
                    stj = dyn[j, R_STATE]
                    if nn != 4:
                        dyn[j, ds + lw] = v
                    elif (stj >> (MASK_SHIFT + lw)) & 1 == 1:
                        dyn[j, ds + _POPCOUNT[(stj >> MASK_SHIFT) & ((1 << lw) - 1)]] = v
                if status != OK:
                    break
            else:  # a vertex exactly on a node: the cells around the node, each tested
                node = nodes[c, w - ne]
                key = n_edges + node
                lo = nc_off[node]
                end = nc_off[node + 1]
                for q in range(lo, end):
                    j = nc[q] >> CELL_SHIFT
                    o = dyn[j, R_GEN]
                    if o < gen or o >= top:
                        o2 = _cas_row(dyn, j, R_GEN, o, me)
                        if o2 == o:
                            tested += 1
                            cj, xj = _values_of(nodes, j, nn, s, value, faces, vals)
                            if cj < 0:
                                dyn[j, R_STATE] = NOT_CROSSED
                                continue
                            if sp == cap_q:
                                status = FULL_QUEUE
                                break
                            stj = cj | (xj << 16)
                            if nn == 4:
                                if xj == 0:
                                    stj |= case_mask[cj] << MASK_SHIFT
                                else:
                                    stj |= _exact_mask(cj, xj, vals, value, tri_table, tri_count, local_edges,
                                                       codes_j) << MASK_SHIFT
                            dyn[j, R_STATE] = stj
                            for w2 in range(n_slots):
                                dyn[j, ds + w2] = -1
                            n_p += 1
                            stack[t, sp] = j
                            sp += 1
                            continue
                        o = o2
                    if o != me:
                        other = True
                if status != OK:
                    break
            if other:
                contested += 1
                o = _cas(ev, key, -1, v)
                if o != -1:
                    v = o
            if v == n_v * n_thr + t:  # created here: its key and edge ends into this thread's buffer
                vkey[t, n_v] = ~key if other else key  # ~key: ev[key] holds this id, to be put back
                if w < ne:
                    x = nodes[c, local_edges[w, 0]]
                    y = nodes[c, local_edges[w, 1]]
                    vend[t, n_v, 0] = min(x, y)
                    vend[t, n_v, 1] = max(x, y)
                else:
                    vend[t, n_v, 0] = node
                    vend[t, n_v, 1] = node
                    node_vertices += 1
                n_v += 1
            if w < ne and v % n_thr == t:
                continue  # pass 1 registered it: this thread made it
            # pass 2: (again) the vertex's id into this thread's cells around N, or around E after a lost CAS
            for q in range(lo, end):
                if w < ne:
                    packed = ec[q]
                    lw = packed & LOCAL
                else:
                    packed = nc[q]
                    lw = ne + (packed & LOCAL)
                j = packed >> CELL_SHIFT
                if dyn[j, R_GEN] != me:
                    continue
                stj = dyn[j, R_STATE]
                if stj == NOT_CROSSED:
                    continue
                if nn != 4:
                    dyn[j, ds + lw] = v
                elif (stj >> (MASK_SHIFT + lw)) & 1 == 1:
                    dyn[j, ds + _POPCOUNT[(stj >> MASK_SHIFT) & ((1 << lw) - 1)]] = v
        if status != OK:
            break
        if n_t > cap_t:
            status = FULL_TRIANGLES
            break
        for tt in range(k):
            for jj in range(3):
                w = tri_table[case, 3 * tt + jj] if exact == 0 else codes[tt, jj]
                tris[t, n_t, jj] = dyn[c, ds + _slot(st, w, nn)]
            tri_cell[t, n_t] = c
            n_t += 1
    counters[t, 0] = n_t
    counters[t, 1] = n_v
    counters[t, 2] = sp
    counters[t, 3] = n_p
    counters[t, 4] = pops
    counters[t, 5] = tested
    counters[t, 6] = contested
    counters[t, 7] = node_vertices
    return status


@njit(parallel=True, cache=_KCACHE)
def construct_parallel(nodes, ids, starts, dyn, ds, nn, s, value, faces, tri_table, tri_count, case_mask, local_edges,
                       n_edges, ec_off, ec, nc_off, nc, gen, seeds, next_seed, ev, stack, tris, tri_cell, vkey, vend,
                       counters, status):
    """t1 + t2 by ``T = stack.shape[0]`` threads, each doing :func:`construct`'s work on its own part.

    The claims by compare-and-swap and the memory ordering are in the
    Notes below. ``seeds`` (all of them, tested here: the
    claim comes first) are handed out from ``next_seed[0]`` (0 on entry);
    ``dyn`` stamps take the values ``gen .. gen + T - 1`` (thread ``t``
    claims with ``gen + t``: the caller reserves T generations); ``ev``
    (n_edges + n_nodes,) int32 is -1 everywhere on entry, and again once
    the caller has run :func:`release_contested`.

    Per thread ``t`` (buffers (T, cap, ...)): triangles ``tris[t,
    :counters[t, 0]]`` as vertex codes ``k * T + u`` (thread ``u``'s
    ``k``-th vertex), their cells ``tri_cell[t]``, its vertices' keys
    ``vkey[t, :counters[t, 1]]`` (``~key`` for a vertex whose id went
    through ``ev``) and edge ends ``vend[t]``; counters ``(triangles,
    vertices, stack depth, polygons, pops, cells tested, contested vertices,
    vertices on nodes)``, zeros on entry; ``status[t]`` OK or
    the buffer that was too small (the caller grows it and runs the query
    again under new generations).

    Notes
    -----
    Every thread runs construct's loop (LIFO) on its own stack; the seeds are handed out one at a time
    from a shared counter, each flooded to exhaustion before the next is taken. Memory ordering, and why
    no thread ever reads half of something another thread is writing:

    * claims: a cell belongs to the thread whose compare-and-swap moved its stamp from an old value
      (< gen) to ``gen + t``: a query takes the T generations ``gen .. gen + T - 1``, one per thread,
      so the stamp alone says "claimed in this query, by thread t" in one word and a single CAS. Only
      the owner writes the cell's state and slots, and only the owner reads them: a thread sees of
      another thread's cell nothing but its stamp (a plain load first; a value in the block is final
      -- a claim is never undone within the query -- and any other value is decided by the CAS, whose
      result names the owner; a stale plain load only sends the thread to a CAS that fails). Half-initialised
      records are therefore never read. Stamps of earlier queries, serial or parallel, are all below
      ``gen`` (generations only grow; the builder clears every stamp before they would wrap), and the
      next query starts above ``gen + T - 1``. The CAS is LLVM's ``cmpxchg seq_cst`` (``lock cmpxchg``
      on x86), so a claim is visible to every thread before the claimer writes the cell's state.
    * vertices: the thread that pops one of its cells with an empty slot for edge E (or node N) creates
      the vertex. First pass over the cells around E: claim the unclaimed ones (construct, push), and
      note whether any belongs to another thread. If none does, this thread owns every cell around E
      for the rest of the query (they are all claimed now and claims are final), nobody else can ever
      need the vertex, and it is created without any shared write. If one does ("contested"), the
      vertex id is decided by a CAS on ``ev[key]`` from -1 to this thread's new id (``k * T + t``, the
      thread's k-th vertex): the winner creates it, a loser takes the winner's id from the CAS's result.
      Any two threads that both create E see each other's cell (the one each popped was claimed before
      its pass, and the other's pass either claims it -- impossible, it is owned -- or sees it owned),
      so a vertex is never created twice. The id is only a number: the vertex's key and ends live in
      the winner's own buffer and are read after the parallel region ends (its join is the barrier).
      The first pass already puts the new id into this thread's own cells around E; a second pass
      overwrites it with the winner's id after a lost CAS (and registers a vertex on a node).
    * ``ev`` holds -1 outside a query: each winner marks the keys it swapped (``~key`` in its vertex
      list) and :func:`release_contested` puts -1 back after the query (also after an overflow), so
      the entries need no generation and the cost is paid only on contested edges (the boundaries between
      the threads' regions: a few per cent of the vertices, see benchmarks/parallel_construction.py).
    Per cell the work is construct's plus one CAS per claimed cell; a contested edge costs one more CAS.
    """
    n_thr = stack.shape[0]
    for t in prange(n_thr):
        # np.int64: numba types the prange index int64, then uint64 in the parallel body: two builds otherwise
        status[t] = _flood(np.int64(t), nodes, ids, starts, dyn, ds, nn, s, value, faces, tri_table, tri_count,
                           case_mask, local_edges, n_edges, ec_off, ec, nc_off, nc, gen, seeds, next_seed, ev, stack,
                           tris, tri_cell, vkey, vend, counters, 0)


@njit(parallel=True, cache=_KCACHE)
def gather_parallel(tris, tri_cell, vkey, vend, counters, t_base, v_base, out_tri, out_cell, out_key, out_end):
    """The threads' triangles and vertices, concatenated, vertex codes ``k * T + u`` -> ``v_base[u] + k``."""
    n_thr = tris.shape[0]
    for t in prange(n_thr):
        b = t_base[t]
        for i in range(counters[t, 0]):
            for jj in range(3):
                code = tris[t, i, jj]
                out_tri[b + i, jj] = v_base[code % n_thr] + code // n_thr
            out_cell[b + i] = tri_cell[t, i]
        b = v_base[t]
        for i in range(counters[t, 1]):
            k = vkey[t, i]
            out_key[b + i] = ~k if k < 0 else k
            out_end[b + i, 0] = vend[t, i, 0]
            out_end[b + i, 1] = vend[t, i, 1]


@njit(cache=_KCACHE)
def release_contested(vkey, counters, ev):
    """``ev`` back to -1 at the keys a thread won by compare-and-swap (marked ``~key`` in ``vkey``)."""
    for t in range(vkey.shape[0]):
        for i in range(counters[t, 1]):
            k = vkey[t, i]
            if k < 0:
                ev[~k] = -1


# ------------------------------------------------------------------ the parallel construction, tetrahedra with records
#: :func:`_flood_tet` status: a thread's list of normal terms for other threads' vertices is full
FULL_FOREIGN = 6
#: columns of a parallel query's ``counters`` (T, N_PAR_COUNTERS): triangles, vertices, stack depth, polygons,
#: pops, cells tested, contested vertices, vertices on nodes, normal terms for other threads' vertices
N_PAR_COUNTERS = 9


@njit(inline="always")
def _thread_bits(n_thr):
    """The bits of a thread number in a vertex code of the tetrahedron kernels: thread ``t``'s ``k``-th vertex
    is ``k << b | t`` (a shift and a mask, where ``k * T + t`` needs a division to take apart)."""
    b = 0
    while (1 << b) < n_thr:
        b += 1
    return b


@njit(error_model="numpy")
def _corner_position(rec, rb, w, local_edges, s, value, points):
    """The position of vertex code ``w`` of the tetrahedron whose record starts at ``rec[rb]``, by
    :func:`construct_tet`'s expression (the same bits as the thread that created the vertex wrote)."""
    if w < 6:
        x = rec[rb + R_NODES + local_edges[w, 0]]
        y = rec[rb + R_NODES + local_edges[w, 1]]
        na = min(x, y)
        nb = max(x, y)
        c1 = s[na]
        c2 = s[nb]
        # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
        return (((value - c1) * points[nb, 0] - (value - c2) * points[na, 0]) / (c2 - c1),
                ((value - c1) * points[nb, 1] - (value - c2) * points[na, 1]) / (c2 - c1),
                ((value - c1) * points[nb, 2] - (value - c2) * points[na, 2]) / (c2 - c1))
    node = rec[rb + R_NODES + w - 6]
    return points[node, 0], points[node, 1], points[node, 2]


@njit(cache=_KCACHE, error_model="numpy")
def _flood_tet(t, rec, dyn, dw, ds, nodes2, dyn2, s, value, faces, tri_table, tri_count, case_mask, tri_slots,
               local_edges, n_edges, ec, nc_off, nc, gen, seeds, next_seed, ev, stack, tris, tri_cell, vkey, vend,
               points, pos, acc, fcode, fval, mean, counters, budget):
    """Thread ``t``'s share of :func:`construct_tet_parallel`: :func:`_flood` with :func:`construct_tet`'s work.

    The claims, contested vertices and memory ordering are :func:`_flood`'s
    (see :func:`construct_parallel`); the work per cell is
    :func:`construct_tet`'s (flat records, four slots, the slot of a
    triangle corner from ``tri_slots``, the edge lists and the records of the
    cells on them fetched early), and stage 3 rides along as there: the
    thread that creates a vertex writes its position into ``pos[t, k]`` (its
    ``k``-th vertex) and, with ``mean``, zeroes its normal sum ``acc[t, k]``.
    When a thread writes a triangle it adds the triangle's normal into
    ``acc`` at the corners it created; a corner created by another thread
    (a contested vertex that thread won) is not written (that thread may be
    adding to it): the term goes into this thread's list ``fcode[t, i]``
    (the vertex code) / ``fval[t, i]`` (the term), added after the parallel
    region by :func:`gather_tet_parallel`. The corner positions a triangle
    needs are read from ``pos[t]`` for this thread's vertices and computed
    again from the cell's record for another thread's (by the same
    expression: the same bits; the other thread may not have written its
    copy yet).

    ``rec`` (M * 16,) and ``dyn`` (M * dw,) are flat as in
    :func:`construct_tet`, ``nodes2``/``dyn2`` their 2-D views (for a vertex
    exactly on a node); per-thread buffers (T, cap, ...) as in :func:`_flood`,
    plus ``pos``, ``acc`` (T, cap_v, 3) float64, ``fcode`` (T, cap_f) int32
    and ``fval`` (T, cap_f, 3) float64; ``counters[t]`` the
    ``N_PAR_COUNTERS`` columns (column 8: the terms in ``fcode[t]``).
    ``budget``: as in :func:`_flood`. Returns the thread's status
    (``FULL_FOREIGN``: ``fcode`` is too small). Vertex codes are ``k << b |
    t`` (thread ``t``'s ``k``-th vertex, ``b`` = :func:`_thread_bits`),
    not :func:`_flood`'s ``k * T + t``.
    """
    pts = points.reshape(-1)  # flat, for the prefetch hints (a view)
    n_thr = stack.shape[0]
    tb = _thread_bits(n_thr)
    tm = (1 << tb) - 1
    me = gen + t
    top = gen + n_thr
    cap_t = tris.shape[1] - _m.MAX_TRIANGLES
    cap_v = vkey.shape[1]
    cap_q = stack.shape[1]
    cap_f = fcode.shape[1]
    n_seeds = seeds.shape[0]
    vals = np.empty(8, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    codes_j = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    n_t = counters[t, 0]
    n_v = counters[t, 1]
    sp = counters[t, 2]
    n_p = counters[t, 3]
    pops = counters[t, 4]
    tested = counters[t, 5]
    contested = counters[t, 6]
    node_vertices = counters[t, 7]
    n_f = counters[t, 8]
    stop = pops + budget if budget > 0 else -1
    status = OK
    while status == OK:
        if pops == stop:
            status = PAUSED
            break
        if sp == 0:  # flooded: the next seed nobody has claimed
            i = _fetch_add(next_seed, 0, 1)
            if i >= n_seeds:
                break
            c = _u(seeds[i])
            db = c * dw
            o = dyn[db + R_GEN]
            if o >= gen and o < top:
                continue
            if _cas(dyn, db + R_GEN, o, me) != o:
                continue
            tested += 1
            rb = c * 16
            x0 = s[_u(rec[rb + 2])]
            x1 = s[_u(rec[rb + 3])]
            x2 = s[_u(rec[rb + 4])]
            x3 = s[_u(rec[rb + 5])]
            case, exact = _tet_bits(x0, x1, x2, x3, value)
            if case == 0 or case == 15:
                dyn[db + R_STATE] = NOT_CROSSED
                continue
            if exact == 0:
                mask = case_mask[case]
            else:
                vals[0], vals[1], vals[2], vals[3] = x0, x1, x2, x3
                mask = _exact_mask(case, exact, vals, value, tri_table, tri_count, local_edges, codes_j)
            dyn[db + R_STATE] = case | (exact << 16) | (mask << MASK_SHIFT)
            for w2 in range(4):
                dyn[db + ds + w2] = -1
            n_p += 1
            stack[t, 0] = c
            sp = 1
        sp -= 1
        c = _u(stack[t, sp])
        pops += 1
        rb = c * 16
        db = c * dw
        st = dyn[db + R_STATE]
        case = st & 0xFFFF
        exact = (st >> 16) & 15
        todo = (st >> MASK_SHIFT) & 0x3FF
        if exact == 0:
            k = tri_count[case]
        else:  # a node at the isovalue: node codes, zero-area triangles dropped
            for i in range(4):
                vals[i] = s[_u(rec[rb + R_NODES + i])]
            k, _ = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
        # as construct_tet: the lists of the open edges, then the records of the cells on them, fetched early
        pre = todo & 63
        sl = 0
        while pre:
            w = _ctz(pre)
            pre &= pre - 1
            if dyn[db + ds + sl] < 0:
                _prefetch_item(ec, _u(rec[rb + 10 + w]))
            sl += 1
        pre = todo & 63
        sl = 0
        while pre:
            w = _ctz(pre)
            pre &= pre - 1
            if dyn[db + ds + sl] < 0:
                q = _u(rec[rb + 10 + w])
                while True:
                    packed = _u(ec[q])
                    _prefetch_item(rec, (packed >> CELL_SHIFT) * 16)
                    if dw != 16:
                        _prefetch_item(dyn, (packed >> CELL_SHIFT) * dw)
                    q += 1
                    if packed & LAST:
                        break
            sl += 1
        sl = -1
        while todo:  # for-loop (2): the vertices of P_i not registered yet
            w = _ctz(todo)
            todo &= todo - 1
            sl += 1
            if dyn[db + ds + sl] >= 0:
                continue
            if n_v == cap_v:
                status = FULL_VERTICES
                break
            if w >= 6 and nc_off.shape[0] == 0:
                status = NEED_NODE_CELLS
                break
            other = False
            node = -1
            v = (n_v << tb) | t  # this thread's next vertex, unless another thread made it first
            if w < 6:
                lo = _u(rec[rb + 10 + w])
                key = ec[lo - 1]
                q = lo
                while True:  # pass 1: claim the unclaimed cells around E, register v in mine
                    packed = _u(ec[q])
                    q += 1
                    j = packed >> CELL_SHIFT
                    jb = j * dw
                    o = dyn[jb + R_GEN]
                    if o < gen or o >= top:
                        o2 = _cas(dyn, jb + R_GEN, o, me)
                        if o2 == o:
                            if sp == cap_q:
                                status = FULL_QUEUE
                                break
                            rj = j * 16
                            x0 = s[_u(rec[rj + 2])]
                            x1 = s[_u(rec[rj + 3])]
                            x2 = s[_u(rec[rj + 4])]
                            x3 = s[_u(rec[rj + 5])]
                            cj, xj = _tet_bits(x0, x1, x2, x3, value)
                            if xj == 0:
                                mj = case_mask[cj]
                            else:
                                vals[0], vals[1], vals[2], vals[3] = x0, x1, x2, x3
                                mj = _exact_mask(cj, xj, vals, value, tri_table, tri_count, local_edges, codes_j)
                            # its nodes' positions, read when its vertices are created, and (below) its edges'
                            # cell lists, long before C_j is taken from the stack
                            _prefetch_item(pts, _u(rec[rj + 2]) * 3)
                            _prefetch_item(pts, _u(rec[rj + 3]) * 3)
                            _prefetch_item(pts, _u(rec[rj + 4]) * 3)
                            _prefetch_item(pts, _u(rec[rj + 5]) * 3)
                            pm = mj & 63
                            while pm:
                                w3 = _ctz(pm)
                                pm &= pm - 1
                                _prefetch_item(ec, _u(rec[rj + 10 + w3]))
                            dyn[jb + R_STATE] = cj | (xj << 16) | (mj << MASK_SHIFT)
                            for w2 in range(4):
                                dyn[jb + ds + w2] = -1
                            n_p += 1
                            stack[t, sp] = j
                            sp += 1
                            o = me
                        else:
                            o = o2
                    if o != me:
                        other = True
                    else:
                        lw = packed & LOCAL  # register v (this thread's new vertex, unless a CAS below says not)
                        stj = dyn[jb + R_STATE]
                        if (stj >> (MASK_SHIFT + lw)) & 1 == 1:
                            dyn[jb + ds + _POPCOUNT[(stj >> MASK_SHIFT) & ((1 << lw) - 1)]] = v
                    if packed & LAST:
                        break
                if status != OK:
                    break
                end = q
            else:  # a vertex exactly on a node: the cells around the node, each tested (as _flood)
                node = rec[rb + R_NODES + w - 6]
                key = n_edges + node
                lo = nc_off[node]
                end = nc_off[node + 1]
                for q in range(lo, end):
                    j = nc[q] >> CELL_SHIFT
                    o = dyn2[j, R_GEN]
                    if o < gen or o >= top:
                        o2 = _cas_row(dyn2, j, R_GEN, o, me)
                        if o2 == o:
                            tested += 1
                            cj, xj = _values_of(nodes2, j, 4, s, value, faces, vals)
                            if cj < 0:
                                dyn2[j, R_STATE] = NOT_CROSSED
                                continue
                            if sp == cap_q:
                                status = FULL_QUEUE
                                break
                            _construct_polygon(dyn2, ds, j, cj, xj, 4, 4, vals, value, tri_table, tri_count,
                                               case_mask, local_edges, codes_j)
                            n_p += 1
                            stack[t, sp] = j
                            sp += 1
                            continue
                        o = o2
                    if o != me:
                        other = True
                if status != OK:
                    break
            if other:
                contested += 1
                o = _cas(ev, key, -1, v)
                if o != -1:
                    v = o
            if v == (n_v << tb) | t:  # created here: key, edge ends, position (and a zero normal sum)
                vkey[t, n_v] = ~key if other else key  # ~key: ev[key] holds this id, to be put back
                if w < 6:
                    x = rec[rb + R_NODES + local_edges[w, 0]]
                    y = rec[rb + R_NODES + local_edges[w, 1]]
                    na = _u(min(x, y))
                    nb = _u(max(x, y))
                    vend[t, n_v, 0] = na
                    vend[t, n_v, 1] = nb
                    c1 = s[na]
                    c2 = s[nb]
                    # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
                    for d in range(3):
                        pos[t, n_v, d] = ((value - c1) * points[nb, d] - (value - c2) * points[na, d]) / (c2 - c1)
                else:
                    vend[t, n_v, 0] = node
                    vend[t, n_v, 1] = node
                    for d in range(3):
                        pos[t, n_v, d] = points[node, d]
                    node_vertices += 1
                if mean:
                    for d in range(3):
                        acc[t, n_v, d] = 0.0
                n_v += 1
            if w < 6 and v & tm == t:
                continue  # pass 1 registered it: this thread made it
            # pass 2: (again) the vertex's id into this thread's cells around N, or around E after a lost CAS
            for q in range(lo, end):
                if w < 6:
                    packed = ec[q]
                    lw = packed & LOCAL
                else:
                    packed = nc[q]
                    lw = 6 + (packed & LOCAL)
                j = packed >> CELL_SHIFT
                if dyn2[j, R_GEN] != me:
                    continue
                stj = dyn2[j, R_STATE]
                if stj == NOT_CROSSED:
                    continue
                if (stj >> (MASK_SHIFT + lw)) & 1 == 1:
                    dyn2[j, ds + _POPCOUNT[(stj >> MASK_SHIFT) & ((1 << lw) - 1)]] = v
        if status != OK:
            break
        if n_t > cap_t:
            status = FULL_TRIANGLES
            break
        if mean and n_f + 3 * k > cap_f:
            status = FULL_FOREIGN
            break
        m = (st >> MASK_SHIFT) & 0x3FF
        for tt in range(k):  # every vertex of P_i is registered: its triangles, as vertex ids
            if exact == 0:
                e0 = tri_table[case, 3 * tt]
                e1 = tri_table[case, 3 * tt + 1]
                e2 = tri_table[case, 3 * tt + 2]
                i0 = dyn[db + ds + tri_slots[case, 3 * tt]]
                i1 = dyn[db + ds + tri_slots[case, 3 * tt + 1]]
                i2 = dyn[db + ds + tri_slots[case, 3 * tt + 2]]
            else:
                e0 = codes[tt, 0]
                e1 = codes[tt, 1]
                e2 = codes[tt, 2]
                i0 = dyn[db + ds + _POPCOUNT[m & ((1 << e0) - 1)]]
                i1 = dyn[db + ds + _POPCOUNT[m & ((1 << e1) - 1)]]
                i2 = dyn[db + ds + _POPCOUNT[m & ((1 << e2) - 1)]]
            tris[t, n_t, 0] = i0
            tris[t, n_t, 1] = i1
            tris[t, n_t, 2] = i2
            tri_cell[t, n_t] = c
            n_t += 1
            if mean:  # the triangle's normal (marching.triangle_normal), into the sums of its corners
                k0 = _u(i0 >> tb)
                k1 = _u(i1 >> tb)
                k2 = _u(i2 >> tb)
                own0 = i0 & tm == t
                own1 = i1 & tm == t
                own2 = i2 & tm == t
                if own0:
                    p0x, p0y, p0z = pos[t, k0, 0], pos[t, k0, 1], pos[t, k0, 2]
                else:
                    p0x, p0y, p0z = _corner_position(rec, rb, e0, local_edges, s, value, points)
                if own1:
                    p1x, p1y, p1z = pos[t, k1, 0], pos[t, k1, 1], pos[t, k1, 2]
                else:
                    p1x, p1y, p1z = _corner_position(rec, rb, e1, local_edges, s, value, points)
                if own2:
                    p2x, p2y, p2z = pos[t, k2, 0], pos[t, k2, 1], pos[t, k2, 2]
                else:
                    p2x, p2y, p2z = _corner_position(rec, rb, e2, local_edges, s, value, points)
                ux = p1x - p0x
                uy = p1y - p0y
                uz = p1z - p0z
                wx = p2x - p0x
                wy = p2y - p0y
                wz = p2z - p0z
                nx = uy * wz - uz * wy
                ny = uz * wx - ux * wz
                nz = ux * wy - uy * wx
                if own0:
                    acc[t, k0, 0] += nx
                    acc[t, k0, 1] += ny
                    acc[t, k0, 2] += nz
                else:
                    fcode[t, n_f] = i0
                    fval[t, n_f, 0] = nx
                    fval[t, n_f, 1] = ny
                    fval[t, n_f, 2] = nz
                    n_f += 1
                if own1:
                    acc[t, k1, 0] += nx
                    acc[t, k1, 1] += ny
                    acc[t, k1, 2] += nz
                else:
                    fcode[t, n_f] = i1
                    fval[t, n_f, 0] = nx
                    fval[t, n_f, 1] = ny
                    fval[t, n_f, 2] = nz
                    n_f += 1
                if own2:
                    acc[t, k2, 0] += nx
                    acc[t, k2, 1] += ny
                    acc[t, k2, 2] += nz
                else:
                    fcode[t, n_f] = i2
                    fval[t, n_f, 0] = nx
                    fval[t, n_f, 1] = ny
                    fval[t, n_f, 2] = nz
                    n_f += 1
    counters[t, 0] = n_t
    counters[t, 1] = n_v
    counters[t, 2] = sp
    counters[t, 3] = n_p
    counters[t, 4] = pops
    counters[t, 5] = tested
    counters[t, 6] = contested
    counters[t, 7] = node_vertices
    counters[t, 8] = n_f
    return status


@njit(parallel=True, cache=_KCACHE)
def construct_tet_parallel(rec, dyn, dw, ds, nodes2, dyn2, s, value, faces, tri_table, tri_count, case_mask,
                           tri_slots, local_edges, n_edges, ec, nc_off, nc, gen, seeds, next_seed, ev, stack, tris,
                           tri_cell, vkey, vend, points, pos, acc, fcode, fval, mean, counters, status):
    """:func:`construct_parallel` for tetrahedra with records, with :func:`construct_tet`'s work per cell.

    ``T = stack.shape[0]`` threads each run :func:`_flood_tet`; arguments
    and outputs as there and in :func:`construct_parallel` (``counters``
    (T, ``N_PAR_COUNTERS``), zeros on entry). The positions and the normal
    sums are written by the threads as the serial :func:`construct_tet`
    writes them; :func:`gather_tet_parallel` puts the parts together.
    """
    n_thr = stack.shape[0]
    for t in prange(n_thr):
        # np.int64: one build (the prange index is int64, then uint64 in the parallel body: 7 + 11 CPU-s on data4)
        status[t] = _flood_tet(np.int64(t), rec, dyn, dw, ds, nodes2, dyn2, s, value, faces, tri_table, tri_count,
                               case_mask, tri_slots, local_edges, n_edges, ec, nc_off, nc, gen, seeds, next_seed, ev,
                               stack, tris, tri_cell, vkey, vend, points, pos, acc, fcode, fval, mean, counters, 0)


@njit(parallel=True, cache=_KCACHE)
def gather_tet_parallel(tris, tri_cell, vkey, vend, pos, acc, fcode, fval, counters, t_base, v_base, mean, out_tri,
                        out_cell, out_key, out_end, out_pos, out_nrm, n_zero):
    """:func:`gather_parallel` (vertex codes ``k << b | u``, :func:`_thread_bits`) plus the positions and, with
    ``mean``, the unit mean normals.

    Thread ``u`` copies its part (positions into ``out_pos``, normal sums
    into ``out_nrm``), then adds to the sums of its vertices the terms the
    other threads listed for them (``fcode``/``fval``, :func:`_flood_tet`)
    and normalises them in place (as :func:`polygen.volume.marching.normalised`;
    ``n_zero[u]``: its rows :func:`~polygen.volume.marching.zero_rows` would
    list). Each vertex's sum is the serial one's terms in another order
    (this thread's triangles in its order, then the others'): equal to it up
    to rounding.
    """
    n_thr = tris.shape[0]
    tb = _thread_bits(n_thr)
    tm = (1 << tb) - 1
    for t in prange(n_thr):
        b = t_base[t]
        for i in range(counters[t, 0]):
            for jj in range(3):
                code = tris[t, i, jj]
                out_tri[b + i, jj] = v_base[code & tm] + (code >> tb)
            out_cell[b + i] = tri_cell[t, i]
        b = v_base[t]
        for i in range(counters[t, 1]):
            k = vkey[t, i]
            out_key[b + i] = ~k if k < 0 else k
            out_end[b + i, 0] = vend[t, i, 0]
            out_end[b + i, 1] = vend[t, i, 1]
            for d in range(3):
                out_pos[b + i, d] = pos[t, i, d]
            if mean:
                for d in range(3):
                    out_nrm[b + i, d] = acc[t, i, d]
    if mean:
        for u in prange(n_thr):
            for t in range(n_thr):
                if t == u:
                    continue
                for i in range(counters[t, 8]):
                    code = fcode[t, i]
                    if code & tm == u:
                        r = v_base[u] + (code >> tb)
                        for d in range(3):
                            out_nrm[r, d] += fval[t, i, d]
            nz = 0
            for r in range(v_base[u], v_base[u + 1]):
                nz += _m.unit_into(out_nrm[r, 0], out_nrm[r, 1], out_nrm[r, 2], out_nrm, r)
            n_zero[u] = nz


# ------------------------------------------------------------------ stage 3 in parallel
@njit(parallel=True, cache=_KCACHE)
def positions_parallel(vend, n_v, points, s, value, out):
    """:func:`positions` over the vertices by numba's threads (each vertex on its own: no two write one row)."""
    for v in prange(n_v):
        a = vend[v, 0]
        b = vend[v, 1]
        if a == b:
            for d in range(3):
                out[v, d] = points[a, d]
        else:
            c1 = s[a]
            c2 = s[b]
            # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
            for d in range(3):
                out[v, d] = ((value - c1) * points[b, d] - (value - c2) * points[a, d]) / (c2 - c1)


@njit(parallel=True, cache=_KCACHE)
def mean_normals_parallel(vertices, triangles, out, extra):
    """``marching._mean_normals`` by ``P = extra.shape[0] + 1`` threads, in two passes.

    The triangles are cut into ``P`` consecutive parts; part 0 adds its
    area-weighted triangle normals into ``out``, part ``p`` into ``extra[p -
    1]`` (V, 3) (a scatter-add of several threads into one array would need
    atomics); then each vertex sums its ``P`` rows and is normalised. The
    sums are the serial ones regrouped (part by part), equal to them up to
    rounding.
    """
    n_parts = extra.shape[0] + 1
    n_t = triangles.shape[0]
    n_v = out.shape[0]
    for p in prange(n_parts):
        acc = out if p == 0 else extra[p - 1]
        for v in range(n_v):
            acc[v, 0] = 0.0
            acc[v, 1] = 0.0
            acc[v, 2] = 0.0
        for t in range(p * n_t // n_parts, (p + 1) * n_t // n_parts):
            i0 = triangles[t, 0]
            i1 = triangles[t, 1]
            i2 = triangles[t, 2]
            nx, ny, nz = _m.triangle_normal(vertices, i0, i1, i2)
            for i in (i0, i1, i2):
                acc[i, 0] += nx
                acc[i, 1] += ny
                acc[i, 2] += nz
    for v in prange(n_v):
        x = out[v, 0]
        y = out[v, 1]
        z = out[v, 2]
        for p in range(n_parts - 1):
            x += extra[p, v, 0]
            y += extra[p, v, 1]
            z += extra[p, v, 2]
        _m.unit_into(x, y, z, out, v)
