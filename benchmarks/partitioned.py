"""Partitioned volumes on Dask: preparation, query and bytes against the single-volume path.

One volume (default: the 2M data set, field ``fem``) split into 2, 4 and 8
partitions (Morton ranges of cells) on a ``LocalCluster`` of two worker
processes (one thread each), the default method (cell-edge-centred
construction from the thinning skeleton) on every partition; twenty values
``linspace(min, max, 22)[1:-1]``, mean normals:

* **single**: the method prepared on the whole volume here, the twenty
  values by ``extract_many`` (the yardstick) and one by one;
* **k partitions**: splitting here, preparation on the workers (wall clock,
  and each partition's own time), the twenty values by one
  ``extract_many`` call in each of two modes -- **stitched on the client**
  (``stitch_on="client"``, what ``"auto"`` picks on one machine: per chunk
  of five values, each partition extracts and reports its counts and seam
  vertices, the client lays out the stitched surfaces in a shared-memory
  block, each partition writes its rows of the stitched arrays into it, the
  client makes the seam normals; the 20 values in one chunk) and
  **on the workers** (a task per partition and chunk
  of values, the pieces merged pairwise on the workers up the tree of
  Morton neighbours, the stitched surfaces to the client) -- with the bytes
  that came to the client and moved between workers, the work per
  partition (t1 + t2 + t3, and the piece making), the client's wait and
  stitch, and the CPU seconds of the client process and of each worker
  process (the machine is shared: wall clocks include waiting for a core);
* every stitched surface is checked against the single volume's (triangle
  and vertex counts).

Query times are the best of two sweeps after a first one (``first_query_s``:
a partition builds its propagator for seam seeds at the first value that
needs one). Results go to
``benchmarks/results/partitioned.{json,md}``; the markdown also carries a
model on paper of a 1B-cell volume on 64 workers built from these numbers.

    python benchmarks/partitioned.py            # 2M, 2, 4 and 8 partitions
    python benchmarks/partitioned.py 10M 2      # another data set and partition counts (results/partitioned_10M.*)
    python benchmarks/partitioned.py 2M 2 client  # and only one mode
    python benchmarks/partitioned.py 10M 2 client cells,span  # and the split by span weights too
"""

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "2")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from _common import RESULTS, machine, write_results  # noqa: E402

SWEEP = 20
PARTITIONS = (2, 4, 8)
MODES = ("client", "workers")  # where the pieces are stitched (DaskPartitionedMethod.stitch_on)
REPEAT = 2
WORKERS = 2


