"""The registries of isosurface methods and seed sources, filled where each is defined.

A module that defines a method registers it at its bottom (as meshio's
formats do): ``@register_method`` on an
:class:`~polygen.volume.methods.IsosurfaceMethod` subclass, or
``register_seed_source(name, build)`` for a seed source (where a surface
starts: ``build(vol, field, **params) -> (structure, query)`` with
``query(value) -> (cells, n_tested, seconds)``). The registry never lists or
probes its plugins: importing :mod:`polygen.volume` imports every module that
registers something, so the registries are complete once the package is
imported.

This module imports nothing of ours, so that the mesh
(:meth:`UnstructuredVolume.isosurface`) can look a method up without
importing the methods (which import the mesh's layer and above).
"""

from __future__ import annotations

from polygen.volume.errors import VolumeError

__all__ = [
    "METHODS",
    "SEED_SOURCES",
    "DEFAULT_METHOD",
    "DEFAULT_SEED_SOURCE",
    "register_method",
    "get_method",
    "method_names",
    "register_seed_source",
    "get_seed_source",
    "seed_source_names",
]

#: method name -> IsosurfaceMethod subclass, in the order they were registered
METHODS: dict = {}
#: seed-source name -> ``build(vol, field, **params) -> (structure, query)``
SEED_SOURCES: dict = {}

#: the method ``UnstructuredVolume.isosurface`` and the CLI use first: the fastest one measured
#: (benchmarks/results/interactive.md: the active-cell scan, the crossed cells as prefixes of
#: span-space rows scanned by every core, against the cell-edge-centred construction with the edge table
#: (``edge-centred-table``, the fastest of the 2001 paper's four): on 2M a 20-value sweep in about 2/3 of
#: its time, the largest surface in about 2/3, prepared in 0.6 s instead of 0.9 s with 2/3 of its memory)
DEFAULT_METHOD = "active-scan"
#: the seed source of the edge-centred method when none is named (chapter 7's skeleton)
DEFAULT_SEED_SOURCE = "thinning"


def register_method(cls):
    """Class decorator: make an isosurface method available under its ``name``."""
    name = getattr(cls, "name", "")
    if not name or not isinstance(name, str):
        raise ValueError(f"a method needs a unique name; got {name!r}")
    if METHODS.get(name, cls) is not cls:
        raise ValueError(f"a method needs a unique name; {name!r} is already {METHODS[name].__name__}")
    METHODS[name] = cls
    return cls


def get_method(name):
    """The method class registered as ``name``; :class:`VolumeError` (a ``ValueError``) naming the known ones
    otherwise."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise VolumeError(f"unknown isosurface method {name!r}; the methods are {list(METHODS)}") from None


def method_names():
    """Registered method names, the default first."""
    return sorted(METHODS, key=lambda n: n != DEFAULT_METHOD)


def register_seed_source(name, build):
    """Register ``build(vol, field, **params) -> (structure, query)`` as the seed source ``name``."""
    if not name or not isinstance(name, str) or not callable(build):
        raise ValueError(f"a seed source needs a name and a callable builder; got {name!r}, {build!r}")
    if SEED_SOURCES.get(name, build) is not build:
        raise ValueError(f"the seed source {name!r} is already registered")
    SEED_SOURCES[name] = build
    return build


def get_seed_source(name):
    """The builder registered as seed source ``name`` (``KeyError`` if there is none)."""
    return SEED_SOURCES[name]


def seed_source_names():
    """Registered seed-source names, in the order they were registered."""
    return list(SEED_SOURCES)
