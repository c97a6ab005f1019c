"""Benchmark: visibility error against cost, to choose k (k x k rays per element-patch pair).

Writes ``benchmarks/results/visibility.json`` and ``visibility.md``.

    python benchmarks/visibility.py [--ks 1,2,3,4,6,8] [--reference 16]

For the thesis's Fig 2.8 room (:func:`~polygen.radiosity.scenes.small_shadows_room`)
and the Cornell box (with its blocks), each k is compared with k = 16
(256 rays per pair) on the same mesh:

* ``light_err``: the direct-light factor sum_p F(e -> p) over the light's
  patches, RMS over the elements that see some of it, relative to its mean
  (the visibility fraction's error, where the shadows are);
* ``B_err``: element radiosity after progressive refinement to 1 % unshot,
  RMS over all elements relative to the mean (what one sees);
* ``ms_per_shot``: solve time per shot (single thread; JIT excluded).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from polygen.radiosity import scenes
from polygen.radiosity.formfactor import analytic_column, element_geometry, pack_polygons
from polygen.radiosity.mesh import mesh_scene
from polygen.radiosity.solve import progressive_refinement

from _common import RESULTS, machine

CASES = {
    "small_shadows_room (Fig 2.8)": (scenes.small_shadows_room, 1.5, 1),
    "cornell_box": (scenes.cornell_box, 120.0, 1),
}


def light_factors(mesh, k):
    packed, geometry = pack_polygons(mesh.scene.polygons), element_geometry(mesh)
    lights = np.flatnonzero(np.isin(mesh.patch_polygon, mesh.scene.area_lights))
    return sum(analytic_column(mesh, p, packed=packed, geometry=geometry, visibility_samples=k,
                               parallel=False) for p in lights)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ks", default="1,2,3,4,6,8")
    ap.add_argument("--reference", type=int, default=16)
    args = ap.parse_args(argv)
    ks = [int(k) for k in args.ks.split(",")]
    out = {"machine": machine(), "reference_k": args.reference, "cases": []}
    lines = ["# Visibility by area sampling: error against cost", "",
             f"Reference: k = {args.reference} ({args.reference ** 2} rays per element-patch "
             "pair) on the same mesh. light_err: RMS error of the direct-light factor over the "
             "elements that see the light, / its mean. B_err: RMS radiosity error after "
             "progressive refinement to 1 % unshot, / mean radiosity. Single thread.", ""]
    for name, (build, size, levels) in CASES.items():
        mesh = mesh_scene(build(), size, element_levels=levels)
        progressive_refinement(mesh, visibility_samples=1, max_shots=2, parallel=False)  # JIT
        f_ref = light_factors(mesh, args.reference)
        b_ref = progressive_refinement(mesh, visibility_samples=args.reference, tol=0.01,
                                       parallel=False).radiosity.mean(axis=1)
        seen = f_ref > 0
        rows = []
        for k in ks:
            f = light_factors(mesh, k)
            t0 = time.perf_counter()
            r = progressive_refinement(mesh, visibility_samples=k, tol=0.01, parallel=False)
            dt = time.perf_counter() - t0
            b = r.radiosity.mean(axis=1)
            rows.append({"k": k, "rays_per_pair": k * k,
                         "light_err": float(np.sqrt(np.mean((f[seen] - f_ref[seen]) ** 2))
                                            / f_ref[seen].mean()),
                         "B_err": float(np.sqrt(np.mean((b - b_ref) ** 2)) / b_ref.mean()),
                         "B_err_max": float(np.abs(b - b_ref).max() / b_ref.mean()),
                         "shots": int(r.stats["n_shots"]), "seconds": round(dt, 3),
                         "ms_per_shot": round(1e3 * dt / max(r.stats["n_shots"], 1), 3)})
        out["cases"].append({"scene": name, "patch_size": size, "element_levels": levels,
                             "n_patches": mesh.n_patches, "n_elements": mesh.n_elements,
                             "rows": rows})
        lines += [f"## {name}: {mesh.n_patches} patches, {mesh.n_elements} elements", "",
                  "| k | rays/pair | light_err | B_err (RMS) | B_err (max) | ms/shot |",
                  "|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['k']} | {r['rays_per_pair']} | {r['light_err']:.2%} | {r['B_err']:.2%} | "
                  f"{r['B_err_max']:.2%} | {r['ms_per_shot']:.2f} |" for r in rows]
        lines.append("")
    lines += [f"Machine: {machine()} (shared with other jobs while measured)", ""]
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "visibility.json").write_text(json.dumps(out, indent=2) + "\n")
    (RESULTS / "visibility.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
