"""Numba kernels behind :mod:`polygen.volume.mesh`.

Arrays in, arrays out; nothing here imports anything of polygen's but the
JIT options. The central trick is :func:`match_rows`: rows of node ids
(faces, edges), each sorted, are bucketed by their smallest node with a
counting sort and matched inside the bucket, which is linear in the number
of rows and needs neither a global sort nor a Python loop.
"""

import numba
import numpy as np

from polygen._jit import empty, njit, prange
from polygen.volume._cells import HEX_FACES as HEX_FACE_NODES


@njit
def sort_rows(rows):
    """Sort each row of a small-width integer array in place (insertion sort)."""
    k = rows.shape[1]
    for r in range(rows.shape[0]):
        for i in range(1, k):
            v = rows[r, i]
            j = i - 1
            while j >= 0 and rows[r, j] > v:
                rows[r, j + 1] = rows[r, j]
                j -= 1
            rows[r, j + 1] = v


def csr_from_keys(keys, n_keys):
    """Group ``arange(len(keys))`` by ``keys``: returns ``(offsets (n_keys+1,) int64, order int64)``.

    ``order[offsets[k]:offsets[k+1]]`` are the positions holding key ``k``,
    in increasing position (a stable counting sort, parallel: :func:`stable_csr`).
    """
    return stable_csr(keys, n_keys)


@njit
def _csr_serial(keys, n_keys):
    """:func:`csr_from_keys` in one thread, for the kernels."""
    offsets = np.zeros(n_keys + 1, np.int64)
    for i in range(keys.shape[0]):
        offsets[keys[i] + 1] += 1
    for k in range(n_keys):
        offsets[k + 1] += offsets[k]
    fill = offsets[:-1].copy()
    order = np.empty(keys.shape[0], np.int64)
    for i in range(keys.shape[0]):
        k = keys[i]
        order[fill[k]] = i
        fill[k] += 1
    return offsets, order


@njit
def match_rows(rows, n_nodes):
    """Number the distinct rows of ``rows`` (each row sorted ascending).

    Rows are bucketed by their first (smallest) node; inside a bucket the
    rest of the row, packed into one integer, is sorted by insertion, so
    equal rows end up adjacent. Returns ``(ids, first)``: ``ids[r]`` is the
    number of row ``r``'s distinct value (numbered by smallest node, then
    by the rest), and ``first[i]`` is the first row with number ``i``.
    Rows of width 2-3 with node ids below 2**31 are packed exactly.
    """
    n = rows.shape[0]
    k = rows.shape[1]
    offsets, order = _csr_serial(rows[:, 0], n_nodes)
    ids = np.empty(n, np.int64)
    first = np.empty(n, np.int64)
    key = np.empty(n, np.int64)
    for r in range(n):
        v = np.int64(0)
        for c in range(1, k):
            v = v * n_nodes + rows[r, c]
        key[r] = v
    n_unique = 0
    for b in range(n_nodes):
        lo = offsets[b]
        hi = offsets[b + 1]
        # insertion sort of order[lo:hi] by key (buckets hold tens of rows)
        for i in range(lo + 1, hi):
            r = order[i]
            kr = key[r]
            j = i - 1
            while j >= lo and (key[order[j]] > kr or (key[order[j]] == kr and order[j] > r)):
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = r
        prev = np.int64(-1)
        for i in range(lo, hi):
            r = order[i]
            if i == lo or key[r] != prev:
                first[n_unique] = r
                n_unique += 1
                prev = key[r]
            ids[r] = n_unique - 1
    return ids, first[:n_unique].copy()


