"""Volume thinning: isosurfaces from a skeleton that keeps the volume's genus (thesis chapter 7).

With through-holes an extrema graph can miss parts of an isosurface (Fig.
7.1, Thm 7.3): a surface cut in two by a hole is crossed by the graph only
once. A skeleton that joins the extrema *and* keeps a loop around every
through-hole crosses every part, so no boundary cell lists are needed. The
skeleton is made by removing cells one at a time from the outside, as 2D
image thinning removes pixels (7.3, :func:`thin_image`).

Preprocessing (once per volume and field, Fig. 7.5, :func:`thin_volume`):

1. **Marks** (Defs 7.1, 7.9). The extrema are found as in chapter 6
   (:func:`polygen.volume.extrema_graph.find_extrema`); one cell touching
   each extremum is marked, class ``C_-1``, and is never removed. (A
   face-connected part of the volume that holds no extremum of its own --
   possible only when parts touch at a node -- gets one marked cell too, so
   no part vanishes.)
2. **Classes and boundary groups** (7.5.1, Defs 7.6-7.8). The class C_n of
   a cell is its number of non-removed face neighbours; removed cells are
   C_0. Every node on the boundary gets the number ``n_B`` of its connected
   boundary-face group (1 = outer surface, 2.. = voids; see
   :attr:`UnstructuredVolume.boundary_groups`), inner nodes 0. The cells
   that touch the boundary go into one FIFO per class (C_1 .. C_3 for
   tetrahedra, C_1 .. C_5 for hexahedra).
3. **Removal** (7.5.2, Figs 7.6, 7.13), always from the lowest non-empty
   class: C_1 cells go; a C_2 cell goes when the walk around the edge it
   shares with its two neighbours E_a, E_b (the triple-shared edge, Def.
   7.3) leads from E_a to E_b through non-removed cells; a tetrahedral C_3
   cell goes when the node shared with its three neighbours (the
   quadruple-shared node, Def. 7.4) has ``n_B = 0``. Hexahedra: C_2 needs a
   triple-shared edge (adjacent neighbours) and the walk; C_3 either one
   inner quadruple-shared node or two successful walks; C_4 two inner
   quadruple-shared nodes (with opposite open faces it stays); C_5 four.
   A removed cell's inner nodes come onto the boundary and take the group
   of its other nodes; its neighbours move one class down, into that
   class's FIFO. On a large volume (``thin_volume(parallel=None)``) the
   FIFO runs first in the two halves of the cells at once, each over the
   cells whose nodes only its own cells touch, then serially over the rest
   (:func:`_fifo_halves`): Thms 7.4-7.6 are proven one removal at a time,
   from E, its neighbours, the cells around its edges and its nodes' n_B
   (the thesis's proofs, appendix of chapter 7), so they hold in any order
   of removals that pass the tests; the lowest-class-first rule of 7.5.2
   shapes the skeleton (how thin it is), not its guarantees.
4. **Voids** (7.5.3, Fig. 7.7). When every FIFO is empty, each void is
   still wrapped in a layer of cells. One layer is pricked open: the
   thesis's three cells -- E with nodes on the outer side and on the void,
   a neighbour E_1 open to the outer side and a neighbour E_2 open to the
   void (for hexahedra a single cell open to both sides when there is one)
   -- are removed, and thinning resumes. Once per void.
5. **Registration** (7.5.4). The cells left (classes other than C_0) are
   the skeleton; they are put into value classes by their node range
   (Gallagher's span filter, :class:`polygen.volume.seeds.span_filter.SpanFilter`).

The query (7.5.5, :meth:`Skeleton.seeds`) tests the skeleton cells of the
value class of C and grows the surface from every hit by propagation
(:class:`polygen.volume.propagate.Propagator`). Preprocessing is O(n): each
cell enters each class's FIFO at most once (7.6).

The method is registered as ``thinning`` in :mod:`polygen.volume.methods`::

    m = methods.get("thinning")(vol)
    iso = m.extract(0.5)
    m.skeleton.stats   # Table 7.1/7.2 quantities; m.stats: this call's T_mg, N_cg, N_ci
"""

from __future__ import annotations

import dataclasses
import functools
import os
import threading
import time
import warnings

import numpy as np

from polygen import _jit
from polygen._jit import parallel_kernels_may_overlap
from polygen.volume import _thinning_kernels as _k
from polygen.volume.extrema_graph import Extrema, find_extrema
from polygen.volume.homology import boundary_defects
from polygen.volume.methods import SeedsThenPropagate, register
from polygen.volume.registry import register_seed_source
from polygen.volume.seeds.source import Seeds
from polygen.volume.seeds.span_filter import SpanFilter
from polygen.volume.surface import IsoSurfaceError, check_value, volume_arrays

__all__ = [
    "ThinningError",
    "ThinningWarning",
    "boundary_defects",
    "ThinningRecord",
    "RemovalTest",
    "removal_test",
    "Skeleton",
    "SkeletonSeeds",
    "ThinningMethod",
    "thin_volume",
    "thin_image",
    "pixel_removable",
    "cell_subset_volume",
]


