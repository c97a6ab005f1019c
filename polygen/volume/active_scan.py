"""The active-cell scan: the crossed cells, stored in span-space order, scanned in parallel (ours, beyond the thesis).

Every construction of the thesis finds the crossed cells by a search
(chapter 5's active-cell searches, chapter 6's extrema graph, chapter 7's
thinning) and then walks from cell to neighbouring cell. The walk is a
chain of dependent loads into arrays much larger than the caches (record,
then the cells around an edge, then their records), and on today's
processors it, not the cell tests, is what a large surface costs: about
160 ns of one core per crossed cell on 2M for the cell-edge-centred
construction.

This method walks nothing. It keeps the cells in **span-space order**
(Livnat, Shen & Johnson 1996): in rows of their minimum value, and inside a
row by their maximum, largest first. The cells a value ``C`` crosses
(minimum ``< C <=`` maximum) are then a prefix of every row whose lower
bound is below ``C`` -- one binary search per row -- and only the rows'
last cells are tested for nothing (at most one row's worth: the row that
holds ``C``). The table holds, per cell and in that order, its nodes and
its edges' ids, so the scan streams through memory. On a large volume
(:attr:`ActiveScan.BLOCKS_FROM`) the order is kept per block of
consecutive cells, so that a query's reads of node values, positions and
edge vertices stay near each other (one row per block is then tested for
nothing at most).

The three passes:

1. **count** (parallel over chunks of the active cells): each cell's case;
   per chunk the triangles and the vertices it will make;
2. **vertices**: every crossed edge has one *owner*, its first cell (fixed
   when the table is built; the value does not change it, and every cell
   of a crossed edge is crossed), and only the owner makes the edge's
   vertex -- its id (numbered by chunk) into ``ev[edge]``, its position
   (5.2) -- with no search, no hash and no atomic operation. A vertex
   exactly on a node (rare) is numbered after them, serially;
3. **triangles**: each cell reads its corners from ``ev`` and, for the mean
   normals, adds its triangles' normals into one array of sums shared by the
   threads: a thread writes only the rows of the vertices its own chunks made,
   and a triangle with a corner made by another thread's chunks goes on a side
   list, whose normals are added afterwards in a fixed order. Each read of a
   corner's vertex id at its edge id (``ev[edge]``) is the read the array
   propagation counts as a vertex look-up, and is counted as one
   (``vertex_lookups``, ``stats["lookups"]``): one per triangle corner on an
   edge, plus a second for the corners of a triangle that went to a side
   list after its ids were read (several threads only).

On a volume in blocks, passes 2 and 3 go **block by block**: each thread makes
a block's vertices, then its triangles, while the block's rows of ``ev``, the
positions and the normal sums are still in its core's cache. A triangle may
then need a vertex not made yet -- one whose owner is in a block another thread
holds, or in the part of a block cut between two threads -- so the table's
owner column also says which of a cell's edges are owned in an earlier block
and how many blocks back the earliest such owner is; a triangle that reaches
further back than the thread has gone keeps its corners' edge ids and waits on
the side list, looked up once every vertex is made. Measured (20 values, one
process, medians of interleaved sweeps, 2-core VM, blocks of 65,536 cells): 0.93 of the separate
passes' time on 2M (side lists 10 % of the triangles against 3.4 %), 0.89 on
10M, 1.04 on data4 (nine blocks: the block cut between the two threads is a
larger share; side lists 24 % of the triangles).

Chunks are numbered in the table's order, so the vertices and triangles
come out in the same order whatever the number of threads. The triangles
are the marching ones of every other method (same keys, same positions bit
for bit, normals equal up to rounding: :func:`~polygen.volume.surface.same_surface`).

Cost: the table (nodes, edge ids, owned edges and the cell id per cell: 48
bytes per tetrahedron, 88 per hexahedron), the maxima (4 bytes per cell),
``ev`` (4 bytes per edge) and a stamp per node. Preparation: the volume's
edge table, then a counting sort by (block,) row and a sort of each row.

Several queries side by side (``extract_many``) are not faster: each query
already has every core, and two of them share the caches (2M, twenty values:
53 ms side by side against 42 ms one after the other on a 2-core AMD VM, 61
against 55 ms on a 2-core Intel VM).
"""

