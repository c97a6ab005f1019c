"""Reproducible volume data sets: FEM parts, analytic fields, tiny volumes.

The thesis measured its methods on five tetrahedral volumes that came out of
finite-element analyses (Tables 6.1 and 7.1: 20736, 61680, 346644, 557868 and
458664 cells). Those volumes are not available, so this module makes volumes
of the same kind and size here, deterministically, and caches them on disk:

* **FEM volumes** ``"data1"`` .. ``"data5"``, ``"2M"``, ``"10M"``: gmsh
  meshes (OpenCASCADE geometry, HXT 3D algorithm, one thread so that the
  mesh is the same on every run) of mechanical-looking parts with
  through-holes and internal voids, carrying the node temperature of a
  steady heat-conduction problem solved with scikit-fem: Dirichlet patches
  on some holes and faces, Gaussian heat sources and sinks inside (so that
  there are interior maxima and minima, and isosurfaces that are closed as
  well as ones that end on the boundary). Data 5 adds a random heat load on
  every node, which gives thousands of extrema as in Table 7.1.
* **Hexahedral volumes** ``"hexa1"`` .. ``"hexa3"``: plates and a flange
  with round through-holes and closed voids. gmsh meshes the cross-section
  (holes and void footprints included) with quadrilaterals only (Blossom
  full-quad recombination), and the quads are stacked in layers; the
  hexahedra over a void footprint in the void's layers are left out. The
  mesh is unstructured in plan and follows the curved holes. (gmsh's
  tetrahedron-to-four-hexahedra subdivision was tried first: its distorted
  hexahedra gave the trilinear FEM field hundreds of spurious extrema on the
  boundary.) The FEM field is solved with trilinear hexahedra
  (``ElementHex1``).
* **Analytic fields** on every volume: ``"gaussians"``, a seeded sum of
  Gaussian bumps with many extrema, and ``"distance"``, the distance from a
  point outside the volume (the equi-distance surfaces of thesis 7.8).
* **Tiny volumes** for tests, whose topology can be checked by hand: one
  and two tetrahedra or hexahedra, a ring (genus 1), a hollow cube (one
  void) and a block with three holes (genus 3), as tetrahedra and as
  hexahedra.

Everything is a pure function of the data set's name and the ``seed``: the
geometry and the mesh depend on the name only, the seed moves the heat
sources, the random loads and the Gaussian bumps. Nothing is downloaded.

Built volumes are cached as uncompressed ``.npz`` files under
:func:`cache_dir` (``platformdirs.user_cache_dir("polygen")/volumes``, or
``$POLYGEN_CACHE_DIR``), keyed by the name, the seed, the build parameters
and :data:`FORMAT_VERSION`, and written atomically.

Examples
--------
>>> from polygen.volume import datasets
>>> vol = datasets.load("torus")
>>> vol.cell_type, int(vol.group_genus[0])
('tetra', 1)
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from polygen._jit import njit, prange
from polygen.volume._cells import HEX_UNIT_CORNERS, KUHN_TETS

__all__ = [
    "FORMAT_VERSION",
    "CACHE_ENV",
    "DatasetError",
    "DatasetInfo",
    "names",
    "info",
    "load",
    "build",
    "cache_dir",
    "cache_path",
    "is_cached",
    "node_extrema",
    "count_extrema",
    "gaussian_field",
    "distance_field",
    "distance_origin",
]

#: Version of the cache format and of the generators; bump it when either
#: changes, so that stale cache files are not read.
FORMAT_VERSION = 2  # 2: cached volumes renumbered along a Morton curve
#: Environment variable that overrides the cache directory.
CACHE_ENV = "POLYGEN_CACHE_DIR"


class DatasetError(ValueError):
    """A data set request is malformed (unknown name or field, bad seed)."""


@dataclasses.dataclass(frozen=True)
class DatasetInfo:
    """What a data set is and what its construction implies.

    Attributes
    ----------
    name : str
    cell_type : str
        ``"tetra"`` or ``"hexa"``.
    target_cells : int
        Number of cells aimed at (the built mesh is within 5 % for the
        meshed parts, exact for the tiny volumes).
    genus : tuple of int
        Genus of each boundary-face group as :class:`UnstructuredVolume`
        numbers them: the outer surface first, then the voids.
    n_voids : int
        Number of internal voids.
    n_through_holes : int
        Sum of the genera (Def. 5.8).
    fields : tuple of str
        Names of the node fields; the first is the default.
    description : str
    thesis : dict
        The thesis's numbers this data set stands in for (cells, nodes,
        boundary cells, extrema), empty when there are none.
    cached : bool
        Whether :func:`load` caches the volume on disk (the tiny volumes
        are built on the fly).
    """

    name: str
    cell_type: str
    target_cells: int
    genus: tuple
    n_voids: int
    n_through_holes: int
    fields: tuple
    description: str
    thesis: dict = dataclasses.field(default_factory=dict)
    cached: bool = True


# ---------------------------------------------------------------- kernels
@njit
def _node_extrema_kernel(edges, values, is_max, is_min):
    # a node is a strict maximum when it is greater than every node it shares an edge with
    for e in range(edges.shape[0]):
        a = edges[e, 0]
        b = edges[e, 1]
        va = values[a]
        vb = values[b]
        if not va > vb:
            is_max[a] = False
        if not vb > va:
            is_max[b] = False
        if not va < vb:
            is_min[a] = False
        if not vb < va:
            is_min[b] = False


@njit(parallel=True)
def _gaussian_sum_kernel(points, centres, amps, sigmas, cutoff, out):
    # sum_k a_k (exp(-r^2 / 2 s_k^2) - exp(-c^2 / 2)) for r < c s_k: continuous, exactly 0 far away
    n = points.shape[0]
    k = centres.shape[0]
    floor = np.exp(-0.5 * cutoff * cutoff)
    for i in prange(n):
        x = points[i, 0]
        y = points[i, 1]
        z = points[i, 2]
        acc = 0.0
        for j in range(k):
            s = sigmas[j]
            r2max = (cutoff * s) ** 2
            dx = x - centres[j, 0]
            d2 = dx * dx
            if d2 >= r2max:
                continue
            dy = y - centres[j, 1]
            d2 += dy * dy
            if d2 >= r2max:
                continue
            dz = z - centres[j, 2]
            d2 += dz * dz
            if d2 >= r2max:
                continue
            acc += amps[j] * (np.exp(-0.5 * d2 / (s * s)) - floor)
        out[i] = acc


@njit
def _separated_kernel(points, candidates, min_dist, max_count, out):
    # greedy: take candidates in the given (seeded) order, keep those at least min_dist from all kept
    n_kept = 0
    d2min = min_dist * min_dist
    for c in range(candidates.shape[0]):
        if n_kept >= max_count:
            break
        i = candidates[c]
        ok = True
        for j in range(n_kept):
            q = out[j]
            dx = points[i, 0] - points[q, 0]
            dy = points[i, 1] - points[q, 1]
            dz = points[i, 2] - points[q, 2]
            if dx * dx + dy * dy + dz * dz < d2min:
                ok = False
                break
        if ok:
            out[n_kept] = i
            n_kept += 1
    return n_kept


@njit
def _csr_matvec(indptr, indices, data, x, out):
    # serial: called once per CG iteration, where waking a thread team costs more than it saves
    for i in range(indptr.size - 1):
        acc = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            acc += data[k] * x[indices[k]]
        out[i] = acc


@njit
def _dot(a, b):
    # serial on purpose: a fixed summation order keeps the solve bit-for-bit reproducible
    acc = 0.0
    for i in range(a.size):
        acc += a[i] * b[i]
    return acc


@njit
def _pcg_kernel(indptr, indices, data, b, x, rtol, maxiter):
    # conjugate gradients with the Jacobi (diagonal) preconditioner, from x; returns iterations
    n = b.size
    inv_diag = np.ones(n)
    for i in range(n):
        for k in range(indptr[i], indptr[i + 1]):
            if indices[k] == i and data[k] != 0.0:
                inv_diag[i] = 1.0 / data[k]
    r = np.empty(n)
    _csr_matvec(indptr, indices, data, x, r)
    for i in range(n):
        r[i] = b[i] - r[i]
    z = r * inv_diag
    p = z.copy()
    q = np.empty(n)
    rz = _dot(r, z)
    bnorm = np.sqrt(_dot(b, b))
    tol = rtol * (bnorm if bnorm > 0.0 else 1.0)
    for it in range(maxiter):
        if np.sqrt(_dot(r, r)) <= tol:
            return it
        _csr_matvec(indptr, indices, data, p, q)
        alpha = rz / _dot(p, q)
        for i in range(n):
            x[i] += alpha * p[i]
            r[i] -= alpha * q[i]
            z[i] = r[i] * inv_diag[i]
        rz_new = _dot(r, z)
        beta = rz_new / rz
        rz = rz_new
        for i in range(n):
            p[i] = z[i] + beta * p[i]
    return -1


def _pcg(rtol=1e-10, maxiter=20000):
    """A ``skfem.solve`` solver: Jacobi-preconditioned CG in numba.

    scipy's ``cg`` would do, but its BLAS dot products spin threads that
    fight on a busy two-core machine (measured: 16 ms for one dot of 26k
    numbers under load, 3 us with one thread), and serial sums keep the
    result reproducible.
    """

    def solver(A, b, **kwargs):
        A = A.tocsr()
        A.sort_indices()
        x = np.zeros(A.shape[0])
        it = _pcg_kernel(
            A.indptr.astype(np.int64), A.indices.astype(np.int64), A.data.astype(np.float64),
            np.ascontiguousarray(b, dtype=np.float64), x, float(rtol), int(maxiter),
        )
        if it < 0:
            raise RuntimeError(f"PCG did not reach rtol={rtol} in {maxiter} iterations")
        return x

    return solver


# ---------------------------------------------------------- public helpers
def node_extrema(vol, field=None):
    """Node extrema of a scalar field: nodes strictly above (below) all edge neighbours.

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str, optional
        Field name; the volume's first field by default.

    Returns
    -------
    maxima, minima : (K,) int64
        Sorted node ids of the strict local maxima and minima. Nodes on a
        plateau (equal to a neighbour) are neither.
    """
    values = vol.scalars(field)
    edges = vol.edges
    is_max = np.ones(vol.n_points, np.bool_)
    is_min = np.ones(vol.n_points, np.bool_)
    _node_extrema_kernel(edges, values, is_max, is_min)
    return np.flatnonzero(is_max), np.flatnonzero(is_min)


def count_extrema(vol, field=None):
    """``(n_maxima, n_minima)`` of :func:`node_extrema`."""
    mx, mn = node_extrema(vol, field)
    return int(mx.size), int(mn.size)


def gaussian_field(points, *, n_bumps, seed=0, width=0.3, cutoff=5.0):
    """A seeded sum of Gaussian bumps of both signs.

    Parameters
    ----------
    points : (N, 3) float64
        Where to evaluate.
    n_bumps : int, keyword-only
        Number of bumps; centres are uniform in the bounding box of
        ``points``, amplitudes ``+-U(0.5, 1)``.
    seed : int, keyword-only
    width : float, keyword-only
        Standard deviation of each bump relative to the mean spacing
        ``(box volume / n_bumps) ** (1/3)``, jittered by ``U(0.7, 1.3)``.
    cutoff : float, keyword-only
        Each bump is shifted down by its value at ``cutoff`` standard
        deviations and clipped there, so the field stays continuous and is
        exactly zero far from every bump.

    Returns
    -------
    values : (N,) float64
    """
    points = _as_points(points)
    if int(n_bumps) < 1:
        raise DatasetError(f"n_bumps must be at least 1; got {n_bumps}")
    if not (width > 0 and cutoff > 0):
        raise DatasetError(f"width and cutoff must be positive; got width={width}, cutoff={cutoff}")
    n_bumps = int(n_bumps)
    rng = np.random.default_rng(_seed(seed))
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = np.maximum(hi - lo, 1e-12)
    centres = lo + rng.random((n_bumps, 3)) * span
    amps = rng.choice([-1.0, 1.0], n_bumps) * rng.uniform(0.5, 1.0, n_bumps)
    spacing = (np.prod(span) / n_bumps) ** (1.0 / 3.0)
    sigmas = width * spacing * rng.uniform(0.7, 1.3, n_bumps)
    out = np.empty(points.shape[0])
    _gaussian_sum_kernel(points, centres, amps, sigmas, float(cutoff), out)
    return out


def distance_origin(points):
    """The default eye for :func:`distance_field`: outside the box, below its low corner.

    ``lo - 0.25 * (hi - lo)`` for the bounding box ``[lo, hi]`` of
    ``points`` (N, 3); returns (3,) float64.
    """
    points = _as_points(points)
    lo, hi = points.min(axis=0), points.max(axis=0)
    return lo - 0.25 * (hi - lo)


def distance_field(points, origin=None):
    """Euclidean distance of each point from ``origin`` (thesis 7.8, equi-distance surfaces).

    Parameters
    ----------
    points : (N, 3) float64
    origin : (3,) float64, optional
        The eye; :func:`distance_origin` by default.

    Returns
    -------
    values : (N,) float64
    """
    points = _as_points(points)
    origin = distance_origin(points) if origin is None else np.asarray(origin, dtype=np.float64)
    if origin.shape != (3,) or not np.all(np.isfinite(origin)):
        raise DatasetError(f"origin must be 3 finite numbers; got {origin!r}")
    return np.sqrt(((points - origin) ** 2).sum(axis=1))


def _as_points(points):
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise DatasetError(f"points must have shape (N, 3) with N > 0; got {points.shape}")
    return np.ascontiguousarray(points)


def _seed(seed):
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise DatasetError(f"seed must be a non-negative integer; got {seed!r}")
    return int(seed)


# ----------------------------------------------------------- tiny volumes
def _grid_volume(keep, cell_type):
    """Unit-cube grid over the ``True`` cells of ``keep`` (nx, ny, nz), compacted."""
    keep = np.asarray(keep, bool)
    nx, ny, nz = keep.shape
    ix, iy, iz = np.nonzero(keep)
    corner = ix[:, None] + HEX_UNIT_CORNERS[:, 0]
    cy = iy[:, None] + HEX_UNIT_CORNERS[:, 1]
    cz = iz[:, None] + HEX_UNIT_CORNERS[:, 2]
    hexes = (corner * (ny + 1) + cy) * (nz + 1) + cz
    gx, gy, gz = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
    points = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1).astype(np.float64)
    cells = hexes if cell_type == "hexa" else hexes[:, KUHN_TETS].reshape(-1, 4)
    used, inverse = np.unique(cells, return_inverse=True)
    return points[used], inverse.reshape(cells.shape).astype(np.int64)


def _orient_tets(points, cells):
    """Swap nodes 1 and 2 of negative tetrahedra so that every cell is positive in VTK order."""
    p = points[cells]
    vol6 = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    neg = vol6 < 0
    cells = cells.copy()
    cells[neg, 1], cells[neg, 2] = cells[neg, 2], cells[neg, 1].copy()
    return cells


def _tiny(kind, cell_type):
    if kind == "one":
        if cell_type == "tetra":
            points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
            cells = np.array([[0, 1, 2, 3]], np.int64)
        else:
            return _grid_volume(np.ones((1, 1, 1)), "hexa")
    elif kind == "two":
        if cell_type == "tetra":
            # two tetrahedra sharing the face (1, 2, 3), on both sides of the plane x + y + z = 1
            points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], np.float64)
            cells = np.array([[0, 1, 2, 3], [4, 1, 3, 2]], np.int64)
        else:
            return _grid_volume(np.ones((2, 1, 1)), "hexa")
    elif kind == "torus":
        keep = np.ones((3, 3, 1), bool)
        keep[1, 1, 0] = False
        points, cells = _grid_volume(keep, cell_type)
    elif kind == "hollow_cube":
        keep = np.ones((3, 3, 3), bool)
        keep[1, 1, 1] = False
        points, cells = _grid_volume(keep, cell_type)
    elif kind == "genus3":
        keep = np.ones((7, 3, 1), bool)
        keep[[1, 3, 5], 1, 0] = False
        points, cells = _grid_volume(keep, cell_type)
    else:  # pragma: no cover - registry and builders are defined together
        raise AssertionError(kind)
    if cell_type == "tetra":
        cells = _orient_tets(points, cells)
    return points, cells


def _tiny_fields(points, seed):
    # hand-checkable: a linear field with no ties on integer grids, the distance from
    # the default eye, and three Gaussian bumps
    linear = points[:, 0] + 0.31 * points[:, 1] + 0.097 * points[:, 2]
    return {
        "linear": linear,
        "distance": distance_field(points),
        "gaussians": gaussian_field(points, n_bumps=3, seed=seed, width=0.5),
    }


# ------------------------------------------------------------ CAD parts
@dataclasses.dataclass(frozen=True)
class _Part:
    """A mechanical-looking part: OCC construction, topology, heat-problem set-up."""

    name: str
    description: str
    genus: int  # of the outer surface, as the construction implies
    n_voids: int
    build: Callable  # (occ) -> volume tag; creates the solid in the current model
    # Dirichlet patches: (predicate on (3, N) coordinates true only on boundary nodes, value)
    patches: tuple


def _on_plane(axis, value):
    return lambda x: np.abs(x[axis] - value) < 1e-6


def _on_cylinder(axis, centre, radius, where=None):
    a, b = [i for i in range(3) if i != axis]

    def test(x):
        on = np.abs(np.hypot(x[a] - centre[0], x[b] - centre[1]) - radius) < 1e-6
        return on if where is None else on & where(x)

    return test


def _cut(occ, base, tools):
    out, _ = occ.cut([(3, base)], [(3, t) for t in tools])
    if len(out) != 1:  # pragma: no cover - the constructions below give one solid
        raise RuntimeError(f"OCC cut gave {len(out)} solids")
    return out[0][1]


def _fuse(occ, tags):
    out, _ = occ.fuse([(3, tags[0])], [(3, t) for t in tags[1:]])
    if len(out) != 1:  # pragma: no cover
        raise RuntimeError(f"OCC fuse gave {len(out)} solids")
    return out[0][1]


def _bracket(occ):
    # 4 x 2 x 1 block, two vertical bolt holes, a spherical void between them
    box = occ.addBox(0, 0, 0, 4, 2, 1)
    holes = [occ.addCylinder(x, 1, -1, 0, 0, 3, 0.4) for x in (1.0, 3.0)]
    void = occ.addSphere(2, 1, 0.5, 0.3)
    return _cut(occ, box, holes + [void])


def _flange(occ):
    # disc r = 2, thickness 0.8, central bore, four bolt holes; a spherical and a box void
    disc = occ.addCylinder(0, 0, 0, 0, 0, 0.8, 2.0)
    bore = occ.addCylinder(0, 0, -1, 0, 0, 3, 0.6)
    bolts = [
        occ.addCylinder(1.4 * np.cos(t), 1.4 * np.sin(t), -1, 0, 0, 3, 0.2)
        for t in np.deg2rad([0.0, 90.0, 180.0, 270.0])
    ]
    c = np.cos(np.pi / 4)
    sphere = occ.addSphere(1.0 * c, 1.0 * c, 0.4, 0.15)
    box = occ.addBox(-1.0 * c - 0.15, -1.0 * c - 0.15, 0.25, 0.3, 0.3, 0.3)
    return _cut(occ, disc, [bore] + bolts + [sphere, box])


def _pillow_block(occ):
    # base plate with two bolt holes, a pedestal and a round boss with a bearing bore along y;
    # a spherical void under the bore and a box void in the base
    base = occ.addBox(0, 0, 0, 6, 2, 0.8)
    pedestal = occ.addBox(1.6, 0, 0, 2.8, 2, 1.6)
    boss = occ.addCylinder(3, 0, 1.6, 0, 2, 0, 1.4)
    body = _fuse(occ, [base, pedestal, boss])
    bore = occ.addCylinder(3, -1, 1.6, 0, 4, 0, 0.7)
    bolts = [occ.addCylinder(x, 1, -1, 0, 0, 3, 0.3) for x in (0.8, 5.2)]
    sphere = occ.addSphere(3, 1, 0.45, 0.25)
    box = occ.addBox(4.3, 0.2, 0.25, 0.4, 0.4, 0.3)
    return _cut(occ, body, [bore] + bolts + [sphere, box])


def _manifold(occ):
    # 4 x 4 x 3 block; a bore along x crossing a bore along y (genus 3 together), a vertical
    # bolt hole (genus 1 more); two spherical voids
    block = occ.addBox(0, 0, 0, 4, 4, 3)
    bx = occ.addCylinder(-1, 2, 1.5, 6, 0, 0, 0.5)
    by = occ.addCylinder(2, -1, 1.5, 0, 6, 0, 0.5)
    bolt = occ.addCylinder(0.8, 0.8, -1, 0, 0, 5, 0.3)
    s1 = occ.addSphere(3, 3, 0.75, 0.4)
    s2 = occ.addSphere(3, 3, 2.4, 0.3)
    return _cut(occ, block, [bx, by, bolt, s1, s2])


def _angle_bracket(occ):
    # L-shaped bracket: a horizontal plate with two bolt holes, an upright with a bore along x;
    # a spherical void in the upright
    plate = occ.addBox(0, 0, 0, 5, 3, 0.8)
    upright = occ.addBox(0, 0, 0, 0.8, 3, 4)
    body = _fuse(occ, [plate, upright])
    bolts = [occ.addCylinder(x, 1.5, -1, 0, 0, 3, 0.35) for x in (2.5, 4.0)]
    bore = occ.addCylinder(-1, 1.5, 2.5, 3, 0, 0, 0.5)
    void = occ.addSphere(0.4, 1.5, 1.4, 0.2)
    return _cut(occ, body, bolts + [bore, void])


@dataclasses.dataclass(frozen=True)
class _ExtrudedPart:
    """A part made by stacking a cross-section (with holes) in layers, with prism voids inside."""

    name: str
    description: str
    genus: int
    n_voids: int
    build: Callable  # (occ) -> (section face tag, [void footprint face tags])
    thickness: float
    void_z: tuple  # (z0, z1) of each footprint's void
    patches: tuple


def _plate_section(occ):
    # the bracket's cross-section: two bolt holes; a round void footprint between them
    rect = occ.addRectangle(0, 0, 0, 4, 2)
    holes = [occ.addDisk(x, 1, 0, 0.4, 0.4) for x in (1.0, 3.0)]
    out, _ = occ.cut([(2, rect)], [(2, d) for d in holes])
    return out[0][1], [occ.addDisk(2, 1, 0, 0.3, 0.3)]


def _flange_section(occ):
    disc = occ.addDisk(0, 0, 0, 2.0, 2.0)
    cuts = [occ.addDisk(0, 0, 0, 0.6, 0.6)] + [
        occ.addDisk(1.4 * np.cos(t), 1.4 * np.sin(t), 0, 0.2, 0.2) for t in np.deg2rad([0.0, 90.0, 180.0, 270.0])
    ]
    out, _ = occ.cut([(2, disc)], [(2, d) for d in cuts])
    c = np.cos(np.pi / 4)
    return out[0][1], [occ.addDisk(c, c, 0, 0.15, 0.15), occ.addRectangle(-c - 0.15, -c - 0.15, 0, 0.3, 0.3)]


def _base_plate_section(occ):
    rect = occ.addRectangle(0, 0, 0, 6, 3)
    holes = [occ.addDisk(x, 1.5, 0, 0.35, 0.35) for x in (1.0, 3.0, 5.0)]
    out, _ = occ.cut([(2, rect)], [(2, d) for d in holes])
    return out[0][1], [occ.addDisk(2.0, 0.6, 0, 0.25, 0.25), occ.addRectangle(3.8, 2.1, 0, 0.4, 0.4)]


_PARTS = {
    "bracket": _Part(
        "bracket",
        "a 4x2x1 block with two bolt holes and a spherical void",
        2,
        1,
        _bracket,
        ((_on_cylinder(2, (1.0, 1.0), 0.4), 0.0), (_on_plane(0, 4.0), 1.0)),
    ),
    "flange": _Part(
        "flange",
        "a round flange with a central bore, four bolt holes, a spherical and a box void",
        5,
        2,
        _flange,
        ((_on_cylinder(2, (0.0, 0.0), 0.6), 0.0), (_on_cylinder(2, (0.0, 0.0), 2.0, lambda x: x[0] > 1.2), 1.0)),
    ),
    "pillow_block": _Part(
        "pillow_block",
        "a pillow block: base with two bolt holes, a boss with a bearing bore, two voids",
        3,
        2,
        _pillow_block,
        ((_on_cylinder(1, (3.0, 1.6), 0.7), 1.0), (_on_cylinder(2, (0.8, 1.0), 0.3), 0.0), (_on_plane(0, 6.0), 0.0)),
    ),
    "manifold": _Part(
        "manifold",
        "a manifold block with two crossing bores, a bolt hole and two spherical voids",
        4,
        2,
        _manifold,
        ((_on_cylinder(0, (2.0, 1.5), 0.5), 1.0), (_on_plane(2, 0.0), 0.0), (_on_cylinder(2, (0.8, 0.8), 0.3), 0.5)),
    ),
    "angle_bracket": _Part(
        "angle_bracket",
        "an angle bracket: a plate with two bolt holes, an upright with a bore, a spherical void",
        3,
        1,
        _angle_bracket,
        ((_on_cylinder(0, (1.5, 2.5), 0.5), 1.0), (_on_plane(0, 5.0), 0.0)),
    ),
    "plate": _ExtrudedPart(
        "plate",
        "a 4x2x1 plate with two bolt holes and a cylindrical void (extruded hexahedra)",
        2,
        1,
        _plate_section,
        1.0,
        ((0.3, 0.7),),
        ((_on_cylinder(2, (1.0, 1.0), 0.4), 0.0), (_on_plane(0, 4.0), 1.0)),
    ),
    "flange_hex": _ExtrudedPart(
        "flange_hex",
        "a round flange with a central bore, four bolt holes, a cylindrical and a box void (extruded hexahedra)",
        5,
        2,
        _flange_section,
        0.8,
        ((0.25, 0.55), (0.25, 0.55)),
        ((_on_cylinder(2, (0.0, 0.0), 0.6), 0.0), (_on_cylinder(2, (0.0, 0.0), 2.0, lambda x: x[0] > 1.2), 1.0)),
    ),
    "base_plate": _ExtrudedPart(
        "base_plate",
        "a 6x3x1.2 base plate with three bolt holes, a cylindrical and a box void (extruded hexahedra)",
        3,
        2,
        _base_plate_section,
        1.2,
        ((0.4, 0.8), (0.4, 0.8)),
        ((_on_cylinder(2, (1.0, 1.5), 0.35), 0.0), (_on_plane(0, 6.0), 1.0)),
    ),
}


# ------------------------------------------------------------------ gmsh
@contextlib.contextmanager
def _gmsh_model(name):
    """A fresh gmsh model; gmsh is initialised (and finalised) here unless it already runs."""
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.Verbosity", 0)
        gmsh.model.add(name)
        yield gmsh
    finally:
        if own:
            gmsh.finalize()
        else:
            gmsh.model.remove()


def _mesh_part(part, h, cell_type, *, target=None, tolerance=0.03, max_tries=6):
    """Mesh ``part`` with size ``h``; adjust ``h`` until the cell count is within ``tolerance`` of ``target``.

    Returns ``points (N, 3), cells (M, 4|8), h``, cells positive in VTK order.
    """
    if isinstance(part, _ExtrudedPart):
        return _extrude_part(part, h, target=target, tolerance=tolerance, max_tries=max_tries)
    with _gmsh_model(f"polygen-{part.name}") as gmsh:
        part.build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        _single_thread(gmsh)
        opt = gmsh.option.setNumber
        opt("Mesh.Algorithm", 6)  # Frontal-Delaunay surfaces
        opt("Mesh.Algorithm3D", 10)  # HXT
        for _ in range(max_tries):
            gmsh.model.mesh.clear()
            opt("Mesh.MeshSizeMin", h)
            opt("Mesh.MeshSizeMax", h)
            gmsh.model.mesh.generate(3)
            _, conn = gmsh.model.mesh.getElementsByType(4)
            n = conn.size // 4
            if target is None or abs(n / target - 1.0) <= tolerance:
                break
            h *= (n / target) ** (1.0 / 3.0)  # cells scale like h^-3
        tags, coords, _ = gmsh.model.mesh.getNodes()
    points, cells = _compact(tags, coords, conn, 4)
    return points, _orient_tets(points, cells), h


def _single_thread(gmsh):
    # HXT with several threads gives a different mesh on every run; one thread is reproducible
    opt = gmsh.option.setNumber
    opt("General.NumThreads", 1)
    opt("Mesh.MaxNumThreads1D", 1)
    opt("Mesh.MaxNumThreads2D", 1)
    opt("Mesh.MaxNumThreads3D", 1)
    opt("Mesh.MeshSizeFromCurvature", 0)
    opt("Mesh.MeshSizeFromPoints", 0)
    opt("Mesh.RandomSeed", 1)


def _compact(tags, coords, conn, nper):
    """gmsh node tags and connectivity -> points (N, 3) and cells (M, nper) over the used nodes only."""
    lookup = np.zeros(int(tags.max()) + 1, np.int64)
    lookup[tags.astype(np.int64)] = np.arange(tags.size)
    cells = lookup[conn.astype(np.int64)].reshape(-1, nper)
    points = coords.reshape(-1, 3)
    used, inverse = np.unique(cells, return_inverse=True)
    return np.ascontiguousarray(points[used]), inverse.reshape(cells.shape).astype(np.int64)


def _extrude_part(part, h, *, target=None, tolerance=0.03, max_tries=6):
    """Hexahedral mesh of an extruded part: a gmsh all-quad mesh of the cross-section, stacked in layers.

    The section's holes become through-holes; the hexahedra above the void
    footprints in the void's layers are left out, which makes closed voids.
    """
    with _gmsh_model(f"polygen-{part.name}") as gmsh:
        occ = gmsh.model.occ
        section, footprints = part.build(occ)
        out, out_map = occ.fragment([(2, section)], [(2, f) for f in footprints])
        occ.synchronize()
        # faces that came from footprint i (the fragment keeps them whole: they lie inside the section)
        foot_faces = [[t for d, t in out_map[1 + i] if d == 2] for i in range(len(footprints))]
        _single_thread(gmsh)
        opt = gmsh.option.setNumber
        opt("Mesh.Algorithm", 8)  # Frontal-Delaunay for quads
        opt("Mesh.RecombineAll", 1)
        opt("Mesh.RecombinationAlgorithm", 3)  # Blossom full-quad
        for _ in range(max_tries):
            gmsh.model.mesh.clear()
            opt("Mesh.MeshSizeMin", h)
            opt("Mesh.MeshSizeMax", h)
            gmsh.model.mesh.generate(2)
            types = gmsh.model.mesh.getElementTypes(2)
            if list(types) != [3]:  # pragma: no cover - Blossom full-quad gives quads only
                raise RuntimeError(f"the section of {part.name} did not mesh into quadrilaterals only: {types}")
            _, qconn = gmsh.model.mesh.getElementsByType(3)
            n_quads = qconn.size // 4
            nz = max(3, int(round(part.thickness / h)))
            n = n_quads * nz  # minus the few void cells
            if target is None or abs(n / target - 1.0) <= tolerance:
                break
            h *= (n / target) ** (1.0 / 3.0)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        in_foot = []
        for faces in foot_faces:
            conns = [gmsh.model.mesh.getElementsByType(3, t)[1] for t in faces]
            in_foot.append(np.concatenate(conns) if conns else np.zeros(0, np.uint64))
    lookup = np.zeros(int(tags.max()) + 1, np.int64)
    lookup[tags.astype(np.int64)] = np.arange(tags.size)
    quads = lookup[qconn.astype(np.int64)].reshape(-1, 4)
    xy = coords.reshape(-1, 3)[:, :2]
    # counter-clockwise seen from +z, so that the stacked hexahedra are positive in VTK order
    q = xy[quads]
    area2 = ((q[:, :, 0] * np.roll(q[:, :, 1], -1, axis=1)) - (np.roll(q[:, :, 0], -1, axis=1) * q[:, :, 1])).sum(1)
    quads[area2 < 0] = quads[area2 < 0][:, ::-1]
    # footprint membership of each quad, by its sorted node tuple
    key = np.sort(quads, axis=1)
    void_layers = np.zeros((quads.shape[0], nz), bool)
    zc = (np.arange(nz) + 0.5) * part.thickness / nz
    for conn_i, (z0, z1) in zip(in_foot, part.void_z):
        fq = np.sort(lookup[conn_i.astype(np.int64)].reshape(-1, 4), axis=1)
        member = _rows_in(key, fq)
        void_layers[np.ix_(member, (zc > z0) & (zc < z1))] = True
    n2 = xy.shape[0]
    z = np.linspace(0.0, part.thickness, nz + 1)
    points = np.concatenate([np.column_stack([xy, np.full(n2, zk)]) for zk in z])
    layer = np.repeat(np.arange(nz), quads.shape[0])
    base = np.tile(quads, (nz, 1)) + (layer * n2)[:, None]
    cells = np.concatenate([base, base + n2], axis=1)
    cells = cells[~void_layers.T.ravel()]
    used, inverse = np.unique(cells, return_inverse=True)
    return np.ascontiguousarray(points[used]), inverse.reshape(cells.shape).astype(np.int64), h


def _rows_in(a, b):
    """Boolean (len(a),): which rows of a (K, 4) int array also occur in b."""
    if b.shape[0] == 0:
        return np.zeros(a.shape[0], bool)
    _, ids = np.unique(np.concatenate([a, b]), axis=0, return_inverse=True)
    ids = ids.ravel()
    return np.isin(ids[: a.shape[0]], ids[a.shape[0]:])


# ----------------------------------------------------------- FEM solve
# VTK hexahedron node order -> scikit-fem MeshHex1 order (skfem.io.meshio.INV_HEX_MAPPING[:8])
_VTK_TO_SKFEM_HEX = np.array([0, 4, 3, 1, 7, 5, 2, 6])


def _heat_field(points, cells, part, *, spacing, n_sources, seed, noise=0.0, progress=None):
    """Steady heat conduction -lap u = f on the part, u fixed on its Dirichlet patches.

    ``f`` is ``n_sources`` Gaussian sources and sinks (+-), centred on nodes at
    least 5 sigma apart and 2 sigma inside the part, plus ``noise`` times a
    standard normal load on every node. Natural (insulated) boundary elsewhere.
    """
    from scipy.spatial import cKDTree
    from skfem import (
        Basis,
        BilinearForm,
        ElementHex1,
        ElementTetP1,
        LinearForm,
        MeshHex1,
        MeshTet1,
        asm,
        condense,
        solve,
    )
    from skfem.helpers import dot, grad

    rng = np.random.default_rng(_seed(seed))
    if cells.shape[1] == 4:
        mesh = MeshTet1(np.ascontiguousarray(points.T), np.ascontiguousarray(cells.T.astype(np.int32)))
        basis = Basis(mesh, ElementTetP1(), intorder=2)
    else:
        t = np.ascontiguousarray(cells[:, _VTK_TO_SKFEM_HEX].T.astype(np.int32))
        mesh = MeshHex1(np.ascontiguousarray(points.T), t)
        basis = Basis(mesh, ElementHex1(), intorder=2)
    _tick(progress, "assemble")

    @BilinearForm
    def laplace(u, v, w):
        return dot(grad(u), grad(v))

    @LinearForm
    def load(v, w):
        return w.s * v

    # Dirichlet patches: nodes_satisfying on geometric predicates (no facet search)
    u = np.zeros(mesh.nvertices)
    dirichlet = []
    for test, value in part.patches:
        nodes = mesh.nodes_satisfying(test)
        u[nodes] = value
        dirichlet.append(nodes)
    dirichlet = np.unique(np.concatenate(dirichlet))
    if dirichlet.size == 0:  # pragma: no cover - every part has patches on its surface
        raise RuntimeError(f"no Dirichlet nodes found on {part.name}")

    # sources wide enough to span a few cells (spacing = mesh edge length), narrow enough to fit
    volume = float(np.abs(basis.dx).sum())
    sigma = max(0.8 * spacing, 0.1 * (volume / max(n_sources, 1)) ** (1.0 / 3.0))
    # centres at least 2 sigma inside the part, so that the extrema they make are interior nodes
    from polygen.volume.mesh import UnstructuredVolume

    surface = np.unique(UnstructuredVolume(points, cells, validate=False).boundary_face_nodes)
    dist = cKDTree(points[surface]).query(points, k=1)[0]
    candidates = np.flatnonzero(dist > 2.0 * sigma)
    candidates = candidates[rng.permutation(candidates.size)]
    chosen = np.empty(max(n_sources, 1), np.int64)
    n_chosen = _separated_kernel(points, candidates, 5.0 * sigma, n_sources, chosen)
    centres = points[chosen[:n_chosen]]
    signs = np.where(np.arange(n_chosen) % 2 == 0, 1.0, -1.0)  # as many sinks as sources
    amps = signs * rng.uniform(0.7, 1.3, n_chosen) / sigma**2
    s = np.empty(points.shape[0])
    _gaussian_sum_kernel(points, centres, amps, np.full(n_chosen, sigma), 5.0, s)

    K = asm(laplace, basis)
    f = asm(load, basis, s=basis.interpolate(s))
    if noise:
        # a random heat load on every node, scaled by the largest nodal load of the sources
        scale = noise * np.abs(f).max()
        f = f + scale * rng.standard_normal(f.size)
    _tick(progress, "solve")
    x = solve(*condense(K, f, x=u, D=dirichlet), solver=_pcg(rtol=1e-10))
    return np.asarray(x, dtype=np.float64)


def _tick(bar, stage):
    # the previous stage (if any) is done; label the one that starts
    if bar is not None:
        if bar.postfix:
            bar.update(1)
        bar.set_postfix_str(stage)


# --------------------------------------------------------------- registry
@dataclasses.dataclass(frozen=True)
class _Spec:
    info: DatasetInfo
    params: dict  # everything the result depends on besides the seed (cache key)
    builder: Callable  # (seed, bar) -> (points, cells, fields)
    stages: int = 1


_REGISTRY: dict = {}


def _register(info, params, builder, stages=1):
    _REGISTRY[info.name] = _Spec(info, params, builder, stages)


_THESIS = {
    "data1": dict(cells=20736, nodes=4002, boundary_cells=2048, extrema=21),
    "data2": dict(cells=61680, nodes=11624, boundary_cells=5432, extrema=46),
    "data3": dict(cells=346644, nodes=62107, boundary_cells=16908, extrema=135),
    "data4": dict(cells=557868, nodes=97473, boundary_cells=17876, extrema=540),
    "data5": dict(cells=458664, nodes=80468, extrema=5986),
}


def _part_builder(part, cell_type, target, h0, n_sources, noise, n_bumps, fem):
    def build(seed, bar):
        _tick(bar, "mesh")
        points, cells, h = _mesh_part(part, h0, cell_type, target=target)
        fields = {}
        if fem:
            fields["fem"] = _heat_field(
                points, cells, part, spacing=h, n_sources=n_sources, seed=seed, noise=noise, progress=bar
            )
        _tick(bar, "analytic fields")
        fields["gaussians"] = gaussian_field(points, n_bumps=n_bumps, seed=seed)
        fields["distance"] = distance_field(points)
        return points, cells, fields

    return build


def _add_part(name, part_key, cell_type, target, h0, *, n_sources, noise=0.0, n_bumps, fem=True, thesis=None, note=""):
    part = _PARTS[part_key]
    fields = ("fem", "gaussians", "distance") if fem else ("gaussians", "distance")
    desc = f"{part.description}; {cell_type}, ~{target} cells" + (f"; {note}" if note else "")
    info = DatasetInfo(
        name=name,
        cell_type=cell_type,
        target_cells=int(target),
        genus=(part.genus,) + (0,) * part.n_voids,
        n_voids=part.n_voids,
        n_through_holes=part.genus,
        fields=fields,
        description=desc,
        thesis=dict(thesis or {}),
    )
    params = dict(
        part=part_key, cell_type=cell_type, target=int(target), h0=float(h0), n_sources=int(n_sources),
        noise=float(noise), n_bumps=int(n_bumps), fem=bool(fem),
    )
    _register(info, params, _part_builder(part, cell_type, target, h0, n_sources, noise, n_bumps, fem), 4 if fem else 2)


# the thesis's data 1-5 (Tables 6.1, 7.1); h0 is the mesh size that hits the target with gmsh 4.15
_add_part("data1", "bracket", "tetra", 20736, 0.11425, n_sources=22, n_bumps=60, thesis=_THESIS["data1"])
_add_part("data2", "flange", "tetra", 61680, 0.08431, n_sources=46, n_bumps=150, thesis=_THESIS["data2"])
_add_part("data3", "pillow_block", "tetra", 346644, 0.05794, n_sources=136, n_bumps=600, thesis=_THESIS["data3"])
_add_part("data4", "manifold", "tetra", 557868, 0.06658, n_sources=540, n_bumps=1000, thesis=_THESIS["data4"])
_add_part(
    "data5", "angle_bracket", "tetra", 458664, 0.05453, n_sources=60, noise=1.0, n_bumps=3000,
    thesis=_THESIS["data5"], note="random heat load on every node: thousands of extrema",
)
_add_part("2M", "manifold", "tetra", 2_000_000, 0.04355, n_sources=800, n_bumps=2000, note="for scaling")
_add_part(
    "10M", "manifold", "tetra", 10_000_000, 0.02547, n_sources=0, n_bumps=4000, fem=False,
    note="for scaling; analytic fields only (an FEM solve at this size needs too much memory and time)",
)
_add_part("hexa1", "plate", "hexa", 20736, 0.07145, n_sources=22, n_bumps=60)
_add_part("hexa2", "flange_hex", "hexa", 61680, 0.0545, n_sources=46, n_bumps=150)
_add_part("hexa3", "base_plate", "hexa", 346644, 0.03943, n_sources=136, n_bumps=600)


def _tiny_builder(kind, cell_type):
    def build(seed, bar):
        points, cells = _tiny(kind, cell_type)
        return points, cells, _tiny_fields(points, seed)

    return build


_TINY = [
    # name, kind, cell type, cells, genus by group, description
    ("one_tet", "one", "tetra", 1, (0,), "one tetrahedron"),
    ("two_tets", "two", "tetra", 2, (0,), "two tetrahedra sharing a face"),
    ("one_hex", "one", "hexa", 1, (0,), "one unit cube"),
    ("two_hexes", "two", "hexa", 2, (0,), "two unit cubes sharing a face"),
    ("torus", "torus", "tetra", 48, (1,), "a ring of 8 cubes (3x3x1 minus the centre), 6 tetrahedra each: genus 1"),
    ("torus_hex", "torus", "hexa", 8, (1,), "a ring of 8 cubes (3x3x1 minus the centre): genus 1"),
    ("hollow_cube", "hollow_cube", "tetra", 156, (0, 0), "3x3x3 cubes minus the centre, 6 tetrahedra each: one void"),
    ("hollow_cube_hex", "hollow_cube", "hexa", 26, (0, 0), "3x3x3 cubes minus the centre: one void"),
    ("genus3", "genus3", "tetra", 108, (3,), "7x3x1 cubes with three holes, 6 tetrahedra each: genus 3"),
    ("genus3_hex", "genus3", "hexa", 18, (3,), "7x3x1 cubes with three holes: genus 3"),
]
for _name, _kind, _ct, _nc, _genus, _desc in _TINY:
    _register(
        DatasetInfo(
            name=_name, cell_type=_ct, target_cells=_nc, genus=_genus, n_voids=len(_genus) - 1,
            n_through_holes=sum(_genus), fields=("linear", "distance", "gaussians"), description=_desc, cached=False,
        ),
        dict(kind=_kind, cell_type=_ct),
        _tiny_builder(_kind, _ct),
    )
del _name, _kind, _ct, _nc, _genus, _desc


# ------------------------------------------------------------------- API
def names():
    """Names of all data sets, in listing order (data 1-5, scaling, hexahedral, tiny)."""
    return list(_REGISTRY)


def _spec(name):
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise DatasetError(f"unknown data set {name!r}; the data sets are {names()}") from None


def info(name):
    """The :class:`DatasetInfo` of data set ``name``."""
    return _spec(name).info


def cache_dir():
    """Where built volumes are cached: ``$POLYGEN_CACHE_DIR`` or the platform cache dir + ``volumes``."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("polygen")) / "volumes"


