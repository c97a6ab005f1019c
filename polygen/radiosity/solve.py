"""Radiosity solvers: progressive refinement shooting and Gauss-Seidel gathering.

Both solve the same linear system on a :class:`RadiosityMesh` (patches
shoot, elements gather; thesis (2.7) with reciprocity (2.5))::

    B_e = E_e + rho_e * sum_p F(e -> p) B_p,      B_p = sum_{e in p} A_e B_e / A_p

per RGB channel, where ``E_e`` includes the direct light of point and
parallel lights (``rho_e`` times their irradiance).

* :func:`progressive_refinement` (2.2.2, Cohen et al. 1988): repeatedly
  pick the patch with the largest unshot power, compute its form factors
  to all elements (one hemicube at the patch centroid, or Lambert's formula
  with ray-cast visibility at each element), and add
  ``rho_e * dB_p * F(e -> p)`` to every element's radiosity and unshot
  radiosity.  Memory is linear in the number of elements.
* :func:`gauss_seidel` (2.2.1, (2.3)): assemble the (M, P) matrix of
  F(e -> p) and sweep Gauss-Seidel over the elements.

Note on notation: the thesis writes F_ij for "the fraction of light leaving
j that arrives at i"; here F(a -> b) is the fraction of light leaving a that
arrives at b, so reciprocity reads A_a F(a -> b) = A_b F(b -> a).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from polygen._jit import njit
from polygen.radiosity.formfactor import (
    analytic_column,
    direct_irradiance,
    pack_polygons,
    triangle_samples,
)
from polygen.radiosity.hemicube import delta_form_factors, hemicube_column
from polygen.radiosity.mesh import RadiosityMesh

__all__ = [
    "SolverError",
    "RadiosityResult",
    "FormFactorColumns",
    "progressive_refinement",
    "gauss_seidel",
    "form_factor_matrix",
]


PARALLEL_MIN_ELEMENTS = 20000


class SolverError(ValueError):
    """Bad solver input."""


@dataclass(frozen=True)
class RadiosityResult:
    """Element radiosities and how they were obtained.

    Attributes
    ----------
    radiosity : (M, 3) float64
        Element radiosity B (without the ambient term).
    irradiance : (M, 3) float64
        Light arriving at each element from the other surfaces and lights
        (so ``B = E + rho * irradiance``).
    unshot : (M, 3) float64
        Unshot radiosity left on the elements (progressive refinement).
    ambient : (3,) float64
        Cohen et al.'s ambient radiosity estimate for the unshot energy;
        zero unless asked for.
    history : (k,) float64
        Progressive refinement: total unshot power / initial power before
        each shot and after the last.  Gauss-Seidel: max change per sweep.
    shots : (k-1,) int64
        Patch shot at each step (empty for Gauss-Seidel).
    emitted_power : (3,) float64
        Initial unshot power sum_e A_e E_e (self-emission plus direct light).
    converged : bool
    method : str
    seconds : float
    """

    radiosity: np.ndarray
    irradiance: np.ndarray
    unshot: np.ndarray
    ambient: np.ndarray
    history: np.ndarray
    shots: np.ndarray
    emitted_power: np.ndarray
    converged: bool
    method: str
    seconds: float
    stats: dict = field(default_factory=dict)

    def display_radiosity(self, mesh):
        """(M, 3) radiosity plus the ambient term rho_e * ambient, for display."""
        return self.radiosity + mesh.element_reflectance * self.ambient

    def absorbed_power(self, mesh):
        """(3,) float64: power absorbed by all elements, sum A_e (1 - rho_e) H_e."""
        return ((1.0 - mesh.element_reflectance) * self.irradiance
                * mesh.element_area[:, None]).sum(axis=0)

    def unshot_power(self, mesh):
        """(3,) float64: power not yet shot, sum A_e dB_e."""
        return (self.unshot * mesh.element_area[:, None]).sum(axis=0)


class FormFactorColumns:
    """F(e -> p) for one patch p at a time, by the hemicube or analytically.

    Parameters
    ----------
    mesh : RadiosityMesh
    method : {"hemicube", "analytic"}
    resolution : int
        Hemicube top-face resolution (even).
    visibility_level : int
        Analytic method: ``4**visibility_level`` visibility samples per patch.
    parallel : bool or None
        Multi-threaded kernels; None: only for meshes of at least
        ``PARALLEL_MIN_ELEMENTS`` elements (thread start-up dominates below).
    """

    def __init__(self, mesh, method="hemicube", *, resolution=100, visibility_level=0,
                 parallel=None):
        if method not in ("hemicube", "analytic"):
            raise SolverError(f"form factor method must be 'hemicube' or 'analytic', got {method!r}")
        self.mesh = mesh
        self.method = method
        self.resolution = int(resolution)
        self.visibility_level = int(visibility_level)
        if parallel is None:
            parallel = mesh.n_elements >= PARALLEL_MIN_ELEMENTS
        self.parallel = bool(parallel)
        if method == "hemicube":
            self.delta = delta_form_factors(self.resolution)
        else:
            self.packed = pack_polygons(mesh.scene.polygons)
            self.samples = triangle_samples(self.visibility_level)

    def __call__(self, patch):
        """(M,) float64 F(e -> patch)."""
        if self.method == "hemicube":
            return hemicube_column(self.mesh, patch, delta=self.delta, parallel=self.parallel)
        return analytic_column(self.mesh, patch, packed=self.packed, samples=self.samples,
                               parallel=self.parallel)


# ----------------------------------------------------------------------------
# kernels
# ----------------------------------------------------------------------------
@njit
def _patch_power(unshot, area, element_patch, n_patches, out):
    out[:] = 0.0
    for e in range(unshot.shape[0]):
        p = element_patch[e]
        for c in range(3):
            out[p, c] += area[e] * unshot[e, c]


@njit
def _shoot(p, f_ep, rho, area, element_patch, pe_start, pe_list, patch_area, radiosity, irradiance,
           unshot, power):
    """Shoot patch p's unshot power through F(e -> p): (2.7) with (2.5)."""
    db = np.empty(3)
    for c in range(3):
        db[c] = power[p, c] / patch_area[p]  # unshot radiosity of the patch
        power[p, c] = 0.0
    for k in range(pe_start[p], pe_start[p + 1]):
        e = pe_list[k]
        for c in range(3):
            unshot[e, c] = 0.0
    for e in range(f_ep.shape[0]):
        f = f_ep[e]
        if f == 0.0:
            continue
        q = element_patch[e]
        for c in range(3):
            h = db[c] * f
            irradiance[e, c] += h
            d = rho[e, c] * h
            radiosity[e, c] += d
            unshot[e, c] += d
            power[q, c] += area[e] * d


