"""Ray casting of tetrahedral and hexahedral volumes (thesis 7.8.1, Fig. 7.8(a))."""

from __future__ import annotations

import dataclasses
import threading
import time

import numpy as np

from polygen import _jit
from polygen.volume.render import _kernels as _k
from polygen.volume.render.transfer import Lighting, check_optical_model, check_tf
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
    bins of the last view, and the kept samples, are guarded by a lock.

    With ``keep_samples=True`` the caster keeps, for the last view and
    sample spacing, every sample's scalar and gradient along every ray
    (``(S, Gx, Gy, Gz)``, 32 bytes a sample): a new transfer function,
    lighting, background or optical model on the same view and spacing then
    classifies and composites them again (7.1, 7.2) without walking a cell,
    the cache :class:`~polygen.volume.render.ShellRenderer` keeps as its
    fragments. A new view or spacing walks again and replaces them.

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
        Field name or node values (the volume's first field by default).
    keep_samples : bool, keyword-only
        Keep the samples of the last view and spacing (above).

    Attributes
    ----------
    walks : int
        Frames whose rays walked the cells.
    sample_builds : int
        How many times the kept samples were made (``keep_samples`` only).
    kept_bytes : int
        Bytes the kept samples hold (0 without them).

    The counters are the work the calls did, for checks that do not depend
    on the machine's speed.
    """

    def __init__(self, vol, field=None, *, keep_samples=False):
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
        self.keep_samples = bool(keep_samples)
        self._kept = None  # (camera key, step, store offsets, samples, store, length, entries)
        self.walks = 0
        self.sample_builds = 0
        self.preprocess_s = time.perf_counter() - t0

    def __getstate__(self):
        # pickling and deepcopy (Dask, multiprocessing): the lock does not travel, the copy makes its own
        with self._lock:
            state = self.__dict__.copy()
        del state["_lock"]
        return _jit.note_read_only(state)

    def __setstate__(self, state):
        self.__dict__.update(state)
        _jit.restore_read_only(self)
        if self._kept is not None:  # the kept samples, read-only like the ones it made
            for a in self._kept[2:]:
                a.setflags(write=False)
        self._lock = threading.Lock()

    @staticmethod
    def _key(camera):
        return (camera.eye, camera.target, camera.up, camera.fov, camera.height, camera.size)

    @property
    def kept_bytes(self):
        kept = self._kept
        return 0 if kept is None else int(sum(a.nbytes for a in kept[2:]))

    def _view(self, camera):
        key = self._key(camera)
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

    def render(self, camera, tf, *, step, lighting=None, background=0.0, optical_model="opacity"):
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
        optical_model : {"opacity", "attenuation"}, keyword-only
            What the table's opacity means (:data:`~polygen.volume.render.transfer.OPTICAL_MODELS`):
            ``"opacity"``, polygen's, the opacity of a slab ``tf.unit`` thick (attenuation
            ``-ln(1 - a) / unit``); ``"attenuation"``, VTK's, ``a / unit`` the attenuation
            coefficient itself (sample opacity ``1 - exp(-a * step / unit)``).

        Returns
        -------
        RenderResult
            ``seconds`` has ``bins``, ``cast`` (the walk, 0 when kept samples
            were composited), ``composite`` and ``total``.
        """
        camera, tf, step = check_view(camera), check_tf(tf), check_step(step)
        alpha, tau = tf.sample_table(step, check_optical_model(optical_model))
        e, energy, light, head, shade = (lighting or Lighting()).arrays()
        bg = check_background(background)
        w, h = camera.size
        t0 = time.perf_counter()
        if self.keep_samples:
            with self._lock:
                kept = self._kept
            if kept is not None and kept[0] == self._key(camera) and kept[1] == step:
                _, _, store_off, samples, store, length, entries = kept
                dirs = self._view(camera)[3]
                t1 = time.perf_counter()
                image = _jit.scratch((dirs.shape[0], 3))
                _k.composite_samples(store_off, samples, store, dirs, tf.knots, tf.rgb, alpha, tau, e, energy,
                                     light, head, shade, bg, image)
                t2 = time.perf_counter()
                return RenderResult(image=image.reshape(h, w, 3), length=length.reshape(h, w),
                                    entries=entries.reshape(h, w), samples=samples.reshape(h, w).copy(),
                                    seconds={"bins": t1 - t0, "cast": 0.0, "composite": t2 - t1,
                                             "total": t2 - t0})
        offsets, items, origins, dirs, start = self._view(camera)
        t1 = time.perf_counter()
        npix = origins.shape[0]
        if self.keep_samples:
            cap = _jit.scratch(npix, np.int64)
            _k.sample_bounds(self.vol.points, self.btris, offsets, items, origins, dirs, start, step, cap)
            store_off = np.zeros(npix + 1, np.int64)
            np.cumsum(cap, out=store_off[1:])
            store = _jit.scratch((int(store_off[-1]), 4))
        else:
            store_off, store = np.zeros(0, np.int64), np.zeros((0, 4))
        image = _jit.scratch((npix, 3))
        length = _jit.scratch(npix)
        entries = _jit.scratch(npix, np.int64)
        samples = _jit.scratch(npix, np.int64)
        _k.cast(self.vol.points, self.vol.cells, self.faces, self.is_hex, self.nb, self.values, self.grads,
                self.btris, self.bcell, offsets, items, origins, dirs, start, step, tf.knots, tf.rgb,
                alpha, tau, e, energy, light, head, shade, bg, self.scale, self.vol.n_cells,
                store_off, store, image, length, entries, samples)
        t2 = time.perf_counter()
        with self._lock:
            self.walks += 1
        if self.keep_samples:
            over = np.flatnonzero(samples > np.diff(store_off))
            if over.size:  # the bound of sample_bounds failed: a bug, not bad input
                raise RuntimeError(f"{over.size} rays have more samples than their bound (pixel {over[0]}: "
                                   f"{samples[over[0]]} > {np.diff(store_off)[over[0]]})")
            for a in (store_off, samples, store, length, entries):
                a.setflags(write=False)
            with self._lock:
                self._kept = (self._key(camera), step, store_off, samples, store, length, entries)
                self.sample_builds += 1
        return RenderResult(image=image.reshape(h, w, 3), length=length.reshape(h, w),
                            entries=entries.reshape(h, w), samples=samples.reshape(h, w).copy(),
                            seconds={"bins": t1 - t0, "cast": t2 - t1, "composite": 0.0, "total": t2 - t0})


def raycast(vol, camera, tf, *, field=None, step, lighting=None, background=0.0, optical_model="opacity"):
    """Ray-cast ``vol`` once (a :class:`RayCaster` made and used for one frame).

    Parameters and result as :meth:`RayCaster.render`; ``field`` as :class:`RayCaster`.
    """
    return RayCaster(vol, field).render(camera, tf, step=step, lighting=lighting, background=background,
                                        optical_model=optical_model)
