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

The one seed interface over a volume (:mod:`polygen.volume.seeds.source`)
serves these structures, the extrema graph and the thinning skeleton alike:

>>> src = seed_source(vol, "fem", "span-space")          # doctest: +SKIP
>>> found = src.query(0.5); found.cells, found.n_tested  # doctest: +SKIP
"""

from polygen.volume.seeds.base import (
    METHODS,
    ActiveCellSearch,
    IntervalError,
    QueryResult,
    cell_ranges,
    check_intervals,
    check_value,
    get,
    register,
)

from polygen.volume.seeds.source import Seeds, SeedSource, seed_source

# each structure registers itself at the bottom of its module; imported in the order of Table 5.2
from polygen.volume.seeds.full_scan import FullScan  # isort: skip
from polygen.volume.seeds.sorted_lists import SortedLists  # isort: skip
from polygen.volume.seeds.span_filter import SpanFilter  # isort: skip
from polygen.volume.seeds.span_space import SpanSpace  # isort: skip
from polygen.volume.seeds.issue_lattice import IssueLattice  # isort: skip
from polygen.volume.seeds.interval_tree import IntervalTree  # isort: skip

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
    "Seeds",
    "SeedSource",
    "seed_source",
]
