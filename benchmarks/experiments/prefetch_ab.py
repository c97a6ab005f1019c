"""The edge-centred construction with and without its prefetch hints, and on huge pages.

The kernels of :mod:`polygen.volume._edge_centred_kernels` are chosen at
import (``POLYGEN_PREFETCH=0`` selects the plain ones: no ``llvm.prefetch``
hints, and a loop for the count of trailing zeros), so each arm runs in a
process of its own, and the arms are interleaved over ``ROUNDS`` rounds:

- ``prefetch``: the kernels as shipped;
- ``no prefetch``: ``POLYGEN_PREFETCH=0``;
- ``prefetch, huge pages``: as shipped since the records moved to huge pages
  (``EdgeCentredTable.HUGE_PAGES``): after the preparation a background
  thread collapses the builder's records and edge lists (the two large
  arrays the construction reads at random: 172 MB on 2M) into transparent
  huge pages (``MADV_COLLAPSE``, :func:`polygen._jit.collapse_to_huge_pages`),
  so a random record costs no page walk; the arm waits for it
  (``EdgeCentredTable.settle``) before timing and reports the wait. The two
  other arms set ``HUGE_PAGES = False`` (4 KiB pages, the layout before).

In each process: the 2M volume (field ``fem``), twenty isovalues
``linspace(min, max, 22)[1:-1]``, ``edge-centred-table`` prepared once and
the seeds searched beforehand; each value extracted with ``threads=1`` and
``threads=2`` alternately, ``REPEATS`` times; per value the median wall time
of ``extract`` (construction, positions, mean normals), then the sum and
the max over the values. Every arm must give the same serial surfaces (a
digest of the triangles and vertices) and 2-thread surfaces equal to the
serial ones (``same_surface``).

    python benchmarks/experiments/prefetch_ab.py          # 2M
    python benchmarks/experiments/prefetch_ab.py data4
"""

import hashlib
import json
import os
import subprocess
import sys
import time

import numpy as np

ARMS = {"prefetch": {"HUGE": "0"}, "no prefetch": {"POLYGEN_PREFETCH": "0", "HUGE": "0"},
        "prefetch, huge pages": {"HUGE": "1"}}
ROUNDS = 3
REPEATS = 5
COLUMNS = ["data", "arm", "1 thread: sum_ms", "1 thread: max_ms", "2 threads: sum_ms", "2 threads: max_ms",
           "per round (1 thread sum)", "huge-page wait s", "AnonHugePages MB", "same surfaces", "load"]


def _anon_huge_mb():
    for line in open("/proc/self/smaps_rollup"):
        if line.startswith("AnonHugePages"):
            return int(line.split()[1]) >> 10
    return -1


def child(name):
    """One arm in this process: prints a JSON line."""
    from polygen.volume import _edge_centred_kernels as k
    from polygen.volume import datasets, isovalues, methods
    from polygen.volume.surface import same_surface

    from polygen.volume.edge_centred import EdgeCentredTable

    EdgeCentredTable.HUGE_PAGES = os.environ.get("HUGE") == "1"
    vol = datasets.load(name)
    m = methods.get("edge-centred-table")(vol, field="fem")
    b = m.builder
    t0 = time.perf_counter()
    b.settle()  # the background collapse to huge pages (HUGE=1), finished before timing
    copy_s = time.perf_counter() - t0
    values = isovalues(vol.scalars("fem"), 20)
    seeds = [m.source.query(v).cells for v in values]
    digest = hashlib.sha1()
    same = True
    for v, sd in zip(values, seeds):  # compile, warm, check
        ref = b.extract(v, sd, threads=1)
        digest.update(ref.triangles.tobytes())
        digest.update(ref.vertices.tobytes())
        same &= bool(same_surface(ref, b.extract(v, sd, threads=2)))
    wall = {th: np.zeros((REPEATS, len(values))) for th in (1, 2)}
    for r in range(REPEATS):
        for i, (v, sd) in enumerate(zip(values, seeds)):
            for th in ((1, 2) if r % 2 == 0 else (2, 1)):
                t0 = time.perf_counter()
                b.extract(v, sd, threads=th)
                wall[th][r, i] = time.perf_counter() - t0
    out = {"prefetch": bool(k.PREFETCH), "digest": digest.hexdigest(), "same": same, "copy_s": copy_s,
           "huge_mb": _anon_huge_mb(), "load": os.getloadavg()[0]}
    for th in (1, 2):
        per_value = np.median(wall[th], axis=0) * 1e3
        out[f"sum{th}"] = float(per_value.sum())
        out[f"max{th}"] = float(per_value.max())
    print(json.dumps(out), flush=True)


def run(name):
    got = {arm: [] for arm in ARMS}
    for r in range(ROUNDS):
        arms = list(ARMS)
        for arm in arms[r % len(arms):] + arms[:r % len(arms)]:
            env = dict(os.environ, **ARMS[arm])
            p = subprocess.run([sys.executable, __file__, "--child", name], env=env, capture_output=True, text=True,
                               check=True)
            got[arm].append(json.loads(p.stdout.strip().splitlines()[-1]))
    digests = {g["digest"] for runs in got.values() for g in runs}
    rows = []
    for arm, runs in got.items():
        med = {key: float(np.median([g[key] for g in runs])) for key in ("sum1", "max1", "sum2", "max2", "copy_s")}
        rows.append({"data": name, "arm": arm, "1 thread: sum_ms": med["sum1"], "1 thread: max_ms": med["max1"],
                     "2 threads: sum_ms": med["sum2"], "2 threads: max_ms": med["max2"],
                     "per round (1 thread sum)": " / ".join(f"{g['sum1']:.1f}" for g in runs),
                     "huge-page wait s": " / ".join(f"{g['copy_s']:.3f}" for g in runs) if "huge" in arm else "",
                     "AnonHugePages MB": max(g["huge_mb"] for g in runs),
                     "same surfaces": len(digests) == 1 and all(g["same"] for g in runs),
                     "load": " / ".join(f"{g['load']:.2f}" for g in runs)})
    return rows


def main(names):
    import _experiment  # noqa: F401  (benchmarks/_common.py, results under experiments/results/)
    from _common import write_results

    rows = []
    for name in names:
        rows += run(name)
        print(*rows[-len(ARMS):], sep="\n", flush=True)
    notes = [f"{ROUNDS} rounds of one process per arm, interleaved; per process {REPEATS} repeats of the 20 values, "
             "threads=1 and threads=2 alternately; per value the median wall time of extract, then the sum and max "
             "over the values; the table gives the median over the rounds",
             "no prefetch: POLYGEN_PREFETCH=0 (the plain kernels: no hints, and a loop instead of llvm.cttz)",
             "prefetch, huge pages: the builder's records and edge lists collapsed into transparent huge pages by "
             "the background thread after the preparation (EdgeCentredTable.HUGE_PAGES, the default; the wait for it "
             "after the method was ready, per round; AnonHugePages of the process at the end); the other arms "
             "HUGE_PAGES = False",
             "same surfaces: every arm's serial triangles and vertices byte for byte equal (one digest), and every "
             "2-thread surface the serial one",
             f"load: 1-minute load average of the machine ({os.cpu_count()} cores) at the end of each process"]
    return write_results("prefetch_ab", rows, COLUMNS, title="Prefetch hints and huge pages (edge-centred "
                         "construction)", notes=notes)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        child(sys.argv[2])
    else:
        print(main(sys.argv[1:] or ["2M"]))