@njit
def face_neighbors_from_ids(face_ids, n_faces_per_cell, n_unique):
    """Pair the cell faces that carry the same face id.

    Returns ``(neighbors (M, F), bad)``, where ``bad`` is the first face id
    shared by more than two cells, or -1.
    """
    n_rows = face_ids.shape[0]
    m = n_rows // n_faces_per_cell
    first = np.full(n_unique, -1, np.int64)
    second = np.full(n_unique, -1, np.int64)
    bad = -1
    for r in range(n_rows):
        u = face_ids[r]
        if first[u] < 0:
            first[u] = r
        elif second[u] < 0:
            second[u] = r
        elif bad < 0:
            bad = r
    neighbors = np.full((m, n_faces_per_cell), -1, np.int64)
    for u in range(n_unique):
        a = first[u]
        b = second[u]
        if b >= 0:
            neighbors[a // n_faces_per_cell, a % n_faces_per_cell] = b // n_faces_per_cell
            neighbors[b // n_faces_per_cell, b % n_faces_per_cell] = a // n_faces_per_cell
    return neighbors, bad


@njit
def gather_local(cells, local):
    """``out[c*L + i, j] = cells[c, local[i, j]]``: the faces or edges of every cell."""
    m = cells.shape[0]
    n_loc = local.shape[0]
    w = local.shape[1]
    out = np.empty((m * n_loc, w), np.int64)
    for c in prange(m):
        for i in range(n_loc):
            for j in range(w):
                out[c * n_loc + i, j] = cells[c, local[i, j]]
    return out


@njit(parallel=True)
def tet_volumes6(points, cells):
    """Six times the signed volume of each tetrahedron, and its longest edge."""
    m = cells.shape[0]
    vol = np.empty(m)
    longest = np.empty(m)
    for c in prange(m):
        p0 = points[cells[c, 0]]
        a = points[cells[c, 1]] - p0
        b = points[cells[c, 2]] - p0
        d = points[cells[c, 3]] - p0
        vol[c] = (a[0] * (b[1] * d[2] - b[2] * d[1])
                  - a[1] * (b[0] * d[2] - b[2] * d[0])
                  + a[2] * (b[0] * d[1] - b[1] * d[0]))
        e = 0.0
        for i in range(4):
            for j in range(i + 1, 4):
                s = 0.0
                for x in range(3):
                    t = points[cells[c, i], x] - points[cells[c, j], x]
                    s += t * t
                if s > e:
                    e = s
        longest[c] = np.sqrt(e)
    return vol, longest


@njit
def points_range(points, lo, hi):
    """Whether every coordinate is finite; if so ``lo``, ``hi`` (3,) get the per-axis min and max.

    One pass over the points instead of numpy's ``isfinite``, ``min`` and
    ``max`` along axis 0 (strided reductions: 15 ms on 2M's 346k nodes).
    """
    for d in range(3):
        lo[d] = np.inf
        hi[d] = -np.inf
    for i in range(points.shape[0]):
        for d in range(3):
            x = points[i, d]
            if not (abs(x) < np.inf):  # NaN or infinite
                return False
            if x < lo[d]:
                lo[d] = x
            if x > hi[d]:
                hi[d] = x
    return True


@njit
def _tet_clearly_valid(points, i0, i1, i2, i3, rtol):
    """Whether the tetrahedron ``i0 i1 i2 i3`` (ids in range) has a positive volume clearly above the
    degeneracy bound of :meth:`UnstructuredVolume._check_geometry` (``6V > rtol * longest**3`` with a
    relative margin of 1e-9, so that rounding never calls a cell valid that the exact check would refuse)."""
    ax = points[i1, 0] - points[i0, 0]
    ay = points[i1, 1] - points[i0, 1]
    az = points[i1, 2] - points[i0, 2]
    bx = points[i2, 0] - points[i0, 0]
    by = points[i2, 1] - points[i0, 1]
    bz = points[i2, 2] - points[i0, 2]
    dx = points[i3, 0] - points[i0, 0]
    dy = points[i3, 1] - points[i0, 1]
    dz = points[i3, 2] - points[i0, 2]
    v6 = ax * (by * dz - bz * dy) - ay * (bx * dz - bz * dx) + az * (bx * dy - by * dx)
    e = max(ax * ax + ay * ay + az * az, bx * bx + by * by + bz * bz, dx * dx + dy * dy + dz * dz)
    for i, j in ((i1, i2), (i1, i3), (i2, i3)):  # the other edges from the points, as tet_volumes6
        ex = points[i, 0] - points[j, 0]
        ey = points[i, 1] - points[j, 1]
        ez = points[i, 2] - points[j, 2]
        e = max(e, ex * ex + ey * ey + ez * ez)
    return v6 > rtol * (1.0 + 1e-9) * e * np.sqrt(e)  # False for NaN too


@njit
def _own_tets(points, src, dst, geometry, rtol, used, lo, hi, counts_t):
    """:func:`_own_cells` for the tetrahedra ``lo:hi`` (the four ids in registers): how many are not clearly
    valid."""
    n = points.shape[0]
    n_bad = 0
    for c in range(lo, hi):
        i0 = src[c, 0]
        i1 = src[c, 1]
        i2 = src[c, 2]
        i3 = src[c, 3]
        dst[c, 0] = i0
        dst[c, 1] = i1
        dst[c, 2] = i2
        dst[c, 3] = i3
        low = min(min(i0, i1), min(i2, i3))
        if (low < 0 or max(max(i0, i1), max(i2, i3)) >= n
                or i0 == i1 or i0 == i2 or i0 == i3 or i1 == i2 or i1 == i3 or i2 == i3):
            n_bad += 1
            continue
        counts_t[low] += 1
        if geometry and not _tet_clearly_valid(points, np.int64(i0), np.int64(i1), np.int64(i2), np.int64(i3), rtol):
            n_bad += 1
            continue
        used[i0] = 1
        used[i1] = 1
        used[i2] = 1
        used[i3] = 1
    return n_bad


@njit
def _own_rows(n, src, dst, used, lo, hi, counts_t):
    """:func:`_own_cells` for the rows ``lo:hi`` of any width (ids only): how many are not clearly valid."""
    k = src.shape[1]
    n_bad = 0
    for c in range(lo, hi):
        ok = True
        low = n
        for i in range(k):
            a = src[c, i]
            dst[c, i] = a
            if a < 0 or a >= n:
                ok = False
            elif a < low:
                low = a
            for j in range(i):
                if src[c, j] == a:
                    ok = False
        if not ok:
            n_bad += 1
            continue
        counts_t[low] += 1
        for i in range(k):
            used[src[c, i]] = 1
    return n_bad


@njit(parallel=True)
def _own_cells(points, src, dst, geometry, rtol, used, sb, counts, bad):
    """:func:`own_cells`' one pass, slab ``t`` of ``sb`` by thread: ``bad[t]`` its cells that are not clearly
    valid, ``counts[t, k]`` its valid-id cells whose smallest node is ``k``."""
    for t in prange(sb.shape[0] - 1):
        if src.shape[1] == 4:
            bad[t] = _own_tets(points, src, dst, geometry, rtol, used, sb[t], sb[t + 1], counts[t])
        else:
            bad[t] = _own_rows(points.shape[0], src, dst, used, sb[t], sb[t + 1], counts[t])


def own_cells(points, cells, dtype, geometry, rtol, used):
    """The constructor's one parallel pass over the cells: ``(copy, bad, counted)``.

    ``copy``: ``cells`` (int32 or int64, C-contiguous) as a fresh ``dtype`` array. ``bad``: how many cells
    are not clearly valid -- a node id outside ``0..len(points)-1`` (read before the narrowing copy could
    wrap it into range), a repeated node, or (``geometry``, tetrahedra) a volume not clearly above the
    degeneracy bound (:func:`_tet_clearly_valid`); ``used[node] = 1`` for the nodes of the others. The
    constructor runs the exact checks (and their messages) only when ``bad`` is not zero. ``counted``: the
    slabs and counts of :func:`find_duplicate_cells`' counting sort by smallest node, complete whenever every
    id is in range and distinct in its cell.

    Reading the caller's rows once for the copy, the checks and the count, instead of a numpy copy and two
    passes over it: the first constructor of a fresh process on 80M took 2.70 and 3.07 s against 3.19 and
    5.78 s before (runs alternated; 2.3-7.0 s in later runs, the page faults the same); on 2M no change (0.083-0.096 s against 0.080-0.096), where the
    15,000 first writes to fresh pages, the same number either way, are most of the time.
    """
    m, n = cells.shape[0], points.shape[0]
    if cells.flags.writeable:  # read-only rows, as a volume's own: one compiled pass for both (a view: not a copy)
        cells = cells.view()
        cells.setflags(write=False)
    dst = empty(cells.shape, dtype)
    sb, counts = _slabs(m, numba.get_num_threads(), n)
    bad = np.zeros(sb.shape[0] - 1, np.int64)
    _own_cells(points, cells, dst, geometry, rtol, used, sb, counts, bad)
    return dst, int(bad.sum()), (sb, counts)


def tet_cells_clearly_valid(points, cells, rtol, used):
    """How many tetrahedra are *not* clearly valid (ids out of range or repeated, or a volume not clearly
    above the degeneracy bound); marks ``used[node] = 1`` for the others' nodes (:func:`own_cells`)."""
    return own_cells(points, cells, cells.dtype, True, rtol, used)[1]


@njit
def _cell_hash(cells, c):
    """A hash of cell ``c``'s node set, the same in any node order (a sum of mixed ids)."""
    h = np.uint64(0)
    for k in range(cells.shape[1]):
        x = np.uint64(cells[c, k]) * np.uint64(0x9E3779B97F4A7C15)
        x ^= x >> np.uint64(29)
        x *= np.uint64(0xBF58476D1CE4E5B9)
        x ^= x >> np.uint64(32)
        h += x
    return h


@njit
def _same_nodes(cells, a, b):
    for i in range(cells.shape[1]):
        found = False
        for j in range(cells.shape[1]):
            if cells[a, i] == cells[b, j]:
                found = True
                break
        if not found:
            return False
    return True


@njit
def _smallest_node(cells, c):
    v = cells[c, 0]
    for k in range(1, cells.shape[1]):
        v = min(v, cells[c, k])
    return v


@njit(parallel=True)
def _count_smallest_nodes(cells, sb, counts):
    """``counts[t, k]``: the cells of slab ``t`` of ``sb`` whose smallest node is ``k``."""
    for t in prange(sb.shape[0] - 1):
        for c in range(sb[t], sb[t + 1]):
            counts[t, _smallest_node(cells, c)] += 1


#: the high 32 bits of a packed group entry (:func:`_group_by_smallest_node`): the node-set hash
_HASH_BITS = np.uint64(0xFFFFFFFF00000000)


@njit(parallel=True)
def _group_by_smallest_node(cells, sb, counts, keyed, hash_mask):
    """The cells grouped by smallest node, from their counts per slab (:func:`_count_smallest_nodes`), into
    ``keyed`` (uint64): each cell's id in the low bits, the high 32 bits of its node-set hash above them
    (``hash_mask``: :data:`_HASH_BITS`, or 0 where the ids need all 64 bits); returns the offsets
    ``(n_nodes + 1,)``. A stable counting sort as :func:`_stable_csr` (slabs of cells, one per thread), the
    hash computed while the rows are read in order and written with the id (one random write a cell), so that
    comparing a group reads ``keyed`` in order and a row only where two hashes agree. Also returns whether
    the counts were not those of ``cells`` (then ``keyed`` is incomplete)."""
    offsets = _slab_offsets(counts)
    wrong = np.zeros(counts.shape[0], np.bool_)
    for t in prange(counts.shape[0]):
        for c in range(sb[t], sb[t + 1]):
            k = _smallest_node(cells, c)
            p = counts[t, k]
            if p >= offsets[k + 1]:  # counts that are not these cells' (guarded: never a write out of place)
                wrong[t] = True
                continue
            keyed[p] = (_cell_hash(cells, c) & hash_mask) | np.uint64(c)
            counts[t, k] = p + 1
    return offsets, wrong.any()


@njit
def _repeats_in_group(cells, keyed, hash_mask, lo, hi):
    """How many cells of the group ``keyed[lo:hi]`` (ascending ids) repeat the node set of an earlier one.
    Equal hashes are compared node by node; a group of more than 64 is sorted by hash first, so that a node
    shared by very many cells costs ``k log k``, not ``k**2``."""
    ids = ~hash_mask
    count = 0
    if hi - lo <= 64:
        for i in range(lo + 1, hi):
            h = keyed[i] & hash_mask
            for j in range(lo, i):
                if keyed[j] & hash_mask == h and _same_nodes(cells, keyed[j] & ids, keyed[i] & ids):
                    count += 1
                    break
        return count
    by_hash = np.argsort(keyed[lo:hi] & hash_mask, kind="mergesort") + lo  # stable: equal hashes by cell id
    a = 0
    while a < by_hash.shape[0]:
        b = a + 1
        while b < by_hash.shape[0] and keyed[by_hash[b]] & hash_mask == keyed[by_hash[a]] & hash_mask:
            b += 1
        for i in range(a + 1, b):
            for j in range(a, i):
                if _same_nodes(cells, keyed[by_hash[j]] & ids, keyed[by_hash[i]] & ids):
                    count += 1
                    break
        a = b
    return count


@njit(parallel=True)
def _count_repeats(cells, offsets, keyed, hash_mask, n_chunks):
    """The number of cells that repeat the node set of an earlier cell, from the groups of
    :func:`_group_by_smallest_node`; independent of ``n_chunks``."""
    bounds = _chunk_bounds(offsets.shape[0] - 1, n_chunks)
    counts = np.zeros(n_chunks, np.int64)
    for t in prange(n_chunks):
        n = 0
        for b in range(bounds[t], bounds[t + 1]):
            if offsets[b + 1] - offsets[b] > 1:
                n += _repeats_in_group(cells, keyed, hash_mask, offsets[b], offsets[b + 1])
        counts[t] = n
    return counts.sum()


@njit
def _repeat_examples(cells, offsets, keyed, hash_mask, out):
    """The first ``out.shape[0]`` pairs ``(earliest, later)`` of cells with the same node set, in the order
    of the later cell (the serial pass that names them, once :func:`_count_repeats` found some)."""
    ids = ~hash_mask
    n = 0
    for c in range(cells.shape[0]):
        if n == out.shape[0]:
            break
        b = _smallest_node(cells, c)
        h = _cell_hash(cells, c) & hash_mask
        for p in range(offsets[b], offsets[b + 1]):
            e = keyed[p] & ids
            if e >= c:
                break
            if keyed[p] & hash_mask == h and _same_nodes(cells, e, c):
                out[n, 0] = e
                out[n, 1] = c
                n += 1
                break
    return n


def find_duplicate_cells(cells, limit=5, n_nodes=None, counted=None):
    """``(count, pairs)``: how many cells repeat the node set of an earlier cell, and up to ``limit``
    ``(earlier, later)`` pairs of them (``earlier`` the first cell with that node set).

    The node ids must be in range (``0..n_nodes-1``; ``n_nodes`` defaults to
    the largest id + 1) and distinct in each cell (checked before). A repeated
    cell has the same smallest node as its original, so the cells are grouped
    by smallest node (a parallel counting sort, which reads the rows in order,
    where a hash table over all cells reads at random) and compared inside
    each group; the pairs are named in a second, serial pass only when there
    are any. ``counted``: the slabs and counts of that sort, from :func:`own_cells` (else counted here).
    """
    m = cells.shape[0]
    if n_nodes is None:
        n_nodes = int(cells.max()) + 1 if m else 0
    keyed = empty(m, np.uint64)
    mask = _HASH_BITS if m <= 2**32 else np.uint64(0)  # ids of 33 bits and more: every pair compared
    if counted is None:
        counted = _slabs(m, numba.get_num_threads(), n_nodes)
        _count_smallest_nodes(cells, *counted)
    offsets, wrong = _group_by_smallest_node(cells, *counted, keyed, mask)
    if wrong:
        raise ValueError("find_duplicate_cells: the counts by smallest node given are not those of these cells")
    count = int(_count_repeats(cells, offsets, keyed, mask, 4 * numba.get_num_threads()))
    out = np.zeros((limit, 2), np.int64)
    n = _repeat_examples(cells, offsets, keyed, mask, out) if count else 0
    return count, out[:n]


@njit(parallel=True)
def hex_jacobians(points, cells, corners):
    """Corner Jacobian determinants ``(M, 8)``, volume and longest edge of each hexahedron."""
    m = cells.shape[0]
    jac = np.empty((m, 8))
    vol = np.empty(m)
    longest = np.empty(m)
    for c in prange(m):
        # scalars throughout (row slices such as points[i] - p0 would allocate an array each, in the loop)
        for i in range(8):
            i0 = cells[c, corners[i, 0]]
            i1 = cells[c, corners[i, 1]]
            i2 = cells[c, corners[i, 2]]
            i3 = cells[c, corners[i, 3]]
            a0 = points[i1, 0] - points[i0, 0]
            a1 = points[i1, 1] - points[i0, 1]
            a2 = points[i1, 2] - points[i0, 2]
            b0 = points[i2, 0] - points[i0, 0]
            b1 = points[i2, 1] - points[i0, 1]
            b2 = points[i2, 2] - points[i0, 2]
            d0 = points[i3, 0] - points[i0, 0]
            d1 = points[i3, 1] - points[i0, 1]
            d2 = points[i3, 2] - points[i0, 2]
            jac[c, i] = (a0 * (b1 * d2 - b2 * d1)
                         - a1 * (b0 * d2 - b2 * d0)
                         + a2 * (b0 * d1 - b1 * d0))
        # volume by the divergence theorem over the six faces split at their centroid
        v = 0.0
        for f in range(6):
            q = HEX_FACE_NODES[f]
            cx = 0.0
            cy = 0.0
            cz = 0.0
            for j in range(4):
                cx += points[cells[c, q[j]], 0] * 0.25
                cy += points[cells[c, q[j]], 1] * 0.25
                cz += points[cells[c, q[j]], 2] * 0.25
            o = cells[c, 0]
            for j in range(4):
                ja = cells[c, q[j]]
                jb = cells[c, q[(j + 1) % 4]]
                pa0 = points[ja, 0] - points[o, 0]
                pa1 = points[ja, 1] - points[o, 1]
                pa2 = points[ja, 2] - points[o, 2]
                pb0 = points[jb, 0] - points[o, 0]
                pb1 = points[jb, 1] - points[o, 1]
                pb2 = points[jb, 2] - points[o, 2]
                px = cx - points[o, 0]
                py = cy - points[o, 1]
                pz = cz - points[o, 2]
                v += (px * (pa1 * pb2 - pa2 * pb1)
                      - py * (pa0 * pb2 - pa2 * pb0)
                      + pz * (pa0 * pb1 - pa1 * pb0))
        vol[c] = v / 6.0
        e = 0.0
        for i in range(8):
            for j in range(1, 4):
                s = 0.0
                for x in range(3):
                    t = points[cells[c, corners[i, 0]], x] - points[cells[c, corners[i, j]], x]
                    s += t * t
                if s > e:
                    e = s
        longest[c] = np.sqrt(e)
    return jac, vol, longest


@njit
def union(parent, a, b):
    """Join the sets of ``a`` and ``b`` (find with path halving; the smaller root wins). False if already one."""
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    while parent[b] != b:
        parent[b] = parent[parent[b]]
        b = parent[b]
    if a == b:
        return False
    if a < b:
        parent[b] = a
    else:
        parent[a] = b
    return True


@njit
def find_all(parent):
    """The root of every item of a union-find forest (compressing the paths)."""
    out = np.empty(parent.shape[0], np.int64)
    for i in range(parent.shape[0]):
        a = i
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        out[i] = a
    return out


@njit
def union_find_rows(row_ids, n_items, row_owner):
    """Connected components of items linked through shared row ids.

    ``row_owner[r]`` is the item of row ``r``; items whose rows carry the
    same id are joined. Returns labels ``0..n_comp-1`` numbered by first item.
    """
    parent = np.arange(n_items)
    n_ids = 0
    for r in range(row_ids.shape[0]):
        if row_ids[r] + 1 > n_ids:
            n_ids = row_ids[r] + 1
    first_owner = np.full(n_ids, -1, np.int64)
    for r in range(row_ids.shape[0]):
        u = row_ids[r]
        a = row_owner[r]
        if first_owner[u] < 0:
            first_owner[u] = a
            continue
        union(parent, a, first_owner[u])
    roots = find_all(parent)
    labels = np.full(n_items, -1, np.int64)
    n_comp = 0
    for i in range(n_items):
        a = roots[i]
        if labels[a] < 0:
            labels[a] = n_comp
            n_comp += 1
        labels[i] = labels[a]
    return labels, n_comp


@njit
def _label_components(neighbors, labels, stack):
    """Fill ``labels`` (M,), all -1 on entry, with the connected part of each cell through face
    neighbours (depth first, ``stack`` (M,) scratch of the same dtype); returns the number of parts."""
    m, f = neighbors.shape
    n_comp = 0
    for s in range(m):
        if labels[s] >= 0:
            continue
        labels[s] = n_comp
        stack[0] = s
        top = 1
        while top > 0:
            top -= 1
            c = stack[top]
            for i in range(f):
                d = neighbors[c, i]
                if d >= 0 and labels[d] < 0:
                    labels[d] = n_comp
                    stack[top] = d
                    top += 1
        n_comp += 1
    return n_comp


def cell_components(neighbors, dtype=np.int64):
    """Connected components of cells through face neighbours: ``(labels (M,) dtype, n)``."""
    m = neighbors.shape[0]
    labels = empty(m, dtype)
    labels.fill(-1)
    n_comp = _label_components(neighbors, labels, empty(m, dtype))
    return labels, n_comp


# ---------------------------------------------------------------- point location

@njit
def build_bins(points, cells, lo, inv_h, dims):
    """Register each cell in every bin its bounding box overlaps (CSR)."""
    m, k = cells.shape
    nb = dims[0] * dims[1] * dims[2]
    counts = np.zeros(nb + 1, np.int64)
    ranges = np.empty((m, 6), np.int64)
    for c in range(m):
        for x in range(3):
            mn = np.inf
            mx = -np.inf
            for j in range(k):
                v = points[cells[c, j], x]
                mn = min(mn, v)
                mx = max(mx, v)
            i0 = int((mn - lo[x]) * inv_h[x])
            i1 = int((mx - lo[x]) * inv_h[x])
            ranges[c, 2 * x] = min(max(i0, 0), dims[x] - 1)
            ranges[c, 2 * x + 1] = min(max(i1, 0), dims[x] - 1)
        for a in range(ranges[c, 0], ranges[c, 1] + 1):
            for b in range(ranges[c, 2], ranges[c, 3] + 1):
                for d in range(ranges[c, 4], ranges[c, 5] + 1):
                    counts[(a * dims[1] + b) * dims[2] + d + 1] += 1
    for i in range(nb):
        counts[i + 1] += counts[i]
    fill = counts[:-1].copy()
    items = np.empty(counts[nb], np.int64)
    for c in range(m):
        for a in range(ranges[c, 0], ranges[c, 1] + 1):
            for b in range(ranges[c, 2], ranges[c, 3] + 1):
                for d in range(ranges[c, 4], ranges[c, 5] + 1):
                    j = (a * dims[1] + b) * dims[2] + d
                    items[fill[j]] = c
                    fill[j] += 1
    return counts, items


@njit
def _tet_weights(points, cells, c, q, w):
    p0 = points[cells[c, 0]]
    a = points[cells[c, 1]] - p0
    b = points[cells[c, 2]] - p0
    d = points[cells[c, 3]] - p0
    r = q - p0
    det = (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0])
           + a[2] * (b[0] * d[1] - b[1] * d[0]))
    if det == 0.0:
        return False
    w1 = (r[0] * (b[1] * d[2] - b[2] * d[1]) - r[1] * (b[0] * d[2] - b[2] * d[0])
          + r[2] * (b[0] * d[1] - b[1] * d[0])) / det
    w2 = (a[0] * (r[1] * d[2] - r[2] * d[1]) - a[1] * (r[0] * d[2] - r[2] * d[0])
          + a[2] * (r[0] * d[1] - r[1] * d[0])) / det
    w3 = (a[0] * (b[1] * r[2] - b[2] * r[1]) - a[1] * (b[0] * r[2] - b[2] * r[0])
          + a[2] * (b[0] * r[1] - b[1] * r[0])) / det
    w[0] = 1.0 - w1 - w2 - w3
    w[1] = w1
    w[2] = w2
    w[3] = w3
    tol = -1e-10
    return w[0] >= tol and w1 >= tol and w2 >= tol and w3 >= tol


