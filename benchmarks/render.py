"""Volume rendering (thesis 7.8): our ray caster against VTK's, equi-distance surfaces against ray casting.

Part 1, against VTK: our ray caster and VTK's
``vtkUnstructuredGridVolumeRayCastMapper`` (the Bunyk caster pyvista's
``add_volume(..., mapper="ugrid")`` uses) on the same grid, transfer
function (opacity per the same unit length), view and rays (VTK's camera
moved half a pixel so that it casts through the pixel centres, as ours),
shading off (the mapper does not shade). Hexahedral volumes: VTK's caster
takes tetrahedra, so VTK cuts them first (``vtkDataSetTriangleFilter``);
ours walks the hexahedra. PSNR over the foreground (the pixels either image
covers) and over the whole image, for both optical models: ``attenuation``
(VTK's: ``a / unit`` is the attenuation coefficient) and ``opacity``
(polygen's default: ``a`` is the opacity of a slab ``unit`` thick); ``ratio``
is our foreground's summed colour over VTK's. Frames alternate between the
two; the time per frame is the median. Ours includes binning the boundary
faces for the view (as if the view were new each frame); VTK's includes
reading the image back.

Part 2, equi-distance surfaces against ray casting, same view and sample
spacing: PSNR (35 dB asked, fixed before measuring); ``T_prepare`` is the renderer's
construction for the first eye (node gradients, distance, extrema,
skeleton, incidence tables), ``T_shells`` and ``T_fragments`` the first
frame's surfaces and their crossings with the rays. Then, for a fixed eye,
re-rendering after a transfer-function change, each renderer with and
without its cache: ``tf_change_s``, the equi-distance renderer with its
fragments kept (only (7.1) runs again); ``redraw_s``, the same with the
fragments recomputed from the kept surfaces; ``recast_s``, the ray caster
walking again; ``rekept_s``, the ray caster re-classifying its kept samples
(``RayCaster(keep_samples=True)``); ``T_first_kept``, the kept caster's
first frame (walk and store). ``kept_MB`` and ``fragments_MB``: the bytes
each cache holds, from its arrays. Medians of alternating runs.

Part 3, the skeleton's cost when the eye moves (7.8.3: distance at the
nodes, extrema, thinning, plus the edge-centred incidence tables), against
the cell count; chapter 7 says O(n).

Wall-clock seconds on a shared 2-core machine; numba compiled beforehand.

    python benchmarks/render.py            # 256 x 256 images, data 1-5, hexa 1-3
    python benchmarks/render.py --quick    # 96 x 96, data 1, 4, hexa1
"""

import argparse
import json
import os
import statistics
import time

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402

from _common import RESULTS, fmt, machine  # noqa: E402
from polygen.volume import datasets  # noqa: E402
from polygen.volume.render import (View, Lighting, RayCaster, ShellRenderer, TransferFunction,  # noqa: E402
                                   foreground, psnr)


def view(vol, size):
    lo, hi = vol.points.min(0), vol.points.max(0)
    c = (lo + hi) / 2
    diag = float(np.linalg.norm(hi - lo))
    return View(eye=c + diag * np.array([1.2, -1.6, 0.9]), target=c, fov=35, size=(size, size)), diag


def tfs(vol, diag):
    s = vol.scalars()
    return [TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.6), unit=diag / 20),
            TransferFunction.ramp(s.min(), s.max(), cmap="magma", opacity=(0.5, 0.05), unit=diag / 20),
            TransferFunction.ramp(s.min(), s.max(), cmap="coolwarm", opacity=(0.3, 0.3), unit=diag / 20)]