class ThinningError(IsoSurfaceError):
    """Bad input to volume or image thinning (the message says what)."""


class ThinningWarning(UserWarning):
    """The volume is outside the theorems' assumptions (its boundary is no 2-manifold)."""


@dataclasses.dataclass(frozen=True, eq=False)
class ThinningRecord:
    """The thinning process, for Figs 7.18-7.21: which cells remain after k removals.

    Attributes
    ----------
    removal_order : (R,) int64
        Cells in the order they were removed (pricked cells included).
    pricks : (P, 3) int64
        Per pricked void: removals before it, the void's boundary group, cells it removed.
    n_cells : int
    decided_cell, decided_class : (D,) int64
        Every cell taken from a FIFO, in order, and the class it was taken at
        (Figs 7.4, 7.6, 7.13: the removal tests).
    decided_removed : (D,) bool
        Whether the tests of 7.5.2 let it go.
    decided_after : (D,) int64
        Removals before the test: ``remaining(decided_after[k])`` is the state it saw.
    """

    removal_order: np.ndarray
    pricks: np.ndarray
    n_cells: int
    decided_cell: np.ndarray = None
    decided_class: np.ndarray = None
    decided_removed: np.ndarray = None
    decided_after: np.ndarray = None

    @property
    def n_removed(self) -> int:
        return int(self.removal_order.shape[0])

    def remaining(self, k):
        """(M,) bool: the cells not removed after the first ``k`` removals."""
        k = int(k)
        if not 0 <= k <= self.n_removed:
            raise ThinningError(f"k must be in 0..{self.n_removed}; got {k}")
        keep = np.ones(self.n_cells, bool)
        keep[self.removal_order[:k]] = False
        return keep

    def steps(self, n):
        """``n`` removal counts from 0 to the end, evenly spaced (for a strip of figures)."""
        return np.unique(np.linspace(0, self.n_removed, int(n)).round().astype(np.int64))


@dataclasses.dataclass(frozen=True, eq=False)
class RemovalTest:
    """One cell taken from a FIFO and what the tests of 7.5.2 looked at (Figs 7.4, 7.6, 7.12, 7.13).

    Attributes
    ----------
    cell, cls : int
        The cell E and the class it was taken at.
    removed : bool
        The kernel's decision (from the record).
    remaining : (M,) bool
        The cells not removed when E was tested.
    neighbours : (q,) int64
        E's non-removed face neighbours (E_a, E_b, ...).
    shared_edges : (k, 2) int64
        Node pairs of E shared by two of those neighbours' faces (triple-shared edges, Def. 7.3).
    quad_nodes : (j,) int64
        Nodes of E on three or more of those faces (quadruple-shared nodes, Def. 7.4).
    on_boundary : (N,) bool
        Nodes with ``n_B != 0`` at that moment: on the volume's boundary or on a removed cell.
    """

    cell: int
    cls: int
    removed: bool
    remaining: np.ndarray
    neighbours: np.ndarray
    shared_edges: np.ndarray
    quad_nodes: np.ndarray
    on_boundary: np.ndarray

    def edge_ring(self, vol, edge):
        """(r,) int64: the non-removed cells around ``edge`` (both its nodes), E included."""
        off, nc = vol.node_cells
        a, b = int(edge[0]), int(edge[1])
        ring = np.intersect1d(nc[off[a]:off[a + 1]], nc[off[b]:off[b + 1]])
        return ring[self.remaining[ring]]


def removal_test(vol, record, k):
    """The situation of the ``k``-th FIFO decision of a recorded thinning, rebuilt from the record.

    Parameters
    ----------
    vol : UnstructuredVolume
        The volume that was thinned.
    record : ThinningRecord
        From ``thin_volume(..., record=True)``.
    k : int
        Index into ``record.decided_cell``.

    Returns
    -------
    RemovalTest
    """
    if record.decided_cell is None:
        raise ThinningError("this record has no decisions; thin with record=True")
    k = int(k)
    if not 0 <= k < record.decided_cell.shape[0]:
        raise ThinningError(f"k must be in 0..{record.decided_cell.shape[0] - 1}; got {k}")
    c = int(record.decided_cell[k])
    after = int(record.decided_after[k])
    remaining = record.remaining(after)
    on_b = np.zeros(vol.n_points, bool)
    on_b[vol.boundary_face_nodes.ravel()] = True
    on_b[vol.cells[record.removal_order[:after]].ravel()] = True
    nb = vol.face_neighbors[c]
    open_faces = [f for f in range(nb.shape[0]) if nb[f] >= 0 and remaining[nb[f]]]
    faces = [set(vol.cells[c, vol.local_faces[f]].tolist()) for f in open_faces]
    edges = [sorted(faces[i] & faces[j]) for i in range(len(faces)) for j in range(i + 1, len(faces))
             if len(faces[i] & faces[j]) == 2]
    quad = [int(x) for x in vol.cells[c] if sum(x in f for f in faces) >= 3]
    return RemovalTest(cell=c, cls=int(record.decided_class[k]), removed=bool(record.decided_removed[k]),
                       remaining=remaining, neighbours=nb[open_faces].astype(np.int64),
                       shared_edges=np.array(edges, np.int64).reshape(-1, 2), quad_nodes=np.array(quad, np.int64),
                       on_boundary=on_b)


