"""Simplified discontinuity meshing and the intensity-based bubble mesh combined.

The thesis closes chapter 4 (4.5) with this as future work: mesh along the
discontinuity lines that simplified discontinuity meshing finds (chapter 3,
:func:`~polygen.discontinuity.simplified_discontinuity`), and size the
elements between them by the intensity variation of a first solution
(:func:`~polygen.radiosity.intensity_bubble_mesh`).  Both meshes of the
two-pass loop keep the lines as constrained segments (D0: nodes duplicated
across, D1: shared); the size grid is built per region, from the nodes of
that region only, so that the plate never carries the fine size of a shadow
boundary across a D0 line into the light or the umbra beside it.
"""

from __future__ import annotations

from polygen.discontinuity.simplified import simplified_discontinuity
from polygen.radiosity.intensity import intensity_bubble_mesh
from polygen.radiosity.scene import Scene, SceneError

__all__ = ["combined_bubble_mesh"]


def combined_bubble_mesh(scene, *, size_initial, size_min, size_max, discontinuity=None,
                         **kwargs):
    """The two-pass loop of Fig. 4.3 on a mesh cut by the scene's discontinuity lines.

    Parameters
    ----------
    scene : Scene
    size_initial, size_min, size_max : float, keyword-only
        As :func:`~polygen.radiosity.intensity_bubble_mesh` (patch sizes;
        ``size_max < size_initial < size_min``).
    discontinuity : SimplifiedDiscontinuity or None, keyword-only
        The scene's discontinuity phase; None: computed here.
    **kwargs
        Other keywords of :func:`~polygen.radiosity.intensity_bubble_mesh`
        (``grid``, ``element_levels``, ``seed``, ``solve``, ``first`` ...).

    Returns
    -------
    IntensityMesh
        Its ``parameters["segments"]`` are the lines used; both meshes have
        regions (``element_region``).

    Raises
    ------
    SceneError
        ``scene`` is not a Scene, or ``discontinuity`` is of another scene.
    MeshError
        As :func:`~polygen.radiosity.intensity_bubble_mesh`.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a Scene, got {type(scene).__name__}")
    if discontinuity is None:
        discontinuity = simplified_discontinuity(scene)
    elif discontinuity.scene is not scene:
        raise SceneError("discontinuity was computed for another scene")
    if "segments" in kwargs:
        raise TypeError("combined_bubble_mesh takes its segments from the discontinuity phase")
    return intensity_bubble_mesh(scene, size_initial=size_initial, size_min=size_min,
                                 size_max=size_max, segments=discontinuity.segments, **kwargs)
