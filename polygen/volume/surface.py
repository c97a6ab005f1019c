"""The isosurface result and the input validation shared by every construction.

:class:`IsoSurface` is what every extractor returns (the full scan of
:mod:`polygen.volume.isosurface`, the propagation of
:mod:`polygen.volume.propagate`, the edge-centred construction of
:mod:`polygen.volume.edge_centred`); :func:`finish` is their common stage 3
(vertex positions and normals). The ``check_*`` and :func:`volume_arrays`
functions are the one validation layer of the constructions and methods:
sibling modules import them under these public names.
"""

from __future__ import annotations

import dataclasses
import functools
import time
import weakref

import numpy as np
from polygen import _jit
from polygen.volume import io as _io
from polygen.volume import marching as _m
from polygen.volume.errors import IsoSurfaceError

__all__ = [
    "IsoSurface",
    "IsoSurfaceError",
    "PairKeyedIsoSurface",
    "NORMALS",
    "check_value",
    "check_normals",
    "volume_arrays",
    "node_gradients",
    "finish",
    "vertex_normals",
    "drop_double_faces",
    "same_surface",
    "isovalues",
    "component_table",
]

#: the ``normals`` choices of every extractor
NORMALS = ("mean", "gradient", None)


@dataclasses.dataclass(frozen=True, eq=False)
class IsoSurface:
    """One isosurface: triangles, their shared vertices, counters and timings.

    Attributes
    ----------
    value : float
        The isovalue ``C``.
    vertices : (V, 3) float64
        Crossing points (5.2) on the cell edges.
    triangles : (T, 3) int64
        Vertex ids; the right-hand normal points towards increasing scalar.
    normals : (V, 3) float64 or None
        Unit vertex normals (area-weighted mean of the adjacent triangle
        normals, or the interpolated gradient), ``None`` when not asked for.
    vertex_keys : (V,) int64
        What each vertex is: an edge id of the volume (``key < n_edges``),
        or ``n_edges + node`` when the value hits a node exactly.
    triangle_cells : (T,) int64
        The cell each triangle was made in.
    cells_tested, cells_intersected : int
        Cells whose intersection was tested / that the surface crosses.
    vertex_lookups : int
        Times a vertex was looked up by its key (one per intersected cell and
        crossed edge used by its triangles).
    t1, t2, t3 : float
        Seconds: find intersected cells / build the triangle topology /
        vertex positions and normals (2001 paper, Table 1).
    method : str
        ``"scan"`` or ``"propagate"``.
    """

    value: float
    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray | None
    vertex_keys: np.ndarray
    triangle_cells: np.ndarray
    cells_tested: int
    cells_intersected: int
    vertex_lookups: int
    t1: float
    t2: float
    t3: float
    method: str = "scan"

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def is_empty(self) -> bool:
        return self.n_triangles == 0

    @property
    def time(self) -> float:
        """``t1 + t2 + t3``."""
        return self.t1 + self.t2 + self.t3

    def counters(self) -> dict:
        """The counters as a plain dict (for tables and JSON)."""
        return {
            "cells_tested": self.cells_tested,
            "cells_intersected": self.cells_intersected,
            "n_triangles": self.n_triangles,
            "n_vertices": self.n_vertices,
            "vertex_lookups": self.vertex_lookups,
            "t1": self.t1,
            "t2": self.t2,
            "t3": self.t3,
        }

    def triangle_areas(self) -> np.ndarray:
        """(T,) float64 area of each triangle."""
        v = self.vertices
        t = self.triangles
        cross = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
        return 0.5 * np.linalg.norm(cross, axis=1)

    def area(self) -> float:
        """Total surface area."""
        return float(self.triangle_areas().sum())

    def connected_components(self):
        """``(labels (T,) int64, n)``: parts of the surface joined through shared vertices.

        Labels are numbered in order of each part's first triangle.
        """
        from scipy.sparse import bmat, coo_matrix
        from scipy.sparse.csgraph import connected_components

        t = self.triangles
        nt, nv = t.shape[0], self.vertices.shape[0]
        if nt == 0:
            return np.zeros(0, np.int64), 0
        tri_of_corner = np.repeat(np.arange(nt), 3)
        incidence = coo_matrix((np.ones(3 * nt, np.int8), (tri_of_corner, t.ravel())), shape=(nt, nv))
        # triangles and vertices as one bipartite graph
        _, labels = connected_components(bmat([[None, incidence], [incidence.T, None]]), directed=False)
        _, first, tri_labels = np.unique(labels[:nt], return_index=True, return_inverse=True)
        order = np.argsort(np.argsort(first))
        return order[tri_labels].astype(np.int64), int(first.shape[0])

    @functools.cached_property
    def _component_table(self):
        # computed once per surface (the dataclass is frozen; cached_property writes the instance
        # dict directly) and handed out as read-only arrays
        table = component_table(self.vertices, self.triangles)
        for a in table.values():
            a.setflags(write=False)
        return table

    def components(self) -> dict:
        """The connected components of the surface, one row per component, largest area first.

        Two triangles are in one component when they share a vertex (vertices
        are merged: each crossed edge is one vertex). Computed on first call
        and kept; the arrays are read-only.

        Returns
        -------
        dict of str to ndarray, each with one row per component (``k`` rows):

        ``"triangles"`` : (k,) int64
            Triangle count.
        ``"area"`` : (k,) float64
            Surface area; rows are sorted by it, descending (ties: the
            component whose first triangle comes first).
        ``"volume"`` : (k,) float64
            For a closed component, the volume it encloses by the divergence
            theorem, ``sum(v0 . (v1 x v2)) / 6`` over its triangles. It is
            signed: the right-hand normal of our triangles points towards
            increasing scalar, so the volume is positive when the enclosed
            region holds the lower values (around a minimum, e.g. the sphere
            ``|x| = r``) and negative when it holds the higher values (around
            a maximum). NaN for a component that is not closed.
        ``"bounds"`` : (k, 6) float64
            ``xmin, xmax, ymin, ymax, zmin, zmax`` of its vertices.
        ``"closed"`` : (k,) bool
            Every edge of the component is shared by exactly two of its
            triangles.
        ``"touches_boundary"`` : (k,) bool
            The component has an open edge (an edge of one triangle only): it
            ends on the boundary of the volume.

        See Also
        --------
        triangle_components : the component of each triangle, numbered as these rows.
        """
        return {k: v for k, v in self._component_table.items() if k != "component"}

    def triangle_components(self) -> np.ndarray:
        """(T,) int64 (read-only): the row of :meth:`components` each triangle belongs to."""
        return self._component_table["component"]

    def to_pyvista(self):
        """A ``pyvista.PolyData`` with the normals as point data ``"Normals"``."""
        import pyvista as pv

        if self.is_empty:
            return pv.PolyData()
        poly = pv.PolyData.from_regular_faces(self.vertices, self.triangles)
        if self.normals is not None:
            poly.point_data["Normals"] = self.normals
            poly.point_data.active_normals_name = "Normals"
        return poly

    def save(self, path, *, binary=True):
        """Write the surface to ``path``: ``.vtp``, ``.vtk``, ``.ply``, ``.obj`` or ``.stl``.

        Vertex normals are written where the format has them (all but STL,
        whose facet normals follow the triangles' right-hand order, towards
        increasing scalar). See :func:`polygen.volume.io.write_surface`.

        Parameters
        ----------
        path : str or os.PathLike
            The format is chosen by the extension.
        binary : bool, keyword-only
            Binary VTK/PLY/STL (PLY and STL hold float32 coordinates, and PLY
            float32 normals, either way).

        Returns
        -------
        pathlib.Path

        Raises
        ------
        IsoSurfaceError
            An unknown extension, or an empty surface for PLY/OBJ/STL.
        """
        return _io.write_surface(path, self.vertices, self.triangles, self.normals, binary=binary)

    def __repr__(self):
        return (
            f"IsoSurface(value={self.value:g}, {self.n_triangles} triangles, {self.n_vertices} vertices, "
            f"{self.cells_intersected}/{self.cells_tested} cells intersected/tested, method={self.method!r})"
        )


