"""The registry of data sets and their on-disk cache: names, info, build, load."""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from polygen.volume._cells import index_dtype
from polygen.volume.datasets._base import CACHE_ENV, FORMAT_VERSION, DatasetError, DatasetInfo, _seed
from polygen.volume.datasets.fem import _heat_field, _tick
from polygen.volume.datasets.fields import distance_field, gaussian_field
from polygen.volume.datasets.meshing import _mesh_part
from polygen.volume.datasets.parts import _PARTS
from polygen.volume.datasets.tiny import _tiny, _tiny_fields


# --------------------------------------------------------------- registry
@dataclasses.dataclass(frozen=True)
class _Spec:
    info: DatasetInfo
    params: dict  # everything the result depends on besides the seed (cache key)
    builder: Callable  # (seed, bar) -> (points, cells, fields)
    stages: int = 1
    reorder: bool = True  # renumber along a Morton curve after building (a refined volume keeps its parent's)


_REGISTRY: dict = {}


def _register(info, params, builder, stages=1, reorder=True):
    _REGISTRY[info.name] = _Spec(info, params, builder, stages, reorder)


_THESIS = {
    "data1": dict(cells=20736, nodes=4002, boundary_cells=2048, extrema=21),
    "data2": dict(cells=61680, nodes=11624, boundary_cells=5432, extrema=46),
    "data3": dict(cells=346644, nodes=62107, boundary_cells=16908, extrema=135),
    "data4": dict(cells=557868, nodes=97473, boundary_cells=17876, extrema=540),
    "data5": dict(cells=458664, nodes=80468, extrema=5986),
}


def _part_builder(part, cell_type, target, h0, n_sources, noise, n_bumps, fem):
    def build(seed, bar):
        _tick(bar, "mesh")
        points, cells, h = _mesh_part(part, h0, cell_type, target=target)
        fields = {}
        if fem:
            fields["fem"] = _heat_field(
                points, cells, part, spacing=h, n_sources=n_sources, seed=seed, noise=noise, progress=bar
            )
        _tick(bar, "analytic fields")
        fields["gaussians"] = gaussian_field(points, n_bumps=n_bumps, seed=seed)
        fields["distance"] = distance_field(points)
        return points, cells, fields

    return build


def _add_part(name, part_key, cell_type, target, h0, *, n_sources, noise=0.0, n_bumps, fem=True, thesis=None, note=""):
    part = _PARTS[part_key]
    fields = ("fem", "gaussians", "distance") if fem else ("gaussians", "distance")
    desc = f"{part.description}; {cell_type}, ~{target} cells" + (f"; {note}" if note else "")
    info = DatasetInfo(
        name=name,
        cell_type=cell_type,
        target_cells=int(target),
        genus=(part.genus,) + (0,) * part.n_voids,
        n_voids=part.n_voids,
        n_through_holes=part.genus,
        fields=fields,
        description=desc,
        thesis=dict(thesis or {}),
    )
    params = dict(
        part=part_key, cell_type=cell_type, target=int(target), h0=float(h0), n_sources=int(n_sources),
        noise=float(noise), n_bumps=int(n_bumps), fem=bool(fem),
    )
    _register(info, params, _part_builder(part, cell_type, target, h0, n_sources, noise, n_bumps, fem), 4 if fem else 2)


def _refined_builder(parent):
    def build(seed, bar):
        from polygen.volume.datasets.refine import refine_tetrahedra

        spec = _REGISTRY[parent]
        _tick(bar, f"load {parent}")
        coarse = load(parent, seed=seed, progress=bar is not None)
        _tick(bar, "refine")
        cells_bar = None
        if bar is not None:
            from tqdm.auto import tqdm

            cells_bar = tqdm(total=coarse.n_cells, desc=f"refining {parent}", unit="cell", unit_scale=True,
                             leave=False)
        try:
            # a field the parent solved (FEM) is interpolated at the midpoints; the analytic ones are evaluated
            points, cells, fields, _ = refine_tetrahedra(coarse, fields="interpolate" if spec.params["fem"] else None,
                                                         progress=cells_bar)
        finally:
            if cells_bar is not None:
                cells_bar.close()
        del coarse
        _tick(bar, "analytic fields")
        # the same bumps and eye as the parent's: the box of the points, which the midpoints do not widen
        fields["gaussians"] = gaussian_field(points, n_bumps=spec.params["n_bumps"], seed=seed)
        fields["distance"] = distance_field(points)
        return points, cells, {name: fields[name] for name in spec.info.fields}

    return build


