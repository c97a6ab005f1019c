"""The unstructured volume of thesis chapter 5.2 (Defs 5.1-5.10).

A volume is made only of tetrahedra or only of hexahedra (Def. 5.4), in
VTK node order, with one or more scalar fields on its nodes (Def. 5.2).
Everything derived from the cells -- face neighbours (Def. 5.1), boundary
faces (Def. 5.3), connected boundary-face groups with their Euler number
and genus (Defs 5.6-5.8, 7.7), node and edge incidence -- is computed once,
lazily, by the numba kernels of :mod:`polygen.volume._topology`.
"""

from __future__ import annotations

import collections.abc
import functools
import threading
import warnings

import numpy as np
from polygen import _jit
from polygen._jit import parallel_kernels_may_overlap
from polygen.volume import _topology as _k
from polygen.volume import io as _io
from polygen.volume import registry as _registry
from polygen.volume._cells import HEX_CORNER_FRAMES, HEX_EDGES, HEX_FACES, TET_EDGES, TET_FACES, index_dtype
from polygen.volume.errors import VolumeError, VolumeWarning

__all__ = ["UnstructuredVolume", "VolumeError", "VolumeWarning", "TET_FACES", "HEX_FACES", "TET_EDGES", "HEX_EDGES"]

_CELL_TYPES = {4: "tetra", 8: "hexa"}
# relative tolerance on |6V| / longest_edge**3 below which a cell is degenerate
_DEGENERATE_RTOL = 1e-10
_INT32_MAX = np.iinfo(np.int32).max



class _Fields(collections.abc.MutableMapping):
    """The node fields of a volume: a mapping name -> read-only (N,) float64 array.

    Assigning a name (``vol.fields["f"] = values``) is :meth:`UnstructuredVolume.add_field`:
    the values are checked and copied, and the methods prepared on that name are
    dropped. The arrays themselves are read-only, so ``vol.fields["f"][:] = new``
    raises ``ValueError`` instead of leaving prepared structures stale.
    """

    def __init__(self, owner):
        self._owner = owner
        self._data = {}

    def __getitem__(self, name):
        return self._data[name]

    def __setitem__(self, name, values):
        self._owner.add_field(name, values)

    def __delitem__(self, name):
        with self._owner._iso_lock:  # the field and what was prepared on it go together
            del self._data[name]
            self._owner._forget_field(name)

    def __iter__(self):
        return iter(self._data)

    def __len__(self):
        return len(self._data)

    def __repr__(self):
        return f"fields({', '.join(f'{k!r}: ({v.shape[0]},)' for k, v in self._data.items())})"


#: the values of :attr:`UnstructuredVolume.preparation` (see :meth:`UnstructuredVolume.isosurface`)
PREPARATION_POLICIES = ("background", "now", "never")


@functools.cache
def _local_incidence(cell_type, what):
    """:func:`polygen.volume._topology.local_incidence` of a cell type's faces or edges."""
    local = {"faces": TET_FACES if cell_type == "tetra" else HEX_FACES,
             "edges": TET_EDGES if cell_type == "tetra" else HEX_EDGES}[what]
    return _k.local_incidence(local, 4 if cell_type == "tetra" else 8)


def _nbytes(obj):
    """Bytes of the numpy arrays in ``obj`` (an array or a tuple of them)."""
    if isinstance(obj, np.ndarray):
        return int(obj.nbytes)
    if isinstance(obj, (tuple, list)):
        return sum(_nbytes(o) for o in obj)
    return 0


def _owned(a, dtype):
    """A C-contiguous ``dtype`` array with the values of ``a`` that shares no memory with it.

    A fresh buffer from :func:`polygen._jit.astype`, without numpy's huge-page advice (see
    ``polygen._jit.HUGE_ADVICE_BYTES``): measured in this project's VM, the first write of 1 GiB took
    1.5-10 s with the advice, 0.6-0.9 s without, and an 80M-cell volume's copy is 1.3 GB.
    """
    return _jit.astype(a, dtype)


def _not_a_path(obj, where, what):
    import os

    if isinstance(obj, (str, bytes, os.PathLike)):
        raise VolumeError(f"{where} takes {what}; got the path {str(obj)!r}: UnstructuredVolume.read(path) reads a "
                          "file")


def _examples(idx, n=5):
    idx = np.asarray(idx).ravel()
    head = ", ".join(str(int(i)) for i in idx[:n])
    return f"[{head}{', ...' if idx.size > n else ''}]"


