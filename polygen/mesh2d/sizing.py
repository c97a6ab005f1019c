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
    ny, nx = values.shape
    for k in prange(xy.shape[0]):
        u = (xy[k, 0] - x0) / dx
        v = (xy[k, 1] - y0) / dy
        # points outside the grid take the nearest border value
        u = min(max(u, 0.0), nx - 1.0)
        v = min(max(v, 0.0), ny - 1.0)
        i = min(int(u), nx - 2)
        j = min(int(v), ny - 2)
        s = u - i
        t = v - j
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
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "spacing", s)
        object.__setattr__(self, "values", v)

    @classmethod
    def from_function(cls, fn, bounds, shape):
        """Sample a size function on a lattice covering ``bounds = (xmin, ymin, xmax, ymax)``."""
        xmin, ymin, xmax, ymax = map(float, bounds)
        ny, nx = shape
        x = np.linspace(xmin, xmax, nx)
        y = np.linspace(ymin, ymax, ny)
        X, Y = np.meshgrid(x, y)
        v = np.asarray(fn(np.stack([X.ravel(), Y.ravel()], axis=1)), dtype=np.float64)
        return cls((xmin, ymin), (x[1] - x[0], y[1] - y[0]), v.reshape(ny, nx))

    def __call__(self, xy):
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
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
