"""``polygen datasets``: list, describe and build the reproducible volume data sets.

``polygen datasets`` lists every data set with its size and whether it is
cached; ``polygen datasets build data1 data4`` (or ``--all``) builds into
the cache with progress bars; ``polygen datasets info data4`` describes one.
"""

from __future__ import annotations

import sys
import time

EXAMPLES = """examples:
  polygen datasets                        every data set, its size and whether it is cached
  polygen datasets info data4             what data set 4 is (thesis figure, fields, topology)
  polygen datasets build data1 data4      build two data sets into the cache
  polygen datasets path                   the cache directory
"""


def configure(parser):
    parser.add_argument(
        "action", nargs="?", choices=("list", "build", "info", "path"), default="list",
        help="list (default): the data sets and their cache state; build NAME...: build into the cache; "
        "info NAME...: what a data set is; path: the cache directory",
    )
    parser.add_argument("names", nargs="*", metavar="NAME", help="data set names (see the list)")
    parser.add_argument("--all", action="store_true", help="build every data set (10M takes minutes and GBs)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the fields (default 0)")
    parser.add_argument("--force", action="store_true", help="rebuild even if cached")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def _size(n):
    return f"{n / 1e6:.0f}M" if n >= 1_000_000 and n % 1_000_000 == 0 else str(n)


def _list(ds, seed, out):
    rows = []
    for name in ds.names():
        inf = ds.info(name)
        if inf.cached:
            state = "cached" if ds.is_cached(name, seed) else "-"
        else:
            state = "on the fly"
        topo = f"genus {'/'.join(str(g) for g in inf.genus)}, {inf.n_voids} void{'s' if inf.n_voids != 1 else ''}"
        rows.append((name, inf.cell_type, _size(inf.target_cells), topo, state, inf.description))
    head = ("name", "type", "cells", "topology", "cache")
    widths = [max(len(r[i]) for r in rows + [head]) for i in range(5)]
    print("  ".join(h.ljust(w) for h, w in zip(head, widths)) + "  description", file=out)
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r[:5], widths)) + "  " + r[5], file=out)
    print(f"\ncache: {ds.cache_dir()} (set ${ds.CACHE_ENV} to move it); seed {seed}", file=out)
    print("build with: polygen datasets build NAME... (or --all)", file=out)


def run(args) -> int:
    from polygen.volume import datasets as ds

    out = sys.stdout
    unknown = [n for n in args.names if n not in ds.names()]
    if unknown:
        print(f"polygen datasets: unknown data set(s) {unknown}; the data sets are {ds.names()}", file=sys.stderr)
        return 2
    if args.action == "list":
        _list(ds, args.seed, out)
        return 0
    if args.action == "path":
        print(ds.cache_dir(), file=out)
        return 0
    if args.action == "info":
        if not args.names:
            print("polygen datasets info: name at least one data set", file=sys.stderr)
            return 2
        for name in args.names:
            inf = ds.info(name)
            print(f"{name}: {inf.description}", file=out)
            print(f"  cells {inf.cell_type} ~{inf.target_cells}; genus by boundary group {inf.genus}; "
                  f"voids {inf.n_voids}; through-holes {inf.n_through_holes}; fields {', '.join(inf.fields)}", file=out)
            if inf.thesis:
                print(f"  thesis: {inf.thesis}", file=out)
            if inf.cached:
                print(f"  cache file: {ds.cache_path(name, args.seed)} "
                      f"({'present' if ds.is_cached(name, args.seed) else 'not built'})", file=out)
        return 0
    # build
    names = ds.names() if args.all else args.names
    if not names:
        print("polygen datasets build: name the data sets to build, or pass --all", file=sys.stderr)
        return 2
    for name in names:
        t0 = time.perf_counter()
        if ds.is_cached(name, args.seed) and not args.force:
            print(f"{name}: already cached at {ds.cache_path(name, args.seed)}", file=out)
            continue
        ds.build(name, seed=args.seed, force=args.force, progress=not args.no_progress)
        vol = ds.load(name, seed=args.seed)  # from the cache just written (tiny volumes: on the fly)
        dt = time.perf_counter() - t0
        print(f"{name}: {vol.n_cells} {vol.cell_type} cells, {vol.n_points} nodes, fields {list(vol.fields)}; "
              f"genus by group {vol.group_genus.tolist()}, voids {vol.n_voids}; {dt:.1f} s", file=out)
    return 0