@njit
def _hex_shape(r, s, t, n):
    n[0] = (1 - r) * (1 - s) * (1 - t)
    n[1] = r * (1 - s) * (1 - t)
    n[2] = r * s * (1 - t)
    n[3] = (1 - r) * s * (1 - t)
    n[4] = (1 - r) * (1 - s) * t
    n[5] = r * (1 - s) * t
    n[6] = r * s * t
    n[7] = (1 - r) * s * t


@njit
def _hex_weights(points, cells, c, q, w):
    """Trilinear weights of ``q`` in hexahedron ``c`` by Newton's method on (r, s, t)."""
    r = 0.5
    s = 0.5
    t = 0.5
    jm = np.empty((3, 3))
    for _ in range(30):
        _hex_shape(r, s, t, w)
        fx = -q[0]
        fy = -q[1]
        fz = -q[2]
        for j in range(8):
            p = points[cells[c, j]]
            fx += w[j] * p[0]
            fy += w[j] * p[1]
            fz += w[j] * p[2]
        # derivatives of the shape functions
        dr = np.array([-(1 - s) * (1 - t), (1 - s) * (1 - t), s * (1 - t), -s * (1 - t),
                       -(1 - s) * t, (1 - s) * t, s * t, -s * t])
        ds = np.array([-(1 - r) * (1 - t), -r * (1 - t), r * (1 - t), (1 - r) * (1 - t),
                       -(1 - r) * t, -r * t, r * t, (1 - r) * t])
        dt = np.array([-(1 - r) * (1 - s), -r * (1 - s), -r * s, -(1 - r) * s,
                       (1 - r) * (1 - s), r * (1 - s), r * s, (1 - r) * s])
        for x in range(3):
            jm[x, 0] = 0.0
            jm[x, 1] = 0.0
            jm[x, 2] = 0.0
            for j in range(8):
                p = points[cells[c, j], x]
                jm[x, 0] += dr[j] * p
                jm[x, 1] += ds[j] * p
                jm[x, 2] += dt[j] * p
        det = (jm[0, 0] * (jm[1, 1] * jm[2, 2] - jm[1, 2] * jm[2, 1])
               - jm[0, 1] * (jm[1, 0] * jm[2, 2] - jm[1, 2] * jm[2, 0])
               + jm[0, 2] * (jm[1, 0] * jm[2, 1] - jm[1, 1] * jm[2, 0]))
        if det == 0.0:
            return False
        # Cramer's rule for J d = f
        d0 = (fx * (jm[1, 1] * jm[2, 2] - jm[1, 2] * jm[2, 1])
              - jm[0, 1] * (fy * jm[2, 2] - jm[1, 2] * fz)
              + jm[0, 2] * (fy * jm[2, 1] - jm[1, 1] * fz)) / det
        d1 = (jm[0, 0] * (fy * jm[2, 2] - jm[1, 2] * fz)
              - fx * (jm[1, 0] * jm[2, 2] - jm[1, 2] * jm[2, 0])
              + jm[0, 2] * (jm[1, 0] * fz - fy * jm[2, 0])) / det
        d2 = (jm[0, 0] * (jm[1, 1] * fz - fy * jm[2, 1])
              - jm[0, 1] * (jm[1, 0] * fz - fy * jm[2, 0])
              + fx * (jm[1, 0] * jm[2, 1] - jm[1, 1] * jm[2, 0])) / det
        r -= d0
        s -= d1
        t -= d2
        if abs(d0) + abs(d1) + abs(d2) < 1e-13:
            break
        if abs(r) > 10 or abs(s) > 10 or abs(t) > 10:
            return False
    tol = 1e-9
    if not (-tol <= r <= 1 + tol and -tol <= s <= 1 + tol and -tol <= t <= 1 + tol):
        return False
    # Newton may wander far from a point outside the cell and stop inside by
    # chance: accept only a converged map
    _hex_shape(r, s, t, w)
    size = 0.0
    res = 0.0
    for x in range(3):
        v = -q[x]
        for j in range(8):
            v += w[j] * points[cells[c, j], x]
            size = max(size, abs(points[cells[c, j], x] - points[cells[c, 0], x]))
        res += v * v
    return np.sqrt(res) <= 1e-9 * size