@dataclasses.dataclass(frozen=True, eq=False)
class SkeletonSeeds:
    """The seeds of one query (7.5.5) and its counters.

    Attributes
    ----------
    value : float
    cells : (K,) int64
        Skeleton cells the surface crosses.
    n_tested : int
        Skeleton cells of the value class, all tested (N_cg).
    t_search : float
        Seconds.
    """

    value: float
    cells: np.ndarray
    n_tested: int
    t_search: float


@dataclasses.dataclass(eq=False)
class Skeleton:
    """The skeleton of one volume and field after thinning (7.5.1-7.5.4).

    Attributes
    ----------
    vol : UnstructuredVolume
    s : (N,) float64
    extrema : Extrema
    marked : (X,) int64
        Marked cells (class ``C_-1``), one per extremum (plus one per part without an extremum).
    classes : (M,) int8
        Final class of every cell: -1 marked, 0 removed, n non-removed neighbours.
    cells : (K,) int64
        The skeleton: cells of class other than C_0, ascending.
    neighbour_counts : (K,) int64
        Non-removed face neighbours of each skeleton cell, marked ones included
        (the classes of Table 7.2).
    node_groups : (N,) int64
        ``n_B`` after thinning (nodes that came onto the boundary took a group).
    group_root : (G+1,) int64
        After pricking, the outer group a void was joined to (``group_root[g] == g`` otherwise).
    unpricked_voids : (V,) int64
        Voids whose layer no cell configuration could open (their layer stays).
    record : ThinningRecord or None
    stats : dict
        ``T_topology`` (face neighbours, components and boundary groups when not cached and not
        built beside the FIFO),
        ``T_check`` (:func:`boundary_defects`), ``nonmanifold_edges``, ``nonmanifold_nodes``,
        ``T_pe`` (extrema and marks), ``T_thin`` (classes, n_B, removal; of which ``T_halves`` the two
        halves at once, when ``parallel``; ``T_resume`` the FIFO's last run, with the pricking), ``T_wait`` (on a large
        volume, the FIFO's wait for the boundary groups numbered beside it),
        ``T_register`` (value classes), ``T_total`` (all but topology), ``extrema``,
        ``skeleton_cells`` (N_e2 of Table 7.1), ``C1`` .. ``C6`` (Table 7.2),
        ``processed``/``removed`` per class, ``walks``, ``pricks``, ``prick_cells``; ``parallel`` (the
        FIFO ran in two halves first), ``band_cells`` (cells left to the serial FIFO from the start
        then), ``removed_in_halves``.
    """

    vol: object
    s: np.ndarray
    extrema: Extrema
    marked: np.ndarray
    classes: np.ndarray
    cells: np.ndarray
    neighbour_counts: np.ndarray
    node_groups: np.ndarray
    group_root: np.ndarray
    unpricked_voids: np.ndarray
    record: ThinningRecord | None
    stats: dict
    _cmin: np.ndarray = dataclasses.field(repr=False, default=None)
    _cmax: np.ndarray = dataclasses.field(repr=False, default=None)
    _buckets: SpanFilter = dataclasses.field(repr=False, default=None)
    _hits: np.ndarray = dataclasses.field(repr=False, default=None)

    @property
    def n_cells(self) -> int:
        return int(self.cells.shape[0])

    def __repr__(self):
        st = self.stats
        return (f"Skeleton({self.n_cells} of {self.vol.n_cells} cells, {st['extrema']} extrema, "
                f"{st['pricks']} voids pricked, preprocess {st['T_total']:.3g} s)")

    def mask(self):
        """(M,) bool: the skeleton cells."""
        return self.classes != 0

    def seeds(self, value):
        """Skeleton cells crossed by ``S = value``, from its value class (7.5.4, 7.5.5).

        Parameters
        ----------
        value : float

        Returns
        -------
        SkeletonSeeds
        """
        value = check_value(value)
        b = self._buckets
        t0 = time.perf_counter()
        k, tested = _k.query(self.cells, self._cmin, self._cmax, b.offsets, b.ids, b.lo, b.hi, b.width,
                             b.n_buckets, value, self._hits)
        t = time.perf_counter() - t0
        return SkeletonSeeds(value=value, cells=self._hits[:k].copy(), n_tested=int(tested), t_search=t)

    def as_volume(self):
        """The skeleton as an :class:`UnstructuredVolume` of its own (nodes compacted, fields kept)."""
        return cell_subset_volume(self.vol, self.cells)


