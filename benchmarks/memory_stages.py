"""Peak RSS of each stage of loading, preparing and querying one cached data set.

Stages, one after the other in one process (numba kernels compiled or
loaded from the cache on data4 first, not counted): read the cached
arrays; the ``UnstructuredVolume`` constructor; the first surface
(``prepare=False``: the unprepared scan); the default method's
preparation (``active-scan``: the edge table through the node -> cells
lists, then the span-space table); 20 queries one at a time; then, off
the default path, the face neighbours and the boundary groups. Each stage's peak is read from ``VmHWM`` after
resetting it (``/proc/self/clear_refs`` = 5) at the stage's start: the
stage's peak above the RSS it started from is its temporaries plus what
it keeps.

    python benchmarks/memory_stages.py 2M 10M 80M   # each in its own process; writes results/memory_stages.*
    python benchmarks/memory_stages.py --one 2M [--budget BYTES] [--json out.json] [--npz FILE]
"""

import argparse
import gc
import json
import os
import sys
import time

import numpy as np


def _status(key):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    raise KeyError(key)


def _reset_peak():
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")


class Stages:
    def __init__(self, n_cells=1):
        self.rows = []
        self.n_cells = n_cells

    def run(self, name, fn):
        gc.collect()
        before = _status("VmRSS")
        _reset_peak()
        t0 = time.perf_counter()
        out = fn()
        t = time.perf_counter() - t0
        peak = _status("VmHWM")
        after = _status("VmRSS")
        self.rows.append(dict(stage=name, seconds=t, rss_before=before, peak=peak, rss_after=after))
        return out