class _EdgeKeys:
    """``vertex_keys`` of a :class:`PairKeyedIsoSurface`: edge ids, computed on first access."""

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        keys = obj.__dict__.get("_vertex_keys")
        if keys is None:
            keys = obj._edge_keys()
            obj.__dict__["_vertex_keys"] = keys
        return keys

    def __set__(self, obj, value):
        obj.__dict__["_vertex_keys"] = value


class PairKeyedIsoSurface(IsoSurface):
    """An :class:`IsoSurface` made without the volume's edge table (the unprepared scan).

    Its vertices are identified by the node pairs of their edges
    (:attr:`vertex_pairs`); :attr:`vertex_keys`, the edge ids of the
    volume, are looked up on first access (which builds the volume's edge
    table, :attr:`UnstructuredVolume.edges`, if nothing has yet). Everything
    else -- vertices, triangles, normals, counters -- is there at once.
    """

    vertex_keys = _EdgeKeys()

    def _edge_keys(self):
        pairs, vol = self.vertex_pairs, self._volume
        n = vol.n_points
        edges = vol.edges  # (E, 2), a < b, numbered by a then b: sorted codes
        on_node = pairs[:, 0] == pairs[:, 1]
        keys = _jit.scratch(pairs.shape[0], np.int64)
        keys[on_node] = edges.shape[0] + pairs[on_node, 0]
        codes = pairs[~on_node, 0].astype(np.int64) * n + pairs[~on_node, 1]  # int32 ids: a * N in int64
        edge_codes = edges[:, 0].astype(np.int64) * n + edges[:, 1]
        idx = np.searchsorted(edge_codes, codes)
        if codes.size and not np.array_equal(edge_codes[np.minimum(idx, edge_codes.size - 1)], codes):
            raise IsoSurfaceError("a vertex's node pair is not an edge of the volume")  # never: the tests check
        keys[~on_node] = idx
        keys.setflags(write=False)
        return keys


