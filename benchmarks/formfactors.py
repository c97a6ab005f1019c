"""Benchmark: accuracy of the form factors (furnace tests, per-pair errors), hemicube vs default.

Writes ``benchmarks/results/formfactors.json`` and ``formfactors.md``.

    python benchmarks/formfactors.py [--pairs 4000]

1. The furnace box (48 patches, 192 elements, rho 0.5, E 1): B (1 - rho) / E
   per element must be 1 (:func:`~polygen.radiosity.solve.furnace_error`),
   with the thesis's hemicube at resolutions 64 / 100 / 200 and with the
   default (analytic) factors.
2. The same in the Cornell box closed by a front wall, with its blocks
   (occluders: the rows no longer sum to 1 by construction), for
   k = 1..4 visibility rays per side.
3. Per element-patch factors in the empty Cornell box (60 patches split into
   240 / 960 / 3840 elements) against a reference that is not the method's
   own formula: Lambert's point factor integrated over the element by a
   collapsed Gauss rule of order 24 (576 points), on a fixed-seed random
   subset of the pairs with a nonzero reference.  Relative errors
   |F - F_ref| / F_ref, percentiles 50 / 95 / 99.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from polygen.radiosity import scenes
from polygen.radiosity.formfactor import (
    _gauss_triangle,
    analytic_column,
    element_geometry,
    pack_polygons,
    point_polygon_form_factor,
)
from polygen.radiosity.mesh import mesh_scene
from polygen.radiosity.solve import form_factor_matrix, furnace_error

from _common import RESULTS, machine


def reference_pairs(mesh, elements, patches, order=24):
    """F(e -> p) by Lambert's point factor integrated over e with order**2 Gauss points."""
    bary, w = _gauss_triangle(order)
    out = np.empty(len(elements))
    for k, (e, p) in enumerate(zip(elements, patches)):
        x = bary @ mesh.nodes[mesh.elements[e]]
        tri = mesh.nodes[mesh.patches[p]]
        front = (x - mesh.patch_centroid[p]) @ mesh.patch_normal[p] > 0.0
        f = point_polygon_form_factor(x, np.broadcast_to(mesh.element_normal[e], x.shape), [tri])
        out[k] = np.sum(w * f * front)
    return out


def analytic_matrix(mesh, **kw):
    """form_factor_matrix's analytic columns with analytic_column's own keywords."""
    packed, geometry = pack_polygons(mesh.scene.polygons), element_geometry(mesh)
    return np.stack([analytic_column(mesh, p, packed=packed, geometry=geometry, parallel=False,
                                     **kw) for p in range(mesh.n_patches)], axis=1)


