"""Helpers shared by the isosurface tests: small grid volumes and surface comparisons."""

import numpy as np

from polygen.volume import UnstructuredVolume, methods
from polygen.volume._cells import HEX_UNIT_CORNERS, KUHN_TETS
from polygen.volume.isosurface import extract


#: the tiny volumes of :mod:`polygen.volume.datasets` (built on the fly), for the ``tiny_volume`` fixture
TINY_VOLUMES = ("one_tet", "two_tets", "one_hex", "two_hexes", "torus", "torus_hex", "hollow_cube",
                "hollow_cube_hex", "genus3", "genus3_hex")


def grid_volume(dims, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), *, tets=True, jitter=0.0, seed=0):
    """A box of ``dims`` grid points as tetrahedra (VTK's triangulation) or hexahedra, nodes jittered."""
    import pyvista as pv

    img = pv.ImageData(dimensions=dims, spacing=spacing, origin=origin)
    grid = img.triangulate() if tets else img.cast_to_unstructured_grid()
    vol = UnstructuredVolume.from_pyvista(grid)
    if jitter:
        rng = np.random.default_rng(seed)
        vol = UnstructuredVolume(vol.points + jitter * min(spacing) * rng.uniform(-1, 1, vol.points.shape), vol.cells)
    return vol




def block_volume(keep, cell_type="tetra", jitter=0.0, seed=0):
    """Unit cubes over the True entries of ``keep`` (hexahedra, or 6 Kuhn tetrahedra each).

    Carries two fields: ``"bumps"`` (a few smooth extrema) and ``"linear"``.
    """
    keep = np.asarray(keep, bool)
    nx, ny, nz = keep.shape
    c = np.argwhere(keep)[:, None, :] + HEX_UNIT_CORNERS[None]
    hexes = (c[..., 0] * (ny + 1) + c[..., 1]) * (nz + 1) + c[..., 2]
    used, cells = np.unique(hexes, return_inverse=True)
    cells = cells.reshape(hexes.shape)
    g = np.stack(np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij"), -1)
    pts = g.reshape(-1, 3)[used].astype(float)
    if jitter:
        pts = pts + np.random.default_rng(seed).uniform(-jitter, jitter, pts.shape)
    if cell_type == "tetra":
        cells = cells[:, KUHN_TETS].reshape(-1, 4)
        p = pts[cells]
        vol6 = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
        neg = vol6 < 0
        cells[neg, 1], cells[neg, 2] = cells[neg, 2], cells[neg, 1].copy()
    p = pts
    fields = {"bumps": np.sin(1.3 * p[:, 0] + 0.2) * np.cos(1.1 * p[:, 1] - 0.3) + 0.37 * np.sin(0.9 * p[:, 2] + 1),
              "linear": p[:, 0] + 0.31 * p[:, 1] + 0.097 * p[:, 2]}
    return UnstructuredVolume(pts, cells, fields)


def iso_values(s, n=200, seed=0):
    """Half evenly spread over the range (and just outside), half equal to node values (ties)."""
    rng = np.random.default_rng(seed)
    lo, hi = float(s.min()), float(s.max())
    even = np.linspace(lo - 0.01 * (hi - lo), hi + 0.01 * (hi - lo), n // 2)
    return np.concatenate([even, rng.choice(s, n - n // 2)])


def oriented_triangles(iso):
    """Triangles as vertex-key triples, orientation kept (rotated to start at the smallest key)."""
    k = iso.vertex_keys[iso.triangles]
    r = np.argmin(k, axis=1)
    rolled = np.stack([k[np.arange(len(k)), (r + i) % 3] for i in range(3)], axis=1)
    return {tuple(t) for t in rolled.tolist()}


def assert_same_surface(ref, iso, *, cells=True, lookups=False):
    """``iso`` is ``ref`` triangle for triangle (orientation included), vertex for vertex (positions bit for
    bit), each vertex once, with the same normals; with ``cells`` also the same intersected cells and each
    triangle made in the same cell; with ``lookups`` the same vertex look-ups."""
    assert iso.n_triangles == ref.n_triangles and iso.n_vertices == ref.n_vertices
    assert oriented_triangles(iso) == oriented_triangles(ref)
    assert np.unique(iso.vertex_keys).size == iso.n_vertices  # no vertex twice
    oa, ob = np.argsort(ref.vertex_keys), np.argsort(iso.vertex_keys)
    np.testing.assert_array_equal(ref.vertex_keys[oa], iso.vertex_keys[ob])
    np.testing.assert_array_equal(ref.vertices[oa], iso.vertices[ob])  # (5.2) bit for bit
    assert (ref.normals is None) == (iso.normals is None)
    if ref.normals is not None:
        np.testing.assert_allclose(ref.normals[oa], iso.normals[ob], atol=1e-12)
    if lookups:
        assert iso.vertex_lookups == ref.vertex_lookups
    if cells:
        assert iso.cells_intersected == ref.cells_intersected
        ka = {tuple(sorted(t)) + (c,) for t, c in zip(ref.vertex_keys[ref.triangles].tolist(), ref.triangle_cells)}
        kb = {tuple(sorted(t)) + (c,) for t, c in zip(iso.vertex_keys[iso.triangles].tolist(), iso.triangle_cells)}
        assert ka == kb  # each triangle made in the same cell


def sorted_triangles(iso):
    """(T, 3) vertex keys of each triangle, sorted within and across triangles."""
    t = np.sort(iso.vertex_keys[iso.triangles], axis=1)
    return t[np.lexsort(t.T[::-1])]


def assert_complete(name, vol, field, values, **params):
    """The isosurface of method ``name`` equals the full scan's for every value; returns the method."""
    m = methods.get(name)(vol, field, **params)
    for v in values:
        ours = m.extract(v)
        ref = extract(vol, v, field=field)
        a, b = sorted_triangles(ours), sorted_triangles(ref)
        assert a.shape == b.shape and np.array_equal(a, b), (
            f"value {v}: {a.shape[0]} triangles by {name}, {b.shape[0]} by the scan")
        assert m.stats["N_ci"] == ref.cells_intersected
    return m


def run_without_prefetch(script, path, *args):
    """Run ``script`` (``python -c``) in a fresh process with ``POLYGEN_PREFETCH=0`` and this checkout's
    polygen: the kernels are chosen at import, so only a new process gets the plain ones. ``script``
    writes its results to ``path`` (its first argument); returns them, ``numpy.load``-ed."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    env = dict(os.environ, POLYGEN_PREFETCH="0")
    root = Path(__file__).resolve().parents[1]
    env["PYTHONPATH"] = os.pathsep.join([str(root), env.get("PYTHONPATH", "")])
    subprocess.run([sys.executable, "-c", script, str(path), *args], env=env, cwd=root, check=True)
    return np.load(path)
