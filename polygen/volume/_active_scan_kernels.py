"""Numba kernels of the active-cell scan (:mod:`polygen.volume.active_scan`).

Arrays in, arrays out; the only polygen imports are the marching kernels and
the JIT options. See :mod:`polygen.volume.active_scan` for the method.

The table ``tab`` (M, W) int32 holds one row per cell, in *span-space
order*: the cells are grouped in rows of their minimum value (the bins
``lower``), and inside a row sorted by their maximum, largest first. A row
of ``tab`` is

``tab[p, 0:nn]``
    the cell's nodes;
``tab[p, nn:nn+ne]``
    its edges' ids (the volume's ``cell_edges``: the vertex keys);
``tab[p, nn+ne]``
    bit ``w``: the cell *owns* its local edge ``w`` (it is the first cell
    of the edge): the one cell that makes the vertex of a crossed edge;
    bit ``FOREIGN + w``: that owner lies in another (an earlier) block;
    bits ``REACH ..``: how many blocks before the cell's own the earliest
    owner of its edges lies (at most ``REACH_MAX``: that many or more);
``tab[p, nn+ne+1]``
    the cell's id.

The cells a value ``C`` crosses (minimum ``< C <=`` maximum) are then in a
prefix of each row whose lower bound is below ``C``: :func:`active_ranges`
finds them by one binary search per row over ``cmx`` (the maxima, float32
rounded up: a cell may be tested for nothing, none is missed). The ranges,
seen as one sequence, are cut into chunks of ``chunk`` cells that the
threads take: three passes (count, vertices, triangles), each over the
chunks in parallel -- on a volume in blocks the last two block by block
(:func:`fused_pass`) -- and the numbering by chunk makes the output the same
whatever the thread count.

The passes step from range to range with the same four lines written out in
each: as one inline helper returning ``(r, p)`` a 2M sweep took 1.2 times as
long (numba 0.68, one process, interleaved).
"""

import numpy as np

from polygen._jit import njit, prange
from polygen.volume import _edge_centred_kernels as _ek
from polygen.volume import marching as _m
from polygen.volume._intrinsics import _KCACHE, _ctz, _prefetch_item

#: ``st`` of a cell the value does not cross
NOT_CROSSED = -1
#: the table's owner column: bit ``FOREIGN + w``, the owner of the cell's local edge ``w`` is in another block;
#: from bit ``REACH`` (7 bits): how many blocks back the earliest owner of the cell's edges is (``REACH_MAX``:
#: that many or more)
FOREIGN = 12
REACH = 24
REACH_MAX = 127
#: how many ranges ahead a pass hints the first rows of (:func:`_ask_range`): the one prefetch hint left
#: (2M, 20 values, in one process: 0.96-0.975 of the time without it; 10M 0.98; data4 0.98)
RANGES_AHEAD = 2
# No hints per cell: the blocks keep a query's reads of node values, positions and edge vertices near each
# other. With one block (2M, an AMD VM, the sessions before) hints for those of the cells 8 ahead had made
# the count pass 10.4 -> 8.3 ms and the vertex pass 13.6-14.3 -> 11.7-12.1 ms; with blocks of 65536 cells
# (an Intel VM) leaving them out made the sweep 5 % faster on 2M and 3 % on 10M.


# ------------------------------------------------------------------ preparation
@njit(parallel=True)
def cell_extremes(cells, s, cmin, cmax):
    """Each cell's smallest and largest node value."""
    nn = cells.shape[1]
    for c in prange(cells.shape[0]):
        a = s[cells[c, 0]]
        b = a
        for i in range(1, nn):
            x = s[cells[c, i]]
            if x < a:
                a = x
            if x > b:
                b = x
        cmin[c] = a
        cmax[c] = b