from __future__ import annotations

import time

import numba
import numpy as np
from polygen import _jit
from polygen.volume import _active_scan_kernels as _k
from polygen.volume import _edge_centred_kernels as _ek
from polygen.volume import marching as _m
from polygen.volume.methods import IsosurfaceMethod, register
from polygen.volume.surface import (
    IsoSurface,
    IsoSurfaceError,
    check_normals,
    check_value,
    drop_double_faces,
    drop_unreferenced,
    node_gradients,
    vertex_normals,
    volume_arrays,
)

__all__ = ["ActiveScan", "ActiveScanMethod"]

_INT32_MAX = np.iinfo(np.int32).max
#: the normal sums of a query that does not fuse them (no rows)
_NO_SUMS = np.zeros((0, 3))


class _Scratch:
    """What one query writes: the vertex of each crossed edge (``ev``, never cleared: a query reads only
    the entries it wrote), the stamped vertex of each node at the value (``nvid``: ``gen << 32 | id``),
    the rows' ranges and buffers kept between queries (grown, never shrunk: a fresh array of megabytes
    costs a page fault per 4 KiB at its first write, every query)."""

    def __init__(self, scan):
        self.ev = _jit.scratch(scan.n_edges, scan._idx)
        self.nvid = np.zeros(scan.points.shape[0], np.int64)
        self.ranges = _jit.scratch((scan.row_off.shape[0] - 1, 2), np.int64)
        self.roff = _jit.scratch(scan.row_off.shape[0], np.int64)
        self.gen = 0
        self.buffers = {}

    def next_generation(self):
        if self.gen >= _INT32_MAX:
            self.nvid.fill(0)
            self.gen = 0
        self.gen += 1
        return self.gen

    def buffer(self, name, n, dtype):
        buf = self.buffers.get(name)
        if buf is None or buf.shape[0] < n:
            buf = self.buffers[name] = _jit.empty(max(n, 1024), dtype)
        return buf[:n]

    def nbytes(self):
        return (self.ev.nbytes + self.nvid.nbytes + self.ranges.nbytes + self.roff.nbytes
                + sum(b.nbytes for b in self.buffers.values()))


