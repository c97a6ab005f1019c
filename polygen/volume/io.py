"""Reading volumes and writing isosurfaces: every file format goes through here.

Reading (:func:`read_arrays`, behind :meth:`UnstructuredVolume.read
<polygen.volume.mesh.UnstructuredVolume.read>`): meshio first, then pyvista
(VTK's readers) for whatever meshio cannot read -- VTU, legacy VTK, gmsh MSH
(v2 and v4), XDMF (meshio needs ``h5py`` for it, even for XML data), Exodus II
(meshio needs ``netCDF4``; VTK's reader reads it without), and the rest of
either library's formats. What comes back is plain arrays: one block of
tetrahedra or of hexahedra, the node fields, the names of the cell arrays.

Two conversions on request:

* ``cell_data="average"``: each floating-point cell array becomes a node
  field, the volume-weighted average of the cells around each node
  (:func:`cell_to_node`).
* ``tetrahedralize=True``: a mesh of other or mixed 3D cells (wedges,
  pyramids, hexahedra beside tetrahedra, quadratic cells) is split into
  tetrahedra by VTK's ``vtkDataSetTriangleFilter`` (pyvista's
  ``triangulate()``), which orders each cell's split by global node ids, so
  that two cells sharing a quadrilateral face split it along the same
  diagonal (the result is conforming; a test checks it).

Writing (:func:`write_surface`, behind :meth:`IsoSurface.save
<polygen.volume.surface.IsoSurface.save>`): ``.vtp``, ``.vtk``, ``.ply``,
``.obj``, ``.stl`` through pyvista; vertex normals are kept where the format
has them (all but STL, which stores one normal per facet).

This module sits below the mesh: it imports nothing of ours but the error
classes and the cell tables, and hands arrays up.
"""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np

from polygen.volume._cells import KUHN_TETS
from polygen.volume.errors import IsoSurfaceError, VolumeError

__all__ = [
    "VolumeArrays",
    "CELL_DATA",
    "SURFACE_FORMATS",
    "read_arrays",
    "meshio_arrays",
    "pyvista_arrays",
    "cell_volumes",
    "cell_to_node",
    "write_surface",
]

#: the ``cell_data`` choices of the readers: ``None`` keeps only the names, ``"average"`` converts
CELL_DATA = (None, "average")
#: surface file formats :func:`write_surface` writes, by extension
SURFACE_FORMATS = (".vtp", ".vtk", ".ply", ".obj", ".stl")

_VTK_TETRA, _VTK_VOXEL, _VTK_HEXAHEDRON = 10, 11, 12
# VTK voxel node order -> hexahedron node order
_VOXEL_TO_HEX = np.array([0, 1, 3, 2, 4, 5, 7, 6])
# meshio's cell blocks below three dimensions: boundary and physical-group elements meshers write
_LOWER = {"vertex", "line", "line3", "triangle", "triangle6", "triangle7", "quad", "quad8", "quad9", "polygon"}


@dataclasses.dataclass(frozen=True)
class VolumeArrays:
    """What a reader found: the arguments of :class:`~polygen.volume.mesh.UnstructuredVolume`.

    Attributes
    ----------
    points : (N, 3) float64
    cells : (M, 4) or (M, 8) int64
        Tetrahedra or hexahedra in VTK node order.
    fields : dict of str to (N,) arrays
        Node fields: one-component numeric point arrays, then (with
        ``cell_data="average"``) the converted cell arrays.
    cell_data_names : tuple of str
        Every cell array of the file (converted or not).
    converted : tuple of str
        The fields made from cell arrays (empty unless ``cell_data="average"``).
    """

    points: np.ndarray
    cells: np.ndarray
    fields: dict
    cell_data_names: tuple = ()
    converted: tuple = ()
    #: ``(name, what)`` of the point arrays that are no scalar field (vectors, tensors, text)
    dropped: tuple = ()


def _check_options(cell_data, tetrahedralize):
    if cell_data not in CELL_DATA:
        raise VolumeError(f"cell_data must be one of {CELL_DATA}; got {cell_data!r}")
    if not isinstance(tetrahedralize, (bool, np.bool_)):
        raise VolumeError(f"tetrahedralize must be True or False; got {tetrahedralize!r}")


def _mixed_message(desc, tetrahedralize_hint):
    msg = f"a volume must be only tetrahedra or only hexahedra; this mesh has {desc}"
    if tetrahedralize_hint:
        msg += "; tetrahedralize=True splits its cells into tetrahedra"
    return msg


