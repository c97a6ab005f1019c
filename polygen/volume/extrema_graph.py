"""The extrema graph: fast isosurfaces from a graph joining the extrema (thesis chapter 6).

Preprocessing (once per volume and field, Fig. 6.4):

1. **Extrema** (6.3.1, Fig. 6.5, :func:`find_extrema`). Each cell marks
   all its nodes but the largest "not-maximum" and all but the smallest
   "not-minimum"; when several nodes tie at the cell's largest (smallest)
   value they get a "plural-maximums" ("plural-minimums") mark. A node
   never marked "not-maximum" is a maximum (Def. 6.3, non-strictly); one
   that carries a plural mark stands for its flat group of equal nodes,
   whose marks are cleared by a search through the cells, so each flat
   group gives one extremum.
2. **The graph** (6.3.2, Figs 6.6-6.10, :func:`build_extrema_graph`).
   Every extremum carries a component number. Each extremum in turn
   sorts the extrema numbered differently by distance and is joined to
   the nearest one that a straight segment reaches inside the volume,
   walked cell by cell through face neighbours (Fig. 6.7); when the
   segment leaves the volume (concave parts, voids) the next nearest is
   tried (Fig. 6.8); when no segment stays inside, the polyline walk
   (Fig. 6.9) crosses, from cell to cell, the non-boundary face to an
   unvisited cell with the smallest sum of node distances to the goal.
   The joined sides take the smaller number (Fig. 6.6). Each arc keeps its
   cells and the smallest and largest node value of those cells (S_min,
   S_max, Def. 6.8). The thesis leaves open what to do when the polyline
   walk dead-ends; we then join the nearest differently numbered extremum
   in face steps by a breadth-first search, so the graph always spans
   every face-connected part of the volume (counted as ``search`` arcs).
3. **Boundary cell lists** (6.3.3): the cells with a boundary face, each
   once, sorted by S_min and by S_max. Or, with ``boundary="loops"`` (ours,
   not the thesis's), only the cells along edge loops that generate the
   boundary's first homology (:mod:`polygen.volume.homology`): an
   isosurface that reaches the boundary and separates the volume has an
   extremum on each side and so crosses an arc; one that does not separate
   it crosses one of the loops. On our parts that is 1.5-3.6 % of the
   boundary cells, and the cells tested to find seeds drop accordingly.

The query for an isovalue ``C`` (6.3.4, :meth:`ExtremaGraph.seeds`): arcs
whose ``[S_min, S_max]`` cannot hold an intersected cell are skipped, the
cells of the others are tested; the boundary cells are taken from the list
on the near side of ``C`` (the shorter of ``S_min < C`` and ``S_max >= C``)
and tested; every cell is tested once per query. Propagation
(:class:`~polygen.volume.propagate.Propagator`) grows the surface from
every hit. Closed isosurfaces enclose an extremum and so cross an arc
(Thms 6.1, 6.2); the others reach the boundary.

The method is registered as ``extrema-graph`` in
:mod:`polygen.volume.methods`::

    m = methods.get("extrema-graph")(vol)
    iso = m.extract(0.5)
    m.stats        # T_mg, T_mb, T_mt, T_mv, N_cg, N_ci of Table 6.5 for this call
    m.graph.stats  # T_pe, T_pc, T_pb, extrema, graph cells, polyline arcs of Table 6.3
"""

from __future__ import annotations

import dataclasses
import functools
import time

import numpy as np

from polygen import _jit
from polygen.volume import _extrema_kernels as _k
from polygen.volume._cells import index_dtype
from polygen.volume.homology import BoundaryLoops, boundary_loops
from polygen.volume.methods import SeedsThenPropagate, register
from polygen.volume.registry import register_seed_source
from polygen.volume.seeds.source import Seeds
from polygen.volume.surface import IsoSurfaceError, check_value, volume_arrays

__all__ = [
    "ExtremaGraphError",
    "Extrema",
    "ExtremaGraph",
    "GraphRecord",
    "GraphSeeds",
    "ExtremaGraphMethod",
    "find_extrema",
    "build_extrema_graph",
    "extrema_graph_2d",
    "ARC_KINDS",
]

