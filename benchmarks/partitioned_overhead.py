"""Where a partitioned sweep's overhead goes: each stage's CPU seconds, and the Dask timeline.

The single volume's 20-value sweep against the same values split into 2
partitions, on a machine of 2 cores shared with other work -- so stages are
timed in CPU seconds of the thread that runs them (``time.thread_time``),
which say what a stage costs whatever the load:

* **local stages** (one thread, no Dask): the single volume value after
  value (mean normals, and without normals to see what the normals cost);
  per partition, what its worker does -- the method (no normals), the seam
  seeds and seam vertices (``find``), then its rows of the stitched arrays
  (global keys, positions, the normals of its own vertices, triangles
  renumbered, global cell ids) written into the shared-memory block of the
  value (``write``); and what the client does -- the layout (seam vertices
  matched, the block made) and ``finish`` (seam normals, the surface);
* **on Dask** (``LocalCluster`` of 2 workers, stitched on the client, best
  of 3 sweeps): every call's start and end on its worker and the client's
  phases on one clock (``time.perf_counter`` is the machine's monotonic
  clock on Linux), each worker's process CPU beside the CPU of its calls (the
  rest is Dask's), the workers' idle time between calls, and the client's
  wait, stitch and CPU (its process also runs the scheduler).

    python benchmarks/partitioned_overhead.py 2M
    python benchmarks/partitioned_overhead.py 10M

Results: ``benchmarks/results/partitioned_overhead_<name>.json`` (the
markdown table in ``partitioned_overhead.md`` is written by hand from them,
before and after each change).
"""

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from _common import RESULTS, machine  # noqa: E402

SWEEP = 20
REPEAT = 3


def _cpu(fn):
    c0 = time.thread_time()
    out = fn()
    return time.thread_time() - c0, out


def local_stages(vol, field, values, k=2):
    """CPU seconds of each stage over the sweep, one thread, no Dask (every surface kept, as a sweep keeps them)."""
    from polygen.volume import methods
    from polygen.volume.distributed import SharedMemoryPartition, _new_block, _unlink_quietly
    from polygen.volume.partitioned import PartitionedVolume, check_partitions, finish_rows, rows_arrays, rows_layout

    m = methods.get(methods.DEFAULT)(vol, field=field)
    m.extract(values[0])
    single, ref = _cpu(lambda: [m.extract(v) for v in values])
    ref_n = [(r.n_triangles, r.n_vertices) for r in ref]
    ref = None
    single_nonorm, _ = _cpu(lambda: [m.extract(v, normals=None) for v in values])
    _ = None
    pvol = PartitionedVolume.split(vol, k)
    parts = [SharedMemoryPartition(p, i, field, None, {}) for i, p in enumerate(pvol.pieces)]
    offsets, n_ids, shared = check_partitions([p.info for p in parts])
    for p, o in zip(parts, offsets):
        p.set_layout(o, n_ids, shared)
    # the client's side of DaskPartitionedMethod._run_direct, one value a chunk, without Dask: two passes, the
    # second timed; a block per value, made by the first pass and written again by the second (as a sweep's
    # blocks are once the surfaces of the sweep before are gone)
    blocks = {}
    for j, v in [(j, v) for _ in range(2) for j, v in enumerate(values)]:
        if j == 0:
            st = {s: np.zeros(k) for s in ("find", "write")}
            cl = dict.fromkeys(("layout", "finish"), 0.0)
            kept, tris = [], 0
        found = [p.find_shared([v], "mean", ("ov", j)) for p in parts]
        for i, a in enumerate(found):
            st["find"][i] += a["timing"]["cpu_s"]
        name = f"polygen-ov-{os.getpid()}-{j}"

        def layout():
            lay = rows_layout([a["found"][0] for a in found])
            if j not in blocks:
                blocks[j] = _new_block(name, max(rows_arrays(lay, "mean", empty=False)[1], 64))
            return lay, np.frombuffer(blocks[j], np.uint8)

        c, (lay, block) = _cpu(layout)
        cl["layout"] += c
        written = [p.write_shared(("ov", j), name, [{"n_vertices": lay["n_vertices"],
                                                      "n_triangles": lay["n_triangles"], "offset": 0,
                                                      "plan": lay["plans"][i]}], "mean") for i, p in enumerate(parts)]
        for i, a in enumerate(written):
            st["write"][i] += a["timing"]["cpu_s"]
        _unlink_quietly(name)
        c, s = _cpu(lambda: finish_rows(v, rows_arrays(lay, "mean", buf=block)[0], lay, [a["found"][0] for a in found],
                                        [a["written"][0] for a in written], n_ids=n_ids, normals="mean"))
        cl["finish"] += c
        assert (s.n_triangles, s.n_vertices) == ref_n[j]
        tris += s.n_triangles
        kept.append(s)
        block = s = None
    kept = None
    return {"single_s": single, "single_nonormals_s": single_nonorm, "triangles": tris} \
        | {f"worker_{s}_s": st[s].tolist() for s in st} | {f"client_{s}_s": cl[s] for s in cl}