# ------------------------------------------------------------------ volumes

def cell_volumes(points, cells) -> np.ndarray:
    """Unsigned volume of each tetrahedron or hexahedron.

    Parameters
    ----------
    points : (N, 3) float64
    cells : (M, 4) or (M, 8) int64
        VTK node order. A hexahedron's volume is that of its six Kuhn
        tetrahedra (exact for a parallelepiped).

    Returns
    -------
    (M,) float64
    """
    points = np.asarray(points, dtype=np.float64)
    cells = np.asarray(cells)
    tets = cells if cells.shape[1] == 4 else cells[:, KUHN_TETS].reshape(-1, 4)
    p = points[tets]
    six_v = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    vol = np.abs(six_v) / 6.0
    return vol if cells.shape[1] == 4 else vol.reshape(-1, 6).sum(axis=1)


def cell_to_node(points, cells, values) -> np.ndarray:
    """A cell array as node values: the volume-weighted average of the cells around each node.

    ``node[i] = sum_c V_c x_c / sum_c V_c`` over the cells ``c`` holding node
    ``i``; a node in no cell (or only in cells of zero volume) gets the plain
    mean of its cells, or 0 when it has none (such nodes are ignored by every
    isosurface method).

    Parameters
    ----------
    points : (N, 3) float64
    cells : (M, 4) or (M, 8) int64
    values : (M,) float
        One value per cell.

    Returns
    -------
    (N,) float64
    """
    cells = np.asarray(cells)
    values = np.asarray(values, dtype=np.float64)
    if values.shape != (cells.shape[0],):
        raise VolumeError(f"cell values must have shape ({cells.shape[0]},); got {values.shape}")
    n, k = len(points), cells.shape[1]
    w = cell_volumes(points, cells)
    idx = cells.ravel()
    num = np.bincount(idx, weights=np.repeat(w * values, k), minlength=n)
    den = np.bincount(idx, weights=np.repeat(w, k), minlength=n)
    # a node whose cells all have zero volume: the plain mean of its cells
    cnt = np.bincount(idx, minlength=n).astype(np.float64)
    plain = np.bincount(idx, weights=np.repeat(values, k), minlength=n)
    out = np.zeros(n)
    ok = den > 0
    out[ok] = num[ok] / den[ok]
    flat = ~ok & (cnt > 0)
    out[flat] = plain[flat] / cnt[flat]
    return out


