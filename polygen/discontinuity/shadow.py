"""Shadow polyhedra (thesis 3.3.1, Defs 3.2-3.4) and their sections on receivers.

A light and a convex occluder bound two convex, half-infinite polyhedra
(Def. 3.2): the *umbra* polyhedron, inside which the occluder hides the
whole light, and the *penumbra* polyhedron, inside which it hides some of
it.  A point or a parallel light casts one (umbra = penumbra, D0
boundaries; Theorem 3.1).

The interface with the loop code of :mod:`polygen.discontinuity` is the
:class:`ShadowSection`: for one receiver polygon, one light and one convex
occluder, the two polyhedra cut by the receiver's plane, as convex polygons
in the receiver's own (u, v) frame (:meth:`Polygon.to_2d`, the frame of
:func:`~polygen.radiosity.layout.polygon_layout`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ShadowError", "ShadowSection", "shadow_sections", "scene_sections"]


class ShadowError(ValueError):
    """A light or occluder that shadow polyhedra cannot be built from (names the polygon)."""


@dataclass(frozen=True, eq=False)
class ShadowSection:
    """The umbra and penumbra polyhedra of one (light, occluder) pair cut by one receiver's plane.

    Attributes
    ----------
    light : int
        Index of the light: ``0 .. A-1`` are the scene's area lights in
        ``scene.area_lights`` order, then ``scene.lights`` (point and
        parallel lights) in their order.
    occluder : int
        Index of the occluding polygon in ``scene.polygons``.
    receiver : int
        Index of the receiving polygon in ``scene.polygons``.
    umbra : (k, 2) float64
        Convex polygon, counter-clockwise in the receiver's (u, v) frame;
        ``(0, 2)`` when the umbra polyhedron misses the receiver's plane.
    penumbra : (k, 2) float64
        Convex polygon, counter-clockwise, containing ``umbra``; both are
        clipped to the receiver's 2-D bounding box enlarged by ``margin``
        (so a boundary of either lying on that box is not a shadow edge).
    side : int
        +1 when the light reaches the receiver's front face, -1 its back
        face (a two-sided receiver).
    piece : int
        Which convex piece of the occluder (``Polygon.convex_pieces``); 0
        for a convex occluder.
    kind : str
        ``"area"`` (D1 boundaries), ``"point"`` or ``"parallel"`` (D0:
        umbra and penumbra are the same polygon).
    """

    light: int
    occluder: int
    receiver: int
    umbra: np.ndarray
    penumbra: np.ndarray
    side: int = 1
    piece: int = 0
    kind: str = "area"


def shadow_sections(scene, receiver_index, **kwargs):
    """The :class:`ShadowSection` list of one receiver (stub: implementation follows)."""
    raise NotImplementedError


def scene_sections(scene, **kwargs):
    """``{receiver index: [ShadowSection, ...]}`` for the whole scene (stub)."""
    raise NotImplementedError
