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
The hash table is open addressing with linear probing over the global
vertex keys of :mod:`polygen.volume.marching` (an edge id, or
``n_edges + node`` for a crossing exactly on a node); its look-ups are
counted.
"""

from __future__ import annotations

import time

import numpy as np

from polygen._jit import njit
from polygen.volume import marching as _m
from polygen.volume.surface import (
    IsoSurfaceError,
    check_normals,
    check_value,
    finish,
    node_gradients,
    volume_arrays,
)

__all__ = ["Propagator", "propagate"]

_EMPTY = -1
_GOLDEN = np.uint64(11400714819323198485)  # 2**64 / golden ratio: Fibonacci hashing


@njit
def _slot(key, shift):
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(shift))


@njit
def _hash_insert(hkeys, hvals, key, val, shift):
    mask = hkeys.shape[0] - 1
    i = _slot(key, shift)
    while hkeys[i] != _EMPTY:
        i = (i + 1) & mask
    hkeys[i] = key
    hvals[i] = val


@njit
def _hash_get_or_add(hkeys, hvals, key, new_val, shift):
    """The value stored under ``key``, or ``new_val`` after storing it (then -1 - new_val)."""
    mask = hkeys.shape[0] - 1
    i = _slot(key, shift)
    while True:
        k = hkeys[i]
        if k == key:
            return hvals[i]
        if k == _EMPTY:
            hkeys[i] = key
            hvals[i] = new_val
            return -1 - new_val
        i = (i + 1) & mask


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
def _propagate(rec, nn, nf, s, value, faces, n_edges, tri_table, tri_count, local_edges,
               visited, generation, queue, qcase, n_queued, cand, hkeys, hvals, keys, tris, tri_cell):
    """t2: breadth-first propagation.

    ``rec`` are the cell records (:attr:`UnstructuredVolume.cell_records`: ``nn`` nodes, ``nf`` face
    neighbours, then the edge ids). ``queue`` holds the ``n_queued`` crossed
    seeds and ``qcase`` their cases. ``cand`` are more seeds
    tested lazily, in order: whenever the FIFO runs empty, the next
    candidate not marked yet is tested and, if crossed, propagated from (so
    a candidate that an earlier propagation reached is never tested); the
    crossed ones are written over the front of ``cand``. ``hkeys`` (a
    power of two long) must be all ``_EMPTY``; ``keys``, ``tris``,
    ``tri_cell`` and ``qcase`` are scratch buffers. Each buffer that fills
    up is replaced by one twice as large, so the caller gets them all back
    to reuse: returns (n_vertices, n_triangles, n_cells, tested,
    cand_tested, cand_crossed, lookups, queue, qcase, hkeys, hvals, keys,
    tris, tri_cell).
    """
    cap = hkeys.shape[0]
    hash_bits = 0
    while (1 << hash_bits) < cap:
        hash_bits += 1
    shift = 64 - hash_bits
    n_v = 0
    n_t = 0
    local = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    vids = np.empty(24, np.int64)  # per cell: vertex id of each local code
    tested = 0
    cand_tested = 0
    cand_crossed = 0
    lookups = 0
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
                    key = np.int64(rec[c, ed0 + code]) if code < 16 else n_edges + rec[c, code - 16]
                    lookups += 1
                    v = _hash_get_or_add(hkeys, hvals, key, n_v, shift)
                    if v < 0:  # a new vertex
                        v = -1 - v
                        if n_v == keys.shape[0]:
                            keys = _grow(keys)
                        keys[n_v] = key
                        n_v += 1
                        if 2 * n_v > cap:  # keep the load factor under 1/2
                            hash_bits += 1
                            cap = 1 << hash_bits
                            shift = 64 - hash_bits
                            hkeys = np.full(cap, _EMPTY, np.int64)
                            hvals = np.empty(cap, np.int64)
                            for q in range(n_v):
                                _hash_insert(hkeys, hvals, keys[q], q, shift)
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
    return n_v, n_t, tail, tested, cand_tested, cand_crossed, lookups, queue, qcase, hkeys, hvals, keys, tris, tri_cell


class Propagator:
    """Propagation from seeds on one volume and field, reused across queries.

    Keeps the ``visited`` generation stamps (so each query starts in O(1)),
    the field, the face neighbours and, once asked for, the node gradients.
    The stamps and buffers are shared by its queries, so one propagator
    serves one thread at a time (the methods of :mod:`polygen.volume.methods`
    hold a lock around it; use one propagator per thread otherwise).

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name or node values (the first field by default).

    Examples
    --------
    >>> prop = Propagator(vol)                  # doctest: +SKIP
    >>> iso = prop.extract(0.5, seeds=[10, 99])  # doctest: +SKIP
    """

    def __init__(self, vol, field=None):
        self.vol = vol
        self.points, self.cells, self.s, self.cell_type = volume_arrays(vol, field)
        self.table, self.count, self.local_edges, self.faces = _m.local_tables(self.cell_type)
        self.rec = vol.cell_records  # nodes, face neighbours and edge ids of a cell side by side
        self._nn, self._nf = self.cells.shape[1], vol.face_neighbors.shape[1]
        self.edges = np.ascontiguousarray(vol.edges, np.int64)
        self.visited = np.zeros(self.cells.shape[0], np.int32)
        self.generation = 0
        self._node_grad = None
        # scratch buffers reused across queries; the kernel doubles the ones that fill up
        self._queue = np.empty(1024, np.int64)
        self._qcase = np.empty(1024, np.int64)
        self._hkeys = np.full(1 << 10, _EMPTY, np.int64)
        self._hvals = np.empty(1 << 10, np.int64)
        self._keys = np.empty(512, np.int64)
        self._tris = np.empty((1024, 3), np.int64)
        self._tri_cell = np.empty(1024, np.int64)
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
            the neighbours tested, each once.
        """
        value = check_value(value)
        check_normals(normals)
        seeds = self._seeds(seeds)
        node_grad = self.node_gradients if normals == "gradient" else None
        if self.generation == np.iinfo(np.int32).max:  # once in 2**31 queries: really clear the marks
            self.visited[:] = 0
            self.generation = 0
        self.generation += 1

        cand = self._no_cand if then is None else self._seeds(then)  # a copy: the kernel writes over it

        t0 = time.perf_counter()
        if self._queue.shape[0] < seeds.shape[0]:
            self._queue = np.empty(2 * seeds.shape[0], np.int64)
            self._qcase = np.empty(2 * seeds.shape[0], np.int64)
        nn, nf = self._nn, self._nf
        tested_seeds, n_queued = _test_seeds(self.rec, nn, self.s, value, self.faces, seeds, self.visited,
                                             self.generation, self._queue, self._qcase)
        t1 = time.perf_counter() - t0

        t0 = time.perf_counter()
        self._hkeys.fill(_EMPTY)
        (n_v, n_t, n_cells, tested, cand_tested, cand_crossed, lookups, self._queue, self._qcase, self._hkeys,
         self._hvals, self._keys, self._tris, self._tri_cell) = _propagate(
            self.rec, nn, nf, self.s, value, self.faces, self.edges.shape[0], self.table, self.count,
            self.local_edges, self.visited, self.generation, self._queue, self._qcase, n_queued, cand,
            self._hkeys, self._hvals, self._keys, self._tris, self._tri_cell)
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

        return finish(value, keys, tri, tri_cell, points=self.points, edges=self.edges, s=self.s,
                      normals=normals, node_grad=node_grad, method="propagate",
                      cells_tested=tested_seeds + tested, cells_intersected=n_cells, vertex_lookups=lookups,
                      t1=t1, t2=t2)


def propagate(vol, value, seeds, *, field=None, normals="mean"):
    """One isosurface by propagation from ``seeds`` (a one-off :class:`Propagator`)."""
    return Propagator(vol, field).extract(value, seeds, normals=normals)
