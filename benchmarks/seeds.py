"""Table 5.2 measured: preprocessing and query cost of the active-cell searches against n.

Workload like an FEM field on a mesh of n cells: ``S_min`` uniform on
[0, 1), span ``S_max - S_min`` exponential with mean ``0.5 n^(-1/3)`` (a
cell's size, and so its value span, shrinks like n^(-1/3)); an isosurface
then meets k ~ n^(2/3) cells (assumption 5.1). Twenty isovalues
``linspace(min, max, 22)[1:-1]`` per size, as in the thesis's tables.

For each method and n: ``preprocess_s`` (best of a few builds for small n),
``query_s`` (the 20 queries, best of a few sweeps; Python wrapper included),
``cells_tested`` and ``hits`` summed over the 20 values, and
``overhead`` = cells_tested - hits (the search term of Table 5.2 without k).
Log-log slopes are least-squares fits over n >= 1e5.

    python benchmarks/seeds.py            # n = 1e4 ... 2e6
    python benchmarks/seeds.py --quick    # n = 1e4 ... 1e5
"""

import argparse
import json
import time

import numpy as np

from _common import RESULTS, machine
from polygen.volume import isovalues, seeds

EXPECTED = {
    "full-scan": ("-", "O(n)"),
    "sorted-lists": ("O(n log n)", "O(n)"),
    "span-filter": ("O(n)", "O(n)"),
    "span-filter/by-min": ("O(n) + sort per class", "O(n)"),
    "span-space": ("O(n log n)", "O(sqrt(n) + k)"),
    "issue-lattice": ("O(n log n)", "O(log(n/L) + sqrt(n)/L + k)"),
    "interval-tree": ("O(n log n)", "O(log n + k)"),
}


def fem_like(n, seed):
    rng = np.random.default_rng(seed)
    lo = rng.random(n)
    return lo, lo + rng.exponential(0.5 * n ** (-1 / 3), n)


def slope(ns, ys, n_from=1e5):
    ns = np.asarray(ns, float)
    ys = np.asarray(ys, float)
    keep = (ns >= n_from) & (ys > 0)
    if keep.sum() < 2:
        return None
    return float(np.polyfit(np.log(ns[keep]), np.log(ys[keep]), 1)[0])


# (label, registry name, build parameters): every method with its defaults,
# plus Gallagher's own layout of the span filter
VARIANTS = [(name, name, {}) for name in seeds.METHODS]
VARIANTS.insert(3, ("span-filter/by-min", "span-filter", {"layout": "by-min"}))


def measure(label, name, params, n, lo, hi, values):
    cls = seeds.get(name)
    reps = 5 if n <= 1e5 else 2 if n <= 5e5 else 1
    pre = float("inf")
    for _ in range(reps):
        search = cls.build(lo, hi, **params)
        pre = min(pre, search.preprocess_s)
    q = float("inf")
    for _ in range(max(reps, 2)):
        t0 = time.perf_counter()
        rs = [search.query(v) for v in values]
        q = min(q, time.perf_counter() - t0)
    tested = sum(r.n_tested for r in rs)
    hits = sum(r.n_hits for r in rs)
    return {
        "method": label,
        "n": n,
        "preprocess_s": pre,
        "query_s": q,
        "cells_tested": tested,
        "hits": hits,
        "overhead": tested - hits,
        "nbytes": search.nbytes,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="n up to 1e5 only")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    sizes = [10_000, 30_000, 100_000] if args.quick else [10_000, 30_000, 100_000, 300_000, 1_000_000, 2_000_000]

    # compile (or load from the numba cache) every kernel before timing
    lo, hi = fem_like(2000, args.seed)
    for _, name, params in VARIANTS:
        seeds.get(name).build(lo, hi, **params).query(0.5)

    rows = []
    for n in sizes:
        lo, hi = fem_like(n, args.seed)
        values = isovalues([lo.min(), hi.max()], 20)
        for label, name, params in VARIANTS:
            row = measure(label, name, params, n, lo, hi, values)
            rows.append(row)
            print(
                f"n={n:>9d} {label:19s} pre {row['preprocess_s']:.4f} s  query(20) {row['query_s']:.4f} s  "
                f"tested {row['cells_tested']:>10d}  hits {row['hits']:>9d}",
                flush=True,
            )

    n_from = sizes[0] if args.quick else 100_000
    fits = {}
    for name, _, _ in VARIANTS:
        rr = [r for r in rows if r["method"] == name]
        ns = [r["n"] for r in rr]
        fits[name] = {
            "expected_pre": EXPECTED[name][0],
            "expected_query": EXPECTED[name][1],
            # the full scan builds nothing: its "preprocessing" is an allocation
            "slope_preprocess": None if name == "full-scan" else slope(ns, [r["preprocess_s"] for r in rr], n_from),
            "slope_query": slope(ns, [r["query_s"] for r in rr], n_from),
            "slope_tested": slope(ns, [r["cells_tested"] for r in rr], n_from),
            "slope_overhead": slope(ns, [r["overhead"] for r in rr], n_from),
        }
    hits = [r["hits"] for r in rows if r["method"] == "full-scan"]
    slope_k = slope(sizes, hits, n_from)

    notes = [
        "workload: S_min ~ U[0,1), span ~ Exp(mean 0.5 n^(-1/3)), 20 values linspace(min, max, 22)[1:-1], "
        f"seed {args.seed}",
        f"slope of k (hits) against n: {slope_k:.3f}" if slope_k is not None else "too few sizes for slopes",
        f"slopes: least squares of log y on log n over n >= {n_from:g}",
        "times are wall clock on a machine shared with other jobs; counts are exact",
        "query_s includes the Python wrapper (~tens of microseconds per query)",
    ]
    RESULTS.mkdir(parents=True, exist_ok=True)
    payload = {"machine": machine(), "notes": notes, "sizes": sizes, "rows": rows, "slopes": fits, "slope_hits": slope_k}
    (RESULTS / "seeds.json").write_text(json.dumps(payload, indent=2) + "\n")

    def fmt(x, p=".3f"):
        return "-" if x is None else format(x, p)

    lines = ["# Active-cell searches (thesis Table 5.2) against n", "", f"## Fitted log-log slopes (n >= {n_from:g})", ""]
    lines += [
        "| method | Table 5.2 pre | Table 5.2 query | slope pre | slope query | slope tested | slope tested - k |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, f in fits.items():
        lines.append(
            f"| {name} | {f['expected_pre']} | {f['expected_query']} | {fmt(f['slope_preprocess'])} | "
            f"{fmt(f['slope_query'])} | {fmt(f['slope_tested'])} | {fmt(f['slope_overhead'])} |"
        )
    lines += ["", "## Measurements (20 isovalues per row)", ""]
    lines += ["| method | n | preprocess s | query s (20) | cells tested | hits (k) | tested - k | MB |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['method']} | {r['n']} | {r['preprocess_s']:.4g} | {r['query_s']:.4g} | {r['cells_tested']} | "
            f"{r['hits']} | {r['overhead']} | {r['nbytes'] / 2**20:.1f} |"
        )
    lines += [""] + [f"- {n}" for n in notes] + [f"- machine: {machine()}"]
    (RESULTS / "seeds.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[:15] + lines[-len(notes) - 1 :]))


if __name__ == "__main__":
    main()
