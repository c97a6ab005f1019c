"""Radiosity solvers: progressive refinement shooting and Gauss-Seidel gathering.

Both solve the same linear system on a :class:`RadiosityMesh` (patches
shoot, elements gather; thesis (2.7) with reciprocity (2.5))::

    B_e = E_e + rho_e * sum_p F(e -> p) B_p,      B_p = sum_{e in p} A_e B_e / A_p

per RGB channel, where ``E_e`` includes the direct light of point and
parallel lights (``rho_e`` times their irradiance).

* :func:`progressive_refinement` (2.2.2, Cohen et al. 1988): repeatedly
  pick the patch with the largest unshot power, compute its form factors
  to all elements, and add ``rho_e * dB_p * F(e -> p)`` to every element's
  radiosity and unshot radiosity.  Memory is linear in the number of
  elements.
* :func:`gauss_seidel` (2.2.1, (2.3)): assemble the (M, P) matrix of
  F(e -> p) and sweep Gauss-Seidel over the elements.
* :func:`furnace_error`: the furnace test of a form-factor method.

Form factors (``form_factors=``): ``"analytic"`` (the default) is Lambert's
exact point-to-polygon factor integrated over the element where it is near
the patch, times area-sampled visibility (k x k jittered rays between
element and patch); it passes the furnace test within 1 % also with
occluders.  ``"hemicube"`` is the thesis's shooting hemicube at the patch
centroid (2.2.1): in the furnace box its rows sum to 0.86-1.23 at any
resolution (the proximity error of a point-sampled shooter), so B comes out
1.85-2.22 instead of 2; it is kept to reproduce the thesis.

Note on notation: the thesis writes F_ij for "the fraction of light leaving
j that arrives at i"; here F(a -> b) is the fraction of light leaving a that
arrives at b, so reciprocity reads A_a F(a -> b) = A_b F(b -> a).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import numpy as np

from polygen._jit import njit
from polygen._memory import check_fits
from polygen.radiosity.formfactor import (
    VISIBILITY_SAMPLES,
    analytic_column,
    direct_irradiance,
    element_geometry,
    pack_polygons,
)
from polygen.radiosity.hemicube import delta_form_factors, hemicube_column
from polygen.radiosity.mesh import RadiosityMesh

__all__ = [
    "SolverError",
    "RadiosityResult",
    "FormFactorColumns",
    "COLUMN_CACHE_BYTES",
    "progressive_refinement",
    "gauss_seidel",
    "form_factor_matrix",
    "furnace_error",
]


PARALLEL_MIN_ELEMENTS = {"hemicube": 20000, "analytic": 2000}
"""Mesh size from which the form-factor kernels run multi-threaded by default: thread
start-up dominates below (the analytic path does ~10x more work per element; measured on
the ~10k-element Cornell box, 2 cores: 32 s single, 12-18 s multi-threaded)."""


COLUMN_CACHE_BYTES = 256 * 2**20
"""Memory the progressive solver may keep form-factor columns in, for patches that shoot again.