def one(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("name")
    ap.add_argument("--field", default=None)
    ap.add_argument("--budget", type=float, default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--npz", default=None, help="read this cache file instead (a checkout without the name)")
    args = ap.parse_args(argv)

    from polygen.volume import UnstructuredVolume, datasets, isovalues
    from polygen.volume.datasets.registry import _key, _read_cache, cache_path

    # compile / load every kernel first, on data4 (560k cells: the parallel and blocked paths of the large ones)
    small = datasets.load("data4")
    for validate in (True, False):
        sv = UnstructuredVolume(small.points, small.cells, dict(small.fields), validate=validate)
        sv.isosurface(float(np.median(sv.scalars())), prepare=False)
    sv.face_neighbors, sv.n_boundary_groups
    for v in isovalues(sv.scalars(), 20):
        sv.isosurface(v, prepare=True)
    del small, sv
    gc.collect()
    base = _status("VmRSS")

    st = Stages()
    def read():
        if args.npz is None:
            return _read_cache(cache_path(args.name), _key(args.name, 0)[1])
        with np.load(args.npz) as z:
            return z["points"], z["cells"], {str(n): z[f"field_{i}"] for i, n in enumerate(z["field_names"])}

    points, cells, fields = st.run("read cache", read)
    field = args.field or next(iter(fields))
    s = fields[field]
    m = cells.shape[0]
    st.n_cells = m
    arrays = points.nbytes + cells.nbytes + sum(f.nbytes for f in fields.values())
    vol = st.run("constructor", lambda: UnstructuredVolume(points, cells, {field: s},
                                                          validate=m <= 1_000_000))
    del points, cells, fields
    gc.collect()
    values = isovalues(vol.scalars(), 20)
    st.run("first surface (unprepared scan)", lambda: vol.isosurface(values[10], prepare=False).n_triangles)
    kw = {} if args.budget is None else {"memory_budget": int(args.budget)}

    def prepare():
        from polygen.volume import methods
        meth = methods.get("active-scan")(vol, field=field, **kw)
        with vol._iso_lock:
            vol._iso_methods[(field, "active-scan")] = meth
        vol.release_preparation_tables()
        return meth

    meth = st.run("active-scan preparation", prepare)
    st.run("20 queries", lambda: [meth.extract(v).n_triangles for v in values])
    # not on the default method's path: the face neighbours (through the node -> cells lists) and the boundary
    # groups, for their cost on top of everything above
    st.run("(extra) face neighbours", lambda: vol.face_neighbors)
    st.run("(extra) boundary groups", lambda: vol.n_boundary_groups)
    peak_all = max(r["peak"] for r in st.rows if not r["stage"].startswith("(extra)"))  # the default path
    peak_extra = max(r["peak"] for r in st.rows)
    out = dict(name=args.name, cells=m, nodes=vol.n_points, field=field, base_rss=base, input_bytes=arrays,
               stages=st.rows, peak_rss=peak_all, peak_rss_with_extras=peak_extra, peak_over_base=peak_all - base,
               method_bytes=meth.scan.memory_bytes(), volume_bytes=vol.memory_bytes(),
               held=dict(points=vol.points.nbytes, cells=vol.cells.nbytes, field=vol.scalars().nbytes),
               load=os.getloadavg())
    print(f"{args.name}: {m} cells, {vol.n_points} nodes; base RSS {base / 2**20:.0f} MiB (after warm-up)")
    print(f"{'stage':36s} {'s':>7s} {'before':>9s} {'peak':>9s} {'after':>9s} {'peak-before B/cell':>19s} "
          f"{'kept B/cell':>12s}")
    for r in st.rows:
        print(f"{r['stage']:36s} {r['seconds']:7.2f} {r['rss_before'] / 2**20:9.0f} {r['peak'] / 2**20:9.0f} "
              f"{r['rss_after'] / 2**20:9.0f} {(r['peak'] - r['rss_before']) / m:19.1f} "
              f"{(r['rss_after'] - r['rss_before']) / m:12.1f}")
    print(f"peak RSS {peak_all / 2**20:.0f} MiB = {peak_all / m:.1f} B/cell; above the warm-up "
          f"{(peak_all - base) / m:.1f} B/cell; with the extras {peak_extra / 2**20:.0f} MiB")
    print("method", {k: round(v / m, 1) for k, v in meth.scan.memory_bytes().items()}, "B/cell")
    print("volume", {k: round(v / m, 1) for k, v in vol.memory_bytes().items()}, "B/cell")
    print("held", {k: round(v / m, 1) for k, v in out["held"].items()}, "B/cell; load", os.getloadavg())
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


def main(names):
    """Each data set in its own process (the peak of one is not the next one's floor); the results file."""
    import subprocess
    import tempfile
    from pathlib import Path

    from _common import RESULTS, machine

    rows = []
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "one.json"
            subprocess.run([sys.executable, __file__, "--one", name, "--json", str(out)], check=True)
            rows.append(json.loads(out.read_text()))
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "memory_stages.json").write_text(json.dumps({"machine": machine(), "rows": rows}, indent=1) + "\n")
    lines = ["# Peak RSS by stage: load, construct, prepare (active-scan), 20 queries", "",
             "Each data set in its own process, kernels compiled on data4 first; each stage's peak is `VmHWM` "
             "after resetting it at the stage's start. The face neighbours and boundary groups (extra) are not on "
             "the default method's path; they are measured last, for their cost on top of it.", ""]
    for r in rows:
        m = r["cells"]
        lines += [f"## {r['name']} ({m:,} cells, {r['nodes']:,} nodes, field {r['field']!r})", "",
                  f"Load average at the end {tuple(round(x, 2) for x in r['load'])}; RSS after the warm-up "
                  f"{r['base_rss'] / 2**20:.0f} MiB.", "",
                  "| stage | s | RSS before MiB | peak MiB | after MiB | peak - before, B/cell | kept, B/cell |",
                  "|---|---|---|---|---|---|---|"]
        for s in r["stages"]:
            lines.append(f"| {s['stage']} | {s['seconds']:.2f} | {s['rss_before'] / 2**20:.0f} | "
                         f"{s['peak'] / 2**20:.0f} | {s['rss_after'] / 2**20:.0f} | "
                         f"{(s['peak'] - s['rss_before']) / m:.1f} | {(s['rss_after'] - s['rss_before']) / m:.1f} |")
        lines += ["", f"**Peak RSS {r['peak_rss'] / 2**30:.2f} GiB = {r['peak_rss'] / m:.1f} bytes per cell** "
                  f"({(r['peak_rss'] - r['base_rss']) / m:.1f} above the warm-up; with the extras "
                  f"{r['peak_rss_with_extras'] / 2**30:.2f} GiB). Held at the end (the extras too), bytes "
                  "per cell: " + ", ".join(f"{k} {v / m:.1f}" for k, v in {**r["held"], **r["method_bytes"],
                                                                           **r["volume_bytes"]}.items()), ""]
    lines.append(f"Machine: {machine()}")
    (RESULTS / "memory_stages.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        sys.exit(one(sys.argv[2:]))
    sys.exit(main(sys.argv[1:] or ["2M"]))
