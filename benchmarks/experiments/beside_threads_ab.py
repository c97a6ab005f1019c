"""The records thread's numba threads during the preparation: numba's count against the cores the thinning leaves.

The default method's preparation on a volume of 200,000 cells or more
builds the edge table and the edge-centred records in a second Python
thread while the thinning runs in the first
(:func:`polygen.volume.edge_centred._seeds_beside_table`). The thinning's
FIFO halves are one parallel kernel of two threads; the records thread's
kernels are parallel too. Arms:

* ``numba's count`` (``BESIDE_THREADS = None``, the code before): the records
  thread's kernels run on numba's thread count, so on a 2-core machine four
  threads, busy or spinning (libgomp), share the two cores;
* ``cores left`` (``BESIDE_THREADS = "cores left"``): the records thread runs on
  the cores the halves leave, at least one.

What a user waits for is the first preparation in a process, so each
measurement is one fresh process: load the data set, prepare the default
method on a fresh volume once (timed: wall, user and system CPU, minor page
faults), then wait for the records' huge-page collapse (``settle``, not
timed, so that it cannot run into another measurement). The arms alternate,
``ROUNDS`` per data set, 2M (field ``fem``) and 10M (``gaussians``).

Criterion, written before the first measurement: ``cores left`` becomes the
default when its median wall time is at least 5 % below ``numba's count`` on
both 2M and 10M.

    python benchmarks/experiments/beside_threads_ab.py
"""

import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

import _experiment  # noqa: F401  (benchmarks/_common.py, results under experiments/results/)
from _common import write_results

ARMS = {"numba's count": None, "cores left": "cores left"}
ROUNDS = {"2M": 8, "10M": 5}
FIELDS = {"data4": "fem", "2M": "fem", "10M": "gaussians"}


def worker(name, arm):
    from polygen.volume import datasets, edge_centred, methods
    from polygen.volume.mesh import UnstructuredVolume
    edge_centred.BESIDE_THREADS = ARMS[arm]
    v0 = datasets.load(name)
    s = v0.scalars(FIELDS[name])
    vol = UnstructuredVolume(v0.points, v0.cells, {FIELDS[name]: s}, validate=False)
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    m = methods.get(methods.DEFAULT)(vol, field=FIELDS[name])
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    m.builder.settle()
    print(json.dumps({"wall_s": wall, "user_s": r1.ru_utime - r0.ru_utime, "sys_s": r1.ru_stime - r0.ru_stime,
                      "minflt": r1.ru_minflt - r0.ru_minflt, "seeds_s": m.seed_preprocess_s,
                      "records_s": m.construct_preprocess_s}))


def main(names):
    subprocess.run([sys.executable, __file__, "--worker", "data4", "cores left"], check=True, capture_output=True)
    subprocess.run([sys.executable, __file__, "--worker", "data4", "numba's count"], check=True,
                   capture_output=True)  # compile / load the kernels outside the timed processes
    rows = []
    for name in names:
        runs = {a: [] for a in ARMS}
        load0 = os.getloadavg()
        for r in range(ROUNDS[name]):
            for arm in (list(ARMS) if r % 2 == 0 else list(ARMS)[::-1]):
                out = subprocess.run([sys.executable, __file__, "--worker", name, arm], check=True,
                                     capture_output=True, text=True).stdout
                runs[arm].append(json.loads(out.strip().splitlines()[-1]))
                print(name, arm, runs[arm][-1], flush=True)
        load1 = os.getloadavg()
        for arm, rs in runs.items():
            row = {"data": name, "arm": arm}
            for k in ("wall_s", "user_s", "sys_s", "minflt", "seeds_s", "records_s"):
                row[k] = float(np.median([x[k] for x in rs]))
            row["wall min-max s"] = f"{min(x['wall_s'] for x in rs):.3f}-{max(x['wall_s'] for x in rs):.3f}"
            row["load before/after"] = f"{load0[0]:.2f}/{load1[0]:.2f}"
            row["runs"] = rs
            rows.append(row)
    met = all(next(r for r in rows if r["data"] == n and r["arm"] == "cores left")["wall_s"]
              <= 0.95 * next(r for r in rows if r["data"] == n and r["arm"] == "numba's count")["wall_s"]
              for n in names)
    columns = ["data", "arm", "wall_s", "wall min-max s", "user_s", "sys_s", "minflt", "seeds_s", "records_s",
               "load before/after"]
    notes = [f"one fresh process per measurement (the first preparation in a process), arms alternating, "
             f"{', '.join(f'{n}: {ROUNDS[n]} rounds' for n in names)}; the table gives medians; user/sys: CPU "
             "seconds of the whole process during the preparation (getrusage), minflt its minor page faults",
             "criterion (fixed before measuring): 'cores left' >= 5 % faster (median wall) on both 2M and 10M: "
             + ("met" if met else "not met"),
             "per-run figures in the JSON"]
    write_results("beside_threads_ab", rows, columns,
                  title="The records thread's numba threads during the preparation", notes=notes)


if __name__ == "__main__":
    if "--worker" in sys.argv:
        i = sys.argv.index("--worker")
        worker(sys.argv[i + 1], sys.argv[i + 2])
    else:
        main(sys.argv[1:] or list(ROUNDS))