A patch shoots as often as it gathers enough unshot power: on the 12 x 15 sphere's DM
mesh (22,560 elements, 5640 patches) the 1 % solve's 4459 shots are of 1470 patches, each
wall patch shooting ~19 times; its columns fit in ~0.1 GB (sparse ones as index/value pairs)."""


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
    """F(e -> p) for one patch p at a time, analytically (default) or by the hemicube.

    Parameters
    ----------
    mesh : RadiosityMesh
    method : {"analytic", "hemicube"}
        ``"analytic"``: Lambert's exact point-to-polygon factor, integrated
        over the element near the patch, times area-sampled visibility
        (:func:`~polygen.radiosity.formfactor.analytic_column`); it passes
        the furnace test.  ``"hemicube"``: the thesis's shooting hemicube at
        the patch centroid (2.2.1), with its proximity error.
    resolution : int
        Hemicube top-face resolution (even, >= 2).
    visibility_samples : int
        Analytic method: k * k visibility rays per element-patch pair.
    parallel : bool or None
        Multi-threaded kernels; None: only for meshes of at least
        ``PARALLEL_MIN_ELEMENTS[method]`` elements (thread start-up dominates
        below).
    cache_bytes : int >= 0, keyword-only
        Keep computed columns up to this many bytes (a column with few
        non-zeros as index/value pairs), so a patch that shoots again costs
        no second column; once full, new columns are not kept (progressive
        refinement shoots patches nearly round-robin, where dropping the
        least recently used would keep none that comes back).  A column is a
        deterministic function of (mesh, patch, settings), so a kept one is
        the column bit for bit.  0: keep none.

    Attributes
    ----------
    computed, reused : int
        Columns computed, and returned from the cache, so far.

    Notes
    -----
    The object caches per-mesh arrays and columns; a mesh is immutable, so
    they stay valid.  Calls may run from several threads (the column cache
    is locked).
    """

    def __init__(self, mesh, method="analytic", *, resolution=100,
                 visibility_samples=VISIBILITY_SAMPLES, parallel=None, cache_bytes=0):
        if method not in ("hemicube", "analytic"):
            raise SolverError(f"form_factors must be 'analytic' or 'hemicube', got {method!r}")
        self.mesh = mesh
        self.method = method
        self.resolution = _check_int("resolution", resolution, 2, None)
        if self.resolution % 2:
            raise SolverError(f"resolution must be an even integer >= 2, got {resolution}")
        self.visibility_samples = _check_int("visibility_samples", visibility_samples, 1, 64)
        if parallel is None:
            parallel = mesh.n_elements >= PARALLEL_MIN_ELEMENTS[method]
        self.parallel = bool(parallel)
        if method == "hemicube":
            self.delta = delta_form_factors(self.resolution)
        else:
            self.packed = pack_polygons(mesh.scene.polygons)
            self.geometry = element_geometry(mesh)
        self.cache_bytes = _check_int("cache_bytes", cache_bytes, 0, None)
        self._cache = {}  # patch -> column, or (indices, values) of its non-zeros
        self._cache_used = 0
        self._lock = threading.Lock()
        self.computed = 0
        self.reused = 0

    def __call__(self, patch):
        """(M,) float64 F(e -> patch)."""
        patch = int(patch)
        with self._lock:
            kept = self._cache.get(patch)
            if kept is not None:
                self.reused += 1
        if kept is not None:
            if isinstance(kept, tuple):
                out = np.zeros(self.mesh.n_elements)
                out[kept[0]] = kept[1]
                return out
            return kept.copy()
        if self.method == "hemicube":
            col = hemicube_column(self.mesh, patch, delta=self.delta, parallel=self.parallel)
        else:
            col = analytic_column(self.mesh, patch, packed=self.packed, geometry=self.geometry,
                                  visibility_samples=self.visibility_samples,
                                  parallel=self.parallel)
        with self._lock:
            self.computed += 1
            if self.cache_bytes and patch not in self._cache:
                nz = np.flatnonzero(col)
                kept = ((nz.astype(np.int32), col[nz]) if 12 * len(nz) < col.nbytes
                        else col.copy())
                size = kept.nbytes if isinstance(kept, np.ndarray) else 12 * len(nz)
                if self._cache_used + size <= self.cache_bytes:
                    self._cache[patch] = kept
                    self._cache_used += size
        return col


def _check_int(name, value, lo, hi):
    """An integer in [lo, hi] (hi None: unbounded), else SolverError naming the parameter."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise SolverError(f"{name} must be an integer, got {value!r}")
    if value < lo or (hi is not None and value > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise SolverError(f"{name} must be {rng}, got {value}")
    return int(value)


def _check_tol(tol):
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.integer, np.floating)) \
            or not np.isfinite(tol) or not tol > 0:
        raise SolverError(f"tol must be a finite number > 0, got {tol!r}")
    return float(tol)


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