def on_dask(vol, field, values, k=2):
    """The sweep on a LocalCluster of 2 workers, stitched on the client: the best of REPEAT, its timeline."""
    from polygen.volume.distributed import local_client
    from polygen.volume.distributed import prepare as dask_prepare
    from polygen.volume.partitioned import PartitionedVolume

    client = local_client(2)
    try:
        prepared = dask_prepare(PartitionedVolume.split(vol, k), field, client=client, stitch_on="client")
        prepared.extract_many(values)
        best = None
        for _ in range(REPEAT):
            w0 = client.run(time.process_time)
            load = os.getloadavg()[0]
            c0, t0 = time.process_time(), time.perf_counter()
            prepared.extract_many(values)
            t, c = time.perf_counter() - t0, time.process_time() - c0
            w1 = client.run(time.process_time)
            if best is None or t < best["query_s"]:
                calls = prepared.phases_last["calls"]
                best = {"query_s": t, "load": load, "client_cpu_s": c, "t0": t0,
                        "client_wait_s": prepared.phases_last["wait_s"],
                        "client_stitch_s": prepared.phases_last["stitch_s"], "calls": calls,
                        "workers_cpu_s": {prepared.placement.index(a): w1[a] - w0[a] for a in w1}}
        prepared.close()
    finally:
        client.close()
        client.cluster.close()
    calls, out = best.pop("calls"), best
    t0 = out.pop("t0")
    for i in range(k):
        mine = sorted((c for c in calls if c["partition"] == i), key=lambda c: c["start"])
        busy = sum(c["end"] - c["start"] for c in mine)
        out[f"part{i}"] = {
            "calls": len(mine), "cpu_s": sum(c["cpu_s"] for c in mine),
            "surface_cpu_s": sum(c["surface_cpu_s"] for c in mine), "piece_cpu_s": sum(c["piece_cpu_s"] for c in mine),
            "busy_s": busy, "first_start_s": mine[0]["start"] - t0, "last_end_s": mine[-1]["end"] - t0,
            "idle_between_s": mine[-1]["end"] - mine[0]["start"] - busy,
            "start_after_sent_s": [round(c["start"] - max(c["sent"], p["end"] if p else 0), 4)
                                   for p, c in zip([None] + mine[:-1], mine)],
            "gathered_after_end_s": [round(c["gathered"] - max(c["end"], c["waited"]), 4) for c in mine],
            "finds": sum(c["kind"] == "find" for c in mine), "writes": sum(c["kind"] == "write" for c in mine)}
    return out


def main(name="2M", what="local,dask"):
    from polygen.volume import datasets, isovalues

    vol = datasets.load(name)
    field = "fem" if "fem" in vol.fields else next(iter(vol.fields))
    values = isovalues(vol.scalars(field), SWEEP)
    vol.face_neighbors, vol.edges, vol.cell_edges, vol.boundary_faces
    out = {"data": name, "machine": machine()}
    if "local" in what:
        out["local"] = local_stages(vol, field, values)
        print(json.dumps(out["local"], default=float))
    if "dask" in what:
        out["dask"] = on_dask(vol, field, values)
        print(json.dumps(out["dask"], default=float, indent=1))
    (RESULTS / f"partitioned_overhead_{name}.json").write_text(json.dumps(out, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main(*sys.argv[1:3])