# ------------------------------------------------------------------ helpers

def component_table(vertices, triangles):
    """The connected components of a triangle mesh (triangles sharing a vertex) as a table.

    What :meth:`IsoSurface.components` returns, plus ``"component"``: the
    (T,) int64 row of each triangle. Rows are sorted by area, descending.

    Parameters
    ----------
    vertices : (V, 3) float64
    triangles : (T, 3) int64
        Vertex ids (merged vertices: a shared vertex is one id).

    Returns
    -------
    dict of str to ndarray
        ``component`` (T,) int64, ``triangles`` (k,) int64, ``area`` (k,)
        float64, ``volume`` (k,) float64 (signed, NaN unless closed),
        ``bounds`` (k, 6) float64, ``closed`` (k,) bool,
        ``touches_boundary`` (k,) bool.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    nt, nv = t.shape[0], v.shape[0]
    if nt == 0:
        return {"component": np.zeros(0, np.int64), "triangles": np.zeros(0, np.int64),
                "area": np.zeros(0), "volume": np.zeros(0), "bounds": np.zeros((0, 6)),
                "closed": np.zeros(0, bool), "touches_boundary": np.zeros(0, bool)}
    # vertices joined along the triangles' edges: components of that graph are the surface's parts
    e = t[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    n_raw, vlab = connected_components(coo_matrix((np.ones(e.shape[0], np.int8), (e[:, 0], e[:, 1])),
                                                  shape=(nv, nv)), directed=False)
    raw = vlab[t[:, 0]]
    p0, p1, p2 = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    tri_area = 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    area_raw = np.bincount(raw, tri_area, minlength=n_raw)
    first = np.full(n_raw, nt, np.int64)
    np.minimum.at(first, raw, np.arange(nt))
    present = first < nt  # vertex-graph components without triangles (unused vertices) are dropped
    ids = np.flatnonzero(present)
    ids = ids[np.lexsort((first[ids], -area_raw[ids]))]
    k = ids.shape[0]
    rank = np.full(n_raw, -1, np.int64)
    rank[ids] = np.arange(k)
    comp = rank[raw]
    area = area_raw[ids]
    count = np.bincount(comp, minlength=k).astype(np.int64)
    # edges: shared by exactly two triangles everywhere = closed; by one = an open edge
    es = np.sort(e, axis=1)
    _, inv, uses = np.unique(es[:, 0] * nv + es[:, 1], return_inverse=True, return_counts=True)
    uses = uses[inv.ravel()]
    ecomp = np.repeat(comp, 3)
    touches = np.bincount(ecomp, weights=uses == 1, minlength=k) > 0
    closed = np.bincount(ecomp, weights=uses != 2, minlength=k) == 0
    # bounds over the vertices of each component
    vcomp = rank[vlab]
    used = vcomp >= 0
    order = np.argsort(vcomp[used], kind="stable")
    pts = v[used][order]
    starts = np.searchsorted(vcomp[used][order], np.arange(k))
    lo, hi = np.minimum.reduceat(pts, starts, axis=0), np.maximum.reduceat(pts, starts, axis=0)
    bounds = np.stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1], lo[:, 2], hi[:, 2]], axis=1)
    # divergence theorem about each component's centre (translation-invariant when closed; less cancellation)
    c = (0.5 * (lo + hi))[comp]
    six = np.einsum("ij,ij->i", p0 - c, np.cross(p1 - c, p2 - c))
    volume = np.bincount(comp, six, minlength=k) / 6.0
    volume[~closed] = np.nan
    return {"component": comp, "triangles": count, "area": area, "volume": volume, "bounds": bounds,
            "closed": closed, "touches_boundary": touches}


#: the node-value copies :func:`volume_arrays` made and that are alive, by id
_VALUE_COPIES = weakref.WeakValueDictionary()


def volume_arrays(vol, field):
    """(points, cells, s, cell_type) of ``vol``, the scalars from ``field``."""
    try:
        cell_type = vol.cell_type
        points, cells = vol.points, vol.cells
    except AttributeError:
        raise IsoSurfaceError(f"expected an UnstructuredVolume; got {type(vol).__name__}") from None
    if isinstance(field, str) or field is None:
        s = vol.scalars(field)
    elif any(field is f for f in (getattr(vol, "fields", None) or {}).values()):
        s = field  # the volume's own field: read-only float64, checked when it was added
    else:
        # node values given as an array: a read-only copy, so that a method never keeps the caller's array
        # (written later, it would leave the preparation stale) and the kernels see one array type (numba
        # builds each once, not again for a writable field: a second build of the edge-centred table's flood
        # is ~9 s). A copy made here (a method keeps one and hands it on to its parts) is checked, not copied
        # again; any other array is copied, read-only or not.
        s = field if _VALUE_COPIES.get(id(field)) is field else None
        if s is None:
            s = np.array(field, dtype=np.float64, order="C")
            s.setflags(write=False)
            _VALUE_COPIES[id(s)] = s
        if s.shape != (vol.n_points,):
            raise IsoSurfaceError(f"field values must have shape ({vol.n_points},); got {s.shape}")
        if not np.all(np.isfinite(s)):
            raise IsoSurfaceError("field values must be finite")
        if s.size:  # the bound UnstructuredVolume.add_field puts on a named field
            with np.errstate(over="ignore"):
                span = float(s.max()) - float(s.min())
                reach = 2.0 * span * float(np.abs(points).max())
            if not (np.isfinite(span) and np.isfinite(reach)):
                raise IsoSurfaceError(f"field values span {s.min():.6g} .. {s.max():.6g}: their range (times the "
                                      "coordinates, in the crossing points (5.2)) overflows float64; rescale them")
    return points, cells, s, cell_type


def check_value(value):
    """``value`` as a finite float, else :class:`IsoSurfaceError`; a string or a bool is no number here."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise IsoSurfaceError(f"value must be a number; got {type(value).__name__} {value!r}")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise IsoSurfaceError(f"value must be a number; got {value!r}") from None
    if not np.isfinite(value):
        raise IsoSurfaceError(f"value must be finite; got {value}")
    return value