def cell_subset_volume(vol, cells):
    """A volume made of some cells of ``vol``, its unused nodes dropped.

    Parameters
    ----------
    vol : UnstructuredVolume
    cells : (K,) int64 cell ids, or (M,) bool mask

    Returns
    -------
    UnstructuredVolume
        Fields are carried over; boundary groups, genus and voids are the subset's own.
    """
    from polygen.volume.mesh import UnstructuredVolume

    idx = np.asarray(cells)
    if idx.dtype == bool:
        if idx.shape != (vol.n_cells,):
            raise ThinningError(f"a cell mask must have shape ({vol.n_cells},); got {idx.shape}")
        idx = np.flatnonzero(idx)
    if idx.ndim != 1 or idx.size == 0:
        raise ThinningError("cell_subset_volume needs at least one cell")
    sub = vol.cells[idx]
    used, inv = np.unique(sub, return_inverse=True)
    return UnstructuredVolume(vol.points[used], inv.reshape(sub.shape), {k: v[used] for k, v in vol.fields.items()},
                              validate=False)


def _extremum_cells(vol, ext):
    """One cell per extremum (Def. 7.9): the first cell around each extremum's node, ascending."""
    off, nc = vol.node_cells
    return np.unique(np.asarray(nc)[np.asarray(off)[ext.nodes]]).astype(np.int64)


def _one_part(vol, defects):
    """Whether ``vol`` is known to be one face-connected part without labelling its cells.

    With a 2-manifold boundary (no ``defects``: :func:`boundary_defects`) two parts share no boundary
    node, so every boundary group belongs to one part; a part's groups enclose its (positive) volume,
    so one of them is no void. One outer group then means one part (2M: saves the labelling, 0.09 s).
    """
    bad_edges, bad_nodes = defects
    return bad_edges.size == 0 and bad_nodes.size == 0 and int(np.count_nonzero(~vol.group_is_void)) == 1


def _parts_without_mark(vol, marked, defects=None):
    """(P,) int64: the first cell of each face-connected part of ``vol`` with no cell in ``marked``."""
    if defects is not None and _one_part(vol, defects):
        return np.zeros(0, np.int64)
    labels, n = vol.cell_components
    if n <= 1:
        return np.zeros(0, np.int64)
    has = np.zeros(n, bool)
    has[labels[marked]] = True
    if has.all():
        return np.zeros(0, np.int64)
    _, first = np.unique(labels, return_index=True)
    return first[~has].astype(np.int64)


def _marked_cells(vol, ext, defects=None):
    """One cell per extremum (Def. 7.9), plus one for each face-connected part with none."""
    marked = _extremum_cells(vol, ext)
    extra = _parts_without_mark(vol, marked, defects)
    return np.unique(np.concatenate([marked, extra])) if extra.size else marked


def thin_volume(vol, field=None, *, prick_voids=True, record=False, n_buckets=None, parallel=None,
                edge_table_aside=True):
    """Thin ``vol`` to a skeleton joining its extrema that keeps its genus (thesis 7.4-7.5).

    Parameters
    ----------
    vol : UnstructuredVolume
        Tetrahedra or hexahedra.
    field : str or (N,) float64, optional
        Field name or node values; the volume's first field by default.
    prick_voids : bool, keyword-only
        Open the layers left around voids and resume thinning (7.5.3).
    record : bool, keyword-only
        Keep the removal order (:class:`ThinningRecord`, Figs 7.18-7.21).
    n_buckets : int, keyword-only, optional
        Value classes of the skeleton (7.5.4); by default about one per
        eight skeleton cells, at most 1024.
    parallel : bool or None, keyword-only
        Run the FIFO of 7.5.2 first in the two halves of the cells at once (two threads), each over
        the cells interior to it, then serially over the cells left (:func:`_fifo_halves`). Every
        removal passes the same tests of 7.5.2, so Thms 7.4-7.6 hold, but the removal order, and so
        the skeleton, differ from the serial FIFO's. ``None`` (default): from
        ``PARALLEL_MIN_CELLS`` cells on a machine of two or more cores whose numba threading layer
        lets parallel kernels overlap, unless ``record`` (a record then shows the thesis's order, one
        layer after another, for Figs 7.18-7.21); ``False``: the serial FIFO; ``True``: always (a
        record then lists half 0's removals, then half 1's, then the serial FIFO's: a valid serial
        order, every test replayable on the state it names).
    edge_table_aside : bool, keyword-only
        On a large volume, build the volume's edge table in a second thread meanwhile, for the
        constructions that read it next (:func:`_edge_table_aside`). False for a construction that
        stores no edges (the hash propagation and the edge walk of the 2001 paper): the volume then
        holds no edge table after the thinning.

    Returns
    -------
    Skeleton
    """
    _, cells, s, cell_type = volume_arrays(vol, field)
    if n_buckets is not None and (isinstance(n_buckets, bool) or not isinstance(n_buckets, (int, np.integer))
                                  or n_buckets < 1):
        raise ThinningError(f"n_buckets must be a positive integer; got {n_buckets!r}")
    if parallel is not None and not isinstance(parallel, (bool, np.bool_)):
        raise ThinningError(f"parallel must be True, False or None; got {parallel!r}")
    if parallel is None:
        parallel = (not record and vol.n_cells >= PARALLEL_MIN_CELLS and (os.cpu_count() or 1) >= 2
                    and parallel_kernels_may_overlap())
    t0 = time.perf_counter()
    vol.node_cells  # first: face neighbours and edges are matched through it
    face_nb = vol.face_neighbors  # int32 while the cell ids fit; the kernels read it as it is
    aside = _edge_table_aside(vol) if edge_table_aside else None
    try:
        return _thin(vol, cells, s, face_nb, t0, prick_voids, record, n_buckets, bool(parallel))
    finally:
        if aside is not None:
            aside.join()