class UnstructuredVolume:
    """A tetrahedral-only or hexahedral-only volume with node scalars.

    The volume never keeps or writes the caller's arrays: ``points``,
    ``cells`` and every field are copied (converted to float64 / int32 --
    int64 past 2**31 nodes -- / float64), and the copies are read-only
    (``vol.points``, ``vol.cells``), so neither a later change to the caller's arrays nor an assignment into
    ``vol.points`` can bypass the checks below or leave the topology and the
    prepared methods stale. ``orient=True`` reorders the nodes of the copy.

    A volume pickles and deep-copies (for Dask and multiprocessing) with its
    fields, the tables built so far and its prepared methods; locks and
    background preparations are not carried (the copy makes fresh locks and
    prepares again, when asked, what was still being prepared).

    Parameters
    ----------
    points : (N, 3) float64
        Node coordinates.
    cells : (M, 4) or (M, 8) integer
        Node ids of each cell in VTK order (``VTK_TETRA`` or ``VTK_HEXAHEDRON``); kept as int32
        (``vol.cells``), int64 for more than 2**31 nodes.
    fields : dict of str -> (N,) float64, optional
        Scalar fields on the nodes. The first one is the default. They are
        copied and kept read-only (:meth:`add_field`); ``vol.fields`` is a
        mapping whose assignment is :meth:`add_field`.
    validate : bool, keyword-only
        Check cell geometry (zero-volume and inverted cells). Shapes, index
        ranges and finiteness are always checked.
    orient : bool, keyword-only
        Reorder the nodes of inverted cells instead of raising.

    Raises
    ------
    VolumeError
        On wrong shapes, indices out of range, non-finite coordinates or
        scalars, scalars whose range overflows float64, degenerate (zero-volume) or inverted cells, duplicate
        cells (two cells with the same nodes: always checked), faces shared by more than two cells (when
        the face neighbours are first built).
    """

    def __init__(self, points, cells, fields=None, *, validate=True, orient=False):
        if fields is not None and not isinstance(fields, collections.abc.Mapping):
            hint = " (name it: fields={'f': values})" if isinstance(fields, np.ndarray) else ""
            raise VolumeError(f"fields must be a dict of name -> (N,) values; got {type(fields).__name__}{hint}")
        points = np.asarray(points)
        cells = np.asarray(cells)
        if points.ndim != 2 or points.shape[1] != 3:
            raise VolumeError(f"points must have shape (N, 3); got {points.shape}")
        if not np.issubdtype(points.dtype, np.number) or np.issubdtype(points.dtype, np.complexfloating):
            raise VolumeError(f"points must be real numbers; got dtype {points.dtype}")
        if cells.ndim != 2 or cells.shape[1] not in _CELL_TYPES:
            raise VolumeError(
                f"cells must have shape (M, 4) for tetrahedra or (M, 8) for hexahedra; got {cells.shape}"
                " (a volume mixes no cell types: Def. 5.4)"
            )
        if cells.shape[0] == 0:
            raise VolumeError("cells is empty: a volume needs at least one cell")
        if not np.issubdtype(cells.dtype, np.integer):
            if np.issubdtype(cells.dtype, np.floating) and np.all(np.isfinite(cells)) and np.all(cells == np.round(cells)):
                cells = cells.astype(np.int64)
            else:
                raise VolumeError(f"cells must hold integer node ids; got dtype {cells.dtype}")
        # the volume's own copies: the caller's arrays are never written (orient=True reorders our copy) and
        # a later change to them cannot reach the checks or anything prepared from these
        self.points = _owned(points, np.float64)
        n = self.points.shape[0]
        index = index_dtype(n)
        if cells.dtype not in (np.int32, np.int64) or not cells.flags.c_contiguous:
            # another integer type or layout: a numpy copy first (the pass below reads int32 or int64 rows, one
            # compiled kernel each); ids outside 0..n-1 are named from the caller's values, before a narrowing
            # copy could wrap them into range
            if not np.can_cast(cells.dtype, index) and (int(cells.min()) < 0 or int(cells.max()) >= n):
                self.cells = cells  # read only by the check, which raises
                self._check_cells(n)
            cells = _owned(cells, index)
        lo, hi = np.zeros(3), np.zeros(3)
        finite = bool(_k.points_range(self.points, lo, hi))  # the row-wise check below only when it fails
        bad_pts = np.flatnonzero(~np.all(np.isfinite(self.points), axis=1)) if not finite else np.zeros(0, np.int64)
        if bad_pts.size:
            raise VolumeError(f"{bad_pts.size} points have NaN or infinite coordinates, e.g. points {_examples(bad_pts)}")
        if not n:
            lo, hi = np.zeros(3), np.zeros(3)
        with np.errstate(over="ignore"):
            extent = hi - lo
        # max |x| over the coordinates, for add_field's overflow check (the same value as np.abs(points).max())
        self._coord_abs_max = float(np.maximum(np.abs(lo), np.abs(hi)).max())
        if not np.all(np.isfinite(extent)):
            raise VolumeError(f"the points span {extent.tolist()}: max - min of a coordinate overflows float64; "
                              "rescale the coordinates")
        # one parallel pass over the caller's rows: the volume's own copy (int32 node ids whenever every valid id
        # fits: 16 bytes per tetrahedron instead of 32), the ids, and for tetrahedra the geometry: it decides
        # when every cell is clearly valid (the usual case); otherwise the exact checks below find the bad cells
        # and name them. It also counts the cells by smallest node for the duplicate check
        used = _jit.empty(n, np.uint8)  # 1 for the nodes of the cells the pass found clearly valid
        used[:] = 0
        fast_geometry = cells.shape[1] == 4 and validate and not orient
        self.cells, bad, counted = _k.own_cells(self.points, cells, index, fast_geometry, _DEGENERATE_RTOL, used)
        clear = bad == 0
        if not clear:
            copy, self.cells = self.cells, cells  # the caller's values: a wrapped id is named as the caller gave it
            self._check_cells(n)
            self.cells = copy
        self._check_duplicates(counted)
        self.cell_type = _CELL_TYPES[self.cells.shape[1]]
        self.fields = _Fields(self)
        self._iso_methods = {}  # (field, method) -> a prepared IsosurfaceMethod, for isosurface()
        self._iso_lock = threading.RLock()  # guards _iso_methods (isosurface() from several threads)
        self._table_lock = threading.Lock()  # one build of the edge table when threads ask at once
        self._iso_pending = {}  # (field, method) -> the thread preparing it in the background
        #: (field, method) -> the exception a background preparation raised (isosurface() then scans)
        self.preparation_errors = {}
        #: what :meth:`isosurface` does about the default method's preparation: one of
        #: :data:`PREPARATION_POLICIES` (``"background"``, ``"now"``, ``"never"``)
        self.preparation = "background"
        for name, values in (fields or {}).items():
            self.add_field(name, values)
        if (validate or orient) and not (fast_geometry and clear):
            self._check_geometry(orient)
        self.points.setflags(write=False)
        self.cells.setflags(write=False)
        if not clear:  # a cell the pass could not call valid passed the exact checks: count its nodes too
            used = np.bincount(self.cells.ravel(), minlength=n)
        self.unreferenced_nodes = np.flatnonzero(np.equal(used, 0, out=_jit.empty(n, bool)))
        if self.unreferenced_nodes.size:
            warnings.warn(
                f"{self.unreferenced_nodes.size} of {n} nodes are used by no cell, e.g. nodes "
                f"{_examples(self.unreferenced_nodes)}; they keep their ids and every isosurface method ignores them "
                "(remove_unreferenced_nodes() gives a copy without them)",
                VolumeWarning,
                stacklevel=2,
            )

    def _check_cells(self, n):
        """Node ids in range and distinct in every cell, or a VolumeError naming the bad cells."""
        out_of_range = np.flatnonzero(np.any((self.cells < 0) | (self.cells >= n), axis=1))
        if out_of_range.size:
            c = out_of_range[0]
            raise VolumeError(
                f"{out_of_range.size} cells reference node ids outside 0..{n - 1}, e.g. cells "
                f"{_examples(out_of_range)} (cell {c} has nodes {self.cells[c].tolist()})"
            )
        repeated = np.flatnonzero(np.any(np.diff(np.sort(self.cells, axis=1), axis=1) == 0, axis=1))
        if repeated.size:
            raise VolumeError(
                f"{repeated.size} degenerate cells repeat a node, e.g. cells {_examples(repeated)} "
                f"(cell {repeated[0]} has nodes {self.cells[repeated[0]].tolist()})"
            )

    def __getstate__(self):
        # pickling and deepcopy (Dask, multiprocessing): locks and background threads do not travel; the
        # copy makes fresh locks, and prepares again what was still being prepared here when it is asked
        with self._iso_lock:
            state = self.__dict__.copy()
            state["_iso_methods"] = dict(self._iso_methods)
        del state["_iso_lock"], state["_table_lock"]
        state["_iso_pending"] = {}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._iso_lock = threading.RLock()
        self._table_lock = threading.Lock()
        # an unpickled or deep-copied array is writable again: the volume's own arrays stay read-only
        for a in (self.points, self.cells, *self.fields._data.values()):
            a.setflags(write=False)

    def _check_duplicates(self, counted=None):
        """No two cells with the same nodes (in any order), or a VolumeError naming them.

        Two copies of a cell share each of its faces, so an inner face of it
        has three or more cells; even on the boundary every surface through
        it comes out twice. Always checked (cells grouped by smallest node), so
        that every method and the unprepared scan refuse such a volume alike.
        """
        count, pairs = _k.find_duplicate_cells(self.cells, n_nodes=self.n_points, counted=counted)
        if count:
            a, b = (int(x) for x in pairs[0])
            raise VolumeError(
                f"{count} cells repeat the nodes of an earlier cell (duplicate cells), e.g. cells "
                f"{_examples(pairs[:, 1])}: cell {b} has the nodes of cell {a} {sorted(self.cells[a].tolist())}; "
                "a volume's face belongs to at most two cells"
            )

    # ------------------------------------------------------------------ basics
    @property
    def n_points(self) -> int:
        return self.points.shape[0]

    @property
    def n_cells(self) -> int:
        return self.cells.shape[0]

    @property
    def local_faces(self) -> np.ndarray:
        """``TET_FACES`` or ``HEX_FACES``."""
        return TET_FACES if self.cell_type == "tetra" else HEX_FACES

    @property
    def local_edges(self) -> np.ndarray:
        """``TET_EDGES`` or ``HEX_EDGES``."""
        return TET_EDGES if self.cell_type == "tetra" else HEX_EDGES

    def __repr__(self):
        names = ", ".join(self.fields) or "no fields"
        return f"UnstructuredVolume({self.n_cells} {self.cell_type} cells, {self.n_points} nodes; {names})"

    def add_field(self, name, values):
        """Attach a node scalar field (also ``vol.fields[name] = values``).

        The values are copied into a read-only float64 array, so neither the
        caller's array nor ``vol.fields[name][:] = ...`` can change them behind
        the methods prepared on them; replacing a field by name drops the
        methods prepared on it (:meth:`isosurface` prepares them again).

        Raises
        ------
        VolumeError
            On a wrong length, a non-real dtype, NaN or infinite values, or
            values so large that the isosurface arithmetic overflows float64:
            the kernels form differences of node values (``max - min`` must
            be finite) and the crossing points of (5.2) multiply such a
            difference by a coordinate, so ``2 * (max - min) * max|x|`` must
            be finite too.
        """
        name = str(name)
        values = np.asarray(values)
        if values.ndim != 1 or values.shape[0] != self.n_points:
            raise VolumeError(f"field {name!r} must have shape ({self.n_points},); got {values.shape}")
        if not np.issubdtype(values.dtype, np.number) or np.issubdtype(values.dtype, np.complexfloating):
            raise VolumeError(f"field {name!r} must be real numbers; got dtype {values.dtype}")
        values = _owned(values, np.float64)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise VolumeError(f"field {name!r} has {bad.size} NaN or infinite values, e.g. at nodes {_examples(bad)}")
        if values.size:
            lo, hi = float(values.min()), float(values.max())
            with np.errstate(over="ignore"):
                span = hi - lo
                reach = 2.0 * span * self._coord_abs_max
            if not np.isfinite(span):
                raise VolumeError(f"field {name!r} spans {lo:.6g} .. {hi:.6g}: max - min overflows float64; "
                                  "rescale the field")
            if not np.isfinite(reach):
                raise VolumeError(f"field {name!r} spans {lo:.6g} .. {hi:.6g}: its range times the coordinates "
                                  "overflows float64 in the crossing points (5.2); rescale the field")
        values.setflags(write=False)
        with self._iso_lock:  # the new values and the end of what was prepared on the old ones, together
            self.fields._data[name] = values
            self._forget_field(name)

    def _forget_field(self, name):
        """Drop the methods :meth:`isosurface` prepared on field ``name`` (it changed or went)."""
        with self._iso_lock:
            self._iso_methods = {k: m for k, m in self._iso_methods.items() if k[0] != name}
            self.preparation_errors = {k: e for k, e in self.preparation_errors.items() if k[0] != name}

    def scalars(self, name=None) -> np.ndarray:
        """The node values of field ``name`` (the first field by default)."""
        if not self.fields:
            raise VolumeError("this volume has no scalar field; add one with add_field(name, values)")
        if name is None:
            return next(iter(self.fields.values()))
        try:
            return self.fields[name]
        except KeyError:
            raise VolumeError(f"no field {name!r}; the fields are {list(self.fields)}") from None

    def _check_geometry(self, orient):
        if self.cell_type == "tetra":
            vol6, longest = _k.tet_volumes6(self.points, self.cells)
            scale = longest**3
            degenerate = np.flatnonzero(np.abs(vol6) <= _DEGENERATE_RTOL * scale)
            inverted = np.flatnonzero(vol6 < -_DEGENERATE_RTOL * scale)
        else:
            jac, vol, longest = _k.hex_jacobians(self.points, self.cells, HEX_CORNER_FRAMES)
            scale = longest**3
            degenerate = np.flatnonzero(np.abs(vol) <= _DEGENERATE_RTOL * scale)
            inverted = np.flatnonzero(vol < -_DEGENERATE_RTOL * scale)
        if degenerate.size:
            self._voxel_order(degenerate)
            raise VolumeError(
                f"{degenerate.size} degenerate cells have zero volume, e.g. cells {_examples(degenerate)}"
            )
        if inverted.size and orient:
            if self.cell_type == "tetra":
                self.cells[inverted[:, None], [1, 2]] = self.cells[inverted[:, None], [2, 1]]
            else:
                self.cells[inverted] = self.cells[inverted][:, [4, 5, 6, 7, 0, 1, 2, 3]]
                jac, _, longest = _k.hex_jacobians(self.points, self.cells, HEX_CORNER_FRAMES)
            inverted = inverted[:0]
        if inverted.size:
            raise VolumeError(
                f"{inverted.size} of {self.n_cells} cells are inverted (negative volume in VTK node order), "
                f"e.g. cells {_examples(inverted)}; pass orient=True to reorder their nodes"
            )
        if self.cell_type == "hexa":
            folded = np.flatnonzero(np.any(jac <= _DEGENERATE_RTOL * (longest**3)[:, None], axis=1))
            if folded.size:
                self._voxel_order(folded)
                raise VolumeError(
                    f"{folded.size} hexahedra are folded or degenerate at a corner (Jacobian <= 0), "
                    f"e.g. cells {_examples(folded)}"
                )

    def _voxel_order(self, bad):
        """A VolumeError saying so when the hexahedra ``bad`` are valid in VTK_VOXEL node order.

        A voxel numbers its corners 0-1-3-2 / 4-5-7-6 (x fastest, then y):
        read as a VTK hexahedron its faces twist, with zero volume.
        """
        if self.cell_type != "hexa":
            return
        order = [0, 1, 3, 2, 4, 5, 7, 6]
        cells = np.ascontiguousarray(self.cells[bad][:, order])
        jac, vol, longest = _k.hex_jacobians(self.points, cells, HEX_CORNER_FRAMES)
        scale = longest**3
        if np.all(vol > _DEGENERATE_RTOL * scale) and np.all(jac > _DEGENERATE_RTOL * scale[:, None]):
            raise VolumeError(
                f"{bad.size} hexahedra are in voxel node order (VTK_VOXEL: corners 0-1-3-2 / 4-5-7-6), e.g. cells "
                f"{_examples(bad)}, not the hexahedron order a volume takes (VTK_HEXAHEDRON: 0-1-2-3 around the "
                "bottom face, 4-5-6-7 above); reorder them with cells[:, [0, 1, 3, 2, 4, 5, 7, 6]]"
            )

    def remove_unreferenced_nodes(self) -> "UnstructuredVolume":
        """A copy without the nodes no cell uses."""
        keep = np.ones(self.n_points, bool)
        keep[self.unreferenced_nodes] = False
        new_id = np.cumsum(keep) - 1
        fields = {k: v[keep] for k, v in self.fields.items()}
        return UnstructuredVolume(self.points[keep], new_id[self.cells], fields, validate=False)

    def reordered(self, *, return_permutations=False):
        """A copy with nodes and cells renumbered along a Morton (Z-order) curve.

        Neighbouring cells and nodes get nearby numbers, so walks through the
        mesh (propagation, thinning) and scans read memory nearly in order.
        Meshers often number cells in an order far from spatial (gmsh's
        parallel HXT: face neighbours are typically hundreds of thousands of
        cell ids apart); renumbering such a mesh roughly halves isosurface
        times, for VTK as well as for polygen. Geometry and fields are
        unchanged; only the numbering moves.

        Parameters
        ----------
        return_permutations : bool, keyword-only
            Also return ``(node_order, cell_order)``: new node ``i`` is old
            node ``node_order[i]``, new cell ``j`` is old cell ``cell_order[j]``.
        """
        lo = self.points.min(axis=0)
        span = float((self.points.max(axis=0) - lo).max())
        scale = (2**21 - 1) / span if span > 0 else 0.0
        node_order = np.argsort(_k.morton_codes(self.points, lo, scale), kind="stable")
        new_id = _jit.scratch(self.n_points, index_dtype(self.n_points))  # the copy below is in the index dtype
        new_id[node_order] = np.arange(self.n_points)
        centroids = _k.cell_centroids(self.points, self.cells)
        cell_order = np.argsort(_k.morton_codes(centroids, lo, scale), kind="stable")
        out = UnstructuredVolume(
            self.points[node_order],
            new_id[self.cells[cell_order]],
            {k: v[node_order] for k, v in self.fields.items()},
            validate=False,
        )
        return (out, node_order, cell_order) if return_permutations else out

    # ------------------------------------------------------------ isosurface
    def isosurface(self, value, *, field=None, method=None, normals="mean", prepare=None):
        """The isosurface ``S = value``: at once on a fresh volume, by the fastest method once it is ready.

        **Policy** (``method=None``, the usual call). The default method
        (:data:`~polygen.volume.registry.DEFAULT_METHOD`, the active-cell
        scan of :mod:`polygen.volume.active_scan`) needs a preparation -- the
        edge table, the cells sorted in span-space order: about 0.3 s per
        million cells on two cores -- that a single surface does not repay.
        So the first surface never waits for it:

        * ``prepare=None`` (default) follows :attr:`preparation`, the
          volume's setting, ``"background"`` unless changed: until the
          default method is prepared on the field, the answer comes from
          the ``"unprepared-scan"`` (every cell tested in parallel, vertices
          merged by the node pairs of the crossed edges; no topology needed,
          the same triangles as every other method) while the first call
          starts the preparation in a background thread (its numba kernels
          release the GIL). Later calls use the prepared method as soon as
          it is there. With ``preparation = "now"`` the first call prepares
          and then answers (the behaviour before the active-cell scan); with
          ``"never"`` every call scans.
        * ``prepare=True``: prepare now (or wait for the background
          preparation already running) and answer with the prepared method.
        * ``prepare=False``: answer with the unprepared scan and start nothing.

        With ``method`` named, that method is prepared on first use, before
        answering (``prepare`` does not apply), and kept.

        Replacing the field (``vol.fields[name] = new``) drops what was
        prepared on it (a background preparation of the old values is
        discarded when it ends). A query answers for the field as it was
        when the query began, even if another thread replaces it meanwhile
        (never with an error about the replacement). Safe from several threads: each preparation
        happens once, and a prepared method's lock lets one extraction run at
        a time (:class:`~polygen.volume.methods.IsosurfaceMethod`). Whichever
        path answers, the triangles, vertices and normals are the same; the
        ``vertex_keys`` of an unprepared answer (a
        :class:`~polygen.volume.surface.PairKeyedIsoSurface`) are computed
        when first read.

        Parameters
        ----------
        value : float
        field : str, optional, keyword-only
            Field name (the first field by default).
        method : str, optional, keyword-only
            A registered method (:func:`polygen.volume.registry.method_names`);
            by default :data:`~polygen.volume.registry.DEFAULT_METHOD`
            (``"active-scan"``) once prepared, the unprepared scan before.
        normals : {"mean", "gradient", None}, keyword-only
        prepare : bool or None, keyword-only
            Force (True) or skip (False) the preparation of the default method.

        Returns
        -------
        IsoSurface
        """
        self.scalars(field)  # a clear error when the field is missing
        name = field if field is not None else next(iter(self.fields))
        if method is not None:
            return self._as_of(name, method, lambda m: m.extract(value, normals=normals))
        if prepare not in (None, True, False):
            raise VolumeError(f"prepare must be True, False or None; got {prepare!r}")
        policy = self.preparation if prepare is None else ("now" if prepare else "never")
        if policy not in PREPARATION_POLICIES:
            raise VolumeError(f"preparation must be one of {PREPARATION_POLICIES}; got {policy!r}")
        key = (name, _registry.DEFAULT_METHOD)
        with self._iso_lock:
            values = self.fields._data.get(name)
            prepared = self._iso_methods.get(key)
        if prepared is not None:
            with prepared.as_of_field(values) as held:  # serialised per method (IsosurfaceMethod's lock)
                if held is not None:
                    return held.extract(value, normals=normals)
            # the field was replaced since: the query begins again on the new one (below)
        if policy == "now":
            pending = self._iso_pending.get(key)
            if pending is not None:
                pending.join()  # the background preparation is running: wait for it rather than build twice
            return self._as_of(name, _registry.DEFAULT_METHOD, lambda m: m.extract(value, normals=normals))
        iso = self._as_of(name, "unprepared-scan", lambda m: m.extract(value, normals=normals))
        if policy == "background":
            with self._iso_lock:  # started after the answer, so that it does not compete with it for the cores
                self._prepare_in_background(key)
        return iso

    def extract_many(self, values, *, field=None, method=None, normals="mean", threads=None):
        """The isosurfaces of several values, in their order, by one prepared method.

        ``method`` (by default :data:`~polygen.volume.registry.DEFAULT_METHOD`) is prepared on
        first use and kept, as for :meth:`isosurface` with a named method; its ``extract_many``
        answers (the edge-centred method runs up to ``threads`` values at a time; the others take
        ``threads`` and run one value after the other). Every surface is for the field as it was
        when the call began.

        Parameters
        ----------
        values : sequence of float
        field, method, normals : as for :meth:`isosurface`, keyword-only
        threads : int, optional, keyword-only

        Returns
        -------
        list of IsoSurface
        """
        self.scalars(field)  # a clear error when the field is missing
        name = field if field is not None else next(iter(self.fields))
        method = _registry.DEFAULT_METHOD if method is None else method
        return self._as_of(name, method, lambda m: m.extract_many(values, normals=normals, threads=threads))

    def _as_of(self, name, method, call):
        """``call(m)`` with ``m`` the method ``method`` prepared on field ``name`` as it is now.

        The field and its prepared method are taken together under ``_iso_lock`` (``add_field``
        replaces a field and drops what was prepared on it under the same lock); the call then
        answers for those values even if the field is replaced while it runs.
        """
        for _ in range(3):
            with self._iso_lock:
                values = self.fields._data.get(name)
                if values is None:
                    self.scalars(name)  # removed meanwhile: the missing field's VolumeError
                prepared = self._prepared(name, method)
            with prepared.as_of_field(values) as held:
                if held is not None:
                    return call(held)
        # not reached: under the lock the cached method is always the one prepared on the field's values
        raise RuntimeError(f"no method {method!r} prepared on the current field {name!r}")  # pragma: no cover

    def _prepared(self, name, method):
        """The method ``method`` prepared on field ``name``, prepared now if it is not yet."""
        key = (name, method)
        with self._iso_lock:  # one preparation per (field, method), also when threads ask at once
            prepared = self._iso_methods.get(key)
            if prepared is None:
                # the registry, not the methods: they sit above the mesh and register themselves there
                prepared = self._iso_methods[key] = _registry.get_method(method)(self, field=name)
                if method == _registry.DEFAULT_METHOD:
                    self.release_preparation_tables()
        return prepared

    def _prepare_in_background(self, key):
        """Start preparing ``key = (field, method)`` in a daemon thread (once; call under ``_iso_lock``)."""
        if key in self._iso_methods or key in self._iso_pending or key in self.preparation_errors:
            return
        if not parallel_kernels_may_overlap():  # numba's workqueue layer: prepared at the next query instead
            return
        thread = threading.Thread(target=self._background_preparation, args=(key,), daemon=True,
                                  name=f"polygen-prepare-{key[1]}-{key[0]}")
        self._iso_pending[key] = thread
        thread.start()

    def _background_preparation(self, key):
        name, method = key
        try:
            prepared = _registry.get_method(method)(self, field=name)
        except Exception as e:  # kept for the caller; isosurface() goes on scanning, prepare=True raises it
            with self._iso_lock:
                self.preparation_errors[key] = e
                self._iso_pending.pop(key, None)
            return
        with self._iso_lock:
            # the field may have been replaced meanwhile: then the preparation is stale, drop it
            if self.fields._data.get(name) is prepared._field_values and key not in self._iso_methods:
                self._iso_methods[key] = prepared
            self._iso_pending.pop(key, None)
            if method == _registry.DEFAULT_METHOD:
                self.release_preparation_tables()

    def wait_prepared(self, timeout=None):
        """Wait for the background preparations started by :meth:`isosurface`; True when none is left."""
        with self._iso_lock:
            threads = list(self._iso_pending.values())
        for thread in threads:
            thread.join(timeout)
        with self._iso_lock:
            return not self._iso_pending

    def memory_bytes(self):
        """Bytes of the derived tables this volume holds (topology, incidence), by name.

        Only what is held now is counted (the tables are built lazily, and
        the preparation of the default method drops those only it reads:
        :meth:`release_preparation_tables`): ``face_neighbors`` (int32, 16
        bytes per tetrahedron), the edge table (``edges`` int32 like
        the cells, and ``cell_edges`` int32), ``cell_records``, ``edge_cells``,
        ``node_cells`` (int32 cells), ``cell_components``, the boundary
        tables and the locator. The points, cells and fields themselves are
        not counted.
        """
        out = {}
        for attr in ("face_neighbors", "boundary_faces", "_edge_table", "cell_records",
                     "edge_cells", "node_cells", "cell_components", "_locator", "boundary_edge_table"):
            obj = self.__dict__.get(attr)
            if obj is not None:
                out[attr] = _nbytes(obj)
        return out

    # ------------------------------------------------------------- adjacency
    def _incidence(self):
        """The node -> cells lists: the cached :attr:`node_cells`, else a temporary copy not kept.

        Face neighbours and edges are matched in the bucket of their smallest
        node, found among the cells around that node. Who asks for only one
        of them (a scan's edge ids, say) does not keep the lists; the
        preparation (:meth:`build_topology`) builds them once for all.
        """
        nc = self.__dict__.get("node_cells")
        return nc if nc is not None else _k.node_cells_csr(self.cells, self.n_points)

    def build_topology(self):
        """Build the tables the prepared isosurface methods start from, sharing the work between them.

        ``node_cells`` first (the others are matched through it), then
        ``face_neighbors``, the edge table and ``cell_components``. Each is
        also built on its own when first read; this only avoids building the
        node -> cells lists more than once.
        """
        self.node_cells
        self.face_neighbors
        self._edge_table
        self.cell_components

    def release_preparation_tables(self):
        """Drop the tables only a preparation reads: ``node_cells``, ``cell_components``, ``face_neighbors``,
        ``cell_edges`` and ``boundary_edge_table`` (about 63 bytes per tetrahedron on 2M).

        The prepared default method keeps what it needs in its own table
        and reads only :attr:`edges` from the volume afterwards, so
        :meth:`isosurface` calls this once it has prepared it (``edges``,
        ``boundary_faces`` and the boundary groups computed from the
        boundary edge table stay). A later reader of a dropped table builds
        it again (the same values).
        """
        with self._iso_lock:
            for attr in ("node_cells", "cell_components", "face_neighbors", "boundary_edge_table"):
                self.__dict__.pop(attr, None)
            table = self.__dict__.get("_edge_table")
            if table is not None and table[1] is not None:
                self.__dict__["_edge_table"] = (table[0], None)

    @functools.cached_property
    def face_neighbors(self) -> np.ndarray:
        """(M, F) int32 (int64 past 2**31 cells): the cell across each local face, -1 on the boundary (Def. 5.1).

        Cells are neighbours only when their faces have the same nodes.
        """
        off, nc = self._incidence()
        nf = self.local_faces.shape[0]
        # fresh big arrays from numba's allocator, not numpy's huge-page advice (polygen._jit.empty: on 2M
        # the first touch of the preparation's arrays cost 0.1-0.35 s of system time with the advice)
        out = _jit.empty((self.n_cells, nf), np.int32 if self.n_cells < _INT32_MAX else np.int64)
        out.fill(-1)
        bad = _k.face_neighbors_by_node(self.cells, self.local_faces, *_local_incidence(self.cell_type, "faces"),
                                        off, nc, out)
        if bad >= 0:
            face = self.cells[bad // nf, self.local_faces[bad % nf]]
            around = nc[off[face.min()]:off[face.min() + 1]]
            shared = around[np.isin(self.cells[around], face).sum(axis=1) == face.size]
            raise VolumeError(
                f"a face is shared by {shared.size} cells {_examples(shared)}; "
                "a volume's face belongs to at most two cells"
            )
        return out

    @functools.cached_property
    def boundary_faces(self) -> np.ndarray:
        """(B, 2) int64 rows ``(cell, local face)`` of the faces owned by one cell (Def. 5.3)."""
        c, f = np.nonzero(self.face_neighbors < 0)
        return np.stack([c, f], axis=1).astype(np.int64)

    @functools.cached_property
    def boundary_face_nodes(self) -> np.ndarray:
        """(B, 3|4) node ids of each boundary face, outward oriented (the dtype of :attr:`cells`)."""
        bf = self.boundary_faces
        return self.cells[bf[:, :1], self.local_faces[bf[:, 1]]]

    @functools.cached_property
    def boundary_cells(self) -> np.ndarray:
        """(Kb,) int64 sorted cells that own a boundary face."""
        return np.unique(self.boundary_faces[:, 0])

    @functools.cached_property
    def _edge_table(self):
        # one build when several threads ask at once (the preparation builds it beside the thinning;
        # functools.cached_property has no lock of its own from Python 3.12)
        with self._table_lock:
            table = self.__dict__.get("_edge_table")
            if table is None:
                table = self.__dict__["_edge_table"] = self._build_edge_table()
            return table

    def _build_edge_table(self):
        off, nc = self._incidence()
        ne = self.local_edges.shape[0]
        if self.n_cells >= 1 << 28 or self.n_points >= 1 << 31:  # pragma: no cover - packed keys overflow
            edges = _k.gather_local(self.cells, self.local_edges)
            _k.sort_rows(edges)
            ids, first = _k.match_rows(edges, self.n_points)
            return edges[first], ids.reshape(self.n_cells, -1)
        cell_edges = _jit.empty((self.n_cells, ne), np.int32 if self.n_cells * ne < _INT32_MAX else np.int64)
        edges = _k.edges_by_node(self.cells, self.local_edges, _local_incidence(self.cell_type, "edges")[0], off, nc,
                                 cell_edges)
        return edges, cell_edges

    def _edges_into(self, cell_edges):
        """The edge table's ``edges``, each cell's edge ids written into ``cell_edges`` (M, 6|12), the
        caller's array (the edge-id columns of a preparation's table), instead of one the volume keeps.

        The volume then keeps ``edges`` alone, as after :meth:`release_preparation_tables` (a reader of
        :attr:`cell_edges` builds them again). ``None`` where the volume holds its cell edges already
        (the caller reads them) or its packed keys would overflow.
        """
        with self._table_lock:
            table = self.__dict__.get("_edge_table")
            if (table is not None and table[1] is not None) or self.n_cells >= 1 << 28 or self.n_points >= 1 << 31:
                return None
            off, nc = self._incidence()
            edges = _k.edges_by_node(self.cells, self.local_edges, _local_incidence(self.cell_type, "edges")[0], off,
                                     nc, cell_edges)
            if table is None:
                self.__dict__["_edge_table"] = (edges, None)
            return edges if table is None else table[0]

    @property
    def edges(self) -> np.ndarray:
        """(E, 2) distinct cell edges, ``a < b``, numbered by ``a`` then ``b``; the dtype of :attr:`cells`."""
        return self._edge_table[0]

    @property
    def cell_edges(self) -> np.ndarray:
        """(M, 6|12) int32 (int64 past 2**31 cell edges) id (row of :attr:`edges`) of each local edge of each cell."""
        edges, cell_edges = self._edge_table
        if cell_edges is None:  # dropped after a preparation (release_preparation_tables): build it again
            # under the table's lock, where _edges_into cannot put back a table without cell edges between the
            # check and the build (it did once, under CI's load: a scan got None, in the four-thread stress test)
            with self._table_lock:
                table = self.__dict__.get("_edge_table")
                if table is None or table[1] is None:
                    table = self.__dict__["_edge_table"] = self._build_edge_table()
                cell_edges = table[1]
        return cell_edges

    @functools.cached_property
    def cell_records(self) -> np.ndarray:
        """(M, 16|32) int32 (int64 past 2**31 ids) per cell: nodes, face neighbours, edge ids (-1 padded).

        The layout the propagation reads (:mod:`polygen.volume.propagate`):
        one or two cache lines per cell instead of three arrays.
        """
        return _k.cell_records(self.cells, self.face_neighbors, self.cell_edges)

    @functools.cached_property
    def edge_cells(self):
        """CSR ``(offsets (E+1,), cells)``: the cells around each edge."""
        ce = self.cell_edges
        offsets, order = _k.csr_from_keys(ce.ravel(), self.edges.shape[0])
        return offsets, order // ce.shape[1]

    @functools.cached_property
    def node_cells(self):
        """CSR ``(offsets (N+1,) int64, cells (4M|8M,) int32)``: the cells using each node, ascending.

        int64 cells past 2**31 cells.
        """
        return _k.node_cells_csr(self.cells, self.n_points)

    @functools.cached_property
    def cell_components(self):
        """``(labels (M,) int32, n)``: connected parts of the volume through face neighbours (int64 labels
        past 2**31 cells)."""
        return _k.cell_components(self.face_neighbors, np.int64 if self.n_cells >= _INT32_MAX else np.int32)

    # ------------------------------------------------------- boundary groups
    @functools.cached_property
    def boundary_edge_table(self):
        """``(ids, edges)``: ``ids[f*k + i]`` numbers the edge from corner i to i+1 of boundary face f
        (rows of :attr:`boundary_face_nodes`); ``edges`` (E, 2) are those edges' nodes, ``a < b``."""
        bfn = np.ascontiguousarray(self.boundary_face_nodes, np.int64)
        k = bfn.shape[1]
        loc = np.array([[i, (i + 1) % k] for i in range(k)], np.int64)
        rows = _k.gather_local(bfn, loc)
        _k.sort_rows(rows)
        ids, first = _k.match_rows(rows, self.n_points)
        return ids, rows[first]

    @functools.cached_property
    def _groups(self):
        bfn = self.boundary_face_nodes
        nb, k = bfn.shape
        if nb == 0:  # cannot happen for a finite volume, but keep shapes sane
            z = np.zeros(0, np.int64)
            return z, z, z, np.zeros(0), np.zeros(0, bool)
        edge_ids = self.boundary_edge_table[0]
        owner = np.repeat(np.arange(nb, dtype=np.int64), k)
        labels, n_groups = _k.union_find_rows(edge_ids, nb, owner)
        # Euler number V + F - E of each group (Def. 5.7)
        faces_per = np.bincount(labels, minlength=n_groups)
        # the faces around an edge are joined, so each edge has one group: count it at one of its faces
        # (np.unique of (group, edge) codes gave the same counts at 0.15 s on 2M)
        rep = _jit.scratch(int(edge_ids.max()) + 1, np.int64)
        rep[edge_ids] = owner
        edges_per = np.bincount(labels[rep], minlength=n_groups)
        # distinct (group, node) pairs per group: a node of a manifold boundary has one group, so a
        # node -> group array is checked instead of a np.unique of the pairs (2M: 0.03-0.1 s)
        face_group = np.repeat(labels, k)
        group_of = np.full(self.n_points, -1, np.int64)
        group_of[bfn.ravel()] = face_group
        if np.array_equal(group_of[bfn.ravel()], face_group):
            nodes_per = np.bincount(group_of[group_of >= 0], minlength=n_groups)
        else:  # a node on several groups (cells touching at a node)
            node_group = np.unique(face_group * self.n_points + bfn.ravel()) // self.n_points
            nodes_per = np.bincount(node_group, minlength=n_groups)
        euler = nodes_per + faces_per - edges_per
        # enclosed signed volume: positive for an outer surface, negative around a void
        centre = self.points.mean(axis=0)
        p = self.points[bfn] - centre
        tri = 0.0
        signed = np.zeros(n_groups)
        for i in range(1, k - 1):
            tri = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, i], p[:, i + 1])) / 6.0
            signed += np.bincount(labels, weights=tri, minlength=n_groups)
        is_void = signed < 0
        # number: outer surfaces first (largest first), then voids (largest first)
        order = np.lexsort((-np.abs(signed), is_void))
        rank = _jit.scratch(n_groups, np.int64)
        rank[order] = np.arange(1, n_groups + 1)
        return rank[labels], euler[order], signed[order], is_void[order]

    @property
    def boundary_groups(self) -> np.ndarray:
        """(B,) int64 group of each boundary face: 1 = outer surface, 2.. = voids (Def. 7.7).

        Faces are in one group when they are joined through shared edges. A
        group that encloses negative volume (its outward faces point into
        an empty region) is a void (Def. 5.6). With several disjoint parts
        every outer surface is numbered before the voids.
        """
        return self._groups[0]

    @property
    def n_boundary_groups(self) -> int:
        return self._groups[1].shape[0]

    @property
    def group_euler(self) -> np.ndarray:
        """(G,) Euler number V + F - E of each boundary group (Def. 5.7); index g-1 for group g."""
        return self._groups[1]

    @property
    def group_genus(self) -> np.ndarray:
        """(G,) genus G = 1 - E/2 of each boundary group (Def. 5.8)."""
        return 1 - self._groups[1] // 2

    @property
    def group_signed_volume(self) -> np.ndarray:
        """(G,) volume enclosed by each group, negative for voids."""
        return self._groups[2]

    @property
    def group_is_void(self) -> np.ndarray:
        """(G,) bool: the group bounds a void (Def. 5.6)."""
        return self._groups[3]

    @property
    def n_voids(self) -> int:
        return int(self._groups[3].sum())

    @property
    def n_through_holes(self) -> int:
        """Number of through-holes: the sum of the groups' genera (Def. 5.8)."""
        return int(self.group_genus.sum())

    # ------------------------------------------------------- interpolation
    @functools.cached_property
    def _locator(self):
        lo = self.points.min(axis=0)
        hi = self.points.max(axis=0)
        extent = np.maximum(hi - lo, 1e-300)
        # about one cell per bin on average, bins as cubic as the box allows
        h = (np.prod(extent) / self.n_cells) ** (1.0 / 3.0)
        dims = np.clip(np.ceil(extent / h), 1, 1024).astype(np.int64)
        inv_h = dims / extent
        counts, items = _k.build_bins(self.points, self.cells, lo, inv_h, dims)
        return counts, items, lo, inv_h, dims

    def locate(self, xyz) -> np.ndarray:
        """(K,) int64 a cell containing each point of ``xyz (K, 3)``, -1 outside."""
        return self._interpolate(xyz, _jit.read_only(np.zeros(self.n_points)))[1]  # read-only as a field is

    def interpolate(self, xyz, field=None) -> np.ndarray:
        """(K,) float64 the field at points ``xyz (K, 3)`` by Def. 5.5, NaN outside.

        Inside a tetrahedron the interpolation is linear (barycentric); inside
        a hexahedron it is trilinear in the cell's parametric coordinates,
        the isoparametric interpolation of an 8-node FEM element.
        """
        return self._interpolate(xyz, self.scalars(field))[0]

    def _interpolate(self, xyz, values):
        xyz = np.ascontiguousarray(np.atleast_2d(np.asarray(xyz, dtype=np.float64)))
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise VolumeError(f"query points must have shape (K, 3); got {xyz.shape}")
        counts, items, lo, inv_h, dims = self._locator
        return _k.locate_and_interpolate(self.points, self.cells, values, counts, items, lo, inv_h, dims, xyz)

    # ---------------------------------------------------------- conversion
    def to_pyvista(self):
        """A ``pyvista.UnstructuredGrid`` with the fields as point data."""
        import pyvista as pv

        ctype = pv.CellType.TETRA if self.cell_type == "tetra" else pv.CellType.HEXAHEDRON
        grid = pv.UnstructuredGrid({ctype: self.cells}, self.points)
        for name, values in self.fields.items():
            grid.point_data[name] = values
        return grid

    @classmethod
    def from_pyvista(cls, grid, *, validate=True, orient=False, cell_data=None, tetrahedralize=False):
        """From a pyvista/VTK data set (or ``MultiBlock``) of tetrahedra, hexahedra or voxels only.

        Single-component point arrays become fields; others are skipped.
        ``cell_data`` and ``tetrahedralize`` as for :meth:`read`.
        """
        _not_a_path(grid, "from_pyvista", "a pyvista data set")
        return cls._from_arrays(_io.pyvista_arrays(grid, cell_data=cell_data, tetrahedralize=tetrahedralize),
                                validate=validate, orient=orient)

    def to_meshio(self):
        """A ``meshio.Mesh`` with one cell block and the fields as point data."""
        import meshio

        block = "tetra" if self.cell_type == "tetra" else "hexahedron"
        return meshio.Mesh(self.points, [(block, self.cells)], point_data=dict(self.fields))

    @classmethod
    def from_meshio(cls, mesh, *, validate=True, orient=False, cell_data=None, tetrahedralize=False):
        """From a ``meshio.Mesh``.

        Cell blocks of dimension 0-2 (vertices, lines, triangles, quads: the
        boundary and physical-group elements that meshers write beside the
        volume cells) are ignored; the 3D blocks must all be ``tetra`` or all
        ``hexahedron`` (or ``tetrahedralize``). ``cell_data`` and
        ``tetrahedralize`` as for :meth:`read`.
        """
        _not_a_path(mesh, "from_meshio", "a meshio.Mesh")
        if not (hasattr(mesh, "points") and hasattr(mesh, "cells") and hasattr(mesh, "point_data")):
            raise VolumeError(f"from_meshio takes a meshio.Mesh; got {type(mesh).__name__}")
        return cls._from_arrays(_io.meshio_arrays(mesh, cell_data=cell_data, tetrahedralize=tetrahedralize),
                                validate=validate, orient=orient)

    @classmethod
    def _from_arrays(cls, arrays, *, validate, orient):
        vol = cls(arrays.points, arrays.cells, arrays.fields, validate=validate, orient=orient)
        # what was not kept: a caller asking for one of these is told it is cell data
        vol.cell_data_names = arrays.cell_data_names
        vol.cell_data_converted = arrays.converted
        #: point arrays that are no scalar field (vectors, tensors, text): name -> what they are
        vol.dropped_point_data = dict(arrays.dropped)
        # floating-point vectors and tensors are said; integer ones are tags (gmsh:dim_tags), text is no field
        vectors = [(name, what) for name, what in arrays.dropped if what.endswith("components")]
        if vectors:
            said = ", ".join(f"{name!r} ({what})" for name, what in vectors)
            first = vectors[0][0]
            warnings.warn(f"point arrays {said} are not scalar and were not kept as fields (a field is one value "
                          f"per node); take a component, e.g. vol.add_field('{first}_x', mesh.point_data['{first}']"
                          "[:, 0])", VolumeWarning, stacklevel=3)
        return vol

    @classmethod
    def read(cls, path, *, validate=True, orient=False, cell_data=None, tetrahedralize=False):
        """Read a volume from any file meshio reads (VTU, MSH, XDMF, ...), or else pyvista reads.

        meshio is tried first; whatever it cannot read (any failure, including
        the ``SystemExit`` meshio raises on a corrupt file, a legacy VTK file
        it misparses, or Exodus without ``netCDF4``) is handed to pyvista.
        Neither reader prints anything. The formats and conversions live in
        :mod:`polygen.volume.io`.

        Parameters
        ----------
        path : str or os.PathLike
            The mesh file.
        validate, orient : bool, keyword-only
            As for the constructor.
        cell_data : {None, 'average'}, keyword-only
            ``None``: cell arrays are not read (their names are kept).
            ``'average'``: each floating-point cell array becomes a node
            field of the same name (``"NAME (cell average)"`` when a node
            field has that name): the volume-weighted average of the cells
            around each node (:func:`polygen.volume.io.cell_to_node`).
            Integer cell arrays (ids, material tags) are never converted.
        tetrahedralize : bool, keyword-only
            Split the 3D cells into tetrahedra (VTK's ordered triangulation,
            conforming across shared faces) -- for meshes of wedges,
            pyramids, quadratic or mixed cells, which are refused otherwise.

        Returns
        -------
        UnstructuredVolume
            Its fields are the file's one-component node arrays (then the
            converted cell arrays); ``cell_data_names`` (tuple of str) names
            the file's cell arrays and ``cell_data_converted`` those that
            became fields.

        Raises
        ------
        VolumeError
            Naming the file: it is missing, a directory, unreadable by both
            readers (with each reader's reason), or holds no valid volume.
        """
        arrays = _io.read_arrays(path, cell_data=cell_data, tetrahedralize=tetrahedralize)
        try:
            return cls._from_arrays(arrays, validate=validate, orient=orient)
        except VolumeError as e:
            raise VolumeError(f"{str(path)!r}: {e}") from e