def _add_refined(name, parent):
    """``name``: every tetrahedron of data set ``parent`` split into eight (:mod:`.refine`), its analytic fields
    evaluated again at the new nodes, its FEM field (if any) interpolated. Not reordered: the parent's Morton
    order carries over (a refined node follows its edge's smaller node, children follow their parent)."""
    p = _REGISTRY[parent]
    info = dataclasses.replace(
        p.info, name=name, target_cells=8 * p.info.target_cells,
        description=f"{parent} refined once: each tetrahedron into 8 at its edges' midpoints (~{8 * p.info.target_cells} "
                    "cells); for the memory limit")
    params = dict(parent=parent, parent_params=p.params, refine="midpoints-shortest-diagonal")
    _register(info, params, _refined_builder(parent), 3, reorder=False)


# the thesis's data 1-5 (Tables 6.1, 7.1); h0 is the mesh size that hits the target with gmsh 4.15
_add_part("data1", "bracket", "tetra", 20736, 0.11425, n_sources=22, n_bumps=60, thesis=_THESIS["data1"])
_add_part("data2", "flange", "tetra", 61680, 0.08431, n_sources=46, n_bumps=150, thesis=_THESIS["data2"])
_add_part("data3", "pillow_block", "tetra", 346644, 0.05794, n_sources=136, n_bumps=600, thesis=_THESIS["data3"])
_add_part("data4", "manifold", "tetra", 557868, 0.06658, n_sources=540, n_bumps=1000, thesis=_THESIS["data4"])
_add_part(
    "data5", "angle_bracket", "tetra", 458664, 0.05453, n_sources=60, noise=1.0, n_bumps=3000,
    thesis=_THESIS["data5"], note="random heat load on every node: thousands of extrema",
)
_add_part("2M", "manifold", "tetra", 2_000_000, 0.04355, n_sources=800, n_bumps=2000, note="for scaling")
_add_part(
    "10M", "manifold", "tetra", 10_000_000, 0.02547, n_sources=0, n_bumps=4000, fem=False,
    note="for scaling; analytic fields only (an FEM solve at this size needs too much memory and time)",
)
_add_refined("80M", "10M")
_add_part("hexa1", "plate", "hexa", 20736, 0.07145, n_sources=22, n_bumps=60)
_add_part("hexa2", "flange_hex", "hexa", 61680, 0.0545, n_sources=46, n_bumps=150)
_add_part("hexa3", "base_plate", "hexa", 346644, 0.03943, n_sources=136, n_bumps=600)


def _tiny_builder(kind, cell_type):
    def build(seed, bar):
        points, cells = _tiny(kind, cell_type)
        return points, cells, _tiny_fields(points, seed)

    return build


_TINY = [
    # name, kind, cell type, cells, genus by group, description
    ("one_tet", "one", "tetra", 1, (0,), "one tetrahedron"),
    ("two_tets", "two", "tetra", 2, (0,), "two tetrahedra sharing a face"),
    ("one_hex", "one", "hexa", 1, (0,), "one unit cube"),
    ("two_hexes", "two", "hexa", 2, (0,), "two unit cubes sharing a face"),
    ("torus", "torus", "tetra", 48, (1,), "a ring of 8 cubes (3x3x1 minus the centre), 6 tetrahedra each: genus 1"),
    ("torus_hex", "torus", "hexa", 8, (1,), "a ring of 8 cubes (3x3x1 minus the centre): genus 1"),
    ("hollow_cube", "hollow_cube", "tetra", 156, (0, 0), "3x3x3 cubes minus the centre, 6 tetrahedra each: one void"),
    ("hollow_cube_hex", "hollow_cube", "hexa", 26, (0, 0), "3x3x3 cubes minus the centre: one void"),
    ("genus3", "genus3", "tetra", 108, (3,), "7x3x1 cubes with three holes, 6 tetrahedra each: genus 3"),
    ("genus3_hex", "genus3", "hexa", 18, (3,), "7x3x1 cubes with three holes: genus 3"),
]
for _name, _kind, _ct, _nc, _genus, _desc in _TINY:
    _register(
        DatasetInfo(
            name=_name, cell_type=_ct, target_cells=_nc, genus=_genus, n_voids=len(_genus) - 1,
            n_through_holes=sum(_genus), fields=("linear", "distance", "gaussians"), description=_desc, cached=False,
        ),
        dict(kind=_kind, cell_type=_ct),
        _tiny_builder(_kind, _ct),
    )