def check_values(values):
    """``values`` (a sequence of numbers, as ``extract_many`` takes) as a list of floats, else
    :class:`IsoSurfaceError` (a single number is refused with a pointer to ``extract``)."""
    if isinstance(values, (str, bytes)) or np.ndim(values) == 0:
        raise IsoSurfaceError(f"values must be a sequence of numbers; got {type(values).__name__} {values!r} "
                              "(extract(value) gives one surface)")
    if np.ndim(values) != 1:
        raise IsoSurfaceError(f"values must be a flat sequence of numbers; got shape {np.shape(values)}")
    return [check_value(v) for v in values]


def machine_cores():
    """The cores this process may run on (``os.sched_getaffinity``, else ``os.cpu_count()``)."""
    import os

    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def check_threads(threads, *, auto=False):
    """``threads`` as an int >= 1 (``None``: numba's thread count; with ``auto``, ``"auto"`` as it is), else
    :class:`IsoSurfaceError`: the one rule of every method's ``threads``."""
    if threads is None:
        import numba

        return numba.get_num_threads()
    if auto and isinstance(threads, str) and threads == "auto":
        return "auto"
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) or threads < 1:
        also = ", 'auto'" if auto else ""
        raise IsoSurfaceError(f"threads must be a whole number >= 1{also} (or None: numba's thread count); "
                              f"got {threads!r}")
    return int(threads)


