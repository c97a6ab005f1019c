"""Partitioned volumes: one volume in pieces, isosurfaces across them stitched exactly.

Finite-element solvers that run on clusters write one piece per process (a
``.pvtu`` with its ``.vtu`` pieces, or one file per partition); pieces share
their boundary nodes and name every node by a **global id** (point array
``GlobalNodeId``). A :class:`PartitionedVolume` holds such pieces, read
lazily, or splits one :class:`~polygen.volume.mesh.UnstructuredVolume` into
``k`` spatial partitions (contiguous ranges of cells along a Morton curve).

An isosurface is extracted in each partition by any registered method, as
if the partition were the whole volume. The hope is that every method is
complete on any volume, and a partition's seam is part of its boundary, so
that a component cut by a seam is found by each side from its own seeds.
That does not hold as such: a Morton range of cells often touches its
neighbour along an edge or a node only, its boundary is then not a
2-manifold, and chapter 7's theorems (7.4-7.6) no longer promise a complete
skeleton. Measured on data 3 (20 values, against the single volume,
without what follows): the ``thinning`` method missed pieces in 2, 10 and
11 of the 20 values with 2, 5 and 8 partitions; the ``edge-centred``
construction (same skeleton) left out part of a piece in 2 of 20 with 5
partitions. So each partition also tests its
**seam cells** (cells with a boundary face whose nodes are all shared with
another partition) at every query, and propagates (thesis 5.4.2) from the
crossed ones that the method left without triangles: a missed piece
touching the seam crosses a seam cell. The tests check every partition's
result against its own full scan. ``span-space``, ``extrema-graph`` and the
scan matched the single volume without seam seeds in those runs. A scan (a method whose
``construction`` is ``"scan"``: the active scan, the default, and the full
scan) tests every cell the surface crosses, so it skips the seam test.

The pieces are stitched by naming each vertex by the **pair of global node
ids** of its edge (``a * N + b``, ``a < b``; ``a * N + a`` for a crossing
exactly on node ``a``; ``N`` the number of global ids): a vertex on a seam
edge is made by both sides and kept once, so the surface has no duplicate
vertex and no crack. A partition's nodes are numbered in increasing global
id, so both sides compute a seam vertex from the same end of its edge, bit
for bit as the single volume does. Each cell lies in one partition, so each
triangle is made once (a triangle lying exactly in a shared face at ``C``
is made by both cells and kept once, from the lower global cell id, as on
one volume). Only **seam vertices** can be made twice: those whose edge's
two nodes both lie on another partition too (known from the global ids
when the partitions are laid out). Each partition marks them, and the
stitch matches only those by key; every other vertex is taken as it is,
piece after piece, and the triangles are renumbered in one pass. Mean
normals are made by each partition for its own vertices (all their
triangles are there, summed in the stitched surface's order: bit for bit
the normals of the whole stitched surface); a seam vertex's normal is made
by the stitch from the triangles that touch it, on both sides.
``normals="gradient"`` is refused (a seam node's gradient needs the cells
of both sides). The stitched vertices come piece after piece (not sorted
by key); ``vertex_keys`` names each.

:func:`merge` turns pieces into one piece again, so the stitch can be done
all at once (:func:`stitch`: what :class:`PartitionedMethod` does here, one
partition after the other) or pairwise up a tree of neighbouring partitions
(:func:`reduce_tree`, :func:`tree_stitch`): what
:mod:`polygen.volume.distributed` does on the Dask workers
(``distributed.prepare(pvol, client=...)``), so that only the stitched
surface reaches the client. Both give the same arrays. This module does not
import dask.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import pathlib
import threading
import time
import warnings
import xml.etree.ElementTree as ET

import numpy as np
from polygen import _jit
from polygen.volume import marching as _m
from polygen.volume import registry as _registry
from polygen.volume.mesh import UnstructuredVolume, VolumeError
from polygen._jit import njit
from polygen.volume import _topology as _topo
from polygen.volume.thinning import ThinningWarning
from polygen.volume.surface import IsoSurface, IsoSurfaceError, check_normals, check_value

__all__ = ["PartitionedVolume", "PartitionedMethod", "PartitionError", "StitchedIsoSurface", "GLOBAL_IDS",
           "stitch", "tree_stitch", "merge", "finish", "reduce_tree", "scale_model", "span_weights", "seam_plan",
           "drop_face_twins", "rows_layout", "rows_arrays", "finish_rows", "direct_stitch", "auto_partitions",
           "MIN_CELLS_PER_PARTITION"]

#: the point array that numbers the nodes globally (as ParaView's D3 filter and VTK's redistribution name it)
GLOBAL_IDS = "GlobalNodeId"

#: the fewest cells a partition keeps when the partition count is chosen automatically (:func:`auto_partitions`)
MIN_CELLS_PER_PARTITION = 1_000_000

logger = logging.getLogger(__name__)


def auto_partitions(n_cells, workers=None):
    """How many partitions a volume of ``n_cells`` cells is split into by default, and why: ``(k, reason)``.

    The rule: one partition per worker (``workers``; default this
    machine's cores, ``os.cpu_count()``), but no more than keep
    :data:`MIN_CELLS_PER_PARTITION` cells each; ``k = 1`` (not split) when
    the volume has fewer than twice that many cells or there is one worker.

    Why: a single volume's default method (``active-scan``) already runs
    every query on all of this machine's cores, so a split gains nothing on
    one machine but memory per process, and costs every query a fixed
    price: two calls per partition (extract and report the seam, then write
    the rows), the client's layout of the stitched arrays and the seam
    normals, and each partition's seam cells tested again -- about half a
    millisecond on two partitions of one machine (each call's round trip
    ~0.1 ms). The active scan does about 2 ms of one thread's work per
    million cells and query (measured on 2M, quiet: 44 ms for 20
    values on 2 threads, 1.96 M cells), so a partition of fewer than a
    million cells would spend a quarter of its query or more on that fixed
    price; workers on other machines gain their cores only when each has
    such a partition to work on. data4 (560,860 cells) is not split.
    """
    if isinstance(n_cells, bool) or not isinstance(n_cells, (int, np.integer)) or n_cells < 1:
        raise PartitionError(f"n_cells must be a positive integer; got {n_cells!r}")
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise PartitionError(f"workers must be a positive integer; got {workers!r}")
    n_cells, workers = int(n_cells), int(workers)
    fits = n_cells // MIN_CELLS_PER_PARTITION
    if workers == 1:
        return 1, f"not split: one worker ({n_cells:,} cells)"
    if fits < 2:
        return 1, (f"not split: {n_cells:,} cells are fewer than 2 x {MIN_CELLS_PER_PARTITION:,} (the fewest cells a "
                   "partition keeps by default: below that a partitioned query's fixed cost is a large share of its "
                   "work, and one volume's active scan uses every core already)")
    k = min(workers, fits)
    why = "one per worker" if k == workers else f"at least {MIN_CELLS_PER_PARTITION:,} cells each"
    return k, f"split into {k} partitions ({why}: {n_cells:,} cells, {workers} workers)"


class PartitionError(ValueError):
    """A partitioned volume or a query across it is wrong (the message names the piece)."""


# ----------------------------------------------------------------- pieces

@dataclasses.dataclass(frozen=True)
class _MemoryPiece:
    """A partition held in memory (from :meth:`PartitionedVolume.split`)."""

    name: str
    points: np.ndarray
    cells: np.ndarray
    fields: dict
    global_ids: np.ndarray
    cell_ids: np.ndarray

    def load(self):
        vol = UnstructuredVolume(self.points, self.cells, self.fields, validate=False)
        return vol, self.global_ids, self.cell_ids


@dataclasses.dataclass(frozen=True)
class _FilePiece:
    """A partition in a mesh file, read where it is prepared."""

    name: str
    path: str
    global_ids_name: str

    def load(self):
        if not os.path.exists(self.path):
            raise PartitionError(f"piece {self.name!r}: no such file {self.path!r}")
        try:
            vol = UnstructuredVolume.read(self.path, validate=False)
        except VolumeError as e:
            raise PartitionError(f"piece {self.name!r}: {e}") from e
        gid = vol.fields.get(self.global_ids_name)
        if gid is None:
            raise PartitionError(f"piece {self.name!r} has no point array {self.global_ids_name!r} of global node ids "
                                 f"(its point arrays: {list(vol.fields)})")
        if not (np.all(gid == np.round(gid)) and gid.min() >= 0):
            raise PartitionError(f"piece {self.name!r}: {self.global_ids_name!r} must hold non-negative integers")
        del vol.fields[self.global_ids_name]
        return vol, gid.astype(np.int64), None


def _sorted_by_global_id(vol, gids):
    """``vol`` with its nodes renumbered in increasing global id (and the sorted ids).

    Then ``a < b`` locally exactly when it is globally, so both sides of a
    seam compute a crossing point (5.2) from the same end of its edge, bit
    for bit as on the whole volume.
    """
    if gids.shape != (vol.n_points,):
        raise PartitionError(f"global ids must have shape ({vol.n_points},); got {gids.shape}")
    order = np.argsort(gids, kind="stable")
    sg = gids[order]
    if sg.size > 1 and np.any(sg[1:] == sg[:-1]):
        dup = sg[1:][sg[1:] == sg[:-1]][0]
        raise PartitionError(f"global node id {int(dup)} is given to two nodes of one piece")
    if np.array_equal(order, np.arange(order.size)):
        return vol, gids
    new_id = _jit.scratch(order.size, np.int64)
    new_id[order] = np.arange(order.size)
    out = UnstructuredVolume(vol.points[order], new_id[vol.cells], {k: v[order] for k, v in vol.fields.items()},
                             validate=False)
    return out, sg


class PreparedPartition:
    """One partition with a method prepared on it: what a worker keeps between queries.

    Parameters
    ----------
    piece : a piece source (``load() -> (vol, global_ids, cell_ids)``)
    index : int
        The partition's place in the volume.
    field, method : str or None
    params : dict
        The method's keyword parameters.

    Attributes
    ----------
    info : dict
        What the client checks across partitions: ``n_cells``, ``n_points``,
        ``fields`` (names), ``boundary_ids`` / ``boundary_points`` /
        ``boundary_values`` (the global ids, coordinates and field values of
        the nodes on the partition's boundary), ``min`` / ``max`` of the
        field, ``preprocess_s``.
    """

    def __init__(self, piece, index, field=None, method=None, params=None):
        t0 = time.perf_counter()
        self.name = piece.name
        self.index = index
        vol, gids, cell_ids = piece.load()
        self.vol, self.global_ids = _sorted_by_global_id(vol, np.asarray(gids, np.int64))
        self.cell_ids = cell_ids  # global cell ids; None until offset by the client (pieces from files)
        self.cell_offset = 0
        fields = list(self.vol.fields)
        if not fields:
            raise PartitionError(f"piece {self.name!r} has no node field")
        self.field = fields[0] if field is None else field
        if self.field not in self.vol.fields:
            raise PartitionError(f"piece {self.name!r} has no field {self.field!r}; its fields are {fields}")
        method = _registry.DEFAULT_METHOD if method is None else method
        params = dict(params or {})
        if method == "edge-centred-table":
            # one thread per partition: the partitions are the parallelism, and the stitched arrays come out
            # in one order whatever the machine's load (threads="auto" may build a surface by two threads,
            # whose vertex order varies from run to run)
            params.setdefault("threads", 1)
        with warnings.catch_warnings(record=True) as caught:
            # a Morton range of cells may touch its neighbour along an edge or a node only; thinning
            # warns that its theorems (7.4-7.6) need a manifold boundary: the seam seeds make up for it
            # there, and set_layout says so again where the boundary is not a manifold away from the seams
            warnings.simplefilter("always", ThinningWarning)
            self.method = _registry.get_method(method)(self.vol, field=self.field, **params)
        for w in caught:
            if not issubclass(w.category, ThinningWarning):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        self._thinning_warned = any(issubclass(w.category, ThinningWarning) for w in caught)
        # a scan (the active scan, the full scan) tests every cell the surface crosses: it cannot miss a piece at
        # the seam, and testing the seam cells again would only cost (2M in 2 partitions: ~0.2 ms per value, a
        # tenth of the active scan's query)
        self._complete = getattr(self.method, "construction", "") == "scan"
        self._propagator = None
        self._lock = threading.Lock()
        self.seam_cells = np.zeros(0, np.int64)
        bnodes = np.unique(self.vol.boundary_face_nodes)
        self.info = {
            "name": self.name, "n_cells": self.vol.n_cells, "n_points": self.vol.n_points, "fields": fields,
            "cell_type": self.vol.cell_type,
            "boundary_ids": self.global_ids[bnodes], "boundary_points": self.vol.points[bnodes],
            "boundary_values": self.vol.fields[self.field][bnodes],
            "max_id": int(self.global_ids.max()), "min": float(self.vol.fields[self.field].min()),
            "max": float(self.vol.fields[self.field].max()), "preprocess_s": time.perf_counter() - t0,
        }

    def __getstate__(self):
        # pickling and deepcopy (a PartitionedMethod held by a Dask or multiprocessing user): the lock stays
        state = self.__dict__.copy()
        del state["_lock"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def get_info(self):
        """:attr:`info` (a method: what a Dask actor can be asked)."""
        return self.info

    def set_layout(self, cell_offset, n_ids, shared_ids):
        """The client's numbering and seams.

        ``cell_offset``: this partition's first global cell id (pieces from
        files); ``n_ids``: the number of global node ids; ``shared_ids``
        (sorted int64): the global ids on more than one partition. A
        boundary face whose nodes are all shared lies on a seam; its cell is
        a seam cell, tested at every query (the seam seeds). Where the
        method's thinning found the partition's boundary pinched at shared
        nodes (the cut's doing, or the volume's own pinch lying on the seam),
        the cells around those nodes are seam cells too.
        """
        self.cell_offset = int(cell_offset)
        self.n_ids = int(n_ids)
        vol = self.vol
        # a node on another partition too: a vertex on an edge between two such nodes may be made there too
        self._shared_node = np.isin(self.global_ids, shared_ids)
        # every vertex key's global key, negative (-1 - key) for a seam vertex: made once here, so that a query
        # reads one int64 per vertex instead of its edge's two nodes, their global ids and seam marks (2M, one
        # partition, 20 values: 4.6-7.2 -> 1.6 ms)
        self._key_map = _jit.scratch(vol.edges.shape[0] + vol.n_points, np.int64)
        _key_map(vol.edges, self.global_ids, self._shared_node, self.n_ids,
                 self._key_map)
        on_seam = np.all(self._shared_node[vol.boundary_face_nodes], axis=1)
        seam_cells = [vol.boundary_faces[on_seam, 0]]
        own = np.zeros(0, np.int64)
        if self._thinning_warned:
            from polygen.volume.homology import boundary_defects

            edges, nodes = boundary_defects(vol)
            pinched = np.unique(np.concatenate([edges.ravel(), nodes]))
            own = pinched[~self._shared_node[pinched]]
            # a pinch on the seam may be the volume's own (blocks touching along an edge there), not the cut's:
            # the cells around it are seam cells too. Found by the property test: thinning in 7 partitions of
            # 72 cells missed 2 triangles in two cells at such an edge, with no seam cell on them and no warning
            on = pinched[self._shared_node[pinched]]
            if on.size:
                off, cells = vol.node_cells
                seam_cells.append(np.concatenate([cells[off[a]:off[a + 1]] for a in on]))
        self.seam_cells = np.unique(np.concatenate(seam_cells)).astype(vol.boundary_faces.dtype, copy=False)
        self._made = np.zeros(vol.n_cells, bool)
        s = vol.fields[self.field][vol.cells[self.seam_cells]]
        self._seam_min, self._seam_max = s.min(axis=1), s.max(axis=1)
        last = (int(self.cell_ids.max()) if self.cell_ids.size else 0) if self.cell_ids is not None \
            else self.cell_offset + vol.n_cells - 1
        self._cells32 = last < 2**31  # global cell ids travel as int32 when they fit
        if self._thinning_warned:
            if own.size:  # not the seam's doing: the seam seeds do not reach there
                warnings.warn(ThinningWarning(
                    f"piece {self.name!r}: the volume's boundary is not a 2-manifold away from the partitions' "
                    f"seams (e.g. global nodes {self.global_ids[own[:4]].tolist()}): Thms 7.4-7.6 do not hold "
                    "there, and the method may miss parts of an isosurface; use a scan-based method "
                    "('active-scan', 'scan') for this volume"), stacklevel=2)
        return True

    def _seam_seeds(self, value, iso):
        """Seam cells the surface crosses (a node below ``C``, one above) that ``iso`` has no triangle in."""
        # one pass: a mark per cell set and cleared around the look-up, O(triangles + seam cells), where np.isin
        # sorts them (measured on 2M in two partitions: isin took as long as the extraction itself)
        if not self.seam_cells.size:
            return self.seam_cells
        out = _jit.scratch(self.seam_cells.shape[0], np.int64)
        n = _missed_seam_cells(self.seam_cells, self._seam_min, self._seam_max, value,
                               np.ascontiguousarray(iso.triangle_cells, np.int64), self._made, out)
        return out[:n]

    def extract(self, value, normals="mean"):
        """This partition's part of the surface ``S = value``, vertices keyed by global id pairs (a dict)."""
        iso, counters = self.surface(value)
        return self._piece(iso, normals) | counters

    def surface(self, value):
        """This partition's :class:`IsoSurface` of ``value`` (local keys, no normals) and its counters."""
        # normals are made on the stitched surface (a seam vertex's triangles are on both sides): none here
        iso = self.method.extract(value, normals=None)
        # the method is complete on the partition when its theorems hold there; a piece of the surface it
        # missed must cross the partition's seam (measured: the thinning skeleton of a Morton range whose
        # boundary is not a manifold), so propagation from the crossed seam cells it left out finds it
        t0 = time.perf_counter()
        missed = self.seam_cells[:0] if self._complete else self._seam_seeds(value, iso)
        seam_seeds = int(missed.size)
        tested = 0 if self._complete else int(self.seam_cells.size)
        if missed.size:
            if self._propagator is None:
                from polygen.volume.propagate import Propagator

                self._propagator = Propagator(self.vol, self.field)
            extra = self._propagator.extract(value, missed, normals=None)
            # a construction may leave out part of a piece it found (measured: the edge-centred one on a
            # partition whose boundary is not a manifold); a cell's triangles are made together, so the
            # cells it made are kept and the propagation fills in the rest
            iso = _with_missed(iso, extra, self._made)
        t_seam = time.perf_counter() - t0
        return iso, {"cells_tested": iso.cells_tested + tested, "seam_seeds": seam_seeds,
                     "cells_intersected": iso.cells_intersected, "vertex_lookups": iso.vertex_lookups,
                     "t1": iso.t1 + t_seam, "t2": iso.t2, "t3": iso.t3, "method": iso.method}

    def _piece(self, iso, normals, empty=np.empty):
        """The arrays of a piece (see :func:`merge`): global keys, seam marks, this side's normals.

        A vertex both of whose edge nodes lie on another partition too may be
        made there as well (a **seam vertex**); every other vertex, and every
        triangle, is made here only. So a non-seam vertex's mean normal is
        final here (all its triangles are here, summed in the order the
        stitched surface lists them), and only the seam vertices and the
        triangles touching them (``seam``, ``seam_tris``) need the stitch.

        ``empty(shape, dtype)`` allocates the arrays that travel (keys,
        vertices, seam, triangles, seam_tris, triangle_cells, normals:
        :meth:`piece_bytes_bound` bounds their bytes), so a worker can hand out
        views on a shared-memory block written in place; ``seam`` and
        ``seam_tris`` get their upper bound (``n``, ``m`` rows) and travel as
        their first rows.
        """
        t0 = time.perf_counter()
        vol = self.vol
        n = iso.vertices.shape[0]
        gkeys = empty(n, np.int64)
        verts = empty((n, 3), np.float64)
        verts[...] = iso.vertices
        seam = _jit.scratch(n, np.bool_)
        seam_at = empty(n, np.int64)
        n_seam = _global_keys(np.ascontiguousarray(iso.vertex_keys, np.int64), self._key_map, gkeys, seam, seam_at)
        tri_in = np.ascontiguousarray(iso.triangles, np.int64)
        m = tri_in.shape[0]
        tri = empty((m, 3), np.int32 if n < 2**31 else np.int64)
        seam_tris = empty(m, np.int64)
        gcells = empty(m, np.int32 if self._cells32 else np.int64)
        nrm = empty((n, 3), np.float64) if normals is not None else _jit.scratch((0, 3))
        flat = np.zeros(n if normals is not None else 0, np.bool_)
        n_seam_tris, n_flat = _piece_triangles(verts, tri_in, seam, tri, seam_tris, nrm, flat)
        _global_cells(np.ascontiguousarray(iso.triangle_cells, np.int64),
                      np.zeros(0, np.int64) if self.cell_ids is None else self.cell_ids, self.cell_offset, gcells)
        fallback = None
        if normals is not None:
            fallback = (np.zeros(0, np.int64), np.zeros((0, 3)))
            if n_flat:
                fallback = self._fallback(iso, seam, nrm, flat)
        return {"keys": gkeys, "vertices": verts, "normals": nrm if normals is not None else None,
                "seam": seam_at[:n_seam], "triangles": tri, "seam_tris": seam_tris[:n_seam_tris],
                "triangle_cells": gcells, "fallback": fallback, "flat": int(flat.sum()),
                "piece_s": time.perf_counter() - t0}

    def extract_many(self, values, normals="mean"):
        """:meth:`extract` of each value, one caller at a time (a worker's task threads and its actor's share it)."""
        with self._lock:
            return [self.extract(v, normals) for v in values]

    def _fallback(self, iso, seam, nrm, flat):
        """The normals of vertices on an edge that touch a zero-area triangle here and got none.

        Such a vertex can get a zero mean normal (all its triangles of zero
        area, or rounding-level ones that cancel); the single volume then
        gives it the direction of its edge towards increasing scalar
        (:func:`~polygen.volume.surface.vertex_normals`). A non-seam vertex's
        normal is final: set here. A seam vertex's is made by the stitch:
        its ``(keys, directions)`` rows go with the piece.
        """
        edges = self.vol.edges
        lone = np.flatnonzero(flat)
        lone = lone[iso.vertex_keys[lone] < edges.shape[0]]
        e = edges[iso.vertex_keys[lone]]
        pts, sv = self.vol.points, self.vol.fields[self.field]
        d = (pts[e[:, 1]] - pts[e[:, 0]]) * np.sign(sv[e[:, 1]] - sv[e[:, 0]])[:, None]
        d = d / np.linalg.norm(d, axis=1)[:, None]
        on_seam = seam[lone]
        mine = lone[~on_seam]
        zero = ~(np.abs(nrm[mine]).sum(axis=1) > 0.0)
        nrm[mine[zero]] = d[~on_seam][zero]
        es = e[on_seam]  # edge vertices: their global key a * n_ids + b (a < b: nodes numbered by global id)
        return self.global_ids[es[:, 0]] * self.n_ids + self.global_ids[es[:, 1]], d[on_seam]

    # ---- the two-phase query of a client on this machine (polygen.volume.distributed): the seam first, then
    # this partition's rows written straight into the stitched surface's arrays

    def seam_of(self, iso):
        """``(seam, seam_keys)``: the indices (ascending, int64) and global keys of ``iso``'s seam vertices.

        What the client needs from every partition, with the vertex and
        triangle counts, to lay out the stitched surface
        (:func:`seam_plan`) before any partition writes its rows.
        """
        m = self.marks(iso)
        return m["seam"], m["seam_keys"]

    def marks(self, iso):
        """:meth:`seam_of` and, kept here for :meth:`write_rows`, every vertex's global key and seam mark.

        Returns a dict: ``seam``, ``seam_keys`` (what the client needs),
        ``keys`` (n,) int64 and ``is_seam`` (n,) bool (one pass over the
        vertices and the edges they lie on, not one per phase).
        """
        n = iso.vertices.shape[0]
        keys, is_seam, at = _jit.scratch(n, np.int64), _jit.scratch(n, np.bool_), _jit.scratch(n, np.int64)
        ns = _global_keys(np.ascontiguousarray(iso.vertex_keys, np.int64), self._key_map, keys, is_seam, at)
        at = at[:ns].copy()
        return {"seam": at, "seam_keys": keys[at], "keys": keys, "is_seam": is_seam}

    def write_rows(self, iso, normals, plan, out, marks=None):
        """Write this partition's rows of a stitched surface into ``out`` (the whole surface's arrays).

        ``plan``: ``row0`` (this partition's first vertex row), ``gone``
        (ascending local indices of its seam vertices an earlier partition
        keeps) and ``targets`` (their rows there), ``tri0`` (its first
        triangle row), as :func:`seam_plan` lays them out. ``out``:
        ``keys`` (V,) int64, ``vertices`` (V, 3), ``normals`` (V, 3) or None,
        ``triangles`` (T, 3) int64, ``triangle_cells`` (T,) int64. The rows
        are :func:`merge`'s, bit for bit: the kept vertices with their global
        keys, the normals of this side (final but at seam vertices), the
        triangles renumbered, the global cell ids.

        ``marks``: :meth:`marks` of ``iso`` (made here when not given).

        Returns ``seam_tris`` (local triangle indices touching a seam vertex,
        int64), ``fallback`` and ``flat`` as :meth:`_piece` makes them, and
        ``piece_s``.
        """
        t0 = time.perf_counter()
        n, m = iso.vertices.shape[0], iso.triangles.shape[0]
        row0, tri0 = int(plan["row0"]), int(plan["tri0"])
        gone = np.asarray(plan["gone"], np.int64)
        targets = np.asarray(plan["targets"], np.int64)
        newidx = _jit.scratch(n if gone.size else 0, np.int64)
        marks = self.marks(iso) if marks is None else marks
        seam = marks["is_seam"]
        _write_vertices(marks["keys"], iso.vertices, gone, targets, row0, out["keys"], out["vertices"], newidx)
        if normals is not None:
            # nothing dropped: the normals summed straight into the surface's rows; else here, then the kept rows
            nrm = out["normals"][row0:row0 + n] if not gone.size else _jit.scratch((n, 3))
        else:
            nrm = _jit.scratch((0, 3))
        flat = np.zeros(n if normals is not None else 0, np.bool_)
        seam_tris = _jit.scratch(m, np.int64)
        n_seam_tris, n_flat = _write_triangles(
            iso.vertices, np.ascontiguousarray(iso.triangles, np.int64), seam, newidx, row0, out["triangles"], tri0,
            seam_tris, nrm, flat, np.ascontiguousarray(iso.triangle_cells, np.int64),
            np.zeros(0, np.int64) if self.cell_ids is None else self.cell_ids, self.cell_offset,
            out["triangle_cells"])
        fallback = None
        if normals is not None:
            fallback = (np.zeros(0, np.int64), np.zeros((0, 3)))
            if n_flat:
                fallback = self._fallback(iso, seam, nrm, flat)
            if gone.size:
                _kept_rows(nrm, gone, out["normals"], row0)
        return {"seam_tris": seam_tris[:n_seam_tris].copy(), "fallback": fallback, "flat": int(flat.sum()),
                "piece_s": time.perf_counter() - t0}


@njit
def _missed_seam_cells(seam_cells, seam_min, seam_max, value, tri_cells, made, out):
    """The seam cells the surface ``value`` crosses (a node below, one above) that no triangle lies in, into
    ``out`` in ``seam_cells``' order (their count returned); ``made`` (a mark per cell, all False) is left so."""
    for t in range(tri_cells.shape[0]):
        made[tri_cells[t]] = True
    n = 0
    for j in range(seam_cells.shape[0]):
        if seam_min[j] < value and value < seam_max[j] and not made[seam_cells[j]]:
            out[n] = seam_cells[j]
            n += 1
    for t in range(tri_cells.shape[0]):
        made[tri_cells[t]] = False
    return n


@njit
def _key_map(edges, gids, shared, n_ids, out):
    """The global key of every vertex key of a partition (edge ``e``: ``a * n_ids + b`` over its nodes' global
    ids ``a < b``; node ``a`` at ``len(edges) + a``: ``a * n_ids + a``), stored as ``-1 - key`` where both
    nodes lie on another partition too (a seam vertex)."""
    ne = edges.shape[0]
    for e in range(ne):
        a = edges[e, 0]
        b = edges[e, 1]
        k = gids[a] * n_ids + gids[b]
        out[e] = -1 - k if shared[a] and shared[b] else k
    for a in range(gids.shape[0]):
        k = gids[a] * n_ids + gids[a]
        out[ne + a] = -1 - k if shared[a] else k


@njit
def _global_keys(keys, key_map, out, seam, seam_at):
    """Global pair keys of a piece's vertices (from :func:`_key_map`), whether both nodes of each lie on
    another partition too (a seam vertex), and the seam vertices' indices in ascending order (``seam_at``;
    their count returned)."""
    ns = 0
    for v in range(keys.shape[0]):
        k = key_map[keys[v]]
        if k < 0:
            out[v] = -1 - k
            seam[v] = True
            seam_at[ns] = v
            ns += 1
        else:
            out[v] = k
            seam[v] = False
    return ns


@njit
def _write_vertices(keys, verts, gone, targets, row0, out_keys, out_verts, newidx):
    """A piece's kept vertices written from row ``row0`` on (global keys, positions); with ``gone``
    (ascending local indices dropped, ``targets`` their rows elsewhere) each vertex's row in ``newidx``.
    Returns the next free row."""
    ng = gone.shape[0]
    g = 0
    r = row0
    for v in range(keys.shape[0]):
        if g < ng and gone[g] == v:
            newidx[v] = targets[g]
            g += 1
            continue
        if ng > 0:
            newidx[v] = r
        out_keys[r] = keys[v]
        for d in range(3):
            out_verts[r, d] = verts[v, d]
        r += 1
    return r


@njit
def _write_triangles(vertices, triangles, seam, newidx, row0, out_tri, tri0, seam_tris, nrm, flat, cells, cell_ids,
                     offset, out_cells):
    """:func:`_piece_triangles` writing the stitched surface's rows: the triangles renumbered (``newidx[v]``,
    or ``row0 + v`` when it is empty) from row ``tri0`` on, their global cell ids (as :func:`_global_cells`),
    the triangles touching a seam vertex, and, when ``nrm`` has rows, this side's mean normals (the same
    arithmetic, bit for bit) and ``flat``. Returns ``(seam triangles, flat triangles)``."""
    do_normals = nrm.shape[0] > 0
    mapped = newidx.shape[0] > 0
    by_ids = cell_ids.shape[0] > 0
    if do_normals:
        nrm[:] = 0.0
    ns = 0
    n_flat = 0
    for t in range(triangles.shape[0]):
        i0 = triangles[t, 0]
        i1 = triangles[t, 1]
        i2 = triangles[t, 2]
        if mapped:
            out_tri[tri0 + t, 0] = newidx[i0]
            out_tri[tri0 + t, 1] = newidx[i1]
            out_tri[tri0 + t, 2] = newidx[i2]
        else:
            out_tri[tri0 + t, 0] = row0 + i0
            out_tri[tri0 + t, 1] = row0 + i1
            out_tri[tri0 + t, 2] = row0 + i2
        out_cells[tri0 + t] = cell_ids[cells[t]] if by_ids else cells[t] + offset
        # written out in each kernel: through a helper (numba inline='always', or a plain call) this loop took 4x
        # as long (58 against 15 ns per triangle without normals, 68 against 21 with, 2M-sized)
        if seam[i0] or seam[i1] or seam[i2]:
            seam_tris[ns] = t
            ns += 1
        if do_normals:
            nx, ny, nz = _m.triangle_normal(vertices, i0, i1, i2)
            for i in (i0, i1, i2):
                nrm[i, 0] += nx
                nrm[i, 1] += ny
                nrm[i, 2] += nz
            if nx == 0.0 and ny == 0.0 and nz == 0.0:
                flat[i0] = flat[i1] = flat[i2] = True
                n_flat += 1
    if do_normals:
        _m._normalize(nrm)
    return ns, n_flat


@njit
def _kept_rows(nrm, gone, out, row0):
    """The rows of ``nrm`` but ``gone`` (ascending) into ``out`` from row ``row0`` on."""
    ng = gone.shape[0]
    g = 0
    r = row0
    for v in range(nrm.shape[0]):
        if g < ng and gone[g] == v:
            g += 1
            continue
        for d in range(3):
            out[r, d] = nrm[v, d]
        r += 1


@njit
def _global_cells(cells, cell_ids, offset, out):
    """Global cell ids of a piece's triangles: ``cell_ids[cells]`` (a split volume's), else ``cells + offset``
    (pieces from files, numbered piece after piece), in ``out``'s dtype."""
    if cell_ids.shape[0] > 0:
        for t in range(cells.shape[0]):
            out[t] = cell_ids[cells[t]]
    else:
        for t in range(cells.shape[0]):
            out[t] = cells[t] + offset


@njit
def _piece_triangles(vertices, triangles, seam, tri_out, seam_tris, nrm, flat):
    """One pass over a piece's triangles: ``tri_out`` (the travel dtype), the triangles touching a seam
    vertex (``seam_tris``; their count), and, when ``nrm`` has rows, the mean normals (5.3.1) with the
    arithmetic of :func:`polygen.volume.marching._mean_normals` and ``flat`` marking the vertices of
    zero-area triangles (their count)."""
    do_normals = nrm.shape[0] > 0
    if do_normals:
        nrm[:] = 0.0
    ns = 0
    n_flat = 0
    for t in range(triangles.shape[0]):
        i0 = triangles[t, 0]
        i1 = triangles[t, 1]
        i2 = triangles[t, 2]
        tri_out[t, 0] = i0
        tri_out[t, 1] = i1
        tri_out[t, 2] = i2
        # written out here too (see _write_triangles: a helper made the loop 4x slower)
        if seam[i0] or seam[i1] or seam[i2]:
            seam_tris[ns] = t
            ns += 1
        if do_normals:
            nx, ny, nz = _m.triangle_normal(vertices, i0, i1, i2)
            for i in (i0, i1, i2):
                nrm[i, 0] += nx
                nrm[i, 1] += ny
                nrm[i, 2] += nz
            if nx == 0.0 and ny == 0.0 and nz == 0.0:
                flat[i0] = flat[i1] = flat[i2] = True
                n_flat += 1
    if do_normals:
        _m._normalize(nrm)
    return ns, n_flat


@njit
def _merge_piece(keys, vertices, normals, keep, tri, cells, new_index, out_keys, out_vertices, out_normals,
                 out_tri, out_cells, row0, tri0):
    """One piece written into the merged arrays in one pass: its kept vertices (``keep``; all when empty)
    with their keys and normals (when ``normals`` has rows) from row ``row0`` on, its triangles in the merged
    numbering (``new_index[v]``, or ``row0 + v`` when ``new_index`` is empty: nothing dropped) and global
    cell ids from row ``tri0`` on, in the merged arrays' dtypes. Returns the next free vertex row."""
    r = row0
    every = keep.shape[0] == 0
    with_normals = normals.shape[0] > 0
    for i in range(keys.shape[0]):
        if every or keep[i]:
            out_keys[r] = keys[i]
            for d in range(3):
                out_vertices[r, d] = vertices[i, d]
            if with_normals:
                for d in range(3):
                    out_normals[r, d] = normals[i, d]
            r += 1
    mapped = new_index.shape[0] > 0
    for t in range(tri.shape[0]):
        for d in range(3):
            out_tri[tri0 + t, d] = new_index[tri[t, d]] if mapped else row0 + tri[t, d]
        out_cells[tri0 + t] = cells[t]
    return r


@njit
def _seam_normals(vertices, triangles, seam_tris, seam, is_seam, nrm):
    """The mean normals of the seam vertices, from all their triangles (``seam_tris``, in the surface's
    order): the sums and the arithmetic of :func:`polygen.volume.marching._mean_normals`, bit for bit."""
    for j in range(seam.shape[0]):
        for d in range(3):
            nrm[seam[j], d] = 0.0
    for j in range(seam_tris.shape[0]):
        t = seam_tris[j]
        i0 = triangles[t, 0]
        i1 = triangles[t, 1]
        i2 = triangles[t, 2]
        nx, ny, nz = _m.triangle_normal(vertices, i0, i1, i2)
        for i in (i0, i1, i2):
            if is_seam[i]:
                nrm[i, 0] += nx
                nrm[i, 1] += ny
                nrm[i, 2] += nz
    for j in range(seam.shape[0]):
        v = seam[j]
        ln = np.sqrt(nrm[v, 0] ** 2 + nrm[v, 1] ** 2 + nrm[v, 2] ** 2)
        if ln > 0.0:
            for d in range(3):
                nrm[v, d] /= ln


def _with_missed(iso, extra, made):
    """Surface ``iso`` and the triangles of ``extra`` (same partition and value) in cells ``iso`` has none in,
    as one surface whose vertex keys are unique: ``extra``'s vertices already in ``iso`` are ``iso``'s.

    ``iso`` first, then ``extra``'s new vertices in their order (every one: a vertex of a triangle dropped
    stays), its kept triangles renumbered. ``made``: a mark per cell, all False (left so). O(size of both),
    no sort of ``iso``'s arrays (10M, a seam piece of one triangle beside a surface of 1M: 45-75 ms with
    ``np.isin`` and ``np.unique``); each surface's own keys must be unique (a method's and a propagation's
    are).
    """
    keep = _jit.scratch(extra.triangle_cells.shape[0], np.bool_)
    _cells_not_made(np.ascontiguousarray(iso.triangle_cells, np.int64),
                    np.ascontiguousarray(extra.triangle_cells, np.int64), made, keep)
    ek = np.ascontiguousarray(extra.vertex_keys, np.int64)
    order = np.argsort(ek, kind="stable")
    at = np.full(ek.shape[0], -1, np.int64)
    _find_keys(np.ascontiguousarray(iso.vertex_keys, np.int64), ek[order], order, at)
    new = at < 0
    n = iso.vertices.shape[0]
    at[new] = n + np.arange(int(new.sum()), dtype=np.int64)
    return dataclasses.replace(
        iso, vertices=np.concatenate([iso.vertices, extra.vertices[new]]), normals=None,
        triangles=np.concatenate([iso.triangles, at[extra.triangles[keep]]]),
        vertex_keys=np.concatenate([iso.vertex_keys, ek[new]]),
        triangle_cells=np.concatenate([iso.triangle_cells, extra.triangle_cells[keep]]),
        cells_tested=iso.cells_tested + extra.cells_tested,
        cells_intersected=iso.cells_intersected + extra.cells_intersected,
        vertex_lookups=iso.vertex_lookups + extra.vertex_lookups, t2=iso.t2 + extra.t2, t3=iso.t3 + extra.t3)


@njit
def _cells_not_made(cells, other, made, keep):
    """``keep[t]``: no entry of ``cells`` is ``other[t]`` (``made``: a mark per cell, all False, left so)."""
    for t in range(cells.shape[0]):
        made[cells[t]] = True
    for t in range(other.shape[0]):
        keep[t] = not made[other[t]]
    for t in range(cells.shape[0]):
        made[cells[t]] = False


@njit
def _find_keys(keys, sorted_keys, order, at):
    """``at[order[j]] = v`` for each ``keys[v]`` equal to ``sorted_keys[j]`` (binary search per key)."""
    m = sorted_keys.shape[0]
    for v in range(keys.shape[0]):
        k = keys[v]
        lo = 0
        hi = m
        while lo < hi:
            mid = (lo + hi) >> 1
            if sorted_keys[mid] < k:
                lo = mid + 1
            else:
                hi = mid
        if lo < m and sorted_keys[lo] == k:
            at[order[lo]] = v


# ----------------------------------------------------------------- result

@dataclasses.dataclass(frozen=True, eq=False)
class StitchedIsoSurface(IsoSurface):
    """An :class:`~polygen.volume.surface.IsoSurface` stitched from the partitions' pieces.

    ``vertex_keys`` are global: ``a * n_ids + b`` for a vertex on the edge
    between global nodes ``a < b``, ``a * n_ids + a`` for one exactly on node
    ``a``. ``triangle_cells`` are global cell ids. The counters and ``t1``,
    ``t2``, ``t3`` are sums over the partitions (work, not wall clock).

    Attributes
    ----------
    partitions : tuple of dict
        Each partition's counters (``IsoSurface.counters()`` keys).
    seam_vertices : int
        Vertices made by more than one partition (kept once).
    stitch_s : float
        Seconds of merging (summed over the merges of a tree) and of the
        mean normals: on the client for :func:`stitch`, on the workers for
        the stitch on Dask.
    stitch_cpu_s : float
        The same in CPU seconds of the threads that did it (on a shared
        machine, the wall clock also counts waiting for a core).
    n_ids : int
        The number of global node ids (the base of the keys).
    """

    partitions: tuple = ()
    seam_vertices: int = 0
    stitch_s: float = 0.0
    stitch_cpu_s: float = 0.0
    n_ids: int = 0


_COUNTERS = ("cells_tested", "cells_intersected", "vertex_lookups", "seam_seeds", "t1", "t2", "t3", "piece_s")


def _parts(piece):
    """The per-partition counters a piece carries: its own (a partition's piece) or its partitions' (merged)."""
    if "parts" in piece:
        return list(piece["parts"])
    return [{k: piece[k] for k in _COUNTERS}
            | {"n_triangles": int(piece["triangles"].shape[0]), "n_vertices": int(piece["keys"].shape[0])}]


def merge(pieces, *, n_ids):
    """One piece from neighbouring pieces of one value (dicts of :meth:`PreparedPartition.extract` or of ``merge``).

    Only the **seam vertices** (``seam``: vertices whose edge's two nodes
    both lie on more than one partition; a superset of those made by two
    sides) are matched, by global key: a seam vertex made again by a later
    piece is dropped and its triangles point at the first piece's copy
    (both sides compute it from the same edge end, bit for bit). Every
    other vertex is made by one piece only and is taken as it is, after the
    vertices of the pieces before it; triangles are renumbered in one pass
    and kept in piece order, except a triangle lying in a shared face at
    ``C`` (three node vertices: seam vertices) made by two cells, kept once
    from the lower global cell id. The result is a piece again, so pieces
    can be merged in any grouping of consecutive pieces -- all at once
    (:func:`stitch`) or pairwise up a tree (:func:`reduce_tree`, on the
    Dask workers) -- with the same arrays. Normals: a piece's normals are
    final but at seam vertices, which :func:`finish` makes from
    ``seam_tris`` (the triangles touching a seam vertex).

    Parameters
    ----------
    pieces : list of dict
        ``keys`` (n_i,) int64 global vertex keys, ``vertices`` (n_i, 3)
        float64, ``normals`` (n_i, 3) float64 or None, ``seam`` (s_i,) int64
        (ascending vertex indices), ``triangles`` (m_i, 3) int32/int64,
        ``seam_tris`` (q_i,) int64 (ascending triangle indices),
        ``triangle_cells`` (m_i,) int32/int64 global cell ids, ``fallback``
        (keys, directions) of seam vertices or None, the counters.
    n_ids : int
        The number of global node ids (the base of the keys).

    Returns
    -------
    dict
        The same fields (``triangles`` and ``triangle_cells`` int64),
        ``parts`` (each partition's counters, in piece order),
        ``seam_vertices`` (vertices merged away so far), ``merge_s`` and
        ``merge_cpu_s`` (seconds of merging so far, wall clock and the
        merging thread's CPU time, summed over the tree).
    """
    t0, c0 = time.perf_counter(), time.thread_time()
    if not pieces:
        return {"keys": np.zeros(0, np.int64), "vertices": np.zeros((0, 3)), "normals": None,
                "seam": np.zeros(0, np.int64), "triangles": np.zeros((0, 3), np.int64),
                "seam_tris": np.zeros(0, np.int64), "triangle_cells": np.zeros(0, np.int64), "fallback": None,
                "parts": [], "seam_vertices": 0, "merge_s": 0.0, "merge_cpu_s": 0.0, "method": ""}
    sizes = [p["keys"].shape[0] for p in pieces]
    plans, first_new, base, n_dup = seam_plan(sizes, [p["seam"] for p in pieces],
                                              [p["keys"][p["seam"]] for p in pieces])
    maps, keeps = [], []
    for n, plan in zip(sizes, plans):
        gone = plan["gone"]
        if gone.size:
            keep = np.ones(n, bool)
            keep[gone] = False
            new = plan["row0"] + np.cumsum(keep) - 1
            new[gone] = plan["targets"]  # kept by an earlier piece
        else:  # nothing dropped: vertex v goes to row row0 + v (no map made)
            keep = new = None
        maps.append(new)
        keeps.append(keep)

    # every piece written into the merged arrays in one pass each, in piece order: its kept vertices, its
    # triangles renumbered, its cell ids (new arrays, never a piece's: finish writes the seam normals into
    # them, and pieces may be views on shared memory)
    with_normals = pieces[0].get("normals") is not None
    keys, verts = _jit.empty(base, np.int64), _jit.empty((base, 3))
    nrm = _jit.empty((base, 3)) if with_normals else None
    no_keep, no_map, no_nrm = np.zeros(0, np.bool_), np.zeros(0, np.int64), np.zeros((0, 3))
    tri_sizes = [p["triangles"].shape[0] for p in pieces]
    tri_off = np.cumsum([0] + tri_sizes)
    tri = _jit.empty((tri_off[-1], 3), np.int64)
    tcell = _jit.empty(tri_off[-1], np.int64)
    row0 = 0
    for p, kp, new, t0_ in zip(pieces, keeps, maps, tri_off[:-1]):
        row0 = _merge_piece(p["keys"], p["vertices"], p["normals"] if with_normals else no_nrm,
                            no_keep if kp is None else kp, p["triangles"], p["triangle_cells"],
                            no_map if new is None else new, keys, verts, nrm if with_normals else no_nrm,
                            tri, tcell, row0, int(t0_))
    seam_tris = np.concatenate([p["seam_tris"] + o for p, o in zip(pieces, tri_off[:-1])]).astype(np.int64, copy=False)
    seam = np.sort(first_new)
    tri, tcell, seam_tris = drop_face_twins(keys, tri, tcell, seam_tris, n_ids)
    fb = [p["fallback"] for p in pieces if p.get("fallback") is not None]
    fallback = (np.concatenate([f[0] for f in fb]), np.concatenate([f[1] for f in fb]).reshape(-1, 3)) if fb else None
    return {"keys": keys, "vertices": verts, "normals": nrm, "seam": seam, "triangles": tri, "seam_tris": seam_tris,
            "triangle_cells": tcell, "fallback": fallback, "parts": [c for p in pieces for c in _parts(p)],
            "seam_vertices": sum(p.get("seam_vertices", 0) for p in pieces) + n_dup,
            "merge_s": sum(p.get("merge_s", 0.0) for p in pieces) + time.perf_counter() - t0,
            "merge_cpu_s": sum(p.get("merge_cpu_s", 0.0) for p in pieces) + time.thread_time() - c0,
            "method": pieces[0]["method"]}


def seam_plan(sizes, seams, seam_keys):
    """Where each piece's vertices go in the merged piece: :func:`merge`'s layout from the seam vertices only.

    Parameters
    ----------
    sizes : list of int
        Each piece's vertex count, in piece order.
    seams : list of (s_i,) int64
        Each piece's seam vertex indices, ascending.
    seam_keys : list of (s_i,) int64
        Their global keys.

    Returns
    -------
    plans : list of dict
        Per piece: ``row0`` (its first row), ``gone`` (ascending indices of
        its seam vertices an earlier piece made too: dropped) and
        ``targets`` (their rows, the earlier piece's copy).
    first_new : (u,) int64
        The row of each distinct seam key (its first copy, in piece order).
    n_vertices : int
        Rows of the merged piece.
    n_dropped : int
        Seam vertices dropped.
    """
    k = len(sizes)
    skeys = np.concatenate([np.asarray(s, np.int64) for s in seam_keys]) if k else np.zeros(0, np.int64)
    sowner = np.repeat(np.arange(k), [len(s) for s in seams])
    sidx = np.concatenate([np.asarray(s, np.int64) for s in seams]) if k else np.zeros(0, np.int64)
    uniq, first, inv = np.unique(skeys, return_index=True, return_inverse=True)
    inv = inv.ravel()
    dup = np.ones(skeys.shape[0], bool)
    dup[first] = False
    first_new = _jit.scratch(uniq.shape[0], np.int64)
    plans, base = [], 0
    for i in range(k):
        here = sowner == i
        gone = sidx[here & dup]
        kept_here = here & ~dup
        again = inv[here & dup]
        twice = sowner[first[again]] == i
        if twice.any():  # its row is not laid out yet: a wrong surface, never a guess
            raise PartitionError(f"piece {i} names seam vertex key {int(uniq[again[twice][0]])} twice: its "
                                 "method made one vertex twice")
        targets = first_new[again]  # an earlier piece's rows: set already
        kept = sidx[kept_here]
        # a kept vertex v goes to row base + v less the dropped ones before it
        first_new[inv[kept_here]] = base + kept - (np.searchsorted(gone, kept) if gone.size else 0)
        plans.append({"row0": base, "gone": gone, "targets": targets})
        base += int(sizes[i]) - gone.size
    return plans, first_new, base, int(dup.sum())


def drop_face_twins(keys, tri, tcell, seam_tris, n_ids):
    """A triangle lying in a shared face at ``C`` (three node vertices: seam vertices) made by a cell on each
    side, kept once, from the lower global cell id: ``(tri, tcell, seam_tris)``, new arrays only when one
    goes."""
    if n_ids and seam_tris.size > 1:
        sk = keys[tri[seam_tris]]
        cand = seam_tris[np.all((sk // n_ids) == (sk % n_ids), axis=1)]
        if cand.size > 1:
            cand = cand[np.argsort(tcell[cand], kind="stable")]
            _, keep_first = np.unique(np.sort(keys[tri[cand]], axis=1), axis=0, return_index=True)
            if keep_first.size < cand.size:
                keep_t = np.ones(tri.shape[0], bool)
                keep_t[cand] = False
                keep_t[cand[keep_first]] = True
                new_t = np.cumsum(keep_t) - 1
                seam_tris = new_t[seam_tris[keep_t[seam_tris]]]
                tri, tcell = tri[keep_t], tcell[keep_t]
    return tri, tcell, seam_tris


def rows_layout(found):
    """The stitched surface's layout from each partition's counts and seam (the first phase of a direct stitch).

    A **direct stitch** writes every partition's rows straight into the
    stitched surface's arrays (:meth:`PreparedPartition.write_rows`), with
    the rows :func:`merge` gives, so nothing is copied after: first each
    partition reports its vertex and triangle counts and its seam vertices
    (:meth:`PreparedPartition.seam_of`), then this lays out the rows, then
    each partition writes its own, then :func:`finish_rows` makes the seam
    normals and the surface.

    Parameters
    ----------
    found : list of dict
        Per partition, in order: ``n`` (vertices), ``m`` (triangles),
        ``seam`` and ``seam_keys`` (:meth:`PreparedPartition.seam_of`).

    Returns
    -------
    dict
        ``plans`` (per partition: ``row0``, ``gone``, ``targets``, ``tri0``),
        ``first_new`` (the seam vertices' rows), ``n_vertices``,
        ``n_triangles``, ``n_dropped``.
    """
    plans, first_new, nv, n_dup = seam_plan([f["n"] for f in found], [f["seam"] for f in found],
                                            [f["seam_keys"] for f in found])
    tri0 = np.cumsum([0] + [int(f["m"]) for f in found])
    for plan, t in zip(plans, tri0[:-1]):
        plan["tri0"] = int(t)
    return {"plans": plans, "first_new": first_new, "n_vertices": int(nv), "n_triangles": int(tri0[-1]),
            "n_dropped": n_dup}


#: the arrays of a stitched surface a direct stitch writes: (name, columns, dtype)
ROW_ARRAYS = (("keys", 0, np.int64), ("vertices", 3, np.float64), ("normals", 3, np.float64),
              ("triangles", 3, np.int64), ("triangle_cells", 0, np.int64))


def rows_arrays(layout, normals, empty=None, buf=None, offset=0):
    """The (uninitialised) arrays of a stitched surface laid out by :func:`rows_layout`, and the bytes they take.

    From ``empty(shape, dtype)`` (default :func:`polygen._jit.empty`), or,
    with ``buf``, views on the buffer from byte ``offset`` on, each array on
    a 64-byte line (``buf=None`` and ``empty=False``: only the bytes).
    ``normals`` is None for a surface without normals.
    """
    out, at = {}, offset
    for name, cols, dtype in ROW_ARRAYS:
        if name == "normals" and normals is None:
            out[name] = None
            continue
        rows = layout["n_triangles"] if name in ("triangles", "triangle_cells") else layout["n_vertices"]
        shape = (rows, cols) if cols else (rows,)
        nbytes = rows * max(cols, 1) * np.dtype(dtype).itemsize
        if buf is not None:
            out[name] = np.ndarray(shape, dtype, buffer=buf, offset=at)
        elif empty is not False:
            out[name] = (empty or _jit.empty)(shape, dtype)
        at += -(-nbytes // 64) * 64
    return out, at - offset


def finish_rows(value, out, layout, found, written, *, n_ids, normals="mean", t0=None, c0=None):
    """The :class:`StitchedIsoSurface` of a direct stitch once every partition wrote its rows into ``out``.

    ``found``: the partitions' first-phase answers (``n``, ``m``, ``seam``,
    ``seam_keys`` and their counters); ``written``: their
    :meth:`PreparedPartition.write_rows` answers. The arrays are ``out``'s
    own (a triangle in a shared face at ``C`` made twice is dropped by
    copying, as :func:`merge` does). ``t0``, ``c0``: when the stitch began
    (``time.perf_counter``, ``time.thread_time``; default now).
    """
    t0 = time.perf_counter() if t0 is None else t0
    c0 = time.thread_time() if c0 is None else c0
    keys, tri, tcell = out["keys"], out["triangles"], out["triangle_cells"]
    seam_tris = np.concatenate([np.zeros(0, np.int64)] + [np.asarray(w["seam_tris"], np.int64) + p["tri0"]
                                                          for w, p in zip(written, layout["plans"])])
    tri, tcell, seam_tris = drop_face_twins(keys, tri, tcell, seam_tris, n_ids)
    fb = [w["fallback"] for w in written if w.get("fallback") is not None]
    fallback = (np.concatenate([f[0] for f in fb]), np.concatenate([f[1] for f in fb]).reshape(-1, 3)) if fb else None
    parts = [{k: f[k] for k in _COUNTERS if k != "piece_s"} | {"piece_s": w["piece_s"], "n_triangles": int(f["m"]),
                                                              "n_vertices": int(f["n"])}
             for f, w in zip(found, written)]
    piece = {"keys": keys, "vertices": out["vertices"], "normals": out["normals"],
             "seam": np.sort(layout["first_new"]), "triangles": tri, "seam_tris": seam_tris, "triangle_cells": tcell,
             "fallback": fallback, "parts": parts, "seam_vertices": layout["n_dropped"],
             "merge_s": time.perf_counter() - t0, "merge_cpu_s": time.thread_time() - c0,
             "method": found[0]["method"] if found else ""}
    return finish(value, piece, n_ids=n_ids, normals=normals)


def direct_stitch(value, partitions, *, n_ids, normals="mean"):
    """One surface from prepared partitions (here, one after another), each writing its rows in place.

    The same arrays as :func:`stitch` of their pieces (:meth:`PreparedPartition.extract`),
    without the pieces: what :class:`PartitionedMethod` does, and what a
    client on the workers' machine does through shared memory
    (:mod:`polygen.volume.distributed`).
    """
    # the methods one partition after another (each on all of numba's threads); the marks and the rows, one
    # thread per partition (their kernels release the GIL, and each partition writes rows of its own)
    surfaces = [p.surface(value) for p in partitions]
    marks = _side_by_side(lambda i: partitions[i].marks(surfaces[i][0]), len(partitions))
    found = [counters | {"n": iso.vertices.shape[0], "m": iso.triangles.shape[0], "seam": mk["seam"],
                         "seam_keys": mk["seam_keys"]} for (iso, counters), mk in zip(surfaces, marks)]
    t0, c0 = time.perf_counter(), time.thread_time()
    layout = rows_layout(found)
    out, _ = rows_arrays(layout, normals)
    written = _side_by_side(lambda i: partitions[i].write_rows(surfaces[i][0], normals, layout["plans"][i], out,
                                                               marks[i]), len(partitions))
    return finish_rows(value, out, layout, found, written, n_ids=n_ids, normals=normals, t0=t0, c0=c0)


_POOL = None
_POOL_LOCK = threading.Lock()


def _side_by_side(fn, n):
    """``[fn(0), ..., fn(n - 1)]``, on up to numba's thread count of threads at once (a pool kept here)."""
    import numba

    if n < 2 or numba.get_num_threads() < 2:
        return [fn(i) for i in range(n)]
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            from concurrent.futures import ThreadPoolExecutor

            _POOL = ThreadPoolExecutor(max_workers=os.cpu_count() or 2, thread_name_prefix="polygen-partitions")
        pool = _POOL
    width = min(n, numba.get_num_threads())
    out = [None] * n
    for a in range(0, n, width):  # at most ``width`` at once
        futures = [pool.submit(fn, i) for i in range(a, min(n, a + width))]
        for i, f in enumerate(futures, a):
            out[i] = f.result()
    return out


def reduce_tree(items, combine):
    """``items`` combined pairwise up a binary tree of neighbours: ``combine(a, b)`` of items 0-1, 2-3, ...

    then of those results in pairs, and so on (an odd item out goes up a
    level as it is); the root. Partitions are consecutive Morton ranges, so
    neighbours in this order share seams and each merge removes the seam
    vertices between them. The one reduction of the local tree stitch
    (:func:`tree_stitch`) and of the stitch on Dask workers
    (:mod:`polygen.volume.distributed`).
    """
    items = list(items)
    if not items:
        raise PartitionError("nothing to reduce: no pieces")
    while len(items) > 1:
        items = [combine(items[i], items[i + 1]) if i + 1 < len(items) else items[i] for i in range(0, len(items), 2)]
    return items[0]


def finish(value, piece, *, n_ids, normals="mean"):
    """The :class:`StitchedIsoSurface` of a piece holding every partition's part (the root of the merges).

    The seam vertices' mean normals are made here, from all their triangles
    (they lie on both sides of a seam); every other vertex's normal came
    final from its partition. A seam vertex whose triangles all have zero
    area takes its edge's direction from a partition that has it.
    """
    t0, c0 = time.perf_counter(), time.thread_time()
    if "parts" not in piece:
        piece = merge([piece], n_ids=n_ids)
    verts, keys, seam = piece["vertices"], piece["keys"], piece["seam"]
    tri = np.ascontiguousarray(piece["triangles"], np.int64)
    nrm = None
    if normals is not None and piece["parts"]:
        nrm = piece["normals"]
        if nrm is None:
            raise PartitionError("the pieces were made without normals; extract them with normals='mean'")
        if seam.size:
            nrm = nrm if nrm.flags.writeable else nrm.copy()  # merge's own array (arrays off the wire may be read-only)
            is_seam = np.zeros(verts.shape[0], np.bool_)
            is_seam[seam] = True
            _seam_normals(verts, tri, piece["seam_tris"], seam, is_seam, nrm)
            if piece["fallback"] is not None and piece["fallback"][0].size:
                fk, fd = piece["fallback"]
                order = np.argsort(keys[seam])
                at = seam[order[np.searchsorted(keys[seam], fk, sorter=order)]]
                zero = ~(np.abs(nrm[at]).sum(axis=1) > 0.0)
                nrm[at[zero]] = fd[zero]
    parts = tuple(piece["parts"])
    total = {k: sum(p[k] for p in parts) for k in ("cells_tested", "cells_intersected", "vertex_lookups",
                                                   "t1", "t2", "t3")}
    return StitchedIsoSurface(
        value=value, vertices=verts, triangles=tri, normals=nrm, vertex_keys=keys,
        triangle_cells=np.asarray(piece["triangle_cells"], np.int64), method=piece["method"],
        cells_tested=int(total["cells_tested"]), cells_intersected=int(total["cells_intersected"]),
        vertex_lookups=int(total["vertex_lookups"]), t1=total["t1"], t2=total["t2"], t3=total["t3"],
        partitions=parts, seam_vertices=int(piece["seam_vertices"]),
        stitch_s=piece["merge_s"] + time.perf_counter() - t0,
        stitch_cpu_s=piece["merge_cpu_s"] + time.thread_time() - c0, n_ids=int(n_ids))


def stitch(value, pieces, *, n_ids, normals="mean"):
    """One surface from the partitions' pieces (dicts of :meth:`PreparedPartition.extract`), merged at once.

    :func:`merge` of all pieces, then :func:`finish`: what the client does
    with every piece in hand (the local path, :class:`PartitionedMethod`).
    """
    return finish(value, merge(list(pieces), n_ids=n_ids), n_ids=n_ids, normals=normals)


def tree_stitch(value, pieces, *, n_ids, normals="mean"):
    """The same surface as :func:`stitch`, merged pairwise up :func:`reduce_tree` (as the Dask workers do)."""
    root = reduce_tree(pieces, lambda a, b: merge([a, b], n_ids=n_ids))
    return finish(value, root, n_ids=n_ids, normals=normals)


def check_partitions(infos):
    """Check the partitions agree with one another; return ``(cell_offsets, n_ids, shared_ids)``.

    Raises :class:`PartitionError` naming the piece when their field sets
    or cell types differ, or when a node on two partitions' boundaries has
    one global id but two positions or two field values, or one position
    but two global ids.
    """
    ref = infos[0]
    for inf in infos[1:]:
        if inf["fields"] != ref["fields"]:
            raise PartitionError(f"piece {inf['name']!r} has the fields {inf['fields']}, piece {ref['name']!r} has "
                                 f"{ref['fields']}: every piece must carry the same node fields")
        if inf["cell_type"] != ref["cell_type"]:
            raise PartitionError(f"piece {inf['name']!r} has {inf['cell_type']} cells, piece {ref['name']!r} has "
                                 f"{ref['cell_type']}")
    ids = np.concatenate([i["boundary_ids"] for i in infos])
    pts = np.concatenate([i["boundary_points"] for i in infos])
    vals = np.concatenate([i["boundary_values"] for i in infos])
    owner = np.repeat(np.arange(len(infos)), [i["boundary_ids"].shape[0] for i in infos])

    def clash(order, same_key, what):
        o = order
        eq = same_key(o)
        if not eq.any():
            return
        # neighbours in the order with one key: they must agree on everything
        j = np.flatnonzero(eq)
        a, b = o[j], o[j + 1]
        bad_pos = np.any(pts[a] != pts[b], axis=1)
        bad_id = ids[a] != ids[b]
        bad_val = vals[a] != vals[b]
        bad = bad_pos | bad_id | bad_val
        if bad.any():
            k = np.flatnonzero(bad)[0]
            pa, pb = infos[owner[a[k]]]["name"], infos[owner[b[k]]]["name"]
            raise PartitionError(
                f"pieces {pa!r} and {pb!r} disagree on a shared node ({what}): global ids {int(ids[a[k]])} / "
                f"{int(ids[b[k]])}, coordinates {pts[a[k]].tolist()} / {pts[b[k]].tolist()}, values "
                f"{vals[a[k]]:.17g} / {vals[b[k]]:.17g}")

    order = np.argsort(ids, kind="stable")
    clash(order, lambda o: ids[o[1:]] == ids[o[:-1]], "same global id")
    order = np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))
    clash(order, lambda o: np.all(pts[o[1:]] == pts[o[:-1]], axis=1), "same coordinates")
    offsets = np.cumsum([0] + [i["n_cells"] for i in infos])[:-1]
    n_ids = max(i["max_id"] for i in infos) + 1
    u, counts = np.unique(ids, return_counts=True)
    return offsets, n_ids, u[counts > 1]


# ----------------------------------------------------------------- volume

class PartitionedVolume:
    """A volume in partitions that share boundary nodes, named by global node ids.

    Build one with :meth:`split` (one volume into ``k`` Morton ranges of
    cells), :meth:`from_pvtu` or :meth:`from_files` (pieces read lazily,
    where they are prepared). Nothing is read until :meth:`prepare`.

    Parameters
    ----------
    pieces : list of piece sources
        Objects with ``name`` and ``load() -> (UnstructuredVolume, global_ids (N_i,) int64, cell_ids or None)``.
    """

    def __init__(self, pieces):
        pieces = list(pieces)
        if not pieces:
            raise PartitionError("a partitioned volume needs at least one piece")
        self.pieces = pieces
        #: why :meth:`split` chose this many partitions (automatic count), else None
        self.split_reason = None

    @property
    def n_partitions(self) -> int:
        return len(self.pieces)

    def __repr__(self):
        return f"PartitionedVolume({self.n_partitions} pieces: {', '.join(p.name for p in self.pieces[:4])}" \
               f"{', ...' if self.n_partitions > 4 else ''})"

    @classmethod
    def split(cls, vol, k=None, *, weights=None, workers=None):
        """``vol`` in ``k`` partitions: contiguous ranges of its cells along a Morton curve.

        Global node and cell ids are ``vol``'s own; each partition holds its
        cells' nodes (in increasing global id), so neighbouring partitions
        share the nodes of their common faces.

        Parameters
        ----------
        vol : UnstructuredVolume
        k : int, optional
            Number of partitions, ``1 <= k <= vol.n_cells``. Default: chosen
            by :func:`auto_partitions` from the cell count and ``workers``
            (a volume too small to gain is not split: one partition); the
            choice and its reason are logged (``logging``, logger
            ``polygen.volume.partitioned``, level INFO) and kept as
            :attr:`split_reason`.
        weights : (n_cells,) array_like of float, optional, keyword-only
            Each cell's expected work: the ranges are cut where the running
            sum of weights along the curve passes ``i / k`` of the total
            (each range keeps at least one cell). Default: every cell the same
            (ranges of equal cell counts). :func:`span_weights` gives a sweep's
            expected work (a partition's workers finish together).
        workers : int, optional, keyword-only
            The workers the partitions will run on, for the automatic count
            (default: this machine's cores); ignored when ``k`` is given.
        """
        if not isinstance(vol, UnstructuredVolume):
            raise PartitionError(f"expected an UnstructuredVolume; got {type(vol).__name__}")
        reason = None
        if k is None:
            k, reason = auto_partitions(vol.n_cells, workers)
            logger.info("%s", reason)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= vol.n_cells:
            raise PartitionError(f"k must be an integer in 1..{vol.n_cells}; got {k!r}")
        lo = vol.points.min(axis=0)
        span = float((vol.points.max(axis=0) - lo).max())
        scale = (2**21 - 1) / span if span > 0 else 0.0
        order = np.argsort(_topo.morton_codes(_topo.cell_centroids(vol.points, vol.cells), lo, scale),
                           kind="stable")
        if weights is None:
            chunks = np.array_split(order, int(k))
        else:
            w = np.asarray(weights, np.float64)
            if w.shape != (vol.n_cells,) or not np.all(np.isfinite(w)) or (w.size and w.min() < 0):
                raise PartitionError(f"weights must be {vol.n_cells} finite non-negative numbers (one per cell); "
                                     f"got shape {w.shape}")
            cw = np.cumsum(w[order])
            if not cw.size or cw[-1] <= 0:
                chunks = np.array_split(order, int(k))
            else:
                cuts = np.searchsorted(cw, cw[-1] * np.arange(1, k) / k, side="right")
                # at least one cell per range: cuts strictly increasing, cut i in i .. n - k + i
                d = np.minimum(np.maximum.accumulate(np.maximum(cuts - np.arange(1, k), 0)), vol.n_cells - k)
                chunks = np.split(order, d + np.arange(1, k))
        pieces = []
        for i, chunk in enumerate(chunks):
            chunk = np.sort(chunk)  # the volume's own cell order inside a partition (a cache's is Morton already)
            cells = vol.cells[chunk]
            nodes = np.unique(cells)
            pieces.append(_MemoryPiece(
                name=f"part{i}", points=vol.points[nodes], cells=np.searchsorted(nodes, cells),
                fields={n: v[nodes] for n, v in vol.fields.items()}, global_ids=nodes, cell_ids=chunk))
        out = cls(pieces)
        out.split_reason = reason
        return out

    def partition_of_cells(self):
        """(n_cells,) int32: the partition holding each global cell (a volume from :meth:`split`)."""
        if not all(isinstance(p, _MemoryPiece) for p in self.pieces):
            raise PartitionError("partition_of_cells needs the pieces of split(): pieces from files are numbered "
                                 "piece after piece when prepared")
        out = _jit.scratch(sum(p.cell_ids.shape[0] for p in self.pieces), np.int32)
        for i, p in enumerate(self.pieces):
            out[p.cell_ids] = i
        return out

    @classmethod
    def from_files(cls, paths, *, global_ids=GLOBAL_IDS):
        """Pieces in mesh files (any format :meth:`UnstructuredVolume.read` reads), each with a point
        array ``global_ids`` numbering its nodes globally. Missing files are named at once."""
        paths = [str(p) for p in paths]
        missing = [p for p in paths if not os.path.isfile(p)]
        if missing:
            raise PartitionError(f"piece file {missing[0]!r} does not exist"
                                 + (f" (nor {len(missing) - 1} more)" if len(missing) > 1 else ""))
        return cls([_FilePiece(name=os.path.basename(p), path=p, global_ids_name=global_ids) for p in paths])

    @classmethod
    def from_pvtu(cls, path, *, global_ids=GLOBAL_IDS):
        """The pieces a ``.pvtu`` file names (``<Piece Source=...>``, relative to the file), read lazily."""
        path = pathlib.Path(path)
        if not path.is_file():
            raise PartitionError(f"{str(path)!r}: no such file")
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as e:
            raise PartitionError(f"{str(path)!r} is not a .pvtu file: {e}") from e
        grid = root.find("PUnstructuredGrid")
        sources = [p.get("Source") for p in grid.iter("Piece")] if grid is not None else []
        if not sources or any(s is None for s in sources):
            raise PartitionError(f"{str(path)!r} names no pieces (<PUnstructuredGrid><Piece Source=...>)")
        return cls.from_files([path.parent / s for s in sources], global_ids=global_ids)

    def write_pvtu(self, path, *, global_ids=GLOBAL_IDS):
        """Write the partitions as ``.vtu`` pieces beside a ``.pvtu`` file naming them (VTK's XML writers).

        Each piece carries the point array ``global_ids`` (int64).
        Returns the list of piece paths.
        """
        import pyvista as pv  # noqa: F401  (to_pyvista imports it too; a clear ImportError here)

        path = pathlib.Path(path)
        stem = path.with_suffix("")
        written, arrays = [], None
        for i, piece in enumerate(self.pieces):
            vol, gids, _ = piece.load()
            grid = vol.to_pyvista()
            grid.point_data[global_ids] = np.asarray(gids, np.int64)
            p = stem.parent / f"{stem.name}_{i}.vtu"
            grid.save(p)
            written.append(p)
            arrays = arrays or [(n, str(np.asarray(grid.point_data[n]).dtype)) for n in grid.point_data.keys()]
        vtk_type = {"float64": "Float64", "int64": "Int64", "float32": "Float32", "int32": "Int32"}
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="PUnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
                 '  <PUnstructuredGrid GhostLevel="0">', "    <PPointData>"]
        lines += [f'      <PDataArray type="{vtk_type.get(t, "Float64")}" Name="{n}"/>' for n, t in arrays]
        lines += ["    </PPointData>", '    <PPoints><PDataArray type="Float64" NumberOfComponents="3"/></PPoints>']
        lines += [f'    <Piece Source="{p.name}"/>' for p in written]
        lines += ["  </PUnstructuredGrid>", "</VTKFile>", ""]
        path.write_text("\n".join(lines))
        return written

    def prepare(self, field=None, method=None, **params):
        """Prepare ``method`` on every partition here; a :class:`PartitionedMethod` answering across them.

        On Dask workers: :func:`polygen.volume.distributed.prepare`.

        Parameters
        ----------
        field, method : str, optional
            As for :meth:`UnstructuredVolume.isosurface`.
        **params
            The method's parameters.
        """
        return PartitionedMethod(self, field, method, **params)


class PartitionedMethod:
    """A method prepared on every partition of a :class:`PartitionedVolume`, run here one partition after another.

    Not for several threads at once (the prepared methods keep scratch
    state; each holds its own lock). The partitions are read when this is
    made; nothing invalidates them afterwards (pieces are read once).

    Attributes
    ----------
    partitions : list of PreparedPartition
    infos : list of dict
        Each partition's :attr:`PreparedPartition.info`.
    preprocess_s : float
        Wall clock of reading and preparing all partitions.
    """

    def __init__(self, pvol, field=None, method=None, **params):
        t0 = time.perf_counter()
        self.partitions = [PreparedPartition(p, i, field, method, params) for i, p in enumerate(pvol.pieces)]
        self.infos = [p.info for p in self.partitions]
        offsets, self.n_ids, shared = check_partitions(self.infos)
        for p, off in zip(self.partitions, offsets):
            p.set_layout(off, self.n_ids, shared)
        self.preprocess_s = time.perf_counter() - t0

    def extract(self, value, *, normals="mean"):
        """The stitched surface ``S = value`` (a :class:`StitchedIsoSurface`)."""
        value = check_value(value)
        _check_normals(normals)
        # each partition writes its rows straight into the stitched arrays: stitch()'s arrays without the pieces
        return direct_stitch(value, self.partitions, n_ids=self.n_ids, normals=normals)

    def extract_many(self, values, *, normals="mean"):
        return [self.extract(v, normals=normals) for v in values]


def _check_normals(normals):
    check_normals(normals)
    if normals == "gradient":
        raise IsoSurfaceError("normals='gradient' is not available across partitions (a seam node's gradient "
                              "needs the cells of both sides); use 'mean' or None")


def span_weights(vol, field=None):
    """(n_cells,) float64: each cell's field range (max - min over its nodes), for :meth:`PartitionedVolume.split`.

    A surface ``S = C`` crosses a cell when ``C`` lies inside its range, so
    over a sweep of values spread evenly over the field's range a cell is
    crossed in proportion to its range: cut by these weights, the partitions
    share a sweep's extraction evenly (cut by cell counts, the busiest of two
    partitions of 2M and 10M did 8-9 % more than the mean,
    ``benchmarks/results/partitioned*.md``).
    """
    s = vol.scalars(field)[vol.cells]
    return s.max(axis=1) - s.min(axis=1)


# ----------------------------------------------------------------- a model on paper

def scale_model(*, n_cells, crossed_per_value, triangles_per_value, prepare_s_per_cell, query_s_per_crossed_cell,
                stitch_s_per_triangle, piece_bytes_per_triangle, surface_bytes_per_triangle,
                target_cells=1e9, workers=64, bandwidth_bytes_s=10e9 / 8, sweep=20):
    """Preparation, per-query latency and network volume of a bigger volume, from costs measured on a small one.

    A model on paper, with these assumptions: the big volume holds the
    same field shape on a finer mesh, so a surface crosses
    ``g = (target_cells / n_cells) ** (2/3)`` times as many cells and has
    ``g`` times as many triangles (surface area grows as n^(2/3)); one
    partition per worker (``workers`` a power of two), each prepared where
    its piece lives (no volume moves); preparation and extraction cost the
    same per cell and per crossed cell as measured, and spread evenly over
    the workers; the stitch is a tree of pairwise merges on the workers
    (:func:`reduce_tree`), a merge at level ``l = 1 .. L`` (``L =
    log2(workers)``) handling ``2**l / workers`` of the surface, each
    costing at most what one :func:`stitch` of that share costs, so the
    merges on the critical path handle ``2 - 2 / workers`` surfaces; the
    pieces moved up that path add up to one surface of pieces (half of each
    merged node travels), the network volume between workers is ``L / 2``
    surfaces of pieces, and the stitched surface crosses the client's link
    once; every link carries ``bandwidth_bytes_s``.

    For a sweep of ``sweep`` values the tree's merges (``L`` surfaces of
    work per value) spread over the workers, each value's root on another
    worker: ``max(sweep * L / workers, 2 - 2 / workers)`` stitches, where one
    client stitching every value merges ``sweep`` surfaces, one after
    another, and takes in every piece through its one link.

    Parameters
    ----------
    n_cells : int
        Cells of the measured volume.
    crossed_per_value, triangles_per_value : float
        Cells crossed and triangles per value, measured.
    prepare_s_per_cell : float
        Seconds of preparation per cell (all partitions' preparation summed, over ``n_cells``).
    query_s_per_crossed_cell : float
        Seconds of extraction per crossed cell (t1 + t2 + t3 of the partitions, summed).
    stitch_s_per_triangle : float
        Seconds of one stitch (merge + normals) per triangle of the surface.
    piece_bytes_per_triangle, surface_bytes_per_triangle : float
        Bytes per triangle of the partitions' pieces, and of a stitched surface.
    target_cells, workers, bandwidth_bytes_s : float
        The volume modelled, its workers (a power of two), each link's bytes per second.
    sweep : int
        Values in a sweep (``extract_many``).

    Returns
    -------
    dict
        ``growth``, ``crossed``, ``triangles`` (per value), ``prepare_s``
        (per worker, in parallel), ``extract_s``, ``stitch_s``,
        ``transfer_s`` (critical path between workers + client link),
        ``latency_s`` (their sum, per value), ``bytes_between_workers``,
        ``bytes_to_client`` (per value), ``levels``; for a sweep,
        ``sweep_stitch_workers_s`` and ``sweep_stitch_client_s`` (the tree on
        the workers, one client stitching all) and ``sweep_client_link_s``
        (the client's link: the stitched surfaces, or every piece).
    """
    levels = int(round(np.log2(workers)))
    if workers < 1 or 2**levels != workers:
        raise PartitionError(f"workers must be a power of two; got {workers}")
    if min(n_cells, target_cells) <= 0:
        raise PartitionError(f"cell counts must be positive; got {n_cells}, {target_cells}")
    g = (target_cells / n_cells) ** (2 / 3)
    crossed, tri = crossed_per_value * g, triangles_per_value * g
    prepare_s = prepare_s_per_cell * target_cells / workers
    extract_s = query_s_per_crossed_cell * crossed / workers
    stitch_s = stitch_s_per_triangle * tri * (2 - 2 / workers)
    pieces_path = piece_bytes_per_triangle * tri * (1 - 1 / workers)
    to_client = surface_bytes_per_triangle * tri
    transfer_s = (pieces_path + to_client) / bandwidth_bytes_s
    one = stitch_s_per_triangle * tri
    sweep_out = {"sweep_stitch_workers_s": one * max(sweep * levels / workers, 2 - 2 / workers),
                 "sweep_stitch_client_s": one * sweep,
                 "sweep_client_link_s": (sweep * to_client / bandwidth_bytes_s,
                                         sweep * piece_bytes_per_triangle * tri / bandwidth_bytes_s)}
    return sweep_out | {"growth": g, "crossed": crossed, "triangles": tri, "levels": levels, "prepare_s": prepare_s,
            "extract_s": extract_s, "stitch_s": stitch_s, "transfer_s": transfer_s,
            "latency_s": extract_s + stitch_s + transfer_s,
            "bytes_between_workers": piece_bytes_per_triangle * tri * levels / 2, "bytes_to_client": to_client}