def progressive_refinement(mesh, *, form_factors="analytic", resolution=100,
                           visibility_samples=VISIBILITY_SAMPLES, tol=1e-3, max_shots=None,
                           ambient=False, progress=False, parallel=None,
                           cache_bytes=COLUMN_CACHE_BYTES):
    """Progressive refinement radiosity: shoot from patches to elements (2.2.2).

    Parameters
    ----------
    mesh : RadiosityMesh
    form_factors : {"analytic", "hemicube"}, keyword-only
        ``"analytic"`` (default): Lambert's exact point-to-polygon factor,
        integrated over the element where it is near the patch, times the
        visible fraction of k x k jittered rays between element and patch;
        it passes the furnace test.  ``"hemicube"``: the thesis's hemicube
        at the shooting patch's centroid (2.2.1), which carries the
        proximity error of a point-sampled shooter (see
        :func:`furnace_error`).
    resolution : int, keyword-only
        Hemicube top-face resolution (even, >= 2).
    visibility_samples : int in [1, 64], keyword-only
        Analytic: k, for k * k visibility rays per element-patch pair.
    tol : float, keyword-only
        Stop when the total unshot power is below ``tol`` times the initial
        (emitted) power; > 0.
    max_shots : int or "lights", keyword-only
        Upper bound on the number of shots, >= 0 (default 50 * number of
        patches).  ``"lights"``: every patch of an area light shoots once
        and nothing else does -- the direct light of the area lights, with
        ``ambient=True`` an ambient term for the rest (a preview solve; a
        light meshed into several patches is shot whole, whatever the
        patch size).
    ambient : bool, keyword-only
        Estimate the ambient term for the remaining unshot energy.
    progress : bool, keyword-only
        Show a tqdm bar of the unshot fraction.
    parallel : bool or None, keyword-only
        Multi-threaded form-factor kernels (default: for large meshes).
    cache_bytes : int >= 0, keyword-only
        Memory for the columns of patches that may shoot again (see
        :class:`FormFactorColumns`); the result is the same whatever it is.

    Returns
    -------
    RadiosityResult
        ``stats`` counts the shots, and the columns computed and reused.
    """
    _check_mesh(mesh)
    tol = _check_tol(tol)
    n_p = mesh.n_patches
    shooters = None
    if isinstance(max_shots, str):
        if max_shots != "lights":
            raise SolverError(f"max_shots must be an integer >= 0 or 'lights', got {max_shots!r}")
        shooters = np.zeros(n_p, dtype=bool)
        shooters[mesh.element_patch[(mesh.element_emission > 0).any(axis=1)]] = True
        max_shots = int(shooters.sum())
    else:
        max_shots = 50 * n_p if max_shots is None else _check_int("max_shots", max_shots, 0, None)
    t0 = time.perf_counter()
    columns = FormFactorColumns(mesh, form_factors, resolution=resolution,
                                visibility_samples=visibility_samples, parallel=parallel,
                                cache_bytes=cache_bytes)
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
            if shooters is not None:
                psum = np.where(shooters, psum, -np.inf)
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
                                  "n_elements": mesh.n_elements,
                                  "columns_computed": columns.computed,
                                  "columns_reused": columns.reused})


def form_factor_matrix(mesh, *, form_factors="analytic", resolution=100,
                       visibility_samples=VISIBILITY_SAMPLES, progress=False, parallel=None):
    """The (M, P) matrix of F(e -> p), one patch column at a time.

    Uses exactly the columns that :func:`progressive_refinement` shoots
    with, so both solvers solve the same system; the keywords are theirs.

    Returns
    -------
    (M, P) float64
    """
    _check_mesh(mesh)
    check_fits(8.0 * mesh.n_elements * mesh.n_patches,
               f"the form-factor matrix of {mesh.n_elements} elements x {mesh.n_patches} patches (float64)",
               lambda msg: SolverError(msg + "; progressive_refinement needs no matrix"))
    columns = FormFactorColumns(mesh, form_factors, resolution=resolution,
                                visibility_samples=visibility_samples, parallel=parallel)
    out = np.empty((mesh.n_elements, mesh.n_patches))
    it = range(mesh.n_patches)
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="form factors", unit="patch")
    for p in it:
        out[:, p] = columns(p)
    return out