#: names of ``ExtremaGraph.arc_kind`` values
ARC_KINDS = ("straight", "polyline", "search")


class ExtremaGraphError(IsoSurfaceError):
    """Bad input to the extrema graph (the message says what)."""


# ------------------------------------------------------------------ extrema
@dataclasses.dataclass(frozen=True, eq=False)
class Extrema:
    """The extrema of a node field (6.3.1) and the marks that found them (Fig. 6.5).

    Attributes
    ----------
    nodes : (m,) int64
        Node ids of the extrema, ascending; one per flat group.
    is_max, is_min : (m,) bool
        Whether each is a maximum / a minimum (a node of a constant region is both).
    not_max, not_min : (N,) bool
        The "not-maximum" / "not-minimum" marks after the cell loop.
    plural_max, plural_min : (N,) bool
        The "plural-maximums" / "plural-minimums" marks after the cell loop
        (before the flat groups were cleared).
    n_flat : int
        Extrema that stand for a flat group of tied nodes.
    """

    nodes: np.ndarray
    is_max: np.ndarray
    is_min: np.ndarray
    not_max: np.ndarray
    not_min: np.ndarray
    plural_max: np.ndarray
    plural_min: np.ndarray
    n_flat: int

    @property
    def n(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def maxima(self) -> np.ndarray:
        return self.nodes[self.is_max]

    @property
    def minima(self) -> np.ndarray:
        return self.nodes[self.is_min]


def _cells_and_values(cells, values):
    cells = np.asarray(cells)
    if cells.ndim != 2 or cells.shape[1] < 2 or not np.issubdtype(cells.dtype, np.integer):
        raise ExtremaGraphError(f"cells must be an (M, k) integer array; got {cells.dtype} {cells.shape}")
    s = np.asarray(values, dtype=np.float64)
    if s.ndim != 1:
        raise ExtremaGraphError(f"node values must be 1-D; got shape {s.shape}")
    if not np.all(np.isfinite(s)):
        raise ExtremaGraphError(f"node values must be finite; {int(np.sum(~np.isfinite(s)))} are not")
    if cells.size and (cells.min() < 0 or cells.max() >= s.shape[0]):
        raise ExtremaGraphError(f"cells refer to nodes outside 0..{s.shape[0] - 1}")
    return np.ascontiguousarray(cells, index_dtype(s.shape[0])), np.ascontiguousarray(s)


def _node_cells_csr(cells, n):
    flat = cells.ravel()
    order = np.argsort(flat, kind="stable")
    off = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(flat, minlength=n), out=off[1:])
    return off, (order // cells.shape[1]).astype(np.int64)


def _extrema_from_arrays(cells, s, node_off, node_cells):
    n = s.shape[0]
    not_max = np.zeros(n, np.bool_)
    not_min = np.zeros(n, np.bool_)
    plural_max = np.zeros(n, np.bool_)
    plural_min = np.zeros(n, np.bool_)
    _k._mark_cells(cells, s, not_max, not_min, plural_max, plural_min)
    kind = np.zeros(n, np.int8)
    _k._register_strict(not_max, not_min, plural_max, plural_min, kind)
    n_fmax, n_fmin = _k._register_extrema(s, cells, node_off, node_cells, not_max, not_min, plural_max.copy(),
                                          plural_min.copy(), kind)
    nodes = np.flatnonzero(kind).astype(np.int64)
    # a node no cell uses (FE exports keep reference nodes) has no neighbour, so it would count as an
    # extremum with no cell to seed from: it is not part of the volume (Def. 5.2), drop it
    nodes = nodes[node_off[nodes + 1] > node_off[nodes]]
    kk = kind[nodes]
    return Extrema(nodes=nodes, is_max=(kk & _k.KIND_MAX) > 0, is_min=(kk & _k.KIND_MIN) > 0, not_max=not_max,
                   not_min=not_min, plural_max=plural_max, plural_min=plural_min, n_flat=int(n_fmax + n_fmin))


def find_extrema(vol, field=None):
    """Local maxima and minima of a node field by the marks of Fig. 6.5 (thesis 6.3.1).

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name or node values; the volume's first field by default.

    Returns
    -------
    Extrema
        A node is a maximum when no cell has a larger node (Def. 6.3, ties
        allowed); each flat group of tied extreme nodes joined through
        cells gives one extremum, its first node.
    """
    _, cells, s, _ = volume_arrays(vol, field)
    off, nc = vol.node_cells  # int64 offsets, int32 cells: read as they are (no 32-byte-per-cell copy)
    return _extrema_from_arrays(cells, s, off, nc)


# ------------------------------------------------------------------ the graph
@dataclasses.dataclass(frozen=True, eq=False)
class GraphSeeds:
    """Seeds of one query (6.3.4) and its counters (Table 6.5).

    Attributes
    ----------
    value : float
    cells : (K,) int64
        Intersected cells found on arcs, then on the boundary.
    n_from_arcs : int
        How many of ``cells`` came from arcs (the rest from the boundary lists).
    tested_arcs, tested_boundary : int
        Cells tested on arcs / taken from a boundary list and tested (each cell once per query).
    arcs_tested : int
        Arcs whose [S_min, S_max] admitted ``value``.
    used_max_list : bool
        The boundary cells came from the list sorted by S_max (``C`` near the top).
    t_graph, t_boundary : float
        Seconds (T_mg, T_mb).
    """

    value: float
    cells: np.ndarray
    n_from_arcs: int
    tested_arcs: int
    tested_boundary: int
    arcs_tested: int
    used_max_list: bool
    t_graph: float
    t_boundary: float

    @property
    def n_tested(self) -> int:
        """N_cg: cells tested to find the seeds."""
        return self.tested_arcs + self.tested_boundary


@dataclasses.dataclass(frozen=True, eq=False)
class GraphRecord:
    """Every try of the graph construction in order (Fig. 6.10), for Figs 6.6-6.9.

    Attributes
    ----------
    start, goal : (T,) int64
        Extremum indices (into ``Extrema.nodes``) of the start point and the
        point tried as goal (-1 for a breadth-first search that found none).
    kind : (T,) int64
        :data:`ARC_KINDS` index of the walk tried.
    ok : (T,) bool
        Whether the walk reached the goal (then it is the next arc).
    offsets : (T+1,) int64, cells : (L,) int64
        CSR: the cells each try walked through, in order (a failed straight
        walk: up to where the segment left the volume).
    """

    start: np.ndarray
    goal: np.ndarray
    kind: np.ndarray
    ok: np.ndarray
    offsets: np.ndarray
    cells: np.ndarray

    @property
    def n_tries(self) -> int:
        return int(self.start.shape[0])

    def try_cells(self, k):
        """(n,) int64: the cells walked in try ``k``."""
        return self.cells[self.offsets[k]:self.offsets[k + 1]]

    def components(self, m):
        """(A+1, m) int64: the number C_i of each extremum before the first arc and after each (Fig. 6.6).

        Replays the numbering of the arcs in the order they were made: both
        ends take the smaller number, and so do all extrema that had the larger.
        """
        comp = np.arange(m)
        out = [comp.copy()]
        for i, j in zip(self.start[self.ok], self.goal[self.ok]):
            lo, hi = min(comp[i], comp[j]), max(comp[i], comp[j])
            comp[comp == hi] = lo
            out.append(comp.copy())
        return np.array(out)


@dataclasses.dataclass(eq=False)
class ExtremaGraph:
    """The extrema graph and the boundary cell lists of one volume and field (Defs 6.6-6.9).

    Attributes
    ----------
    extrema : Extrema
    arc_ends : (A, 2) int64
        Node ids of the two extrema of each arc (start point, goal point).
    arc_offsets : (A+1,) int64, arc_cells : (L,) int64
        CSR: the cells each arc passes through, in walking order.
    arc_smin, arc_smax : (A,) float64
        Smallest / largest node value over the cells of each arc (Def. 6.8).
    arc_kind : (A,) int64
        0 straight, 1 polyline, 2 breadth-first search (:data:`ARC_KINDS`).
    component : (m,) int64
        Component number of each extremum after the construction (all 0 for a connected volume).
    blist_min, blist_max : (Kb,) int64
        Boundary cells, each once, by ascending S_min / ascending S_max (6.3.3);
        empty with ``boundary="loops"``.
    blist_min_values, blist_max_values : (Kb,) float64
        Their S_min / S_max, ascending.
    boundary : {"lists", "loops"}
        What stands for the boundary in the query (see :func:`build_extrema_graph`).
    loops : BoundaryLoops or None
        With ``boundary="loops"``: the boundary's homology generators.
    loop_smin, loop_smax : (L,) float64
        Smallest / largest node value along each loop.
    record : GraphRecord or None
        With ``record=True``: every try of the construction.
    stats : dict
        Table 6.3: ``T_pe``, ``T_pc``, ``T_pb`` (s), ``extrema``, ``graph_cells``
        (sum of arc lengths), ``graph_cells_unique``, ``polyline_arcs``,
        ``search_arcs``, ``straight_failures``, ``polyline_failures``,
        ``failed_walk_cells``, ``sorts``, ``boundary_cells`` (the cells that
        stand for the boundary: every boundary cell, or the loops' cells),
        ``loops``.
    """

    vol: object
    s: np.ndarray
    extrema: Extrema
    arc_ends: np.ndarray
    arc_offsets: np.ndarray
    arc_cells: np.ndarray
    arc_smin: np.ndarray
    arc_smax: np.ndarray
    arc_kind: np.ndarray
    component: np.ndarray
    blist_min: np.ndarray
    blist_min_values: np.ndarray
    blist_max: np.ndarray
    blist_max_values: np.ndarray
    stats: dict
    boundary: str = "lists"
    loops: BoundaryLoops | None = None
    loop_smin: np.ndarray = None
    loop_smax: np.ndarray = None
    record: GraphRecord | None = None
    _max_by_min: np.ndarray = dataclasses.field(repr=False, default=None)
    _min_by_max: np.ndarray = dataclasses.field(repr=False, default=None)
    _mark: np.ndarray = dataclasses.field(repr=False, default=None)
    _stamp: int = 0

    @property
    def n_arcs(self) -> int:
        return int(self.arc_ends.shape[0])

    def __repr__(self):
        st = self.stats
        return (f"ExtremaGraph({st['extrema']} extrema, {self.n_arcs} arcs over {st['graph_cells']} cells "
                f"({st['polyline_arcs']} polyline, {st['search_arcs']} search), "
                f"{st['boundary_cells']} boundary cells)")

    def arc(self, a):
        """(k,) int64 cells of arc ``a``."""
        return self.arc_cells[self.arc_offsets[a]:self.arc_offsets[a + 1]]

    def graph_cells(self):
        """(G,) int64 distinct cells registered on the arcs."""
        return np.unique(self.arc_cells)

    def seeds(self, value):
        """The intersected cells that the graph and the boundary lists give for ``C = value`` (6.3.4).

        Parameters
        ----------
        value : float

        Returns
        -------
        GraphSeeds
        """
        value = check_value(value)
        if self._stamp == np.iinfo(np.int64).max:  # pragma: no cover - 2**63 queries
            self._mark[:] = 0
            self._stamp = 0
        self._stamp += 1
        cells = self.vol.cells
        n_boundary = self.loops.cells.shape[0] if self.boundary == "loops" else self.blist_min.shape[0]
        hits = _jit.scratch(self.arc_cells.shape[0] + n_boundary, np.int64)
        t0 = time.perf_counter()
        n_arc_hits, tested_arcs, arcs_tested = _k._query_arcs(cells, self.s, self.arc_offsets, self.arc_cells,
                                                             self.arc_smin, self.arc_smax, value, self._mark,
                                                             self._stamp, hits, 0)
        t1 = time.perf_counter()
        if self.boundary == "loops":
            n_hits, tested_b, _ = _k._query_arcs(cells, self.s, self.loops.offsets, self.loops.cells, self.loop_smin,
                                                 self.loop_smax, value, self._mark, self._stamp, hits, n_arc_hits)
            used_max = False
        else:
            n_hits, tested_b, used_max = _k._query_boundary(self.blist_min, self.blist_min_values, self._max_by_min,
                                                            self.blist_max, self.blist_max_values, self._min_by_max,
                                                            value, self._mark, self._stamp, hits, n_arc_hits)
        t2 = time.perf_counter()
        return GraphSeeds(value=value, cells=hits[:n_hits].copy(), n_from_arcs=int(n_arc_hits),
                          tested_arcs=int(tested_arcs), tested_boundary=int(tested_b), arcs_tested=int(arcs_tested),
                          used_max_list=bool(used_max), t_graph=t1 - t0, t_boundary=t2 - t1)

    def arc_candidates(self, value):
        """Step 3 of 6.3.4 without the tests: the cells of every arc whose [S_min, S_max] admits ``value``.

        Returns
        -------
        cells : (K,) int64
            In arc order (a cell on two arcs appears twice).
        arcs : int
            Arcs admitted.
        """
        value = check_value(value)
        return _admitted(self.arc_offsets, self.arc_cells, self.arc_smin, self.arc_smax, value)

    def boundary_candidates(self, value):
        """Step 4 of 6.3.4 without the tests: the boundary cells on the near side of the range.

        Cells with ``S_min < C`` (a prefix of the list by S_min) or with
        ``S_max >= C`` (a suffix of the list by S_max), whichever is
        shorter; every boundary cell the surface crosses is among them.
        With ``boundary="loops"``: the cells of every loop whose node range
        admits ``value``, in loop order.

        Returns
        -------
        cells : (K,) int64
        used_max_list : bool
        """
        value = check_value(value)
        if self.boundary == "loops":
            return _admitted(self.loops.offsets, self.loops.cells, self.loop_smin, self.loop_smax, value)[0], False
        nb = self.blist_min.shape[0]
        k_lo = int(np.searchsorted(self.blist_min_values, value, side="left"))
        k_hi = nb - int(np.searchsorted(self.blist_max_values, value, side="left"))
        if k_lo <= k_hi:
            return self.blist_min[:k_lo], False
        return self.blist_max[nb - k_hi:], True

    def arc_polylines(self):
        """(A, 2, 3) float64 end points of each arc (for plots)."""
        return self.vol.points[self.arc_ends]


def _admitted(offsets, cells, smin, smax, value):
    """The cells of the CSR paths whose [smin, smax] can hold a crossing at ``value``, and how many paths."""
    adm = np.flatnonzero((smax >= value) & (smin < value))
    starts = offsets[adm]
    lens = offsets[adm + 1] - starts
    shift = np.repeat(starts - (np.cumsum(lens) - lens), lens)
    return cells[np.arange(int(lens.sum())) + shift], int(adm.size)


BOUNDARY = ("lists", "loops")


def build_extrema_graph(vol, field=None, *, polyline=True, boundary="lists", record=False):
    """Extrema, extrema graph and boundary cell lists of ``vol`` (thesis 6.3.1-6.3.3).

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name or node values; the volume's first field by default.
    polyline : bool, keyword-only
        Use the polyline walk of Fig. 6.9 before the breadth-first fallback
        (``False`` skips straight to the fallback; for experiments).
    boundary : {"lists", "loops"}, keyword-only
        ``"lists"``: the thesis's sorted boundary cell lists (6.3.3).
        ``"loops"``: instead, the cells along boundary edge loops that
        generate the boundary's homology (:func:`~polygen.volume.homology.boundary_loops`),
        each loop skipped when the isovalue is outside its node range; T_pb
        then times the loops and their ranges. A non-manifold boundary
        (cells that touch only along an edge or at a node) falls back to the
        lists and says so in ``stats["loops_fallback"]``.
    record : bool, keyword-only
        Keep every try of the construction (:class:`GraphRecord`, Figs 6.6-6.9).

    Returns
    -------
    ExtremaGraph
        ``stats`` holds the Table 6.3 timings and counters. The volume's
        topology tables (face neighbours, node cells, boundary faces) are
        computed before the clocks start.
    """
    if boundary not in BOUNDARY:
        raise ExtremaGraphError(f"boundary must be one of {BOUNDARY}; got {boundary!r}")
    _, cells, s, cell_type = volume_arrays(vol, field)  # the volume's cells as they are (int32), not copied
    # topology is the volume model's, not part of Table 6.3
    face_nb = np.ascontiguousarray(vol.face_neighbors, np.int64)
    off, nc = vol.node_cells
    off = np.ascontiguousarray(off, np.int64)
    nc = np.ascontiguousarray(nc, np.int64)
    bcells = np.ascontiguousarray(vol.boundary_cells, np.int64)
    faces = np.ascontiguousarray(vol.local_faces, np.int64)
    points = np.ascontiguousarray(vol.points, np.float64)

    t0 = time.perf_counter()
    ext = _extrema_from_arrays(cells, s, off, nc)
    t1 = time.perf_counter()
    arc_ext, arc_off, arc_cells, arc_kind, comp, counters, tries, tcells = _k._build_graph(
        points, cells, s, faces, face_nb, off, nc, ext.nodes, bool(polyline), bool(record))
    smin = _jit.scratch(arc_ext.shape[0])
    smax = _jit.scratch(arc_ext.shape[0])
    _k._arc_ranges(cells, s, arc_off, arc_cells, smin, smax)
    t2 = time.perf_counter()
    loops = loop_smin = loop_smax = None
    fallback = None
    if boundary == "loops":
        loops = boundary_loops(vol)
        if not loops.manifold:
            # cells touching along an edge or at a node: the loops do not stand for the face-connected
            # volume's boundary, and an extremum can hide behind a neighbour across the pinch
            fallback = (f"non-manifold boundary ({loops.nonmanifold_edges} edges, {loops.nonmanifold_nodes} nodes): "
                        "boundary lists used")
            boundary, loops = "lists", None
    if boundary == "loops":
        if loops.n_loops:
            starts = loops.offsets[:-1]
            loop_smin = np.minimum.reduceat(s[loops.nodes], starts)
            loop_smax = np.maximum.reduceat(s[loops.nodes], starts)
        else:
            loop_smin = loop_smax = np.zeros(0)
        bcells = np.zeros(0, np.int64)
    # 6.3.3: S_min and S_max of each boundary cell (each cell once), two sorted lists
    lo = _jit.scratch(bcells.shape[0])
    hi = _jit.scratch(bcells.shape[0])
    _k._cell_min_max(cells, s, bcells, lo, hi)
    o_min = np.argsort(lo, kind="stable")
    o_max = np.argsort(hi, kind="stable")
    t3 = time.perf_counter()

    stats = {
        "T_pe": t1 - t0,
        "T_pc": t2 - t1,
        "T_pb": t3 - t2,
        "extrema": ext.n,
        "maxima": int(ext.is_max.sum()),
        "minima": int(ext.is_min.sum()),
        "flat_extrema": ext.n_flat,
        "arcs": int(arc_ext.shape[0]),
        "graph_cells": int(arc_cells.shape[0]),
        "graph_cells_unique": int(np.unique(arc_cells).shape[0]),
        "polyline_arcs": int(np.sum(arc_kind == _k.ARC_POLYLINE)),
        "search_arcs": int(np.sum(arc_kind == _k.ARC_SEARCH)),
        "straight_failures": int(counters[0]),
        "polyline_failures": int(counters[1]),
        "failed_walk_cells": int(counters[2]),
        "sorts": int(counters[3]),
        "boundary_cells": int(bcells.shape[0]) if loops is None else int(loops.unique_cells().shape[0]),
        "loops": 0 if loops is None else loops.n_loops,
        "loops_fallback": fallback,
    }
    return ExtremaGraph(
        vol=vol, s=s, extrema=ext, arc_ends=ext.nodes[arc_ext].reshape(-1, 2), arc_offsets=arc_off,
        arc_cells=arc_cells, arc_smin=smin, arc_smax=smax, arc_kind=arc_kind, component=comp,
        blist_min=bcells[o_min], blist_min_values=lo[o_min], blist_max=bcells[o_max], blist_max_values=hi[o_max],
        stats=stats, boundary=boundary, loops=loops, loop_smin=loop_smin, loop_smax=loop_smax,
        record=GraphRecord(start=tries[:, 0].copy(), goal=tries[:, 1].copy(), kind=tries[:, 2].copy(),
                           ok=tries[:, 3].astype(bool), offsets=np.append(tries[:, 5], tcells.shape[0]), cells=tcells)
        if record else None,
        _max_by_min=hi[o_min], _min_by_max=lo[o_max], _mark=np.zeros(cells.shape[0], np.int64),
    )


# ------------------------------------------------------------------ 2D illustration
def extrema_graph_2d(points, triangles, values):
    """Fig. 6.2 in the plane: extrema of a field on a triangulation, joined nearest-first.

    The extrema are found with the marks of Fig. 6.5 (the same kernel as
    in 3D, on triangles); each extremum in turn is joined by a straight
    segment to the nearest extremum numbered differently (Fig. 6.6). The
    segments are not walked through the triangles, so this is meant for a
    convex domain (an illustration, not a search structure).

    Parameters
    ----------
    points : (N, 2) float64
    triangles : (T, 3) int64
    values : (N,) float64

    Returns
    -------
    extrema : Extrema
    arcs : (A, 2) int64
        Node ids of the joined extrema.
    """
    pts = np.asarray(points, np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ExtremaGraphError(f"points must be (N, 2); got {pts.shape}")
    tri, s = _cells_and_values(triangles, values)
    if s.shape[0] != pts.shape[0]:
        raise ExtremaGraphError(f"values must have one entry per point ({pts.shape[0]}); got {s.shape[0]}")
    off, nc = _node_cells_csr(tri, s.shape[0])
    ext = _extrema_from_arrays(tri, s, off, nc)
    xyz = np.zeros((pts.shape[0], 3))
    xyz[:, :2] = pts
    arcs = _k._join_nearest(xyz, ext.nodes)
    return ext, ext.nodes[arcs].reshape(-1, 2)


# ------------------------------------------------------------------ the method
@register
class ExtremaGraphMethod(SeedsThenPropagate):
    """The extrema graph method (thesis chapter 6) for :mod:`polygen.volume.methods`: its seeds x propagation.

    The keyword-only parameters after ``vol`` and ``field`` are these.

    Other Parameters
    ----------------
    polyline : bool
        Passed to :func:`build_extrema_graph`.
    boundary : {"lists", "loops"}
        Passed to :func:`build_extrema_graph`; ``"lists"`` (the thesis's)
        here, ``"loops"`` in the ``extrema-graph-loops`` method.
    order : {"thesis", "separate"}
        ``"thesis"`` (6.3.4 as written): the cells of the admitted arcs are
        tested and propagated from, and only then the boundary cells on the
        near side of the range, each one only if no propagation has reached
        it yet, each crossed one propagated from at once. ``"separate"``:
        :meth:`ExtremaGraph.seeds` finds every intersected arc and boundary
        cell first (its own marks), then one propagation starts from all of
        them (in id order). The surface is the same; the thesis's order
        tests fewer boundary cells.

    Notes
    -----
    After each :meth:`extract`, ``stats`` holds Table 6.5's quantities for
    that call: ``T_mg``, ``T_mb`` (seed search on arcs / boundary lists; in
    the thesis's order the boundary cells' tests run inside the propagation
    and count in ``T_mt``), ``T_mt`` (triangles: propagation), ``T_mv``
    (vertex positions and normals), ``N_cg`` (cells tested to find seeds),
    ``N_ci`` (cells intersected), and ``seeds`` (a :class:`GraphSeeds`:
    in the thesis's order, the boundary seeds are those that started a
    propagation).
    """

    name = "extrema-graph"
    description = "Itoh's extrema graph: arcs between extrema plus sorted boundary cell lists (chapter 6)"

    seeds = "extrema-graph"
    boundary = "lists"

    def _prepare(self, polyline=True, order="thesis", boundary=None):
        if order not in ("thesis", "separate"):
            raise ExtremaGraphError(f"order must be 'thesis' or 'separate'; got {order!r}")
        self.order = order
        super()._prepare(polyline=polyline, boundary=self.boundary if boundary is None else boundary)

    @property
    def graph(self):
        """The :class:`ExtremaGraph` the seeds come from."""
        return self.source.structure

    def extract(self, value, *, normals="mean"):
        if self.order == "separate":
            return self._extract_separate(value, normals)
        value = check_value(value)
        t0 = time.perf_counter()
        arc_cells, arcs = self.graph.arc_candidates(value)
        t1 = time.perf_counter()
        boundary, used_max = self.graph.boundary_candidates(value)
        t2 = time.perf_counter()
        prop = self.propagator
        iso = prop.extract(value, arc_cells, normals=normals, then=boundary)
        found = GraphSeeds(value=value,
                           cells=np.concatenate([prop.last_order[:prop.last_seeds_crossed], prop.last_then_seeds]),
                           n_from_arcs=prop.last_seeds_crossed, tested_arcs=prop.last_seeds_tested,
                           tested_boundary=prop.last_then_tested, arcs_tested=arcs, used_max_list=used_max,
                           t_graph=t1 - t0 + iso.t1, t_boundary=t2 - t1)
        self.seed_cells_tested = found.n_tested
        self.stats = {
            "T_mg": found.t_graph,
            "T_mb": found.t_boundary,
            "T_mt": iso.t2,
            "T_mv": iso.t3,
            "N_cg": found.n_tested,
            "N_ci": iso.cells_intersected,
            "seeds": found,
        }
        return dataclasses.replace(iso, t1=found.t_graph + found.t_boundary)  # t_graph includes the arc tests

    def _extract_separate(self, value, normals):
        found = self.graph.seeds(value)
        t0 = time.perf_counter()
        # the boundary hits come in the lists' value order; in id order (cells numbered along a
        # space-filling curve) the propagation reads memory nearly in order (data4: 0.40 -> 0.33 s)
        seeds = np.sort(found.cells)
        t_sort = time.perf_counter() - t0
        iso = self.propagator.extract(value, seeds, normals=normals)
        self.seed_cells_tested = found.n_tested
        self.stats = {
            "T_mg": found.t_graph,
            "T_mb": found.t_boundary + t_sort,
            "T_mt": iso.t1 + iso.t2,
            "T_mv": iso.t3,
            "N_cg": found.n_tested,
            "N_ci": iso.cells_intersected,
            "seeds": found,
        }
        return dataclasses.replace(iso, cells_tested=iso.cells_tested + found.n_tested,
                                   t1=iso.t1 + found.t_graph + found.t_boundary + t_sort)


@register
class ExtremaGraphLoopsMethod(ExtremaGraphMethod):
    """The extrema graph with the boundary cell lists replaced by boundary homology loops (ours).

    Same arcs, same query order; in step 4 the cells along the loops of
    :func:`~polygen.volume.homology.boundary_loops` whose node range admits
    the value are tested instead of the near side of a boundary list.
    """

    name = "extrema-graph-loops"
    description = "extrema graph with boundary loops generating H1 in place of the boundary lists (ours)"
    boundary = "loops"


def _graph_seed_source(vol, field=None, **params):
    """The seed interface of the extrema graph: build, then ``query(value) -> Seeds``."""
    graph = build_extrema_graph(vol, field, **params)
    return graph, functools.partial(_graph_query, graph)  # not a closure: a prepared method pickles


def _graph_query(graph, value):
    found = graph.seeds(value)
    return Seeds(found.value, found.cells, found.n_tested, found.t_graph + found.t_boundary, found)


register_seed_source("extrema-graph", _graph_seed_source)
register_seed_source("extrema-graph-loops", functools.partial(_graph_seed_source, boundary="loops"))
