"""Isosurfaces of unstructured volumes: the full scan and :func:`extract` (the result is in :mod:`polygen.volume.surface`).

An isosurface (Def. 5.11) is the set of triangles that marching
tetrahedra / hexahedra (:mod:`polygen.volume.marching`) produce for a value
``C``. Every vertex lies on a cell edge and is shared by all the triangles
around it, so the surface is watertight except on the volume boundary.

Two constructions are offered here (and every registered method of
:mod:`polygen.volume.methods` by name):

* ``method="scan"``: test every cell (the "all cells" column of the
  thesis's tables), in two parallel passes -- count, then fill -- with the
  vertices merged through their cell-edge ids;
* ``method="propagate"``: breadth-first propagation from seed cells (thesis
  5.4.2, :mod:`polygen.volume.propagate`), with a vertex hash table.

Stage timings follow Table 1 of the 2001 paper: ``t1`` finding the
intersected cells, ``t2`` building the triangle topology (including the
vertex identification), ``t3`` the vertex positions and normals.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from polygen import _jit
from polygen.volume._cells import index_dtype
from polygen.volume import marching as _m
from polygen.volume import registry as _registry
from polygen.volume.propagate import Propagator
from polygen.volume.surface import (
    IsoSurface,
    IsoSurfaceError,
    PairKeyedIsoSurface,
    check_normals,
    check_value,
    finish,
    node_gradients,
    same_surface,
    volume_arrays,
)

__all__ = ["IsoSurface", "extract", "IsoSurfaceError", "same_surface"]

_CHUNK = 8192
_INT32_MAX = np.iinfo(np.int32).max
_NO_CELL_EDGES = np.zeros((0, 6), np.int32)  # the unprepared scan keys by node pairs: no edge table (int32 as a
# volume's cell_edges: one build of _m._scan_fill serves both scans)


def _classify(cells, s, value, cell_type, table, count, local_edges, faces):
    """t1 of both scans: every cell's case, and per chunk of cells the crossed cells and triangle offsets."""
    nch = max(1, -(-cells.shape[0] // _CHUNK))
    cases = _jit.empty(cells.shape[0], np.int32)
    ch_cells = _jit.empty(nch, np.int64)
    ch_tris = _jit.empty(nch, np.int64)
    ch_look = _jit.empty(nch, np.int64)
    _m._scan_count(cells, s, value, faces, table, count, _m.crossed_counts(cell_type), local_edges, _CHUNK,
                   cases, ch_cells, ch_tris, ch_look)
    tri_off = np.zeros(nch + 1, np.int64)
    np.cumsum(ch_tris, out=tri_off[1:])
    return cases, ch_cells, ch_look, tri_off


def _scan(vol, value, field, normals, node_grad=None):
    points, cells, s, cell_type = volume_arrays(vol, field)
    table, count, local_edges, faces = _m.local_tables(cell_type)
    cell_edges = vol.cell_edges
    edges = vol.edges
    n_edges = edges.shape[0]
    if normals == "gradient" and node_grad is None:
        node_grad = node_gradients(vol, s)
    m = cells.shape[0]

    # t1: classify all cells (pass 1 counts per chunk)
    t0 = time.perf_counter()
    cases, ch_cells, ch_look, tri_off = _classify(cells, s, value, cell_type, table, count, local_edges, faces)
    t1 = time.perf_counter() - t0

    # t2: triangles as vertex keys (pass 2), then one vertex per key
    t0 = time.perf_counter()
    n_ic, n_t = int(ch_cells.sum()), int(tri_off[-1])
    tri_keys = _jit.empty((n_t, 3), np.int64)
    tri_cell = _jit.empty(n_t, np.int64)
    _m._scan_fill(cells, s, value, cell_edges, n_edges, points.shape[0], False, table, count, local_edges,
                  _CHUNK, cases, tri_off, tri_keys, tri_cell)
    n_keys = n_edges + points.shape[0]
    tri = _jit.empty((n_t, 3), np.int64)
    if n_t:
        seen = _jit.empty(n_keys, np.uint8)
        seen[:] = 0
        vid = _jit.empty(n_keys, np.int32)
        keys = _jit.empty(min(n_keys, 3 * n_t), np.int64)
        n_v = _m._number_vertices(tri_keys, seen, vid, keys, tri)
        keys = keys[:n_v].copy()
    else:
        keys = np.zeros(0, np.int64)
    t2 = time.perf_counter() - t0

    return finish(value, keys, tri, tri_cell, points=points, edges=edges, s=s, normals=normals,
                  node_grad=node_grad, method="scan", cells_tested=m, cells_intersected=n_ic,
                  vertex_lookups=int(ch_look.sum()), t1=t1, t2=t2)


def _scan_unprepared(vol, value, field, normals, node_grad=None):
    """The full scan with the vertices merged by node pairs: no edge table needed.

    The same two parallel passes as :func:`_scan`; pass 2 keys each corner by
    the sorted node pair of its crossed edge (or its node), and a hash table
    over the crossed edges alone numbers the vertices in order of first use
    -- the full scan's numbering, so vertices, triangles and normals come out
    identical to it, array for array. Output-sensitive: nothing of the
    volume's edge count is allocated or swept.
    """
    points, cells, s, cell_type = volume_arrays(vol, field)
    table, count, local_edges, faces = _m.local_tables(cell_type)
    n_points = points.shape[0]
    if n_points > 3_037_000_499:  # a * N + b must fit int64
        raise IsoSurfaceError(f"the unprepared scan keys node pairs as a * N + b; {n_points} nodes overflow int64")
    if normals == "gradient" and node_grad is None:
        node_grad = node_gradients(vol, s)
    m = cells.shape[0]

    t0 = time.perf_counter()
    cases, ch_cells, ch_look, tri_off = _classify(cells, s, value, cell_type, table, count, local_edges, faces)
    t1 = time.perf_counter() - t0

    t0 = time.perf_counter()
    n_ic, n_t = int(ch_cells.sum()), int(tri_off[-1])
    tri_codes = _jit.empty((n_t, 3), np.int64)
    tri_cell = _jit.empty(n_t, np.int64)
    _m._scan_fill(cells, s, value, _NO_CELL_EDGES, 0, n_points, True, table, count, local_edges, _CHUNK,
                  cases, tri_off, tri_codes, tri_cell)
    tri = _jit.empty((n_t, 3), np.int64)
    v_max = 3 * n_t  # every corner its own vertex: the bound (rows past the count are never touched)
    codes = _jit.empty(v_max, np.int64)
    edges = _jit.empty((v_max, 2), index_dtype(n_points))  # node pairs in the dtype of vol.edges (one build of
    # the kernels that read either)
    keys = _jit.empty(v_max, np.int64)
    # the hash table is sized for at most n_t vertices (a closed surface has about n_t / 2), half full at
    # most; past that the kernel stops and the table is sized for the bound. A table for the bound (12 n_t
    # slots, all written) was most of the memory a first surface touched: 268 of ~560 MB on 10M, 2.0 M
    # triangles, where each fresh page costs a fault.
    n_v = -1
    for n_most in (n_t, v_max):
        bits = max(4, int(2 * n_most).bit_length())
        table_keys = _jit.empty(1 << bits, np.int64)
        table_keys[:] = -1
        table_vals = _jit.empty(1 << bits, np.int32 if v_max < _INT32_MAX else np.int64)
        n_v = _m._number_pair_codes(tri_codes, n_points, 64 - bits, table_keys, table_vals, codes, tri, edges,
                                    keys)
        del table_keys, table_vals
        if n_v >= 0:
            break
    keys = keys[:n_v]
    t2 = time.perf_counter() - t0

    iso = finish(value, keys, tri, tri_cell, points=points, edges=edges, s=s, normals=normals,
                 node_grad=node_grad, method="scan", cells_tested=m, cells_intersected=n_ic,
                 vertex_lookups=int(ch_look.sum()), t1=t1, t2=t2)
    out = PairKeyedIsoSurface(**{f.name: getattr(iso, f.name) for f in dataclasses.fields(iso)
                                 if f.name != "vertex_keys"}, vertex_keys=None)
    object.__setattr__(out, "vertex_pairs", edges[:n_v].copy())
    object.__setattr__(out, "_volume", vol)
    return out


def extract(vol, value, *, field=None, method="scan", normals="mean", seeds=None):
    """The isosurface ``S = value`` of a tetrahedral or hexahedral volume.

    Parameters
    ----------
    vol : UnstructuredVolume
        The volume (its ``edges``, ``cell_edges`` and, for propagation,
        ``face_neighbors`` are used).
    value : float
        The isovalue ``C``. Nodes with ``S >= C`` count as above. A value
        outside the field's range gives an empty surface (with its counters).
    field : str or (N,) float64, optional, keyword-only
        Field name in ``vol.fields`` or node values; the first field by default.
    method : str, keyword-only
        One vocabulary with :meth:`UnstructuredVolume.isosurface` and the
        CLI: a registered method name (:func:`polygen.volume.registry.method_names`;
        ``"scan"``, the default, tests every cell), prepared for this one
        call; or ``"propagate"``, the bare construction of
        :mod:`polygen.volume.propagate` from the ``seeds`` given here
        (thesis 5.4.2).
    normals : {"mean", "gradient", None}, keyword-only
        Mean of the adjacent triangle normals, area-weighted (the thesis's
        choice, 5.3.1); or the node gradients (volume-weighted mean of the
        cell gradients, recomputed per call here, cached by
        :class:`~polygen.volume.propagate.Propagator`) interpolated along the
        edge; or none.
    seeds : (K,) int64, optional, keyword-only
        Seed cells for ``method="propagate"`` (required there); seeds that
        the surface does not cross are tested and skipped.

    Returns
    -------
    IsoSurface
    """
    value = check_value(value)
    check_normals(normals)
    if method == "scan":
        if seeds is not None:
            raise IsoSurfaceError("seeds are only used with method='propagate'")
        return _scan(vol, value, field, normals)
    if method == "propagate":
        if seeds is None:
            raise IsoSurfaceError("method='propagate' needs seeds (cells to start from)")
        return Propagator(vol, field).extract(value, seeds, normals=normals)
    if isinstance(method, str) and method in _registry.METHODS:
        if seeds is not None:
            raise IsoSurfaceError(f"seeds are only used with method='propagate'; {method!r} finds its own")
        return _registry.get_method(method)(vol, field).extract(value, normals=normals)
    raise IsoSurfaceError(f"method must be 'propagate' or a registered method {list(_registry.METHODS)}; "
                          f"got {method!r}")