@njit(parallel=True)
def locate_and_interpolate(points, cells, scalars, counts, items, lo, inv_h, dims, queries):
    """Value of the linear (tetra) or trilinear (hexa) interpolant at each query, NaN outside."""
    nq = queries.shape[0]
    k = cells.shape[1]
    out = np.full(nq, np.nan)
    where = np.full(nq, -1, np.int64)
    for i in prange(nq):
        q = queries[i]
        ix = np.empty(3, np.int64)
        inside_grid = True
        for x in range(3):
            v = int(np.floor((q[x] - lo[x]) * inv_h[x]))
            if v < 0 or v >= dims[x]:
                # on the far face of the box the point still belongs to the last bin
                if v == dims[x] and q[x] - lo[x] <= dims[x] / inv_h[x] * (1 + 1e-12):
                    v = dims[x] - 1
                else:
                    inside_grid = False
            ix[x] = v
        if not inside_grid:
            continue
        b = (ix[0] * dims[1] + ix[1]) * dims[2] + ix[2]
        w = np.empty(8)
        for p in range(counts[b], counts[b + 1]):
            c = items[p]
            if k == 4:
                ok = _tet_weights(points, cells, c, q, w)
            else:
                ok = _hex_weights(points, cells, c, q, w)
            if ok:
                s = 0.0
                for j in range(k):
                    s += w[j] * scalars[cells[c, j]]
                out[i] = s
                where[i] = c
                break
    return out, where


