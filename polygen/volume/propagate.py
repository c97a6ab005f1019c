"""Isosurface propagation from seed cells (thesis 5.4.2, Fig. 5.7).

The algorithm, as the thesis gives it:

1. register the seed cells that the isosurface crosses in a FIFO queue and
   mark them "processed";
2. until the queue is empty: take a cell, find its crossed edges, look each
   polygon vertex up in a hash table keyed by the cell edge (create it if
   it is not there), make the cell's polygons (marching tetrahedra /
   hexahedra), and register every face neighbour that is not marked and
   that the isosurface crosses, marking it;
3. compute the vertex positions by (5.2) and
4. the vertex normals.

Marks are generation stamps: ``visited[c] == generation`` means "processed
in this query", so starting a new query costs O(1) (the generation counter
is kept across queries by :class:`Propagator`). Every neighbour that is
tested is marked, crossed or not, so no cell is tested twice in one query.

Two ways to find a vertex again (``vertex_search``), both counted by the
kernel (``vertex_lookups``: one per polygon vertex of every cell built):

``"hash"`` (the default; the thesis's and the 2001 paper's reference [12])
    a hash table keyed by the edge's two end nodes (:mod:`._vertex_hash`:
    open addressing, linear probing; ``stats["probes"]`` counts the slots
    inspected), so the volume's edges need not be numbered or stored. The
    table is allocated once and grows only when a surface larger than any
    before needs it (``stats["hash_grows"]``); it is emptied by taking the
    next generation stamp, not by clearing it. The vertices get the
    volume's edge ids (the :class:`~polygen.volume.surface.IsoSurface`
    convention) after stage 3, timed apart (``stats["t_label"]``).
``"array"``
    the vertex id in an array indexed by edge id (and ``n_edges + node``),
    stamped the same way: what the paper's section 2.1 says becomes
    possible *if the cell edges were stored*, which they are here
    (:attr:`UnstructuredVolume.cell_edges`).
"""

from __future__ import annotations

import time

import numpy as np

from polygen import _jit
from polygen._jit import njit
from polygen.volume import _vertex_hash as _h
from polygen.volume import marching as _m
from polygen.volume.surface import (
    IsoSurface,
    IsoSurfaceError,
    check_normals,
    check_value,
    drop_double_faces,
    finish,
    node_gradients,
    vertex_normals,
    volume_arrays,
)

__all__ = ["Propagator", "propagate", "VERTEX_SEARCHES", "VERTEX_KEYS", "pair_stage3", "EdgeLabels"]

#: the ways :class:`Propagator` finds a vertex again
VERTEX_SEARCHES = ("hash", "array")
#: what a hash propagation's ``vertex_keys`` are: the volume's edge ids (labelled after stage 3, which
#: needs the volume's edge list) or the node pairs it searched by (no edge list anywhere)
VERTEX_KEYS = ("edge-ids", "node-pairs")

_EMPTY = -1
_GOLDEN = np.uint64(11400714819323198485)  # 2**64 / golden ratio: Fibonacci hashing


@njit
def _test_seeds(rec, nn, s, value, faces, seeds, visited, generation, queue, qcase):
    """t1: test the seeds (once each), mark them, queue the crossed ones with their case. Returns (tested, queued)."""
    tested = 0
    n = 0
    for i in range(seeds.shape[0]):
        c = seeds[i]
        if visited[c] == generation:
            continue
        visited[c] = generation
        tested += 1
        case = _m._cell_case_n(rec, c, nn, s, value, faces)
        if case >= 0:
            queue[n] = c
            qcase[n] = case
            n += 1
    return tested, n


@njit
def _grow(a):
    out = np.empty(2 * a.shape[0], a.dtype)
    out[: a.shape[0]] = a
    return out


@njit
def _grow2(a):
    out = np.empty((2 * a.shape[0], a.shape[1]), a.dtype)
    out[: a.shape[0]] = a
    return out


@njit(inline="always")
def _enqueue(queue, qcase, tail, c, case):
    """Append cell ``c`` and its case to the FIFO, doubling it when full."""
    if tail == queue.shape[0]:
        queue = _grow(queue)
        qcase = _grow(qcase)
    queue[tail] = c
    qcase[tail] = case
    return queue, qcase, tail + 1