def _finish(points, cells, point_data, cell_data, cell_data_mode):
    """Fields from the one-component numeric point arrays, then the converted cell arrays."""
    points = np.asarray(points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:  # a planar file: z = 0 (then refused as flat cells)
        points = np.column_stack([points, np.zeros(len(points))])
    fields = {}
    dropped = []
    for name, arr in point_data.items():
        arr = np.asarray(arr)
        if arr.ndim == 2 and arr.shape[1] == 1:
            arr = arr[:, 0]
        if arr.ndim == 1 and np.issubdtype(arr.dtype, np.number) and not np.issubdtype(arr.dtype, np.complexfloating):
            fields[str(name)] = arr
        elif arr.ndim == 2 and np.issubdtype(arr.dtype, np.floating):
            dropped.append((str(name), f"{arr.shape[1]} components"))
        else:
            dropped.append((str(name), f"shape {arr.shape[1:]}, dtype {arr.dtype}"))
    converted = []
    if cell_data_mode == "average":
        for name, arr in cell_data.items():
            arr = np.asarray(arr)
            if arr.ndim == 2 and arr.shape[1] == 1:
                arr = arr[:, 0]
            # integer cell arrays are ids and material tags: an average of them means nothing
            if arr.ndim != 1 or not np.issubdtype(arr.dtype, np.floating) or arr.shape[0] != len(cells):
                continue
            key = str(name) if str(name) not in fields else f"{name} (cell average)"
            fields[key] = cell_to_node(points, cells, arr)
            converted.append(key)
    return VolumeArrays(points, np.asarray(cells, dtype=np.int64), fields,
                        tuple(str(k) for k in cell_data), tuple(converted), tuple(dropped))


def pyvista_arrays(grid, *, cell_data=None, tetrahedralize=False) -> VolumeArrays:
    """The arrays of a pyvista/VTK data set (a ``MultiBlock``, as Exodus files give, is combined).

    Parameters
    ----------
    grid : pyvista.DataSet or pyvista.MultiBlock
    cell_data : {None, 'average'}, keyword-only
        ``'average'`` converts the floating-point cell arrays to node fields
        (:func:`cell_to_node`).
    tetrahedralize : bool, keyword-only
        Split the 3D cells into tetrahedra (``triangulate()``) when they are
        not all tetrahedra or all hexahedra; always, for hexahedra too, when
        True. Cells of fewer dimensions are dropped first.

    Raises
    ------
    VolumeError
        No cells, or cells that are not all tetrahedra or all hexahedra
        (saying that ``tetrahedralize=True`` splits them, when it would).
    """
    import pyvista as pv

    _check_options(cell_data, tetrahedralize)
    if isinstance(grid, pv.MultiBlock):
        grid = grid.combine(merge_points=True) if grid.n_blocks else pv.UnstructuredGrid()
    if not isinstance(grid, pv.UnstructuredGrid):
        if not hasattr(grid, "cast_to_unstructured_grid"):
            raise VolumeError(f"cannot read a volume from {type(grid).__name__}")
        grid = grid.cast_to_unstructured_grid()
    types = np.asarray(grid.celltypes)
    if types.size == 0:
        raise VolumeError("the grid has no cells")
    three_d = np.array([pv.CellType(t).name.lower() not in _PV_LOWER for t in types])
    if tetrahedralize and three_d.any():
        grid = _tetrahedralized(grid.extract_cells(np.flatnonzero(three_d)) if not three_d.all() else grid)
        types = np.asarray(grid.celltypes)
    kinds, counts = np.unique(types, return_counts=True)
    if kinds.size != 1 or kinds[0] not in (_VTK_TETRA, _VTK_HEXAHEDRON, _VTK_VOXEL):
        desc = ", ".join(f"{c} {pv.CellType(t).name.lower()}" for t, c in zip(kinds, counts))
        raise VolumeError(_mixed_message(desc, three_d.any()))
    k = 4 if kinds[0] == _VTK_TETRA else 8
    cells = np.asarray(grid.cell_connectivity).reshape(-1, k)
    if kinds[0] == _VTK_VOXEL:
        cells = cells[:, _VOXEL_TO_HEX]
    return _finish(grid.points, cells, grid.point_data, grid.cell_data, cell_data)


_PV_LOWER = {"empty_cell", "vertex", "poly_vertex", "line", "poly_line", "triangle", "triangle_strip", "polygon",
             "pixel", "quad", "quadratic_edge", "quadratic_triangle", "quadratic_quad", "biquadratic_quad",
             "quadratic_polygon", "cubic_line", "biquadratic_triangle", "quadratic_linear_quad",
             "lagrange_curve", "lagrange_triangle", "lagrange_quadrilateral"}


def _tetrahedralized(grid):
    """Tetrahedra only: VTK's ordered triangulation of every cell (conforming across shared faces)."""
    import pyvista as pv

    out = grid.triangulate()
    keep = np.flatnonzero(np.asarray(out.celltypes) == _VTK_TETRA)
    if keep.size != out.n_cells:
        out = out.extract_cells(keep)
    if not isinstance(out, pv.UnstructuredGrid):
        out = out.cast_to_unstructured_grid()
    for name in ("vtkOriginalCellIds", "vtkOriginalPointIds"):  # extract_cells' bookkeeping, not the file's
        if name in out.cell_data and name not in grid.cell_data:
            del out.cell_data[name]
        if name in out.point_data and name not in grid.point_data:
            del out.point_data[name]
    return out


# meshio numbers a linear wedge as gmsh does (triangle 0-1-2 turned towards 3-4-5), VTK the other way
# round; meshio's own VTK reader and writer swap them, pyvista.from_meshio does not
_MESHIO_TO_VTK_ORDER = {"wedge": np.array([0, 2, 1, 3, 5, 4])}


def _vtk_order(cell_type, data):
    order = _MESHIO_TO_VTK_ORDER.get(cell_type)
    return data if order is None else data[:, order]


def meshio_arrays(mesh, *, cell_data=None, tetrahedralize=False) -> VolumeArrays:
    """The arrays of a ``meshio.Mesh``.

    Cell blocks of dimension 0-2 (vertices, lines, triangles, quads: the
    boundary and physical-group elements that meshers write beside the
    volume cells) are ignored; the 3D blocks must all be ``tetra`` or all
    ``hexahedron``, unless ``tetrahedralize`` (then the mesh goes through
    :func:`pyvista_arrays`). ``cell_data`` as there.
    """
    _check_options(cell_data, tetrahedralize)
    volume_blocks = {"tetra": [], "hexahedron": []}
    other_3d = {}
    keep = []  # indices of the 3D blocks, for their cell data
    for i, block in enumerate(mesh.cells):
        if block.type in volume_blocks:
            volume_blocks[block.type].append(np.asarray(block.data))
            keep.append(i)
        elif block.type not in _LOWER:
            other_3d[block.type] = other_3d.get(block.type, 0) + len(block.data)
            keep.append(i)
    present = {t: sum(len(b) for b in bs) for t, bs in volume_blocks.items() if bs}
    present.update(other_3d)
    if tetrahedralize and present and (other_3d or "hexahedron" in present):
        import pyvista as pv

        blocks = [(mesh.cells[i].type, _vtk_order(mesh.cells[i].type, np.asarray(mesh.cells[i].data))) for i in keep]
        sub = type(mesh)(mesh.points, blocks, point_data=mesh.point_data,
                         cell_data={k: [v[i] for i in keep] for k, v in mesh.cell_data.items()})
        return pyvista_arrays(pv.from_meshio(sub), cell_data=cell_data, tetrahedralize=True)
    if len(present) != 1 or other_3d:
        desc = ", ".join(f"{n} {t}" for t, n in present.items()) or "no 3D cells"
        raise VolumeError(_mixed_message(desc, bool(present)))
    ctype = next(iter(present))
    cells = np.concatenate(volume_blocks[ctype])
    cdata = {}
    for name, per_block in mesh.cell_data.items():
        parts = [np.asarray(per_block[i]) for i in keep]
        if all(p.ndim == parts[0].ndim for p in parts):
            cdata[name] = np.concatenate(parts)
    points = mesh.points if mesh.points.shape[1] != 3 else np.asarray(mesh.points, dtype=np.float64)
    return _finish(points, cells, mesh.point_data, cdata, cell_data)


def read_arrays(path, *, cell_data=None, tetrahedralize=False) -> VolumeArrays:
    """Read a volume mesh file with meshio, or else pyvista; ``VolumeError`` naming the file otherwise.

    meshio is tried first; whatever it cannot read (any failure, including
    the ``SystemExit`` meshio raises on a corrupt file, a legacy VTK file it
    misparses, or a format whose optional library is missing) is handed to
    pyvista. Neither reader prints anything.

    Parameters
    ----------
    path : str or os.PathLike
    cell_data, tetrahedralize : keyword-only
        As for :func:`pyvista_arrays`.

    Returns
    -------
    VolumeArrays

    Raises
    ------
    VolumeError
        Naming the file: it is missing, a directory, unreadable by both
        readers (with each reader's reason), or holds no valid volume.
    """
    import contextlib
    import io

    _check_options(cell_data, tetrahedralize)
    path = pathlib.Path(path)
    if not path.exists():
        raise VolumeError(f"{str(path)!r}: no such file")
    if path.is_dir():
        raise VolumeError(f"{str(path)!r} is a directory, not a mesh file")
    said = io.StringIO()  # meshio prints its reasons before it gives up
    try:
        import meshio

        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            data = meshio.read(path)
        convert = meshio_arrays
    except (Exception, SystemExit) as e:  # meshio ends a failed read with sys.exit(1)
        why_meshio = _reader_message(e, said.getvalue())
        try:
            convert, data = pyvista_arrays, _read_pyvista(path)
        except (Exception, SystemExit) as e2:
            raise VolumeError(f"cannot read {str(path)!r} as a volume mesh: meshio: {why_meshio}; "
                              f"pyvista: {_reader_message(e2)}") from e2
    try:
        return convert(data, cell_data=cell_data, tetrahedralize=tetrahedralize)
    except VolumeError as e:
        raise VolumeError(f"{str(path)!r}: {e}") from e


def _read_pyvista(path):
    """pyvista's reader for ``path``: VTK's complaints become an exception, not printed nor logged."""
    import gc
    import logging
    import warnings

    import pyvista as pv

    failure = data = None
    # pyvista's readers log VTK's errors with logging.error on the root logger (which installs a
    # stderr handler when the root has none): a handler of our own, and logging off, meanwhile
    quiet, was_disabled = logging.NullHandler(), logging.root.manager.disable
    logging.root.addHandler(quiet)
    logging.disable(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pyvista repeats VTK's errors as warnings: the exception says it
            # the outer catcher keeps VTK quiet until a failed reader is freed (it complains again then)
            with _stderr_fd_silenced(), pv.vtk_verbosity("off"), pv.VtkErrorCatcher(send_to_logging=False):
                try:
                    with pv.VtkErrorCatcher(raise_errors=True, send_to_logging=False):
                        data = pv.get_reader(str(path)).read()
                except Exception as e:
                    failure = RuntimeError(_reader_message(e))  # no traceback holding the VTK reader
                    data = None
                gc.collect()
    finally:
        logging.disable(was_disabled)
        logging.root.removeHandler(quiet)
    if failure is not None:
        raise failure
    return data


class _stderr_fd_silenced:
    """Send file descriptor 2 to the null device meanwhile: C libraries VTK links (libxml2) print there."""

    def __enter__(self):
        import os
        import sys

        try:
            sys.stderr.flush()
            self._saved = os.dup(2)
        except (OSError, ValueError, AttributeError):
            self._saved = None  # no real descriptor 2 (an embedding host): nothing to silence
            return self
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
        return self

    def __exit__(self, *exc):
        import os

        if self._saved is not None:
            os.dup2(self._saved, 2)
            os.close(self._saved)
        return False


def _reader_message(exc, printed=""):
    """One line saying why a reader failed: VTK's source locations and object addresses dropped."""
    import re

    if isinstance(exc, SystemExit):  # what meshio printed before sys.exit is the reason
        lines = [ln.strip() for ln in printed.splitlines() if ln.strip()]
        return lines[0].removeprefix("Error:").strip() if lines else "failed"
    if isinstance(exc, ModuleNotFoundError) and exc.name:  # an optional library of the format (h5py, netCDF4)
        return f"this format needs the {exc.name} package (pip install {exc.name})"
    text = re.sub(r"ERROR: In \S+, line \d+", " ", str(exc))
    text = re.sub(r"\w+ \(0x[0-9a-fA-F]+\): ", "", text)
    text = " ".join(text.split())
    text = text if len(text) <= 160 else text[:157] + "..."
    if isinstance(exc, RuntimeError) and type(exc) is RuntimeError:  # already said by _read_pyvista
        return text
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


# ------------------------------------------------------------------ surfaces

def write_surface(path, vertices, triangles, normals=None, *, binary=True):
    """Write a triangle surface as ``.vtp``, ``.vtk``, ``.ply``, ``.obj`` or ``.stl`` (by the extension).

    Parameters
    ----------
    path : str or os.PathLike
    vertices : (V, 3) float64
    triangles : (T, 3) int64
    normals : (V, 3) float64 or None
        Vertex normals, written where the format has them (VTP/VTK point
        data ``"Normals"``, PLY ``nx ny nz``, OBJ ``vn``); STL stores one
        normal per facet, which VTK computes from the triangle's corners
        (right-hand order, as ours).
    binary : bool, keyword-only
        Binary files where the format has both (VTK, PLY, STL). PLY and STL
        store coordinates (and PLY its normals) as float32 either way; OBJ
        is always text; VTP is always XML with binary data.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    IsoSurfaceError
        An extension not in :data:`SURFACE_FORMATS`, or an empty surface for
        a format that cannot hold one (PLY, OBJ, STL).
    """
    import pyvista as pv

    path = pathlib.Path(path)
    ext = path.suffix.lower()
    if ext not in SURFACE_FORMATS:
        raise IsoSurfaceError(f"cannot write {str(path)!r}: the surface formats are {', '.join(SURFACE_FORMATS)}")
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    if len(triangles) == 0 and ext not in (".vtp", ".vtk"):
        raise IsoSurfaceError(f"cannot write {str(path)!r}: the surface is empty, and {ext} cannot hold "
                              "an empty surface (.vtp and .vtk can)")
    poly = pv.PolyData.from_regular_faces(vertices, triangles) if len(triangles) else pv.PolyData()
    if normals is not None and len(triangles) and ext != ".stl":
        # VTK's PLY writer drops normals that are not float32 (with a warning)
        poly.point_data["Normals"] = np.asarray(normals, dtype=np.float32 if ext == ".ply" else np.float64)
        poly.point_data.active_normals_name = "Normals"
    if ext == ".vtp":
        poly.save(path)
    elif ext == ".ply":  # pyvista recomputes PLY normals from the faces unless told not to: ours are kept
        poly.save(path, binary=binary, recompute_normals=normals is None)
    else:
        poly.save(path, binary=binary)
    return path
