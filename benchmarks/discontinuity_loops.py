"""Benchmark of the receiver side of simplified discontinuity meshing (3.3.2-3.3.5).

Run ``python benchmarks/discontinuity_loops.py`` from the repository root;
writes ``benchmarks/results/discontinuity_loops.json`` and ``.md``.  For the
three scenes of chapter 3: the discontinuity phase of
:func:`polygen.discontinuity.simplified.simplified_discontinuity` timed per
phase as Table 3.2 names them (best of ``--repeat`` warm runs), Table 3.1's
counts (N_f1 polygons before division, N_f2 regions after, N_d
discontinuity edges), and the walk's machine-independent counters: the
segment-edge tests it made against those an all-edges test would make
(3.3.3's claim), point-in-loop tests, receivers rebuilt by the fallback.
"""

import argparse

from _common import best_of, write_results  # noqa: E402  (benchmarks/ is the script's directory)
from polygen.discontinuity.simplified import simplified_discontinuity
from polygen.radiosity import scenes

# Tables 3.1 and 3.2: example 1 (the box room, Fig. 3.15) and example 2 (the sphere, Fig. 3.19)
THESIS = {"two_rectangles_room": dict(N_f1=8, N_f2=20, N_d=40, T_sdw=0.03, T_isr=0.04, T_idd=0.02,
                                      T_lop=0.01, T_lit=0.01, T_div=0.01),
          "sphere_scene": dict(N_f1=721, N_f2=2495, N_d=3116, T_sdw=0.21, T_isr=154.48, T_idd=3.76,
                               T_lop=2.13, T_lit=5.50, T_div=0.50)}
PHASES = ["T_sdw", "T_isr", "T_idd", "T_lop", "T_lit", "T_div", "T_chk"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    rows = []
    for name in ["two_rectangles_room", "sphere_scene", "chair_scene"]:
        sc = getattr(scenes, name)()
        simplified_discontinuity(sc)  # warm-up: numba kernels compiled or loaded
        t, sd = best_of(lambda: simplified_discontinuity(sc), args.repeat)
        c = sd.counters
        row = dict(scene=name, total_s=t, N_f1=len(sc.polygons),
                   N_f2=len(sc.polygons) - c["receivers"] + c["regions"], N_d=c["discontinuity_edges"],
                   receivers=c["receivers"], sections=c["sections"], point_in_loop=c["point_in_loop"],
                   edge_tests=c["edge_tests"], edge_tests_all=c["edge_tests_all"],
                   edge_test_ratio=c["edge_tests"] / max(c["edge_tests_all"], 1),
                   fallback=c.get("fallback", 0))
        row.update({k: sd.timings[k] for k in PHASES})
        for k, v in THESIS.get(name, {}).items():
            row[f"thesis_{k}"] = v
        rows.append(row)
    cols = ["scene", "total_s", "N_f1", "N_f2", "N_d", "receivers", "sections", "point_in_loop",
            "edge_tests", "edge_tests_all", "edge_test_ratio", "fallback"] + PHASES
    path = write_results("discontinuity_loops", rows, cols,
                         title="Simplified discontinuity meshing: the discontinuity phase per scene",
                         notes=["thesis values (Tables 3.1, 3.2; IBM RS/6000 560) are in the JSON as thesis_*",
                                "edge_tests_all: every section edge against every edge of its receiver "
                                "(the cost the walk of 3.3.3 avoids)",
                                "T_chk: verification of every receiver complex (not a phase of the thesis)"])
    print(path.read_text())


if __name__ == "__main__":
    main()