def _key(name, seed):
    spec = _spec(name)
    payload = json.dumps(
        dict(name=name, seed=seed, params=spec.params, format=FORMAT_VERSION), sort_keys=True
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:12], payload


def cache_path(name, seed=0):
    """Path of the cache file of ``name`` built with ``seed`` (which may not exist yet)."""
    seed = _seed(seed)
    digest, _ = _key(name, seed)
    return cache_dir() / f"{name}-seed{seed}-v{FORMAT_VERSION}-{digest}.npz"


def is_cached(name, seed=0):
    """Whether ``load(name, seed=seed)`` would read a cache file."""
    return _spec(name).info.cached and cache_path(name, seed).is_file()


def _write_cache(path, points, cells, fields, payload):
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {"points": points, "cells": cells, "field_names": np.array(list(fields), dtype=str)}
    arrays["key"] = np.array(payload)
    for i, values in enumerate(fields.values()):
        arrays[f"field_{i}"] = values
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)  # uncompressed: loading is a plain read
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _read_cache(path, payload):
    try:
        with np.load(path, allow_pickle=False) as z:
            if str(z["key"]) != payload:
                return None
            names_ = [str(s) for s in z["field_names"]]
            fields = {n: z[f"field_{i}"] for i, n in enumerate(names_)}
            return z["points"], z["cells"], fields
    except (OSError, KeyError, ValueError):
        return None  # unreadable or foreign file: rebuild and overwrite


