"""``polygen isosurface``: the main job, every method against VTK on one volume.

With no argument it loads (or builds) data set 4, extracts 20 isosurfaces
(``linspace(min, max, 22)[1:-1]``) with every registered method and with
VTK's ``vtkContourFilter``, prints a table, and writes the surfaces
(``.vtp``) and one PNG (six of the surfaces, one per panel).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

DEFAULT_DATA = "data4"

EXAMPLES = """examples:
  polygen isosurface                      data set 4, 20 values, every method against VTK
  polygen isosurface torus --values 4     a small data set (see 'polygen datasets')
  polygen isosurface part.vtu --field temperature --value 350 --method edge-centred
  polygen isosurface part.msh --orient    reorder the nodes of inverted cells instead of refusing them
  polygen isosurface part.vtu --cell-data --field stress   a cell array, averaged onto the nodes
  polygen isosurface mixed.vtu --tetrahedralize            wedges, pyramids, mixed cells: split into tetrahedra
  polygen isosurface part.vtu --no-compare-vtk --no-files --json times.json
  polygen isosurface torus --value 0.5 --method scan --components   the surface's connected parts
  polygen isosurface volume.pvtu --workers 4        a partitioned volume on a local Dask cluster
  polygen isosurface data4 --partitions 8 --scheduler tcp://host:8786   split, on a running Dask cluster
