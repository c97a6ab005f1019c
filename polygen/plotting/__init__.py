"""Figures for the notebooks: pyvista scenes and matplotlib plots, one module per wing.

=======================  ==============================================
``plotting.volume``      chapter 5: volumes, marching cases, isosurfaces
``plotting.extrema``     chapter 6: the extrema graph
``plotting.thinning``    chapter 7: volume thinning
``plotting.render``      chapter 7.8: volume rendering (Figs 7.8, 7.9), VTK's ray caster
``plotting.radiosity``   chapters 2-4: radiosity and 2D meshing
=======================  ==============================================

Nothing in polygen's algorithms imports this package (a test walks the
imports). pyvista and matplotlib are imported inside the functions. Every 3D
function returns a ``pyvista.Plotter`` (call ``.show()`` in a notebook,
``.screenshot(path)`` elsewhere); rendering is off-screen when there is no
display. The helpers every notebook uses (:func:`setup_notebook`,
:func:`table`, ...) and chapter 5's volume figures are importable from the
package itself.
"""

from polygen.plotting._common import (
    ORIGINAL,
    boundary_mesh,
    boundary_surface,
    setup_notebook,
    table,
    with_thesis,
)
from polygen.plotting.volume import (
    plot_boundary_groups,
    plot_cell_and_neighbours,
    plot_isosurfaces,
    plot_volume_kinds,
)

__all__ = [
    "ORIGINAL",
    "setup_notebook",
    "boundary_mesh",
    "boundary_surface",
    "table",
    "with_thesis",
    "plot_boundary_groups",
    "plot_cell_and_neighbours",
    "plot_volume_kinds",
    "plot_isosurfaces",
]