def main(name="2M", parts=None, modes=None, splits="cells"):
    parts = PARTITIONS if parts is None else tuple(int(k) for k in parts.split(","))
    modes = MODES if modes is None else tuple(modes.split(","))
    splits = tuple(splits.split(","))
    from polygen.volume import datasets, isovalues, methods
    from polygen.volume.distributed import local_client
    from polygen.volume.distributed import prepare as dask_prepare
    from polygen.volume.partitioned import PartitionedVolume, span_weights

    vol = datasets.load(name)
    field = "fem" if "fem" in vol.fields else next(iter(vol.fields))
    values = isovalues(vol.scalars(field), SWEEP)
    # compile the kernels here (the workers load them from the cache)
    tiny = datasets.load("hollow_cube")
    PartitionedVolume.split(tiny, 2).prepare().extract_many([0.3, 0.6])

    t0 = time.perf_counter()
    vol.face_neighbors, vol.edges, vol.cell_edges, vol.boundary_faces
    topo_s = time.perf_counter() - t0
    m = methods.get(methods.DEFAULT)(vol, field=field)
    prep_single = topo_s + m.preprocess_s
    m.extract_many(values[:2])
    many, many_cpu = min(_cpu_timed(lambda: m.extract_many(values))[::2] for _ in range(2))
    one_by_one, ref = _timed(lambda: [m.extract(v) for v in values])
    tris = sum(r.n_triangles for r in ref)
    rows = [{"run": "single volume", "partitions": 1, "prepare_s": prep_single, "query_s": many,
             "query_one_by_one_s": one_by_one, "triangles": tris, "vs_single": 1.0}]
    print(f"{name}: {vol}; single: prepare {prep_single:.2f} s, 20 values {many:.3f} s (extract_many), "
          f"{one_by_one:.3f} s one by one; {tris} triangles")

    client = local_client(WORKERS)
    try:
        for k, how in [(k, how) for k in parts for how in splits]:
            t0 = time.perf_counter()
            pvol = PartitionedVolume.split(vol, k, weights=span_weights(vol, field) if how == "span" else None)
            split_s = time.perf_counter() - t0
            prepared = dask_prepare(pvol, field, client=client)
            # a first sweep of every value: a partition builds its propagator for seam seeds (cell records, ~1.2 s
            # on a 10M half) at the first value that misses a seam cell -- once, reported as first_query_s
            first_s, _ = _timed(lambda: [None for _ in prepared.extract_many(values)])
            # the two stitches on the same partitions, interleaved with the single volume (a shared machine's
            # load drifts): best of REPEAT each
            best = {mode: (float("inf"), None, None) for mode in modes}
            for _ in range(REPEAT):
                many, many_cpu = min((many, many_cpu), _cpu_timed(lambda: m.extract_many(values))[::2])
                for mode in modes:
                    prepared.stitch_on = mode
                    load = os.getloadavg()[0]
                    t, out, cpu, wcpu = _cpu_timed(lambda: prepared.extract_many(values), client)
                    # only what the rows need: the surfaces go, as the single volume's do between its sweeps (their
                    # memory is then reused: malloc's there, the shared-memory blocks here)
                    out = [_light(s) for s in out]
                    if t < best[mode][0]:
                        best[mode] = (t, out, dict(wait=prepared.wait_last, client=prepared.bytes_last,
                                                   blocks_made=getattr(prepared, "blocks_made_last", 0),
                                                   workers=prepared.bytes_workers_last, pieces=prepared.bytes_pieces_last,
                                                   phases=dict(getattr(prepared, "phases_last", {})), load=load, cpu=cpu, wcpu=wcpu))
            for mode in modes:
                t, surfaces, got = best[mode]
                ok = all(s.n_triangles == r.n_triangles and s.n_vertices == r.n_vertices
                         for s, r in zip(surfaces, ref))
                work, piece = np.zeros(k), np.zeros(k)
                for s in surfaces:
                    work += [p["t1"] + p["t2"] + p["t3"] for p in s.partitions]
                    piece += [p.get("piece_s", np.nan) for p in s.partitions]
                phases = got["phases"] if mode == "client" else {}
                cells = np.array([i["n_cells"] for i in prepared.infos])
                row = {"run": f"{k} partitions{' (span-weighted)' if how == 'span' else ''} on {WORKERS} workers, "
                              f"stitched on the {mode}", "partitions": k, "split": how,
                       "stitch_on": mode, "split_s": split_s,
                       "prepare_s": prepared.preprocess_s, "prepare_part_max_s": max(prepared.prepare_s),
                       "prepare_part_sum_s": sum(prepared.prepare_s), "first_query_s": first_s, "query_s": t, "wait_s": got["wait"],
                       "bytes_per_query": got["client"] / SWEEP, "bytes_per_triangle": got["client"] / max(tris, 1),
                       "bytes_workers_per_query": got["workers"] / SWEEP,
                       "bytes_pieces_per_query": got["pieces"] / SWEEP,
                       "crossed": sum(s.cells_intersected for s in surfaces),
                       "work_part_max_s": float(work.max()), "work_part_sum_s": float(work.sum()),
                       "piece_part_max_s": float(piece.max()),
                       "client_wait_s": phases.get("wait_s", float("nan")),
                       "client_stitch_s": phases.get("stitch_s", float("nan")), "load": got["load"],
                       "cpu_client_s": got["cpu"], "cpu_workers_s": "/".join(f"{c:.3f}" for c in got["wcpu"]),
                       "cpu_all_s": got["cpu"] + sum(got["wcpu"]), "blocks_made": got["blocks_made"],
                       "stitch_s": sum(s.stitch_s for s in surfaces),
                       "stitch_cpu_s": sum(s.stitch_cpu_s for s in surfaces),
                       "seam_vertices": sum(s.seam_vertices for s in surfaces),
                       "seam_seeds": sum(p["seam_seeds"] for s in surfaces for p in s.partitions),
                       "cells_per_part": int(cells.mean()), "triangles": sum(s.n_triangles for s in surfaces),
                       "same_as_single": ok}
                rows.append(row)
            rows[0]["query_s"] = many
            rows[0]["cpu_client_s"] = rows[0]["cpu_all_s"] = many_cpu
            for row in rows:
                row["vs_single"] = row["query_s"] / many
                row["cpu_vs_single"] = row["cpu_all_s"] / many_cpu
            for row in rows[-len(modes):]:
                print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()})
            prepared.close()
    finally:
        client.close()
        client.cluster.close()
    _write(name, vol, rows)


