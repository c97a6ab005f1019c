"""Where the combination's extra image error sits (diagnosis).

One pair of meshes of similar element counts on the scene of Fig. 4.8, with the settings of
``benchmarks/intensity_mesh.py``:

* the combination, ``combined_bubble_mesh`` at ``size_initial`` 1.7, ``size_min`` 2.2,
  ``size_max`` 0.85, width cap, ``lines="narrow"`` (``intensity_mesh_narrow.md``: 2808
  elements) -- and, from the same first pass, the default ``lines="all"`` (3664);
* this method from the fine first mesh (``--fine-first``: ``size_initial`` 1.2,
  ``size_min`` 1.5, ``size_max`` 0.6; 3088 elements), the point of this method's curve the
  combination is compared with at those counts; and this method at 1.7 (1448) for the counts.

The yardstick is the benchmark's (:mod:`polygen.radiosity.error`: a 160^2 Gouraud image
against the uniform mesh of 1.1 with 16 elements per patch).  Per pixel: the squared error
summed over RGB, for each mesh.  Each covered pixel gets the world point of the reference
surface seen there (the reference mesh rendered with its node positions as colours) and the
polygon of that surface; the zones, fixed before measuring, are taken from the
combination's mesh (the one whose extra error is looked for), first match wins:

1. ``skinny``: the combination's element seen at that pixel has a smallest angle < 20 deg;
2. ``strip``: the pixel lies in a region of the combination's second-mesh lines whose local
   width there (:func:`polygen.mesh2d.region_width.region_width`) is < 2 h, h the
   combination's element size at that pixel (the side of the equilateral triangle of the
   element's area): a strip at most two elements wide between merged lines;
3. ``near lines``: within h of a discontinuity line as found
   (``SimplifiedDiscontinuity.segments``);
4. ``elsewhere``.

Also split: pixels in a penumbra region of the lines as found, or not.  Element counts: the
elements whose centroid lies within 0.425 / 0.85 / 1.7 (the finest element at 1.7, the
patch size at size_max, size_initial) of a line as found, and the rest.

    python benchmarks/experiments/combination_error_zones.py

Writes ``benchmarks/experiments/results/combination_error_zones.json`` and ``.md``.
"""

from __future__ import annotations

import json
import os
import time

import numpy as np

import _experiment  # noqa: F401  (benchmarks/_common.py, results under experiments/results/)
from _common import RESULTS, machine, write_results
from intensity_mesh import IMPROVE, SIZE_MIN_RATIO, camera

from polygen.discontinuity import simplified_discontinuity
from polygen.discontinuity.combined import _nearest_on_segments, combined_bubble_mesh
from polygen.mesh2d.region_width import region_width
from polygen.radiosity import intensity_bubble_mesh, mesh_scene, progressive_refinement, scenes
from polygen.radiosity.error import image_error, shade
from polygen.radiosity.layout import polygon_layout
from polygen.radiosity.raster import render

ZONES = ("skinny", "strip", "near lines", "elsewhere")
SKINNY_DEG = 20.0
BANDS = (0.425, 0.85, 1.7)


def line_distance(scene, segments, poly_of, xyz):
    """Distance in its polygon's plane from each point to that polygon's lines (inf: none)."""
    d = np.full(len(xyz), np.inf)
    for k, sg in segments.items():
        m = poly_of == k
        if not m.any() or len(sg) == 0:
            continue
        poly = scene.polygons[k]
        ends, _ = sg.in_plane(poly)
        d[m], _ = _nearest_on_segments(poly.to_2d(xyz[m]), np.asarray(ends).reshape(-1, 2, 2))
    return d