@njit
def _propagate(rec, nn, nf, s, value, faces, n_edges, n_points, tri_table, tri_count, local_edges,
               visited, generation, queue, qcase, n_queued, cand, use_hash, htable, vtable,
               keys, vend, tris, tri_cell, counters):
    """t2: breadth-first propagation.

    ``rec`` are the cell records (:attr:`UnstructuredVolume.cell_records`: ``nn`` nodes, ``nf`` face
    neighbours, then the edge ids). ``queue`` holds the ``n_queued`` crossed
    seeds and ``qcase`` their cases. ``cand`` are more seeds
    tested lazily, in order: whenever the FIFO runs empty, the next
    candidate not marked yet is tested and, if crossed, propagated from (so
    a candidate that an earlier propagation reached is never tested); the
    crossed ones are written over the front of ``cand``.

    Vertex search: with ``use_hash``, the stamped hash table ``htable``
    (:func:`._vertex_hash.get_or_add`) keyed by
    :func:`._vertex_hash.pair_key` (the edge ids of the records are not
    read); otherwise ``vtable[key] = (stamp, vertex id)``, valid where the
    stamp is ``generation``, indexed by the edge id (or ``n_edges + node``). ``keys[v]`` gets the vertex's key, ``vend[v]`` its
    edge's end nodes. Each buffer that fills up is replaced by one twice as
    large, so the caller gets them all back to reuse: returns (n_vertices,
    n_triangles, n_cells, tested, cand_tested, cand_crossed, queue, qcase,
    htable, keys, vend, tris, tri_cell); ``counters`` gets
    the look-ups, the hash probes and the times the hash table grew.
    """
    n_v = 0
    n_t = 0
    local = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    vids = np.empty(24, np.int64)  # per cell: vertex id of each local code
    tested = 0
    cand_tested = 0
    cand_crossed = 0
    lookups = 0
    probes = 0
    grows = 0
    shift = _h.shift_of(htable.shape[0])
    head = 0
    tail = n_queued
    nxt = 0  # next candidate
    ed0 = nn + nf  # where the edge ids start in a record
    while True:
        while head == tail and nxt < cand.shape[0]:  # FIFO empty: the next unmarked candidate
            c = cand[nxt]
            nxt += 1
            if visited[c] == generation:
                continue
            visited[c] = generation
            cand_tested += 1
            case = _m._cell_case_n(rec, c, nn, s, value, faces)
            if case >= 0:
                cand[cand_crossed] = c  # cand_crossed < nxt: no candidate still to come is overwritten
                cand_crossed += 1
                queue, qcase, tail = _enqueue(queue, qcase, tail, c, case)
        if head == tail:
            break
        c = queue[head]
        case = qcase[head]
        head += 1
        k = _m._cell_codes(rec, c, s, value, case, tri_table, tri_count, local_edges, local)
        for i in range(24):
            vids[i] = -1
        if n_t + k > tris.shape[0]:
            tris = _grow2(tris)
            tri_cell = _grow(tri_cell)
        for t in range(k):
            for j in range(3):
                code = local[t, j]
                if vids[code] < 0:
                    if code < 16:
                        x = rec[c, local_edges[code, 0]]
                        y = rec[c, local_edges[code, 1]]
                    else:
                        x = rec[c, code - 16]
                        y = x
                    lookups += 1
                    if use_hash:  # reference [12]: the edge's two nodes are the key
                        key = _h.pair_key(x, y, n_points)
                        v, p = _h.get_or_add(htable, generation, key, n_v, shift)
                        probes += p
                    else:  # the stored edges: the vertex id sits at the edge id
                        key = np.int64(rec[c, ed0 + code]) if code < 16 else n_edges + np.int64(x)
                        if vtable[key, 0] == generation:
                            v = np.int64(vtable[key, 1])
                        else:
                            vtable[key, 0] = generation
                            vtable[key, 1] = n_v
                            v = -1 - np.int64(n_v)
                    if v < 0:  # a new vertex
                        v = -1 - v
                        if n_v == keys.shape[0]:
                            keys = _grow(keys)
                            vend = _grow2(vend)
                        keys[n_v] = key
                        vend[n_v, 0] = min(x, y)
                        vend[n_v, 1] = max(x, y)
                        n_v += 1
                        if use_hash and 2 * n_v > htable.shape[0]:  # keep the load factor under 1/2
                            grows += 1
                            htable = _h.rehash(keys, n_v, 2 * htable.shape[0], generation)
                            shift = _h.shift_of(htable.shape[0])
                    vids[code] = v
                tris[n_t, j] = vids[code]
            tri_cell[n_t] = c
            n_t += 1
        for f in range(nf):
            nb = rec[c, nn + f]
            if nb < 0 or visited[nb] == generation:
                continue
            visited[nb] = generation
            tested += 1
            nb_case = _m._cell_case_n(rec, nb, nn, s, value, faces)
            if nb_case >= 0:
                queue, qcase, tail = _enqueue(queue, qcase, tail, nb, nb_case)
    counters[0] = lookups
    counters[1] = probes
    counters[2] = grows
    return n_v, n_t, tail, tested, cand_tested, cand_crossed, queue, qcase, htable, keys, vend, tris, tri_cell