def pair_errors(mesh, fmats, n_pairs, seed=0):
    rng = np.random.default_rng(seed)
    other = mesh.element_polygon[:, None] != mesh.patch_polygon[None, :]
    cand = np.argwhere(other)
    pick = cand[rng.choice(len(cand), min(n_pairs, len(cand)), replace=False)]
    ref = reference_pairs(mesh, pick[:, 0], pick[:, 1])
    ok = ref > 0
    out = {}
    for name, f in fmats.items():
        rel = np.abs(f[pick[ok, 0], pick[ok, 1]] - ref[ok]) / ref[ok]
        out[name] = [round(float(v), 4) for v in np.percentile(rel, [50, 95, 99])]
    return out, int(ok.sum())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=4000)
    args = ap.parse_args(argv)
    out = {"machine": machine()}
    lines = ["# Form-factor accuracy: hemicube (thesis 2.2.1) vs the default (analytic)", ""]

    fm = mesh_scene(scenes.furnace_box(), 0.5, element_levels=1)
    rows = []
    for name, kw in [("hemicube res 64", {"form_factors": "hemicube", "resolution": 64}),
                     ("hemicube res 100", {"form_factors": "hemicube", "resolution": 100}),
                     ("hemicube res 200", {"form_factors": "hemicube", "resolution": 200}),
                     ("default (analytic)", {})]:
        t0 = time.perf_counter()
        ratio, rows_sum = furnace_error(fm, **kw)
        rows.append({"method": name, "B_min": float(2 * ratio.min()), "B_max": float(2 * ratio.max()),
                     "row_sum_min": float(rows_sum.min()), "row_sum_max": float(rows_sum.max()),
                     "max_rel_error": float(np.abs(ratio - 1).max()),
                     "seconds": round(time.perf_counter() - t0, 2)})
    out["furnace_box"] = {"n_patches": fm.n_patches, "n_elements": fm.n_elements, "rows": rows}
    lines += [f"## Furnace box ({fm.n_patches} patches, {fm.n_elements} elements, rho 0.5, E 1: "
              "B must be 2)", "",
              "| method | B min | B max | row sum min | row sum max | max rel. error |",
              "|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['method']} | {r['B_min']:.4f} | {r['B_max']:.4f} | {r['row_sum_min']:.4f} | "
              f"{r['row_sum_max']:.4f} | {r['max_rel_error']:.2%} |" for r in rows]

    cm = mesh_scene(scenes.cornell_box(closed=True), 100.0, element_levels=1)
    rows = []
    for name, kw in ([("hemicube res 100", {"form_factors": "hemicube"})]
                     + [(f"analytic, k = {k}", {"visibility_samples": k}) for k in (1, 2, 3, 4)]):
        t0 = time.perf_counter()
        ratio, rows_sum = furnace_error(cm, **kw)
        err = np.abs(ratio - 1)
        rows.append({"method": name, "max_rel_error": float(err.max()),
                     "p95_rel_error": float(np.percentile(err, 95)),
                     "row_sum_min": float(rows_sum.min()), "row_sum_max": float(rows_sum.max()),
                     "seconds": round(time.perf_counter() - t0, 2)})
    out["closed_cornell_furnace"] = {"n_patches": cm.n_patches, "n_elements": cm.n_elements,
                                     "rows": rows}
    lines += ["", f"## Closed Cornell box with its blocks as a furnace ({cm.n_patches} patches, "
              f"{cm.n_elements} elements)", "",
              "| method | max rel. error | 95th pct | row sum min | row sum max | seconds |",
              "|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['method']} | {r['max_rel_error']:.2%} | {r['p95_rel_error']:.2%} | "
              f"{r['row_sum_min']:.4f} | {r['row_sum_max']:.4f} | {r['seconds']:.2f} |" for r in rows]

    scene = scenes.cornell_box(blocks=False)
    rows = []
    for levels in (1, 2, 3):
        m = mesh_scene(scene, 275.0, element_levels=levels)
        fmats = {"hemicube res 100": form_factor_matrix(m, form_factors="hemicube"),
                 "centroid (near = 0)": analytic_matrix(m, near=0.0, order=1),
                 "default (analytic)": form_factor_matrix(m)}
        pct, n = pair_errors(m, fmats, args.pairs)
        rows.append({"n_patches": m.n_patches, "n_elements": m.n_elements, "pairs": n,
                     "percentiles_50_95_99": pct})
    out["empty_cornell_pairs"] = rows
    lines += ["", "## Per element-patch factors, empty Cornell box, vs the element-integrated "
              "exact factor (Gauss order 24)", "",
              "| elements | pairs | method | 50th | 95th | 99th |", "|---:|---:|---|---:|---:|---:|"]
    for r in rows:
        for name, p in r["percentiles_50_95_99"].items():
            lines.append(f"| {r['n_elements']} | {r['pairs']} | {name} | {p[0]:.2%} | {p[1]:.2%} "
                         f"| {p[2]:.2%} |")
    lines += ["", f"Machine: {machine()}", ""]
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "formfactors.json").write_text(json.dumps(out, indent=2) + "\n")
    (RESULTS / "formfactors.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