def main():
    t0 = time.perf_counter()
    solve = {"tol": 0.01, "ambient": True}
    sc = scenes.three_rectangles_box()
    cam = camera(160)
    sd = simplified_discontinuity(sc)
    comb_all = combined_bubble_mesh(sc, size_initial=1.7, size_min=SIZE_MIN_RATIO * 1.7,
                                    size_max=0.85, solve=solve, discontinuity=sd,
                                    improve=IMPROVE)
    comb = combined_bubble_mesh(sc, size_initial=1.7, size_min=SIZE_MIN_RATIO * 1.7,
                                size_max=0.85, solve=solve, discontinuity=sd, improve=IMPROVE,
                                lines="narrow", first=comb_all)
    ours = intensity_bubble_mesh(sc, size_initial=1.2, size_min=1.25 * 1.2, size_max=0.6,
                                 solve=solve)
    ours17 = intensity_bubble_mesh(sc, size_initial=1.7, size_min=SIZE_MIN_RATIO * 1.7,
                                   size_max=0.85, solve=solve, improve=IMPROVE)
    print(f"meshes {time.perf_counter() - t0:.0f} s", flush=True)
    ref_mesh = mesh_scene(sc, 1.1, element_levels=2)
    ref_b = progressive_refinement(ref_mesh, **solve).display_radiosity(ref_mesh)
    reference = shade(ref_mesh, ref_b, cam)
    print(f"reference {ref_mesh.n_elements} elements, {time.perf_counter() - t0:.0f} s",
          flush=True)
    # world point and polygon of every covered pixel (the fine reference surface)
    pos, rid = render(ref_mesh.nodes, ref_mesh.elements, ref_mesh.nodes, cam,
                      background=np.nan, return_ids=True)
    seen = rid >= 0
    xyz = pos[seen]
    poly_of = ref_mesh.element_polygon[rid[seen]]

    meshes = {"combination, narrow lines": comb, "combination, all lines": comb_all,
              "this method, fine first": ours}
    img, ids, err = {}, {}, {}
    for name, r in meshes.items():
        m = r.second_mesh
        im = shade(m, r.second_radiosity, cam)
        _, ids[name] = render(m.nodes, m.elements, np.zeros(m.n_nodes), cam, return_ids=True)
        err[name] = image_error(im, reference)
        img[name] = im
        print(f"{name}: {m.n_elements} elements, error {err[name]:.5f}", flush=True)
    ok = seen & np.all([np.isfinite(v).all(axis=-1) for v in img.values()], axis=0)
    ok_s = ok[seen]
    refs = reference[seen]
    norm = float(np.mean(reference[ok] ** 2))    # image_error's denominator (per channel)
    sq = {n: ((v[seen] - refs) ** 2).sum(axis=-1) for n, v in img.items()}

    lines_found = sd.segments
    dline = line_distance(sc, lines_found, poly_of, xyz)
    in_pen = np.zeros(len(xyz), bool)
    for k, sg in lines_found.items():
        m = poly_of == k
        pp = sd.penumbra_points.get(k)
        if not m.any() or pp is None or len(pp) == 0:
            continue
        lay = polygon_layout(sc.polygons[k], sg)
        pen = np.unique(lay.region_of(np.asarray(pp)))
        in_pen[m] = np.isin(lay.region_of(sc.polygons[k].to_2d(xyz[m])), pen[pen >= 0])

    rows, zone_of = [], {}
    for cname in ("combination, narrow lines", "combination, all lines"):
        cm = meshes[cname].second_mesh
        el = ids[cname][seen]
        ang, _ = cm.element_quality()
        h = np.sqrt(4.0 * cm.element_area / np.sqrt(3.0))
        he = np.where(el >= 0, h[np.maximum(el, 0)], np.nan)
        skinny = (el >= 0) & (ang[np.maximum(el, 0)] < SKINNY_DEG)
        strip = np.zeros(len(xyz), bool)
        segs2 = meshes[cname].parameters["second_segments"]
        for k, sg in segs2.items():
            m = (poly_of == k) & (el >= 0)
            if not m.any():
                continue
            poly = sc.polygons[k]
            lay = polygon_layout(poly, sg)
            p2 = poly.to_2d(xyz[m])
            reg = lay.region_of(p2)
            w = np.full(len(p2), np.inf)
            for r in np.unique(reg[reg >= 0]):
                q = reg == r
                w[q] = region_width(lay, int(r), p2[q])
            idx = np.flatnonzero(m)
            strip[idx] = w < 2.0 * he[idx]
        near = dline < np.nan_to_num(he, nan=0.0)
        zone = np.full(len(xyz), 3)
        zone[near] = 2
        zone[strip] = 1
        zone[skinny] = 0
        zone_of[cname] = zone
        tot = {n: float(sq[n][ok_s].sum()) for n in meshes}
        for z, zname in enumerate(ZONES):
            for pen_name, pen_mask in (("all", np.ones_like(in_pen)), ("penumbra", in_pen),
                                       ("outside penumbra", ~in_pen)):
                mz = ok_s & (zone == z) & pen_mask
                row = {"zones of": cname, "zone": zname, "penumbra": pen_name,
                       "pixels": int(mz.sum())}
                for n, short in ((cname, "combination"),
                                 ("this method, fine first", "this method")):
                    row[f"{short}: sq error share"] = round(float(sq[n][mz].sum()) / tot[n], 4)
                    row[f"{short}: rms in zone"] = (
                        round(float(np.sqrt(sq[n][mz].mean() / 3 / norm)), 5) if mz.any() else None)
                extra = float((sq[cname][mz] - sq["this method, fine first"][mz]).sum())
                row["extra sq error / combination total"] = round(extra / tot[cname], 4)
                rows.append(row)
    counts = []
    for name, r in list(meshes.items()) + [("this method 1.7", ours17)]:
        m = r.second_mesh
        d = line_distance(sc, lines_found, m.element_polygon, m.element_centroid)
        row = {"mesh": name, "elements": m.n_elements}
        for b in BANDS:
            row[f"within {b:g} of a line"] = int((d < b).sum())
        row["area within 0.85"] = round(float(m.element_area[d < 0.85].sum()), 2)
        counts.append(row)
        print(row, flush=True)
    for row in rows:
        if row["penumbra"] == "all":
            print(row, flush=True)
    notes = [" ".join(__doc__.split("\n\n")[2].split()),
             " ".join(__doc__.split("\n\n")[3].split()),
             " ".join(__doc__.split("\n\n")[4].split()),
             "errors: " + ", ".join(f"{n} {meshes[n].second_mesh.n_elements} elements "
                                    f"{e:.5f}" for n, e in err.items())
             + f"; reference {ref_mesh.n_elements} elements",
             "sq error share: that mesh's squared error (RGB summed) in the zone over its "
             "total; rms in zone: relative RMS over the zone's pixels (image_error's "
             "denominator); extra: (combination - this method) squared error in the zone over "
             "the combination's total (their totals differ by that much over all zones)",
             f"load average at the end: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; "
             f"{time.perf_counter() - t0:.0f} s"]
    RESULTS.mkdir(parents=True, exist_ok=True)
    write_results("combination_error_zones", rows + [dict(table="elements", **c) for c in counts],
                  list(rows[0].keys()) + ["table", "mesh", "elements"]
                  + [f"within {b:g} of a line" for b in BANDS] + ["area within 0.85"],
                  title="Where the combination's extra image error sits",
                  notes=notes)
    (RESULTS / "combination_error_zones.json").write_text(json.dumps(
        {"machine": machine(), "errors": err, "zones": rows, "elements": counts,
         "totals_sq": {n: float(sq[n][ok_s].sum()) for n in meshes}}, indent=2) + "\n")
    np.savez_compressed("/tmp/comb15_zones.npz", reference=reference, seen=seen,
                        xyz=xyz, poly_of=poly_of, dline=dline, in_pen=in_pen,
                        **{f"img_{i}": v for i, v in enumerate(img.values())},
                        **{f"zone_{i}": v for i, v in enumerate(zone_of.values())})


if __name__ == "__main__":
    main()