del _name, _kind, _ct, _nc, _genus, _desc


# ------------------------------------------------------------------- API
def names():
    """Names of all data sets, in listing order (data 1-5, scaling, hexahedral, tiny)."""
    return list(_REGISTRY)


def _spec(name):
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise DatasetError(f"unknown data set {name!r}; the data sets are {names()}") from None


def info(name):
    """The :class:`DatasetInfo` of data set ``name``."""
    return _spec(name).info


def cache_dir():
    """Where built volumes are cached: ``$POLYGEN_CACHE_DIR`` or the platform cache dir + ``volumes``."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("polygen")) / "volumes"


def _key(name, seed):
    spec = _spec(name)
    payload = json.dumps(
        dict(name=name, seed=seed, params=spec.params, format=FORMAT_VERSION), sort_keys=True
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:12], payload


def cache_path(name, seed=0):
    """Path of the cache file of ``name`` built with ``seed`` (which may not exist yet)."""
    seed = _seed(seed)
    digest, _ = _key(name, seed)
    return cache_dir() / f"{name}-seed{seed}-v{FORMAT_VERSION}-{digest}.npz"


def is_cached(name, seed=0):
    """Whether ``load(name, seed=seed)`` would read a cache file."""
    return _spec(name).info.cached and cache_path(name, seed).is_file()


def _write_cache(path, points, cells, fields, payload):
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {"points": points, "cells": cells, "field_names": np.array(list(fields), dtype=str)}
    arrays["key"] = np.array(payload)
    for i, values in enumerate(fields.values()):
        arrays[f"field_{i}"] = values
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)  # uncompressed: loading is a plain read
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


_BLOCK_ROWS = 1 << 20  # cells converted per block when a cache file's int64 cells are read as int32


def _read_cells(z, n_points):
    """The ``cells`` of the open cache file ``z`` in the volume's index dtype (int32 below 2**31 nodes).

    Caches written before the volume kept int32 cells hold int64 ones; they are read and narrowed a block of
    rows at a time, so that the full int64 array (32 bytes per tetrahedron, 2.6 GB on 80M) is never held
    beside the int32 one. Ids outside ``0..n_points-1`` raise ``ValueError`` (the file is then rebuilt).
    """
    index = index_dtype(n_points)
    with z.zip.open("cells.npy") as fh:
        version = np.lib.format.read_magic(fh)
        read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, fortran, dtype = read_header(fh)
        if fortran or len(shape) != 2 or dtype.kind not in "iu" or np.can_cast(dtype, index):
            return np.asarray(z["cells"])  # not int64 (a newer file: the index dtype already), read as it is
        out = np.empty(shape, index)
        row = shape[1] * dtype.itemsize
        for a in range(0, shape[0], _BLOCK_ROWS):
            b = min(shape[0], a + _BLOCK_ROWS)
            data = fh.read((b - a) * row)
            if len(data) != (b - a) * row:
                raise ValueError("truncated cells")
            block = np.frombuffer(data, dtype).reshape(b - a, shape[1])
            if block.size and (block.min() < 0 or block.max() >= n_points):
                raise ValueError("node ids out of range")
            out[a:b] = block
        return out


def _read_cache(path, payload):
    try:
        with np.load(path, allow_pickle=False) as z:
            if str(z["key"]) != payload:
                return None
            names_ = [str(s) for s in z["field_names"]]
            fields = {n: z[f"field_{i}"] for i, n in enumerate(names_)}
            points = z["points"]
            return points, _read_cells(z, points.shape[0]), fields
    except (OSError, KeyError, ValueError):
        return None  # unreadable or foreign file: rebuild and overwrite


def _build_arrays(name, seed, progress):
    spec = _spec(name)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=spec.stages, desc=f"building {name}", unit="stage", leave=True)
    try:
        points, cells, fields = spec.builder(seed, bar)
    finally:
        if bar is not None:
            bar.n = bar.total
            bar.set_postfix_str("done")
            bar.close()
    if spec.info.cached and spec.reorder:
        points, cells, fields = _spatial_order(points, cells, fields)
    return points, cells, fields


def _spatial_order(points, cells, fields):
    """Nodes and cells renumbered along a Morton curve (see ``UnstructuredVolume.reordered``).

    gmsh's parallel 3D mesher numbers cells far from spatially; the FEM
    meshes users bring are usually renumbered (bandwidth, cache), so ours
    are too. The same renumbered mesh goes to VTK in every comparison.
    """
    from polygen.volume.mesh import UnstructuredVolume

    vol = UnstructuredVolume(points, cells, fields, validate=False).reordered()
    return vol.points, vol.cells, vol.fields


def build(name, *, seed=0, force=False, progress=False):
    """Build data set ``name`` into the cache (if not there yet) and return the cache file path.

    Parameters
    ----------
    name : str
    seed : int, keyword-only
    force : bool, keyword-only
        Rebuild even if the cache file exists.
    progress : bool, keyword-only
        Show a tqdm progress bar of the build stages.

    Returns
    -------
    pathlib.Path or None
        ``None`` for the tiny volumes, which are not cached.
    """
    spec = _spec(name)
    seed = _seed(seed)
    if not spec.info.cached:
        return None
    path = cache_path(name, seed)
    if force or not path.is_file():
        points, cells, fields = _build_arrays(name, seed, progress)
        _write_cache(path, points, cells, fields, _key(name, seed)[1])
    return path


def load(name, *, seed=0, field=None, progress=False, cache=True):
    """Load (building and caching if needed) the volume ``name``.

    Parameters
    ----------
    name : str
        One of :func:`names`, e.g. ``"data1"`` .. ``"data5"``, ``"2M"``,
        ``"10M"``, ``"80M"`` (10M refined once: building it needs about 6 GiB), ``"hexa1"``, ``"torus"``, ``"hollow_cube"``,
        ``"genus3"``, ``"two_tets"``.
    seed : int, keyword-only
        Moves the heat sources, random loads and Gaussian bumps (the mesh
        depends on the name only).
    field : str, optional, keyword-only
        Field to put first, so that ``vol.scalars()`` returns it; the
        data set's first field (``info(name).fields[0]``) by default. All
        fields are attached either way.
    progress : bool, keyword-only
        Show a tqdm progress bar when building.
    cache : bool, keyword-only
        Read and write the disk cache (default). ``False`` builds in memory.

    Returns
    -------
    UnstructuredVolume

    Raises
    ------
    DatasetError
        Unknown name or field, bad seed.
    """
    from polygen.volume.mesh import UnstructuredVolume

    spec = _spec(name)
    seed = _seed(seed)
    if field is not None and field not in spec.info.fields:
        raise DatasetError(f"data set {name!r} has no field {field!r}; its fields are {list(spec.info.fields)}")
    arrays = None
    use_cache = cache and spec.info.cached
    if use_cache:
        path = cache_path(name, seed)
        payload = _key(name, seed)[1]
        if path.is_file():
            arrays = _read_cache(path, payload)
    if arrays is None:
        arrays = _build_arrays(name, seed, progress)
        if use_cache:
            _write_cache(path, *arrays, payload)
    points, cells, fields = arrays
    # the ids as a volume keeps them (the cache's are): one compiled constructor pass for every data set
    cells = np.asarray(cells, index_dtype(len(points)))
    order = list(fields)
    if field is not None:
        order.remove(field)
        order.insert(0, field)
    # the generators orient every cell; the container's geometric check is left on for the
    # small volumes and skipped above a million cells, where it costs more than the load
    return UnstructuredVolume(
        points, cells, {k: fields[k] for k in order}, validate=cells.shape[0] <= 1_000_000
    )