"""


def configure(parser):
    parser.add_argument("mesh", nargs="?", default=DEFAULT_DATA,
                        help="a mesh file that meshio or pyvista reads, or a data-set name "
                             f"(see 'polygen datasets'; default: {DEFAULT_DATA})")
    parser.add_argument("--field", help="the node field to contour (default: the first one that is not an id "
                                         "array such as vtkOriginalPointIds; the command says which)")
    vals = parser.add_mutually_exclusive_group()
    vals.add_argument("--values", type=int, default=20, metavar="N",
                      help="N values evenly inside the field's range (default: 20)")
    vals.add_argument("--value", type=float, action="append", metavar="V", help="an isovalue (repeatable)")
    parser.add_argument("--method", action="append", metavar="NAME",
                        help="a method to run (repeatable; default: all, the fastest first). One of: " + ", ".join(_method_names()))
    parser.add_argument("--compare-vtk", action=argparse.BooleanOptionalAction, default=True,
                        help="time VTK's vtkContourFilter on the same values (default: on)")
    parser.add_argument("--json", metavar="FILE", help="write the measurements as JSON")
    parser.add_argument("--output", metavar="DIR", default="polygen-output",
                        help="where the .vtp surfaces and the PNG go (default: ./polygen-output)")
    parser.add_argument("--no-files", action="store_true", help="write no surfaces or image")
    parser.add_argument("--orient", action="store_true",
                        help="reorder the nodes of inverted cells (negative volume in VTK node order) "
                             "instead of refusing the mesh")
    parser.add_argument("--cell-data", action="store_true",
                        help="also contour the file's cell arrays (floating point), each averaged onto the nodes "
                             "weighted by cell volume")
    parser.add_argument("--tetrahedralize", action="store_true",
                        help="split cells other than tetrahedra (wedges, pyramids, hexahedra, quadratic or mixed "
                             "cells) into tetrahedra instead of refusing a mesh that is not all tetrahedra or all "
                             "hexahedra")
    dist = parser.add_argument_group("partitioned volumes (a .pvtu, or a volume split with --partitions)")
    dist.add_argument("--workers", type=int, metavar="N",
                      help="prepare the partitions on a local Dask cluster of N worker processes and query there "
                           "(needs pip install 'polygen[distributed]')")
    dist.add_argument("--scheduler", metavar="ADDRESS",
                      help="use the Dask cluster whose scheduler is at ADDRESS (e.g. tcp://host:8786)")
    dist.add_argument("--partitions", type=int, metavar="K",
                      help="split the volume into K partitions (Morton ranges of cells; default: one per worker, "
                           "with at least a million cells each -- a smaller volume is not split)")
    parser.add_argument("--components", action="store_true",
                        help="print each surface's connected components (by the first method): triangles, area, "
                             "enclosed volume, bounds, closed, touching the boundary")


def _method_names():
    from polygen.volume import methods

    return methods.names()


def _load(spec, progress, orient=False, cell_data=False, tetrahedralize=False):
    from polygen.cli import CLIError
    from polygen.volume import UnstructuredVolume, VolumeError, datasets

    if spec in datasets.names():
        return spec, datasets.load(spec, progress=progress)
    path = Path(spec)
    if not path.exists():
        raise CLIError(f"{spec!r} is neither a file nor a data set (data sets: {', '.join(datasets.names())})")
    try:
        return path.name, UnstructuredVolume.read(path, orient=orient, cell_data="average" if cell_data else None,
                                                  tetrahedralize=tetrahedralize)
    except VolumeError as e:  # the library's advice, in the CLI's words
        said = str(e).replace("pass orient=True", "pass --orient")
        raise CLIError(said.replace("tetrahedralize=True splits", "--tetrahedralize splits")) from e


def _is_id_array(name, values):
    """An id or integer-index array (vtkOriginalPointIds, VTKorigID, GlobalNodeId, ...): nothing to contour."""
    low = name.lower()
    return (np.issubdtype(np.asarray(values).dtype, np.integer)
            or low.endswith(("ids", "_id", "origid", "nodeid", "pointid"))
            or low in ("id", "ids"))


def choose_field(vol, field=None):
    """The field to contour: ``field`` if given (else a one-line error, saying when it is cell data),
    or the first that is not an id array; and how it was chosen."""
    from polygen.cli import CLIError

    cell_data = getattr(vol, "cell_data_names", ())
    if not vol.fields:
        extra = f"; the file's cell data ({', '.join(cell_data)}) is one value per cell" if cell_data else ""
        raise CLIError(f"the volume has no node field to contour{extra}" + ("; --cell-data averages it onto the nodes"
                                                                          if cell_data else ""))
    if field is not None:
        if field in vol.fields:
            return field, "--field"
        if field in cell_data:
            raise CLIError(f"{field!r} is cell data (one value per cell); isosurfaces need node data: "
                           f"the node fields are {', '.join(vol.fields)}; --cell-data averages cell arrays onto "
                           f"the nodes")
        raise CLIError(f"no field {field!r}; the node fields are {', '.join(vol.fields)}")
    names = list(vol.fields)
    skipped = [n for n in names if _is_id_array(n, vol.fields[n])]
    usable = [n for n in names if n not in skipped]
    if not usable:
        return names[0], "the only kind of field here: id arrays"
    how = "the first field" if usable[0] == names[0] else f"the first that is not an id array ({', '.join(skipped)})"
    return usable[0], f"{how}; --field to pick another" if len(names) > 1 else how


def _vtk_time(vol, field, values):
    """Seconds for VTK's contour filter (merged points, normals on) on all values, and its triangles."""
    grid = vol.to_pyvista()
    name = field or next(iter(vol.fields))
    # a first call loads VTK's code paths; the second is timed
    grid.contour([values[0]], scalars=name, compute_normals=True, method="contour")
    t0 = time.perf_counter()
    tris = 0
    for v in values:
        out = grid.contour([v], scalars=name, compute_normals=True, method="contour")
        tris += out.n_cells
    return time.perf_counter() - t0, tris