def check_normals(normals):
    if normals not in NORMALS:
        raise IsoSurfaceError(f"normals must be one of {NORMALS}; got {normals!r}")


def node_gradients(vol, field=None):
    """(N, 3) float64 node gradients: volume-weighted mean of the cell gradients."""
    points, cells, s, _ = volume_arrays(vol, field)
    out = _jit.scratch((points.shape[0], 3))
    _m._node_gradients(points, cells, s, _m._HEX_DN, out)
    return out


def finish(value, keys, tri, tri_cell, *, points, edges, s, normals, node_grad, method,
           cells_tested, cells_intersected, vertex_lookups, t1, t2, t0_t3=None):
    """Stage 3 (positions and normals) and the result object. Shared by the extractors."""
    t0 = time.perf_counter()
    tri, tri_cell = drop_double_faces(keys, tri, tri_cell, edges.shape[0])
    t2 += time.perf_counter() - t0
    t0 = time.perf_counter()
    vertices = _jit.scratch((keys.shape[0], 3))
    if keys.shape[0]:
        _m._vertex_positions(keys, edges, points, s, value, vertices)
    nrm = vertex_normals(normals, vertices, tri, keys, edges=edges, s=s, value=value, node_grad=node_grad,
                         points=points)
    t3 = time.perf_counter() - t0
    return IsoSurface(
        value=value, vertices=vertices, triangles=tri, normals=nrm, vertex_keys=keys,
        triangle_cells=tri_cell, cells_tested=int(cells_tested), cells_intersected=int(cells_intersected),
        vertex_lookups=int(vertex_lookups), t1=t1, t2=t2, t3=t3, method=method,
    )


def vertex_normals(normals, vertices, tri, keys, *, edges, s, value, node_grad, points=None, mean_kernel=None,
                   mean_sums=None, mean_done=None):
    """The normals half of stage 3, shared by every construction.

    Parameters
    ----------
    normals : {"mean", "gradient", None}
        Area-weighted mean of the adjacent triangle normals (5.3.1), the node
        gradients interpolated along each vertex's edge, or none.
    vertices : (V, 3) float64
    tri : (T, 3) int64
    keys : (V,) int64
        Vertex keys (edge ids, or ``n_edges + node``).
    edges : (E, 2) int64
    s : (N,) float64
    value : float
    node_grad : (N, 3) float64 or None
        Needed for ``"gradient"`` only.
    points : (N, 3) float64, optional
        Node positions: a vertex whose normal comes out zero gets the
        direction of its edge towards increasing scalar instead.
    mean_kernel : callable, optional
        ``(vertices, tri, out)`` filling ``out`` with the ``"mean"`` normals
        in place of the serial kernel (a parallel one for large surfaces).
    mean_sums : (>= V, 3) float64, optional
        The ``"mean"`` normals' sums, already accumulated (by a construction
        that added each triangle's normal as it wrote the triangle, in
        ``marching._mean_normals``'s order): only normalised here, into a new
        array.
    mean_done : ((V, 3) float64, int), optional
        The ``"mean"`` normals already summed and normalised (as
        :func:`polygen.volume.marching.normalised` does: a zero row left
        zero) and how many rows :func:`polygen.volume.marching.zero_rows`
        would list: used as they are (only zero rows are fixed, see Notes).

    Returns
    -------
    (V, 3) float64 or None

    Notes
    -----
    A value a hair above a minimum (or below a maximum) makes a surface so
    small around the node that its vertices round onto the node: every
    triangle there has zero area, and so has their mean normal. The edge
    the vertex lies on, oriented towards increasing scalar, is then the
    limit of the normal (the surface around a node shrinks to a point whose
    outward directions are its edges).
    """
    if normals is None:
        return None
    if normals == "mean" and mean_done is not None:
        nrm, n_zero = mean_done
    else:
        nrm = _jit.output_empty(vertices.shape, vertices.dtype)
        n_zero = -1  # not counted
    if vertices.shape[0]:
        if normals == "mean" and mean_done is not None:
            pass
        elif normals == "mean" and mean_sums is not None:
            n_zero = _m.normalised(mean_sums, nrm)
        elif normals == "mean":
            (_m._mean_normals if mean_kernel is None else mean_kernel)(vertices, tri, nrm)
        else:
            _m._gradient_normals(keys, edges, s, value, node_grad, nrm)
        if points is not None and n_zero != 0:
            zero = _m.zero_rows(nrm)
            on_edge = zero[keys[zero] < edges.shape[0]]
            if on_edge.size:
                e = edges[keys[on_edge]]
                d = (points[e[:, 1]] - points[e[:, 0]]) * np.sign(s[e[:, 1]] - s[e[:, 0]])[:, None]
                nrm[on_edge] = d / np.linalg.norm(d, axis=1)[:, None]
    return nrm


