"""Interactive isosurfaces: polygen against the strongest VTK configuration.

Per data set (field ``fem``; data4 and 2M by default, 10M when named and
cached):

* **20-value sweep**, ``linspace(min, max, 22)[1:-1]``: VTK's
  ``vtkContourFilter`` and ``vtkContour3DLinearGrid``, each without and
  with ``vtkSpanSpace`` (merged points, normals on, scalars off,
  ``VTK_SMP_BACKEND_IN_USE=STDThread``); polygen's prepared default method
  (``active-scan``) and the cell-edge-centred construction with the edge
  table (``edge-centred-table``, the default before), each one value at a
  time and by ``extract_many``, the paper's variant without stored edges
  (``edge-centred``), the full scan and the unprepared scan (mean normals on). Repeats are interleaved
  (every configuration once per round); the table gives medians over the
  rounds. The best VTK configuration is the fastest median of the four,
  chosen in this run.
* **single-isosurface latency**: median and max over the 20 values (each
  value's median over the rounds) and over 200 values
  (``linspace(min, max, 202)[1:-1]``, one pass), polygen's prepared method
  and the best VTK configuration.
* **time to the first surface** from arrays in memory: polygen's
  constructor (with its validation) then ``vol.isosurface(v)`` on the
  fresh volume (the unprepared scan answers; the preparation starts in
  the background), against VTK's grid construction and its first
  ``vtkContourFilter`` update (no tree) on that fresh grid; then the
  preparation of the default method until it is ready, and alone on a
  fresh volume (edge table, span-space table); and alone the preparation
  of ``edge-centred-table`` (topology, thinning, records).
* **memory**: bytes per cell held by each of the two prepared methods and
  by the volume's derived tables (``memory_bytes()``); and the peak RSS of each
  side, each in its own subprocess (arrays loaded from a ``.npy`` file,
  then: polygen's constructor, first surface, preparation and a sweep; or
  VTK's grid and a sweep in the best configuration), with the RSS after
  loading the arrays subtracted as well.

The machine's load average is recorded before and after. Results go to
``benchmarks/results/interactive.{json,md}``.

    python benchmarks/interactive.py                # data4, 2M
    python benchmarks/interactive.py data4 2M 10M   # 10M only if cached (building it takes long)
    python benchmarks/interactive.py --only first 2M   # quick: constructor, first surface, preparation, memory
    python benchmarks/interactive.py 80M            # polygen and VTK each in a process of its own (see below)

80M (when cached: ``polygen.volume.datasets.load("80M")`` builds it, 2.5 min) runs every part with
polygen and VTK each in a process of its own, both alive, the rounds interleaved between them: one
process holding VTK's grid and span spaces beside polygen's prepared volume would not fit 24 GiB.
``--own-processes`` runs the named data sets that way too. A run without data4 and 2M (80M alone)
writes ``interactive_<names>.{json,md}`` beside the full results.

80M takes ``--only first`` too (each side's first surface and its peak memory so far, no sweeps).
``--only`` takes a comma-separated subset of ``first`` (constructor, first
surface, preparation, memory), ``sweeps`` and ``rss``; a partial run writes
``interactive_<parts>.{json,md}`` beside the full results instead of
replacing them. Wall and CPU seconds (``time.process_time``, every thread)
are both given for the constructor and the preparation: on a shared
machine the CPU seconds say what the code costs.
"""

import os

os.environ["VTK_SMP_BACKEND_IN_USE"] = "STDThread"  # before anything imports vtk

import gc  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import RESULTS, machine, vtk_contour  # noqa: E402
from polygen.volume import UnstructuredVolume, datasets, isovalues, methods  # noqa: E402

DATA = ["data4", "2M"]
FIELD = "fem"
VTK_CONFIGS = [("vtkContourFilter", False), ("vtkContourFilter+SpanSpace", True),
               ("vtkContour3DLinearGrid", False), ("vtkContour3DLinearGrid+SpanSpace", True)]


def rounds(n_cells):
    return 5 if n_cells < 5_000_000 else 3