def gauss_seidel(mesh, *, fmat=None, form_factors="analytic", resolution=100,
                 visibility_samples=VISIBILITY_SAMPLES, tol=1e-10, max_sweeps=1000,
                 progress=False):
    """Gauss-Seidel gathering on the element/patch system (2.2.1, (2.3)).

    Parameters
    ----------
    mesh : RadiosityMesh
    fmat : (M, P) float64, keyword-only
        Precomputed :func:`form_factor_matrix`; computed when omitted.
    form_factors, resolution, visibility_samples : keyword-only
        As in :func:`progressive_refinement` (used when ``fmat`` is omitted).
    tol : float, keyword-only
        Stop when no element radiosity changes by more than ``tol`` in a
        sweep; > 0.
    max_sweeps : int, keyword-only
        >= 1.

    Returns
    -------
    RadiosityResult
        ``history`` holds the largest change per sweep.
    """
    _check_mesh(mesh)
    tol = _check_tol(tol)
    max_sweeps = _check_int("max_sweeps", max_sweeps, 1, None)
    t0 = time.perf_counter()
    if fmat is None:
        fmat = form_factor_matrix(mesh, form_factors=form_factors, resolution=resolution,
                                  visibility_samples=visibility_samples, progress=progress)
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


def furnace_error(mesh, *, reflectance=0.5, fmat=None, form_factors="analytic", resolution=100,
                  visibility_samples=VISIBILITY_SAMPLES, tol=1e-12, max_sweeps=10000):
    """The furnace test of a form-factor method on a closed mesh.

    Every element of a closed scene that emits E = 1 and reflects ``rho``
    must come out at B = E / (1 - rho), whatever its geometry, because its
    form factors to all patches sum to 1.  This solves the mesh's system
    with those materials (the mesh's own materials are ignored) by
    Gauss-Seidel on :func:`form_factor_matrix` and returns ``B (1 - rho)``
    per element (1 when the factors are exact) and the row sums of F.
    The hemicube's proximity error shows here (notebook 02 reports it);
    the default factors pass within 1 %.

    Parameters
    ----------
    mesh : RadiosityMesh
        A closed scene (every direction from every element hits a patch).
    reflectance : float in (0, 1), keyword-only
    fmat : (M, P) float64, keyword-only
        Precomputed factors; else computed with the following keywords.
    form_factors, resolution, visibility_samples : keyword-only
        As in :func:`progressive_refinement`.
    tol, max_sweeps : keyword-only
        Gauss-Seidel stopping rule.

    Returns
    -------
    ratio : (M,) float64
        B (1 - rho) / E per element.
    row_sums : (M,) float64
        sum_p F(e -> p).
    """
    _check_mesh(mesh)
    if not 0.0 < reflectance < 1.0:
        raise SolverError(f"reflectance must be in (0, 1), got {reflectance}")
    tol = _check_tol(tol)
    max_sweeps = _check_int("max_sweeps", max_sweeps, 1, None)
    if fmat is None:
        fmat = form_factor_matrix(mesh, form_factors=form_factors, resolution=resolution,
                                  visibility_samples=visibility_samples)
    fmat = np.ascontiguousarray(fmat, dtype=np.float64)
    if fmat.shape != (mesh.n_elements, mesh.n_patches):
        raise SolverError(f"fmat must be ({mesh.n_elements}, {mesh.n_patches}), got {fmat.shape}")
    m = mesh.n_elements
    emit = np.ones((m, 3))
    rho = np.full((m, 3), float(reflectance))
    radiosity = emit.copy()
    history = np.zeros(max_sweeps)
    _gauss_seidel_kernel(fmat, emit, rho, mesh.element_area, mesh.element_patch, mesh.patch_area,
                         tol, max_sweeps, radiosity, history)
    return radiosity[:, 0] * (1.0 - reflectance), fmat.sum(axis=1)
