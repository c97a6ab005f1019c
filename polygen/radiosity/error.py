"""Image error against a reference: the yardstick for comparing radiosity meshes.

Chapters 3 and 4 compare meshes by what they cost (elements) and what they
show (the image).  This module makes that comparison measurable: a
solution is rendered with Gouraud shading (2.8-2.10) by the same camera as
a *reference* -- the solution on a much finer mesh -- and the image error is
the relative RMS difference over the pixels that show a surface::

    e = sqrt( mean_pixels,channels (I - I_ref)^2 ) / sqrt( mean (I_ref^2) )

in linear radiosity (before tone mapping).  Geometry is the same for every
mesh of a scene (the polygons do not change), so the pixels covered are the
same and the error measures shading only.

:func:`uniform_curve` and :func:`adaptive_curve` give the two baselines of
chapters 3 and 4 as curves of (elements, error): uniform meshes of
decreasing size, and adaptive subdivision (Def. 2.6) repeated on a coarse
mesh.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from polygen.radiosity.adaptive import adaptive_refine, bright_scale
from polygen.radiosity.mesh import MeshError, RadiosityMesh, mesh_scene
from polygen.radiosity.raster import Camera, RasterError, node_intensities, render
from polygen.radiosity.solve import progressive_refinement

__all__ = ["ErrorPoint", "shade", "image_error", "uniform_curve", "adaptive_curve", "adaptive_at_count"]


@dataclass(frozen=True)
class ErrorPoint:
    """One mesh on an error curve.

    Attributes
    ----------
    label : str
        What the mesh is (e.g. ``"uniform 40"``, ``"adaptive level 2"``).
    n_elements, n_patches : int
    error : float
        Relative RMS image error against the reference (:func:`image_error`).
    seconds : float
        Meshing plus solving time.
    """

    label: str
    n_elements: int
    n_patches: int
    error: float
    seconds: float


def shade(mesh, radiosity, camera, *, shading="gouraud"):
    """Render element radiosities of a mesh in linear units.

    Parameters
    ----------
    mesh : RadiosityMesh
    radiosity : (M, 3) float64
        Element radiosities (e.g. ``result.display_radiosity(mesh)``).
    camera : Camera
    shading : {"gouraud", "flat"}, keyword-only
        Gouraud interpolates node intensities (2.8-2.10); flat paints
        each element with its own value.

    Returns
    -------
    image : (H, W, 3) float64
        Background pixels are NaN, so they never count as error.
    """
    if not isinstance(mesh, RadiosityMesh):
        raise MeshError(f"mesh must be a RadiosityMesh, got {type(mesh).__name__}")
    if not isinstance(camera, Camera):
        raise RasterError(f"camera must be a Camera, got {type(camera).__name__}")
    b = np.asarray(radiosity, dtype=np.float64)
    if b.shape != (mesh.n_elements, 3):
        raise RasterError(f"radiosity must be ({mesh.n_elements}, 3), got {b.shape}")
    colors = node_intensities(mesh, b) if shading == "gouraud" else b
    return render(mesh.nodes, mesh.elements, colors, camera, shading=shading,
                  background=np.nan)


def image_error(image, reference, *, mask=None):
    """Relative RMS difference of two linear images over the pixels both show.

    Parameters
    ----------
    image, reference : (H, W, C) float64
        From :func:`shade` (NaN where no surface is seen).
    mask : (H, W) bool, keyword-only, optional
        Take the difference over these of the shown pixels only (a shadow,
        a penumbra), still relative to the reference's RMS over all shown
        pixels, so that errors over different masks share one scale.

    Returns
    -------
    float
        ``sqrt(mean((image - reference)**2)) / sqrt(mean(reference**2))``
        over the pixels where neither is NaN.
    """
    a = np.asarray(image, dtype=np.float64)
    r = np.asarray(reference, dtype=np.float64)
    if a.shape != r.shape:
        raise RasterError(f"image {a.shape} and reference {r.shape} differ in shape")
    seen = np.isfinite(a).all(axis=-1) & np.isfinite(r).all(axis=-1)
    if not seen.any():
        raise RasterError("the image and the reference share no covered pixel")
    norm = np.sqrt(np.mean(r[seen] ** 2))
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != a.shape[:2]:
            raise RasterError(f"mask must be {a.shape[:2]}, got {mask.shape}")
        seen &= mask
        if not seen.any():
            raise RasterError("the mask covers no pixel that both images show")
    d = a[seen] - r[seen]
    return float(np.sqrt(np.mean(d * d)) / norm)


def _solve(mesh, solve):
    result = progressive_refinement(mesh, **solve)
    return result, result.display_radiosity(mesh)


def uniform_curve(scene, camera, reference, patch_sizes, *, element_levels=1, mesher=None,
                  solve=None):
    """Image error of uniform meshes, one per patch size.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    reference : (H, W, 3) float64
        The reference image (:func:`shade` of a much finer solution).
    patch_sizes : sequence of float
        Patch sizes, e.g. decreasing.
    element_levels : int, keyword-only
        Passed to :func:`~polygen.radiosity.mesh_scene`.
    mesher : callable, keyword-only
        Patch mesher (default: :func:`~polygen.radiosity.lattice_delaunay_mesher`).
    solve : dict, keyword-only
        Keywords of :func:`~polygen.radiosity.progressive_refinement`.

    Returns
    -------
    list of ErrorPoint
    """
    solve = {} if solve is None else dict(solve)
    kw = {} if mesher is None else {"mesher": mesher}
    out = []
    for size in patch_sizes:
        t0 = time.perf_counter()
        mesh = mesh_scene(scene, float(size), element_levels=element_levels, **kw)
        _, b = _solve(mesh, solve)
        seconds = time.perf_counter() - t0
        out.append(ErrorPoint(f"uniform {size:g}", mesh.n_elements, mesh.n_patches,
                              image_error(shade(mesh, b, camera), reference), seconds))
    return out


def adaptive_curve(scene, camera, reference, patch_size, levels, *, threshold, element_levels=1,
                   mesher=None, solve=None):
    """Image error of adaptive subdivision (Def. 2.6) repeated on a coarse mesh.

    Level 0 is the uniform mesh of ``patch_size``; each further level
    solves, marks the elements whose radiosity differs from an edge
    neighbour's by more than ``threshold`` times the radiosity of the bright
    surfaces (the 95th percentile over the non-emitting elements of the
    first solution), refines them (:func:`~polygen.radiosity.adaptive_refine`) and
    solves again.

    Parameters
    ----------
    scene, camera, reference, element_levels, mesher, solve
        As :func:`uniform_curve`.
    patch_size : float
    levels : int
        Number of refinement rounds after the first solution.
    threshold : float, keyword-only
        Relative jump that marks an element, in (0, 1).

    Returns
    -------
    list of ErrorPoint
        ``levels + 1`` points; ``seconds`` is cumulative (a user waits for
        all rounds).
    """
    if not 0 < threshold < 1:
        raise MeshError(f"threshold must be in (0, 1), got {threshold}")
    if int(levels) != levels or levels < 0:
        raise MeshError(f"levels must be a non-negative integer, got {levels}")
    solve = {} if solve is None else dict(solve)
    kw = {} if mesher is None else {"mesher": mesher}
    t0 = time.perf_counter()
    mesh = mesh_scene(scene, float(patch_size), element_levels=element_levels, **kw)
    _, b = _solve(mesh, solve)
    scale = bright_scale(mesh, b)
    out = [ErrorPoint("adaptive level 0", mesh.n_elements, mesh.n_patches,
                      image_error(shade(mesh, b, camera), reference), time.perf_counter() - t0)]
    for level in range(1, int(levels) + 1):
        mesh = adaptive_refine(mesh, b, threshold * scale).mesh
        _, b = _solve(mesh, solve)
        out.append(ErrorPoint(f"adaptive level {level}", mesh.n_elements, mesh.n_patches,
                              image_error(shade(mesh, b, camera), reference),
                              time.perf_counter() - t0))
    return out


def adaptive_at_count(scene, n_elements, *, patch_size, threshold=0.1, rtol=0.02, element_levels=1,
                      mesher=None, solve=None, max_rounds=16):
    """Adaptive subdivision (Def. 2.6) from a coarse mesh, stopped at a given element count.

    For comparing a mesh with adaptive subdivision at an equal element
    count.  Rounds as :func:`adaptive_curve` (``threshold`` times the bright
    surfaces' radiosity) follow while the next one stays below
    ``(1 - rtol) * n_elements``; the round that would pass it is made with a
    larger threshold, found by bisection, so that only the largest jumps are
    split and the count lands within ``rtol`` of ``n_elements``.

    Parameters
    ----------
    scene : Scene
    n_elements : int
        The element count to reach.
    patch_size : float, keyword-only
        The starting uniform mesh's patch size.
    threshold : float, keyword-only
        Relative jump that marks an element, in (0, 1).
    rtol : float, keyword-only
        Allowed relative difference from ``n_elements``.
    element_levels, mesher, solve : keyword-only
        As :func:`uniform_curve`.
    max_rounds : int, keyword-only

    Returns
    -------
    mesh : RadiosityMesh
        Within ``rtol`` of ``n_elements``.
    result : RadiosityResult
        Its solution.

    Raises
    ------
    MeshError
        If the starting mesh already has more than ``(1 + rtol) * n_elements``
        elements, or no threshold lands within ``rtol``.
    """
    if not 0 < threshold < 1:
        raise MeshError(f"threshold must be in (0, 1), got {threshold}")
    if not 0 < rtol < 1:
        raise MeshError(f"rtol must be in (0, 1), got {rtol}")
    n = int(n_elements)
    solve = {} if solve is None else dict(solve)
    kw = {} if mesher is None else {"mesher": mesher}
    mesh = mesh_scene(scene, float(patch_size), element_levels=element_levels, **kw)
    if mesh.n_elements > (1 + rtol) * n:
        raise MeshError(f"the starting mesh has {mesh.n_elements} elements, more than "
                        f"{n_elements} (1 + {rtol}); give a larger patch_size")
    result, b = _solve(mesh, solve)
    scale = bright_scale(mesh, b)
    for _ in range(int(max_rounds)):
        if abs(mesh.n_elements - n) <= rtol * n:
            return mesh, result
        nxt = adaptive_refine(mesh, b, threshold * scale).mesh
        if nxt.n_elements == mesh.n_elements:
            break
        if nxt.n_elements > (1 + rtol) * n:
            # the count falls as the threshold rises: bisect between this round's and the largest jump
            lo, hi = threshold * scale, float(np.max(b))
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                nxt = adaptive_refine(mesh, b, mid).mesh
                if abs(nxt.n_elements - n) <= rtol * n:
                    break
                lo, hi = (mid, hi) if nxt.n_elements > n else (lo, mid)
            else:
                break
        mesh = nxt
        result, b = _solve(mesh, solve)
    if abs(mesh.n_elements - n) <= rtol * n:
        return mesh, result
    raise MeshError(f"adaptive subdivision reached {mesh.n_elements} elements, not {n_elements} "
                    f"within {rtol}")