def _node_records(cells, nbrs):
    """(M, nn + nf) records: each cell's nodes, then its face neighbours (int32 while the ids fit).

    The layout of :attr:`UnstructuredVolume.cell_records` without the edge
    ids, so the same kernels read it (they read the edge ids only for the
    array search).
    """
    m, nn = cells.shape
    big = max(m, int(cells.max(initial=0)) + 1) > np.iinfo(np.int32).max
    rec = _jit.empty((m, nn + nbrs.shape[1]), np.int64 if big else np.int32)
    rec[:, :nn] = cells
    rec[:, nn:] = nbrs
    return rec


def pair_stage3(vend, tri, points, s, value, normals, node_grad):
    """Stage 3 for vertices known by their edge's end nodes ``vend`` (V, 2) (a node twice for a node).

    The positions (5.2) and the normals exactly as
    :func:`~polygen.volume.surface.vertex_normals` makes them for edge-id
    keys, with the vertices' own edges standing in for the volume's edge
    list. Returns ``(vertices (V, 3), normals (V, 3) or None)``.
    """
    n_v = vend.shape[0]
    vertices = _jit.scratch((n_v, 3))
    if n_v:
        _m.crossing_points(vend, vend.shape[0], points, s, value, vertices)
    if normals is None:
        return vertices, None
    on_node = vend[:, 0] == vend[:, 1]
    on_edge = np.flatnonzero(~on_node)
    local_edges = np.ascontiguousarray(vend[on_edge], np.int64)
    local_keys = _jit.scratch(n_v, np.int64)
    local_keys[on_edge] = np.arange(on_edge.size)
    local_keys[on_node] = on_edge.size + vend[on_node, 0]
    nrm = vertex_normals(normals, vertices, tri, local_keys, edges=local_edges, s=s, value=value,
                         node_grad=node_grad, points=points)
    return vertices, nrm


class EdgeLabels:
    """The volume's edge ids of vertices known by their pair keys (:func:`._vertex_hash.pair_key`).

    Built on first use from the volume's edge list (which the volume builds
    then, if nothing has yet); a labelling step for the
    :class:`~polygen.volume.surface.IsoSurface` convention, after a
    construction that never used edge ids.
    """

    def __init__(self, vol):
        self.vol = vol
        self._sorted = None

    @property
    def nbytes(self):
        """Bytes of the edge list and of this index (0 before the first use; the volume's ``cell_edges``,
        built with the edge list, not included)."""
        if self._sorted is None:
            return 0
        return int(self.vol.edges.nbytes + self.index_nbytes)

    @property
    def index_nbytes(self):
        """Bytes of this index alone: the sorted edge codes and their order (0 before the first use)."""
        if self._sorted is None:
            return 0
        return int(self._sorted[0].nbytes + self._sorted[1].nbytes)

    def __call__(self, pair_keys):
        edges = self.vol.edges
        n = np.int64(self.vol.n_points)
        if self._sorted is None:
            codes = edges[:, 0].astype(np.int64) * n + edges[:, 1]
            order = np.argsort(codes, kind="stable")
            self._sorted = (codes[order], order)
        codes, order = self._sorted
        pair_keys = np.asarray(pair_keys, np.int64)
        out = _jit.scratch(pair_keys.shape, np.int64)
        node = pair_keys >= n * n
        out[node] = edges.shape[0] + (pair_keys[node] - n * n)
        want = pair_keys[~node]
        at = np.searchsorted(codes, want)
        if at.size and (at.max() >= codes.size or not np.array_equal(codes[at], want)):
            raise IsoSurfaceError("a vertex lies on a pair of nodes that is no cell edge of the volume")
        out[~node] = order[at]
        return out