@njit
def _spread_bits(x):
    """Insert two zero bits after each of the 21 low bits of ``x`` (Morton interleave)."""
    x &= 0x1FFFFF
    x = (x | (x << 32)) & 0x1F00000000FFFF
    x = (x | (x << 16)) & 0x1F0000FF0000FF
    x = (x | (x << 8)) & 0x100F00F00F00F00F
    x = (x | (x << 4)) & 0x10C30C30C30C30C3
    x = (x | (x << 2)) & 0x1249249249249249
    return x


@njit(parallel=True)
def morton_codes(xyz, lo, scale):
    """63-bit Morton (Z-order) code of each point, 21 bits per axis: ``(n,)`` int64."""
    n = xyz.shape[0]
    out = np.empty(n, np.int64)
    for i in prange(n):
        code = 0
        for a in range(3):
            q = np.int64((xyz[i, a] - lo[a]) * scale)
            q = min(max(q, 0), 0x1FFFFF)
            code |= _spread_bits(q) << a
        out[i] = code
    return out


@njit(parallel=True)
def cell_centroids(points, cells):
    m, k = cells.shape
    out = np.zeros((m, 3))
    for c in prange(m):
        for i in range(k):
            for a in range(3):
                out[c, a] += points[cells[c, i], a]
        for a in range(3):
            out[c, a] /= k
    return out


