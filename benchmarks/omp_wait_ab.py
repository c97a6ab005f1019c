"""OpenMP's idle threads: spinning (libgomp's default) against sleeping soon (issue 20's preparation).

numba's ``omp`` threading layer is GNU libgomp. After each parallel region
its idle threads spin (``GOMP_SPINCOUNT``, 300,000 by default) before they
sleep. polygen's preparation runs parallel kernels from two or three Python
threads at once on a 2-core machine (the topology, then the thinning's
halves beside the edge records and the boundary checks), so a spinning
thread takes a core from a thread with work.

Arms, each in a fresh process (libgomp reads its environment when it loads),
interleaved ``ROUNDS`` times:

* ``default``: the environment as it is;
* ``passive``: ``OMP_WAIT_POLICY=passive`` (idle threads sleep at once);
* ``spin1000``: ``GOMP_SPINCOUNT=1000``.

Each process measures, on 2M (field ``fem``): the full preparation of the
default method on a fresh volume (``PREP_REPEATS`` times, the median), then
the 20-value sweep of the prepared method, one surface at a time, with
``threads=2`` and with ``threads="auto"`` (``SWEEP_REPEATS`` interleaved
repeats; per value the median; the sum and max over the values). On 10M
(field ``gaussians``): the preparation only.

Criterion, written before the first measurement: an arm is adopted as
polygen's default when, over the rounds' medians, its 2M and 10M
preparations are both at least 5 % faster than ``default``'s, and its 2M
sweep sum and largest surface (``threads=2`` and ``"auto"``) are no more
than 5 % slower.

    python benchmarks/omp_wait_ab.py
"""

import json
import os
import subprocess
import sys
import time

import numpy as np

from _common import write_results

ARMS = {"default": {}, "passive": {"OMP_WAIT_POLICY": "passive"}, "spin1000": {"GOMP_SPINCOUNT": "1000"}}
ROUNDS = 3
PREP_REPEATS = 5
SWEEP_REPEATS = 3


def prep_times(name, field, repeats):
    from polygen.volume import datasets, methods
    from polygen.volume.mesh import UnstructuredVolume
    v0 = datasets.load(name)
    s = v0.scalars(field)
    out = []
    for _ in range(repeats):
        vol = UnstructuredVolume(v0.points, v0.cells, {field: s}, validate=False)
        t0 = time.perf_counter()
        m = methods.get(methods.DEFAULT)(vol, field=field)
        out.append(time.perf_counter() - t0)
        del m, vol
    return out


def sweep(name, field):
    from polygen.volume import datasets, isovalues, methods
    vol = datasets.load(name)
    s = vol.scalars(field)
    m = methods.get(methods.DEFAULT)(vol, field=field)
    values = isovalues(s, 20)
    seeds = [m.source.query(v).cells for v in values]
    b = m.builder
    kinds = [2, "auto"]
    for v, sd in zip(values, seeds):  # warm
        for k in kinds:
            b.extract(v, sd, threads=k)
    wall = {k: np.zeros((SWEEP_REPEATS, len(values))) for k in kinds}
    for r in range(SWEEP_REPEATS):
        for i, (v, sd) in enumerate(zip(values, seeds)):
            for k in (kinds if r % 2 == 0 else kinds[::-1]):
                t0 = time.perf_counter()
                b.extract(v, sd, threads=k)
                wall[k][r, i] = time.perf_counter() - t0
    out = {}
    for k in kinds:
        per = np.median(wall[k], axis=0) * 1e3
        out[str(k)] = {"sum_ms": float(per.sum()), "max_ms": float(per.max()), "median_ms": float(np.median(per))}
    return out


def worker():
    from polygen.volume import datasets
    res = {"prep_2M": prep_times("2M", "fem", PREP_REPEATS)}
    res["sweep_2M"] = sweep("2M", "fem")
    if datasets.is_cached("10M"):
        res["prep_10M"] = prep_times("10M", "gaussians", 3)
    print(json.dumps(res))


def main():
    # compile / load every kernel once, outside the timed processes
    subprocess.run([sys.executable, __file__, "--warm"], check=True)
    runs = {a: [] for a in ARMS}
    load0 = os.getloadavg()
    for r in range(ROUNDS):
        order = list(ARMS) if r % 2 == 0 else list(ARMS)[::-1]
        for arm in order:
            env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
            env.update(ARMS[arm])
            env["POLYGEN_OMP_WAIT"] = "keep"  # the arm's environment as it is, whatever polygen would set
            out = subprocess.run([sys.executable, __file__, "--worker"], env=env, check=True,
                                 capture_output=True, text=True).stdout
            runs[arm].append(json.loads(out.strip().splitlines()[-1]))
            print(arm, runs[arm][-1], flush=True)
    load1 = os.getloadavg()
    rows = []
    for arm, rs in runs.items():
        row = {"arm": arm, "env": " ".join(f"{k}={v}" for k, v in ARMS[arm].items()) or "(as is)"}
        row["prep_2M_s"] = float(np.median([np.median(x["prep_2M"]) for x in rs]))
        if all("prep_10M" in x for x in rs):
            row["prep_10M_s"] = float(np.median([np.median(x["prep_10M"]) for x in rs]))
        for k in ("2", "auto"):
            row[f"sweep_{k}_sum_ms"] = float(np.median([x["sweep_2M"][k]["sum_ms"] for x in rs]))
            row[f"sweep_{k}_max_ms"] = float(np.median([x["sweep_2M"][k]["max_ms"] for x in rs]))
            row[f"sweep_{k}_median_ms"] = float(np.median([x["sweep_2M"][k]["median_ms"] for x in rs]))
        rows.append(row)
    base = rows[0]
    for row in rows[1:]:
        ok = row["prep_2M_s"] <= 0.95 * base["prep_2M_s"]
        if "prep_10M_s" in row and "prep_10M_s" in base:
            ok &= row["prep_10M_s"] <= 0.95 * base["prep_10M_s"]
        for k in ("2", "auto"):
            ok &= row[f"sweep_{k}_sum_ms"] <= 1.05 * base[f"sweep_{k}_sum_ms"]
            ok &= row[f"sweep_{k}_max_ms"] <= 1.05 * base[f"sweep_{k}_max_ms"]
        row["criterion met"] = bool(ok)
    columns = ["arm", "env", "prep_2M_s", "prep_10M_s", "sweep_2_sum_ms", "sweep_2_max_ms", "sweep_2_median_ms",
               "sweep_auto_sum_ms", "sweep_auto_max_ms", "sweep_auto_median_ms", "criterion met"]
    notes = [f"{ROUNDS} rounds, arms interleaved (order reversed every other round), each arm a fresh process; "
             f"per process the median of {PREP_REPEATS} preparations (3 at 10M) and per value the median of "
             f"{SWEEP_REPEATS} repeats; the table gives the median over the rounds",
             "criterion (fixed before measuring): both preparations >= 5 % faster than default, the 2M sweep's "
             "sum and max (threads=2 and auto) <= 5 % slower",
             f"load average before {tuple(round(x, 2) for x in load0)}, after {tuple(round(x, 2) for x in load1)}",
             "per-round figures in the JSON"]
    for row, (arm, rs) in zip(rows, runs.items()):
        row["rounds"] = rs
    write_results("omp_wait_ab", rows, columns, title="OpenMP idle threads: spin or sleep (issue 20)", notes=notes)


if __name__ == "__main__":
    if "--worker" in sys.argv:
        worker()
    elif "--warm" in sys.argv:
        prep_times("data4", "fem", 1)
        sweep("data4", "fem")
    else:
        main()
