"""Meshing the parts with gmsh: tetrahedra (HXT, one thread) and extruded full-quad hexahedra, sized to a target cell count."""

from __future__ import annotations

import contextlib

import numpy as np

from polygen.volume.datasets.parts import _ExtrudedPart
from polygen.volume.datasets.tiny import _orient_tets


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
