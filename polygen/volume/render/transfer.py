"""Colour and opacity transfer functions (piecewise-linear tables) and the lighting of (7.2)."""

from __future__ import annotations

import dataclasses

import numpy as np

from polygen import _jit
from polygen.volume.render.view import RenderError

__all__ = ["TransferFunction", "Lighting", "OPTICAL_MODELS", "check_tf", "check_optical_model"]

#: What a table opacity ``a`` means along a ray, and so what a renderer integrates (``optical_model=``):
#:
#: ``"opacity"`` (polygen's default): ``a`` is the opacity of a slab ``unit`` thick, so the attenuation
#: coefficient is ``tau = -ln(1 - a) / unit`` and a sample ``step`` apart gets ``1 - (1 - a) ** (step / unit)``
#: (corrected at the knots, interpolated between them). A slab ``unit`` thick of constant ``a`` lets
#: ``1 - a`` through whatever the spacing.
#:
#: ``"attenuation"`` (VTK's): ``a / unit`` *is* the attenuation coefficient, interpolated linearly in the
#: scalar, and a sample gets ``1 - exp(-a(S) * step / unit)``: what VTK's unstructured-grid mappers
#: integrate (``vtkUnstructuredGridPreIntegration`` and ``vtkUnstructuredGridPartialPreIntegration``
#: divide the opacity table by ``ScalarOpacityUnitDistance`` and integrate emission and absorption
#: exactly over each cell's segment). A slab ``unit`` thick of constant ``a`` lets ``exp(-a)`` through,
#: more than ``1 - a``: the same table renders dimmer, most where ``a`` is large (0.9 per unit lets 0.41
#: through, not 0.1).
#:
#: Both composite ``sum c_k a_k prod_{j<k} (1 - a_j)`` over the samples (7.1), colours not pre-multiplied.
OPTICAL_MODELS = ("opacity", "attenuation")


def check_optical_model(model):
    """``model`` if it is one of :data:`OPTICAL_MODELS`; :class:`RenderError` otherwise."""
    if model not in OPTICAL_MODELS:
        raise RenderError(f"optical_model must be one of {OPTICAL_MODELS}; got {model!r}")
    return model