def _build_arrays(name, seed, progress):
    spec = _spec(name)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=spec.stages, desc=f"building {name}", unit="stage", leave=True)
    try:
        points, cells, fields = spec.builder(seed, bar)
    finally:
        if bar is not None:
            bar.n = bar.total
            bar.set_postfix_str("done")
            bar.close()
    if spec.info.cached:
        points, cells, fields = _spatial_order(points, cells, fields)
    return points, cells, fields


def _spatial_order(points, cells, fields):
    """Nodes and cells renumbered along a Morton curve (see ``UnstructuredVolume.reordered``).

    gmsh's parallel 3D mesher numbers cells far from spatially; the FEM
    meshes users bring are usually renumbered (bandwidth, cache), so ours
    are too. The same renumbered mesh goes to VTK in every comparison.
    """
    from polygen.volume.mesh import UnstructuredVolume

    vol = UnstructuredVolume(points, cells, fields, validate=False).reordered()
    return vol.points, vol.cells, vol.fields


def build(name, *, seed=0, force=False, progress=False):
    """Build data set ``name`` into the cache (if not there yet) and return the cache file path.

    Parameters
    ----------
    name : str
    seed : int, keyword-only
    force : bool, keyword-only
        Rebuild even if the cache file exists.
    progress : bool, keyword-only
        Show a tqdm progress bar of the build stages.

    Returns
    -------
    pathlib.Path or None
        ``None`` for the tiny volumes, which are not cached.
    """
    spec = _spec(name)
    seed = _seed(seed)
    if not spec.info.cached:
        return None
    path = cache_path(name, seed)
    if force or not path.is_file():
        points, cells, fields = _build_arrays(name, seed, progress)
        _write_cache(path, points, cells, fields, _key(name, seed)[1])
    return path