@njit
def _gauss_seidel_kernel(fmat, emit, rho, area, element_patch, patch_area, tol, max_sweeps,
                         radiosity, history):
    m, n_p = fmat.shape
    bp = np.zeros((n_p, 3))
    for e in range(m):
        for c in range(3):
            bp[element_patch[e], c] += area[e] * radiosity[e, c] / patch_area[element_patch[e]]
    gathered = np.empty(3)
    for sweep in range(max_sweeps):
        change = 0.0
        for e in range(m):
            gathered[:] = 0.0
            for p in range(n_p):
                f = fmat[e, p]
                if f != 0.0:
                    for c in range(3):
                        gathered[c] += f * bp[p, c]
            q = element_patch[e]
            for c in range(3):
                new = emit[e, c] + rho[e, c] * gathered[c]  # (2.2), element form
                d = new - radiosity[e, c]
                if abs(d) > change:
                    change = abs(d)
                bp[q, c] += area[e] * d / patch_area[q]
                radiosity[e, c] = new
        history[sweep] = change
        if change <= tol:
            return sweep + 1
    return max_sweeps


# ----------------------------------------------------------------------------
# drivers
# ----------------------------------------------------------------------------
def _check_mesh(mesh):
    if not isinstance(mesh, RadiosityMesh):
        raise SolverError(f"mesh must be a RadiosityMesh, got {type(mesh).__name__}")