@dataclasses.dataclass(frozen=True, eq=False)
class TransferFunction:
    """Reflectance ``r(S)`` and opacity ``a(S)`` of 7.8.1 as piecewise-linear tables over the scalar.

    Parameters
    ----------
    knots : (K,) float
        Scalar values, strictly ascending; outside them the end values hold.
    rgb : (K, 3) float
        Reflectance (colour) at each knot, in [0, 1].
    opacity : (K,) float
        Opacity at each knot, in [0, 1], of a stretch of ray ``unit`` long
        (the renderers' ``optical_model`` says how it is integrated:
        :data:`OPTICAL_MODELS`).
    unit : float, keyword-only
        The ray length the opacities are for. With the default optical
        model a sample spacing ``step`` gets ``1 - (1 - a) ** (step / unit)``,
        so an image does not darken or brighten when the number of samples
        (or shells) changes.

    Raises
    ------
    RenderError
        Shapes that disagree, knots not strictly ascending, a negative
        opacity (or above 1), colours outside [0, 1], ``unit <= 0``.
    """

    knots: np.ndarray
    rgb: np.ndarray
    opacity: np.ndarray
    unit: float = 1.0

    def __post_init__(self):
        knots = np.array(self.knots, dtype=np.float64, ndmin=1)
        rgb = np.array(self.rgb, dtype=np.float64, ndmin=2)
        op = np.array(self.opacity, dtype=np.float64, ndmin=1)
        if knots.ndim != 1 or knots.size < 1:
            raise RenderError(f"knots must be a 1-D array of at least one value; got shape {knots.shape}")
        k = knots.size
        if rgb.shape != (k, 3):
            raise RenderError(f"rgb must have shape ({k}, 3), one colour per knot; got {rgb.shape}")
        if op.shape != (k,):
            raise RenderError(f"opacity must have shape ({k},), one per knot; got {op.shape}")
        for name, a in (("knots", knots), ("rgb", rgb), ("opacity", op)):
            if not np.all(np.isfinite(a)):
                raise RenderError(f"{name} must be finite")
        if np.any(np.diff(knots) <= 0):
            raise RenderError(f"knots must be strictly ascending; got {knots.tolist()}")
        if np.any(op < 0):
            raise RenderError(f"opacity must be >= 0; got {op[op < 0][:5].tolist()} at knots "
                              f"{knots[op < 0][:5].tolist()}")
        if np.any(op > 1):
            raise RenderError(f"opacity must be <= 1; got {op[op > 1][:5].tolist()}")
        if np.any(rgb < 0) or np.any(rgb > 1):
            raise RenderError("rgb must lie in [0, 1]")
        if not (np.isfinite(self.unit) and self.unit > 0):
            raise RenderError(f"unit must be a length > 0; got {self.unit!r}")
        for name, a in (("knots", knots), ("rgb", rgb), ("opacity", op)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "unit", float(self.unit))

    @classmethod
    def ramp(cls, lo, hi, *, cmap="viridis", opacity=(0.0, 0.5), n=16, unit=1.0):
        """A colour map and a linear opacity ramp from ``opacity[0]`` at ``lo`` to ``opacity[1]`` at ``hi``."""
        import matplotlib

        if not hi > lo:
            raise RenderError(f"a ramp needs hi > lo; got {lo!r}, {hi!r}")
        x = np.linspace(0.0, 1.0, n)
        rgb = matplotlib.colormaps[cmap](x)[:, :3]
        return cls(lo + x * (hi - lo), rgb, opacity[0] + x * (opacity[1] - opacity[0]), unit=unit)

    def corrected(self, step):
        """(K,) opacities of samples ``step`` apart: ``1 - (1 - a) ** (step / unit)``."""
        if not (np.isfinite(step) and step > 0):
            raise RenderError(f"step must be a length > 0; got {step!r}")
        with np.errstate(divide="ignore"):
            return 1.0 - (1.0 - self.opacity) ** (step / self.unit)

    def sample_table(self, step, optical_model="opacity"):
        """``(alpha (K,), tau)`` for the kernels: what each sample ``step`` apart gets (:data:`OPTICAL_MODELS`).

        ``"opacity"``: the corrected opacities and ``tau = 0``; ``"attenuation"``: the table's
        opacities (attenuation per ``unit``) and ``tau = step / unit``.
        """
        # read-only both (the table's own opacities are): one build of the kernels for either model
        if check_optical_model(optical_model) == "opacity":
            return _jit.read_only(np.ascontiguousarray(self.corrected(step))), 0.0
        return _jit.read_only(np.ascontiguousarray(self.opacity)), float(step) / self.unit

    def __call__(self, s):
        """``(rgb (..., 3), opacity (...))`` of the table at scalar values ``s``."""
        s = np.asarray(s, np.float64)
        rgb = np.stack([np.interp(s, self.knots, self.rgb[:, c]) for c in range(3)], axis=-1)
        return rgb, np.interp(s, self.knots, self.opacity)


@dataclasses.dataclass(frozen=True)
class Lighting:
    """The light of (7.2): emission E, light energy l and direction L.

    The colour of a sample is ``c = E + (G . L) l r``.

    Parameters
    ----------
    emission : float or (3,) float
        ``E``, added to every sample's colour.
    energy : float
        ``l``, the light's energy.
    direction : (3,) float or None
        ``L`` (towards the light); ``None`` is a headlight, ``L`` = minus the
        ray direction, which both renderers use per pixel.
    shade : bool
        ``False`` gives ``c = r`` (no gradient term): the emission-absorption
        model of renderers that do not shade, such as VTK's unstructured-grid
        ray caster.

    Notes
    -----
    ``G . L`` is taken as ``|G . L| / |G|``: the gradient's sign says only
    which way the scalar grows, so a surface of particles is lit from either
    side (two-sided lighting).
    """

    emission: object = 0.15
    energy: float = 0.85
    direction: object = None
    shade: bool = True

    def arrays(self):
        e = np.broadcast_to(np.asarray(self.emission, np.float64), (3,)).copy()
        if not np.all(np.isfinite(e)) or not np.isfinite(self.energy):
            raise RenderError("emission and energy must be finite")
        if self.direction is None:
            light, head = np.zeros(3), True
        else:
            light = np.asarray(self.direction, np.float64)
            if light.shape != (3,) or not np.linalg.norm(light) > 0 or not np.all(np.isfinite(light)):
                raise RenderError(f"light direction must be a non-zero 3-vector; got {self.direction!r}")
            light, head = light / np.linalg.norm(light), False
        return e, float(self.energy), light, head, bool(self.shade)


def check_tf(tf):
    """``tf`` if it is a :class:`TransferFunction`; :class:`RenderError` otherwise."""
    if not isinstance(tf, TransferFunction):
        raise RenderError(f"tf must be a TransferFunction; got {type(tf).__name__}")
    return tf
