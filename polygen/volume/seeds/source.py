"""The one seed interface: where an isosurface starts, whatever finds it.

A *seed source* is built once on a volume and a field and then answers, for
any isovalue, the cells to start the construction from::

    src = seed_source(vol, "fem", "span-space")     # build(vol, field, **params), timed
    found = src.query(0.5)                          # -> Seeds
    found.cells, found.n_tested, found.seconds      # seeds, N_cg, search time

The same interface serves the active-cell searches of Table 5.2 (full scan,
sorted lists, span filter, span space, ISSUE, interval tree: this package),
the extrema graph (chapter 6) and the volume-thinning skeleton (chapter 7).
Each source registers its builder where it is defined, with
:func:`polygen.volume.registry.register_seed_source`; a builder is
``build(vol, field, **params) -> (structure, query)`` with
``query(value) -> Seeds``. An isosurface method is a seed source x a
construction (:mod:`polygen.volume.methods`).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from polygen.volume import registry as _registry
from polygen.volume.surface import IsoSurfaceError

__all__ = ["Seeds", "SeedSource", "seed_source"]


@dataclasses.dataclass(frozen=True, eq=False)
class Seeds:
    """What a seed source answers for one isovalue.

    It also unpacks as ``cells, n_tested, seconds`` (and ``seeds[0]`` is the
    cells), as the seed sources of :mod:`polygen.volume.edge_centred` answered.

    Attributes
    ----------
    value : float
    cells : (K,) int64
        Cells to start from (the construction tests each and skips those the surface misses).
    n_tested : int
        Cells the search tested to find them (N_cg of Tables 6.5 and 7.5).
    seconds : float
        Wall time of the search.
    found : object
        The source's own answer, with its own counters (a
        :class:`~polygen.volume.seeds.QueryResult`, a
        :class:`~polygen.volume.extrema_graph.GraphSeeds` or a
        :class:`~polygen.volume.thinning.SkeletonSeeds`).
    """

    value: float
    cells: np.ndarray
    n_tested: int
    seconds: float
    found: object = None

    # the (cells, n_tested, seconds) triple that edge_centred's seed sources answered before
    def __iter__(self):
        return iter((self.cells, self.n_tested, self.seconds))

    def __getitem__(self, i):
        return (self.cells, self.n_tested, self.seconds)[i]

    def __len__(self):
        return 3


@dataclasses.dataclass(eq=False)
class SeedSource:
    """A seed source built on one volume and field.

    Attributes
    ----------
    name : str
        Its registered name (:func:`polygen.volume.registry.seed_source_names`).
    structure : object
        What was built (an ``ActiveCellSearch``, an ``ExtremaGraph``, a ``Skeleton``).
    preprocess_s : float
        Seconds to build it.
    sort : bool
        Whether its cells come in an order other than ascending cell id (a
        tree's), so that a construction reading the volume in seed order is
        better served sorted.
    """

    name: str
    structure: object
    preprocess_s: float
    _query: object = dataclasses.field(repr=False, default=None)
    sort: bool = False

    def query(self, value) -> Seeds:
        """The seeds of the isosurface ``S = value``."""
        return self._query(value)


def seed_source(vol, field=None, name="auto", **params):
    """Build the seed source ``name`` on ``vol`` (timed as its ``preprocess_s``).

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str or (N,) float64, optional
    name : str
        A registered seed source (``"thinning"``, ``"extrema-graph"``,
        ``"span-space"``, ...), or ``"auto"``: volume thinning
        (:data:`polygen.volume.registry.DEFAULT_SEED_SOURCE`).
    **params
        Tuning of the source, keyword-only (e.g. ``n_buckets`` for thinning).

    Returns
    -------
    SeedSource

    Raises
    ------
    IsoSurfaceError
        For an unknown name; the message lists the registered ones.
    """
    if name == "auto":
        name = _registry.DEFAULT_SEED_SOURCE
    try:
        builder = _registry.get_seed_source(name)
    except (KeyError, TypeError):
        raise IsoSurfaceError(f"unknown seed source {name!r}; the sources are "
                              f"{['auto', *_registry.seed_source_names()]}") from None
    t0 = time.perf_counter()
    structure, query = builder(vol, field, **params)
    return SeedSource(name=name, structure=structure, preprocess_s=time.perf_counter() - t0, _query=query,
                      sort=not getattr(structure, "cells_in_order", True))