#: volumes from this many cells build their edge table in a second thread while they are thinned
_ASIDE_MIN_CELLS = 200_000
#: volumes from this many cells run the FIFO in two halves at once by default (``thin_volume(parallel=None)``)
PARALLEL_MIN_CELLS = 200_000


def _fifo_halves(vol, cells, face_nb, fmask, cls, nb_node, order, decisions, counters, src):
    """The FIFO of 7.5.2 in the two halves of the cells at once (:func:`_k.thin_halves`).

    The cells are split at the median index (the cached volumes are Morton ordered, so each half is
    a compact region and the band between them, the cells with a node touched by both halves, is
    thin). Each half runs the FIFO, lowest class first, over its interior cells only: such a cell's
    tests read only its face neighbours, the cells around its own edges and its own nodes, and its
    removal writes only its neighbours' classes and its nodes' ``n_B`` -- all in its half, never read
    or written by the other. Whatever is left (the band and the cells the halves could not remove
    beside it) is queued afresh for the serial FIFO (:func:`_k.fifo_init`).

    The removals equal those of a serial FIFO that ran half 0's, then half 1's: ``order`` and
    ``decisions`` (when recorded) are written that way, and the split depends only on the cells, so
    the result is the same run after run and for any number of numba threads.

    Returns
    -------
    (n_band, n_removed, n_decisions, labelled) : the band's cells, the removals and recorded decisions
    so far; ``labelled`` the
    deferred-label lists ``[(nodes, n), (nodes, n)]`` of the halves, in order (empty without ``src``).
    """
    m = cells.shape[0]
    split = m // 2
    off, nc = vol.node_cells
    half = _k.cell_halves(cells, off, nc, split)
    nf = fmask.shape[0]
    dec_split = split * (nf + 1) if decisions.shape[0] else 0
    stats2 = np.zeros((2, _k.N_STATS), np.int64)
    st2 = np.zeros((2, _k.N_STATE), np.int64)
    labelled2 = _jit.scratch((2, vol.n_points if src.shape[0] else 0), np.int32)
    _k.thin_halves(cells, face_nb, fmask, cls, nb_node, half, split, stats2, order, decisions, dec_split, st2, src,
                   labelled2)
    counters += stats2.sum(axis=0)
    n0, n1 = int(st2[0, _k.ST_N_REMOVED]), int(st2[1, _k.ST_N_REMOVED])
    d0, d1 = int(st2[0, _k.ST_N_DEC]), int(st2[1, _k.ST_N_DEC])
    if order.shape[0]:  # half 1's removals after half 0's
        order[n0:n0 + n1] = order[split:split + n1].copy()
    if decisions.shape[0]:
        d = decisions[dec_split:dec_split + d1].copy()
        d[:, 3] += n0
        decisions[d0:d0 + d1] = d
    labelled = [(labelled2[t], int(st2[t, _k.ST_N_LABELLED])) for t in range(2)] if src.shape[0] else []
    return int(np.count_nonzero(half < 0)), n0 + n1, d0 + d1, labelled


def _edge_table_aside(vol):
    """Start building ``vol``'s edge table in another thread, or None.

    Thinning reads no edges, and its kernels are serial (the FIFO of 7.5.1
    is one sequence) and launch no parallel region; so on a machine with
    two or more cores the edge table -- which the edge-centred records read
    next -- is built on the idle core meanwhile (2M: about 0.6 s of one
    core). :func:`thin_volume` waits for it before it returns.
    """
    if "_edge_table" in vol.__dict__ or vol.n_cells < _ASIDE_MIN_CELLS or (os.cpu_count() or 1) < 2:
        return None
    if not parallel_kernels_may_overlap():  # numba's workqueue layer: built when first read instead
        return None
    thread = threading.Thread(target=getattr, args=(vol, "_edge_table"), daemon=True,
                              name="polygen-edge-table")
    thread.start()
    return thread