def cell_records(cells, face_nb, cell_edges):
    """(M, W) one row per cell: its nodes, its face neighbours, its edge ids, padded to 16 or 32 entries.

    The propagation reads everything it needs about a cell from one or two
    cache lines instead of three arrays (data 4, twenty surfaces grown from
    the extrema graph's seeds: 0.187 -> 0.146 s; from every intersected cell
    in id order: 0.117 -> 0.112 s). int32 while the ids fit, else int64.
    """
    m, nn = cells.shape
    width = nn + face_nb.shape[1] + cell_edges.shape[1]
    width = 16 if width <= 16 else 32
    big = max(int(cells.max(initial=0)), int(cell_edges.max(initial=0)), m) >= np.iinfo(np.int32).max
    rec = np.full((m, width), -1, np.int64 if big else np.int32)
    rec[:, :nn] = cells
    rec[:, nn:nn + face_nb.shape[1]] = face_nb
    rec[:, nn + face_nb.shape[1]:nn + face_nb.shape[1] + cell_edges.shape[1]] = cell_edges
    return rec


# ---------------------------------------------------------------- topology from node -> cells
#
# The tables below are built bucket by bucket, one bucket per node: the faces (edges) whose
# smallest node is ``a`` are found among the cells around ``a`` (the node -> cells lists)
# and matched there by the rest of their nodes, in a small open-addressing table (a bucket
# holds ~23 faces and ~35 edge entries of ~7 distinct edges: hashing them is cheaper than
# sorting them, and only the distinct far nodes of the edges are sorted, to number the edges
# in order). The table is stamped with ``a + 1`` per bucket, so it is never cleared. Buckets
# are independent, so the nodes are split into chunks that run in parallel, each with its own
# scratch sized for its largest bucket; every output entry is written by exactly one bucket
# (a face's two sides: by the bucket that meets it the second time), so the result does not
# depend on the number of threads.

_N_CHUNKS = 256  # node ranges handed to the threads (more than threads: a rough balance)


@njit
def _chunk_bounds(n, n_chunks):
    bounds = np.empty(n_chunks + 1, np.int64)
    for i in range(n_chunks + 1):
        bounds[i] = (n * i) // n_chunks
    return bounds