# ------------------------------------------------------------------ VTK
def vtk_grid(points, cells, s):
    import pyvista as pv
    from vtk.util.numpy_support import numpy_to_vtk

    grid = pv.UnstructuredGrid({pv.CellType.TETRA if cells.shape[1] == 4 else pv.CellType.HEXAHEDRON: cells},
                               points)
    arr = numpy_to_vtk(np.ascontiguousarray(s), deep=True)
    arr.SetName(FIELD)
    grid.GetPointData().SetScalars(arr)
    return grid


def vtk_filter(grid, label):
    """A configured filter and ``one(v) -> n_triangles``."""
    f, one = vtk_contour(grid, FIELD, linear_grid=label.startswith("vtkContour3DLinearGrid"),
                         span_space=label.endswith("+SpanSpace"))
    return f, lambda v: one(v)[0]


# ------------------------------------------------------------------ helpers
def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return time.perf_counter() - t0, out


def per_value(one, values):
    """(seconds per value, results)."""
    ts, out = [], []
    for v in values:
        t, r = timed(one, v)
        ts.append(t)
        out.append(r)
    return ts, out


def rss_now_mb(key="VmRSS"):
    """This process's resident set (``VmRSS``) or its peak (``VmHWM``), MB. (Not ``ru_maxrss``:
    a child started by ``subprocess`` inherits its parent's value there.)"""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


#: polygen's methods in the sweeps: the prepared default (the active-cell scan), the edge-centred construction
#: with the edge table (the default before), the paper's walk, the two scans
POLYGEN = tuple(dict.fromkeys((methods.DEFAULT, "edge-centred-table", "edge-centred", "scan", "unprepared-scan")))
#: the methods timed by extract_many too (the edge-centred table runs values side by side there)
MANY = tuple(dict.fromkeys((methods.DEFAULT, "edge-centred-table")))


def warm_up():
    """Compile (or load from the cache) every kernel used below, so that no timing includes JIT."""
    # the background preparation on data4 (560,860 cells): from 200,000 cells it takes other paths (the
    # thinning's halves and helper thread, the records beside the seeds), whose kernels data1 would leave
    # to compile inside the first large data set's "background preparation ready" (2M: 18 s instead of 2)
    big = datasets.load("data4")
    s = big.scalars(FIELD)
    fresh = UnstructuredVolume(big.points, big.cells, {FIELD: s})
    fresh.isosurface(isovalues(s, 3)[0])
    fresh.wait_prepared()
    del fresh, big
    vol = datasets.load("data1")
    s = vol.scalars(FIELD)
    values = isovalues(s, 3)
    vtk_filter(vtk_grid(vol.points, vol.cells, np.array(s)), "vtkContourFilter")[1](values[0])  # pyvista, vtk
    for name in POLYGEN:
        m = methods.get(name)(vol, field=FIELD)
        for v in values:
            m.extract(v)
        m.extract_many(values)


