"""Benchmark: the Cornell box with ~10k elements, progressive refinement to 1 % unshot.

Both form-factor paths: the default (``analytic``: element-integrated exact
factors with k x k area-sampled visibility) and the thesis's hemicube.

Writes ``benchmarks/results/radiosity.json`` and ``radiosity.md``.

    python benchmarks/radiosity.py [--patch-size 80] [--levels 2] [--tol 0.01] [--threads both]
                                   [--meshers lattice,bubble,bubble-bubble]

Meshers: ``lattice`` (lattice + constrained Delaunay patches, 1 -> 4 split
elements), ``bubble`` (bubble-mesh patches, 1 -> 4 split elements) and
``bubble-bubble`` (bubble-mesh patches, bubble-mesh elements in each patch).

JIT compilation is excluded (a short warm-up run first).  The thesis's
own radiosity times (Table 3.1, T_rs 156.63 / 289.02 s for 6090 / 17150
elements on an IBM RS/6000 560) are printed beside ours for scale only;
they used a different machine, meshes and convergence criterion.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from _common import machine  # noqa: E402  (benchmarks/ is the script's directory)
from polygen.radiosity import scenes
from polygen.radiosity.mesh import bubble_element_mesher, bubble_mesher, mesh_scene
from polygen.radiosity.formfactor import VISIBILITY_SAMPLES
from polygen.radiosity.solve import progressive_refinement

MESHERS = {
    "lattice": {},
    "bubble": {"mesher": bubble_mesher},
    "bubble-bubble": {"mesher": bubble_mesher, "element_mesher": bubble_element_mesher},
}

RESULTS = Path(__file__).resolve().parent / "results"


def _one(mesh, method, resolution, tol, parallel):
    # warm-up: compile (or load cached) kernels
    progressive_refinement(mesh, form_factors=method, resolution=resolution, tol=tol,
                           max_shots=3, parallel=parallel)
    t0 = time.perf_counter()
    r = progressive_refinement(mesh, form_factors=method, resolution=resolution, tol=tol,
                               parallel=parallel)
    seconds = time.perf_counter() - t0
    balance = (r.absorbed_power(mesh) + r.unshot_power(mesh)) / r.emitted_power
    hist = r.history
    return {
        "method": method,
        "threads": "multi" if parallel else "single",
        "hemicube_resolution": resolution if method == "hemicube" else None,
        "visibility_samples": VISIBILITY_SAMPLES if method == "analytic" else None,
        "seconds": round(seconds, 3),
        "shots": int(r.stats["n_shots"]),
        "ms_per_shot": round(1e3 * seconds / max(r.stats["n_shots"], 1), 3),
        "converged": bool(r.converged),
        "final_unshot_fraction": float(hist[-1]),
        "shots_to_10pct": int(np.argmax(hist <= 0.1)) if np.any(hist <= 0.1) else None,
        "energy_balance_min": float(balance.min()),
        "energy_balance_max": float(balance.max()),
        "mean_radiosity_rgb": r.radiosity.mean(axis=0).round(4).tolist(),
    }


def run(patch_size, levels, tol, resolution, modes, meshers):
    scene = scenes.cornell_box()
    out = []
    for name in meshers:
        mesh_scene(scene, 4 * patch_size, element_levels=0, **MESHERS[name])  # warm-up
        t0 = time.perf_counter()
        mesh = mesh_scene(scene, patch_size, element_levels=levels, **MESHERS[name])
        t_mesh = time.perf_counter() - t0
        _, q = mesh.element_quality()
        info = {"mesher": name, "n_patches": mesh.n_patches, "n_elements": mesh.n_elements,
                "n_nodes": mesh.n_nodes, "mesh_seconds": round(t_mesh, 3),
                "q_mean": round(float(q.mean()), 4), "frac_q_below_0.8": round(float(np.mean(q < 0.8)), 4),
                "t_vertices": int(len(mesh.t_vertices()))}
        rows = [dict(info, **_one(mesh, method, resolution, tol, par))
                for method in ("analytic", "hemicube") for par in modes]
        out.append((mesh, info, rows))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--patch-size", type=float, default=80.0)
    ap.add_argument("--levels", type=int, default=2)
    ap.add_argument("--tol", type=float, default=0.01)
    ap.add_argument("--resolution", type=int, default=100)
    ap.add_argument("--threads", choices=("both", "single", "multi"), default="both")
    ap.add_argument("--meshers", default="lattice,bubble,bubble-bubble")
    args = ap.parse_args(argv)
    modes = {"both": (False, True), "single": (False,), "multi": (True,)}[args.threads]
    meshers = [m for m in args.meshers.split(",") if m]
    unknown = set(meshers) - set(MESHERS)
    if unknown:
        ap.error(f"unknown mesher(s) {sorted(unknown)}; choose from {sorted(MESHERS)}")
    results = run(args.patch_size, args.levels, args.tol, args.resolution, modes, meshers)
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    scene = results[0][0].scene
    out = {
        "benchmark": "cornell_box_progressive_refinement",
        "scene": "cornell_box (published Cornell geometry, mm)",
        "n_polygons": len(scene.polygons),
        "patch_size_mm": args.patch_size,
        "element_levels": args.levels,
        "tol_unshot_fraction": args.tol,
        "threads": args.threads,
        "meshes": [info for _, info, _ in results],
        "runs": [r for _, _, rows in results for r in rows],
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor(),
            "cpu_count": os.cpu_count(),
            "load_average_at_end": [round(x, 2) for x in load] if load else None,
            "note": "shared with other engineers' jobs while measured",
            **{k: v for k, v in machine().items() if k in ("commit", "date")},
        },
        "target": "converged (unshot < 1 % of emitted) in < 60 s",
        "thesis_reference": "Table 3.1 T_rs: 156.63 s (6090 elements), 289.02 s (17150 elements),"
                            " IBM RS/6000 model 560",
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "radiosity.json").write_text(json.dumps(out, indent=2) + "\n")
    lines = [
        "# Radiosity benchmark: Cornell box, progressive refinement",
        "",
        f"{len(scene.polygons)} polygons; patch size {args.patch_size} mm, element size "
        f"{args.patch_size / 2 ** args.levels:g} mm. Stop at unshot < {args.tol:.0%} of emitted. "
        "Meshing and solving times exclude JIT compilation (warm-up runs first).",
        "",
        "| mesher | patches | elements | nodes | mesh s | mean q | q < 0.8 | T-vertices |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for _, info, _ in results:
        lines.append(f"| {info['mesher']} | {info['n_patches']} | {info['n_elements']} | "
                     f"{info['n_nodes']} | {info['mesh_seconds']:.2f} | {info['q_mean']:.4f} | "
                     f"{info['frac_q_below_0.8']:.1%} | {info['t_vertices']} |")
    lines += [
        "",
        "| mesher | form factors | threads | seconds | shots | ms/shot | converged | final unshot | "
        "energy balance |",
        "|---|---|---|---:|---:|---:|---|---:|---:|",
    ]
    for _, info, rows in results:
        for r in rows:
            name = r["method"] + (f" (res {r['hemicube_resolution']})" if r["hemicube_resolution"]
                                  else f" (default, {r['visibility_samples']}^2 rays/pair)")
            lines.append(f"| {info['mesher']} | {name} | {r['threads']} | {r['seconds']:.2f} | "
                         f"{r['shots']} | {r['ms_per_shot']:.2f} | {r['converged']} | "
                         f"{r['final_unshot_fraction']:.4f} | {r['energy_balance_min']:.6f} |")
    lines += [
        "",
        f"Target: < 60 s. Machine: {os.cpu_count()} cores, shared with other engineers' jobs "
        f"while measured (load average at the end: {out['machine']['load_average_at_end']}).",
        "Energy balance = (absorbed + unshot) / emitted; below 1 only because the box's front "
        "is open.",
        "Thesis, for scale only (IBM RS/6000 560, its own meshes): T_rs 156.63 s for 6090 "
        "elements, 289.02 s for 17150 (Table 3.1).",
        "",
    ]
    (RESULTS / "radiosity.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
