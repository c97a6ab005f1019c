"""The common interface of the active-cell search structures (thesis 5.4.1, Table 5.2).

Every structure here sees a volume only through one scalar interval per
cell, ``[S_min, S_max]`` = the smallest and largest node value of the cell
(:func:`cell_ranges`). A cell is *active* for an isovalue ``C`` when
``S_min <= C <= S_max``; these are the cells the marching step must test
(a cell whose interval only touches ``C`` at an end may still yield no
triangle, but it cannot be skipped without looking at its nodes).

A structure is built once (:meth:`ActiveCellSearch.build`, which records
``preprocess_s``) and then answers any number of queries. A query returns
a :class:`QueryResult`:

``cells``
    the candidate cells the structure hands to the marching step: every
    active cell, and for structures that cannot exclude some inactive cells
    without looking at them (the span filter's buckets), those too;
``n_tested``
    how many cells the search touched: cells whose interval was compared
    with ``C`` in a linear scan, plus cells handed over wholesale without a
    comparison (a k-d subtree or lattice element known to be inside the
    query region; each of those is tested by the marching step anyway).
    Binary-search probes are not counted (they are the ``log`` terms of
    Table 5.2). Always ``n_tested >= len(cells) >= n_hits``;
``n_hits``
    the number of active cells.

``n_tested`` is what the "cells tested" columns of thesis Tables 6.5 and
7.5 count for the seed search; ``n_hits`` is the "intersected" column of
Table 6.5 up to cells that only touch ``C``.
"""

import abc
import functools
import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from polygen import _jit
from polygen._jit import njit, prange
from polygen.volume import registry as _registry
from polygen.volume._cells import index_dtype
from polygen.volume.seeds.source import Seeds
from polygen.volume.surface import volume_arrays

__all__ = [
    "IntervalError",
    "QueryResult",
    "ActiveCellSearch",
    "cell_ranges",
    "check_intervals",
    "check_value",
    "METHODS",
    "register",
    "get",
]


class IntervalError(ValueError):
    """Cell intervals or an isovalue that no search structure can use (the message says which)."""


def _examples(idx, n=5):
    idx = np.asarray(idx)
    more = f" (and {idx.size - n} more)" if idx.size > n else ""
    return ", ".join(str(int(i)) for i in idx[:n]) + more