@njit
def _bucket_table_size(nc_off, lo, hi, per_cell):
    """``(cap, size)`` for the node buckets ``lo:hi``: ``cap`` entries at most in one bucket
    (its cells times ``per_cell``), ``size`` the power of two >= 16 and >= 2 cap of an
    open-addressing table that holds them at load factor <= 1/2."""
    big = 0
    for a in range(lo, hi):
        big = max(big, nc_off[a + 1] - nc_off[a])
    cap = big * per_cell
    size = 16
    while size < 2 * cap:
        size *= 2
    return cap, size


_SERIAL_BELOW = 1 << 17  # fewer entries than this: one thread (a parallel launch costs more than the work)


def stable_csr(keys, n_keys):
    """Group ``arange(len(keys))`` by ``keys``, in parallel: ``(offsets (n_keys+1,) int64, order int64)``.

    ``order[offsets[k]:offsets[k+1]]`` are the positions holding key ``k``
    in increasing position: a stable counting sort whose result does not
    depend on the number of threads. The positions are cut into a few
    slabs (at most 8, one per thread), each counted and scattered by one
    thread; slab t of key k goes after every key < k and after slabs < t.
    """
    if keys.shape[0] < _SERIAL_BELOW:
        return _csr_serial(keys, n_keys)
    order = empty(keys.shape[0], np.int64)
    return _stable_csr(keys, n_keys, numba.get_num_threads(), order, 1), order


def node_cells_csr(cells, n_nodes):
    """The cells using each node: ``(offsets (N+1,) int64, cells int32|int64)``, ascending cell ids per node.

    :func:`stable_csr` of the flattened cells, storing the cell id (int32
    while the cell ids fit) instead of the position.
    """
    k = cells.shape[1]
    out = empty(cells.size, np.int32 if cells.shape[0] < np.iinfo(np.int32).max else np.int64)
    flat = cells.reshape(-1)
    if flat.shape[0] < _SERIAL_BELOW:
        offsets, order = _csr_serial(flat, n_nodes)
        out[:] = order // k
        return offsets, out
    return _stable_csr(flat, n_nodes, numba.get_num_threads(), out, k), out


