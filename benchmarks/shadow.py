"""Benchmark: the shadow-polyhedra scene driver against polygon count (Table 3.2's T_sdw, T_isr).

Writes ``benchmarks/results/shadow.json`` and ``shadow.md``.

    python benchmarks/shadow.py [--sizes 12x15,17x21,24x30,34x42,48x60] [--brute 12x15,17x21,24x30]

On the family :func:`~polygen.radiosity.scenes.sphere_scene` (``n_lat x n_lon``
faces, 12 x 15 = 180 is the thesis's Fig. 3.19): polyhedra built, receiver
tests, index nodes visited, sections; T_sdw (shadow polyhedra) and T_isr
(index, receiver tests, sections) with the bounding-volume hierarchy, and
without it (every polyhedron against every receiver, the thesis's O(n^2))
for the smaller sizes.  The log-log slopes of T_isr and of the receiver
tests against the polygon count are fitted over the sizes.  Per-scene
counts (polyhedra, sections, conventional segments, BSP regions) for the
thesis's three scenes and Fig. 3.4's.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from polygen.discontinuity import scene_sections
from polygen.discontinuity.conventional import conventional_bsp, conventional_segments, section_segments
from polygen.radiosity import scenes

from _common import RESULTS, machine


def scene_counts(sc):
    sh = scene_sections(sc)
    conv = bsp_c = bsp_s = simp = 0
    for r in sh.sections:
        R = sc.polygons[r]
        cs = conventional_segments(sc, r, shadows=sh)
        ss, _ = section_segments(R, sh.of(r))
        conv += len(cs.segments)
        simp += len(ss)
        bsp_c += conventional_bsp(R, cs.segments).n_regions
        bsp_s += conventional_bsp(R, ss).n_regions
    return dict(polygons=len(sc), receivers_with_sections=len(sh.sections),
                polyhedra=sh.counters["polyhedra"], sections=sh.counters["sections"],
                simplified_segments=simp, conventional_segments=conv,
                bsp_regions_simplified=bsp_s, bsp_regions_conventional=bsp_c)


def timed(sc, use_index, repeat):
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        sh = scene_sections(sc, use_index=use_index)
        total = time.perf_counter() - t0
        if best is None or total < best[0]:
            best = (total, sh)
    total, sh = best
    return dict(total_s=total, t_sdw=sh.timings["t_sdw"], t_isr=sh.timings["t_isr"], **sh.counters)


def slope(x, y):
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="12x15,17x21,24x30,34x42,48x60")
    ap.add_argument("--brute", default="12x15,17x21,24x30")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args(argv)
    parse = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    brute = {tuple(int(v) for v in s.split("x")) for s in args.brute.split(",") if s}
    scene_sections(scenes.sphere_scene())  # JIT
    out = {"machine": machine(), "family": "sphere_scene(n_lat, n_lon)", "rows": [], "scenes": {}}
    RESULTS.mkdir(parents=True, exist_ok=True)
    for n_lat, n_lon in parse:
        sc = scenes.sphere_scene(n_lat=n_lat, n_lon=n_lon)
        row = {"n_lat": n_lat, "n_lon": n_lon, "polygons": len(sc), "index": timed(sc, True, args.repeat)}
        if (n_lat, n_lon) in brute:
            row["brute"] = timed(sc, False, 1)
        out["rows"].append(row)
        print(row, flush=True)
    n = [r["polygons"] for r in out["rows"]]
    out["slope_t_isr_index"] = slope(n, [r["index"]["t_isr"] for r in out["rows"]])
    out["slope_receiver_tests_index"] = slope(n, [r["index"]["receiver_tests"] for r in out["rows"]])
    out["slope_t_sdw"] = slope(n, [r["index"]["t_sdw"] for r in out["rows"]])
    b = [r for r in out["rows"] if "brute" in r]
    if len(b) >= 2:
        out["slope_t_isr_brute"] = slope([r["polygons"] for r in b], [r["brute"]["t_isr"] for r in b])
        out["slope_receiver_tests_brute"] = slope([r["polygons"] for r in b],
                                                  [r["brute"]["receiver_tests"] for r in b])
    for f in (scenes.two_rectangles_room, scenes.sphere_scene, scenes.chair_scene,
              scenes.figure_3_4_scene):
        sc = f()
        out["scenes"][sc.name] = scene_counts(sc)
        print(sc.name, out["scenes"][sc.name], flush=True)
    (RESULTS / "shadow.json").write_text(json.dumps(out, indent=1))
    lines = ["# Shadow polyhedra: the scene driver against polygon count", "",
             f"Machine: {out['machine']}. Family: {out['family']}; best of {args.repeat} runs. "
             "T_sdw: shadow polyhedra; T_isr: index queries, receiver tests, sections "
             "(Table 3.2's phases; the thesis: T_isr O(n^2)).", "",
             "| polygons | polyhedra | receiver tests | index nodes | sections | T_sdw (s) | T_isr (s) "
             "| brute: receiver tests | brute: T_isr (s) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in out["rows"]:
        i = r["index"]
        br = r.get("brute")
        lines.append(f"| {r['polygons']} | {i['polyhedra']} | {i['receiver_tests']} | {i['node_tests']} "
                     f"| {i['sections']} | {i['t_sdw']:.3f} | {i['t_isr']:.3f} | "
                     + (f"{br['receiver_tests']} | {br['t_isr']:.3f} |" if br else "- | - |"))
    lines += ["", f"log-log slope against polygon count, with the index: T_isr "
              f"{out['slope_t_isr_index']:.2f}, receiver tests {out['slope_receiver_tests_index']:.2f}, "
              f"T_sdw {out['slope_t_sdw']:.2f}"]
    if "slope_t_isr_brute" in out:
        lines[-1] += (f"; without it (every polyhedron against every receiver): T_isr "
                      f"{out['slope_t_isr_brute']:.2f}, receiver tests "
                      f"{out['slope_receiver_tests_brute']:.2f}")
    lines += ["", "## Counts per scene", "",
              "| scene | polygons | polyhedra | sections | simplified segments | conventional segments "
              "| BSP regions (simplified) | BSP regions (conventional) |",
              "|---|---|---|---|---|---|---|---|"]
    for name, c in out["scenes"].items():
        lines.append(f"| {name} | {c['polygons']} | {c['polyhedra']} | {c['sections']} | "
                     f"{c['simplified_segments']} | {c['conventional_segments']} | "
                     f"{c['bsp_regions_simplified']} | {c['bsp_regions_conventional']} |")
    (RESULTS / "shadow.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