def _beside_fifo(vol, out, faces_ready=None):
    """Into ``out``: the boundary faces' nodes (then ``faces_ready`` is set), the boundary groups, then
    the boundary defects and their seconds (or the exception); the cell components only where the
    groups do not tell that the volume is one part (:func:`_one_part`). On a large volume a second
    thread runs this while this one finds the extrema and runs the FIFO."""
    try:
        vol.boundary_face_nodes
        if faces_ready is not None:
            faces_ready.set()
        vol.boundary_groups
        vol.group_is_void
        t1 = time.perf_counter()
        out["defects"] = boundary_defects(vol)
        out["t_check"] = time.perf_counter() - t1
        if not _one_part(vol, out["defects"]):
            vol.cell_components
    except BaseException as exc:  # re-raised in the thinning thread
        out["error"] = exc
    finally:
        if faces_ready is not None:
            faces_ready.set()


def _thin(vol, cells, s, face_nb, t0, prick_voids, record, n_buckets, parallel):
    """:func:`thin_volume` once the node -> cells lists and the face neighbours are there."""
    # The FIFO of 7.5.2 needs the marks (Def. 7.9) and, for its removal tests, only whether a node is on
    # the boundary (n_B != 0), not its group. So on a large volume a second thread labels the cell
    # components, numbers the boundary groups and checks the boundary while this one finds the extrema
    # and runs the FIFO: with the extremum cells as the marks (a face-connected part with no extremum,
    # which needs a mark of its own, is found once the components are there, and the thinning is then
    # run again from the start with every mark: rare, parts must touch at a node) and a placeholder group
    # on the boundary nodes, each node that comes onto the boundary recording where its group comes from;
    # the groups, which only pricking (7.5.3) reads, are put in once the FIFO is empty (_k.thin_resume,
    # _k.resolve_labels). The same skeleton, the same removals in the same order as one run.
    side = {}
    helper = None
    faces_ready = threading.Event()  # the helper has built the boundary faces (10M: 0.13 s) meanwhile
    if vol.n_cells >= _ASIDE_MIN_CELLS and (os.cpu_count() or 1) >= 2 and parallel_kernels_may_overlap():
        helper = threading.Thread(target=_beside_fifo, args=(vol, side, faces_ready), daemon=True,
                                  name="polygen-thinning-beside")
        helper.start()
    try:
        tp = time.perf_counter()
        ext = find_extrema(vol, s)
        t_pe = time.perf_counter() - tp
    except BaseException:
        if helper is not None:
            helper.join()
        raise
    if helper is None:
        _beside_fifo(vol, side)
        if "error" in side:
            raise side["error"]
    t_topology = time.perf_counter() - t0 - t_pe

    t0 = time.perf_counter()
    marked = _extremum_cells(vol, ext) if helper is not None else _marked_cells(vol, ext, side["defects"])
    t1 = time.perf_counter()

    # 7.5.1: classes (Def. 7.6) and node boundary-group numbers (Def. 7.8)
    m = cells.shape[0]
    local_faces = np.ascontiguousarray(vol.local_faces, np.int64)
    fmask = _k.face_masks(local_faces, cells.shape[1])
    none = _jit.scratch(0, np.int32)

    def start(marked):
        cls = _jit.scratch(m, np.int8)
        _k.initial_classes(face_nb, marked, cls)
        # every FIFO entry is taken once: the initial ones and up to F per removal (with the halves first,
        # the serial run's initial ones again)
        n_dec = m * (fmask.shape[0] + 1) + (m * fmask.shape[0] if parallel else 0)
        return (cls, np.zeros(vol.n_points, np.int64), _jit.scratch(m if record else 0, np.int64),
                np.zeros(_k.N_STATS, np.int64), _jit.scratch((n_dec if record else 0, 4), np.int64),
                np.zeros(_k.N_STATE, np.int64))

    def first_pass(src):
        """The halves at once (``parallel``), then the FIFOs of the serial run: ``((queue, head, tail),
        the halves' deferred-label lists)``."""
        lists = []
        if parallel:
            th = time.perf_counter()
            halves["band"], n, st[_k.ST_N_DEC], lists = _fifo_halves(vol, cells, face_nb, fmask, cls, nb_node,
                                                                       order, decisions, counters, src)
            st[_k.ST_N_REMOVED] = halves["removed"] = n
            halves["t"] = time.perf_counter() - th
        return _k.fifo_init(cls, fmask.shape[0]), lists

    cls, nb_node, order, counters, decisions, st = start(marked)
    fifo = None
    lists = []
    halves = {"band": 0, "removed": 0, "t": 0.0}
    t_wait = 0.0
    deferred = helper is not None
    if deferred:  # the FIFO with placeholder groups while the helper numbers them
        faces_ready.wait()
        if "error" in side:
            helper.join()
            raise side["error"]
        bfn = vol.boundary_face_nodes  # built by the helper (read once it is there)
        nb_node[bfn.ravel()] = 1
        src = _jit.scratch(vol.n_points, np.int32)
        labelled = _jit.scratch(vol.n_points, np.int32)
        fifo, lists = first_pass(src)
        queue, head, tail = fifo
        _k.thin_resume(cells, face_nb, local_faces, fmask, cls, nb_node, np.zeros(1, np.int64),
                       np.zeros(1, np.bool_), False, order, np.zeros((1, 3), np.int64), counters, decisions,
                       queue, head, tail, np.zeros(1, np.bool_), st, src, labelled)
        tw = time.perf_counter()
        helper.join()
        t_wait = time.perf_counter() - tw
        if "error" in side:
            raise side["error"]
        extra = _parts_without_mark(vol, marked, side["defects"])
        if extra.size:  # a part with no extremum: its mark was missing, thin again from the start
            marked = np.unique(np.concatenate([marked, extra]))
            cls, nb_node, order, counters, decisions, st = start(marked)
            fifo = None
            deferred = False
        else:
            nb_node[:] = 0
    bfn = vol.boundary_face_nodes
    groups = vol.boundary_groups
    is_void_g = vol.group_is_void
    nb_node[bfn.ravel()] = np.repeat(groups, bfn.shape[1])
    if deferred:
        for nodes, n in lists:  # the halves' first: the serial run's labels may come from theirs
            _k.resolve_labels(nb_node, src, nodes, n)
        _k.resolve_labels(nb_node, src, labelled, st[_k.ST_N_LABELLED])
    if fifo is None:
        fifo, _ = first_pass(none)
        queue, head, tail = fifo
    bad_edges, bad_nodes = side["defects"]
    t_check = side["t_check"]
    if bad_edges.size or bad_nodes.size:
        warnings.warn(
            f"the boundary of this volume is not a 2-manifold ({bad_edges.shape[0]} edges and {bad_nodes.size} "
            "nodes where cells touch without a shared face, e.g. nodes "
            f"{(bad_nodes if bad_nodes.size else bad_edges.ravel())[:5].tolist()}): Thms 7.4-7.6 do not apply "
            "and the skeleton may miss parts of isosurfaces", ThinningWarning, stacklevel=3)
    n_groups = is_void_g.shape[0]
    root = np.arange(n_groups + 1, dtype=np.int64)
    is_void = np.zeros(n_groups + 1, np.bool_)
    is_void[1:] = is_void_g
    prick_log = np.zeros((n_groups + 1, 3), np.int64)
    tr = time.perf_counter()
    _k.thin_resume(cells, face_nb, local_faces, fmask, cls, nb_node, root, is_void, bool(prick_voids), order,
                   prick_log, counters, decisions, queue, head, tail, np.zeros(n_groups + 1, np.bool_), st,
                   none, none)
    t_resume = time.perf_counter() - tr
    n_removed, n_pricks, n_dec = st[_k.ST_N_REMOVED], st[_k.ST_N_PRICKS], st[_k.ST_N_DEC]
    del queue
    t2 = time.perf_counter()

    # 7.5.4: the skeleton and its value classes
    skel = np.flatnonzero(cls != 0).astype(np.int64)
    counts = _jit.scratch(skel.shape[0], np.int64)
    _k.neighbour_counts(face_nb, cls, skel, counts)
    vals = s[cells[skel]]
    cmin = np.ascontiguousarray(vals.min(axis=1))
    cmax = np.ascontiguousarray(vals.max(axis=1))
    nb_ = int(n_buckets) if n_buckets is not None else int(np.clip(skel.shape[0] // 8, 1, 1024))
    buckets = SpanFilter.build(cmin, cmax, n_buckets=nb_, layout="replicate")
    t3 = time.perf_counter()

    unpricked = np.flatnonzero(is_void & (root == np.arange(n_groups + 1))) if prick_voids else \
        np.flatnonzero(is_void)
    nf = face_nb.shape[1]
    stats = {
        "T_topology": t_topology,
        "T_check": t_check,
        "nonmanifold_edges": int(bad_edges.shape[0]),
        "nonmanifold_nodes": int(bad_nodes.size),
        "T_pe": t_pe + t1 - t0,  # the extrema and the marks
        "T_thin": t2 - t1 - t_wait,  # classes, n_B, removal (not the wait for the groups, T_wait)
        "T_wait": t_wait,
        "T_halves": halves["t"],
        "T_resume": t_resume,
        "T_register": t3 - t2,
        "T_total": t_pe + t3 - t0,
        "extrema": ext.n,
        "marked": int(marked.shape[0]),
        "skeleton_cells": int(skel.shape[0]),
        "removed": int(n_removed),
        "processed": {q: int(counters[_k.ST_PROCESSED + q]) for q in range(1, nf)},
        "removed_by_class": {q: int(counters[_k.ST_REMOVED + q]) for q in range(1, nf)},
        "walks": int(counters[_k.ST_WALKS]),
        "walks_reached": int(counters[_k.ST_WALKS_OK]),
        "pricks": int(n_pricks),
        "prick_failures": int(counters[_k.ST_PRICK_FAILED]),
        "prick_cells": int(counters[_k.ST_PRICK_CELLS]),
        "implicit_removals": int(counters[_k.ST_IMPLICIT]),
        "stale_fifo_entries": int(counters[_k.ST_STALE]),
        "n_buckets": nb_,
        "parallel": bool(parallel),
        "band_cells": int(halves["band"]),
        "removed_in_halves": halves["removed"],
    }
    for q in range(0, 7):
        stats[f"C{q}"] = int(np.sum(counts == q))
    rec = None
    if record:
        d = decisions[:n_dec]
        rec = ThinningRecord(removal_order=order[:n_removed].copy(), pricks=prick_log[:n_pricks].copy(), n_cells=m,
                             decided_cell=d[:, 0].copy(), decided_class=d[:, 1].copy(), decided_removed=d[:, 2] == 1,
                             decided_after=d[:, 3].copy())
    return Skeleton(vol=vol, s=s, extrema=ext, marked=marked, classes=cls, cells=skel, neighbour_counts=counts,
                    node_groups=nb_node, group_root=root, unpricked_voids=unpricked, record=rec, stats=stats,
                    _cmin=cmin, _cmax=cmax, _buckets=buckets, _hits=_jit.scratch(skel.shape[0], np.int64))


# ------------------------------------------------------------------ 2D image thinning
def thin_image(image, *, record=False):
    """Thin a binary image to a one-pixel skeleton (thesis 7.3, Fig. 7.2).

    Border pixels are visited layer by layer; a pixel goes when all its
    edge-sharing black neighbours can be visited in one sweep around it
    through black neighbours (edge or corner), unless it is the end of a
    line (one edge neighbour and no corner neighbour). Black regions are
    4-connected, white ones 8-connected; both keep their number.

    Parameters
    ----------
    image : (H, W) bool
    record : bool, keyword-only
        Also return the removed pixels in order, ``(R, 2)`` rows ``(i, j)``.

    Returns
    -------
    skeleton : (H, W) bool
    order : (R, 2) int64, only when ``record``
    """
    img = np.asarray(image)
    if img.ndim != 2:
        raise ThinningError(f"image must be 2-D (H, W); got shape {img.shape}")
    if img.dtype != bool:
        if not np.issubdtype(img.dtype, np.number) or not np.isin(img, (0, 1)).all():
            raise ThinningError("image must be boolean (or hold only 0 and 1)")
    out = np.ascontiguousarray(img, dtype=np.bool_).copy()
    order = _jit.scratch((int(out.sum()) if record else 0, 2), np.int64)
    n = _k.thin_image(out, order)
    return (out, order[:n]) if record else out


def pixel_removable(patch):
    """Whether the centre pixel of a 3x3 ``patch`` may go by the two conditions of 7.3 (Fig. 7.2 (b)-(e)).

    Parameters
    ----------
    patch : (3, 3) bool
        The pixel and its 8 neighbours (black = True); the centre must be black.
    """
    p = np.asarray(patch)
    if p.shape != (3, 3):
        raise ThinningError(f"patch must be 3x3; got shape {p.shape}")
    p = p.astype(bool)
    if not p[1, 1]:
        raise ThinningError("the centre pixel of the patch must be black (True)")
    return bool(_k._pixel_removable(np.ascontiguousarray(p), 1, 1))


# ------------------------------------------------------------------ the method
@register
class ThinningMethod(SeedsThenPropagate):
    """Volume thinning (thesis chapter 7) for :mod:`polygen.volume.methods`: the skeleton's seeds x propagation.

    The keyword-only parameters after ``vol`` and ``field`` are those of
    :func:`thin_volume`. After each :meth:`extract`, ``stats`` holds that
    call's ``T_mg`` (seed search on the skeleton), ``T_mt`` (triangles:
    propagation), ``T_mv`` (vertex positions and normals), ``N_cg`` (skeleton
    cells tested), ``N_ci`` (cells intersected) and ``seeds`` (the
    :class:`SkeletonSeeds`).
    """

    name = "thinning"
    description = "Itoh's volume thinning: a genus-keeping skeleton of cells, no boundary lists (chapter 7)"
    seeds = "thinning"

    def _prepare(self, prick_voids=True, record=False, n_buckets=None, parallel=None, edge_table_aside=True):
        super()._prepare(prick_voids=prick_voids, record=record, n_buckets=n_buckets, parallel=parallel,
                         edge_table_aside=edge_table_aside)

    @property
    def skeleton(self):
        """The :class:`Skeleton` the seeds come from."""
        return self.source.structure


def _thinning_seed_source(vol, field=None, **params):
    """The seed interface of volume thinning: build the skeleton, then ``query(value) -> Seeds``."""
    sk = thin_volume(vol, field, **params)
    return sk, functools.partial(_skeleton_query, sk)  # not a closure: a prepared method pickles


def _skeleton_query(sk, value):
    found = sk.seeds(value)
    return Seeds(found.value, found.cells, found.n_tested, found.t_search, found)


register_seed_source("thinning", _thinning_seed_source)