@njit
def _slabs(n, n_threads, n_keys):
    """A counting sort's slabs of ``n`` positions (at most 8, one per thread, none under 65,536 positions):
    their bounds and their zeroed counts ``(n_slabs, n_keys)``."""
    n_slabs = max(1, min(n_threads, 8, n // 65536))
    return _chunk_bounds(n, n_slabs), np.zeros((n_slabs, n_keys), np.int64)


@njit
def _slab_offsets(counts):
    """Each key's offset, its slabs' counts ``(n_slabs, n_keys)`` turned into each slab's first position in
    place (slab t of key k after every key < k and after slabs < t); returns the offsets ``(n_keys + 1,)``."""
    n_slabs, n_keys = counts.shape
    offsets = np.empty(n_keys + 1, np.int64)
    s = np.int64(0)
    for k in range(n_keys):
        offsets[k] = s
        for u in range(n_slabs):
            c = counts[u, k]
            counts[u, k] = s
            s += c
    offsets[n_keys] = s
    return offsets


@njit(parallel=True)
def _stable_csr(keys, n_keys, n_threads, out, divide):
    """Fill ``out`` with ``position // divide`` grouped by key (stable); return the offsets."""
    sb, counts = _slabs(keys.shape[0], n_threads, n_keys)
    n_slabs = counts.shape[0]
    for t in prange(n_slabs):
        for i in range(sb[t], sb[t + 1]):
            counts[t, keys[i]] += 1
    offsets = _slab_offsets(counts)
    for t in prange(n_slabs):
        for i in range(sb[t], sb[t + 1]):
            k = keys[i]
            out[counts[t, k]] = i // divide
            counts[t, k] += 1
    return offsets


def local_incidence(local, k):
    """For each local node ``i`` of a cell with ``k`` nodes, the rows of ``local`` (faces or edges)
    that contain it: ``(rows (k, R) int64, -1 padded, masks (len(local),) int64 node bitmask of each row)``."""
    masks = np.array([sum(1 << int(j) for j in row) for row in local], np.int64)
    per = [[r for r in range(len(local)) if i in set(int(j) for j in local[r])] for i in range(k)]
    width = max(len(p) for p in per)
    rows = np.full((k, width), -1, np.int64)
    for i, p in enumerate(per):
        rows[i, :len(p)] = p
    return rows, masks


@njit(parallel=True)
def face_neighbors_by_node(cells, local_faces, node_faces, face_masks, nc_off, nc, out):
    """Fill ``out (M, F)`` (preset to -1) with the cell across each local face; the faces are matched
    in the bucket of their smallest node.

    ``node_faces``, ``face_masks``: :func:`local_incidence` of ``local_faces``.
    Returns a slot ``c * F + f`` of a face shared by more than two cells (in
    the first bucket that has one, its smallest such face, at its first
    cell), or -1; ``out`` is then incomplete.
    """
    m, k = cells.shape
    nf, w = local_faces.shape
    n_nodes = nc_off.shape[0] - 1
    n_chunks = min(_N_CHUNKS, max(n_nodes, 1))
    bounds = _chunk_bounds(n_nodes, n_chunks)
    bad = np.full(n_chunks, -1, np.int64)
    for ch in prange(n_chunks):
        # the bucket's faces matched by open addressing on their other nodes, in a table stamped with
        # a + 1 (never cleared): each face is found once more, by its neighbour, with no sort
        cap, size = _bucket_table_size(nc_off, bounds[ch], bounds[ch + 1], node_faces.shape[1])
        mask = size - 1
        t_k1 = np.empty(size, np.int64)
        t_k2 = np.empty(size, np.int64)
        t_stamp = np.zeros(size, np.int64)
        t_cell = np.empty(size, np.int64)
        t_face = np.empty(size, np.int64)
        t_count = np.empty(size, np.int64)
        other = np.empty(4, np.int64)
        for a in range(bounds[ch], bounds[ch + 1]):
            stamp = np.int64(a + 1)
            bad_k1 = np.int64(-1)
            bad_k2 = np.int64(-1)
            bad_slot = np.int64(-1)
            for p in range(nc_off[a], nc_off[a + 1]):
                c = nc[p]
                gt = 0
                ia = 0
                for j in range(k):
                    v = cells[c, j]
                    gt |= (v > a) << j
                    ia += j * (v == a)
                for t in range(node_faces.shape[1]):
                    f = node_faces[ia, t]
                    if f < 0:
                        break
                    rest = face_masks[f] & ~(1 << ia)
                    if rest & gt != rest:
                        continue  # a node of this face is smaller than a: not a's bucket
                    no = 0
                    for j in range(w):
                        v = cells[c, local_faces[f, j]]
                        if v != a:
                            other[no] = v
                            no += 1
                    k2 = np.int64(0)
                    if no == 2:
                        k1 = min(other[0], other[1]) * n_nodes + max(other[0], other[1])
                    else:  # a quadrilateral: its other three nodes, ascending
                        for i in range(1, no):
                            v = other[i]
                            j = i - 1
                            while j >= 0 and other[j] > v:
                                other[j + 1] = other[j]
                                j -= 1
                            other[j + 1] = v
                        k1 = other[0] * n_nodes + other[1]
                        k2 = other[2]
                    x = (k1 ^ (k1 >> 21) ^ (k2 << 5)) & 0x7FFFFFFF
                    h = (x * 2654435761) & mask
                    while t_stamp[h] == stamp and (t_k1[h] != k1 or t_k2[h] != k2):
                        h = (h + 1) & mask
                    if t_stamp[h] != stamp:
                        t_stamp[h] = stamp
                        t_k1[h] = k1
                        t_k2[h] = k2
                        t_cell[h] = c  # cell and face apart: no division by the runtime face count
                        t_face[h] = f
                        t_count[h] = 1
                        continue
                    t_count[h] += 1
                    c0 = t_cell[h]
                    if t_count[h] == 2:
                        out[c0, t_face[h]] = c
                        out[c, f] = c0
                    elif bad_slot < 0 or k1 < bad_k1 or (k1 == bad_k1 and k2 < bad_k2):
                        # a face of three or more cells: named by its first cell, the smallest such face first
                        bad_k1 = k1
                        bad_k2 = k2
                        bad_slot = c0 * nf + t_face[h]
            if bad_slot >= 0 and bad[ch] < 0:
                bad[ch] = bad_slot
    for ch in range(n_chunks):
        if bad[ch] >= 0:
            return bad[ch]
    return -1


@njit
def _sort_packed(keys, n):
    """Sort ``keys[:n]`` ascending (insertion sort; numpy's sort first when long)."""
    if n > 48:
        keys[:n] = np.sort(keys[:n])
        return
    for i in range(1, n):
        v = keys[i]
        j = i - 1
        while j >= 0 and keys[j] > v:
            keys[j + 1] = keys[j]
            j -= 1
        keys[j + 1] = v


@njit(parallel=True)
def edges_by_node(cells, local_edges, node_edges, nc_off, nc, cell_edges):
    """Number the distinct edges by smallest node, then largest; fill ``cell_edges (M, L)``.

    ``node_edges``: :func:`local_incidence` of ``local_edges``. Each bucket
    collects ``other_node << 32 | slot`` (slots ``c << 4 | e``, below 2**32: fewer than 2**28 cells)
    and numbers its edges by sorting only the distinct other nodes, found
    by hashing (a bucket of ~35 entries has ~7: on 2M, 0.56 -> 0.40 s of
    one core against an insertion sort of the entries).
    Returns ``edges (E, 2)`` in the dtype of ``cells``, ``a < b``, in that order (the order of
    sorted node-pair codes ``a * N + b``).
    """
    m, k = cells.shape
    ne = local_edges.shape[0]
    n_nodes = nc_off.shape[0] - 1
    n_chunks = min(_N_CHUNKS, max(n_nodes, 1))
    bounds = _chunk_bounds(n_nodes, n_chunks)
    count = np.zeros(n_nodes + 1, np.int64)
    low = np.int64(0xFFFFFFFF)
    for ch in prange(n_chunks):
        # the bucket's distinct far nodes b, by open addressing in a table stamped with a + 1 (never cleared)
        cap, size = _bucket_table_size(nc_off, bounds[ch], bounds[ch + 1], node_edges.shape[1])
        keys = np.empty(cap, np.int64)
        mask = size - 1
        t_node = np.empty(size, np.int64)
        t_stamp = np.zeros(size, np.int64)
        t_rank = np.empty(size, np.int64)
        where = np.empty(cap, np.int64)
        far = np.empty(cap, np.int64)
        for a in range(bounds[ch], bounds[ch + 1]):
            n = 0
            for p in range(nc_off[a], nc_off[a + 1]):
                c = nc[p]
                ia = 0
                for j in range(k):
                    ia += j * (cells[c, j] == a)
                for t in range(node_edges.shape[1]):
                    e = node_edges[ia, t]
                    if e < 0:
                        break
                    b = cells[c, local_edges[e, 0]] + cells[c, local_edges[e, 1]] - a
                    if b > a:
                        keys[n] = (b << 32) | (c << 4) | e  # shifts, not a division by ne, to unpack
                        n += 1
            # the edges (a, b) numbered by b: only the few distinct b are sorted, not the n entries
            stamp = np.int64(a + 1)
            d = 0
            for i in range(n):
                b = keys[i] >> 32
                h = (b * 2654435761) & mask
                while t_stamp[h] == stamp and t_node[h] != b:
                    h = (h + 1) & mask
                if t_stamp[h] != stamp:
                    t_stamp[h] = stamp
                    t_node[h] = b
                    far[d] = b
                    d += 1
                where[i] = h
            _sort_packed(far, d)
            for r in range(d):
                b = far[r]
                h = (b * 2654435761) & mask
                while t_stamp[h] != stamp or t_node[h] != b:
                    h = (h + 1) & mask
                t_rank[h] = r
            for i in range(n):
                s = keys[i] & low
                cell_edges[s >> 4, s & 15] = t_rank[where[i]]
            count[a + 1] = d
    for a in range(n_nodes):
        count[a + 1] += count[a]
    n_edges = count[n_nodes]
    edges = np.empty((n_edges, 2), cells.dtype)
    for c in prange(m):
        for e in range(ne):
            u = cells[c, local_edges[e, 0]]
            v = cells[c, local_edges[e, 1]]
            a = min(u, v)
            i = cell_edges[c, e] + count[a]
            cell_edges[c, e] = i
            edges[i, 0] = a  # every cell around the edge writes the same two values
            edges[i, 1] = max(u, v)
    return edges
