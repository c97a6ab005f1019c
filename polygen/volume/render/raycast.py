"""Ray casting of tetrahedral and hexahedral volumes (thesis 7.8.1, Fig. 7.8(a))."""

from __future__ import annotations

import dataclasses
import threading
import time

import numpy as np

from polygen import _jit
from polygen.volume.render import _kernels as _k
from polygen.volume.render.transfer import Lighting, check_tf
from polygen.volume.render.view import RenderError, check_background, check_step, check_view
from polygen.volume.surface import node_gradients

__all__ = ["RenderResult", "RayCaster", "raycast", "boundary_triangles"]


@dataclasses.dataclass(frozen=True, eq=False)
class RenderResult:
    """One rendered frame.

    Attributes
    ----------
    image : (H, W, 3) float64
        Composited colour, the background showing through what stays transparent.
    length : (H, W) float64 or None
        Ray caster only: length of each pixel's ray inside material.
    entries : (H, W) int64 or None
        Ray caster only: segments walked (entries into the volume, the eye's cell included).
    samples : (H, W) int64
        Samples composited per pixel (ray samples, or shell fragments).
    seconds : dict
        Stage timings.
    """

    image: np.ndarray
    length: np.ndarray | None
    entries: np.ndarray | None
    samples: np.ndarray
    seconds: dict


def boundary_triangles(vol):
    """The boundary as outward triangles: ``(tris (T, 3) int64, owner cell (T,) int64)``.

    A hexahedron's quadrilateral is cut along the diagonal through its
    smallest node id, as the walk cuts it (:mod:`._kernels`).
    """
    bf = vol.boundary_faces
    nodes = vol.boundary_face_nodes
    if vol.cell_type == "tetra":
        return np.ascontiguousarray(nodes, np.int64), np.ascontiguousarray(bf[:, 0], np.int64)
    k = np.argmin(nodes, axis=1)
    idx = (k[:, None] + np.arange(4)[None, :]) % 4
    q = np.take_along_axis(nodes, idx, axis=1)
    tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    owner = np.concatenate([bf[:, 0], bf[:, 0]])
    return np.ascontiguousarray(tris, np.int64), np.ascontiguousarray(owner, np.int64)


class RayCaster:
    """Ray casting prepared on one volume and field (7.8.1).

    Rays enter through the boundary faces (binned per pixel for each view),
    walk cell to cell through the face neighbours, and re-enter through the
    next boundary face behind a concave part, a through-hole or a void.
    Samples at ``t = k * step`` are interpolated in their cell (Def. 5.5:
    linear in a tetrahedron, trilinear in a hexahedron), value and node
    gradient alike, and composited by (7.1) with colours from (7.2).

    Contract: the node gradients and the boundary triangles are computed
    once, here, from the field's values at construction (a copy is kept, so a
    later change to the volume's field does not reach this caster: make a
    new one). :meth:`render` may be called from several threads; the cached
    bins of the last view are guarded by a lock.

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name or node values (the volume's first field by default).
    """

    def __init__(self, vol, field=None):
        t0 = time.perf_counter()
        self.vol = vol
        s = vol.scalars(field) if field is None or isinstance(field, str) else np.asarray(field, np.float64)
        if s.shape != (vol.n_points,) or not np.all(np.isfinite(s)):
            raise RenderError(f"field values must be {vol.n_points} finite numbers; got shape {np.shape(s)}")
        self.values = np.array(s, np.float64)
        self.values.setflags(write=False)
        self.grads = np.ascontiguousarray(node_gradients(vol, self.values))
        self.btris, self.bcell = boundary_triangles(vol)
        self.nb = np.ascontiguousarray(vol.face_neighbors)
        self.faces = np.ascontiguousarray(vol.local_faces)
        self.is_hex = vol.cell_type == "hexa"
        lo, hi = vol.points.min(axis=0), vol.points.max(axis=0)
        self.scale = float(np.linalg.norm(hi - lo)) or 1.0
        self._lock = threading.Lock()
        self._bins = None  # (camera key, offsets, items, origins, dirs, start cells)
        self.preprocess_s = time.perf_counter() - t0

    def _view(self, camera):
        key = (camera.eye, camera.target, camera.up, camera.fov, camera.height, camera.size)
        with self._lock:
            if self._bins is not None and self._bins[0] == key:
                return self._bins[1:]
        origins, dirs = camera.rays()
        eye, f, r, u, hw, hh, w, h, ortho = camera._kernel_args()
        offsets, items = _k.bin_triangles(self.vol.points, self.btris, eye, f, r, u, hw, hh, w, h, ortho)
        if ortho:
            start = self.vol.locate(origins)
        else:
            start = np.full(origins.shape[0], self.vol.locate(eye[None])[0], np.int64)
        out = (offsets, items, origins, dirs, np.ascontiguousarray(start, np.int64))
        with self._lock:
            self._bins = (key,) + out
        return out

    def render(self, camera, tf, *, step, lighting=None, background=0.0):
        """Cast one frame.

        Parameters
        ----------
        camera : View
        tf : TransferFunction
        step : float, keyword-only
            Sample spacing along each ray (samples at ``k * step`` from the eye).
        lighting : Lighting, optional, keyword-only
        background : float or (3,) float, keyword-only
            What shows through (``C_0`` of (7.1)).

        Returns
        -------
        RenderResult
        """
        camera, tf, step = check_view(camera), check_tf(tf), check_step(step)
        e, energy, light, head, shade = (lighting or Lighting()).arrays()
        bg = check_background(background)
        t0 = time.perf_counter()
        offsets, items, origins, dirs, start = self._view(camera)
        t1 = time.perf_counter()
        npix = origins.shape[0]
        image = _jit.scratch((npix, 3))
        length = _jit.scratch(npix)
        entries = _jit.scratch(npix, np.int64)
        samples = _jit.scratch(npix, np.int64)
        _k.cast(self.vol.points, self.vol.cells, self.faces, self.is_hex, self.nb, self.values, self.grads,
                self.btris, self.bcell, offsets, items, origins, dirs, start, step, tf.knots, tf.rgb,
                tf.corrected(step), e, energy, light, head, shade, bg, self.scale, self.vol.n_cells,
                image, length, entries, samples)
        t2 = time.perf_counter()
        w, h = camera.size
        return RenderResult(image=image.reshape(h, w, 3), length=length.reshape(h, w),
                            entries=entries.reshape(h, w), samples=samples.reshape(h, w),
                            seconds={"bins": t1 - t0, "cast": t2 - t1, "total": t2 - t0})


def raycast(vol, camera, tf, *, field=None, step, lighting=None, background=0.0):
    """Ray-cast ``vol`` once (a :class:`RayCaster` made and used for one frame).

    Parameters and result as :meth:`RayCaster.render`; ``field`` as :class:`RayCaster`.
    """
    return RayCaster(vol, field).render(camera, tf, step=step, lighting=lighting, background=background)