def load(name, *, seed=0, field=None, progress=False, cache=True):
    """Load (building and caching if needed) the volume ``name``.

    Parameters
    ----------
    name : str
        One of :func:`names`, e.g. ``"data1"`` .. ``"data5"``, ``"2M"``,
        ``"10M"``, ``"hexa1"``, ``"torus"``, ``"hollow_cube"``,
        ``"genus3"``, ``"two_tets"``.
    seed : int, keyword-only
        Moves the heat sources, random loads and Gaussian bumps (the mesh
        depends on the name only).
    field : str, optional, keyword-only
        Field to put first, so that ``vol.scalars()`` returns it; the
        data set's first field (``info(name).fields[0]``) by default. All
        fields are attached either way.
    progress : bool, keyword-only
        Show a tqdm progress bar when building.
    cache : bool, keyword-only
        Read and write the disk cache (default). ``False`` builds in memory.

    Returns
    -------
    UnstructuredVolume

    Raises
    ------
    DatasetError
        Unknown name or field, bad seed.
    """
    from polygen.volume.mesh import UnstructuredVolume

    spec = _spec(name)
    seed = _seed(seed)
    if field is not None and field not in spec.info.fields:
        raise DatasetError(f"data set {name!r} has no field {field!r}; its fields are {list(spec.info.fields)}")
    arrays = None
    use_cache = cache and spec.info.cached
    if use_cache:
        path = cache_path(name, seed)
        payload = _key(name, seed)[1]
        if path.is_file():
            arrays = _read_cache(path, payload)
    if arrays is None:
        arrays = _build_arrays(name, seed, progress)
        if use_cache:
            _write_cache(path, *arrays, payload)
    points, cells, fields = arrays
    order = list(fields)
    if field is not None:
        order.remove(field)
        order.insert(0, field)
    # the generators orient every cell; the container's geometric check is left on for the
    # small volumes and skipped above a million cells, where it costs more than the load
    return UnstructuredVolume(
        points, cells, {k: fields[k] for k in order}, validate=cells.shape[0] <= 1_000_000
    )