# ------------------------------------------------------------------ parts
def timed_cpu(fn, *args):
    """``(wall s, CPU s of every thread of this process, result)``."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args)
    return time.perf_counter() - t0, time.process_time() - c0, out


#: constructor repeats (it is cheap: the median of several is steadier than one on a shared machine)
CTOR_REPEATS = 5


def first_surface(points, cells, s, value):
    """Time to the first surface from arrays: polygen vs VTK's first vtkContourFilter (no tree)."""
    ctor, vol = [], None
    for _ in range(CTOR_REPEATS):
        # one volume held at a time, as a user holds it (all five were held until the median was chosen)
        vol = None
        gc.collect()
        t, c, vol = timed_cpu(lambda: UnstructuredVolume(points, cells, {FIELD: s}))
        ctor.append((t, c))
    ctor.sort()
    t_ctor, c_ctor = ctor[len(ctor) // 2]
    t_first, iso = timed(lambda: vol.isosurface(value))
    t_ready, _ = timed(vol.wait_prepared)
    kind = type(iso).__name__
    # an edge-centred method's records move to huge pages in a background thread (EdgeCentredTable.settle):
    # waited for here, untimed, so that it does not run into the timings below (10M: 1-2 s of a core)
    vol.isosurface(value, prepare=True)
    _settle(vol._prepared(FIELD, methods.DEFAULT))
    del vol
    gc.collect()
    t_grid, grid = timed(vtk_grid, points, cells, s)
    _, one = vtk_filter(grid, "vtkContourFilter")
    t_vtk, n_vtk = timed(one, value)
    del grid
    gc.collect()
    # the full preparation alone, on a fresh volume (topology + the method), nothing else running: the
    # default method's, then the edge-centred table's (the default before)
    out = {}
    for key, name in (("", methods.DEFAULT), ("ect_", "edge-centred-table")):
        vol = UnstructuredVolume(points, cells, {FIELD: s}, validate=False)
        t_prep, c_prep, m = timed_cpu(lambda: methods.get(name)(vol, field=FIELD))
        vol.release_preparation_tables()  # as vol.isosurface() does once the default method is prepared
        _settle(m)
        out.update({f"{key}method": name, f"{key}prepare_alone_s": t_prep, f"{key}prepare_alone_cpu_s": c_prep,
                    f"{key}method_bytes": m.memory_bytes(), f"{key}volume_bytes": vol.memory_bytes()})
        if hasattr(m, "seed_preprocess_s") and hasattr(m, "construct_preprocess_s"):
            out[f"{key}prepare_phases"] = {
                "seeds_s": m.seed_preprocess_s, "records_s": m.construct_preprocess_s,
                "thinning": {k: v for k, v in m.source.structure.stats.items() if k.startswith("T_")}}
        del m, vol
        gc.collect()
    return {"ctor_s": t_ctor, "ctor_cpu_s": c_ctor,
            "first_isosurface_s": t_first, "ctor_plus_first_s": t_ctor + t_first,
            "first_answered_by": kind, "first_triangles": iso.n_triangles,
            "background_ready_after_s": t_first + t_ready,
            "vtk_grid_s": t_grid, "vtk_first_contour_s": t_vtk, "vtk_first_triangles": n_vtk, **out}


def _settle(m):
    """Wait for a prepared edge-centred method's move of its records to huge pages (nothing for the others)."""
    settle = getattr(getattr(m, "builder", None), "settle", None)
    if settle is not None:
        settle()


def sweeps(vol, grid, values, values200, n_rounds):
    """Interleaved rounds of every configuration; per-value seconds per round."""
    confs = {}
    for label, _ in VTK_CONFIGS:
        f, one = vtk_filter(grid, label)
        t0 = time.perf_counter()
        one(values[0])  # builds the span space, if any
        confs[label] = {"one": one, "filter": f, "build_s": time.perf_counter() - t0}
    prepared = {name: methods.get(name)(vol, field=FIELD) for name in POLYGEN}
    for m in prepared.values():  # the records' move to huge pages, in the background, done before timing
        _settle(m)
    times = {k: [] for k in list(confs) + [f"polygen {name}" for name in POLYGEN] +
             [f"polygen {name} extract_many" for name in MANY]}
    tris = {}
    for _ in range(n_rounds):
        for label, c in confs.items():
            ts, out = per_value(c["one"], values)
            times[label].append(ts)
            tris[label] = out
        for name, m in prepared.items():
            ts, out = per_value(m.extract, values)
            times[f"polygen {name}"].append(ts)
            tris[f"polygen {name}"] = [i.n_triangles for i in out]
            del out
        for name in MANY:
            t, out = timed(prepared[name].extract_many, values)
            times[f"polygen {name} extract_many"].append([t / len(values)] * len(values))
            tris[f"polygen {name} extract_many"] = [i.n_triangles for i in out]
            del out
        gc.collect()
    rows = {}
    for k, per_round in times.items():
        a = np.array(per_round)  # (rounds, values)
        med_value = np.median(a, axis=0)
        rows[k] = {"sweep_s": float(np.median(a.sum(axis=1))), "latency_median_s": float(np.median(med_value)),
                   "latency_max_s": float(med_value.max()), "triangles": int(sum(tris[k])),
                   "same_counts_as_vtkContourFilter": tris[k] == tris["vtkContourFilter"]}
    vtk_best = min((lbl for lbl, _ in VTK_CONFIGS), key=lambda lbl: rows[lbl]["sweep_s"])
    # 200 values, one pass each: polygen's prepared method and the best VTK configuration
    ts, _ = per_value(prepared[methods.DEFAULT].extract, values200)
    rows[f"polygen {methods.DEFAULT}"].update(latency200_median_s=float(np.median(ts)), latency200_max_s=float(max(ts)))
    ts, _ = per_value(confs[vtk_best]["one"], values200)
    rows[vtk_best].update(latency200_median_s=float(np.median(ts)), latency200_max_s=float(max(ts)))
    for label, c in confs.items():
        rows[label]["build_s"] = c["build_s"]
    return rows, vtk_best


# ------------------------------------------------------------------ RSS workers
def worker(side, path, value):
    """Run one side in this process and print its peak RSS (MB) as JSON."""
    points = np.load(f"{path}_points.npy")
    cells = np.load(f"{path}_cells.npy")
    s = np.load(f"{path}_s.npy")
    values = isovalues(s, 20)
    if side == "polygen":
        warm_up()
    else:
        import pyvista  # noqa: F401  (the libraries are loaded before the baseline, as polygen's warm-up does)
        import vtk  # noqa: F401
    gc.collect()
    base = rss_now_mb()
    if side == "polygen":
        vol = UnstructuredVolume(points, cells, {FIELD: s})
        vol.isosurface(value)
        vol.wait_prepared()
        for v in values:
            vol.isosurface(v)
        vol.isosurface(value, prepare=True).n_triangles
        vol._iso_methods[(FIELD, methods.DEFAULT)].extract_many(values)
    else:
        grid = vtk_grid(points, cells, s)
        label = sys.argv[5]
        _, one = vtk_filter(grid, label)
        for v in values:
            one(v)
    peak = rss_now_mb("VmHWM")
    print(json.dumps({"peak_rss_mb": peak, "rss_after_loading_mb": base}))


def rss(side, path, value, label=""):
    cmd = [sys.executable, __file__, "--worker", side, path, repr(float(value)), label]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=os.environ)
    return json.loads(out.stdout.strip().splitlines()[-1])


