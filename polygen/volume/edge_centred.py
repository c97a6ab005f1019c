"""Polygon construction without vertex search: cell-edge-centred propagation (Itoh et al. 2001).

Most isosurface vertices are shared by several polygons, so a propagation
that builds one cell's polygon at a time must find every vertex again
when the next cell around the same cell edge is built; the thesis's
propagation (:mod:`polygen.volume.propagate`) does that with a hash table
keyed by the edge's two end nodes (the paper's section 2.1, Fig. 1, its
reference [12]), because volume data store nodes and cells but not cell
edges. The 2001 paper (3.1, Fig. 4) turns the loop inside out: when a
polygon vertex is created on a cell edge, *every* cell sharing that edge is
visited at once, its polygon is constructed if it is missing (and the cell
is put into the FIFO), and the vertex is registered in all of them. A
vertex is therefore never needed again and never searched for.

Pseudo-code of the paper (Fig. 5), as implemented by both builders here:

* seeds: the skeleton cells (or other seed cells) the surface crosses go
  into the FIFO (t1);
* for-loop (1): take a cell ``C_i`` from the FIFO; construct ``P_i`` if it
  is missing;
* for-loop (2): for every polygon vertex of ``P_i`` not registered yet
  (on cell edge ``E_n``): allocate ``V_n``;
* for-loop (3): for every cell ``C_j`` sharing ``E_n``: construct ``P_j``
  and insert ``C_j`` into the FIFO if ``P_j`` is missing; register ``V_n``
  into ``P_j``;
* finally the positions (5.2) and normals of all vertices (t3).

Two builders differ only in how for-loop (3) finds the cells sharing
``E_n``:

:class:`EdgeCentredWalk` (method ``edge-centred``) — the paper's setting
    no edge is numbered or stored: the cells round the edge are found by
    walking from face neighbour to face neighbour round it
    (:mod:`._edge_walk_kernels`); the vertex is known by its edge's nodes.
:class:`EdgeCentredTable` (method ``edge-centred-table``, the default of
    ``vol.isosurface`` before ``active-scan``) — with stored edges: an edge
    table and, per edge, the list of its cells with the edge's local index in
    each (:mod:`._edge_centred_kernels`); faster, for about 1.7 times the
    walk's memory (``benchmarks/results/fast_construction.md``).

Every cell around a crossed edge is itself crossed, so for-loop (3) needs
no intersection test. The one exception is the degenerate crossing exactly
on a node (``S == C``, see :mod:`polygen.volume.marching`): that vertex is
the node, shared by every cell around the *node*, so for-loop (3) then
visits the node's cells and tests each (a cell around the node may lie
wholly above ``C``).

Registration is one store: a polygon keeps one vertex slot per local edge
and per node of its cell. Visited cells carry a generation stamp, so a
query starts in O(1), and all buffers are reused from query to query. The
walk's kernel counts the vertex look-ups it makes (``vertex_lookups``):
none; ``EdgeCentredWalk(..., search=True)`` is a deliberately searching
variant that counts them. The table's kernels have no look-up to count
(``vertex_lookups`` is 0 by construction); they count what they do read, a
vertex id from a cell's slot per triangle corner (``stats["slot_reads"]``).

The hexahedral version, which the paper names as future work, is the same
loop: twelve local edges, eight nodes, marching-hexahedra polygons (with
the face-centre rule for ambiguous faces), and the cells around an edge of a
hexahedral mesh.

The result is the same surface as the full scan and the hash-based
propagation, triangle for triangle and vertex for vertex, whenever the seeds
reach every connected part of the surface, which the volume-thinning
skeleton guarantees (thesis chapter 7). Cells visited differ: the paper
notes that a cell is visited several times by for-loop (3) before it is
taken from the FIFO once; the builders' ``stats`` count both.

    m = methods.get("edge-centred")(vol)           # seeds from volume thinning, no stored edges
    iso = m.extract(0.5)
    iso.vertex_lookups, m.stats["visits"]          # 0, cells visited by for-loop (3)
"""

from __future__ import annotations

import copy
import dataclasses
import os
import threading
import time

import numpy as np
from polygen import _jit
from polygen._jit import parallel_kernels_may_overlap
from polygen.volume import _edge_centred_kernels as _k
from polygen.volume import _edge_walk_kernels as _w
from polygen.volume import marching as _m
from polygen.volume import registry as _registry
from polygen.volume._topology import csr_from_keys
from polygen.volume.methods import IsosurfaceMethod, register
from polygen.volume.propagate import EdgeLabels, pair_stage3
from polygen.volume.seeds.source import SeedSource, seed_source
from polygen.volume.surface import (
    IsoSurface,
    IsoSurfaceError,
    check_normals,
    check_threads,
    check_value,
    check_values,
    drop_double_faces,
    machine_cores,
    drop_unreferenced,
    node_gradients,
    vertex_normals,
    volume_arrays,
)

__all__ = ["EdgeCentredWalk", "EdgeCentredTable", "canonical_order", "EdgeCentred", "edge_centred", "SeedSource", "seed_source",
           "SEED_SOURCES", "EdgeCentredMethod", "EdgeCentredTableMethod"]

_INT32_MAX = np.iinfo(np.int32).max


def _check_threads(threads, auto=False):
    """:func:`polygen.volume.surface.check_threads`: the one rule for ``threads``."""
    return check_threads(threads, auto=auto)


_OVERLAP_SAFE = []


def _overlap_safe():
    """:func:`polygen._jit.parallel_kernels_may_overlap`, asked once (it launches a parallel region: on a busy
    machine a wait for the other cores)."""
    if not _OVERLAP_SAFE:
        _OVERLAP_SAFE.append(parallel_kernels_may_overlap())
    return _OVERLAP_SAFE[0]


def _own_runnable():
    """Threads of this process running or runnable now besides the calling one (Linux ``/proc/self/task``)."""
    n = 0
    for tid in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{tid}/stat", "rb") as f:
                st = f.read()
        except OSError:  # the thread ended meanwhile
            continue
        i = st.rindex(b")")
        n += st[i + 2:i + 3] == b"R"
    return max(0, n - 1)


def _runnable_elsewhere():
    """Tasks of other processes runnable on the machine now (Linux: ``/proc/loadavg``), else the 1-minute load
    average; None where neither is known.

    This process's own threads are not counted: numba's OpenMP workers
    spin for 3-10 ms after each parallel region (measured here), so right
    after a parallel query they would look like another program's work.
    (The thread list is read only when the machine-wide count says busy.)
    """
    try:
        with open("/proc/loadavg", "rb") as f:
            running = int(f.read().split()[3].split(b"/")[0]) - 1  # less the calling thread
        if running == 0:
            return 0
        return max(0, running - _own_runnable())
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return None


#: seconds one reading of the machine's runnable tasks (:func:`_runnable_elsewhere`) serves the ``"auto"``
#: thread count: a reading costs 10-60 us (the /proc files; right after a parallel query numba's workers are
#: still spinning, so this process's thread list is read too), 7 % of a 15,000-triangle surface on 2M. 0: read
#: at every query
BUSY_SECONDS = 0.1
_busy_reading = [float("-inf"), 0]  # (time.monotonic(), reading); a race between threads only reads twice
_CPUS = []


def _cpus():
    """``os.cpu_count()`` (at least 1), asked once (5 us a call)."""
    if not _CPUS:
        _CPUS.append(os.cpu_count() or 1)
    return _CPUS[0]


def _busy():
    """:func:`_runnable_elsewhere`, read again when the last reading is :data:`BUSY_SECONDS` old."""
    now = time.monotonic()
    seen, reading = _busy_reading
    if now - seen >= BUSY_SECONDS:
        reading = _runnable_elsewhere()
        _busy_reading[:] = (now, reading)
    return reading


def canonical_order(iso):
    """``iso`` with its vertices sorted by key and its triangles by cell (each cell's in its own order).

    Two constructions of the same surface (serial and parallel, FIFO and
    LIFO) give equal arrays in this order.

    Parameters
    ----------
    iso : IsoSurface
        With ``vertex_keys`` and ``triangle_cells``.

    Returns
    -------
    IsoSurface
        The same surface, reordered.
    """
    order = np.argsort(iso.vertex_keys, kind="stable")
    new_id = _jit.scratch_like(order)
    new_id[order] = np.arange(order.size)
    tri_order = np.argsort(iso.triangle_cells, kind="stable")
    return dataclasses.replace(
        iso, vertices=iso.vertices[order], vertex_keys=iso.vertex_keys[order],
        normals=None if iso.normals is None else iso.normals[order],
        triangles=new_id[iso.triangles[tri_order]], triangle_cells=iso.triangle_cells[tri_order])