def against_vtk(name, size, frames, samples_per_diag):
    from polygen.plotting.render import VtkUgridRayCaster

    vol = datasets.load(name)
    cam, diag = view(vol, size)
    tf = tfs(vol, diag)[0]
    step = diag / samples_per_diag
    flat = Lighting(shade=False)
    rc = RayCaster(vol)
    vtk = VtkUgridRayCaster(vol, cam, tf)
    vtk.render()  # first frame: VTK builds its cell tables
    rc.render(cam, tf, step=step, lighting=flat, optical_model="attenuation")
    ours, theirs = [], []
    for _ in range(frames):
        rc._bins = None  # a new view each frame: the boundary is binned again
        t0 = time.perf_counter()
        mine = rc.render(cam, tf, step=step, lighting=flat, optical_model="attenuation")
        ours.append(time.perf_counter() - t0)
        img, t = vtk.render()
        theirs.append(t)
    vtk.close()
    row = {"data": name, "cells": vol.n_cells, "vtk_cells": vtk.n_cells, "size": size, "step": step,
           "ours_s": statistics.median(ours), "vtk_s": statistics.median(theirs),
           "speedup": statistics.median(theirs) / statistics.median(ours)}
    dense = rc.render(cam, tf, step=step, lighting=flat, optical_model="opacity").image
    for model, image in (("attenuation", mine.image), ("opacity", dense)):
        fg = foreground(image, img)
        row[f"fg_psnr_{model}"] = psnr(image, img, mask=fg)
        row[f"psnr_{model}"] = psnr(image, img)
        row[f"ratio_{model}"] = float(image[fg].sum() / img[fg].sum())
        row["fg_fraction"] = float(fg.mean())
    return row


def shells_vs_rays(name, size, repeats, samples_per_diag):
    vol = datasets.load(name)
    cam, diag = view(vol, size)
    step = diag / samples_per_diag
    tf = tfs(vol, diag)
    rc = RayCaster(vol)
    rck = RayCaster(vol, keep_samples=True)
    t0 = time.perf_counter()
    sr = ShellRenderer(vol, cam)
    build = time.perf_counter() - t0
    first = sr.render(tf[0], step=step)
    ray = rc.render(cam, tf[0], step=step)
    t0 = time.perf_counter()
    rck.render(cam, tf[0], step=step)
    first_kept = time.perf_counter() - t0
    sh = sr.shells(step)
    frag = sr.fragments(step)
    row = {"data": name, "cells": vol.n_cells, "size": size, "step": step, "shells": len(sh.radii),
           "triangles": sh.n_triangles, "psnr": psnr(ray.image, first.image),
           "fg_psnr": psnr(ray.image, first.image, mask=foreground(ray.image, first.image)),
           "T_prepare": build, "T_shells": first.seconds["shells"], "T_fragments": first.seconds["fragments"],
           "T_first_kept": first_kept, "kept_MB": rck.kept_bytes / 1e6,
           "fragments_MB": sum(a.nbytes for a in frag[:3]) / 1e6}
    recast, rekept, recomposite, redraw = [], [], [], []
    for i in range(repeats):
        t = tf[1 + i % 2]
        t0 = time.perf_counter()
        rc.render(cam, t, step=step)
        recast.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        rck.render(cam, t, step=step)
        rekept.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        sr.render(t, step=step)
        recomposite.append(time.perf_counter() - t0)
        sr._fragments.clear()  # the surfaces drawn again from scratch (they are kept)
        t0 = time.perf_counter()
        sr.render(t, step=step)
        redraw.append(time.perf_counter() - t0)
    assert rck.walks == 1  # every re-render above re-classified the kept samples
    row.update(recast_s=statistics.median(recast), rekept_s=statistics.median(rekept),
               tf_change_s=statistics.median(recomposite), redraw_s=statistics.median(redraw))
    return row