@njit
def edge_owners(cell_edges, c0, block, first, own):
    """``own[i]``: the table's owner column (see the module docstring) of cell ``c = c0 + i`` (``cell_edges``
    holds the rows of cells ``c0 ..``): bit ``w``, ``c`` is the first cell of its local edge ``w`` (each edge
    has one owner, the cell that makes its vertex); bit ``FOREIGN + w``, the edge's owner is in another block
    of ``block`` consecutive cells (an earlier one: the owner is the edge's first cell); from bit ``REACH``,
    how many blocks back the earliest owner of the cell's edges is (at most ``REACH_MAX``).

    ``first`` (n_edges): each edge's owner so far, -1 for none (set to -1 before the first call; the
    preparation calls this on its groups of cells in order, carrying ``first`` from one to the next).
    """
    for i in range(cell_edges.shape[0]):
        c = c0 + i
        bits = 0
        b = c // block
        back = 0
        for w in range(cell_edges.shape[1]):
            e = cell_edges[i, w]
            if first[e] < 0:
                first[e] = c
                bits |= 1 << w
            elif first[e] // block != b:
                bits |= 1 << (FOREIGN + w)
                back = max(back, b - first[e] // block)
        own[i] = bits | (min(back, REACH_MAX) << REACH)


@njit
def count_unowned(first):
    """How many edges have no owner after :func:`edge_owners` (0 for a volume's own edge table)."""
    missing = 0
    for e in range(first.shape[0]):
        if first[e] < 0:
            missing += 1
    return missing


@njit
def block_extremes(cmin, cmax, block, bmin, bmax):
    """Each block of ``block`` consecutive cells: its cells' smallest minimum and largest maximum."""
    for blk in range(bmin.shape[0]):
        a = blk * block
        b = min(cmin.shape[0], a + block)
        lo = cmin[a]
        hi = cmax[a]
        for c in range(a + 1, b):
            lo = min(lo, cmin[c])
            hi = max(hi, cmax[c])
        bmin[blk] = lo
        bmax[blk] = hi


@njit(parallel=True)
def block_rows(cmin, block, lower, row):
    """Each block's rows: ``lower[b]`` the lower bounds of block ``b``'s rows, equally filled by its cells'
    minima (from a sample of ``64`` per row; ``-inf`` first, equal bounds merged, ``+inf`` after the last
    one), and ``row[c]`` cell ``c``'s row in its block: the last one whose bound is at most its minimum."""
    n_blocks, n_rows = lower.shape
    m = cmin.shape[0]
    for b in prange(n_blocks):
        a = b * block
        e = min(m, a + block)
        sample = np.sort(cmin[a:e:max(1, (e - a) // (64 * n_rows))])
        k = sample.shape[0]
        lower[b, 0] = -np.inf
        n = 1
        for i in range(1, n_rows):
            x = sample[(i * k) // n_rows]
            if x > lower[b, n - 1]:
                lower[b, n] = x
                n += 1
        for i in range(n, n_rows):
            lower[b, i] = np.inf
        for c in range(a, e):
            x = cmin[c]
            lo = 0
            hi = n
            while hi - lo > 1:  # lower[b, lo] <= x < lower[b, hi]; lo stays in 0 .. n - 1 (NaN too: guarded)
                mid = (lo + hi) >> 1
                if lower[b, mid] <= x:
                    lo = mid
                else:
                    hi = mid
            row[c] = b * n_rows + lo


@njit
def rows_by_count(row, n_rows, row_off, order):
    """Counting sort of the cells by row (stable: by id inside a row); ``row_off`` (n_rows + 1) the row starts."""
    for i in range(n_rows + 1):
        row_off[i] = 0
    for c in range(row.shape[0]):
        row_off[row[c] + 1] += 1
    for i in range(n_rows):
        row_off[i + 1] += row_off[i]
    fill = row_off[:-1].copy()
    for c in range(row.shape[0]):
        r = row[c]
        order[fill[r]] = c
        fill[r] += 1


@njit(parallel=True)
def sort_rows_by_max(order, row_off, cmax32):
    """Inside each row, the cells by their maximum, largest first (ties by cell id: a stable sort)."""
    for r in prange(row_off.shape[0] - 1):
        a = row_off[r]
        b = row_off[r + 1]
        if b - a < 2:
            continue
        part = order[a:b].copy()
        keys = np.empty(b - a, np.float32)
        for i in range(b - a):
            keys[i] = -cmax32[part[i]]
        idx = np.argsort(keys, kind="mergesort")
        for i in range(b - a):
            order[a + i] = part[idx[i]]


@njit(parallel=True)
def fill_table(order, cells, cell_edges, own, cmax32, c0, tab, cmx):
    """``tab`` and ``cmx`` in span-space order (see the module docstring), for the cells ``c0 + order``:
    ``cells``, ``cell_edges``, ``own`` and ``cmax32`` hold those cells' rows from ``c0`` on, ``tab`` and ``cmx``
    the rows of their positions."""
    nn = cells.shape[1]
    ne = cell_edges.shape[1]
    for p in prange(order.shape[0]):
        c = order[p]
        for i in range(nn):
            tab[p, i] = cells[c, i]
        for w in range(ne):
            tab[p, nn + w] = cell_edges[c, w]
        tab[p, nn + ne] = own[c]
        tab[p, nn + ne + 1] = c0 + c
        cmx[p] = cmax32[c]


# ------------------------------------------------------------------ a query
@njit(inline="always")
def _block_ranges(lower, row_off, cmx, value, blk, out, at):
    """Block ``blk``'s prefixes (see :func:`active_ranges`) into ``out[at:]``; returns how many."""
    n_rows = lower.shape[1]
    n = 0
    for r in range(n_rows):
        if lower[blk, r] >= value:
            break
        seg = blk * n_rows + r
        a = row_off[seg]
        lo = a
        hi = row_off[seg + 1]
        while lo < hi:  # the first position whose maximum is below value
            mid = (lo + hi) >> 1
            if cmx[mid] >= value:
                lo = mid + 1
            else:
                hi = mid
        if lo > a:
            out[at + n, 0] = a
            out[at + n, 1] = lo
            n += 1
    return n


@njit(parallel=True, cache=_KCACHE)
def active_ranges(lower, row_off, cmx, value, bmin, bmax, out, roff):
    """The segments' prefixes whose cells may be crossed by ``value``: ``out[:n]`` (start, end), and where
    each starts in the sequence of their cells, ``roff[:n + 1]`` (``roff[n]``: the active cells); returns ``n``.

    Block ``b`` (its cells' smallest minimum ``bmin[b]`` and largest maximum
    ``bmax[b]``) holds rows ``r`` of the cells whose minimum is at least
    ``lower[b, r]`` (and below ``lower[b, r + 1]``), segment ``b * R + r`` of
    the table (``R = lower.shape[1]``). A crossed cell has its minimum below
    ``value`` and its maximum at or above it: blocks without such cells are
    skipped, and in a block the rows from the first one with ``lower[r] >=
    value`` on. The blocks are searched in parallel, each into its own ``R``
    rows of ``out`` (``out`` has one per segment), then moved together in
    block order (10M in blocks of 8192 cells, 78,000 segments: 1.1 ms a value on one thread).
    """
    n_rows = lower.shape[1]
    n_blocks = bmin.shape[0]
    found = np.zeros(n_blocks, np.int64)
    for blk in prange(n_blocks):
        if bmin[blk] < value and bmax[blk] >= value:
            found[blk] = _block_ranges(lower, row_off, cmx, value, blk, out, blk * n_rows)
    n = 0
    roff[0] = 0
    for blk in range(n_blocks):  # forward: block blk's rows start at blk * R >= n
        at = blk * n_rows
        for j in range(found[blk]):
            a = out[at + j, 0]
            b = out[at + j, 1]
            out[n, 0] = a
            out[n, 1] = b
            roff[n + 1] = roff[n] + b - a
            n += 1
    return n


@njit(inline="always")
def _start(roff, i):
    """The range holding the ``i``-th active cell (``roff``: the ranges' starts in the active sequence)."""
    lo = 0
    hi = roff.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if roff[mid] <= i:
            lo = mid
        else:
            hi = mid
    return lo


@njit
def _exact_codes(case, exact, vals, value, tri_table, tri_count, local_edges, out):
    """Triangles of a polygon with a node at ``value`` as vertex codes (``ne + i``: node ``i``); returns
    ``(k, mask)``: the triangles kept (zero-area ones dropped) and the codes of the whole polygon as bits
    (the edge-centred construction's, the rare path: not inlined)."""
    return _ek._polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, out)


@njit(inline="always")
def _ask_range(tab, ranges, r):
    """Hint the first rows of range ``r`` (if there is one): a range is a few dozen cells at a place of the
    table far from the last one, and its first rows would otherwise wait for memory."""
    if r < ranges.shape[0]:
        flat = tab.reshape(-1)
        a = ranges[r, 0] * tab.shape[1]
        _prefetch_item(flat, a)
        _prefetch_item(flat, a + 16)


@njit(inline="always")
def _walk_start(ranges, roff, i):
    """``(range, place in tab)`` of the ``i``-th active cell."""
    r = _start(roff, i)
    return r, ranges[r, 0] + i - roff[r]


@njit(inline="always")
def _count_part_body(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff,
                     chunk, k0, k1, st, ch):
    """Pass 1 over chunks ``k0 .. k1``: each active cell's case into ``st`` (by its place in the active
    sequence, ``NOT_CROSSED`` or ``case | exact << 16``); per chunk ``k`` into ``ch[:, k]``: the triangles,
    the vertices of its owned crossed edges, its cells with a node at ``value``, its crossed cells."""
    n_act = roff[roff.shape[0] - 1]
    vals = np.empty(nn, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    own_col = nn + ne
    edge_bits = (1 << ne) - 1
    for k in range(k0, k1):
        i0 = k * chunk
        i1 = min(n_act, i0 + chunk)
        n_t = 0
        n_v = 0
        n_x = 0
        n_c = 0
        r, p = _walk_start(ranges, roff, i0)
        for i in range(i0, i1):
            while p >= ranges[r, 1]:
                r += 1
                p = ranges[r, 0]
                _ask_range(tab, ranges, r + RANGES_AHEAD)
            case, exact = _ek._values_of(tab, p, nn, s, value, faces, vals)  # a row's first nn: its nodes
            if case < 0:
                st[i] = NOT_CROSSED
                p += 1
                continue
            st[i] = case | (exact << 16)
            n_c += 1
            if exact == 0:
                n_t += tri_count[case]
                mask = case_mask[case]
            else:
                kk, mask = _exact_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
                n_t += kk
                n_x += 1
            bits = mask & tab[p, own_col] & edge_bits
            while bits:
                bits &= bits - 1
                n_v += 1
            p += 1
        ch[0, k] = n_t
        ch[1, k] = n_v
        ch[2, k] = n_x
        ch[3, k] = n_c


# Each pass is built once per cell type: its body inlined with the node and edge counts as constants, so that
# its loops over a cell's nodes and edges are unrolled and the node values kept in registers (the three passes
# so built took 0.87-0.88 of the generic build's time for 20 values on 2M, 0.88-0.89 on 10M; interleaved
# sweeps in one process, 2-core Xeon VM). The two builds are kernels of their own (``_count_part4``,
# ``_count_part8``, ...: tetrahedra, hexahedra), not two branches of one: a volume's cells are of one type
# (:class:`ActiveScan` checks that it is one of these two), and the first run compiles only its type's --
# one kernel with both branches took 15 s of CPU to compile, the fused pass alone (data4, 2-core VM).
# ``count_pass`` and the others (plain Python) choose by ``nn``.


@njit(cache=_KCACHE)
def _count_part4(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                 k0, k1, st, ch):
    """Pass 1 (:func:`_count_part_body`) on tetrahedra (``nn``, ``ne``: 4 and 6)."""
    _count_part_body(tab, 4, 6, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff,
                     chunk, k0, k1, st, ch)


@njit(cache=_KCACHE)
def _count_part8(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                 k0, k1, st, ch):
    """Pass 1 (:func:`_count_part_body`) on hexahedra (``nn``, ``ne``: 8 and 12)."""
    _count_part_body(tab, 8, 12, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff,
                     chunk, k0, k1, st, ch)


@njit(inline="always")
def _vertex_range(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, i0, i1, r, p,
                  st, v, x, ev, pos, keys, exact_cells, acc, vals, codes):
    """Pass 2 over the active cells ``i0 .. i1`` (the first at ``tab`` row ``p`` of range ``r``): each owned
    crossed edge's vertex, ids from ``v`` on: ``ev[edge]``, its position (5.2), its key and, where ``acc``
    (V, 3) has rows, its normal sums zeroed; the cells with a node at ``value`` into ``exact_cells``
    (place in ``tab``, ``st``; from ``x`` on). Returns ``(v, x)`` after them."""
    own_col = nn + ne
    edge_bits = (1 << ne) - 1
    zero = acc.shape[0] > 0
    for i in range(i0, i1):
        while p >= ranges[r, 1]:
            r += 1
            p = ranges[r, 0]
            _ask_range(tab, ranges, r + RANGES_AHEAD)
        code = st[i]
        if code < 0:
            p += 1
            continue
        case = code & 0xFFFF
        exact = code >> 16
        if exact == 0:
            mask = case_mask[case]
        else:
            for j in range(nn):
                vals[j] = s[tab[p, j]]
            _, mask = _exact_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
            exact_cells[x, 0] = p
            exact_cells[x, 1] = code
            x += 1
        bits = mask & tab[p, own_col] & edge_bits
        while bits:
            w = _ctz(bits)
            bits &= bits - 1
            e = tab[p, nn + w]
            ev[e] = v
            a = tab[p, local_edges[w, 0]]
            b = tab[p, local_edges[w, 1]]
            na = min(a, b)
            nb = max(a, b)
            c1 = s[na]
            c2 = s[nb]
            # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
            for d in range(3):
                pos[v, d] = ((value - c1) * points[nb, d] - (value - c2) * points[na, d]) / (c2 - c1)
            keys[v] = e
            if zero:
                acc[v, 0] = 0.0
                acc[v, 1] = 0.0
                acc[v, 2] = 0.0
            v += 1
        p += 1
    return v, x


@njit(inline="always")
def _vertex_part_body(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                      chunk, k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc):
    """Pass 2 over chunks ``k0 .. k1`` (:func:`_vertex_range`; ids from ``v_off[k0]``, ``x_off[k0]``)."""
    n_act = roff[roff.shape[0] - 1]
    i0 = k0 * chunk
    i1 = min(n_act, k1 * chunk)
    if i0 < i1:
        vals = np.empty(nn, np.float64)
        codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
        r, p = _walk_start(ranges, roff, i0)
        _vertex_range(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, i0, i1,
                      r, p, st, v_off[k0], x_off[k0], ev, pos, keys, exact_cells, acc, vals, codes)


@njit(cache=_KCACHE)
def _vertex_part4(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                  k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc):
    """Pass 2 (:func:`_vertex_part_body`) on tetrahedra (see :func:`_count_part4`)."""
    _vertex_part_body(tab, 4, 6, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                      chunk, k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc)


@njit(cache=_KCACHE)
def _vertex_part8(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                  k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc):
    """Pass 2 (:func:`_vertex_part_body`) on hexahedra."""
    _vertex_part_body(tab, 8, 12, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                      chunk, k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc)


@njit(inline="always")
def _triangle_range(tab, nn, ne, s, value, tri_table, tri_count, local_edges, ranges, i0, i1, r, p, st, t, ev, nvid,
                    tris, tri_cell, pos, acc, v0, v1, fused, whole, lag, side_t, n_side, vals, codes):
    """Pass 3 over the active cells ``i0 .. i1`` (the first at ``tab`` row ``p`` of range ``r``): each
    crossed cell's triangles as vertex ids (``ev`` of its edges, ``nvid`` of its nodes at ``value``), from
    ``t`` on; with ``acc`` (V, 3) (rows: the mean normals are asked for and no node is at ``value``) each
    triangle's normal (:func:`~polygen.volume.marching.triangle_normal` of ``pos``) added into its
    corners' rows where all three are this part's (ids ``v0 .. v1``), else the triangle onto the side list
    ``side_t[n_side:]``.

    ``fused`` (:func:`_fused_part_body`, no node at ``value``): the cells are one block's, ``whole`` if
    the part holds all of its active cells, and the part has made the vertices of the ``lag`` blocks before
    it. A triangle whose vertices may not be made yet -- the block is not whole, or a corner's owner is in
    an earlier block further back than ``lag`` -- keeps its corners' edge ids and goes onto the side list
    (:func:`side_normals` looks them up once every vertex is made), and so does one whose corners are not
    all this part's. Returns ``(t, n_side, reads)`` after them: ``reads`` counts the vertex ids read at an
    edge id (``ev[edge]``), one per triangle corner on an edge read here."""
    cell_col = nn + ne + 1
    own_col = nn + ne
    mean = acc.shape[0] > 0
    reads = 0
    for i in range(i0, i1):
        while p >= ranges[r, 1]:
            r += 1
            p = ranges[r, 0]
            _ask_range(tab, ranges, r + RANGES_AHEAD)
        code = st[i]
        if code < 0:
            p += 1
            continue
        case = code & 0xFFFF
        exact = code >> 16
        c = tab[p, cell_col]
        if exact == 0:
            far = -1  # bit w: the vertex of edge w may not be made yet
            if whole:
                own = tab[p, own_col]
                back = (own >> REACH) & REACH_MAX
                far = 0 if back < REACH_MAX and back <= lag else (own >> FOREIGN)
            for j in range(tri_count[case]):
                w0 = tri_table[case, 3 * j]
                w1 = tri_table[case, 3 * j + 1]
                w2 = tri_table[case, 3 * j + 2]
                e0 = tab[p, nn + w0]
                e1 = tab[p, nn + w1]
                e2 = tab[p, nn + w2]
                tri_cell[t] = c
                if fused and ((far >> w0) | (far >> w1) | (far >> w2)) & 1:
                    tris[t, 0] = e0
                    tris[t, 1] = e1
                    tris[t, 2] = e2
                    side_t[n_side] = t
                    n_side += 1
                    t += 1
                    continue
                i0_ = ev[e0]
                i1_ = ev[e1]
                i2_ = ev[e2]
                reads += 3  # the look-ups of the corners' vertex ids by edge id
                if mean and not (v0 <= min(i0_, i1_, i2_) and max(i0_, i1_, i2_) < v1):
                    if fused:
                        tris[t, 0] = e0
                        tris[t, 1] = e1
                        tris[t, 2] = e2
                    else:
                        tris[t, 0] = i0_
                        tris[t, 1] = i1_
                        tris[t, 2] = i2_
                    side_t[n_side] = t
                    n_side += 1
                    t += 1
                    continue
                tris[t, 0] = i0_
                tris[t, 1] = i1_
                tris[t, 2] = i2_
                t += 1
                if mean:
                    nx, ny, nz = _m.triangle_normal(pos, i0_, i1_, i2_)
                    acc[i0_, 0] += nx
                    acc[i0_, 1] += ny
                    acc[i0_, 2] += nz
                    acc[i1_, 0] += nx
                    acc[i1_, 1] += ny
                    acc[i1_, 2] += nz
                    acc[i2_, 0] += nx
                    acc[i2_, 1] += ny
                    acc[i2_, 2] += nz
        else:
            for j in range(nn):
                vals[j] = s[tab[p, j]]
            kk, _ = _exact_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
            for j in range(kk):
                for m in range(3):
                    w = codes[j, m]
                    if w < ne:
                        tris[t, m] = ev[tab[p, nn + w]]
                        reads += 1
                    else:
                        tris[t, m] = nvid[tab[p, w - ne]] & 0xFFFFFFFF
                tri_cell[t] = c
                t += 1
        p += 1
    return t, n_side, reads


@njit(inline="always")
def _triangle_part_body(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                        k0, k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v0, v1, side_t, n_side, reads):
    """Pass 3 over chunks ``k0 .. k1`` (:func:`_triangle_range`, not fused; ids from ``t_off[k0]``);
    returns the side list's end."""
    n_act = roff[roff.shape[0] - 1]
    i0 = k0 * chunk
    i1 = min(n_act, k1 * chunk)
    if i0 < i1:
        vals = np.empty(nn, np.float64)
        codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
        r, p = _walk_start(ranges, roff, i0)
        _, n_side, got = _triangle_range(tab, nn, ne, s, value, tri_table, tri_count, local_edges, ranges, i0, i1, r, p,
                                    st, t_off[k0], ev, nvid, tris, tri_cell, pos, acc, v0, v1, False, True, 0,
                                    side_t, n_side, vals, codes)
        reads[0] += got
    return n_side


@njit(cache=_KCACHE)
def _triangle_part4(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk, k0,
                    k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v0, v1, side_t, n_side, reads):
    """Pass 3 (:func:`_triangle_part_body`) on tetrahedra (see :func:`_count_part4`)."""
    return _triangle_part_body(tab, 4, 6, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff,
                               chunk, k0, k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v0, v1, side_t, n_side,
                               reads)


@njit(cache=_KCACHE)
def _triangle_part8(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk, k0,
                    k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v0, v1, side_t, n_side, reads):
    """Pass 3 (:func:`_triangle_part_body`) on hexahedra."""
    return _triangle_part_body(tab, 8, 12, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff,
                               chunk, k0, k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v0, v1, side_t, n_side,
                               reads)


@njit(inline="always")
def _fused_part_body(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                     block, k0, k1, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, side_t,
                     reads):
    """Passes 2 and 3 over chunks ``k0 .. k1``, block by block: a block's vertices, then its triangles
    (:func:`_triangle_range`, fused), while the block's rows of ``ev``, ``pos`` and ``acc`` are still in
    the core's cache. An edge's owner is its first cell, in the same block or an earlier one, so a block
    that the part holds whole has made the vertices of every edge whose owner is in it; the triangles with
    a corner owned elsewhere wait on the side list. Returns the side list's length (from ``t_off[k0]``)."""
    n_act = roff[roff.shape[0] - 1]
    n_r = ranges.shape[0]
    i_beg = k0 * chunk
    i_end = min(n_act, k1 * chunk)
    n_side = t_off[k0]
    if i_beg >= i_end:
        return 0
    vals = np.empty(nn, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    v0 = v_off[k0]
    v1 = v_off[k1]
    v = v0
    x = 0
    t = t_off[k0]
    i = i_beg
    r, p = _walk_start(ranges, roff, i)
    done = -1  # the part's first block whose vertices it makes all of
    while i < i_end:
        blk = ranges[r, 0] // block  # the ranges of a block are consecutive
        rs = r
        while rs > 0 and ranges[rs - 1, 0] // block == blk:
            rs -= 1
        re = r
        while re + 1 < n_r and ranges[re + 1, 0] // block == blk:
            re += 1
        g_end = min(i_end, roff[re + 1])
        whole = roff[rs] >= i_beg and roff[re + 1] <= i_end
        if done < 0:
            done = blk if roff[rs] >= i_beg else blk + 1
        v, x = _vertex_range(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges,
                             i, g_end, r, p, st, v, x, ev, pos, keys, exact_cells, acc, vals, codes)
        t, n_side, got = _triangle_range(tab, nn, ne, s, value, tri_table, tri_count, local_edges, ranges, i, g_end, r,
                                    p, st, t, ev, nvid, tris, tri_cell, pos, acc, v0, v1, True, whole, blk - done,
                                    side_t, n_side, vals, codes)
        reads[0] += got
        i = g_end
        if i < i_end:
            r = re + 1
            p = ranges[r, 0]
    return n_side - t_off[k0]


@njit(cache=_KCACHE)
def _fused_part4(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                 block, k0, k1, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, side_t, reads):
    """Passes 2 and 3 (:func:`_fused_part_body`) on tetrahedra (see :func:`_count_part4`)."""
    return _fused_part_body(tab, 4, 6, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                            chunk, block, k0, k1, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell,
                            acc, side_t, reads)


@njit(cache=_KCACHE)
def _fused_part8(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                 block, k0, k1, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, side_t, reads):
    """Passes 2 and 3 (:func:`_fused_part_body`) on hexahedra."""
    return _fused_part_body(tab, 8, 12, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                            chunk, block, k0, k1, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell,
                            acc, side_t, reads)


def _fused_part(tab, nn, *args):
    """:func:`_fused_part4` or :func:`_fused_part8`, by ``nn`` (from Python: the tests run the parts one by one)."""
    return (_fused_part4 if nn == 4 else _fused_part8)(tab, nn, *args)


@njit(inline="always")
def _part(n, n_parts, q):
    """Chunks ``q * n // P .. (q + 1) * n // P``: part ``q`` of ``P`` consecutive parts."""
    return q * n // n_parts, (q + 1) * n // n_parts


@njit(inline="always")
def _cut(off, n_parts, q):
    """The first chunk of part ``q`` when the chunks (their items' running counts ``off``, ``n + 1`` of them)
    are cut where the count reaches ``q / P`` of the total: parts of equal work, not equal chunks."""
    n = off.shape[0] - 1
    if q <= 0:
        return 0
    if q >= n_parts:
        return n
    return min(n, np.searchsorted(off, (q * off[n]) // n_parts))


@njit(inline="always")
def _part_by(off, n_parts, q):
    """Chunks ``k0 .. k1`` of part ``q`` of ``P``, cut by the running counts ``off`` (:func:`_cut`)."""
    return _cut(off, n_parts, q), _cut(off, n_parts, q + 1)


# The passes split the chunks into one run of consecutive chunks per thread (not prange over the chunks):
# each part is one thread's from start to end, so it alone writes the normal sums of the vertices its
# chunks made, and the sums come out the same whatever the scheduler did.
def count_pass(tab, nn, *args):
    """:func:`_count_part4` (or 8) by ``n_parts`` threads, then the running counts ``off`` (3, chunks + 1) of the
    triangles, vertices and cells with a node at ``value`` (the chunks' first ids); returns the crossed cells.

    Arguments ``tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
    st, ch, off, n_parts``."""
    return (_count_pass4 if nn == 4 else _count_pass8)(tab, nn, *args)


@njit(parallel=True, cache=_KCACHE)
def _count_pass4(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                 st, ch, off, n_parts):
    """:func:`count_pass` on tetrahedra."""
    n_ch = ch.shape[1]
    for q in prange(n_parts):
        k0, k1 = _part(n_ch, n_parts, q)
        _count_part4(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                     k0, k1, st, ch)
    return _count_offsets(ch, off)


@njit(parallel=True, cache=_KCACHE)
def _count_pass8(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                 st, ch, off, n_parts):
    """:func:`count_pass` on hexahedra."""
    n_ch = ch.shape[1]
    for q in prange(n_parts):
        k0, k1 = _part(n_ch, n_parts, q)
        _count_part8(tab, nn, ne, s, value, faces, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk,
                     k0, k1, st, ch)
    return _count_offsets(ch, off)


@njit(inline="always")
def _count_offsets(ch, off):
    """The running counts ``off`` of the chunks' counts ``ch`` (:func:`count_pass`); returns the crossed cells."""
    n_ch = ch.shape[1]
    n_c = 0
    for j in range(3):
        off[j, 0] = 0
    for k in range(n_ch):
        for j in range(3):
            off[j, k + 1] = off[j, k] + ch[j, k]
        n_c += ch[3, k]
    return n_c


def vertex_pass(tab, nn, *args):
    """:func:`_vertex_part4` (or 8) by ``n_parts`` threads, each with about as many vertices to make (at 2M the
    chunks' halves had up to 4.9 % more in one, weighted over a sweep).

    Arguments ``tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
    st, v_off, x_off, ev, pos, keys, exact_cells, acc, n_parts``."""
    return (_vertex_pass4 if nn == 4 else _vertex_pass8)(tab, nn, *args)


@njit(parallel=True, cache=_KCACHE)
def _vertex_pass4(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                  st, v_off, x_off, ev, pos, keys, exact_cells, acc, n_parts):
    """:func:`vertex_pass` on tetrahedra."""
    for q in prange(n_parts):
        k0, k1 = _part_by(v_off, n_parts, q)
        _vertex_part4(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                      chunk, k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc)


@njit(parallel=True, cache=_KCACHE)
def _vertex_pass8(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                  st, v_off, x_off, ev, pos, keys, exact_cells, acc, n_parts):
    """:func:`vertex_pass` on hexahedra."""
    for q in prange(n_parts):
        k0, k1 = _part_by(v_off, n_parts, q)
        _vertex_part8(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                      chunk, k0, k1, st, v_off, x_off, ev, pos, keys, exact_cells, acc)


@njit
def part_cuts(off, n_parts):
    """The first chunk of each part and the end (``n_parts + 1``): :func:`_cut` by the running counts ``off``."""
    cuts = np.empty(n_parts + 1, np.int64)
    for q in range(n_parts + 1):
        cuts[q] = _cut(off, n_parts, q)
    return cuts


def triangle_pass(tab, nn, *args):
    """:func:`_triangle_part4` (or 8) by ``n_parts`` threads, part ``q`` (chunks ``cuts[q] .. cuts[q + 1]``)
    adding the normals of its triangles whose corners its chunks made (``v_off``) into ``acc``, the others' ids
    onto its side list (``side_t`` from ``t_off[cuts[q]]`` on; its length into ``n_side[q]``); ``ev_reads[q]``
    counts part ``q``'s reads of a vertex id at an edge id (``ev[edge]``), one per triangle corner on an edge.

    Arguments ``tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk, st,
    t_off, ev, nvid, tris, tri_cell, pos, acc, cuts, v_off, side_t, n_side, n_parts, ev_reads``."""
    return (_triangle_pass4 if nn == 4 else _triangle_pass8)(tab, nn, *args)


@njit(parallel=True, cache=_KCACHE)
def _triangle_pass4(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk, st,
                    t_off, ev, nvid, tris, tri_cell, pos, acc, cuts, v_off, side_t, n_side, n_parts, ev_reads):
    """:func:`triangle_pass` on tetrahedra."""
    for q in prange(n_parts):
        k0, k1 = cuts[q], cuts[q + 1]
        t0 = t_off[k0]
        n_side[q] = _triangle_part4(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges,
                                    roff, chunk, k0, k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v_off[k0],
                                    v_off[k1], side_t, t0, ev_reads[q:q + 1]) - t0


@njit(parallel=True, cache=_KCACHE)
def _triangle_pass8(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges, roff, chunk, st,
                    t_off, ev, nvid, tris, tri_cell, pos, acc, cuts, v_off, side_t, n_side, n_parts, ev_reads):
    """:func:`triangle_pass` on hexahedra."""
    for q in prange(n_parts):
        k0, k1 = cuts[q], cuts[q + 1]
        t0 = t_off[k0]
        n_side[q] = _triangle_part8(tab, nn, ne, s, value, tri_table, tri_count, case_mask, local_edges, ranges,
                                    roff, chunk, k0, k1, st, t_off, ev, nvid, tris, tri_cell, pos, acc, v_off[k0],
                                    v_off[k1], side_t, t0, ev_reads[q:q + 1]) - t0


def fused_pass(tab, nn, *args):
    """:func:`_fused_part4` (or 8) by ``n_parts`` threads (no node at the value), part ``q`` chunks ``cuts[q] ..
    cuts[q + 1]``, its side list's length into ``n_side[q]`` (see :func:`triangle_pass`); then
    :func:`side_normals`.

    Arguments ``tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
    block, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, cuts, side_t, n_side, n_parts,
    ev_reads``."""
    return (_fused_pass4 if nn == 4 else _fused_pass8)(tab, nn, *args)


@njit(parallel=True, cache=_KCACHE)
def _fused_pass4(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                 block, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, cuts, side_t, n_side,
                 n_parts, ev_reads):
    """:func:`fused_pass` on tetrahedra."""
    for q in prange(n_parts):
        n_side[q] = _fused_part4(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask,
                                 ranges, roff, chunk, block, cuts[q], cuts[q + 1], st, v_off, t_off, ev, nvid, pos,
                                 keys, exact_cells, tris, tri_cell, acc, side_t, ev_reads[q:q + 1])


@njit(parallel=True, cache=_KCACHE)
def _fused_pass8(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff, chunk,
                 block, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, cuts, side_t, n_side,
                 n_parts, ev_reads):
    """:func:`fused_pass` on hexahedra."""
    for q in prange(n_parts):
        n_side[q] = _fused_part8(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask,
                                 ranges, roff, chunk, block, cuts[q], cuts[q + 1], st, v_off, t_off, ev, nvid, pos,
                                 keys, exact_cells, tris, tri_cell, acc, side_t, ev_reads[q:q + 1])


@njit(parallel=True, cache=_KCACHE)
def side_normals(tris, ev, side_t, cuts, t_off, v_off, n_side, pos, acc, side_n, lookup, ev_reads):
    """Each part's side list (``side_t`` from ``t_off[cuts[q]]``, ``n_side[q]`` long), by its own thread:
    with ``lookup`` (:func:`fused_pass`) the triangles' corners from edge ids to vertex ids (``ev``); with
    ``acc`` (V, 3) (rows: the mean normals) each triangle's normal into ``side_n`` (the parts' lists one
    after the other) and into the part's own rows of ``acc`` (ids ``v_off[cuts[q]] .. v_off[cuts[q + 1]]``);
    :func:`fold_normals` adds them into the other parts' rows. ``ev_reads[q]`` counts the ``ev`` reads."""
    n_parts = n_side.shape[0]
    mean = acc.shape[0] > 0
    for q in prange(n_parts):
        t0 = t_off[cuts[q]]
        v0 = v_off[cuts[q]]
        v1 = v_off[cuts[q + 1]]
        k = 0
        for p in range(q):
            k += n_side[p]
        for j in range(t0, t0 + n_side[q]):
            t = side_t[j]
            if lookup:
                tris[t, 0] = ev[tris[t, 0]]
                tris[t, 1] = ev[tris[t, 1]]
                tris[t, 2] = ev[tris[t, 2]]
                ev_reads[q] += 3
            if mean:
                nx, ny, nz = _m.triangle_normal(pos, tris[t, 0], tris[t, 1], tris[t, 2])
                side_n[k, 0] = nx
                side_n[k, 1] = ny
                side_n[k, 2] = nz
                for m in range(3):
                    v = tris[t, m]
                    if v0 <= v < v1:
                        acc[v, 0] += nx
                        acc[v, 1] += ny
                        acc[v, 2] += nz
            k += 1


@njit
def _fold_part(acc, out, q, v0, v1, tris, side_t, t_first, n_side, side_n):
    """Rows ``v0 .. v1`` (part ``q``'s) of ``out``: ``acc``'s rows plus the normals ``side_n`` of the other
    parts' side lists' triangles (in the parts' order) at their corners among these rows, each to unit
    length (:func:`~polygen.volume.marching.unit_into`: a zero sum stays zero); returns how many are zero
    (marching.zero_rows)."""
    k = 0
    for p in range(n_side.shape[0]):
        if p == q:
            k += n_side[p]
            continue
        for j in range(t_first[p], t_first[p] + n_side[p]):
            t = side_t[j]
            for m in range(3):
                v = tris[t, m]
                if v0 <= v < v1:
                    acc[v, 0] += side_n[k, 0]
                    acc[v, 1] += side_n[k, 1]
                    acc[v, 2] += side_n[k, 2]
            k += 1
    n_zero = 0
    for v in range(v0, v1):
        n_zero += _m.unit_into(acc[v, 0], acc[v, 1], acc[v, 2], out, v)
    return n_zero


@njit(parallel=True)
def fold_normals(acc, out, cuts, v_off, t_off, tris, side_t, n_side, side_n):
    """The mean normals ``out`` from the sums ``acc`` of :func:`triangle_pass` (or :func:`fused_pass`) and
    :func:`side_normals`, each part's vertices by its own thread; returns how many rows are zero."""
    n_parts = n_side.shape[0]
    t_first = np.empty(n_parts, np.int64)
    for q in range(n_parts):
        t_first[q] = t_off[cuts[q]]
    zeros = np.zeros(n_parts, np.int64)
    for q in prange(n_parts):
        # q as int64: one build of _fold_part (a prange index is uint64 in the parallel body, int64 before)
        zeros[q] = _fold_part(acc, out, np.int64(q), v_off[cuts[q]], v_off[cuts[q + 1]], tris, side_t, t_first,
                              n_side, side_n)
    return zeros.sum()


@njit
def node_vertices(tab, nn, s, value, points, tri_table, tri_count, local_edges, exact_cells, n_edges, nvid, gen,
                  first, pos, keys):
    """The vertices exactly on nodes, in the order of the cells listed in ``exact_cells`` (place in ``tab``,
    ``st``), ids from ``first`` on.

    ``nvid[node]`` is ``gen << 32 | id`` once the node's vertex is made in
    query ``gen``. Returns the vertex count after them.
    """
    ne = local_edges.shape[0]
    vals = np.empty(nn, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    v = first
    for q in range(exact_cells.shape[0]):
        p = exact_cells[q, 0]
        code = exact_cells[q, 1]
        for j in range(nn):
            vals[j] = s[tab[p, j]]
        _, mask = _exact_codes(code & 0xFFFF, code >> 16, vals, value, tri_table, tri_count, local_edges, codes)
        for i in range(nn):
            if (mask >> (ne + i)) & 1 == 0:
                continue
            node = tab[p, i]
            if (nvid[node] >> 32) == gen:
                continue
            nvid[node] = (np.int64(gen) << 32) | v
            for d in range(3):
                pos[v, d] = points[node, d]
            keys[v] = n_edges + node
            v += 1
    return v
