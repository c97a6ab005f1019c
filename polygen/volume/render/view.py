"""The view: a small camera dataclass, its pixel rays and its validation."""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["RenderError", "View", "view_around", "check_view", "check_step", "check_background"]


class RenderError(ValueError):
    """Bad input to a volume renderer (the message says which)."""


def _vec3(x, name):
    try:
        v = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise RenderError(f"{name} must be three numbers; got {x!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise RenderError(f"{name} must be three finite numbers; got {x!r}")
    return v


@dataclasses.dataclass(frozen=True, eq=False)
class View:
    """An orthographic or perspective view of ``size = (width, height)`` pixels.

    Parameters
    ----------
    eye : (3,) float
        The viewpoint ``V`` of (7.3).
    target : (3,) float
        A point the view centre looks at.
    up : (3,) float
        Roughly up on the screen (made orthogonal to the view direction).
    fov : float or None
        Vertical field of view in degrees (0 < fov < 180); ``None`` for an
        orthographic view.
    height : float or None
        Orthographic only: the world height the image spans.
    size : (int, int)
        Image width and height in pixels, both >= 1.

    Notes
    -----
    Pixel ``p = row * width + col``, row 0 at the top. Perspective rays start
    at the eye; orthographic rays start on the plane through the eye normal
    to the view direction. Either way the ray parameter ``t`` of a unit ray
    is the distance from the eye that the equi-distance surfaces measure:
    spheres ``|x - V| = t`` (7.3) for a perspective view, planes
    ``(x - V) . f = t`` for an orthographic one.
    """

    eye: tuple
    target: tuple
    up: tuple = (0.0, 0.0, 1.0)
    fov: float | None = 30.0
    height: float | None = None
    size: tuple = (128, 128)

    def __post_init__(self):
        eye = _vec3(self.eye, "eye")
        target = _vec3(self.target, "target")
        up = _vec3(self.up, "up")
        for name, v in (("eye", eye), ("target", target), ("up", up)):
            object.__setattr__(self, name, tuple(float(x) for x in v))
        try:
            w, h = (int(self.size[0]), int(self.size[1]))
            if (w, h) != (self.size[0], self.size[1]) or len(self.size) != 2:
                raise ValueError
        except (TypeError, ValueError, IndexError):
            raise RenderError(f"size must be two whole numbers (width, height); got {self.size!r}") from None
        if w < 1 or h < 1:
            raise RenderError(f"the image must have at least one pixel; got size {self.size!r}")
        object.__setattr__(self, "size", (w, h))
        f = target - eye
        if not np.linalg.norm(f) > 0:
            raise RenderError("eye and target coincide: the view direction is undefined")
        f = f / np.linalg.norm(f)
        r = np.cross(f, up)
        if not np.linalg.norm(r) > 1e-9 * max(np.linalg.norm(up), 1e-300):
            raise RenderError(f"up {self.up} is parallel to the view direction {f.tolist()}")
        if self.fov is None:
            if self.height is None or not (np.isfinite(self.height) and self.height > 0):
                raise RenderError(f"an orthographic camera (fov=None) needs height > 0; got {self.height!r}")
        elif not (np.isfinite(self.fov) and 0 < self.fov < 180):
            raise RenderError(f"fov must be in (0, 180) degrees, or None for orthographic; got {self.fov!r}")

    @property
    def ortho(self) -> bool:
        return self.fov is None

    @property
    def width_px(self) -> int:
        return self.size[0]

    @property
    def height_px(self) -> int:
        return self.size[1]

    @property
    def n_pixels(self) -> int:
        return self.size[0] * self.size[1]

    def basis(self):
        """``(forward, right, up)`` unit vectors (right-handed screen: right x up = -forward)."""
        eye, target = np.array(self.eye), np.array(self.target)
        f = target - eye
        f /= np.linalg.norm(f)
        r = np.cross(f, np.array(self.up))
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        return f, r, u

    def half_extent(self):
        """Half the image's width and height: in world units (orthographic) or tangents (perspective)."""
        w, h = self.size
        hh = self.height / 2.0 if self.ortho else float(np.tan(np.radians(self.fov) / 2.0))
        return hh * w / h, hh

    def rays(self):
        """``origins (P, 3)``, unit ``directions (P, 3)`` float64 of the pixel centres."""
        w, h = self.size
        f, r, u = self.basis()
        hw, hh = self.half_extent()
        su = ((np.arange(w) + 0.5) / w * 2.0 - 1.0) * hw
        sv = (1.0 - (np.arange(h) + 0.5) / h * 2.0) * hh
        uu, vv = np.meshgrid(su, sv)
        uu, vv = uu.ravel(), vv.ravel()
        eye = np.array(self.eye)
        if self.ortho:
            origins = eye + uu[:, None] * r + vv[:, None] * u
            dirs = np.broadcast_to(f, origins.shape).copy()
        else:
            dirs = f + uu[:, None] * r + vv[:, None] * u
            dirs /= np.linalg.norm(dirs, axis=1)[:, None]
            origins = np.broadcast_to(eye, dirs.shape).copy()
        return np.ascontiguousarray(origins), np.ascontiguousarray(dirs)

    def distance(self, points):
        """(N,) float64 distance of ``points (N, 3)`` from the eye as the rays measure it (7.3)."""
        rel = np.asarray(points, np.float64) - np.array(self.eye)
        if self.ortho:
            return rel @ self.basis()[0]
        return np.sqrt(np.einsum("ij,ij->i", rel, rel))

    def replace(self, **changes):
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def _kernel_args(self):
        f, r, u = self.basis()
        hw, hh = self.half_extent()
        return np.array(self.eye), f, r, u, hw, hh, self.size[0], self.size[1], self.ortho


def view_around(points, *, eye=(1.2, -1.6, 0.9), fov=35.0, size=128):
    """A perspective view of the box around ``points`` from a direction, and the box's diagonal.

    The view looks at the centre ``c`` of the bounding box from ``c + D * eye``, ``D`` the box's
    diagonal: the eye's place is given in diagonals, so one ``eye`` frames volumes of any size
    alike. ``D`` is returned too: sample spacings and opacity units are set per diagonal.

    Parameters
    ----------
    points : (N, 3) float
        E.g. ``vol.points``.
    eye : (3,) float, keyword-only
        Eye minus centre, in diagonals (not zero).
    fov : float, keyword-only
        Vertical field of view in degrees.
    size : int or (int, int), keyword-only
        Pixels per side, or ``(width, height)``.

    Returns
    -------
    view : View
    diagonal : float
        ``|max - min|`` of the points' bounding box.

    Raises
    ------
    RenderError
        No points or not (N, 3) finite, a zero ``eye``, a box of zero size, or a bad ``fov``/``size``.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[0] == 0 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise RenderError(f"points must be (N, 3) finite coordinates with N >= 1; got shape {p.shape}")
    lo, hi = p.min(axis=0), p.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    if not diag > 0:
        raise RenderError("the points' bounding box has zero size: nothing to frame")
    direction = _vec3(eye, "eye")
    if not np.linalg.norm(direction) > 0:
        raise RenderError("eye must be a non-zero direction from the centre (in diagonals)")
    size = (size, size) if np.ndim(size) == 0 else tuple(size)
    centre = (lo + hi) / 2
    return View(eye=centre + diag * direction, target=centre, fov=fov, size=size), diag


# ------------------------------------------------------------------ validation shared by the renderers
def check_view(camera):
    """``camera`` if it is a :class:`View`; :class:`RenderError` otherwise."""
    if not isinstance(camera, View):
        raise RenderError(f"camera must be a View; got {type(camera).__name__}")
    return camera


def check_step(step):
    """``step`` as a float > 0 (the sample and surface spacing); :class:`RenderError` otherwise."""
    try:
        step = float(step)
    except (TypeError, ValueError):
        raise RenderError(f"step must be a number; got {step!r}") from None
    if not (np.isfinite(step) and step > 0):
        raise RenderError(f"step must be a length > 0; got {step!r}")
    return step


def check_background(bg):
    """(3,) float64 background colour from a grey level or an RGB triple."""
    b = np.broadcast_to(np.asarray(bg, np.float64), (3,)).copy()
    if not np.all(np.isfinite(b)):
        raise RenderError(f"background must be finite; got {bg!r}")
    return b