def skeleton_cost(name, repeats):
    vol = datasets.load(name)
    cam, diag = view(vol, 8)
    sr = ShellRenderer(vol, cam)
    ts, thin, inc = [], [], []
    for i in range(repeats):
        moved = cam.replace(eye=tuple(np.array(cam.eye) + [0.05 * diag * (i + 1), 0.0, 0.0]))
        sr.set_camera(moved)
        ts.append(sr.skeleton_s)
        thin.append(sr.method.seed_preprocess_s)
        inc.append(sr.method.construct_preprocess_s)
    t = min(ts)
    return {"data": name, "cell_type": vol.cell_type, "cells": vol.n_cells, "T_eye_moved": t,
            "T_thinning": min(thin), "T_incidence": min(inc), "us_per_cell": 1e6 * t / vol.n_cells,
            "skeleton_cells": sr.skeleton.n_cells, "extrema": sr.extrema.n}


def md_table(title, rows, cols):
    lines = [f"## {title}", "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r.get(c, "")) for c in cols) + " |" for r in rows]
    return lines + [""]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    size = 96 if args.quick else 256
    tets = ["data1", "data4"] if args.quick else ["data1", "data2", "data3", "data4", "data5"]
    hexes = ["hexa1"] if args.quick else ["hexa1", "hexa2", "hexa3"]
    frames = 3 if args.quick else 5
    # compile every kernel once
    vol = datasets.load("data1")
    cam, diag = view(vol, 8)
    ShellRenderer(vol, cam).render(tfs(vol, diag)[0], step=diag / 50)
    RayCaster(vol).render(cam, tfs(vol, diag)[0], step=diag / 50)
    kept = RayCaster(vol, keep_samples=True)
    for tf in tfs(vol, diag)[:2]:
        kept.render(cam, tf, step=diag / 50)

    vtk_rows = [against_vtk(n, size, frames, 200) for n in tets + hexes]
    shell_rows = [shells_vs_rays(n, size, frames, 100) for n in tets + hexes]
    skel_rows = sorted([skeleton_cost(n, 3) for n in tets + hexes], key=lambda r: r["cells"])
    out = {"machine": machine(), "size": size, "vtk": vtk_rows, "shells": shell_rows, "skeleton": skel_rows}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "render.json").write_text(json.dumps(out, indent=2) + "\n")
    lines = [f"# Volume rendering (thesis 7.8), {size} x {size} images", ""]
    lines += md_table("Our ray caster against VTK's vtkUnstructuredGridVolumeRayCastMapper (shading off, same rays, "
                      "samples diag/200 apart; hexahedra cut into tetrahedra by VTK for VTK; medians of alternating "
                      "frames, ours with VTK's optical model). PSNR over the foreground (fg_) and the whole image, "
                      "ours with VTK's optical model (attenuation) and with ours (opacity)", vtk_rows,
                      ["data", "cells", "vtk_cells", "ours_s", "vtk_s", "speedup", "fg_fraction",
                       "fg_psnr_attenuation", "psnr_attenuation", "ratio_attenuation", "fg_psnr_opacity",
                       "psnr_opacity", "ratio_opacity"])
    lines += md_table("Equi-distance surfaces against ray casting (samples and surfaces diag/100 apart): PSNR, "
                      "and re-rendering after a transfer-function change, each renderer with its cache and without",
                      shell_rows,
                      ["data", "cells", "shells", "triangles", "psnr", "fg_psnr", "T_prepare", "T_shells",
                       "T_fragments", "T_first_kept", "recast_s", "rekept_s", "tf_change_s", "redraw_s", "kept_MB",
                       "fragments_MB"])
    lines += md_table("Skeleton rebuilt when the eye moves (distance, extrema, thinning, incidence tables)",
                      skel_rows, ["data", "cell_type", "cells", "T_eye_moved", "T_thinning", "T_incidence",
                                  "us_per_cell", "skeleton_cells", "extrema"])
    load = [round(x, 1) for x in os.getloadavg()]
    out["load_average"] = load
    (RESULTS / "render.json").write_text(json.dumps(out, indent=2) + "\n")
    lines += [f"- machine: {machine()}; load average at the end (1, 5, 15 min): {load} -- a shared machine, so "
              "compare the columns of one row (they ran alternately), not absolute seconds",
              "- psnr: dB, images in [0, 1]; seconds are wall clock"]
    (RESULTS / "render.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