def _output_buffers(m, key_dtype=np.int32):
    """The query buffers of a builder over ``m`` cells: queue, triangles, their cells, vertex keys and ends.

    Sized so that the surfaces of a smooth field fit at the first query
    (a queue of ``m / 16`` cells, ``m / 6`` triangles, ``m / 12`` vertices;
    32-bit ids: about 4 bytes per cell with 32-bit keys) -- an overflow makes
    the kernel stop, the buffer double and the query start again, which
    costs that query a second extraction (the slider of
    :mod:`polygen.widgets` felt it on data 4). The results are copied out as
    int64, the :class:`~polygen.volume.surface.IsoSurface` convention.
    """
    q_cap = max(1024, m // 16)
    t_cap = max(2048, m // 6) + _m.MAX_TRIANGLES
    v_cap = max(1024, m // 12)
    return (_jit.scratch(q_cap, np.int32), _jit.scratch((t_cap, 3), np.int32), _jit.scratch(t_cap, np.int32),
            _jit.scratch(v_cap, key_dtype), _jit.scratch((v_cap, 2), np.int32))


_EMPTY_I32 = _jit.scratch(0, np.int32)


def _aligned_records(m, width):
    """(m, width) int32 records starting on a 64-byte boundary (a tetrahedron's record is one cache line)."""
    raw = _jit.empty(m * width + 16, np.int32)  # numba's allocator: no huge-page advice (see polygen._jit.empty)
    start = (-(raw.ctypes.data // 4)) % 16
    return raw[start:start + m * width].reshape(m, width)


def _collapse_all(arrays):
    """:func:`polygen._jit.collapse_to_huge_pages` on each array, in a :meth:`EdgeCentredTable.settle` thread:
    the bytes collapsed, each array's (``collapsed_each``) and in all (``collapsed``)."""
    t = threading.current_thread()
    t.collapsed_each = [_jit.collapse_to_huge_pages(a) for a in arrays]
    t.collapsed = sum(t.collapsed_each)


def _drop_at_nodes(any_node, tri, tri_cell, keys, vend, n_edges):
    """After a query with vertices exactly on nodes: a face at ``C`` kept once, unused vertices dropped.

    Returns ``(tri, tri_cell, keys, vend, collapsed)``; ``collapsed`` holds the
    end nodes of the vertices dropped (registered for polygons that
    collapsed onto nodes, used by no triangle).
    """
    collapsed = vend[:0].copy()
    if not any_node:
        return tri, tri_cell, keys, vend, collapsed
    # a face exactly at C between two cells: keep it once (as every method does)
    tri, tri_cell = drop_double_faces(keys, tri, tri_cell, n_edges)
    tri, keep = drop_unreferenced(tri, keys.shape[0])  # vertices of polygons collapsed onto nodes
    if keep is not None:
        collapsed = np.delete(vend, keep, axis=0)
        keys, vend = keys[keep], np.ascontiguousarray(vend[keep])
    return tri, tri_cell, keys, vend, collapsed


class EdgeCentredTable:
    """Cell-edge-centred construction with a stored edge table, on one volume and field, reused across queries.

    Not the paper's setting: this variant numbers the cell edges and keeps
    the cells around each edge (an edge -> cells index), which the paper's
    method needs not (:class:`EdgeCentredWalk` is the paper's). It is what
    the construction becomes when cell edges are stored.

    Preparing builds one 64-byte record per tetrahedron (stamp, state,
    nodes, four vertex slots, edge ids; 192 bytes per hexahedron) and the
    cells around each edge with the edge's local index in each (O(n)):
    about 97 bytes per tetrahedron in all (records 64, the cells around
    the edges 24 plus each edge's id before its list 4.8, query buffers
    about 4; the edge ids of a cell are read from the volume's
    ``cell_edges`` only by the parallel construction);
    the cells around each node (16.7 bytes per tetrahedron) are built at
    the first query that meets a crossing exactly on a node. Every query
    reuses the stamps and buffers, so one builder serves one thread at a
    time (the ``edge-centred`` method holds a lock around it; :meth:`copy`
    gives a builder for another thread that shares the records and keeps
    its own stamps, states and slots, 24 bytes per tetrahedron).

    Parameters
    ----------
    vol : UnstructuredVolume
        Tetrahedra or hexahedra.
    field : str or (N,) float64, optional
        Field name or node values (the volume's first field by default).
    order : {"fifo", "lifo"}, keyword-only
        Which queued cell for-loop (1) takes next: the oldest (the paper's
        FIFO) or the newest (its neighbours' records are still in cache). The
        surface is the same either way; only the order of its triangles and
        vertices differs.
    layout : {"records", "volume"}, keyword-only
        Where a query reads a cell's nodes and edge ids. ``"records"``: from
        one 64-byte record per tetrahedron that also holds its stamp, state
        and four vertex slots (one cache line per visit). ``"volume"``: from
        the volume's own ``cells`` and ``cell_edges`` (which the volume keeps
        anyway), with only the stamps, states and slots here (24 bytes per
        tetrahedron): 40 bytes per tetrahedron less, for a second and a
        third cache line when a cell is first reached and when it is taken
        from the queue. Default :attr:`DEFAULT_LAYOUT`, chosen by
        measurement (see the notes in ``benchmarks/results/interactive.md``).
    threads : int, "auto" or None, keyword-only
        Threads for one query: a number (``None``: numba's thread count), or
        ``"auto"`` (the default, below).
        With more than one, every thread runs this construction's own loop
        on its own stack, taking the next unclaimed seed from a shared
        counter whenever its stack runs dry; a thread claims a cell by
        compare-and-swap on the cell's stamp (the query takes one generation
        per thread), and a vertex on an edge (node) whose cells belong to
        two threads gets its id by compare-and-swap on a per-edge array (see
        ``_edge_centred_kernels._flood``): each cell is constructed once,
        and the triangles and vertices, gathered from per-thread parts of the
        buffers by prefix sums, are the serial ones in another order
        (``canonical=True``, or :func:`canonical_order`, gives one order for
        both; the order changes from run to run, as the threads' shares do).
        Tetrahedra with records run the parallel flood specialised as the
        serial ``construct_tet`` is (``_edge_centred_kernels._flood_tet``):
        the thread that creates a vertex writes its position (the serial
        bits) and zeroes its normal sum, each thread adds its triangles'
        normals into the sums of the vertices it created and lists the
        terms for another thread's vertices (contested ones), which are
        added after the parallel region: race-free, the mean normals equal
        to the serial ones to rounding (1e-12; the terms are summed in
        another order). Its total work (two threads' shares run on one core,
        2M, 20 values, ``benchmarks/parallel_construction.py``) is about 1.2
        times the serial's in CPU time (one compare-and-swap per cell, the
        gather); the generic kernel (hexahedra, ``layout="volume"``)
        computes positions and mean normals in separate passes, by the
        threads from :attr:`STAGE3_PARALLEL_TRIANGLES` triangles up. Costs
        ``4 (n_edges + n_nodes)`` bytes more (the contested-vertex ids), and
        the query buffers grow to hold ``threads`` times the largest surface
        (each thread's part must hold a whole surface: how the work splits
        depends on the scheduler).
        ``stats`` then has ``pops`` (= ``constructed``: no cell is taken
        twice), ``contested`` (vertices decided by CAS), ``per_thread``
        (cells each thread took), ``kernel`` and ``foreign_terms`` (normal
        terms passed between the threads); every query's ``stats["threads"]``
        says how many ran it. Without working atomics
        (``_edge_centred_kernels.ATOMICS``) a query runs on one thread.

        ``"auto"``: a query runs on ``min(numba threads, cores)`` threads
        when (a) the surface is estimated to cross at least
        :attr:`PARALLEL_MIN_CELLS` cells (:meth:`crossed_estimate`, a few
        microseconds), (b) numba's threading layer lets two Python threads
        launch parallel regions at once (``omp``, ``tbb``; not
        ``workqueue``), and (c) no other program's task is runnable now
        (``/proc/loadavg``, less this process's own threads; elsewhere the
        1-minute load average; one reading serves the queries of the next
        :data:`BUSY_SECONDS`, 0.1 s) -- else, and for every smaller surface,
        on one. Why (c): a parallel region ends when its last thread does, and
        on a busy machine the second thread waits for a scheduler slice
        (measured here at load 3-4: an empty parallel region 7.5 ms;
        20 values on 2M with ``threads=2`` median 22.7 ms against 1.6 with
        one); the check keeps the serial times there (at load 3.1-3.4,
        12 of 100 queries ran on two threads, sum 170 ms against 146; at
        3.2-3.6, none of 100). On a free second core two threads pay (numba
        0.68, ``omp`` layer, an empty parallel region 2 us; 2M, 20 values,
        sweeps timed only while no other program's task was runnable: one
        thread median 1.41 / largest 26.4 / sum 129 ms, two threads 0.96 /
        16.1 / 81.3, ``"auto"`` 1.08 / 16.0 / 80.8; the generic parallel
        kernel 1.03 / 18.2 / 90.4 against 0.95 / 16.6 / 83.0 for this one in
        the same sweeps). Two builders running parallel queries at once from
        two Python threads need a thread-safe numba threading layer (``omp``
        or ``tbb``, not ``workqueue``, where ``"auto"`` stays on one thread);
        :meth:`EdgeCentredMethod.extract_many` runs its values one thread
        each.

    Attributes
    ----------
    stats : dict
        Counters of the last query: ``pops`` (cells taken from the FIFO,
        for-loop (1)), ``visits`` (cells visited by for-loop (3)),
        ``touched`` (cells for-loop (3) saw first in this query),
        ``constructed`` (polygons constructed), ``node_tests`` (cells around
        an exact-node vertex tested), ``node_vertices``, ``seeds_tested``,
        ``seeds_crossed``, ``lookups`` (reads of a vertex by a key, as the
        hash and array propagations count them: the kernels have no such
        read, so it is 0 by construction, not counted), ``slot_reads``
        (serial queries: the vertex ids the kernel read from a cell's slots
        when it wrote the triangles, one per triangle corner, counted by the
        kernel), ``restarts`` (queries redone after a buffer grew),
        ``collapsed`` (the end-node pairs of the vertices registered for
        polygons that collapsed onto nodes at ``C`` and used by no triangle,
        a tuple, usually empty; a node's two ends are equal).
    preprocess_s : float
        Seconds to build the incidence tables.

    Examples
    --------
    >>> ec = EdgeCentredTable(vol)                 # doctest: +SKIP
    >>> iso = ec.extract(0.5, seeds=[10, 99])      # doctest: +SKIP
    >>> iso.vertex_lookups                         # doctest: +SKIP
    0
    """

    method = "edge-centred-table"

    #: the layout by measurement (see the class docstring)
    DEFAULT_LAYOUT = "records"
    #: a parallel query (``threads > 1``) computes positions and mean normals by its threads too from this
    #: many triangles up (below, serially). Not a measured crossover: under the shared machine's load (10)
    #: every parallel region cost 15-45 ms of waiting whatever its size; 20 000 triangles is where serial
    #: stage 3 takes ~1 ms (2M), far above the start-up of a parallel region on a free core (tens of microseconds)
    STAGE3_PARALLEL_TRIANGLES = 20_000
    #: a serial query on tetrahedra with records in LIFO order runs the kernel specialised for it
    #: (``_edge_centred_kernels.construct_tet``); False: the generic one (tests and benchmarks compare them)
    SPECIALISED_KERNEL = True
    #: ``threads="auto"``: a query runs on several threads only when the surface is estimated to cross at least
    #: this many cells (:meth:`crossed_estimate`). Not a measured crossover (on a quiet machine two threads
    #: already pay at a few thousand cells): 10 000 crossed cells is about 13 000 triangles, ~2 ms of serial work
    #: on 2M, so that a parallel query whose second core turns out busy (one scheduler slice of waiting, ~7 ms at
    #: load 3-4, see the class docstring) is a large surface's query, not a small one's
    PARALLEL_MIN_CELLS = 10_000
    #: cells in the fixed random sample whose value ranges :meth:`crossed_estimate` counts
    SPAN_SAMPLE = 1 << 16
    #: after the build, a background thread backs the records and the edges' cell lists by 2 MiB pages
    #: (:func:`polygen._jit.collapse_to_huge_pages`; :meth:`settle` waits for it); False: they keep 4 KiB pages
    HUGE_PAGES = True

    def __init__(self, vol, field=None, *, order="lifo", threads="auto", layout=None):
        t0 = time.perf_counter()
        if order not in ("fifo", "lifo"):
            raise IsoSurfaceError(f"order must be 'fifo' or 'lifo'; got {order!r}")
        layout = self.DEFAULT_LAYOUT if layout is None else layout
        if layout not in ("records", "volume"):
            raise IsoSurfaceError(f"layout must be 'records' or 'volume'; got {layout!r}")
        self.order = order
        self.layout = layout
        self.threads = _check_threads(threads, auto=True)
        self.vol = vol
        points, cells, s, cell_type = volume_arrays(vol, field)
        m, nn = cells.shape
        if m >= 1 << (31 - _k.CELL_SHIFT):
            raise IsoSurfaceError(f"edge-centred construction supports fewer than {1 << (31 - _k.CELL_SHIFT)} "
                                  f"cells; got {m}")
        self.n_edges = int(vol.edges.shape[0])
        if vol.n_points + self.n_edges > _INT32_MAX:  # vertex keys are edge ids and n_edges + node, in int32
            raise IsoSurfaceError("edge-centred construction needs fewer than 2**31 nodes and edges together")
        self.points = np.ascontiguousarray(points, np.float64)
        self.s = s
        self.cell_type = cell_type
        self.nn = nn
        self.table, self.count, self.local_edges, self.faces = _m.local_tables(cell_type)
        self.case_mask = _k.case_masks(self.table, self.count)
        ce = np.ascontiguousarray(vol.cell_edges)
        ne = ce.shape[1]
        self.ne = ne
        if m * ne + self.n_edges > _INT32_MAX:
            raise IsoSurfaceError(f"edge-centred construction supports up to 2**31 cell edges; got {m * ne}")
        # the cells around each node: built at the first crossing exactly on a node, shared with the copies
        self._node_cells = {}
        self.os, self.n_slots, ost, width = _k.record_layout(nn, ne)
        # the edge ids per cell (the volume's own table): read by the kernels only without records (where
        # each edge's list starts); with records an edge's id is the entry before its list, and holding
        # the table here would keep it alive after the volume releases its preparation tables
        self.ids = ce if layout == "volume" else _jit.scratch((0, ne), ce.dtype)
        # one record per cell, aligned to 64-byte cache lines (see _edge_centred_kernels), filled with the
        # cells around each edge (each with the local index of the edge in it; ec_off: where each edge's
        # list starts) by one parallel kernel
        rec = _aligned_records(m, width) if layout == "records" else _jit.scratch((0, width), np.int32)
        self.ec, ec_off = _k.edge_lists_and_records(np.ascontiguousarray(cells), ce, self.n_edges,
                                                    _check_threads(None), rec, self.os, ost)
        if layout == "records":
            # stamps, states and slots in the records for this builder (a copy keeps its own)
            self.rec = rec
            self.nodes = self.rec[:, _k.R_NODES:_k.R_NODES + nn]
            self.starts = self.rec[:, ost:ost + ne]
            self.ec_off = _EMPTY_I32
            self.dyn, self.ds = self.rec, self.os
        else:
            # no records: nodes read from the volume's cells, stamps, states and slots apart
            self.rec = None
            self.nodes = np.ascontiguousarray(cells)
            self.starts = _jit.scratch((0, ne), np.int32)
            self.ec_off = ec_off
            self.dyn, self.ds = np.zeros((m, 2 + self.n_slots), np.int32), 2
        self.generation = 0
        self._node_grad = None
        # buffers, grown by doubling when a query overflows one (the query is then redone)
        self._queue, self._tris, self._tri_cell, self._vkey, self._vend = _output_buffers(m)
        self.stats = {}
        self._settling = None
        big = [a for a in (self.rec, self.ec) if a is not None and a.nbytes >= _jit.HUGE_PAGE_BYTES]
        if self.HUGE_PAGES and big:
            self._settling = threading.Thread(target=_collapse_all, args=(big,), daemon=True,
                                              name="polygen-huge-pages")
            self._settling.start()
        self.preprocess_s = time.perf_counter() - t0

    def settle(self):
        """Wait until the records and the edges' cell lists sit on huge pages (:attr:`HUGE_PAGES`).

        The build fills them on ordinary 4 KiB pages (fast to fill) and a
        daemon thread then asks Linux to back them by 2 MiB pages
        (``MADV_COLLAPSE``; their contents do not change, and queries may run
        meanwhile). The queries' random reads of them then miss the TLB far
        less. Measured on 2M: the collapse takes ~0.3 s of one core (170 MB);
        20 values, interleaved in one process: 1 thread 2-7 % and ``"auto"``
        3-4 % faster; one process per arm (``benchmarks/experiments/prefetch_ab.py``)
        +1 % and -3 %, inside the 10-20 % spread between processes. Returns
        the bytes collapsed (0 where the kernel cannot: not Linux, older
        than 6.1, or nothing to do).
        """
        t = self._settling
        if t is not None:
            t.join()
        return getattr(t, "collapsed", 0)

    def __copy__(self):
        # a shallow copy shares the huge-page thread (copy() below); pickling and deepcopy drop it
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        return new

    def __getstate__(self):
        # the huge-page thread does not travel: the unpickled arrays are fresh, settle() then returns 0
        state = self.__dict__.copy()
        state["_settling"] = None
        state.pop("_tet", None)  # flat views of the records and the state: made again at the next query
        if self.rec is not None:  # views of the records: made again from the one records array on arrival
            del state["nodes"], state["starts"]
            if self.dyn is self.rec:  # (a copy keeps its state in its own array)
                del state["dyn"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        if self.rec is not None:
            # the kernels write stamps through dyn and read nodes and edge-list starts in the same records:
            # pickled apart they would be three separate copies
            ost = _k.record_layout(self.nn, self.ne)[2]
            self.nodes = self.rec[:, _k.R_NODES:_k.R_NODES + self.nn]
            self.starts = self.rec[:, ost:ost + self.ne]
            if "dyn" not in state:
                self.dyn = self.rec

    def copy(self):
        """A builder sharing the records and incidence tables, with its own stamps, states, slots and buffers.

        The records are only read by a query whose stamps, states and slots
        live elsewhere: the copy keeps those in an (M, 2 + slots) int32 array
        (24 bytes per tetrahedron, 88 per hexahedron) instead of a second
        set of records. Two builders can run queries at the same time in two
        threads (the kernels release the GIL);
        :meth:`EdgeCentredMethod.extract_many` does that.
        """
        new = copy.copy(self)
        new.dyn = np.zeros((self.dyn.shape[0], 2 + self.n_slots), np.int32)
        new.ds = 2
        new.generation = 0
        new._queue = _jit.scratch_like(self._queue)
        new._tris = _jit.scratch_like(self._tris)
        new._tri_cell = _jit.scratch_like(self._tri_cell)
        new._vkey = _jit.scratch_like(self._vkey)
        new._vend = _jit.scratch_like(self._vend)
        new._pos = new._acc = None  # made at its first query
        new._fcode = new._fval = None
        new._ev = None
        new.stats = {}
        return new

    def _nc(self):
        """``(nc_off, nc)``: the cells around each node (empty arrays until :meth:`_build_node_cells`)."""
        got = self._node_cells.get("nc")
        return got if got is not None else (_EMPTY_I32, _EMPTY_I32)

    def _build_node_cells(self):
        """The cells around each node with the node's local index in each (int32, packed as ``ec``)."""
        if "nc" not in self._node_cells:
            nc_off, order_ = csr_from_keys(np.ascontiguousarray(self.vol.cells).ravel(), self.vol.n_points)
            if nc_off[-1] > _INT32_MAX:
                raise IsoSurfaceError("edge-centred construction supports up to 2**31 cell nodes")
            self._node_cells["nc"] = (nc_off.astype(np.int32), _k.pack_incidence(nc_off, order_, self.nn))

    @property
    def node_gradients(self):
        if self._node_grad is None:
            self._node_grad = node_gradients(self.vol, self.s)
        return self._node_grad

    def _check_seeds(self, seeds):
        seeds = np.atleast_1d(np.asarray(seeds))
        if seeds.ndim != 1:
            raise IsoSurfaceError(f"seeds must be a 1-D array of cell ids; got shape {seeds.shape}")
        if seeds.size and not np.issubdtype(seeds.dtype, np.integer):
            raise IsoSurfaceError(f"seeds must be integer cell ids; got dtype {seeds.dtype}")
        m = self.dyn.shape[0]
        if seeds.size and (seeds.min() < 0 or seeds.max() >= m):
            bad = seeds[(seeds < 0) | (seeds >= m)]
            raise IsoSurfaceError(f"seed cells must be in 0..{m - 1}; got {bad[:5].tolist()}")
        return np.ascontiguousarray(seeds, np.int32)

    def crossed_estimate(self, value):
        """About how many cells the surface ``S = value`` crosses, in microseconds.

        From a fixed sample of :attr:`SPAN_SAMPLE` cells (seeded, made at the
        first call: their smallest and largest node values, sorted, 16 bytes
        per sampled cell; every cell when there are fewer): a cell is crossed
        when its smallest value is below ``value`` and its largest is not, so
        the count is ``#(min < value) - #(max < value)``, two binary searches,
        scaled to all the cells. Its standard error is about
        ``sqrt(k) * M / SPAN_SAMPLE`` for ``k`` sampled cells crossed.
        """
        smp = self.__dict__.get("_span")
        if smp is None or smp[0] is not self.s:
            m = self.dyn.shape[0]
            k = min(m, self.SPAN_SAMPLE)
            idx = np.arange(m) if k == m else np.random.default_rng(0).integers(0, m, k)
            x = self.s[self.nodes[idx]]
            smp = self._span = (self.s, np.sort(x.min(axis=1)), np.sort(x.max(axis=1)), m / max(k, 1))
        _, lo, hi, scale = smp
        return float(np.searchsorted(lo, value, "left") - np.searchsorted(hi, value, "left")) * scale

    def _auto_threads(self, value):
        """The thread count of a ``threads="auto"`` query (see the class docstring)."""
        import numba

        n = min(numba.get_num_threads(), _cpus())
        if n < 2 or not _k.ATOMICS or self.crossed_estimate(value) < self.PARALLEL_MIN_CELLS:
            return 1
        if not _overlap_safe():  # workqueue: two Python threads' parallel queries would abort
            return 1
        busy = _busy()
        if busy is None:
            return n
        return max(1, min(n, int(_cpus() - busy)))

    def _next_generation(self, n=1):
        """The first of ``n`` new generations (a parallel query takes one per thread)."""
        if self.generation > _INT32_MAX - n:  # once in 2**31 queries: really clear the stamps
            self.dyn[:, _k.R_GEN] = 0
            self.generation = 0
        self.generation += n
        return self.generation - n + 1

    def extract(self, value, seeds, *, normals="mean", threads=None, canonical=False):
        """The isosurface reached from ``seeds``, built without any vertex search.

        Parameters
        ----------
        value : float
            The isovalue ``C`` (nodes with ``S >= C`` are above).
        seeds : (K,) int
            Cells to start from; the ones the surface does not cross are skipped.
        normals : {"mean", "gradient", None}, keyword-only
            As in :func:`polygen.volume.isosurface.extract`.
        threads : int or "auto", optional, keyword-only
            Threads for this query (default: the builder's ``threads``,
            ``"auto"`` unless set; see the class docstring); more than 1 runs
            the parallel construction (:meth:`_extract_parallel`): the same
            triangles and vertices, in another order (:func:`canonical_order`
            gives one order for both).
        canonical : bool, keyword-only
            Return the surface in :func:`canonical_order` (vertices by key,
            triangles by cell): the same arrays whatever the thread count
            and queue order.

        Returns
        -------
        IsoSurface
            ``method == "edge-centred-table"``; ``vertex_lookups`` 0 (no
            read of a vertex by a key; ``stats["slot_reads"]`` counts the
            slot reads);
            ``cells_tested`` counts the seeds tested and the cells whose
            case was computed by the construction; ``t1`` the seed tests,
            ``t2`` the construction (for-loops (1)-(3) with the triangle
            list), ``t3`` positions and normals. (Tetrahedra with records,
            LIFO, one thread: the construction kernel writes the positions
            and sums the mean normals as it goes, so ``t2`` includes them and
            ``t3`` is their copy out and the normalisation.)
        """
        if canonical:
            return canonical_order(self.extract(value, seeds, normals=normals, threads=threads))
        value = check_value(value)
        check_normals(normals)
        seeds = self._check_seeds(seeds)
        threads = self.threads if threads is None else _check_threads(threads, auto=True)
        if threads == "auto":
            threads = self._auto_threads(value)
        node_grad = self.node_gradients if normals == "gradient" else None
        if threads > 1 and _k.ATOMICS:  # without compare-and-swap, one thread
            return self._extract_parallel(value, seeds, normals, node_grad, threads)
        restarts = 0
        counters = np.zeros(_k.N_COUNTERS, np.int64)
        lifo = self.order == "lifo"
        while True:
            gen = self._next_generation()
            t0 = time.perf_counter()
            if self._queue.shape[0] < seeds.shape[0]:
                self._queue = _jit.scratch(2 * seeds.shape[0], np.int32)
            tested, n_queued = _k.test_seeds(self.nodes, self.dyn, self.nn, self.s, value, self.faces, seeds, gen,
                                             self._queue)
            t1 = time.perf_counter() - t0
            t0 = time.perf_counter()
            status, n_p, n_t, n_v, any_node, fused = self._construct(value, gen, n_queued, lifo, counters,
                                                                      normals == "mean")
            if status == _k.OK:
                break
            restarts += 1  # a buffer was too small (or a table missing): grow (build) it and do the query again
            if status == _k.FULL_QUEUE:
                self._queue = _jit.scratch(2 * self._queue.shape[0], np.int32)
            elif status == _k.FULL_TRIANGLES:
                cap = 2 * self._tris.shape[0]
                self._tris = _jit.scratch((cap, 3), np.int32)
                self._tri_cell = _jit.scratch(cap, np.int32)
            elif status == _k.NEED_NODE_CELLS:
                self._build_node_cells()
            else:
                cap = 2 * self._vkey.shape[0]
                self._vkey = _jit.scratch(cap, np.int32)
                self._vend = _jit.scratch((cap, 2), np.int32)
        tri = _jit.astype(self._tris[:n_t], np.int64, output=True)  # the user's arrays: on recycled buffers
        tri_cell = _jit.astype(self._tri_cell[:n_t], np.int64, output=True)
        keys = _jit.astype(self._vkey[:n_v], np.int64, output=True)
        vend = self._vend[:n_v]
        tri, tri_cell, keys, vend, collapsed = _drop_at_nodes(any_node, tri, tri_cell, keys, vend, self.n_edges)
        fused = fused and keys.shape[0] == n_v  # positions and normal sums of the vertices kept, in their order
        n_v = keys.shape[0]
        t2 = time.perf_counter() - t0

        t0 = time.perf_counter()
        vertices = _jit.output_empty((n_v, 3))
        if fused:
            vertices[...] = self._pos[:n_v]
        elif n_v:
            _k.positions(np.ascontiguousarray(vend), n_v, self.points, self.s, value, vertices)
        nrm = vertex_normals(normals, vertices, tri, keys, edges=np.ascontiguousarray(self.vol.edges), s=self.s,
                             value=value, node_grad=node_grad, points=self.points,
                             mean_sums=self._acc if fused and normals == "mean" and not any_node else None)
        t3 = time.perf_counter() - t0

        self.stats = {
            "pops": int(counters[_k.C_POPS]),
            "visits": int(counters[_k.C_VISITS]),
            "touched": int(counters[_k.C_TOUCHED]),
            "constructed": int(counters[_k.C_CONSTRUCTED]),
            "node_tests": int(counters[_k.C_NODE_TESTS]),
            "node_vertices": int(counters[_k.C_NODE_VERTICES]),
            "seeds_tested": int(tested),
            "seeds_crossed": int(n_queued),
            "lookups": 0,  # keyed reads of a vertex: the kernels have none (a vertex is read from its slot)
            "slot_reads": int(counters[_k.C_SLOT_READS]),
            "restarts": restarts,
            "collapsed": tuple(map(tuple, collapsed.tolist())),
            "threads": 1,
        }
        return IsoSurface(
            value=value, vertices=vertices, triangles=tri, normals=nrm, vertex_keys=keys, triangle_cells=tri_cell,
            cells_tested=int(tested + counters[_k.C_TOUCHED]),
            cells_intersected=int(n_p), vertex_lookups=0, t1=t1, t2=t2, t3=t3,
            method=self.method,
        )

    def _construct(self, value, gen, n_queued, lifo, counters, mean):
        """t2 by the serial kernel that fits: ``_k.construct_tet`` (tetrahedra, records, LIFO) or ``_k.construct``.

        Both build the same polygons, vertices and triangles in the same
        order; the first is the generic one specialised (see its docstring),
        which also writes the vertices' positions into ``self._pos`` and, with
        ``mean``, their summed triangle normals into ``self._acc`` (query
        buffers of this builder, as many rows as ``self._vkey``). Returns the
        kernel's ``(status, n_polygons, n_triangles, n_vertices,
        any_node_vertex)`` and whether those two were written.
        """
        if lifo and self._specialised():
            cap = self._vkey.shape[0]
            if getattr(self, "_pos", None) is None or self._pos.shape[0] < cap:
                self._pos = _jit.scratch((cap, 3))
                self._acc = _jit.scratch((cap, 3))
            bufs = (self._tris, self._vend, self.points, self._pos, self._acc)
            if not all(a.flags.c_contiguous for a in bufs):  # flat views, written through (never a copy)
                raise AssertionError("a query buffer is not contiguous")  # never: they are all made whole
            flat = [a.reshape(-1) for a in bufs]
            rec1, dyn1, dw, slots = self._tet_views()
            return (*_k.construct_tet(rec1, dyn1, dw, self.ds, self.nodes, self.dyn, self.s, value, self.faces,
                                      self.table, self.count, self.case_mask, slots, self.local_edges, self.n_edges,
                                      self.ec, *self._nc(), gen, self._queue, n_queued, flat[0], self._tri_cell,
                                      self._vkey, flat[1], counters, flat[2], flat[3], flat[4], mean),
                    True)
        return *_k.construct(
            self.nodes, self.ids, self.starts, self.dyn, self.ds, self.nn, self.s, value, self.faces,
            self.table, self.count,
            self.case_mask, self.local_edges, self.n_edges, self.ec_off, self.ec, *self._nc(), gen,
            self._queue, n_queued, lifo, self._tris, self._tri_cell, self._vkey, self._vend, counters), False

    def _tet_views(self):
        """``(rec, dyn, dw, tri_slots)``: flat views of the records and of this builder's state, its row width,
        and :func:`_edge_centred_kernels.tet_triangle_slots` (made once per state array), for the tetrahedron
        kernels."""
        tet = self.__dict__.get("_tet")
        if tet is None or tet[0] is not self.dyn:
            rec1, dyn1 = self.rec.view(), self.dyn.view()
            rec1.shape = dyn1.shape = (-1,)  # views (an assignment to shape never copies)
            tet = self._tet = (self.dyn, rec1, dyn1, self.dyn.shape[1],
                               _k.tet_triangle_slots(self.table, self.count, self.case_mask))
        return tet[1:]

    def _specialised(self):
        """Whether queries run the tetrahedron kernels (tetrahedra with records; :attr:`SPECIALISED_KERNEL`)."""
        return self.nn == 4 and self.rec is not None and self.SPECIALISED_KERNEL

    def _parallel_buffers(self, threads, tet=False):
        """The serial buffers seen as ``threads`` per-thread parts, and the vertex-id array ``ev`` (made once).

        The parallel construction runs in the serial one's query buffers (a
        builder serves one query at a time): thread ``t`` gets the ``t``-th
        of ``threads`` equal parts of the queue (its stack), the triangle
        list and the vertex lists; an overflow doubles the whole buffer, as
        in the serial path. ``ev`` (n_edges + n_nodes,) int32, -1 between
        queries: the vertex id of a contested edge or node, decided by
        compare-and-swap. With ``tet`` (the tetrahedron kernel) also the
        parts of the positions and normal sums (``_pos``, ``_acc``, as many
        rows as the vertex lists) and of the normal terms for other threads'
        vertices (``_fcode``, ``_fval``); returns ``(stack, tris, tri_cell,
        vkey, vend)`` and, with ``tet``, ``(pos, acc, fcode, fval)`` after them.
        """
        if getattr(self, "_ev", None) is None:
            self._ev = np.full(self.n_edges + self.vol.n_points, -1, np.int32)
        mt = _m.MAX_TRIANGLES
        q = self._queue.shape[0] // threads
        tc = self._tris.shape[0] // threads
        vc = self._vkey.shape[0] // threads
        while q < 16 or tc < mt + 16 or vc < 16:  # parts too small for a polygon: grow them first
            self._queue = _jit.scratch(2 * max(16 * threads, self._queue.shape[0]), np.int32)
            self._tris = _jit.scratch((2 * max((mt + 16) * threads, self._tris.shape[0]), 3), np.int32)
            self._tri_cell = _jit.scratch(self._tris.shape[0], np.int32)
            self._vkey = _jit.scratch(2 * max(16 * threads, self._vkey.shape[0]), np.int32)
            self._vend = _jit.scratch((self._vkey.shape[0], 2), np.int32)
            q, tc, vc = self._queue.shape[0] // threads, self._tris.shape[0] // threads, self._vkey.shape[0] // threads
        out = (self._queue[:q * threads].reshape(threads, q), self._tris[:tc * threads].reshape(threads, tc, 3),
               self._tri_cell[:tc * threads].reshape(threads, tc), self._vkey[:vc * threads].reshape(threads, vc),
               self._vend[:vc * threads].reshape(threads, vc, 2))
        if not tet:
            return out
        cap = self._vkey.shape[0]
        if getattr(self, "_pos", None) is None or self._pos.shape[0] < cap:
            self._pos = _jit.scratch((cap, 3))
            self._acc = _jit.scratch((cap, 3))
        if getattr(self, "_fcode", None) is None:  # contested vertices are a few per cent: an eighth of the triangles
            self._fcode = _jit.scratch(max(64 * threads, self._tris.shape[0] // 8), np.int32)
            self._fval = _jit.scratch((self._fcode.shape[0], 3))
        fc = self._fcode.shape[0] // threads
        while fc < 3 * mt:
            self._fcode = _jit.scratch(2 * max(3 * mt * threads, self._fcode.shape[0]), np.int32)
            self._fval = _jit.scratch((self._fcode.shape[0], 3))
            fc = self._fcode.shape[0] // threads
        return out + (self._pos[:vc * threads].reshape(threads, vc, 3),
                      self._acc[:vc * threads].reshape(threads, vc, 3),
                      self._fcode[:fc * threads].reshape(threads, fc),
                      self._fval[:fc * threads].reshape(threads, fc, 3))

    def _fit_parts(self, threads, counters):
        """Grow the buffers (for the next query) until each thread's part could hold all of this surface.

        How the work splits between the threads depends on the scheduler, so
        a surface that fitted may not fit a part the next time unless every
        part holds it whole: without this, a repeated query could restart.
        The buffers then hold ``threads`` times the largest surface so far.
        The lists of normal terms for other threads' vertices (tetrahedron
        kernel) grow to twice this query's total per part (their length
        depends on the split too; an overflow only restarts the query).
        """
        pops, n_t, n_v = int(counters[:, 4].sum()), int(counters[:, 0].sum()), int(counters[:, 1].sum())
        if self._queue.shape[0] // threads < pops:
            self._queue = _jit.scratch(threads * pops, np.int32)
        if self._tris.shape[0] // threads < n_t + _m.MAX_TRIANGLES:
            self._tris = _jit.scratch((threads * (n_t + _m.MAX_TRIANGLES), 3), np.int32)
            self._tri_cell = _jit.scratch(self._tris.shape[0], np.int32)
        if self._vkey.shape[0] // threads < n_v:
            self._vkey = _jit.scratch(threads * n_v, np.int32)
            self._vend = _jit.scratch((self._vkey.shape[0], 2), np.int32)
        n_f = 2 * int(counters[:, _k.N_PAR_COUNTERS - 1].sum()) + 3 * _m.MAX_TRIANGLES
        if getattr(self, "_fcode", None) is not None and self._fcode.shape[0] // threads < n_f:
            self._fcode = _jit.scratch(threads * n_f, np.int32)
            self._fval = _jit.scratch((self._fcode.shape[0], 3))

    def _extract_parallel(self, value, seeds, normals, node_grad, threads, interleave=0):
        """:meth:`extract` by ``threads`` threads (``_edge_centred_kernels.construct_parallel``, or
        ``construct_tet_parallel`` for tetrahedra with records).

        ``interleave > 0`` (tests): the threads' shares run on this thread
        instead, taking turns of ``interleave`` cells each -- a deterministic
        race between them, whatever the machine's scheduler does.
        """
        nn, s = self.nn, self.s
        tet = self._specialised()
        mean = normals == "mean"
        restarts = 0
        causes = []
        while True:
            parts = self._parallel_buffers(threads, tet)
            stack, tris, tri_cell, vkey, vend = parts[:5]
            gen = self._next_generation(threads)  # thread t claims with gen + t
            counters = np.zeros((threads, _k.N_PAR_COUNTERS), np.int64)
            status = np.zeros(threads, np.int64)
            next_seed = np.zeros(1, np.int64)
            t0 = time.perf_counter()
            if tet:
                rec1, dyn1, dw, slots = self._tet_views()
                nc_off, nc = self._nc()
                args = (rec1, dyn1, dw, self.ds, self.nodes, self.dyn, s, value, self.faces, self.table, self.count,
                        self.case_mask, slots, self.local_edges, self.n_edges, self.ec, nc_off, nc, gen, seeds,
                        next_seed, self._ev, stack, tris, tri_cell, vkey, vend, self.points, *parts[5:], mean,
                        counters)
                flood, kernel = _k._flood_tet, _k.construct_tet_parallel
            else:
                args = (self.nodes, self.ids, self.starts, self.dyn, self.ds, nn, s, value, self.faces, self.table,
                        self.count, self.case_mask, self.local_edges, self.n_edges, self.ec_off, self.ec, *self._nc(),
                        gen, seeds, next_seed, self._ev, stack, tris, tri_cell, vkey, vend, counters)
                flood, kernel = _k._flood, _k.construct_parallel
            if interleave:
                status[:] = _k.PAUSED
                while (status == _k.PAUSED).any():
                    for t in np.flatnonzero(status == _k.PAUSED):
                        status[t] = flood(t, *args, interleave)
            else:
                kernel(*args, status)
            _k.release_contested(vkey, counters, self._ev)  # ev back to -1 where a thread won a vertex
            if not status.any():
                break
            restarts += 1  # a buffer was too small (or a table missing): grow (build) it and do the query again
            worst = int(status[status != _k.OK][0])
            causes.append(worst)
            if worst == _k.FULL_QUEUE:
                self._queue = _jit.scratch(2 * self._queue.shape[0], np.int32)
            elif worst == _k.FULL_TRIANGLES:
                self._tris = _jit.scratch((2 * self._tris.shape[0], 3), np.int32)
                self._tri_cell = _jit.scratch(self._tris.shape[0], np.int32)
            elif worst == _k.NEED_NODE_CELLS:
                self._build_node_cells()
            elif worst == _k.FULL_FOREIGN:
                self._fcode = _jit.scratch(2 * self._fcode.shape[0], np.int32)
                self._fval = _jit.scratch((self._fcode.shape[0], 3))
            else:
                self._vkey = _jit.scratch(2 * self._vkey.shape[0], np.int32)
                self._vend = _jit.scratch((self._vkey.shape[0], 2), np.int32)
        self._fit_parts(threads, counters)
        t_base = np.zeros(threads + 1, np.int64)
        t_base[1:] = np.cumsum(counters[:, 0])
        v_base = np.zeros(threads + 1, np.int64)
        v_base[1:] = np.cumsum(counters[:, 1])
        n_t, n_v = int(t_base[-1]), int(v_base[-1])
        n_node_v = int(counters[:, 7].sum())
        tri = _jit.output_empty((n_t, 3), np.int64)  # the user's arrays: on recycled buffers (polygen._jit)
        tri_cell_out = _jit.output_empty(n_t, np.int64)
        keys = _jit.output_empty(n_v, np.int64)
        ends = _jit.output_empty((n_v, 2), np.int32)  # a temporary: back to the pool at the return
        # the tetrahedron kernel's positions and mean normals, unless vertices on nodes are dropped below
        fused = tet and n_node_v == 0
        if tet:
            vertices = _jit.output_empty((n_v, 3))
            unit = _jit.output_empty((n_v, 3)) if mean else vertices[:0]
            n_zero = np.zeros(threads, np.int64)
            _k.gather_tet_parallel(tris, tri_cell, vkey, vend, *parts[5:9], counters, t_base, v_base, mean and fused,
                                   tri, tri_cell_out, keys, ends, vertices, unit, n_zero)
        else:
            _k.gather_parallel(tris, tri_cell, vkey, vend, counters, t_base, v_base, tri, tri_cell_out, keys, ends)
        tri, tri_cell_out, keys, ends, collapsed = _drop_at_nodes(n_node_v > 0, tri, tri_cell_out, keys, ends,
                                                                  self.n_edges)
        n_v = keys.shape[0]
        t2 = time.perf_counter() - t0

        t0 = time.perf_counter()
        mean_kernel = mean_done = None
        if fused:
            if mean:
                mean_done = (unit, int(n_zero.sum()))
        else:
            vertices = _jit.output_empty((n_v, 3))
            if n_t >= self.STAGE3_PARALLEL_TRIANGLES:  # positions and mean normals by the threads too
                if n_v:
                    _k.positions_parallel(np.ascontiguousarray(ends), n_v, self.points, s, value, vertices)

                def mean_kernel(v, t, out):
                    _k.mean_normals_parallel(v, t, out, _jit.scratch((threads - 1, v.shape[0], 3)))
            elif n_v:
                _k.positions(np.ascontiguousarray(ends), n_v, self.points, s, value, vertices)
        nrm = vertex_normals(normals, vertices, tri, keys, edges=np.ascontiguousarray(self.vol.edges), s=s,
                             value=value, node_grad=node_grad, points=self.points, mean_kernel=mean_kernel,
                             mean_done=mean_done)
        t3 = time.perf_counter() - t0
        n_p = int(counters[:, 3].sum())
        tested = int(counters[:, 5].sum())
        self.stats = {
            "pops": int(counters[:, 4].sum()),
            "constructed": n_p,
            "cells_tested": tested,
            "contested": int(counters[:, 6].sum()),
            "node_vertices": n_node_v,
            "lookups": 0,
            "restarts": restarts,
            "collapsed": tuple(map(tuple, collapsed.tolist())),
            "restart_causes": tuple(causes),
            "threads": threads,
            "per_thread": tuple(int(x) for x in counters[:, 4]),
            "kernel": "tetrahedra" if tet else "generic",
            "foreign_terms": int(counters[:, _k.N_PAR_COUNTERS - 1].sum()),
        }
        return IsoSurface(
            value=value, vertices=vertices, triangles=tri, normals=nrm, vertex_keys=keys, triangle_cells=tri_cell_out,
            cells_tested=tested, cells_intersected=n_p, vertex_lookups=0, t1=0.0, t2=t2, t3=t3, method=self.method,
        )

    def memory_bytes(self):
        """Bytes this builder holds beyond the volume's points, cells and field, by array.

        ``records`` (stamp, state, node copies, vertex slots and edge ids
        per cell: 64 bytes per tetrahedron, 192 per hexahedron; shared with
        the copies), ``query_state`` (a copy's own stamps, states and
        slots: 24 bytes per tetrahedron), ``edge_cells`` (the packed list of
        the cells around each edge, 4 bytes per cell edge) and
        ``edge_cells_offsets`` (where each edge's list starts, int32),
        ``node_cells`` (offsets and packed list, once built), ``edge_list``
        (the volume's ``edges``, read by stage 3 for gradient normals and
        degenerate ones; its ``cell_edges`` serve the preparation only),
        ``buffers`` (queue, triangles, vertex keys and ends at their
        current sizes, with the positions and normal sums of the tetrahedron
        kernels and, after a parallel query on tetrahedra, the lists of
        normal terms passed between its threads; a parallel query cuts them
        into one part per thread); after a ``threads="auto"`` query on a
        volume of more cells than :attr:`SPAN_SAMPLE`, ``span_sample`` (its
        sorted value ranges, 16 bytes per sampled cell);
        after a query with ``threads > 1`` also ``parallel`` (the id of a
        contested vertex per edge and node, int32, -1 between queries).
        """
        vol = self.vol
        out = {
            "records": 0 if self.rec is None else int(self.rec.nbytes),
            "edge_cells": int(self.ec.nbytes),
            "edge_list": int(vol.edges.nbytes),
            "buffers": int(self._queue.nbytes + self._tris.nbytes + self._tri_cell.nbytes + self._vkey.nbytes
                           + self._vend.nbytes
                           + sum(getattr(self, a).nbytes for a in ("_pos", "_acc", "_fcode", "_fval")
                                 if getattr(self, a, None) is not None)),
        }
        if self.ec_off.size:
            out["edge_cells_offsets"] = int(self.ec_off.nbytes)
        if self.dyn is not self.rec:
            out["query_state"] = int(self.dyn.nbytes)
        if "nc" in self._node_cells:
            out["node_cells"] = int(sum(a.nbytes for a in self._node_cells["nc"]))
        if getattr(self, "_ev", None) is not None:
            out["parallel"] = int(self._ev.nbytes)
        if self.__dict__.get("_span") is not None:
            out["span_sample"] = int(self._span[1].nbytes + self._span[2].nbytes)
        return out


class EdgeCentredWalk:
    """The paper's cell-edge-centred construction: no stored cell edges, on one volume and field.

    As the paper states it (2.1, 3.1, Fig. 5): the volume keeps its nodes,
    its cells and their face neighbours; cell edges are neither numbered
    nor stored, and there is no edge -> cells index. When a vertex is
    created on an edge of the cell taken from the FIFO, for-loop (3) finds
    the cells around that edge by walking from face neighbour to face
    neighbour around it (:mod:`._edge_walk_kernels`), constructs the
    missing polygons, queues their cells and registers the vertex into
    each; nothing is looked up later.

    Preparing copies each cell's nodes and face neighbours into one record
    with its stamp, state and vertex slots (O(n)); every query reuses the
    stamps and buffers, so one builder serves one thread at a time
    (:meth:`copy` gives a builder for another thread).

    Parameters
    ----------
    vol : UnstructuredVolume
        Tetrahedra or hexahedra, conforming. Where the cells around an edge
        or a node are not connected through faces (a non-manifold edge or
        node on the boundary), each side makes the vertex and the copies
        are merged after the construction (see :mod:`._edge_walk_kernels`).
    field : str or (N,) float64, optional
        Field name or node values (the volume's first field by default).
    order : {"fifo", "lifo"}, keyword-only
        Which queued cell for-loop (1) takes next (the paper's FIFO, or the
        newest); the same surface either way.
    vertex_keys : {"edge-ids", "node-pairs"}, keyword-only
        What the result's ``vertex_keys`` are. The construction knows a
        vertex by its edge's two nodes; ``"edge-ids"`` (the
        :class:`~polygen.volume.surface.IsoSurface` convention every other
        method follows) then names each vertex by the volume's edge id, a
        labelling step after t3, timed apart as ``stats["t_label"]``, that
        uses the volume's edge list (built by the volume on first use).
        ``"node-pairs"`` keeps ``a * n_points + b`` (``a < b``; ``n_points**2
        + node`` for a node) and never touches an edge list.
    search : bool, keyword-only
        A deliberately searching variant, for checking the look-up counter:
        every polygon vertex is looked up by its edge's nodes in a hash
        table (stamped, reference [12]'s way) instead of read from its slot.
        The same surface, ``vertex_lookups > 0``.

    Attributes
    ----------
    stats : dict
        Counters of the last query: ``pops``, ``visits`` (cells visited by
        for-loop (3)), ``walk_steps`` (face crossings of the walks round
        the edges), ``touched``, ``constructed``, ``node_tests``,
        ``node_vertices``, ``seeds_tested``, ``seeds_crossed``, ``lookups``
        and ``probes`` (hash slots inspected; both 0 unless ``search``),
        ``restarts``, ``collapsed`` (as :class:`EdgeCentredTable`),
        ``open_walks`` (vertices whose walk ended at the boundary both ways,
        or on a node), ``merged_non_manifold`` (vertices made again on the
        other side of a non-manifold edge or node, and merged), ``t_label`` (s).
    preprocess_s : float
        Seconds to build the records.
    """

    method = "edge-centred"

    def __init__(self, vol, field=None, *, order="lifo", vertex_keys="edge-ids", search=False):
        t0 = time.perf_counter()
        if order not in ("fifo", "lifo"):
            raise IsoSurfaceError(f"order must be 'fifo' or 'lifo'; got {order!r}")
        if vertex_keys not in ("edge-ids", "node-pairs"):
            raise IsoSurfaceError(f"vertex_keys must be 'edge-ids' or 'node-pairs'; got {vertex_keys!r}")
        self.order = order
        self.vertex_keys = vertex_keys
        self.search = bool(search)
        self.vol = vol
        points, cells, s, cell_type = volume_arrays(vol, field)
        m, nn = cells.shape
        if m > _INT32_MAX or vol.n_points > _INT32_MAX:
            raise IsoSurfaceError("edge-centred construction needs fewer than 2**31 cells and nodes")
        self.n_points = int(vol.n_points)
        self.points = np.ascontiguousarray(points, np.float64)
        self.s = s
        self.cell_type = cell_type
        self.nn = nn
        self.table, self.count, self.local_edges, self.faces = _m.local_tables(cell_type)
        self.case_mask = _k.case_masks(self.table, self.count)
        local_faces = np.ascontiguousarray(vol.local_faces, np.int64)
        self.edge_faces, self.edge_of, self.node_faces = _w.walk_tables(self.local_edges, local_faces)
        nbrs = vol.face_neighbors
        self.nf = nbrs.shape[1]
        self.rec = _jit.scratch((m, _w.record_width(nn, self.nf, self.local_edges.shape[0])), np.int32)
        _w.fill_records(self.rec, np.ascontiguousarray(cells), np.ascontiguousarray(nbrs))
        # stamps, states and slots: in the records for this builder (a copy keeps its own)
        self.n_slots = self.local_edges.shape[0] + nn
        self.dyn, self.ds = self.rec, _k.R_NODES + nn + self.nf
        self.generation = 0
        self._node_grad = None
        self._labels = EdgeLabels(vol)
        self._queue, self._tris, self._tri_cell, self._vkey, self._vend = _output_buffers(m, np.int64)
        self._open = _jit.scratch(self._vkey.shape[0], np.int32)  # vertices a non-manifold edge may make twice
        self._around = _jit.scratch(256, np.int32)
        self._around_local = _jit.scratch(256, np.int32)
        # open addressing needs a power of two (the probe wraps with a bit mask)
        cap = 1 << int(2 * self._vkey.shape[0] - 1).bit_length() if self.search else 1
        self._htable = np.zeros((cap, 2), np.int64)
        self.stats = {}
        self.preprocess_s = time.perf_counter() - t0

    def copy(self):
        """A builder for a query in another thread: the records shared, its own stamps, states, slots, buffers.

        The copy keeps its stamps, states and slots in an (M, 2 + slots)
        int32 array (48 bytes per tetrahedron) and only reads the records.
        """
        new = copy.copy(self)
        new.dyn = np.zeros((self.rec.shape[0], 2 + self.n_slots), np.int32)
        new.ds = 2
        new.generation = 0
        for name in ("_queue", "_tris", "_tri_cell", "_vkey", "_vend", "_open", "_around", "_around_local"):
            setattr(new, name, _jit.scratch_like(getattr(self, name)))
        new._htable = np.zeros_like(self._htable)
        new.stats = {}
        return new

    @property
    def node_gradients(self):
        if self._node_grad is None:
            self._node_grad = node_gradients(self.vol, self.s)
        return self._node_grad

    _check_seeds = EdgeCentredTable._check_seeds

    def _next_generation(self):
        if self.generation == _INT32_MAX:  # once in 2**31 queries: really clear the stamps
            self.dyn[:, _k.R_GEN] = 0
            self._htable[:] = 0
            self.generation = 0
        self.generation += 1
        return self.generation

    def edge_ids(self, pair_keys):
        """The volume's edge ids (``n_edges + node`` for a node) of vertices known by their pair keys."""
        return self._labels(pair_keys)

    def extract(self, value, seeds, *, normals="mean"):
        """The isosurface reached from ``seeds``, the cells around each edge found by walking.

        Parameters
        ----------
        value : float
            The isovalue ``C`` (nodes with ``S >= C`` are above).
        seeds : (K,) int
            Cells to start from; the ones the surface does not cross are skipped.
        normals : {"mean", "gradient", None}, keyword-only

        Returns
        -------
        IsoSurface
            ``method == "edge-centred"``; ``vertex_lookups`` as the kernel
            counted them (none unless ``search``); ``t1`` the seed tests,
            ``t2`` for-loops (1)-(3) with the triangle list, ``t3``
            positions and normals (the labelling by edge id is not in
            them: ``stats["t_label"]``).
        """
        value = check_value(value)
        check_normals(normals)
        seeds = self._check_seeds(seeds)
        node_grad = self.node_gradients if normals == "gradient" else None
        restarts = 0
        counters = np.zeros(_w.N_COUNTERS, np.int64)
        lifo = self.order == "lifo"
        while True:
            gen = self._next_generation()
            t0 = time.perf_counter()
            if self._queue.shape[0] < seeds.shape[0]:
                self._queue = _jit.scratch(2 * seeds.shape[0], np.int32)
            tested, n_queued = _k.test_seeds(self.rec[:, _k.R_NODES:_k.R_NODES + self.nn], self.dyn, self.nn,
                                             self.s, value, self.faces, seeds, gen, self._queue)
            t1 = time.perf_counter() - t0
            t0 = time.perf_counter()
            status, n_p, n_t, n_v, any_node = _w.construct(
                self.rec, self.dyn, self.ds, self.nn, self.nf, self.n_points, self.s, value, self.faces, self.table,
                self.count,
                self.case_mask, self.local_edges, self.edge_faces, self.edge_of, self.node_faces, gen,
                self._queue, n_queued, lifo, self._tris, self._tri_cell, self._vkey, self._vend, self._open,
                self._around, self._around_local, self.search, self._htable, counters)
            if status == _w.OK:
                break
            if status == _w.BAD_MESH:
                raise IsoSurfaceError(
                    f"walking round an edge or node of cell {int(counters[_w.C_BAD_CELL])} met a face neighbour "
                    "without it: the volume is not a conforming mesh")
            restarts += 1  # a buffer was too small: grow it and do the query again
            if status == _w.FULL_QUEUE:
                self._queue = _jit.scratch(2 * self._queue.shape[0], np.int32)
            elif status == _w.FULL_TRIANGLES:
                cap = 2 * self._tris.shape[0]
                self._tris = _jit.scratch((cap, 3), np.int32)
                self._tri_cell = _jit.scratch(cap, np.int32)
            elif status == _w.FULL_VERTICES:
                cap = 2 * self._vkey.shape[0]
                self._vkey = _jit.scratch(cap, np.int64)
                self._vend = _jit.scratch((cap, 2), np.int32)
                self._open = _jit.scratch(cap, np.int32)
            elif status == _w.FULL_HASH:
                self._htable = np.zeros((2 * self._htable.shape[0], 2), np.int64)
            else:
                self._around = _jit.scratch(2 * self._around.shape[0], np.int32)
                self._around_local = _jit.scratch(2 * self._around.shape[0], np.int32)
        tri = _jit.astype(self._tris[:n_t], np.int64, output=True)
        tri_cell = _jit.astype(self._tri_cell[:n_t], np.int64, output=True)
        pkeys = self._vkey[:n_v].copy()
        vend = self._vend[:n_v]
        # a non-manifold edge or node (two parts touching there only; a partition's seam often has them) is
        # walked round one side at a time, and each side made its vertex: one vertex again
        tri, pkeys, vend, n_merged = _w.merge_open_duplicates(self._open[:int(counters[_w.C_OPEN])], tri, pkeys,
                                                              vend)
        tri, tri_cell, pkeys, vend, collapsed = _drop_at_nodes(any_node, tri, tri_cell, pkeys, vend,
                                                               np.int64(self.n_points) * self.n_points)
        t2 = time.perf_counter() - t0

        t0 = time.perf_counter()
        vertices, nrm = pair_stage3(vend, tri, self.points, self.s, value, normals, node_grad)
        t3 = time.perf_counter() - t0

        t0 = time.perf_counter()
        keys = self.edge_ids(pkeys) if self.vertex_keys == "edge-ids" else pkeys
        t_label = time.perf_counter() - t0
        self.stats = {
            "pops": int(counters[_w.C_POPS]),
            "visits": int(counters[_w.C_VISITS]),
            "walk_steps": int(counters[_w.C_WALK_STEPS]),
            "touched": int(counters[_w.C_TOUCHED]),
            "constructed": int(counters[_w.C_CONSTRUCTED]),
            "node_tests": int(counters[_w.C_NODE_TESTS]),
            "node_vertices": int(counters[_w.C_NODE_VERTICES]),
            "seeds_tested": int(tested),
            "seeds_crossed": int(n_queued),
            "lookups": int(counters[_w.C_LOOKUPS]),
            "probes": int(counters[_w.C_PROBES]),
            "restarts": restarts,
            "collapsed": tuple(map(tuple, collapsed.tolist())),
            "open_walks": int(counters[_w.C_OPEN]),
            "merged_non_manifold": n_merged,
            "t_label": t_label,
        }
        return IsoSurface(
            value=value, vertices=vertices, triangles=tri, normals=nrm, vertex_keys=keys, triangle_cells=tri_cell,
            cells_tested=int(tested + counters[_w.C_TOUCHED]), cells_intersected=int(n_p),
            vertex_lookups=int(counters[_w.C_LOOKUPS]), t1=t1, t2=t2, t3=t3, method=self.method,
        )

    def memory_bytes(self):
        """Bytes this builder holds beyond the volume's points, cells and field, by array.

        ``records`` (stamp, state, node copies, face neighbours, vertex
        slots per cell: 80 bytes per tetrahedron, 144 per hexahedron, shared
        with the copies; ``query_state``: a copy's own stamps, states and
        slots, 48 bytes per tetrahedron, 88 per hexahedron; the
        volume's own ``face_neighbors``, from which they are copied, are
        not needed after preparation), ``buffers`` (queue, triangles,
        vertex keys and ends, the node walk's list, and the hash table of
        ``search``, at their current sizes). No edge table: the labelling
        by edge id (``vertex_keys="edge-ids"``) makes the volume build its
        edge table at the first query; once it has, ``label_index`` (the
        sorted edge codes), ``label_edge_list`` and ``label_cell_edges``
        (the volume's edge list and the cells' edge ids built with it) are
        here.
        """
        out = {
            "records": int(self.rec.nbytes),
            "buffers": int(sum(getattr(self, n).nbytes for n in (
                "_queue", "_tris", "_tri_cell", "_vkey", "_vend", "_open", "_around", "_around_local",
                "_htable"))),
        }
        if self.dyn is not self.rec:
            out["query_state"] = int(self.dyn.nbytes)
        if self._labels.nbytes:
            table = self.vol.__dict__.get("_edge_table")
            out["label_index"] = self._labels.index_nbytes
            out["label_edge_list"] = int(self.vol.edges.nbytes)
            out["label_cell_edges"] = 0 if table is None or table[1] is None else int(table[1].nbytes)
        return out


#: the table variant's name before the paper's own variant (:class:`EdgeCentredWalk`) existed
EdgeCentred = EdgeCentredTable


def edge_centred(vol, value, seeds, *, field=None, normals="mean", table=False):
    """One isosurface by cell-edge-centred construction from ``seeds``.

    A one-off :class:`EdgeCentredWalk` (the paper's: no stored edges), or
    :class:`EdgeCentredTable` with ``table=True``.
    """
    builder = EdgeCentredTable(vol, field) if table else EdgeCentredWalk(vol, field)
    return builder.extract(value, seeds, normals=normals)


# ------------------------------------------------------------------ seed sources
#: seed-source name -> builder ``(vol, field, **params) -> (structure, query)``: the one registry
#: (:mod:`polygen.volume.registry`), filled by the modules that define the sources; the interface
#: itself (:func:`seed_source`, :class:`SeedSource`) is :mod:`polygen.volume.seeds.source`'s
SEED_SOURCES = _registry.SEED_SOURCES


# ------------------------------------------------------------------ the method
#: volumes from this many cells build the edge table and the records beside the seed source
_BESIDE_MIN_CELLS = 200_000


#: numba threads for the edge table and records built beside the thinning: None (numba's count), a
#: number, or "cores left" (those the thinning's two FIFO halves leave, at least one). Measured on two
#: cores, first preparation of a fresh process (``benchmarks/experiments/beside_threads_ab.py``): "cores left" is
#: faster on 2M (0.98 against 1.15 s; the seeds side is the longer one) and slower on 10M (5.47
#: against 4.82 s: the records on one thread become the longer side), so numba's count stays
BESIDE_THREADS = None


def _beside_threads():
    """The numba thread count for the records thread (:data:`BESIDE_THREADS`), or None to leave it as it is."""
    if BESIDE_THREADS is None:
        return None
    import numba

    n = numba.get_num_threads()
    return max(1, n - 2) if BESIDE_THREADS == "cores left" else max(1, min(int(BESIDE_THREADS), n))


def _builds_beside(vol):
    """Whether the edge table and records are built in a second thread while the seeds are prepared."""
    return (getattr(vol, "n_cells", 0) >= _BESIDE_MIN_CELLS and (os.cpu_count() or 1) >= 2
            and hasattr(vol, "_table_lock"))


def _seeds_beside_table(vol, field, seeds, params, order, kw):
    """``(source, builder)``: the seed source in this thread, the :class:`EdgeCentredTable` in another.

    The builder needs only the volume's edge table (built through the
    node -> cells lists), the seed source (volume thinning) the face
    neighbours, the extrema and then a serial FIFO (the cell components,
    boundary groups and boundary check run in a helper thread beside the
    FIFO, :func:`polygen.volume.thinning.thin_volume`): so the node -> cells
    lists and face neighbours are built first (parallel kernels, every
    core), then the edge table and the records in a second thread while the
    thinning runs in this one (on 2M the two sides take about the same CPU
    time; the second thread runs its parallel kernels on
    :data:`BESIDE_THREADS`). Each table is built once and read-only
    afterwards; the results are those of building one after the other (the
    kernels' outputs do not depend on their thread count).
    """
    vol.node_cells  # the edge table and the face neighbours are both matched through it
    vol.face_neighbors
    if not parallel_kernels_may_overlap():  # numba's workqueue layer: one after the other
        return seed_source(vol, field, seeds, **params), EdgeCentredTable(vol, field, order=order, **kw)
    out = {}
    n_threads = _beside_threads()

    def build():
        try:
            if n_threads is not None:  # numba's thread count is per calling thread: this one only
                import numba

                numba.set_num_threads(n_threads)
            out["builder"] = EdgeCentredTable(vol, field, order=order, **kw)
        except BaseException as exc:  # re-raised in the caller's thread
            out["error"] = exc

    thread = threading.Thread(target=build, daemon=True, name="polygen-edge-records")
    thread.start()
    try:
        source = seed_source(vol, field, seeds, **params)
    finally:
        thread.join()
    if "error" in out:
        raise out["error"]
    return source, out["builder"]


class _EdgeCentredMethods(IsosurfaceMethod):
    """Seeds from a skeleton (volume thinning by default), then cell-edge-centred construction.

    The keyword-only parameters after ``vol`` and ``field`` are these.

    Other Parameters
    ----------------
    seeds : str
        Seed source (:func:`seed_source`): ``"auto"`` (thinning), ``"thinning"``,
        ``"extrema-graph"``, ``"span-filter"``, ...
    order : {"fifo", "lifo"}
        Queue discipline of the builder.
    vertex_keys : {"edge-ids", "node-pairs"}
        ``edge-centred`` only: what the surface's vertex keys are
        (:class:`EdgeCentredWalk`; ``"node-pairs"`` stores no edges at all).
    threads : int, "auto" or None
        Threads for one surface (``edge-centred-table`` only; default
        ``"auto"``: several for a large surface while no other program
        competes for the cores, see :class:`EdgeCentredTable`; the other
        method runs one). :meth:`extract_many` runs its values one thread
        each whatever this is.
    **params
        Passed to the seed source.

    Notes
    -----
    After each :meth:`extract`, ``stats`` holds the construction counters
    of the builder's ``stats`` plus ``T_search`` (seed search, s) and
    ``N_cg`` (cells the seed search tested). ``seed_preprocess_s`` is the
    seed source's build time and ``construct_preprocess_s`` the builder's;
    ``preprocess_s`` is both: for ``edge-centred-table`` with thinning seeds
    on a volume of 200,000 cells or more and two or more cores, the edge
    table and records are built in a second thread while the skeleton is
    thinned (:func:`_seeds_beside_table`), so it is less than their sum.
    """

    seeds = "thinning"  # the default; ``seeds=`` names any registered source
    construction = "edge-centred"
    builder_class = None

    def _prepare(self, seeds="auto", order="lifo", threads="auto", layout=None, vertex_keys=None, **params):
        kw = {}
        if vertex_keys is not None:  # the walk's (EdgeCentredWalk); the table's keys are its edge ids
            if self.builder_class is not EdgeCentredWalk:
                raise IsoSurfaceError(f"vertex_keys is the edge-centred method's (no stored edges); {self.name!r} "
                                      f"keys its vertices by edge id; got vertex_keys={vertex_keys!r}")
            kw["vertex_keys"] = vertex_keys
        if self.builder_class is EdgeCentredTable:
            kw["threads"] = threads
            if layout is not None:
                kw["layout"] = layout
        elif not (isinstance(threads, str) and threads == "auto" or threads == 1) or layout is not None:
            raise IsoSurfaceError(f"threads > 1 (one surface by several threads) and layout are the "
                                  f"edge-centred-table method's; {self.name!r} runs one thread on its records; "
                                  f"got threads={threads!r}, layout={layout!r}")
        if self.builder_class is EdgeCentredTable and seeds in ("auto", "thinning") and _builds_beside(self.vol):
            self.source, self.builder = _seeds_beside_table(self.vol, self.field, seeds, params, order, kw)
        else:
            self.source = seed_source(self.vol, self.field, seeds, **params)
            self.builder = self.builder_class(self.vol, self.field, order=order, **kw)
        self.seed_preprocess_s = self.source.preprocess_s
        self.construct_preprocess_s = self.builder.preprocess_s
        self.stats = {}

    def extract(self, value, *, normals="mean"):
        value = check_value(value)
        found = self.source.query(value)
        cells, n_tested, t_search = found.cells, found.n_tested, found.seconds
        iso = self.builder.extract(value, cells, normals=normals)
        self.seed_cells_tested = int(n_tested)
        self.stats = dict(self.builder.stats, T_search=t_search, N_cg=int(n_tested))
        return dataclasses.replace(iso, cells_tested=iso.cells_tested + int(n_tested), t1=iso.t1 + t_search)

    def extract_many(self, values, *, normals="mean", threads=None):
        """Several isosurfaces, up to ``threads`` of them at the same time.

        The seed search runs first for every value (it is tiny); then each
        thread takes the next value and builds it with a builder that shares
        the cell records and keeps its own stamps, states and vertex slots
        (the builder's ``copy``, made once and kept: 24 bytes per tetrahedron
        with the edge table, 48 without, and its query buffers). Every surface is the
        one :meth:`extract` gives; only the wall clock changes. One query is
        a chain of dependent memory reads, so two running side by side on two
        cores take little longer than one.

        Parameters
        ----------
        values : sequence of float
        normals : {"mean", "gradient", None}, keyword-only
        threads : int, optional, keyword-only
            How many at a time, at least 1 (default, ``None``: numba's thread
            count). Never more than ``len(values)`` nor the machine's cores
            (:func:`~polygen.volume.surface.machine_cores`) are used: each
            one keeps a builder (its stamps and query buffers, 24-48 bytes
            per cell and more) that more threads than cores would only hold
            without running it.

        Returns
        -------
        list of IsoSurface
            In the order of ``values`` (empty for no values); ``stats_many``
            holds each one's counters.

        Raises
        ------
        IsoSurfaceError
            ``threads`` is not a whole number >= 1, or a value is not finite.
        """
        threads = check_threads(threads)
        values = check_values(values)
        threads = min(int(threads), len(values), machine_cores())
        if threads < 1:
            return []
        found = [self.source.query(v) for v in values]
        if not hasattr(self, "_builders"):
            self._builders = [self.builder]
        while len(self._builders) < threads:
            self._builders.append(self.builder.copy())
        out = [None] * len(values)
        stats = [None] * len(values)
        lock = threading.Lock()
        nxt = [0]
        errors = []

        def work(builder):
            while not errors:
                with lock:
                    i = nxt[0]
                    nxt[0] += 1
                if i >= len(values):
                    return
                cells, n_tested, t_search = found[i].cells, found[i].n_tested, found[i].seconds
                try:
                    iso = builder.extract(values[i], cells, normals=normals, **one)
                except BaseException as exc:  # re-raised in the caller's thread
                    errors.append(exc)
                    return
                stats[i] = dict(builder.stats, T_search=t_search, N_cg=int(n_tested))
                out[i] = dataclasses.replace(iso, cells_tested=iso.cells_tested + int(n_tested),
                                             t1=iso.t1 + t_search)

        # the values run side by side, each in one thread (parallel kernels are not started from two threads)
        one = {"threads": 1} if isinstance(self.builder, EdgeCentredTable) else {}
        pool = [threading.Thread(target=work, args=(b,)) for b in self._builders[1:threads]]
        for t in pool:
            t.start()
        work(self._builders[0])
        for t in pool:
            t.join()
        if errors:
            raise errors[0]
        self.stats_many = stats
        self.stats = stats[-1]
        self.seed_cells_tested = int(found[-1].n_tested)
        return out


@register
class EdgeCentredMethod(_EdgeCentredMethods):
    """The paper's method: thinning seeds, then the construction without stored edges (:class:`EdgeCentredWalk`)."""

    name = "edge-centred"
    description = ("cell-edge-centred construction without vertex search and without stored cell edges "
                   "(Itoh et al. 2001) from thinning seeds")
    builder_class = EdgeCentredWalk


@register
class EdgeCentredTableMethod(_EdgeCentredMethods):
    """Thinning seeds, then the construction with a stored edge table and edge -> cells index
    (:class:`EdgeCentredTable`)."""

    name = "edge-centred-table"
    description = ("cell-edge-centred construction without vertex search, cells around an edge from a stored "
                   "edge table, from thinning seeds")
    builder_class = EdgeCentredTable
    construction = "edge-centred-table"