class ActiveScan:
    """The active-cell scan prepared on one volume and field (see the module docstring).

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name (the first field by default) or node values.
    rows : int, optional
        Rows of each block's span-space order (bins of its cells' minima,
        equally filled: each block's bounds its own, so that a block whose
        cells share a minimum does not put them all in one row). By default
        one per :attr:`ROW` cells of a block (between 1 and 4096): a query
        tests at most about one row per block of cells it does not cross.
        (Bounds shared by all blocks tested 988,282 cells for the 854,069
        crossed by 20 values on 2M; each block's own, 934,412.)
    block : int, optional
        Cells per block: consecutive cells of the volume, each block in
        span-space order of its own. By default one block
        below :attr:`BLOCKS_FROM` cells, blocks of :attr:`BLOCK` from there.
    chunk : int, optional
        Active cells per unit of parallel work (default 1024).
    memory_budget : int, optional
        Bytes the preparation may allocate beyond what the volume holds:
        the arrays the method keeps (the table, the maxima, the rows, a
        query's scratch: ``planned_bytes["kept"]``), each edge's owner while
        the table is filled, and the temporaries of one group of blocks
        (:attr:`GROUP_BYTES_PER_CELL` per cell). The largest group that fits
        is taken (at most :attr:`GROUP_CELLS` cells); an
        :class:`~polygen.volume.surface.IsoSurfaceError` says what is needed
        when one block does not fit. Not counted: the volume's edge table
        (``vol.edges``, ``vol.cell_edges``, built first if missing, kept by
        the volume), the surfaces a query returns, and the kernels' own
        scratch (kilobytes per thread). ``None``: groups of
        :attr:`GROUP_CELLS` cells.
    group : int, optional
        Blocks per group of the preparation (its unit of work; the arrays do
        not depend on it): by default from ``memory_budget``.
    edges_in_table : bool, optional
        Have the volume write its cells' edge ids into the table instead of
        building ``vol.cell_edges`` beside it (when it has not built them;
        the same table either way). By default :attr:`EDGES_IN_TABLE`.

    Notes
    -----
    A query writes ``ev`` and the node stamps: one query at a time per
    object (the method's lock, :class:`ActiveScanMethod`, sees to it).
    """

    #: from this many triangles up the mean normals are summed by all threads (as the edge-centred method)
    STAGE3_PARALLEL_TRIANGLES = 20_000
    #: cells per block of a volume of ``BLOCKS_FROM`` cells or more (``block=None``)
    BLOCK = 16384
    #: Blocks keep a query's reads of node values, positions and edge vertices near each other (a
    #: block's cells are neighbours in the volume's order), at the price of more, shorter ranges and a
    #: row per block tested for nothing. Measured (20 values, medians of interleaved sweeps, one process):
    #: on a 2-core AMD EPYC VM (1 MiB L2, 32 MiB L3 at 13-44 ns) one block was the faster at 2M, 37.9 ms
    #: against 43-44 ms with blocks of 8192-131072 cells and a row per 128 cells (15,000 segments, searched
    #: serially then); on a 2-core Intel Xeon VM (2 MiB L2, 37 ns at 4 MB, 69 ns at 16 MB) blocks of 65536
    #: cells with 128 rows each took 0.88 of one block's time on data3 and data4, 0.88-0.90 on 2M, and 0.95
    #: of blocks of 8192 cells on 10M (fewer segments, fewer cells tested for nothing). Once passes 2 and 3
    #: went block by block (:attr:`FUSED`), smaller blocks paid (Intel Xeon VM, 4 MiB L2; blocks of 16384
    #: cells against 65536): data2 0.95 (against one block), data3 0.95-0.975, data4 0.91, 2M 0.97, 10M
    #: 0.92, hexa3 0.88 of the time; blocks of 8192 against 16384: data4 1.04, 2M 1.06, 10M 1.02.
    BLOCKS_FROM = 2 * BLOCK
    #: cells per row (by default): fewer tested for nothing against more binary searches per query
    ROW = 512
    #: passes 2 and 3 block by block on a volume in blocks (see the module docstring); False: one after the
    #: other over all the active cells (the same arrays, for comparison)
    FUSED = True

    def __init__(self, vol, field=None, *, rows=None, chunk=1024, block=None, memory_budget=None, group=None,
                 edges_in_table=None):
        points, cells, s, cell_type = volume_arrays(vol, field)
        if isinstance(rows, bool) or not (rows is None or (isinstance(rows, (int, np.integer)) and rows >= 1)):
            raise IsoSurfaceError(f"rows must be a positive integer; got {rows!r}")
        if isinstance(chunk, bool) or not (isinstance(chunk, (int, np.integer)) and chunk >= 1):
            raise IsoSurfaceError(f"chunk must be a positive integer; got {chunk!r}")
        if isinstance(block, bool) or not (block is None or (isinstance(block, (int, np.integer)) and block >= 1)):
            raise IsoSurfaceError(f"block must be a positive integer or None; got {block!r}")
        if isinstance(group, bool) or not (group is None or (isinstance(group, (int, np.integer)) and group >= 1)):
            raise IsoSurfaceError(f"group must be a positive integer (blocks per group) or None; got {group!r}")
        if not (memory_budget is None or (isinstance(memory_budget, (int, np.integer))
                                          and not isinstance(memory_budget, bool) and memory_budget > 0)):
            raise IsoSurfaceError(f"memory_budget must be a positive number of bytes or None; got {memory_budget!r}")
        self.vol = vol
        self.points = points
        self.s = s
        self.cell_type = cell_type
        self.tri_table, self.tri_count, self.local_edges, self.faces = _m.local_tables(cell_type)
        self.case_mask = _ek.case_masks(self.tri_table, self.tri_count)
        self.chunk = int(chunk)
        m = cells.shape[0]
        self.nn = cells.shape[1]
        self.ne = self.local_edges.shape[0]
        if (self.nn, self.ne) not in ((4, 6), (8, 12)):  # the passes are built for these two (_k.count_pass)
            raise IsoSurfaceError(f"the active-cell scan takes tetrahedra or hexahedra; got {self.nn}-node cells")
        if block is None:
            block = self.BLOCK if m >= self.BLOCKS_FROM else max(1, m)
        self.block = int(block)
        n_blocks = -(-m // self.block) if m else 0
        if rows is None:  # a row per ROW cells of a block, at most 4096 (blocks of 16384 cells: 32)
            rows = min(4096, max(1, min(m, self.block) // self.ROW))
        rows = int(rows)
        if memory_budget is not None:  # what the method keeps cannot fit: say so before the edge table is built
            self._plan(m, 0, points.shape[0], n_blocks, rows, np.int32, memory_budget, group)
        in_table = self.EDGES_IN_TABLE if edges_in_table is None else bool(edges_in_table)
        # the volume's edge ids go straight into the table's edge columns when the volume has not built them
        # (the usual first preparation): no (M, 6|12) array of the volume's beside the table (24 bytes per
        # tetrahedron); each group's are copied aside before its rows are sorted in place (below)
        idx = np.int64 if max(points.shape[0], m * self.ne) >= _INT32_MAX else np.int32  # edges < m * ne
        self.table = _jit.empty((m, self.nn + self.ne + 2), idx)
        edges = vol._edges_into(self.table[:, self.nn:self.nn + self.ne]) if in_table else None
        self.edges_in_table = edges is not None
        cell_edges = None if self.edges_in_table else vol.cell_edges
        self.n_edges = (vol.edges if edges is None else edges).shape[0]
        per_group = self._plan(m, self.n_edges, points.shape[0], n_blocks, rows, idx, memory_budget, group)
        self.group = per_group * self.block  # cells per group: the preparation's unit of work (below)

        # the kept arrays; each block's row bounds are equally filled by its cells' minima (from a sample)
        self.lower = _jit.scratch((n_blocks, rows))
        self.block_min = _jit.scratch(n_blocks)
        self.block_max = _jit.scratch(n_blocks)
        self.row_off = _jit.scratch(self.lower.size + 1, np.int64)
        self.row_off[0] = 0
        self.cmx = _jit.empty(m, np.float32)
        # group by group of whole blocks: a block's rows, its span-space order and its table rows depend on
        # its own cells only (and the edge owners on the cells before, carried in ``first``), so the groups
        # give the arrays that one pass over all the cells gives, with temporaries of one group's size
        first = _jit.scratch(self.n_edges, idx)
        first[:] = -1
        for a in range(0, m, self.group):
            self._prepare_group(a, min(m, a + self.group), cells, s, cell_edges, first)
        if _k.count_unowned(first):
            raise IsoSurfaceError("the volume's edge table has edges without a cell")  # pragma: no cover
        del first
        self._idx = idx
        self._scratch = _Scratch(self)  # ev, node stamps, buffers: what one query writes
        self._node_grad = None
        self.stats = {}

    #: bytes per cell of a group's temporaries (:meth:`_prepare_group`): minima and maxima (float64), row and
    #: order (int64), maxima rounded to float32 and the float64 copy they are compared with, owner column
    #: (int32), the rounding mask; and the cell's edge ids copied aside (12 ids of 4 bytes at most)
    GROUP_BYTES_PER_CELL = 8 + 8 + 8 + 8 + 4 + 8 + 4 + 1 + 48
    #: write the volume's edge ids into the table (see ``__init__``) when the volume has not built them; False:
    #: read ``vol.cell_edges`` (the same arrays: tested)
    EDGES_IN_TABLE = True
    #: cells per group by default (rounded down to whole blocks, at least one): the temporaries of 2**20
    #: cells are 49 MiB whatever the volume's size
    GROUP_CELLS = 1 << 20

    def _plan(self, m, n_edges, n_points, n_blocks, rows, idx, budget, group):
        """Blocks per group of the preparation: ``group``, else the most that ``budget`` allows (at most
        :attr:`GROUP_CELLS` cells' worth), else :attr:`GROUP_CELLS` cells' worth; an
        :class:`IsoSurfaceError` when even one block per group does not fit the budget."""
        isz = np.dtype(idx).itemsize
        n_seg = n_blocks * rows
        kept = (m * (self.nn + self.ne + 2) * isz + 4 * m  # table, maxima
                + n_seg * 8 + (n_seg + 1) * 8 + 16 * n_blocks  # row bounds, row starts, block extremes
                + n_edges * isz + 8 * n_points + 16 * n_seg + 8 * (n_seg + 1))  # a query's ev, node stamps, ranges
        fixed = kept + n_edges * isz  # + each edge's owner while the table is filled
        self.planned_bytes = {"kept": int(kept), "fixed": int(fixed)}
        default = max(1, self.GROUP_CELLS // self.block)
        if budget is None:
            return int(group) if group is not None else default
        per_block = self.GROUP_BYTES_PER_CELL * min(self.block, max(m, 1))
        fits = (int(budget) - fixed) // per_block
        want = int(group) if group is not None else default
        if fits < 1 or (group is not None and fits < want):
            need = fixed + per_block * (want if group is not None else 1)
            raise IsoSurfaceError(
                f"the active-cell scan's preparation needs at least {need:,} bytes for {m:,} cells"
                f"{f' and {n_edges:,} edges' if n_edges else ''} ({kept:,} kept: the table, maxima, rows and a "
                f"query's scratch; the rest temporaries of {want if group is not None else 1} block(s) of "
                f"{self.block:,} cells); memory_budget is {int(budget):,} bytes")
        return int(min(fits, want))

    def _prepare_group(self, a, b, cells, s, cell_edges, first):
        """The rows, span-space order and table rows of the cells ``a:b`` (whole blocks; ``b = m`` for the
        last group), with temporaries of their size only."""
        g = b - a
        blk0, blk1 = a // self.block, -(-b // self.block)
        if cell_edges is None:  # the edge ids are in the table's rows a:b, which the fill below overwrites
            ce = self.table[a:b, self.nn:self.nn + self.ne].copy()
        else:
            ce = cell_edges[a:b]
        n_rows = self.lower.shape[1]
        cmin = _jit.empty(g)
        cmax = _jit.empty(g)
        _k.cell_extremes(cells[a:b], s, cmin, cmax)
        lower = self.lower[blk0:blk1]
        row = _jit.scratch(g, np.int64)
        _k.block_rows(cmin, self.block, lower, row)
        _k.block_extremes(cmin, cmax, self.block, self.block_min[blk0:blk1], self.block_max[blk0:blk1])
        with np.errstate(over="ignore"):  # beyond float32's range: +-inf, then rounded up below as the rest
            cmax32 = cmax.astype(np.float32)  # rounded up where float32 is below: tested maybe, never missed
        low = cmax32.astype(np.float64) < cmax
        cmax32[low] = np.nextafter(cmax32[low], np.float32(np.inf))
        del cmin, cmax, low
        row_off = _jit.scratch(lower.size + 1, np.int64)
        order = _jit.scratch(g, np.int64)
        _k.rows_by_count(row, lower.size, row_off, order)
        del row
        _k.sort_rows_by_max(order, row_off, cmax32)
        self.row_off[blk0 * n_rows + 1:blk1 * n_rows + 1] = row_off[1:] + a
        own = _jit.scratch(g, np.int32)
        _k.edge_owners(ce, a, self.block, first, own)
        _k.fill_table(order, cells[a:b], ce, own, cmax32, a, self.table[a:b], self.cmx[a:b])

    def node_gradients(self):
        if self._node_grad is None:
            self._node_grad = node_gradients(self.vol, self.s)
        return self._node_grad

    def extract(self, value, *, normals="mean"):
        """The isosurface ``S = value`` (:class:`~polygen.volume.surface.IsoSurface`), by all of numba's threads."""
        value = check_value(value)
        check_normals(normals)
        node_grad = self.node_gradients() if normals == "gradient" else None
        full = numba.get_num_threads()
        n = query_threads(full)
        if n == full:
            iso, self.stats = self._extract(value, normals, node_grad, self._scratch, n)
            return iso
        numba.set_num_threads(n)  # this Python thread's count only
        try:
            iso, self.stats = self._extract(value, normals, node_grad, self._scratch, n)
        finally:
            numba.set_num_threads(full)
        return iso

    def _extract(self, value, normals, node_grad, sc, n_parts):
        """One query with the scratch ``sc``, by ``n_parts`` threads."""
        tab, nn, ne, s, chunk = self.table, self.nn, self.ne, self.s, self.chunk
        gen = sc.next_generation()

        t0 = time.perf_counter()
        n_r = _k.active_ranges(self.lower, self.row_off, self.cmx, value, self.block_min, self.block_max, sc.ranges,
                               sc.roff)
        ranges = sc.ranges[:n_r]
        roff = sc.roff[:n_r + 1]
        n_act = int(roff[n_r])
        n_ch = -(-n_act // chunk)
        n_parts = max(1, min(n_parts, n_ch))
        st = sc.buffer("st", n_act, np.int32)
        ch = sc.buffer("chunks", 4 * n_ch, np.int64).reshape(4, n_ch)  # triangles, vertices, node cells, crossed
        off = sc.buffer("offsets", 3 * (n_ch + 1), np.int64).reshape(3, n_ch + 1)
        n_crossed = 0
        if n_ch:
            n_crossed = _k.count_pass(tab, nn, ne, s, value, self.faces, self.tri_table, self.tri_count,
                                      self.case_mask, self.local_edges, ranges, roff, chunk, st, ch, off, n_parts)
        else:
            off[:, 0] = 0
        n_t, n_ev, n_x = int(off[0, n_ch]), int(off[1, n_ch]), int(off[2, n_ch])
        t1 = time.perf_counter() - t0

        t0 = time.perf_counter()
        n_vmax = n_ev + nn * n_x
        pos = _jit.output_empty((n_vmax, 3))
        keys = _jit.output_empty(n_vmax, np.int64)
        exact_cells = _jit.scratch((n_x, 2), np.int64)
        sums = normals == "mean" and n_x == 0  # the normal sums ride along with the triangles
        acc = sc.buffer("normals", n_vmax * 3, np.float64).reshape(n_vmax, 3) if sums else _NO_SUMS
        tri = _jit.output_empty((n_t, 3), np.int64)
        tri_cell = _jit.output_empty(n_t, np.int64)
        cuts = _k.part_cuts(off[0], n_parts)
        n_side = np.zeros(n_parts, np.int64)
        ev_reads = np.zeros(n_parts, np.int64)  # vertex ids read at an edge id (ev[edge]), per part
        # block by block (vertices then triangles) where no node is at the value and the parts hold whole blocks
        by_block = n_x == 0 and (n_parts == 1 or self.table.shape[0] > self.block) and self.FUSED
        side_t = sc.buffer("side", n_t if sums or by_block else 0, np.int64)
        if n_ch and by_block:
            _k.fused_pass(tab, nn, ne, s, value, self.points, self.local_edges, self.tri_table, self.tri_count,
                          self.case_mask, ranges, roff, chunk, self.block, st, off[1], off[0], sc.ev, sc.nvid, pos,
                          keys, exact_cells, tri, tri_cell, acc, cuts, side_t, n_side, n_parts, ev_reads)
        elif n_ch:
            args = (tab, nn, ne, s, value, self.points, self.local_edges, self.tri_table, self.tri_count,
                    self.case_mask, ranges, roff, chunk, st, off[1], off[2], sc.ev, pos, keys, exact_cells, acc)
            _k.vertex_pass(*args, n_parts)
        n_v = n_ev
        if n_x:
            n_v = _k.node_vertices(tab, nn, s, value, self.points, self.tri_table, self.tri_count, self.local_edges,
                                   exact_cells, self.n_edges, sc.nvid, gen, n_ev, pos, keys)
        if n_ch and not by_block:
            args = (tab, nn, ne, s, value, self.tri_table, self.tri_count, self.case_mask, self.local_edges, ranges,
                    roff, chunk, st, off[0], sc.ev, sc.nvid, tri, tri_cell, pos, acc, cuts, off[1], side_t, n_side)
            _k.triangle_pass(*args, n_parts, ev_reads)
        side_n = _NO_SUMS
        if n_ch and (sums or by_block):  # the side lists: their corners (by_block), their normals (sums)
            side_n = sc.buffer("side_normals", 3 * int(n_side.sum()) if sums else 0, np.float64).reshape(-1, 3)
            _k.side_normals(tri, sc.ev, side_t, cuts, off[0], off[1], n_side, pos, acc, side_n, by_block, ev_reads)
        vertices, keys = pos[:n_v], keys[:n_v]
        if n_x:  # a face at C kept once, vertices of polygons collapsed onto nodes dropped (as every method)
            tri, tri_cell = drop_double_faces(keys, tri, tri_cell, self.n_edges)
            tri, keep = drop_unreferenced(tri, n_v)
            if keep is not None:
                vertices, keys = vertices[keep], keys[keep]
        t2 = time.perf_counter() - t0

        t0 = time.perf_counter()
        mean_done = mean_kernel = None
        if sums:
            nrm = _jit.output_empty((n_v, 3))
            n_zero = _k.fold_normals(acc, nrm, cuts, off[1], off[0], tri, side_t, n_side, side_n)
            mean_done = (nrm, int(n_zero))
        elif n_parts > 1 and tri.shape[0] >= self.STAGE3_PARALLEL_TRIANGLES:
            def mean_kernel(v, t, out):
                _ek.mean_normals_parallel(v, t, out, _jit.scratch((n_parts - 1, v.shape[0], 3)))
        nrm = vertex_normals(normals, vertices, tri, keys, edges=self.vol.edges, s=s, value=value,
                             node_grad=node_grad, points=self.points, mean_kernel=mean_kernel, mean_done=mean_done)
        t3 = time.perf_counter() - t0
        stats = {"active": n_act, "crossed": n_crossed, "ranges": n_r, "chunks": n_ch, "node_cells": n_x,
                 "threads": n_parts, "side": int(n_side.sum()), "lookups": int(ev_reads.sum())}
        return IsoSurface(
            value=value, vertices=vertices, triangles=tri, normals=nrm, vertex_keys=keys, triangle_cells=tri_cell,
            cells_tested=n_act, cells_intersected=n_crossed, vertex_lookups=int(ev_reads.sum()), t1=t1, t2=t2, t3=t3,
            method="active-scan",
        ), stats

    def memory_bytes(self):
        """Bytes held between queries, by array: ``table`` (nodes, edge ids, owned edges, cell id per cell),
        ``maxima`` (float32 per cell), ``rows`` (the row bounds, the segments' starts, the blocks' extremes)
        and ``scratch`` (``ev``, node
        stamps, the buffers of the largest query so far)."""
        return {
            "table": int(self.table.nbytes),
            "maxima": int(self.cmx.nbytes),
            "rows": int(self.lower.nbytes + self.row_off.nbytes + self.block_min.nbytes + self.block_max.nbytes),
            "scratch": int(self._scratch.nbytes()),
        }


def query_threads(full):
    """The threads of one query: numba's ``full``, fewer while other programs' tasks wait for the cores.

    A query is four parallel passes, each ending at a barrier where numba's
    OpenMP workers spin. With another program's task on a core, a pass
    waits for the time slice of the thread that was put aside, and the
    spinning one burns its own: on this project's 2-core machine at load
    6.7, data1's 20-value sweep took 60-130 ms of CPU a value on two
    threads and 0.23 ms on one. The reading of the machine's runnable tasks is
    the edge-centred table's ``threads="auto"`` one
    (:func:`polygen.volume.edge_centred._busy`, read at most every
    ``BUSY_SECONDS``); the surface is the same whatever the count.
    """
    if full < 2:
        return full
    from polygen.volume import edge_centred as _ec  # the one reading of the machine's load

    busy = _ec._busy()
    if busy is None:
        return full
    return max(1, min(full, int(_ec._cpus() - busy)))


@register
class ActiveScanMethod(IsosurfaceMethod):
    name = "active-scan"
    description = ("the crossed cells as prefixes of span-space rows (cells by minimum, then maximum), scanned in "
                   "parallel; each crossed edge's vertex made by its one owner cell: no search, no walk (ours)")
    construction = "scan"

    def _prepare(self, rows=None, chunk=1024, block=None, memory_budget=None, group=None):
        self.scan = ActiveScan(self.vol, self.field, rows=rows, chunk=chunk, block=block,
                               memory_budget=memory_budget, group=group)

    def extract(self, value, *, normals="mean"):
        iso = self.scan.extract(value, normals=normals)
        self.seed_cells_tested = iso.cells_tested
        return iso
