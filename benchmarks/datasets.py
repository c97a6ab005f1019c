"""Benchmark: build the thesis's data 1-5 from scratch, then load each from the cache.

Run ``python benchmarks/datasets.py`` (add ``--names 2M`` etc. for others).
The builds go into a fresh temporary cache directory, so nothing cached
before is reused (numba's own compile cache is, as in normal use). Writes
``benchmarks/results/datasets.json`` and ``benchmarks/results/datasets.md``.

Targets: all of data 1-5 built in < 3 minutes; each loaded from
the cache in < 2 s. The script reports; it does not fail on a missed target.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

from _common import machine  # benchmarks/ is the script's directory

RESULTS = Path(__file__).resolve().parent / "results"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", nargs="*", default=["data1", "data2", "data3", "data4", "data5"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--progress", action="store_true")
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args(argv)

    with tempfile.TemporaryDirectory(prefix="polygen-bench-") as tmp:
        os.environ["POLYGEN_CACHE_DIR"] = tmp
        from polygen.volume import datasets as ds

        # compile the numba kernels once on a tiny volume so that no build pays for it
        warm = ds.load("torus")
        ds.count_extrema(warm)
        rows = []
        t_all = time.perf_counter()
        for name in args.names:
            t0 = time.perf_counter()
            ds.build(name, seed=args.seed, progress=args.progress)
            t_build = time.perf_counter() - t0
            size = ds.cache_path(name, args.seed).stat().st_size
            t0 = time.perf_counter()
            vol = ds.load(name, seed=args.seed)
            t_load = time.perf_counter() - t0
            inf = ds.info(name)
            n_max, n_min = ds.count_extrema(vol, inf.fields[0])
            row = dict(
                name=name, cell_type=vol.cell_type, cells=vol.n_cells, target_cells=inf.target_cells,
                cell_ratio=round(vol.n_cells / inf.target_cells, 4), nodes=vol.n_points,
                boundary_cells=int(vol.boundary_cells.size), genus=vol.group_genus.tolist(), voids=vol.n_voids,
                field=inf.fields[0], maxima=n_max, minima=n_min, build_s=round(t_build, 2),
                load_s=round(t_load, 3), cache_mb=round(size / 2**20, 1), thesis=inf.thesis,
            )
            rows.append(row)
            print(json.dumps(row), flush=True)
        total = time.perf_counter() - t_all

    build_total = sum(r["build_s"] for r in rows)
    result = dict(
        machine=dict(platform=platform.platform(), cpus=os.cpu_count(), python=platform.python_version(),
                     **{k: v for k, v in machine().items() if k in ("commit", "date")}),
        note="the machine was shared with other jobs while this ran; timings are wall clock",
        build_total_s=round(build_total, 1),
        wall_total_s=round(total, 1),
        max_load_s=max(r["load_s"] for r in rows),
        rows=rows,
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "datasets.json").write_text(json.dumps(result, indent=2) + "\n")
    lines = [
        "# Data sets: build from scratch, then load from the cache",
        "",
        f"Machine: {result['machine']['platform']}, {result['machine']['cpus']} CPUs (shared with other jobs).",
        "",
        "| data | type | cells (thesis) | ratio | nodes (thesis) | boundary cells (thesis) | genus by group | voids "
        "| maxima + minima (thesis) | build s | load s | cache MB |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        th = r["thesis"]
        lines.append(
            f"| {r['name']} | {r['cell_type']} | {r['cells']} ({th.get('cells', '-')}) | {r['cell_ratio']:.3f} "
            f"| {r['nodes']} ({th.get('nodes', '-')}) | {r['boundary_cells']} ({th.get('boundary_cells', '-')}) "
            f"| {r['genus']} | {r['voids']} | {r['maxima']} + {r['minima']} = {r['maxima'] + r['minima']} "
            f"({th.get('extrema', '-')}) | {r['build_s']:.1f} | {r['load_s']:.2f} | {r['cache_mb']} |"
        )
    lines += [
        "",
        f"Build total: {build_total:.1f} s (target < 180 s). Slowest load from cache: {result['max_load_s']:.2f} s "
        "(target < 2 s).",
        "",
    ]
    (out / "datasets.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
