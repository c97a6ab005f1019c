"""Where isosurface extraction starts: active-cell search structures (thesis 5.4.1, Table 5.2).

Each structure is built once over the per-cell intervals ``[S_min, S_max]``
(:func:`cell_ranges`) and then, for an isovalue ``C``, returns the cells to
test and the counters of Tables 6.5 and 7.5 (:class:`QueryResult`).

======================  =======================================  ==============  =====================
name                    method                                   preprocessing   query
======================  =======================================  ==============  =====================
``full-scan``           test every cell                          --              O(n)
``sorted-lists``        Giles and Haimes, sorted min/max lists   O(n log n)      O(n)
``span-filter``         Gallagher, span filtering (classes)      O(n)            O(n)
``span-space``          Livnat et al., span-space k-d tree       O(n log n)      O(sqrt(n) + k)
``issue-lattice``       Shen et al., ISSUE L x L lattice         O(n log n)      O(log(n/L) + sqrt(n)/L + k)
``interval-tree``       Cignoni et al., interval tree            O(n log n)      O(log n + k)
======================  =======================================  ==============  =====================

Example
-------
>>> cmin, cmax = cell_ranges(cells, scalars)            # doctest: +SKIP
>>> search = get("span-space").build(cmin, cmax)        # doctest: +SKIP
>>> r = search.query(0.5); r.cells, r.n_tested, r.n_hits  # doctest: +SKIP
"""

from polygen.volume.seeds.base import (
    ActiveCellSearch,
    IntervalError,
    QueryResult,
    cell_ranges,
    check_intervals,
    check_value,
)
from polygen.volume.seeds.full_scan import FullScan
from polygen.volume.seeds.interval_tree import IntervalTree
from polygen.volume.seeds.issue_lattice import IssueLattice
from polygen.volume.seeds.sorted_lists import SortedLists
from polygen.volume.seeds.span_filter import SpanFilter
from polygen.volume.seeds.span_space import SpanSpace

__all__ = [
    "ActiveCellSearch",
    "IntervalError",
    "QueryResult",
    "cell_ranges",
    "check_intervals",
    "check_value",
    "FullScan",
    "SortedLists",
    "SpanFilter",
    "SpanSpace",
    "IssueLattice",
    "IntervalTree",
    "METHODS",
    "get",
    "register",
]

#: registry name -> class, in the order of Table 5.2
METHODS = {}


def register(cls):
    """Add an :class:`ActiveCellSearch` subclass to :data:`METHODS` under ``cls.name``."""
    if not (isinstance(cls, type) and issubclass(cls, ActiveCellSearch)) or not cls.name:
        raise ValueError(f"{cls!r} is not a named ActiveCellSearch subclass")
    if METHODS.get(cls.name, cls) is not cls:
        raise ValueError(f"the method name {cls.name!r} is already registered by {METHODS[cls.name].__name__}")
    METHODS[cls.name] = cls
    return cls


for _cls in (FullScan, SortedLists, SpanFilter, SpanSpace, IssueLattice, IntervalTree):
    register(_cls)


def get(name):
    """The search class registered as ``name`` (e.g. ``"sorted-lists"``).

    Raises
    ------
    IntervalError
        For an unknown name; the message lists the known ones.
    """
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise IntervalError(f"unknown active-cell search {name!r}; known: {', '.join(METHODS)}") from None