# ------------------------------------------------------------------ two processes (80M)
#: data sets whose two sides run in processes of their own, both alive, the rounds interleaved between them:
#: one process holding VTK's grid and span spaces beside polygen's prepared volume would not fit 24 GiB
OWN_PROCESSES = ("80M",)
#: the line prefix of a side's answers on its stdout (anything else there is a library's print)
ANSWER = "@@ "


def _answer(obj):
    print(ANSWER + json.dumps(obj), flush=True)


def side_main(side, name):
    """One side of :func:`run_own_processes`: loads ``name``, answers ``ready`` with its first-surface
    timings, then one answer per command on stdin (``round``, ``200 LABEL``, ``end``)."""
    loaded = datasets.load(name)
    field = FIELD if FIELD in loaded.fields else next(iter(loaded.fields))
    points, cells, s = loaded.points, loaded.cells, np.array(loaded.scalars(field))
    del loaded
    values, values200 = isovalues(s, 20), isovalues(s, 200)
    first_value = values[len(values) // 2]
    if side == "polygen":
        warm_up()
    else:
        import pyvista  # noqa: F401  (the libraries are loaded before the baseline, as polygen's warm-up does)
        import vtk  # noqa: F401
    gc.collect()
    base = rss_now_mb()
    ready = {"cells": int(cells.shape[0]), "nodes": int(points.shape[0]), "field": field,
             "array_bytes": int(points.nbytes + cells.nbytes + s.nbytes)}
    if side == "polygen":
        t_ctor, c_ctor, vol = timed_cpu(lambda: UnstructuredVolume(points, cells, {FIELD: s}))
        del points, cells  # the volume holds its own copies
        t_first, iso = timed(lambda: vol.isosurface(first_value))
        t_ready, _ = timed(vol.wait_prepared)
        method = vol._prepared(FIELD, methods.DEFAULT)
        ready.update(ctor_s=t_ctor, ctor_cpu_s=c_ctor, ctor_repeats=1, first_isosurface_s=t_first,
                     ctor_plus_first_s=t_ctor + t_first, first_answered_by=type(iso).__name__,
                     first_triangles=int(iso.n_triangles), background_ready_after_s=t_first + t_ready,
                     method=methods.DEFAULT, rss_prepared_mb=rss_now_mb())
        del iso
        method.extract_many(values[:2])  # the other threads' buffers: allocated once, not timed
    else:
        t_grid, grid = timed(vtk_grid, points, cells, s)
        del points, cells
        _, one = vtk_filter(grid, "vtkContourFilter")
        t_vtk, n_vtk = timed(one, first_value)
        ready.update(vtk_grid_s=t_grid, vtk_first_contour_s=t_vtk, vtk_first_triangles=int(n_vtk))
        confs = {}
        for label, _ in VTK_CONFIGS:
            _, one = vtk_filter(grid, label)
            t_build, _ = timed(one, values[0])  # builds the span space, if any
            confs[label] = {"one": one, "build_s": t_build}
        ready["build_s"] = {label: c["build_s"] for label, c in confs.items()}
    _answer(ready)
    for line in sys.stdin:
        cmd = line.split()
        if cmd[0] == "round":
            out = {}
            if side == "polygen":
                ts, isos = per_value(method.extract, values)
                out[f"polygen {methods.DEFAULT}"] = (ts, [i.n_triangles for i in isos])
                del isos
                t, isos = timed(method.extract_many, values)
                out[f"polygen {methods.DEFAULT} extract_many"] = ([t / len(values)] * len(values),
                                                                  [i.n_triangles for i in isos])
                del isos
            else:
                for label, c in confs.items():
                    ts, counts = per_value(c["one"], values)
                    out[label] = (ts, [int(n) for n in counts])
            gc.collect()
            _answer(out)
        elif cmd[0] == "200":
            one = method.extract if side == "polygen" else confs[cmd[1]]["one"]
            ts = [timed(one, v)[0] for v in values200]  # each surface dropped at once: 200 of 80M's do not fit
            _answer(ts)
        else:  # end
            _answer({"peak_rss_mb": rss_now_mb("VmHWM"), "rss_after_loading_mb": base})
            return


class _Side:
    """A side process of :func:`run_own_processes`."""

    def __init__(self, side, name):
        self.proc = subprocess.Popen([sys.executable, __file__, "--side", side, name], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, env=os.environ)

    def read(self):
        for line in self.proc.stdout:
            if line.startswith(ANSWER):
                return json.loads(line[len(ANSWER):])
        raise RuntimeError(f"a side process ended without answering (exit code {self.proc.wait()})")

    def ask(self, cmd):
        self.proc.stdin.write(cmd + "\n")
        self.proc.stdin.flush()
        return self.read()


def run_own_processes(name, parts=("first", "sweeps", "rss")):
    """``run(name)`` with polygen and VTK each in a process of its own, both alive: polygen loads and prepares
    first (nothing else running), then VTK builds its grid and span spaces; then the rounds alternate between
    them (every VTK configuration, then polygen's prepared default one value at a time and by extract_many),
    and each process's peak RSS (VmHWM) is its memory column."""
    row = {"data": name, "own_processes": True, "load_before": tuple(round(x, 2) for x in os.getloadavg())}
    print(f"{name}: polygen's process (load, constructor, first surface, preparation)", file=sys.stderr)
    poly = _Side("polygen", name)
    first = poly.read()
    print(f"{name}: VTK's process (load, grid, first contour, span spaces)", file=sys.stderr)
    vtk_side = _Side("vtk", name)
    vfirst = vtk_side.read()
    row.update(cells=first.pop("cells"), nodes=first.pop("nodes"), field=first.pop("field"),
               array_bytes=first.pop("array_bytes"), rss_prepared_mb=first.pop("rss_prepared_mb"))
    builds = vfirst.pop("build_s")
    row["first"] = {**first, **{k: vfirst[k] for k in ("vtk_grid_s", "vtk_first_contour_s", "vtk_first_triangles")}}
    if "sweeps" not in parts:  # --only first: the first surfaces and each side's peak memory so far
        row["rss_polygen"], row["rss_vtk"] = poly.ask("end"), vtk_side.ask("end")
        for side in (poly, vtk_side):
            side.proc.wait()
        row["load_after"] = tuple(round(x, 2) for x in os.getloadavg())
        return row
    times, tris = {}, {}
    for r in range(rounds(row["cells"])):
        print(f"{name}: round {r + 1}", file=sys.stderr)
        for side in (vtk_side, poly):
            for k, (ts, counts) in side.ask("round").items():
                times.setdefault(k, []).append(ts)
                tris[k] = counts
    rows = {}
    for k, per_round in times.items():
        a = np.array(per_round)
        med_value = np.median(a, axis=0)
        rows[k] = {"sweep_s": float(np.median(a.sum(axis=1))), "latency_median_s": float(np.median(med_value)),
                   "latency_max_s": float(med_value.max()), "triangles": int(sum(tris[k])),
                   "same_counts_as_vtkContourFilter": tris[k] == tris["vtkContourFilter"]}
    for label, b in builds.items():
        rows[label]["build_s"] = b
    best = min((lbl for lbl, _ in VTK_CONFIGS), key=lambda lbl: rows[lbl]["sweep_s"])
    for side, key in ((poly, f"polygen {methods.DEFAULT}"), (vtk_side, best)):
        ts = side.ask(f"200 {best}")
        rows[key].update(latency200_median_s=float(np.median(ts)), latency200_max_s=float(max(ts)))
    row["sweeps"], row["vtk_best"] = rows, best
    row["rss_polygen"], row["rss_vtk"] = poly.ask("end"), vtk_side.ask("end")
    for side in (poly, vtk_side):
        side.proc.wait()
    row["load_after"] = tuple(round(x, 2) for x in os.getloadavg())
    return row


# ------------------------------------------------------------------ main
PARTS = ("first", "sweeps", "rss")


def run(name, parts=PARTS):
    if name in OWN_PROCESSES:
        if set(parts) not in (set(PARTS), {"first"}):
            raise SystemExit(f"{name} runs every part, or --only first, each side in its own process")
        return run_own_processes(name, parts)
    has_fem = FIELD in datasets.info(name).fields
    vol = datasets.load(name, field=FIELD if has_fem else None)
    field = FIELD if has_fem else next(iter(vol.fields))  # 10M, 80M: their analytic field, no FEM solve
    points, cells, s = vol.points.copy(), vol.cells.copy(), np.array(vol.scalars(field))
    if field != FIELD:
        vol = UnstructuredVolume(points, cells, {FIELD: s}, validate=False)
    values = isovalues(s, 20)
    values200 = isovalues(s, 200)
    first_value = values[len(values) // 2]
    row = {"data": name, "cells": int(vol.n_cells), "nodes": int(vol.n_points), "field": field}
    row["load_before"] = tuple(round(x, 2) for x in os.getloadavg())
    if "first" in parts:
        print(f"{name}: first surface", file=sys.stderr)
        row["first"] = first_surface(points, cells, s, first_value)
    if "sweeps" in parts or "rss" in parts:  # the RSS of VTK runs its best configuration of the sweeps
        print(f"{name}: sweeps", file=sys.stderr)
        vol.wait_prepared()
        grid = vtk_grid(points, cells, s)
        row["sweeps"], row["vtk_best"] = sweeps(vol, grid, values, values200, rounds(vol.n_cells))
        del grid
        gc.collect()
    row["array_bytes"] = int(points.nbytes + cells.nbytes + s.nbytes)
    row["load_after"] = tuple(round(x, 2) for x in os.getloadavg())
    if "rss" not in parts:
        return row
    print(f"{name}: rss", file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "arrays")
        np.save(f"{path}_points.npy", points)
        np.save(f"{path}_cells.npy", cells)
        np.save(f"{path}_s.npy", s)
        row["rss_polygen"] = rss("polygen", path, first_value)
        row["rss_vtk"] = rss("vtk", path, first_value, row["vtk_best"])
    del vol
    gc.collect()
    return row


def sweep_lines(r):
    sw, best = r["sweeps"], r["vtk_best"]
    bsw = sw[best]["sweep_s"]
    lines = [f"Best VTK configuration in this run: **{best}**.", "",
             "| configuration | 20 values s | / best VTK | latency median ms | max ms | "
             "200 values: median ms | max ms | triangles | same counts as vtkContourFilter |",
             "|---|---|---|---|---|---|---|---|---|"]
    for k, v in sw.items():
        l2m = v.get("latency200_median_s")
        l2x = v.get("latency200_max_s")
        lines.append(f"| {k} | {v['sweep_s']:.4f} | {v['sweep_s'] / bsw:.3f} | {1e3 * v['latency_median_s']:.2f} | "
                     f"{1e3 * v['latency_max_s']:.2f} | {'' if l2m is None else f'{1e3 * l2m:.2f}'} | "
                     f"{'' if l2x is None else f'{1e3 * l2x:.2f}'} | {v['triangles']} | "
                     f"{v['same_counts_as_vtkContourFilter']} |")
    return lines + [""]


def first_lines(r):
    f = r["first"]
    cpu = (lambda k: f" (CPU {f[k]:.3f})" if k in f else "")  # noqa: E731
    lines = ["| time to first surface | s |", "|---|---|",
             f"| polygen constructor (validation{', median of %d' % f.get('ctor_repeats', CTOR_REPEATS) if 'ctor_cpu_s' in f and f.get('ctor_repeats', CTOR_REPEATS) > 1 else ''}) | "
             f"{f['ctor_s']:.3f}{cpu('ctor_cpu_s')} |",
             f"| polygen first `vol.isosurface(v)` ({f['first_answered_by']}, {f['first_triangles']} triangles) "
             f"| {f['first_isosurface_s']:.3f} |",
             f"| polygen constructor + first surface | {f['ctor_plus_first_s']:.3f} |",
             f"| VTK grid from the arrays | {f['vtk_grid_s']:.3f} |",
             f"| VTK first vtkContourFilter, no tree ({f['vtk_first_triangles']} triangles) | "
             f"{f['vtk_first_contour_s']:.3f} |",
             f"| (constructor + first) / VTK first contour | {f['ctor_plus_first_s'] / f['vtk_first_contour_s']:.2f} |",
             f"| first surface alone / VTK first contour | {f['first_isosurface_s'] / f['vtk_first_contour_s']:.2f} |",
             f"| background preparation of `{f.get('method', methods.DEFAULT)}` ready, from the first call | "
             f"{f['background_ready_after_s']:.3f} |"]
    memory = ["", "| memory, bytes per cell | prepared method | volume's derived tables | together |", "|---|---|---|---|"]
    for key, what in (("", "edge table + span-space table"), ("ect_", "topology + thinning + edge-centred records")):
        if f"{key}method_bytes" not in f:
            continue
        name = f.get(f"{key}method", methods.DEFAULT)
        lines.append(f"| full preparation alone of `{name}` ({what}) | {f[f'{key}prepare_alone_s']:.3f}"
                     f"{cpu(f'{key}prepare_alone_cpu_s')} |")
        ph = f.get(f"{key}prepare_phases")
        if ph is not None:
            lines.append(f"| of which: seeds (thinning) {ph['seeds_s']:.3f}, edge records {ph['records_s']:.3f} "
                         "(side by side from 200k cells) | |")
        pm = f[f"{key}method_bytes"] / r["cells"]
        pv = sum(f[f"{key}volume_bytes"].values()) / r["cells"]
        tables = ", ".join(f"{k} {v / r['cells']:.1f}" for k, v in f[f"{key}volume_bytes"].items())
        memory.append(f"| `{name}` | {pm:.1f} | {pv:.1f} ({tables}) | {pm + pv:.1f} |")
    return lines + memory + [
        f"| input arrays (points, cells, field) | | | {r['array_bytes'] / r['cells']:.1f} |", ""]


def report(rows, load_before, load_after):
    lines = ["# Interactive isosurfaces: polygen vs the strongest VTK configuration", ""]
    for r in rows:
        lines += [f"## {r['data']} ({r['cells']:,} cells, {r['nodes']:,} nodes, field {r.get('field', FIELD)!r})", ""]
        if r.get("own_processes"):
            lines += ["polygen and VTK each in a process of its own, both alive (one process holding both would not "
                      "fit this machine's 24 GiB), the rounds interleaved between them; polygen's rows: the prepared "
                      "default method, one value at a time and by extract_many (the other methods' preparations "
                      "are not held at this size). polygen's resident set once prepared: "
                      f"{r['rss_prepared_mb'] / 1024:.2f} GiB.", ""]
        if "load_before" in r:
            lines += [f"Load average (1, 5, 15 min) before this data set {r['load_before']}, after {r['load_after']}.",
                      ""]
        if "sweeps" in r:
            lines += sweep_lines(r)
        if "first" in r:
            lines += first_lines(r)
        if "rss_polygen" in r:
            best = r.get("vtk_best", "its grid, first contour and span spaces")
            per_cell = (lambda mb: f"{mb * 2**20 / r['cells']:.1f}")  # noqa: E731
            lines += ["| peak memory | MB | bytes per cell |", "|---|---|---|"]
            for side, label in (("rss_polygen", "polygen"), ("rss_vtk", f"VTK, {best}")):
                peak, loaded = r[side]["peak_rss_mb"], r[side]["rss_after_loading_mb"]
                lines.append(f"| peak RSS {label} (above loaded arrays) | {peak:.0f} ({peak - loaded:.0f}) | "
                             f"{per_cell(peak)} ({per_cell(peak - loaded)}) |")
            lines.append("")
    lines += [
        "- 20 values linspace(min, max, 22)[1:-1] of 'fem'; medians over interleaved rounds (5, 3 at 10M); "
        "latency: each value's median over the rounds, then the median / max over the values; "
        "200 values: one pass; extract_many: its wall clock / 20 per value",
        "- VTK: merged points, normals on, scalars off, VTK_SMP_BACKEND_IN_USE=STDThread; the span-space build "
        "(inside the first update) is not in the sweep times (build_s in the JSON)",
        f"- polygen: mean normals on; '{methods.DEFAULT}' = the prepared default method (the 200 values too), "
        "'edge-centred-table' = the cell-edge-centred construction with the edge table (the default before "
        "the active-cell scan), 'edge-centred' = the paper's variant without stored edges, "
        "'unprepared-scan' = what vol.isosurface answers before the preparation is ready",
        "- peak RSS: each side in its own subprocess (VmHWM); polygen's includes the numba runtime and "
        "its warm-up on data1 and data4, and its background preparation",
        f"- machine load average (1, 5, 15 min) before {load_before}, after {load_after}; "
        f"{os.cpu_count()} CPUs shared with other jobs: times are indicative",
        f"- machine: {machine()}",
    ]
    return "\n".join(lines) + "\n"


def main(names, parts=PARTS):
    load_before = tuple(round(x, 2) for x in os.getloadavg())
    warm_up()
    rows = []
    for name in names:
        if name in ("10M", "80M") and not datasets.is_cached(name):
            print(f"{name} is not cached: skipped (building it takes longer than this benchmark)", file=sys.stderr)
            continue
        rows.append(run(name, parts))
        if "sweeps" in rows[-1]:
            print(json.dumps(rows[-1]["sweeps"][rows[-1]["vtk_best"]]), file=sys.stderr)
    load_after = tuple(round(x, 2) for x in os.getloadavg())
    RESULTS.mkdir(parents=True, exist_ok=True)
    stem = "interactive" if set(parts) == set(PARTS) else "interactive_" + "-".join(p for p in PARTS if p in parts)
    if not set(names) >= set(DATA):  # a run of other data sets (80M alone) sits beside the full results
        stem += "_" + "-".join(names)
    (RESULTS / f"{stem}.json").write_text(json.dumps(
        {"machine": machine(), "load_before": load_before, "load_after": load_after, "rows": rows}, indent=2) + "\n")
    (RESULTS / f"{stem}.md").write_text(report(rows, load_before, load_after))
    print(f"wrote {RESULTS / f'{stem}.md'}", file=sys.stderr)


def parse(argv):
    """``(names, parts)`` from ``[--only first,sweeps,rss] [names...]``."""
    parts = PARTS
    global OWN_PROCESSES
    if "--own-processes" in argv:  # every named data set the 80M way (a check of that path on a small one)
        argv = [a for a in argv if a != "--own-processes"]
        OWN_PROCESSES = tuple(argv)
    if "--only" in argv:
        i = argv.index("--only")
        parts = tuple(p for p in argv[i + 1].split(",") if p)
        argv = argv[:i] + argv[i + 2:]
        unknown = set(parts) - set(PARTS)
        if unknown or not parts:
            raise SystemExit(f"--only takes a comma-separated subset of {','.join(PARTS)}; got {sorted(unknown)}")
    return argv or DATA, parts


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    elif len(sys.argv) > 1 and sys.argv[1] == "--side":
        side_main(sys.argv[2], sys.argv[3])
    else:
        main(*parse(sys.argv[1:]))
