"""Element size fields: ``size(xy) -> (K,)`` target edge length at each point.

A size field is anything callable on a ``(K, 2) float64`` array returning
``(K,)`` positive lengths. :class:`GridSize` is the rectangular size grid
of chapter 4 (values on an ``m x n`` lattice, read by bilinear
interpolation, (4.12, 4.13)); :func:`as_size_function` turns a number, a
grid or a callable into a checked size function.
"""

from dataclasses import dataclass

import numpy as np

from polygen._jit import njit, prange

__all__ = ["GridSize", "as_size_function", "uniform_size"]


@njit(parallel=True)
def _bilinear_kernel(x0, y0, dx, dy, values, xy, out):
    # xy has no NaN (checked by the caller), so u, v are finite or +-inf, never NaN
    ny, nx = values.shape
    for k in prange(xy.shape[0]):
        u = (xy[k, 0] - x0) / dx
        v = (xy[k, 1] - y0) / dy
        # points outside the grid take the nearest border value
        u = min(max(u, 0.0), nx - 1.0)
        v = min(max(v, 0.0), ny - 1.0)
        # the cell C_ij holding the point: x_i <= x <= x_{i+1} (the last cell
        # takes its right border); the index is clamped again, so round-off in
        # u can never step outside the lattice
        i = min(max(int(u), 0), nx - 2)
        j = min(max(int(v), 0), ny - 2)
        s = u - i  # (4.13) s = (x - x1) / (x2 - x1)
        t = v - j  # (4.13) t = (y - y1) / (y2 - y1)
        # (4.12) (1 - t)((1 - s) r11 + s r21) + t((1 - s) r12 + s r22), r_ab at (x_a, y_b),
        # expanded (the form meshes made so far were computed with, to the last bit)
        out[k] = ((1 - s) * (1 - t) * values[j, i] + s * (1 - t) * values[j, i + 1]
                  + (1 - s) * t * values[j + 1, i] + s * t * values[j + 1, i + 1])


@dataclass(frozen=True, eq=False)
class GridSize:
    """Size values on a rectangular lattice, read by bilinear interpolation.

    Attributes
    ----------
    origin : (2,) float64
        Coordinates of ``values[0, 0]``.
    spacing : (2,) float64
        Lattice steps ``(dx, dy)``.
    values : (ny, nx) float64
        Positive sizes; ``values[j, i]`` is at ``origin + (i dx, j dy)``.
    """

    origin: np.ndarray
    spacing: np.ndarray
    values: np.ndarray

    def __post_init__(self):
        o = np.asarray(self.origin, dtype=np.float64).reshape(2)
        s = np.asarray(self.spacing, dtype=np.float64).reshape(2)
        v = np.ascontiguousarray(self.values, dtype=np.float64)
        if v.ndim != 2 or min(v.shape) < 2:
            raise ValueError(f"GridSize.values: expected shape (ny >= 2, nx >= 2), got {v.shape}")
        if not np.all(np.isfinite(v)) or v.min() <= 0:
            raise ValueError("GridSize.values: sizes must be finite and positive")
        if not np.all(np.isfinite(s)) or s.min() <= 0:
            raise ValueError(f"GridSize.spacing: must be positive, got {s}")
        if not np.all(np.isfinite(o)):
            raise ValueError(f"GridSize.origin: must be finite, got {o}")
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "spacing", s)
        object.__setattr__(self, "values", v)

    @classmethod
    def from_function(cls, fn, bounds, shape):
        """Sample a size function on a lattice covering ``bounds = (xmin, ymin, xmax, ymax)``."""
        xmin, ymin, xmax, ymax = map(float, bounds)
        if not (np.isfinite([xmin, ymin, xmax, ymax]).all() and xmax > xmin and ymax > ymin):
            raise ValueError(f"bounds: expected finite (xmin, ymin, xmax, ymax) with xmin < xmax, "
                             f"ymin < ymax, got {bounds}")
        ny, nx = (int(k) for k in shape)
        if ny < 2 or nx < 2:
            raise ValueError(f"shape: expected (ny >= 2, nx >= 2), got {shape}")
        x = np.linspace(xmin, xmax, nx)
        y = np.linspace(ymin, ymax, ny)
        X, Y = np.meshgrid(x, y)
        v = np.asarray(fn(np.stack([X.ravel(), Y.ravel()], axis=1)), dtype=np.float64)
        return cls((xmin, ymin), (x[1] - x[0], y[1] - y[0]), v.reshape(ny, nx))

    @property
    def bounds(self):
        """``(xmin, ymin, xmax, ymax)`` of the lattice."""
        ny, nx = self.values.shape
        hi = self.origin + self.spacing * np.array([nx - 1, ny - 1])
        return (float(self.origin[0]), float(self.origin[1]), float(hi[0]), float(hi[1]))

    def __call__(self, xy):
        """Sizes ``(K,) float64`` at ``xy : (K, 2)``: (4.12, 4.13) in the cell holding each point.

        A point outside the lattice takes the value at the nearest lattice
        point of the border (coordinates clamped to the lattice's bounds).
        Infinite coordinates clamp like any other; NaN raises ``ValueError``
        (it would survive the clamping and make the cell index undefined).
        """
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        if np.isnan(xy).any():
            raise ValueError("GridSize: points must not have NaN coordinates")
        out = np.empty(len(xy))
        _bilinear_kernel(self.origin[0], self.origin[1], self.spacing[0], self.spacing[1],
                         self.values, xy, out)
        return out


def uniform_size(h):
    """A constant size field."""
    h = float(h)
    if not np.isfinite(h) or h <= 0:
        raise ValueError(f"size: must be finite and positive, got {h}")

    def size(xy):
        return np.full(np.asarray(xy).reshape(-1, 2).shape[0], h)

    size.constant = h
    return size


def as_size_function(size):
    """A checked size function from a number, a :class:`GridSize` or a callable.

    The returned function raises ``ValueError`` when the field gives a
    non-finite or non-positive size, or the wrong shape.
    """
    if np.isscalar(size):
        return uniform_size(size)
    if not callable(size):
        raise ValueError(f"size: expected a number, a GridSize or a callable, got {type(size).__name__}")

    def checked(xy):
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        v = np.asarray(size(xy), dtype=np.float64).reshape(-1)
        if v.shape[0] != xy.shape[0]:
            raise ValueError(f"size function returned {v.shape[0]} values for {xy.shape[0]} points")
        if not np.all(np.isfinite(v)) or (v.size and v.min() <= 0):
            raise ValueError("size function returned non-finite or non-positive sizes")
        return v

    checked.constant = getattr(size, "constant", None)
    return checked