class Propagator:
    """Propagation from seeds on one volume and field, reused across queries.

    Keeps the ``visited`` generation stamps (so each query starts in O(1)),
    the field, the face neighbours, the vertex search's table and, once
    asked for, the node gradients. The stamps and buffers are shared by its
    queries, so one propagator serves one thread at a time (the methods of
    :mod:`polygen.volume.methods` hold a lock around it; use one propagator
    per thread otherwise).

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name or node values (the first field by default).
    vertex_search : {"hash", "array"}, keyword-only
        How a vertex is found again (see the module): a hash table keyed by
        the edge's two nodes, allocated once (``hash_capacity`` slots to
        begin with, doubled when a surface needs more) and emptied by
        stamps; or an array indexed by the stored edge ids.
    hash_capacity : int, keyword-only
        Initial slots of the hash table (rounded up to a power of two;
        default: twice the larger of 1024 and 1/16 of the cells).
    vertex_keys : {"edge-ids", "node-pairs"}, keyword-only
        What the result's ``vertex_keys`` are (``"hash"`` only).
        ``"edge-ids"`` (the :class:`~polygen.volume.surface.IsoSurface`
        convention) labels the vertices by the volume's edge ids after
        stage 3 (``stats["t_label"]``), which makes the volume build its edge
        table at the first query; ``"node-pairs"`` keeps the keys the hash
        searched by (``a * n_points + b``, ``a < b``; ``n_points**2 + node``)
        and stores no edges at all: the paper's setting.

    Attributes
    ----------
    stats : dict
        The last query's ``lookups``, ``probes`` (hash slots inspected),
        ``hash_grows`` and ``t_label`` (s, labelling the vertices by edge
        id after a hash search).

    Examples
    --------
    >>> prop = Propagator(vol)                  # doctest: +SKIP
    >>> iso = prop.extract(0.5, seeds=[10, 99])  # doctest: +SKIP
    """

    def __init__(self, vol, field=None, *, vertex_search="hash", hash_capacity=None, vertex_keys="edge-ids"):
        if vertex_search not in VERTEX_SEARCHES:
            raise IsoSurfaceError(f"vertex_search must be one of {VERTEX_SEARCHES}; got {vertex_search!r}")
        if vertex_keys not in VERTEX_KEYS:
            raise IsoSurfaceError(f"vertex_keys must be one of {VERTEX_KEYS}; got {vertex_keys!r}")
        if vertex_keys == "node-pairs" and vertex_search != "hash":
            raise IsoSurfaceError("vertex_keys='node-pairs' is the hash search's: the array search keys its "
                                  "vertices by the stored edge ids")
        self.vol = vol
        self.vertex_search = vertex_search
        self.vertex_keys = vertex_keys
        self.points, self.cells, self.s, self.cell_type = volume_arrays(vol, field)
        self.table, self.count, self.local_edges, self.faces = _m.local_tables(self.cell_type)
        nbrs = vol.face_neighbors
        self._nn, self._nf = self.cells.shape[1], nbrs.shape[1]
        if vertex_search == "hash":
            # the paper's setting: no cell edges numbered or stored, so the records hold a cell's nodes and
            # face neighbours only (the volume's cell_records would make it build its whole edge table)
            self.rec = _node_records(self.cells, nbrs)
        else:
            self.rec = vol.cell_records  # nodes, face neighbours and edge ids of a cell side by side
        self.n_points = int(vol.n_points)
        self.visited = np.zeros(self.cells.shape[0], np.int32)
        self.generation = 0
        self._node_grad = None
        # scratch buffers reused across queries; the kernel doubles the ones that fill up
        self._queue = _jit.scratch(1024, np.int64)
        self._qcase = _jit.scratch(1024, np.int64)
        if vertex_search == "hash":
            self.edges = None
            cap = hash_capacity if hash_capacity is not None else 2 * max(1024, self.cells.shape[0] // 16)
            if isinstance(cap, bool) or not isinstance(cap, (int, np.integer)) or cap < 2:
                raise IsoSurfaceError(f"hash_capacity must be a whole number >= 2; got {hash_capacity!r}")
            cap = 1 << int(cap - 1).bit_length()
            self._htable = np.zeros((cap, 2), np.int64)   # key, stamp << 32 | vertex id
            self._vtable = np.zeros((0, 2), np.int32)
            self._labels = EdgeLabels(vol)
        else:
            self.edges = vol.edges  # the volume's (int32), not copied
            self._htable = np.zeros((1, 2), np.int64)
            self._vtable = np.zeros((self.edges.shape[0] + self.n_points, 2), np.int32)  # stamp, vertex id
        self._keys = _jit.scratch(512, np.int64)
        self._vend = _jit.scratch((512, 2), np.int64)
        self._tris = _jit.scratch((1024, 3), np.int64)
        self._tri_cell = _jit.scratch(1024, np.int64)
        self.stats = {}
        #: FIFO order of the last query: the cells in the order they were registered
        self.last_order = np.zeros(0, np.int64)
        #: the last query's seeds: how many were tested and crossed (the crossed ones open ``last_order``)
        self.last_seeds_tested = 0
        self.last_seeds_crossed = 0
        #: the last query's ``then`` cells: how many were tested, and the crossed ones that started a propagation
        self.last_then_tested = 0
        self.last_then_seeds = np.zeros(0, np.int64)
        self._no_cand = np.zeros(0, np.int64)

    @property
    def node_gradients(self):
        if self._node_grad is None:
            self._node_grad = node_gradients(self.vol, self.s)
        return self._node_grad

    def memory_bytes(self):
        """Bytes of the arrays this propagation holds or made the volume build, beyond points, cells and field.

        Found from the arrays themselves, by name: ``records`` (``"hash"``:
        its own copy of each cell's nodes and face neighbours, 32 bytes per
        tetrahedron; ``"array"``: the volume's ``cell_records``, which hold
        the cells' edge ids too, 64 bytes per tetrahedron), ``visited``
        (stamps), ``vertex_table`` (the hash table, or the vertex-id array
        and its stamps), ``buffers`` (queue, keys, vertex ends, triangles at
        their current sizes), ``node_gradients`` once built; ``"array"``
        also ``edge_list`` and ``cell_edges`` (the volume's edge table, from
        which the records were built); ``"hash"`` with
        ``vertex_keys="edge-ids"``, once a query labelled its vertices:
        ``label_index`` (the sorted edge codes) and the volume's edge table
        the labelling made it build (``label_edge_list``,
        ``label_cell_edges``). The volume's ``face_neighbors`` (read to make
        the records) are not counted: every construction and the seed
        sources read them.
        """
        out = {
            "records": int(self.rec.nbytes),
            "visited": int(self.visited.nbytes),
            "vertex_table": int(self._htable.nbytes + self._vtable.nbytes),
            "buffers": int(sum(a.nbytes for a in (self._queue, self._qcase, self._keys, self._vend, self._tris,
                                                   self._tri_cell))),
        }
        if self._node_grad is not None:
            out["node_gradients"] = int(self._node_grad.nbytes)
        table = self.vol.__dict__.get("_edge_table")
        cell_edges = 0 if table is None or table[1] is None else int(table[1].nbytes)
        if self.vertex_search == "array":
            out["edge_list"] = int(self.edges.nbytes)
            out["cell_edges"] = cell_edges
        elif self._labels.nbytes:
            out["label_index"] = self._labels.index_nbytes
            out["label_edge_list"] = int(self.vol.edges.nbytes)
            out["label_cell_edges"] = cell_edges
        return out

    def _seeds(self, seeds):
        seeds = np.atleast_1d(np.asarray(seeds))
        if seeds.ndim != 1:
            raise IsoSurfaceError(f"seeds must be a 1-D array of cell ids; got shape {seeds.shape}")
        if seeds.size and not np.issubdtype(seeds.dtype, np.integer):
            raise IsoSurfaceError(f"seeds must be integer cell ids; got dtype {seeds.dtype}")
        seeds = seeds.astype(np.int64)
        m = self.cells.shape[0]
        bad = np.flatnonzero((seeds < 0) | (seeds >= m))
        if bad.size:
            raise IsoSurfaceError(f"seed cells must be in 0..{m - 1}; got {seeds[bad[:5]].tolist()}")
        return seeds

    def extract(self, value, seeds, *, normals="mean", then=None):
        """The isosurface reached from ``seeds``; see :func:`polygen.volume.isosurface.extract`.

        Parameters
        ----------
        value : float
        seeds : (K,) int64
            Cells to start from; the ones the surface does not cross are skipped.
        normals : {"mean", "gradient", None}, keyword-only
        then : (L,) int64, optional, keyword-only
            More seeds, tested only after the propagation from ``seeds``
            and only if it has not reached them, one at a time, each crossed
            one propagated from before the next is tested: the extrema
            graph's boundary cells after its arcs (thesis 6.3.4, step 4).
            ``last_then_tested`` and ``last_then_seeds`` tell what happened.

        Returns
        -------
        IsoSurface
            ``method == "propagate"``; ``cells_tested`` counts the seeds and
            the neighbours tested, each once; ``vertex_lookups`` the
            searches the kernel made (one per polygon vertex per cell).
        """
        value = check_value(value)
        check_normals(normals)
        seeds = self._seeds(seeds)
        node_grad = self.node_gradients if normals == "gradient" else None
        if self.generation == np.iinfo(np.int32).max:  # once in 2**31 queries: really clear the marks
            self.visited[:] = 0
            self._htable[:] = 0
            self._vtable[:] = 0
            self.generation = 0
        self.generation += 1  # also empties the vertex table: no slot carries this stamp yet

        cand = self._no_cand if then is None else self._seeds(then)  # a copy: the kernel writes over it

        t0 = time.perf_counter()
        if self._queue.shape[0] < seeds.shape[0]:
            self._queue = _jit.scratch(2 * seeds.shape[0], np.int64)
            self._qcase = _jit.scratch(2 * seeds.shape[0], np.int64)
        nn, nf = self._nn, self._nf
        tested_seeds, n_queued = _test_seeds(self.rec, nn, self.s, value, self.faces, seeds, self.visited,
                                             self.generation, self._queue, self._qcase)
        t1 = time.perf_counter() - t0

        t0 = time.perf_counter()
        use_hash = self.vertex_search == "hash"
        counters = np.zeros(3, np.int64)
        n_edges = 0 if use_hash else self.edges.shape[0]
        (n_v, n_t, n_cells, tested, cand_tested, cand_crossed, self._queue, self._qcase, self._htable, self._keys,
         self._vend, self._tris, self._tri_cell) = _propagate(
            self.rec, nn, nf, self.s, value, self.faces, n_edges, self.n_points, self.table, self.count,
            self.local_edges, self.visited, self.generation, self._queue, self._qcase, n_queued, cand, use_hash,
            self._htable, self._vtable, self._keys, self._vend, self._tris, self._tri_cell, counters)
        self.last_seeds_tested = int(tested_seeds)
        self.last_seeds_crossed = int(n_queued)
        self.last_then_tested = int(cand_tested)
        self.last_then_seeds = cand[:cand_crossed].copy()
        tested_seeds += cand_tested
        keys = self._keys[:n_v].copy()
        tri = self._tris[:n_t].copy()
        tri_cell = self._tri_cell[:n_t].copy()
        t2 = time.perf_counter() - t0
        self.last_order = self._queue[:n_cells].copy()
        self.stats = {"lookups": int(counters[0]), "probes": int(counters[1]), "hash_grows": int(counters[2]),
                      "t_label": 0.0}
        if not use_hash:
            return finish(value, keys, tri, tri_cell, points=self.points, edges=self.edges, s=self.s,
                          normals=normals, node_grad=node_grad, method="propagate",
                          cells_tested=tested_seeds + tested, cells_intersected=n_cells,
                          vertex_lookups=counters[0], t1=t1, t2=t2)
        t0 = time.perf_counter()
        tri, tri_cell = drop_double_faces(keys, tri, tri_cell, np.int64(self.n_points) * self.n_points)
        t2 += time.perf_counter() - t0
        t0 = time.perf_counter()
        vertices, nrm = pair_stage3(self._vend[:n_v], tri, self.points, self.s, value, normals, node_grad)
        t3 = time.perf_counter() - t0
        if self.vertex_keys == "edge-ids":
            t0 = time.perf_counter()
            keys = self._labels(keys)
            self.stats["t_label"] = time.perf_counter() - t0
        return IsoSurface(
            value=value, vertices=vertices, triangles=tri, normals=nrm, vertex_keys=keys, triangle_cells=tri_cell,
            cells_tested=int(tested_seeds + tested), cells_intersected=int(n_cells),
            vertex_lookups=int(counters[0]), t1=t1, t2=t2, t3=t3, method="propagate")


def propagate(vol, value, seeds, *, field=None, normals="mean"):
    """One isosurface by propagation from ``seeds`` (a one-off :class:`Propagator`)."""
    return Propagator(vol, field).extract(value, seeds, normals=normals)