def _start_helper():
    """The helper process of :func:`_warm_up`, started now: it imports polygen (seconds) while this one loads
    the volume, then waits for its work on its stdin (:func:`_helper_main`)."""
    import subprocess

    return subprocess.Popen([sys.executable, "-c", "from polygen.cli.isosurface import _helper_main; _helper_main()"],
                            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _early_helper(n_methods):
    """:func:`_start_helper` where this is a first run (the probe kernel that importing polygen runs was compiled,
    not loaded from numba's cache) on two or more cores with the cache on and methods to share; else None."""
    from polygen import _jit
    from polygen.volume import _intrinsics

    stats = getattr(getattr(_intrinsics, "_probe", None), "stats", None)
    first = stats is not None and bool(stats.cache_misses) and not stats.cache_hits
    if not (first and n_methods > 1 and _jit.CACHE and _cores() > 1):
        return None
    return _start_helper()


def _cores():
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _end_helper(proc):
    """Tell a helper from :func:`_start_helper` that got no work to end (its stdin closed), and wait for it."""
    if proc is not None and proc.poll() is None:
        try:
            proc.stdin.close()
        except OSError:  # pragma: no cover - gone already
            pass
        proc.wait()


def _warm_up(names, cell_type, helper=True, n_cells=0):
    """Run each method on a tiny volume of ``cell_type``: the seconds spent (compiling or loading kernels).

    ``n_cells``, the size of the volume the methods will run on: from the sizes where a method or the
    topology takes another path (parallel, in halves), the tiny volume is made to take it too (see
    :func:`_tiny_options`, :data:`_LARGE`), so that their kernels are compiled here, by both processes, and
    not while the methods are measured on the volume (a method that compiles a kernel there is measured again).

    numba compiles on one thread. On a first run (the first kernel compiles) a helper process is
    started (or ``helper``, one from :func:`_start_helper`, is given its work) that runs the same methods
    from the other end of the list, each method taken by whichever
    of the two claims it first; both save what they compile in numba's on-disk cache. This process then
    runs the helper's methods too, which loads their kernels from the cache (or compiles what the helper
    did not save), so the seconds returned are all the compiling and loading it took. No helper where
    numba's cache is off, on one core, or when nothing compiles (a second run).
    """
    import shutil
    import tempfile

    import numba.core.event as ev

    from polygen import _jit

    t0 = time.perf_counter()
    # the items first: one method has the topology's items beside it to share with a helper. The topology first,
    # as the methods share it: this process compiles it while the helper starts from the other end
    names = [_TOPOLOGY] + _warm_up_order(names) + _large_items(n_cells)
    claims = tempfile.mkdtemp(prefix="polygen-warm-up-") if helper and len(names) > 1 else None
    started = []

    def start(proc):
        work = "\t".join([claims, cell_type, str(n_cells), *names]) + "\n"
        try:
            proc.stdin.write(work.encode())
            proc.stdin.close()
        except OSError:  # pragma: no cover - the helper is gone: this process does all
            pass
        started.append(proc)

    class StartHelper(ev.Listener):
        def on_start(self, event):
            if not started:
                start(_start_helper())

        def on_end(self, event):
            pass

    listener = StartHelper()
    registered = False
    if claims is not None and not isinstance(helper, bool):
        start(helper)
    elif claims is not None and _jit.CACHE and _cores() > 1:
        ev.register("numba:compile", listener)
        registered = True
    else:
        _end_helper(None if isinstance(helper, bool) else helper)
    try:
        tiny = _tiny_volume(cell_type)
        left = [name for name in names if not _run_tiny(tiny, name, claims, n_cells)]
        if registered:
            ev.unregister("numba:compile", listener)
            registered = False
        if started:
            started[0].wait()
        for name in left:  # the helper's: from the cache now
            _run_tiny(tiny, name, None, n_cells)
    finally:
        if registered:
            ev.unregister("numba:compile", listener)
        if started and started[0].poll() is None:  # pragma: no cover - interrupted
            started[0].kill()
            started[0].wait()
        if claims is not None:
            shutil.rmtree(claims, ignore_errors=True)
    return time.perf_counter() - t0


#: methods with kernels that no other method compiles: last in the warm-up's list, so that the helper process,
#: which starts from the end, compiles them while this one compiles those that the others share (the tiny
#: volume's topology, the propagation, the marching tables) -- both compiling one kernel at once is work lost.
#: The largest last: the helper's first, so that what is left when the two meet is small (the active scan's
#: kernels were once the last left, 25 s compiled by one process while the other had finished)
_OWN_KERNELS = ("edge-centred", "edge-centred-table", "active-scan")


def _warm_up_order(names):
    """``names`` in the warm-up's order: :data:`_OWN_KERNELS` last."""
    return [n for n in names if n not in _OWN_KERNELS] + [n for n in _OWN_KERNELS if n in names]


def _tiny_options(name, n_cells):
    """The options method ``name`` is given on the tiny volume so that it takes the paths it takes on a volume
    of ``n_cells`` cells (and the warm-up compiles their kernels): thinning's two halves at once, the edge-centred
    table's construction by two threads (which it chooses from 10,000 cells crossed while the cores are idle)."""
    from polygen.volume import edge_centred, thinning

    if name == "thinning" and n_cells >= thinning.PARALLEL_MIN_CELLS:
        return {"parallel": True}
    if name == "edge-centred-table" and n_cells >= edge_centred.EdgeCentredTable.PARALLEL_MIN_CELLS and _cores() > 1:
        return {"threads": 2}
    return {}


#: a warm-up item besides the methods: the parallel counting sort of the topology (node -> cells, edge -> cells)
#: and the probe of numba's threading layer that large volumes make
_LARGE = "(large volumes)"
#: a warm-up item besides the methods: the topology the command builds before the methods (face neighbours, edges,
#: node -> cells, boundary groups, cell records), whatever methods were chosen -- with active-scan alone, which
#: uses none of it on the tiny volume, its 14 kernels were compiled inside the topology's timing (9.5 s on data4)
_TOPOLOGY = "(topology)"


def _large_items(n_cells):
    """The warm-up items besides the methods for a volume of ``n_cells``: :data:`_LARGE` from the size whose
    node -> cells lists (4 or 8 entries a cell) take the parallel sort."""
    from polygen.volume import _topology

    return [_LARGE] if 4 * n_cells >= _topology._SERIAL_BELOW else []


def _build_topology(vol):
    """What the command builds before the methods, shared by them (the warm-up builds it on the tiny volume)."""
    vol.face_neighbors, vol.edges, vol.cell_edges, vol.node_cells, vol.boundary_groups, vol.cell_records


def _tiny_volume(cell_type):
    from polygen.volume import UnstructuredVolume, datasets

    tiny = datasets.load("hollow_cube" if cell_type == "tetra" else "hollow_cube_hex")
    # the same array types as a user's volume: fields added through the constructor
    return UnstructuredVolume(tiny.points, tiny.cells, {"f": tiny.points @ [1.0, 0.7, 0.3]})


def _run_tiny(tiny, name, claims, n_cells=0):
    """Run method ``name`` on the tiny volume, unless ``claims`` (a folder) shows the other process took it:
    whether it ran."""
    from polygen.volume import methods

    if claims is not None:
        try:
            os.close(os.open(os.path.join(claims, name), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except (FileExistsError, FileNotFoundError):  # taken, or the warm-up is over
            return False
    if name == _TOPOLOGY:
        _build_topology(tiny)
        return True
    if name == _LARGE:
        from polygen import _jit
        from polygen.volume import _topology

        _jit.parallel_kernels_may_overlap()
        n = _topology._SERIAL_BELOW
        # a volume's cells are int32 while its node ids fit (int64 past 2**31 nodes, which its cells' count
        # allows from 2**28 hexahedra) and read-only: numba compiles _stable_csr for each, and a kernel the
        # warm-up compiled for another type was compiled again inside the timed topology (1.2 s on data4)
        for dtype in (np.int32,) + ((np.int64,) if 8 * n_cells >= 2**31 else ()):
            cells = np.zeros((n // 4 + 1, 4), dtype)
            cells.setflags(write=False)
            _topology.node_cells_csr(cells, 1)
        _topology.stable_csr(np.zeros(n, np.int64), 1)
        return True
    method = methods.get(name)(tiny, field="f", **_tiny_options(name, n_cells))
    method.extract(1.5)
    if type(method).extract_many is not methods.IsosurfaceMethod.extract_many:
        method.extract_many([1.0, 2.0])
    return True


def _helper_main():
    """The helper process of :func:`_warm_up`: ``claims cell_type n_cells names...`` (one line on stdin, tabs
    between; none: nothing to do); the methods from the last."""
    import polygen.volume  # noqa: F401 - the imports first, while the main process loads its volume

    work = sys.stdin.readline().rstrip("\n")
    if not work:
        return
    claims, cell_type, n_cells, *names = work.split("\t")
    n_cells = int(n_cells)
    tiny = _tiny_volume(cell_type)
    for name in reversed(names):
        if not os.path.isdir(claims):  # the main process is done (or gone)
            return
        _run_tiny(tiny, name, claims, n_cells)


def _is_partitioned(args):
    return (str(args.mesh).lower().endswith(".pvtu") or args.workers is not None or args.scheduler is not None
            or args.partitions is not None)


def run_partitioned(args):
    """A partitioned volume: prepared per partition (here or on Dask), the surfaces stitched; a table."""
    from polygen.cli import CLIError
    from polygen.volume import isovalues
    from polygen.volume.partitioned import PartitionedVolume, PartitionError

    if args.workers is not None and args.scheduler is not None:
        raise CLIError("give --workers (a local cluster) or --scheduler (a running one), not both")
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers needs at least 1; got {args.workers}")
    if args.method and len(args.method) > 1:
        raise CLIError("a partitioned volume runs one --method at a time")
    method = args.method[0] if args.method else None
    if method is not None and method not in _method_names():
        raise CLIError(f"unknown method {method!r}; the methods are {', '.join(_method_names())}")
    try:
        if str(args.mesh).lower().endswith(".pvtu"):
            if args.partitions is not None:
                raise CLIError("a .pvtu is partitioned already: --partitions splits a single volume")
            pvol, label = PartitionedVolume.from_pvtu(args.mesh), Path(args.mesh).name
        else:
            label, vol = _load(args.mesh, sys.stderr.isatty(), orient=args.orient, cell_data=args.cell_data,
                               tetrahedralize=args.tetrahedralize)
            pvol = None
        client = None
        if args.workers is not None or args.scheduler is not None:
            from polygen.volume.distributed import local_client
            from polygen.volume.distributed import prepare as dask_prepare

            client = local_client(args.workers or 2, scheduler=args.scheduler)
        try:
            if pvol is None:
                # without --partitions, as many as pay (auto_partitions: one per worker, none for a small volume)
                workers = None if client is None else len(client.scheduler_info()["workers"]) or None
                pvol = PartitionedVolume.split(vol, args.partitions, workers=workers)
                if pvol.split_reason is not None:
                    print(f"{label}: {pvol.split_reason}")
            if client is None:
                prepared = pvol.prepare(args.field, method)
            else:
                prepared = dask_prepare(pvol, args.field, method, client=client)
            return _partitioned_table(args, label, pvol, prepared, client, isovalues)
        finally:
            if client is not None:
                cluster = client.cluster if args.scheduler is None else None
                client.close()
                if cluster is not None:
                    cluster.close()
    except PartitionError as e:
        raise CLIError(str(e)) from e


def _partitioned_table(args, label, pvol, prepared, client, isovalues):
    from polygen.cli import CLIError

    if args.value:
        values = np.asarray(args.value, float)
        if not np.isfinite(values).all():
            raise CLIError(f"--value must be finite; got {args.value}")
    else:
        if args.values < 1:
            raise CLIError(f"--values needs at least 1; got {args.values}")
        # the field's range: the boundary values every partition reported are a sample; ask a first surface
        lo, hi = _field_range(prepared)
        values = isovalues(np.array([lo, hi]), args.values)
    where = f"on Dask ({len(set(prepared.placement))} workers)" if client is not None else "here"
    print(f"{label}: {pvol.n_partitions} partitions, prepared {where} in {prepared.preprocess_s:.3f} s; "
          f"{len(values)} values")
    t0 = time.perf_counter()
    surfaces = prepared.extract_many(values)
    query = time.perf_counter() - t0
    head = f"{'value':>12s} {'triangles':>10s} {'vertices':>10s} {'seam vertices':>13s} {'seam seeds':>10s}"
    print(head)
    print("-" * len(head))
    for v, iso in zip(values, surfaces):
        seeds = sum(p["seam_seeds"] for p in iso.partitions)
        print(f"{v:12.6g} {iso.n_triangles:10d} {iso.n_vertices:10d} {iso.seam_vertices:13d} {seeds:10d}")
    moved = getattr(prepared, "bytes_last", None)
    print(f"query: {query:.3f} s for {len(values)} values" + (f"; {moved} bytes of surfaces came back" if moved else ""))
    if args.json:
        out = {"mesh": label, "partitions": pvol.n_partitions, "values": np.asarray(values).tolist(),
               "preprocess_s": prepared.preprocess_s, "query_s": query, "bytes": moved,
               "triangles": [s.n_triangles for s in surfaces], "vertices": [s.n_vertices for s in surfaces]}
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    if not args.no_files:
        out = Path(args.output)
        out.mkdir(parents=True, exist_ok=True)
        for i, iso in enumerate(surfaces):
            if not iso.is_empty:
                _save(iso, out / f"{Path(label).stem}-iso{i:02d}.vtp")
        print(f"wrote the surfaces to {out}/")
    return 0


def _field_range(prepared):
    infos = prepared.infos
    return min(i["min"] for i in infos), max(i["max"] for i in infos)


def _check_outputs(args):
    """Before any work: ``--json`` and ``--output`` can be written, else a one-line :class:`CLIError`.

    A file that cannot be written used to fail only after every extraction
    (and VTK's error log); here nothing is created (``--output`` is made
    when the surfaces are written), each folder is tried with a temporary
    file that is removed at once.
    """
    import tempfile

    from polygen.cli import CLIError

    def writable(folder, what):
        try:
            with tempfile.TemporaryFile(dir=folder):
                pass
        except OSError as e:
            raise CLIError(f"{what}: cannot write in {str(folder)!r} ({e.strerror or e})") from None

    if args.json:
        path = Path(args.json)
        folder = path.parent
        if path.is_dir():
            raise CLIError(f"--json {str(path)!r} is a folder; give the name of a file")
        if not folder.is_dir():
            raise CLIError(f"--json {str(path)!r}: the folder {str(folder)!r} does not exist"
                           + (" (it is a file)" if folder.exists() else ""))
        writable(folder, f"--json {str(path)!r}")
    if not args.no_files:
        out = Path(args.output)
        if out.exists() and not out.is_dir():
            raise CLIError(f"--output {str(out)!r} is a file, not a folder")
        existing = out
        while not existing.exists() and existing != existing.parent:  # the folder it will be made in
            existing = existing.parent
        if not existing.is_dir():
            raise CLIError(f"--output {str(out)!r}: {str(existing)!r} is a file, not a folder")
        writable(existing, f"--output {str(out)!r}")


#: bytes each of --values N holds at least: the value, its surface kept for the files (an IsoSurface: its
#: arrays' headers and counters, over 1 KiB even when empty) and its column of the table
BYTES_PER_VALUE = 1024


def _check_memory(args):
    """``--values N`` that cannot fit in memory is refused before the volume is loaded (one line, exit 2)."""
    from polygen._memory import check_fits
    from polygen.cli import CLIError

    if not args.value and args.values > 0:
        check_fits(float(args.values) * BYTES_PER_VALUE, f"--values {args.values}", CLIError)


def run(args):
    _check_outputs(args)
    _check_memory(args)
    if _is_partitioned(args):
        return run_partitioned(args)
    os.environ.setdefault("VTK_SMP_BACKEND_IN_USE", "STDThread")
    from tqdm.auto import tqdm

    from polygen.volume import isovalues, methods

    from polygen.cli import CLIError

    chosen = args.method or methods.names()
    unknown = [m for m in chosen if m not in methods.names()]
    if unknown:  # before any work
        raise CLIError(f"unknown method{'s' if len(unknown) > 1 else ''} {', '.join(map(repr, unknown))}; "
                       f"the methods are {', '.join(methods.names())}")
    if not args.value and args.values < 1:
        raise CLIError(f"--values needs at least 1; got {args.values}")
    progress = sys.stderr.isatty()
    helper = _early_helper(len(chosen))  # a first run: the warm-up's helper imports polygen while the volume loads
    try:
        label, vol = _load(args.mesh, progress, orient=args.orient, cell_data=args.cell_data,
                           tetrahedralize=args.tetrahedralize)
        args.field, how = choose_field(vol, args.field)
        s = vol.scalars(args.field)
        if args.value:
            values = np.asarray(args.value, float)
            if not np.isfinite(values).all():
                raise CLIError(f"--value must be finite; got {args.value}")
        else:
            values = isovalues(s, args.values)
    except BaseException:
        _end_helper(helper)
        raise
    print(f"{label}: {vol}; field {args.field!r} ({how}) in [{s.min():.6g}, {s.max():.6g}]; "
          f"{len(values)} values")
    # numba compiles each kernel on its first call (then loads it from its cache): run every
    # method once on a tiny volume of the same cell type, so that no column carries compilation
    import numba.core.event as ev

    compiled = ev.RecordingListener()  # numba's compile events: a kernel loaded from its cache makes none
    ev.register("numba:compile", compiled)
    warm_s = _warm_up(chosen, vol.cell_type, helper if helper is not None else True, n_cells=vol.n_cells)
    print(f"compiling kernels (once per install, then cached): {warm_s:.1f} s")
    # the volume's topology is shared by the methods: built once here, so that no method's
    # preprocessing column carries it
    compiled.buffer.clear()
    t0 = time.perf_counter()
    _build_topology(vol)
    t_topology, n = time.perf_counter() - t0, _n_compiled(compiled.buffer)
    print(f"topology (face neighbours, edges, boundary groups; shared by every method): {t_topology:.3f} s"
          + (f" (includes compiling {n} kernels the warm-up did not)" if n else ""))

    rows = []
    keep = None
    again = []  # methods measured again: "name (kernels)"
    t_again = 0.0
    for name in chosen:
        compiled.buffer.clear()
        row, surfaces = _measure(name, vol, args.field, values, keep is None, methods, tqdm, progress=progress)
        n = _n_compiled(compiled.buffer)
        if n:
            # a first run, and the volume took a path that the warm-up's tiny one did not (a size, a value
            # at a node): the method is measured again, its kernels compiled now, so that its row is the row
            # of a second run
            t0 = time.perf_counter()
            compiled.buffer.clear()
            row, surfaces = _measure(name, vol, args.field, values, keep is None, methods, tqdm, progress=progress)
            t_again += time.perf_counter() - t0
            again.append(f"{name} ({n})")
        row["compiled"] = _n_compiled(compiled.buffer)  # kernels compiled while timed: none, after the above
        if keep is None:
            keep = surfaces
        rows.append(row)
    ev.unregister("numba:compile", compiled)
    if again:
        print(f"measured again, having compiled kernels this volume takes (first run only): {', '.join(again)}: "
              f"{t_again:.1f} s")
    reference = rows[0]["_counts"]
    for r in rows:
        r["same_as_first"] = r.pop("_counts") == reference

    vtk_s = vtk_tris = None
    if args.compare_vtk:
        vtk_s, vtk_tris = _vtk_time(vol, args.field, values)
    _print_table(rows, vtk_s, vtk_tris)
    for v, iso in zip(values, keep):
        if iso.is_empty:
            print(f"value {v:.6g}: empty surface (0 triangles; {iso.cells_tested} cells tested)")
    if args.components:
        _print_components(values, keep, rows[0]["method"])

    if args.json:
        out = {"mesh": label, "cells": vol.n_cells, "cell_type": vol.cell_type, "values": values.tolist(),
               "methods": {r["method"]: {k: r[k] for k in ("preprocess_s", "query_s", "many_s", "cells_tested",
                                                           "triangles", "vertices", "same_as_first")}
                           for r in rows},
               "vtk_s": vtk_s, "vtk_triangles": vtk_tris}
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    if not args.no_files:
        _write_files(Path(args.output), label, vol, keep, values, rows[0]["method"])
    return 0 if all(r["same_as_first"] for r in rows) else 1



def _n_compiled(events):
    """The kernels (builds) compiled, from a :class:`numba.core.event.RecordingListener`'s ``buffer``."""
    return sum(1 for _, event in events if event.is_start)


def _measure(name, vol, field, values, keep, methods, tqdm, progress=False):
    """Prepare ``name`` on ``vol`` and time its queries: a table row, and the surfaces when ``keep``."""
    method = methods.get(name)(vol, field=field)
    method.extract(values[0])  # first call: thread pool start-up and dispatch, not timed
    query = 0.0
    tested = tris = verts = 0
    counts = []
    surfaces = []
    for v in tqdm(values, desc=name, disable=not progress, leave=False):
        t0 = time.perf_counter()
        iso = method.extract(v)
        query += time.perf_counter() - t0
        tested += iso.cells_tested
        tris += iso.n_triangles
        verts += iso.n_vertices
        counts.append(iso.n_triangles)
        if keep:
            surfaces.append(iso)
    many_s = None
    if type(method).extract_many is not methods.IsosurfaceMethod.extract_many and len(values) > 1:
        method.extract_many(values[:2])  # the other threads' buffers: allocated once, not timed
        t0 = time.perf_counter()
        many = method.extract_many(values)
        many_s = time.perf_counter() - t0
        if [i.n_triangles for i in many] != counts:
            raise RuntimeError(f"{name}: extract_many and extract disagree")  # a bug, never the user's
    return ({"method": name, "preprocess_s": method.preprocess_s, "query_s": query, "many_s": many_s,
             "cells_tested": tested, "triangles": tris, "vertices": verts, "_counts": counts}, surfaces)


def _print_table(rows, vtk_s, vtk_tris):
    head = f"{'method':20s} {'preprocess s':>12s} {'query s':>9s} {'cells tested':>13s} {'triangles':>10s} {'vertices':>10s}"
    if vtk_s is not None:
        head += f" {'VTK s':>7s} {'VTK/ours':>8s}"
    print(head)
    print("-" * len(head))
    for r in rows:
        line = (f"{r['method']:20s} {r['preprocess_s']:12.3f} {r['query_s']:9.3f} {r['cells_tested']:13d} "
                f"{r['triangles']:10d} {r['vertices']:10d}")
        if vtk_s is not None:
            line += f" {vtk_s:7.3f} {vtk_s / max(r['query_s'], 1e-12):8.2f}"
        if not r["same_as_first"]:
            line += "  (triangle counts differ from the first method!)"
        if r.get("compiled"):
            line += f"  (includes compiling {r['compiled']} kernels)"
        print(line)
    if vtk_tris is not None:
        print(f"VTK vtkContourFilter: {vtk_tris} triangles in {vtk_s:.3f} s")
    import numba

    for r in rows:
        if r["many_s"] is not None:
            line = f"{r['method']}, the same values {numba.get_num_threads()} at a time (extract_many): {r['many_s']:.3f} s"
            if vtk_s is not None:
                line += f" (VTK/ours {vtk_s / max(r['many_s'], 1e-12):.2f})"
            print(line)


def _print_components(values, surfaces, method, most=10):
    """One line per component (the ``most`` largest of each surface), from ``IsoSurface.components()``."""
    print(f"components (by {method}; volume: enclosed by a closed component, positive around lower values)")
    head = (f"{'value':>10s} {'#':>4s} {'triangles':>10s} {'area':>12s} {'volume':>12s} {'closed':>6s} "
            f"{'boundary':>8s}  bounds (x, y, z)")
    print(head)
    print("-" * len(head))
    for v, iso in zip(values, surfaces):
        c = iso.components()
        k = c["area"].shape[0]
        for i in range(min(k, most)):
            b = " ".join(f"{x:.4g}" for x in c["bounds"][i])
            vol = "-" if np.isnan(c["volume"][i]) else f"{c['volume'][i]:.6g}"
            print(f"{v:10.6g} {i:4d} {c['triangles'][i]:10d} {c['area'][i]:12.6g} {vol:>12s} "
                  f"{'yes' if c['closed'][i] else 'no':>6s} {'yes' if c['touches_boundary'][i] else 'no':>8s}  {b}")
        if k > most:
            print(f"{v:10.6g} and {k - most} smaller components ({int(c['triangles'][most:].sum())} triangles, "
                  f"area {c['area'][most:].sum():.6g})")
        elif k == 0:
            print(f"{v:10.6g} no components (empty surface)")


def _save(iso, path):
    """Write a surface, or a one-line error: VTK's writer reports a failure only in its (silenced) log."""
    from polygen.cli import CLIError

    if path.is_dir():
        raise CLIError(f"--output: a folder is in the way of the surface file {str(path)!r}")
    path.unlink(missing_ok=True)  # so that a file from an earlier run cannot pass for this one
    iso.to_pyvista().save(path)
    if not path.is_file():
        raise OSError(f"could not write the surface file {str(path)!r}")


def _write_files(out, label, vol, surfaces, values, method):
    out.mkdir(parents=True, exist_ok=True)
    written = 0
    for i, iso in enumerate(surfaces):
        if not iso.is_empty:
            _save(iso, out / f"{label}-iso{i:02d}.vtp")
            written += 1
    from polygen.plotting import setup_notebook
    from polygen.plotting.volume import plot_isosurface_grid

    png = out / f"{label}-isosurfaces.png"
    setup_notebook()
    # six of the surfaces, one per panel: twenty translucent ones stacked in one view hide each other
    plot_isosurface_grid(vol, surfaces).screenshot(str(png))
    print(f"wrote {written} surfaces (by {method}) and {png.name} to {out}/")