def _light(s):
    """What the rows read of a stitched surface (the surface itself is let go)."""
    from types import SimpleNamespace

    return SimpleNamespace(**{f: getattr(s, f) for f in ("n_triangles", "n_vertices", "partitions", "cells_intersected",
                                                          "stitch_s", "stitch_cpu_s", "seam_vertices")})


def _cpu_timed(fn, client=None):
    """Wall clock, result, this process's CPU seconds (all its threads) and, with ``client``, each worker
    process's (sorted by address): on a shared machine the CPU seconds say what the work cost, the wall
    clock also how long it waited for a core."""
    w0 = client.run(time.process_time) if client is not None else {}
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    t, c = time.perf_counter() - t0, time.process_time() - c0
    w1 = client.run(time.process_time) if client is not None else {}
    return t, out, c, [w1[a] - w0[a] for a in sorted(w1)]


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _write(name, vol, rows):
    cols = ["run", "prepare_s", "prepare_part_max_s", "first_query_s", "query_s", "vs_single", "load", "cpu_client_s",
            "cpu_workers_s", "cpu_all_s", "cpu_vs_single", "blocks_made", "work_part_max_s",
            "piece_part_max_s", "client_wait_s", "client_stitch_s", "stitch_s", "stitch_cpu_s", "bytes_per_query",
            "bytes_per_triangle", "bytes_workers_per_query", "bytes_pieces_per_query", "seam_vertices", "seam_seeds",
            "triangles", "same_as_single"]
    notes = [f"{name}: {vol.n_cells} {vol.cell_type} cells, {vol.n_points} nodes; {SWEEP} values "
             "linspace(min, max, 22)[1:-1], mean normals, the default method (edge-centred) on every partition",
             "single volume: prepare_s = topology + method preparation here; query_s = extract_many of the 20 values",
             f"k partitions: LocalCluster(n_workers={WORKERS}, threads_per_worker=1, processes=True); prepare_s = "
             "wall clock of preparing every partition on the workers (pieces sent from here) and checking the seams; "
             "first_query_s = the first sweep of the 20 values after it (a partition builds its propagator for seam "
             "seeds at the first value whose surface misses a seam cell); "
             "query_s = one extract_many of the 20 values, best of 2, interleaved with the single volume's (whose query_s "
             "is its best over the whole run; each sweep's surfaces are let go before the next, as the single "
             "volume's are): stitched on the client = through shared memory (every worker on this machine), the 20 "
             "values in one chunk (DIRECT_CHUNK_VALUES), two actor calls per partition and chunk -- find (extract, report counts and seam "
             "vertices) and write (the partition's rows straight into the stitched arrays, a block per chunk that "
             "the client laid out, written again by a later sweep once its surfaces are gone) -- the workers up to "
             "2 chunks ahead of the client's layout; the client makes the seam normals only; blocks_made: blocks "
             "made by that sweep (0: all written again); span-weighted: "
             "Morton ranges cut at equal total cell field range (span_weights: a sweep's expected crossings) instead "
             "of equal cell counts; on the workers = a task per "
             "partition and chunk of values, the pieces merged pairwise on the workers, the seam normals at the root, "
             "the surfaces to the client",
             "load: the 1-minute load average when the query started (this machine has 2 cores and is shared); "
             "cpu_client_s: CPU seconds of this process during the query (all its threads: the stitch, Dask's client "
             "and -- a LocalCluster -- its scheduler; single volume: the 2 numba threads of extract_many); "
             "cpu_workers_s: CPU seconds of each worker process (extraction, pieces, Dask); cpu_all_s: the sum (the "
             "single volume: its process's); cpu_vs_single: cpu_all_s over the single volume's",
             "work_part_max_s: the busiest partition's t1 + t2 + t3 over the 20 values (wall clock on its worker); "
             "piece_part_max_s: its piece making (stitched on the client: writing its rows -- global keys, positions, "
             "normals of its own vertices, triangles, cell ids); "
             "client_wait_s / client_stitch_s: the client's wait for the workers / its layout and finish (client stitch "
             "only); stitch_s / stitch_cpu_s: the merges and seam normals over the 20 values (wall clock / CPU time "
             "of their threads)",
             "bytes_per_query: what came to the client per value -- stitched on the client: the stitched arrays "
             "written by the workers into shared memory (keys, positions, normals, triangles and cell ids as int64) and "
             "the seam vertices' indices and keys (over TCP: the pieces, triangles and cell ids as int32); on "
             "the workers: the stitched surface (positions, normals, triangles and global cell ids as int32, global "
             "vertex keys); bytes_workers_per_query: pieces moved between workers per value (merge inputs made on the "
             "other worker)",
             "the machine is shared: wall clocks at a load above 2 include waiting for a core; compare the CPU seconds "
             "(at a high load the ratio of wall clocks also favours the partitioned run, whose three processes get a "
             "larger share of the cores than the single volume's one)",
             "where the overhead goes, stage by stage: partitioned_overhead.md"]
    path = write_results("partitioned" if name == "2M" else f"partitioned_{name}", rows, cols,
                         title=f"Partitioned volumes on Dask: {name}", notes=notes)
    model = _model(vol, rows)
    path.write_text(path.read_text() + "\n" + model)
    print(model)