def _ambient(mesh, unshot):
    """Cohen et al. (1988) ambient term: R * (unshot power / total area), R = 1/(1 - rho_avg)."""
    a = mesh.element_area
    rho_avg = (mesh.element_reflectance * a[:, None]).sum(axis=0) / a.sum()
    power = (unshot * a[:, None]).sum(axis=0)
    return power / a.sum() / (1.0 - np.minimum(rho_avg, 1.0 - 1e-12))


def progressive_refinement(mesh, *, form_factors="hemicube", resolution=100, visibility_level=0,
                           tol=1e-3, max_shots=None, ambient=False, progress=False,
                           parallel=None):
    """Progressive refinement radiosity: shoot from patches to elements (2.2.2).

    Parameters
    ----------
    mesh : RadiosityMesh
    form_factors : {"hemicube", "analytic"}, keyword-only
        Hemicube at the shooting patch's centroid, or Lambert's formula at
        each element with ray-cast visibility to the patch.
    resolution : int, keyword-only
        Hemicube top-face resolution (even).
    visibility_level : int, keyword-only
        Analytic: ``4**visibility_level`` visibility samples on the patch.
    tol : float, keyword-only
        Stop when the total unshot power is below ``tol`` times the initial
        (emitted) power.
    max_shots : int, keyword-only
        Upper bound on the number of shots (default 50 * number of patches).
    ambient : bool, keyword-only
        Estimate the ambient term for the remaining unshot energy.
    progress : bool, keyword-only
        Show a tqdm bar of the unshot fraction.
    parallel : bool or None, keyword-only
        Multi-threaded form-factor kernels (default: for large meshes).

    Returns
    -------
    RadiosityResult
    """
    _check_mesh(mesh)
    if not tol > 0:
        raise SolverError(f"tol must be > 0, got {tol}")
    t0 = time.perf_counter()
    columns = FormFactorColumns(mesh, form_factors, resolution=resolution,
                                visibility_level=visibility_level, parallel=parallel)
    n_p = mesh.n_patches
    if max_shots is None:
        max_shots = 50 * n_p
    rho = mesh.element_reflectance
    area = mesh.element_area
    direct = direct_irradiance(mesh)
    irradiance = direct.copy()
    radiosity = mesh.element_emission + rho * direct
    unshot = radiosity.copy()
    power = np.zeros((n_p, 3))
    _patch_power(unshot, area, mesh.element_patch, n_p, power)
    emitted = power.sum(axis=0)
    total0 = float(emitted.sum())
    pe_start, pe_list = mesh.patch_elements
    history = [1.0 if total0 > 0 else 0.0]
    shots = []
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=max_shots, desc="shooting", unit="shot")
    converged = total0 == 0.0
    try:
        while not converged and len(shots) < max_shots:
            psum = power.sum(axis=1)
            p = int(np.argmax(psum))
            f_ep = columns(p)
            _shoot(p, f_ep, rho, area, mesh.element_patch, pe_start, pe_list, mesh.patch_area,
                   radiosity, irradiance, unshot, power)
            shots.append(p)
            frac = float(power.sum()) / total0
            history.append(frac)
            if bar is not None:
                bar.update(1)
                bar.set_postfix(unshot=f"{frac:.2e}")
            converged = frac <= tol
    finally:
        if bar is not None:
            bar.close()
    amb = _ambient(mesh, unshot) if ambient else np.zeros(3)
    return RadiosityResult(radiosity=radiosity, irradiance=irradiance, unshot=unshot, ambient=amb,
                           history=np.asarray(history), shots=np.asarray(shots, dtype=np.int64),
                           emitted_power=emitted, converged=bool(converged),
                           method=f"progressive/{form_factors}",
                           seconds=time.perf_counter() - t0,
                           stats={"n_shots": len(shots), "n_patches": n_p,
                                  "n_elements": mesh.n_elements})


