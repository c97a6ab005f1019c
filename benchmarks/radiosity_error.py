"""Benchmark: image error against element count, uniform meshes vs adaptive subdivision.

The yardstick of chapters 3 and 4: for the Cornell box
and the room of the thesis's Fig. 2.8 (`scenes.small_shadows_room`), a
reference image from a much finer mesh, then the relative RMS image error
(:func:`polygen.radiosity.error.image_error`) of

* uniform meshes of decreasing patch size, and
* adaptive subdivision (Def. 2.6, longest-edge bisection) repeated on a
  coarse mesh,

each solved by progressive refinement with the default form factors to
``--tol`` unshot.  Writes ``benchmarks/results/radiosity_error.json`` and
``.md``; notebook 02 draws the curves from the JSON.

    python benchmarks/radiosity_error.py [--scenes cornell,room] [--image 160] [--quick]
"""

from __future__ import annotations

import argparse
import json
import time

from _common import RESULTS, machine, write_results

from polygen.radiosity import Camera, mesh_scene, progressive_refinement, scenes
from polygen.radiosity.error import adaptive_curve, shade, uniform_curve

# per scene: the scene, its camera, the reference patch size, the uniform patch sizes, the
# coarse patch size of adaptive subdivision and its rounds; element_levels 1 everywhere
SETUPS = {
    "cornell": dict(scene=scenes.cornell_box, camera=lambda n: Camera.cornell(width=n, height=n),
                    # 16 elements per patch, patches of a size no uniform mesh has (a reference
                    # that shares a mesh's patches would flatter that mesh)
                    reference=48.0, reference_levels=2, uniform=[160.0, 113.0, 80.0, 57.0],
                    coarse=160.0, rounds=4),
    "room": dict(scene=scenes.small_shadows_room,
                 camera=lambda n: Camera([5.0, 7.0, -5.0], [5.0, 0.5, 5.0], fov=50.0, width=n,
                                         height=n, near=0.01),
                 # the floor, where the shadows are, with 16 elements per 0.5 patch (elements 4x
                 # smaller in area than the finest uniform mesh's); the smooth walls with
                 # patches of a size no uniform mesh has
                 reference=lambda sc: [0.5 if p.name == "room_y0" else 1.2 for p in sc.polygons],
                 reference_levels=2, uniform=[2.0, 1.4, 1.0], coarse=2.0, rounds=3),
}
QUICK = {"cornell": dict(reference=113.0, uniform=[160.0], rounds=1),
         "room": dict(reference=lambda sc: 2.0, uniform=[4.0], rounds=1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cornell,room")
    ap.add_argument("--image", type=int, default=160, help="image side in pixels")
    ap.add_argument("--tol", type=float, default=0.01, help="unshot fraction to stop at")
    ap.add_argument("--threshold", type=float, default=0.1,
                    help="adaptive subdivision: relative jump that marks an element")
    ap.add_argument("--quick", action="store_true", help="tiny sizes (a smoke test)")
    args = ap.parse_args(argv)
    solve = {"tol": args.tol, "ambient": True}
    rows, curves = [], {}
    for name in args.scenes.split(","):
        cfg = dict(SETUPS[name], **(QUICK[name] if args.quick else {}))
        scene, cam = cfg["scene"](), cfg["camera"](args.image)
        t0 = time.perf_counter()
        ref = cfg["reference"]
        ref_mesh = mesh_scene(scene, ref(scene) if callable(ref) else ref,
                              element_levels=cfg.get("reference_levels", 1))
        ref_result = progressive_refinement(ref_mesh, **solve)
        reference = shade(ref_mesh, ref_result.display_radiosity(ref_mesh), cam)
        t_ref = time.perf_counter() - t0
        print(f"{name}: reference {ref_mesh.n_elements} elements, "
              f"{ref_result.stats['n_shots']} shots, {t_ref:.1f} s", flush=True)
        uni = uniform_curve(scene, cam, reference, cfg["uniform"], solve=solve)
        ada = adaptive_curve(scene, cam, reference, cfg["coarse"], cfg["rounds"],
                             threshold=args.threshold, solve=solve)
        curves[name] = {"reference_elements": ref_mesh.n_elements, "reference_seconds": t_ref,
                        "uniform": [p.__dict__ for p in uni], "adaptive": [p.__dict__ for p in ada]}
        for kind, pts in (("uniform", uni), ("adaptive", ada)):
            for p in pts:
                print(f"  {p.label:20s} {p.n_elements:7d} elements  error {p.error:.4f}  "
                      f"{p.seconds:6.1f} s", flush=True)
                rows.append({"scene": name, "mesh": p.label, "elements": p.n_elements,
                             "patches": p.n_patches, "rms_error": round(p.error, 5),
                             "seconds": round(p.seconds, 2)})
    if args.quick:
        return
    write_results("radiosity_error", rows,
                  ["scene", "mesh", "elements", "patches", "rms_error", "seconds"],
                  title="Image error against element count: uniform meshes and adaptive "
                        "subdivision",
                  notes=[f"relative RMS image error over the covered pixels of a {args.image}^2 "
                         "Gouraud image against a reference from a finer uniform mesh "
                         "(reference elements: " + ", ".join(
                             f"{k} {v['reference_elements']}" for k, v in curves.items()) + ")",
                         f"progressive refinement, default form factors, tol {args.tol}, ambient "
                         f"term on; adaptive threshold {args.threshold} of the bright surfaces' "
                         "radiosity; seconds for adaptive are cumulative over the rounds"])
    (RESULTS / "radiosity_error.json").write_text(json.dumps(
        {"machine": machine(), "image": args.image, "tol": args.tol, "threshold": args.threshold,
         "curves": curves, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