def check_intervals(cmin, cmax):
    """Validate per-cell intervals and return them as contiguous ``float64`` copies.

    Parameters
    ----------
    cmin, cmax : (M,) array_like of float
        Smallest and largest node value of each cell.

    Returns
    -------
    cmin, cmax : (M,) float64
        Contiguous copies (later changes to the caller's arrays do not
        corrupt a structure).

    Raises
    ------
    IntervalError
        When the arrays are not 1-D, differ in length, hold NaN or infinite
        values, or ``cmin > cmax`` for some cell; the message names the cells.
    """
    try:
        lo = np.array(cmin, dtype=np.float64, copy=True)
        hi = np.array(cmax, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as exc:
        raise IntervalError(f"cell intervals must be real numbers: {exc}") from None
    if lo.ndim != 1 or hi.ndim != 1:
        raise IntervalError(f"cmin and cmax must be 1-D (M,) arrays; got shapes {lo.shape} and {hi.shape}")
    if lo.shape != hi.shape:
        raise IntervalError(f"cmin and cmax must have the same length; got {lo.size} and {hi.size}")
    for name, a in (("cmin", lo), ("cmax", hi)):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            kind = "NaN" if np.isnan(a[bad[0]]) else "infinite"
            raise IntervalError(
                f"{name} must be finite; {bad.size} cell(s) are not, first {kind} at cell(s) {_examples(bad)}"
            )
    bad = np.flatnonzero(lo > hi)
    if bad.size:
        i = int(bad[0])
        raise IntervalError(
            f"cmin > cmax for {bad.size} cell(s): cells {_examples(bad)}; "
            f"e.g. cell {i} has cmin={float(lo[i])!r} > cmax={float(hi[i])!r}"
        )
    return np.ascontiguousarray(lo), np.ascontiguousarray(hi)


def check_value(value):
    """Return an isovalue as a Python ``float``; NaN or non-scalars raise :class:`IntervalError`.

    Infinite values are accepted (no finite interval contains them).
    """
    if np.ndim(value) != 0:
        raise IntervalError(f"the isovalue must be a scalar; got an array of shape {np.shape(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise IntervalError(f"the isovalue must be a real number; got {value!r}") from None
    if np.isnan(v):
        raise IntervalError("the isovalue is NaN")
    return v


@dataclass(frozen=True)
class QueryResult:
    """One query of an :class:`ActiveCellSearch`.

    Attributes
    ----------
    value : float
        The isovalue ``C``.
    cells : (K,) int64
        Candidate cells; a superset of the active cells (see the module docstring).
    n_tested : int
        Cells the search touched (``>= K``).
    n_hits : int
        Active cells, those with ``cmin <= C <= cmax`` (``<= K``).
    """

    value: float
    cells: np.ndarray
    n_tested: int
    n_hits: int


def _active_query(structure, value):
    """``query(value) -> Seeds`` of an :class:`ActiveCellSearch` (:meth:`ActiveCellSearch.seed_source`)."""
    t0 = time.perf_counter()
    found = structure.query(value)
    return Seeds(found.value, found.cells, found.n_tested, time.perf_counter() - t0, found)


class ActiveCellSearch(abc.ABC):
    """A structure over per-cell intervals that finds the cells an isosurface may cross.

    Subclasses set ``name`` (the registry name), implement ``_build`` (a
    classmethod that gets validated arrays and keyword parameters and returns
    an instance) and ``_query`` (returns ``(cells, n_tested, n_hits)``).
    A structure keeps one output buffer of ``M`` cells, so one instance must
    not be queried from several threads at once.

    Attributes
    ----------
    cmin, cmax : (M,) float64
        The intervals the structure was built on.
    preprocess_s : float
        Wall time of the build, validation and copying excluded.
    """

    name: ClassVar[str] = ""
    #: whether ``query`` returns its cells in ascending id order (else the order of the structure)
    cells_in_order: ClassVar[bool] = False

    def __init__(self, cmin, cmax):
        self.cmin = cmin
        self.cmax = cmax
        self.preprocess_s = 0.0
        self._out = _jit.scratch(cmin.shape[0], dtype=np.int64)

    @property
    def n_cells(self) -> int:
        """Number of cells ``M``."""
        return int(self.cmin.shape[0])

    @classmethod
    def build(cls, cmin, cmax, **params) -> "ActiveCellSearch":
        """Build the structure over the intervals ``[cmin[i], cmax[i]]``.

        Parameters
        ----------
        cmin, cmax : (M,) float64
            Per-cell smallest and largest node value (:func:`cell_ranges`).
        **params
            Keyword-only tuning parameters of the method.

        Raises
        ------
        IntervalError
            On NaN or infinite values, ``cmin > cmax``, or different lengths.
        """
        lo, hi = check_intervals(cmin, cmax)
        t0 = time.perf_counter()
        obj = cls._build(lo, hi, **params)
        obj.preprocess_s = time.perf_counter() - t0
        return obj

    @classmethod
    @abc.abstractmethod
    def _build(cls, cmin, cmax, **params) -> "ActiveCellSearch":
        """Build from validated contiguous float64 arrays."""

    @abc.abstractmethod
    def _query(self, value: float):
        """Return ``(cells (K,) int64, n_tested, n_hits)`` for a checked value."""

    def query(self, value) -> QueryResult:
        """Candidate cells for the isovalue ``value`` and the search's counters.

        Parameters
        ----------
        value : float
            The isovalue ``C``; values outside the data range give no cells.

        Returns
        -------
        QueryResult
        """
        v = check_value(value)
        cells, n_tested, n_hits = self._query(v)
        return QueryResult(value=v, cells=cells, n_tested=int(n_tested), n_hits=int(n_hits))

    @classmethod
    def seed_source(cls, vol, field=None, **params):
        """The seed interface on a volume: build over its cells' ranges, then query seeds by value.

        Parameters
        ----------
        vol : UnstructuredVolume
        field : str or (N,) float64, optional
        **params
            Keyword-only tuning of the structure.

        Returns
        -------
        structure : ActiveCellSearch
        query : callable
            ``query(value) -> Seeds`` (:mod:`polygen.volume.seeds.source`).
        """
        _, cells, s, _ = volume_arrays(vol, field)
        cmin, cmax = cell_ranges(cells, s)
        structure = cls.build(cmin, cmax, **params)
        # a partial of a module function, not a closure: a prepared method holding it pickles
        return structure, functools.partial(_active_query, structure)

    def active(self, value) -> np.ndarray:
        """Exactly the cells with ``cmin <= value <= cmax``, sorted.

        Returns
        -------
        (K,) int64
        """
        r = self.query(value)
        c = r.cells
        keep = (self.cmin[c] <= r.value) & (self.cmax[c] >= r.value)
        return np.sort(c[keep])

    @property
    def nbytes(self) -> int:
        """Bytes held by the structure's own arrays (intervals and output buffer excluded)."""
        skip = {"cmin", "cmax", "_out"}
        return int(sum(a.nbytes for k, a in vars(self).items() if isinstance(a, np.ndarray) and k not in skip))

    def __repr__(self):
        return f"<{type(self).__name__} {self.name!r}: {self.n_cells} cells, preprocess {self.preprocess_s:.3g} s>"


@njit(parallel=True)
def _cell_ranges(cells, scalars, cmin, cmax):
    for c in prange(cells.shape[0]):
        lo = scalars[cells[c, 0]]
        hi = lo
        for j in range(1, cells.shape[1]):
            v = scalars[cells[c, j]]
            if v < lo:
                lo = v
            elif v > hi:
                hi = v
        cmin[c] = lo
        cmax[c] = hi


def cell_ranges(cells, scalars):
    """Per-cell ``S_min`` and ``S_max``: the extreme node values of each cell (5.4.1).

    Parameters
    ----------
    cells : (M, k) integer
        Node indices of each cell (k = 4 for tetrahedra, 8 for hexahedra); read as int32 (int64 for
        2**31 nodes or more).
    scalars : (N,) float64
        Node values; must be finite.

    Returns
    -------
    cmin, cmax : (M,) float64

    Raises
    ------
    IntervalError
        On a wrong shape, a node index outside ``[0, N)`` or a non-finite value.
    """
    cells = np.asarray(cells)
    s = np.ascontiguousarray(scalars, dtype=np.float64)
    if cells.ndim != 2 or cells.shape[1] < 1:
        raise IntervalError(f"cells must be an (M, k) array with k >= 1; got shape {cells.shape}")
    if cells.size and not np.issubdtype(cells.dtype, np.integer):
        raise IntervalError(f"cells must hold integer node indices; got dtype {cells.dtype}")
    if s.ndim != 1:
        raise IntervalError(f"scalars must be a 1-D (N,) array; got shape {s.shape}")
    if cells.size and (cells.min() < 0 or cells.max() >= s.size):
        bad = np.flatnonzero(((cells < 0) | (cells >= s.size)).any(axis=1))
        raise IntervalError(
            f"{bad.size} cell(s) refer to nodes outside [0, {s.size}): cells {_examples(bad)}"
        )
    # checked before narrowing; a volume's cells pass through uncopied
    cells = np.ascontiguousarray(cells, dtype=index_dtype(s.size))
    bad = np.flatnonzero(~np.isfinite(s))
    if bad.size:
        raise IntervalError(f"scalars must be finite; {bad.size} node(s) are not: nodes {_examples(bad)}")
    m = cells.shape[0]
    cmin = _jit.scratch(m, dtype=np.float64)
    cmax = _jit.scratch(m, dtype=np.float64)
    if m:
        _cell_ranges(cells, s, cmin, cmax)
    return cmin, cmax


#: registry name -> class, in the order of Table 5.2
METHODS = {}


def register(cls):
    """Add an :class:`ActiveCellSearch` subclass to :data:`METHODS` under ``cls.name``.

    It is registered as a seed source of :mod:`polygen.volume.registry` too
    (:meth:`ActiveCellSearch.seed_source`). Each structure's module calls
    this at its bottom.
    """
    if not (isinstance(cls, type) and issubclass(cls, ActiveCellSearch)) or not cls.name:
        raise ValueError(f"{cls!r} is not a named ActiveCellSearch subclass")
    if METHODS.get(cls.name, cls) is not cls:
        raise ValueError(f"the method name {cls.name!r} is already registered by {METHODS[cls.name].__name__}")
    if cls.name not in METHODS:
        _registry.register_seed_source(cls.name, cls.seed_source)
    METHODS[cls.name] = cls
    return cls


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