def form_factor_matrix(mesh, *, form_factors="hemicube", resolution=100, visibility_level=0,
                       progress=False):
    """The (M, P) matrix of F(e -> p), one patch column at a time.

    Uses exactly the columns that :func:`progressive_refinement` shoots
    with, so both solvers solve the same system.

    Returns
    -------
    (M, P) float64
    """
    _check_mesh(mesh)
    columns = FormFactorColumns(mesh, form_factors, resolution=resolution,
                                visibility_level=visibility_level)
    out = np.empty((mesh.n_elements, mesh.n_patches))
    it = range(mesh.n_patches)
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="form factors", unit="patch")
    for p in it:
        out[:, p] = columns(p)
    return out


def gauss_seidel(mesh, *, fmat=None, form_factors="hemicube", resolution=100, visibility_level=0,
                 tol=1e-10, max_sweeps=1000, progress=False):
    """Gauss-Seidel gathering on the element/patch system (2.2.1, (2.3)).

    Parameters
    ----------
    mesh : RadiosityMesh
    fmat : (M, P) float64, keyword-only
        Precomputed :func:`form_factor_matrix`; computed when omitted.
    tol : float, keyword-only
        Stop when no element radiosity changes by more than ``tol`` in a sweep.
    max_sweeps : int, keyword-only

    Returns
    -------
    RadiosityResult
        ``history`` holds the largest change per sweep.
    """
    _check_mesh(mesh)
    t0 = time.perf_counter()
    if fmat is None:
        fmat = form_factor_matrix(mesh, form_factors=form_factors, resolution=resolution,
                                  visibility_level=visibility_level, progress=progress)
    fmat = np.ascontiguousarray(fmat, dtype=np.float64)
    if fmat.shape != (mesh.n_elements, mesh.n_patches):
        raise SolverError(f"fmat must be ({mesh.n_elements}, {mesh.n_patches}), got {fmat.shape}")
    rho = mesh.element_reflectance
    direct = direct_irradiance(mesh)
    emit = mesh.element_emission + rho * direct
    radiosity = emit.copy()
    history = np.zeros(int(max_sweeps))
    sweeps = _gauss_seidel_kernel(fmat, emit, rho, mesh.element_area, mesh.element_patch,
                                  mesh.patch_area, float(tol), int(max_sweeps), radiosity, history)
    history = history[:sweeps]
    with np.errstate(divide="ignore", invalid="ignore"):
        irr = np.where(rho > 0, (radiosity - mesh.element_emission) / np.where(rho > 0, rho, 1.0),
                       0.0)
    # for black elements the gathered light is not in B: recompute it from the matrix
    bp = np.stack([np.bincount(mesh.element_patch, weights=mesh.element_area * radiosity[:, c],
                               minlength=mesh.n_patches) for c in range(3)], axis=1)
    bp /= mesh.patch_area[:, None]
    irr = np.where(rho > 0, irr, fmat @ bp + direct)
    emitted = (mesh.element_emission + rho * direct) * mesh.element_area[:, None]
    return RadiosityResult(radiosity=radiosity, irradiance=irr, unshot=np.zeros_like(radiosity),
                           ambient=np.zeros(3), history=history, shots=np.zeros(0, dtype=np.int64),
                           emitted_power=emitted.sum(axis=0),
                           converged=bool(sweeps and history[-1] <= tol),
                           method=f"gauss-seidel/{form_factors}",
                           seconds=time.perf_counter() - t0,
                           stats={"n_sweeps": int(sweeps)})
