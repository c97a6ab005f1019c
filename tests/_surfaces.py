"""Helpers shared by the isosurface tests: small grid volumes and surface comparisons."""

import numpy as np

from polygen.volume import UnstructuredVolume, methods
from polygen.volume.isosurface import extract


def grid_volume(dims, spacing=(1.0, 1.0, 1.0), *, tets=True, jitter=0.0, seed=0):
    """A box of ``dims`` grid points as tetrahedra (VTK's triangulation) or hexahedra, nodes jittered."""
    import pyvista as pv

    img = pv.ImageData(dimensions=dims, spacing=spacing)
    grid = img.triangulate() if tets else img.cast_to_unstructured_grid()
    vol = UnstructuredVolume.from_pyvista(grid)
    if jitter:
        rng = np.random.default_rng(seed)
        vol = UnstructuredVolume(vol.points + jitter * min(spacing) * rng.uniform(-1, 1, vol.points.shape), vol.cells)
    return vol


def oriented_triangles(iso):
    """Triangles as vertex-key triples, orientation kept (rotated to start at the smallest key)."""
    k = iso.vertex_keys[iso.triangles]
    r = np.argmin(k, axis=1)
    rolled = np.stack([k[np.arange(len(k)), (r + i) % 3] for i in range(3)], axis=1)
    return {tuple(t) for t in rolled.tolist()}


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