def drop_double_faces(keys, tri, tri_cell, n_edges):
    """Keep one copy of a triangle made by both cells around a face lying exactly at ``C``.

    Only a triangle whose three vertices are nodes (``S == C``) can be made
    twice: two cells share a face at ``C`` and have their other nodes below.
    The set ``S == C`` holds that face once, so we keep the copy from the
    lower cell id (VTK keeps both).
    """
    if not keys.size or keys.max() < n_edges:
        return tri, tri_cell
    all_nodes = np.flatnonzero(np.all(keys[tri] >= n_edges, axis=1))
    if all_nodes.size < 2:
        return tri, tri_cell
    all_nodes = all_nodes[np.argsort(tri_cell[all_nodes], kind="stable")]
    _, first = np.unique(np.sort(keys[tri[all_nodes]], axis=1), axis=0, return_index=True)
    if first.size == all_nodes.size:
        return tri, tri_cell
    keep = np.ones(tri.shape[0], bool)
    keep[all_nodes] = False
    keep[all_nodes[first]] = True
    return tri[keep], tri_cell[keep]


def drop_unreferenced(tri, n_vertices):
    """``(tri, keep)``: triangles renumbered onto the vertices they use, and those vertices' old ids.

    A polygon that collapses onto nodes at ``C`` registers vertices that no
    kept triangle uses (they are how propagation reaches the node's other
    cells); the surface holds only the vertices its triangles use, as the
    full scan's does. ``keep`` is ``None`` when every vertex is used.
    """
    used = np.zeros(n_vertices, bool)
    used[tri.ravel()] = True
    if used.all():
        return tri, None
    keep = np.flatnonzero(used)
    new = np.full(n_vertices, -1, tri.dtype)
    new[keep] = np.arange(keep.size, dtype=tri.dtype)
    return new[tri], keep


def same_surface(a, b, *, geometry=True, normals_atol=1e-12):
    """Whether two isosurfaces are the same surface, whatever order their triangles came in.

    The same triangles as sets of vertex keys (cell edges, or nodes for
    crossings exactly on a node), each vertex key once; with ``geometry``
    also the same vertex positions (bit for bit) and normals (within
    ``normals_atol``). Methods that differ only in the order they visit the
    cells (scan, propagation, edge-centred construction) must agree.
    """
    if a.n_triangles != b.n_triangles or a.n_vertices != b.n_vertices:
        return False
    ta = np.unique(np.sort(a.vertex_keys[a.triangles], axis=1), axis=0)
    tb = np.unique(np.sort(b.vertex_keys[b.triangles], axis=1), axis=0)
    if not np.array_equal(ta, tb):
        return False
    if not geometry:
        return True
    oa, ob = np.argsort(a.vertex_keys), np.argsort(b.vertex_keys)
    if not (np.array_equal(a.vertex_keys[oa], b.vertex_keys[ob]) and np.array_equal(a.vertices[oa], b.vertices[ob])):
        return False
    if (a.normals is None) != (b.normals is None):
        return False
    return a.normals is None or bool(np.allclose(a.normals[oa], b.normals[ob], atol=normals_atol, rtol=0))


def isovalues(field, n):
    """``n`` isovalues evenly inside the range of ``field``, its ends excluded.

    ``linspace(min, max, n + 2)[1:-1]``: the twenty values of the thesis's
    tables for ``n = 20``.

    Parameters
    ----------
    field : (N,) array_like of float
        Node values (only their minimum and maximum are used).
    n : int
        How many values (at least 1).

    Returns
    -------
    (n,) float64
    """
    s = np.asarray(field, dtype=np.float64)
    if s.size == 0 or not np.all(np.isfinite(s)):
        raise IsoSurfaceError("isovalues needs a non-empty field of finite values")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise IsoSurfaceError(f"isovalues needs a positive integer count; got {n!r}")
    return np.linspace(s.min(), s.max(), int(n) + 2)[1:-1]