def _model(vol, rows):
    """A 1B-cell volume on 64 workers, on paper (``polygen.volume.partitioned.scale_model``), from the 2-partition run."""
    from polygen.volume.partitioned import scale_model

    on_w = [r for r in rows if r.get("stitch_on") == "workers"]
    if not on_w:
        return "(no run stitched on the workers: no model of a 1B-cell volume)\n"
    r = next((r for r in on_w if r["partitions"] == 2), on_w[0])
    n, tri = vol.n_cells, r["triangles"] / SWEEP
    levels = max(1, int(np.ceil(np.log2(r["partitions"]))))
    rates = dict(n_cells=n, crossed_per_value=r["crossed"] / SWEEP, triangles_per_value=tri,
                 prepare_s_per_cell=r["prepare_part_sum_s"] / n, query_s_per_crossed_cell=r["work_part_sum_s"] / r["crossed"],
                 stitch_s_per_triangle=r["stitch_cpu_s"] / SWEEP / tri / levels,
                 piece_bytes_per_triangle=r["bytes_pieces_per_query"] / tri,
                 surface_bytes_per_triangle=r["bytes_per_query"] / tri)
    m = scale_model(**rates)
    lines = [
        "## Model: 1B cells on 64 workers (on paper, from the rates above)", "",
        f"Measured on {n} cells in {r['partitions']} partitions: preparation {rates['prepare_s_per_cell'] * 1e6:.3g} s "
        f"per million cells on one worker thread; {rates['crossed_per_value']:.0f} crossed cells and {tri:.0f} triangles "
        f"per value; extraction {rates['query_s_per_crossed_cell'] * 1e6:.3g} us per crossed cell; stitch (merge + "
        f"normals, CPU time) {rates['stitch_s_per_triangle'] * 1e9:.3g} ns per triangle per tree level; pieces "
        f"{rates['piece_bytes_per_triangle']:.1f} B and stitched surfaces {rates['surface_bytes_per_triangle']:.1f} B "
        "per triangle.", "",
        "Assumptions (`scale_model`): the same field shape on a finer mesh, so a surface crosses (cells)^(2/3) as many "
        f"cells and has as many more triangles (x{m['growth']:.0f}); one partition per worker, read where it lives; costs "
        "per cell and per crossed cell as measured, spread evenly; the stitch a tree of pairwise merges on the workers "
        f"({m['levels']} levels; the merges on the critical path handle 2 - 2/64 surfaces, the pieces moved along it one "
        "surface); 10 Gb/s links.", "",
        "| quantity | 1B cells on 64 workers |", "|---|---|",
        f"| preparation (per worker, in parallel) | {m['prepare_s']:.0f} s (+ reading 15.6M cells, ~0.5 GB per worker) |",
        f"| triangles per value | {m['triangles']:.3g} |",
        f"| extraction per value (per worker) | {m['extract_s']:.3g} s |",
        f"| stitch per value (merges on the critical path) | {m['stitch_s']:.3g} s |",
        f"| transfers on the critical path + to the client | {m['transfer_s']:.3g} s |",
        f"| bytes between workers per value | {m['bytes_between_workers'] / 1e6:.0f} MB |",
        f"| bytes to the client per value | {m['bytes_to_client'] / 1e6:.0f} MB |",
        f"| latency per value | ~{m['latency_s']:.3g} s |",
        f"| stitch, sweep of {SWEEP} values: tree on the workers / one client | {m['sweep_stitch_workers_s']:.3g} s / "
        f"{m['sweep_stitch_client_s']:.3g} s |",
        f"| client link, sweep of {SWEEP} values: stitched surfaces / every piece | {m['sweep_client_link_s'][0]:.3g} s / "
        f"{m['sweep_client_link_s'][1]:.3g} s |", "",
        "For one value the tree is no faster than one stitch on the client (its root merges the whole surface after "
        "the levels below); over a sweep it spreads the stitch over the workers, and the client's link carries "
        "stitched surfaces only.", "",
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main(*sys.argv[1:5])
    print(f"results in {RESULTS}/partitioned.md; {machine()}")
