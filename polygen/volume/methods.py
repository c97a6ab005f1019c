"""Isosurface extraction methods under one name each, for the CLI and the benchmarks.

A method is built once on a volume and a field (its preprocessing is timed
as ``preprocess_s``) and then extracts one isosurface per call::

    m = methods.get("span-space")(vol, field="fem")
    iso = m.extract(0.5)          # an IsoSurface with counters and t1/t2/t3

``cells_tested`` of the result counts every cell whose intersection with
the surface was examined, by the search structure and by the propagation
together; ``seed_cells_tested`` of the method (after a call) counts the
search alone, the N_cg of Table 6.5.

A method = a seed source x a construction: :class:`SeedsThenPropagate`
takes any seed source of :mod:`polygen.volume.seeds.source` (the one seed
interface) to the propagation of thesis 5.4.2, and
:class:`~polygen.volume.edge_centred.EdgeCentredMethod` to the edge-centred
construction of the 2001 paper. Each registers itself where it is defined
(``@register``: the active-cell searches x propagation here,
``extrema-graph`` and ``thinning`` in their chapters' modules,
``edge-centred`` in :mod:`polygen.volume.edge_centred`); importing
:mod:`polygen.volume` imports them all.
"""

from __future__ import annotations

import abc
import contextlib
import dataclasses
import functools
import threading
import time

import numpy as np

from polygen import _jit
from polygen.volume import registry as _registry
from polygen.volume.isosurface import _scan_unprepared
from polygen.volume.isosurface import extract as _extract
from polygen.volume.propagate import Propagator
from polygen.volume.seeds.source import seed_source as _seed_source
from polygen.volume.surface import IsoSurfaceError, same_surface, volume_arrays
from polygen.volume.surface import check_normals as _check_normals
from polygen.volume.surface import check_threads as _check_threads
from polygen.volume.surface import check_value as _check_value
from polygen.volume.surface import check_values as _check_values

__all__ = ["IsosurfaceMethod", "SeedsThenPropagate", "METHODS", "DEFAULT", "register", "get", "names", "default",
           "Sweep", "sweep"]

#: name -> class, in the order they were registered (the one registry, :mod:`polygen.volume.registry`)
METHODS = _registry.METHODS
#: the method ``UnstructuredVolume.isosurface`` and the CLI use first
DEFAULT = _registry.DEFAULT_METHOD
register = _registry.register_method
get = _registry.get_method
names = _registry.method_names


def default():
    """The name of the default method (:data:`DEFAULT`)."""
    return DEFAULT


@dataclasses.dataclass
class Sweep:
    """Several values extracted by one method, one at a time, and the totals the thesis's tables use.

    Attributes
    ----------
    surfaces : list of IsoSurface
    stats : list of dict
        The method's ``stats`` after each call (empty dicts for methods without).
    query_s : float
        Wall clock of the calls.
    t1 : float
        Sum of the surfaces' t1 (finding the intersected cells).
    seed_cells_tested : int
        Sum of the method's ``seed_cells_tested`` (N_cg for the extrema graph).
    cells_tested, cells_intersected, triangles, vertices : int
        Sums over the surfaces.
    same_as_reference : bool or None
        Every surface has the reference's triangles (None without a reference).
    """

    surfaces: list
    stats: list
    query_s: float
    t1: float
    seed_cells_tested: int
    cells_tested: int
    cells_intersected: int
    triangles: int
    vertices: int
    same_as_reference: bool | None


def sweep(method, values, *, reference=None, normals="mean"):
    """Extract ``values`` one at a time with a prepared ``method`` and add up its counters.

    ``reference``: surfaces of the same values (e.g. the full scan's) that
    each result must equal, triangle for triangle (by vertex keys).
    """
    surfaces, stats = [], []
    query = t1 = 0.0
    seed_tested = 0
    for v in values:
        t0 = time.perf_counter()
        iso = method.extract(v, normals=normals)
        query += time.perf_counter() - t0
        t1 += iso.t1
        seed_tested += method.seed_cells_tested
        surfaces.append(iso)
        stats.append(dict(getattr(method, "stats", {})))
    same = None
    if reference is not None:
        same = len(reference) == len(surfaces) and all(
            same_surface(a, b, geometry=False) for a, b in zip(surfaces, reference))
    return Sweep(surfaces=surfaces, stats=stats, query_s=query, t1=t1, seed_cells_tested=seed_tested,
                 cells_tested=sum(i.cells_tested for i in surfaces),
                 cells_intersected=sum(i.cells_intersected for i in surfaces),
                 triangles=sum(i.n_triangles for i in surfaces), vertices=sum(i.n_vertices for i in surfaces),
                 same_as_reference=same)


def _serialised(fn):
    """``fn`` (an ``extract``) under the method's lock, after checking its field is still the volume's."""

    many = fn.__name__ == "extract_many"

    @functools.wraps(fn)
    def guarded(self, *args, **kwargs):
        if many:  # one rule for every method: the values a sequence of numbers, threads a whole number >= 1
            if args:
                args = (_check_values(args[0]), *args[1:])
            elif "values" in kwargs:
                kwargs["values"] = _check_values(kwargs["values"])
            _check_threads(kwargs.get("threads"))
        with self._lock:
            if not self._as_of:  # inside as_of_field the caller checked the field when its query began
                self._check_field()
            return fn(self, *args, **kwargs)

    guarded._serialised = True
    return guarded


class IsosurfaceMethod(abc.ABC):
    """An isosurface method prepared on one volume and field.

    Threads: a prepared method keeps scratch buffers and counters between
    calls (visit stamps, queues, ``stats``), so its :meth:`extract` and
    :meth:`extract_many` hold a per-method lock (a ``threading.RLock``):
    several threads may share one prepared method and each gets the right
    surface, but their calls run one at a time. For queries side by side,
    prepare one method per thread or use :meth:`extract_many` (the
    edge-centred method runs its values in parallel there). Every subclass's
    ``extract`` and ``extract_many`` get the lock by themselves
    (``__init_subclass__``).

    Pickling and copying: a prepared method pickles and deep-copies with its
    volume (the copy is prepared on the copied field); its lock is not
    carried but made afresh on arrival.

    Changed fields: a method prepared on a field *name* checks at every call
    that the volume still holds the array it was prepared on (fields are
    read-only once added, so only ``vol.fields[name] = new`` or
    ``vol.add_field(name, new)`` can change one) and raises
    :class:`~polygen.volume.surface.IsoSurfaceError` if it was replaced,
    instead of answering for the old values. A call that has begun answers
    for the values it began with, whatever happens to the field meanwhile;
    :meth:`UnstructuredVolume.isosurface` takes the field and its prepared
    method together, so that its queries answer for the field as it was when
    they began, never with this error. The preparation reads the field once:
    a replacement during it cannot mix old and new values. A method prepared
    on an array of values (``field=array``) answers for the values it was
    given.

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str, optional
        Field name (the volume's first field by default).
    **params
        Method-specific tuning, keyword-only.
    """

    name: str = ""
    description: str = ""
    #: where the surface starts: a registered seed source (:mod:`polygen.volume.seeds.source`)
    seeds: str = ""
    #: how the surface is built from there: ``"scan"``, ``"propagate"`` or ``"edge-centred"``
    construction: str = ""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        for name in ("extract", "extract_many"):
            fn = cls.__dict__.get(name)
            if fn is not None and not getattr(fn, "_serialised", False) and not getattr(
                    fn, "__isabstractmethod__", False):
                setattr(cls, name, _serialised(fn))

    def __init__(self, vol, field=None, **params):
        self.vol = vol
        if field is not None and not isinstance(field, str):
            field = volume_arrays(vol, field)[2]  # node values: a read-only copy (checked), never the caller's
        self.field = field
        self._lock = threading.RLock()
        # the array prepared on, when the field is named: a replaced field must not give a stale surface
        self._field_name = self._field_values = None
        fields = getattr(vol, "fields", None)
        if (field is None or isinstance(field, str)) and fields:
            self._field_name = next(iter(fields)) if field is None else field
            self._field_values = fields.get(self._field_name)
        self.seed_cells_tested = 0
        self._as_of = 0  # > 0 while as_of_field holds the lock: the field was checked when the query began
        t0 = time.perf_counter()
        if self._field_values is not None:
            # prepared on the array, not the name: every part of the preparation sees the same values even
            # when the field is replaced meanwhile (they are the ones _check_field then compares)
            self.field = self._field_values
            try:
                self._prepare(**params)
            finally:
                self.field = field
        else:
            self._prepare(**params)
        self.preprocess_s = time.perf_counter() - t0

    @contextlib.contextmanager
    def as_of_field(self, values):
        """Hold the method for calls that answer for field ``values``, the array it was prepared on.

        For :meth:`UnstructuredVolume.isosurface`, which finds the field and this method together:
        the calls made inside answer for ``values`` even if the volume's field is replaced meanwhile
        (a query answers for the field as it was when it began). Gives ``None`` (and holds nothing)
        when the method was not prepared on ``values``.
        """
        with self._lock:
            if self._field_values is None or self._field_values is not values:
                yield None
                return
            self._as_of += 1
            try:
                yield self
            finally:
                self._as_of -= 1

    def _prepare(self, **params):
        """Build what the method needs once per volume (timed as preprocessing)."""

    def __getstate__(self):
        # pickling and deepcopy: the lock does not travel (a fresh one is made on arrival)
        with self._lock:
            state = self.__dict__.copy()
        del state["_lock"]
        state["_as_of"] = 0
        return _jit.note_read_only(state)

    def __setstate__(self, state):
        self.__dict__.update(state)
        _jit.restore_read_only(self)
        self._lock = threading.RLock()

    def _check_field(self):
        if self._field_values is not None and self.vol.fields.get(self._field_name) is not self._field_values:
            raise IsoSurfaceError(f"field {self._field_name!r} of the volume was replaced or removed after this "
                                  f"{self.name or type(self).__name__!r} method was prepared on it; prepare the "
                                  "method again (vol.isosurface does so by itself)")

    @abc.abstractmethod
    def extract(self, value, *, normals="mean"):
        """The isosurface ``S = value`` as an :class:`~polygen.volume.isosurface.IsoSurface`."""

    @_serialised
    def extract_many(self, values, *, normals="mean", threads=None):
        """The isosurfaces of several values, in their order (one after the other here;
        methods that can run queries side by side override this and use ``threads``)."""
        return [self.extract(v, normals=normals) for v in values]

    def memory_bytes(self):
        """Bytes of the arrays this prepared method holds between calls.

        Every numpy array reachable from the method's attributes (through
        lists, tuples, dicts and objects, three levels deep) counts once;
        arrays of the volume (points, cells, fields and its cached topology,
        :meth:`UnstructuredVolume.memory_bytes`) do not. Per-call scratch that
        a method keeps between calls counts: it is held.
        """
        return _held_bytes(self, self.vol)

    def __repr__(self):
        return f"{type(self).__name__}({self.vol!r}, preprocess_s={self.preprocess_s:.3g})"


def _base(a):
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def reachable_buffers(obj, vol, depth=4):
    """``{id(root): root}``: the buffers of the numpy arrays reachable from ``obj`` (through its attributes,
    dicts, lists, tuples and sets, ``depth`` levels), not entering ``vol``. The one walk behind
    :meth:`IsosurfaceMethod.memory_bytes` and :func:`polygen.volume.constructions.construction_memory`."""
    seen, out, stack = {id(vol)}, {}, [(obj, depth)]
    while stack:
        x, d = stack.pop()
        if isinstance(x, np.ndarray):
            r = _base(x)
            out[id(r)] = r
            continue
        if d == 0 or id(x) in seen or isinstance(x, (str, bytes, int, float, type)):
            continue
        seen.add(id(x))
        if isinstance(x, dict):
            stack += [(y, d - 1) for y in x.values()]
        elif isinstance(x, (list, tuple, set)):
            stack += [(y, d - 1) for y in x]
        elif hasattr(x, "__dict__"):
            stack += [(y, d - 1) for y in vars(x).values()]
    return out


def _held_bytes(obj, vol, depth=4):
    """Bytes of the numpy arrays reachable from ``obj``, each buffer once, the volume's excluded."""
    skip = set()
    for a in [getattr(vol, "points", None), getattr(vol, "cells", None)] + list(getattr(vol, "fields", {}).values()):
        if isinstance(a, np.ndarray):
            skip.add(id(_base(a)))

    def vol_arrays(x, d):
        if isinstance(x, np.ndarray):
            skip.add(id(_base(x)))
        elif isinstance(x, (tuple, list)) and d:
            for y in x:
                vol_arrays(y, d - 1)

    for x in getattr(vol, "__dict__", {}).values():
        vol_arrays(x, 2)
    return int(sum(r.nbytes for k, r in reachable_buffers(obj, vol, depth).items() if k not in skip))


@register
class FullScan(IsosurfaceMethod):
    name = "scan"
    description = "test every cell (the 'all cells' column of the thesis's tables)"
    construction = "scan"

    def extract(self, value, *, normals="mean"):
        iso = _extract(self.vol, value, field=self.field, method="scan", normals=normals)
        self.seed_cells_tested = iso.cells_tested
        return iso


@register
class UnpreparedScan(IsosurfaceMethod):
    name = "unprepared-scan"
    description = ("test every cell, merging vertices by the node pairs of the crossed edges: nothing "
                   "prepared (the first surface of a freshly loaded volume)")
    construction = "scan"

    def extract(self, value, *, normals="mean"):
        value = _check_value(value)
        _check_normals(normals)
        iso = _scan_unprepared(self.vol, value, self.field, normals)
        self.seed_cells_tested = iso.cells_tested
        return iso

    def memory_bytes(self):
        """Bytes held between calls: none (every array is per call)."""
        return 0


class SeedsThenPropagate(IsosurfaceMethod):
    """A seed source x the propagation of thesis 5.4.2: the seeds are found, the surface grows from them.

    Subclasses name the registered seed source in ``seeds``; the keyword
    parameters of the method go to the source. After each :meth:`extract`,
    ``stats`` holds that call's quantities of Tables 6.5 and 7.5: ``T_mg``
    (seed search, s), ``T_mt`` (triangles: propagation), ``T_mv`` (vertex
    positions and normals), ``N_cg`` (cells the search tested), ``N_ci``
    (cells intersected) and ``seeds`` (the source's own answer).

    Attributes
    ----------
    source : SeedSource
    propagator : Propagator
    """

    seeds: str = ""
    construction = "propagate"

    def _prepare(self, **params):
        self.source = _seed_source(self.vol, self.field, self.seeds, **params)
        self.propagator = Propagator(self.vol, self.field)
        self.stats = {}

    @property
    def structure(self):
        """What the seed source built (the search structure, the graph, the skeleton)."""
        return self.source.structure

    def extract(self, value, *, normals="mean"):
        found = self.source.query(value)
        t0 = time.perf_counter()
        # the propagation reads the volume in the order of its seeds: in cell-id order (cells are
        # numbered along a space-filling curve) that is nearly sequential, in a tree's order it is
        # random (measured on 2M, 20 values: span space 1.05 s as given, 0.45 s sorted)
        cells = np.sort(found.cells) if self.source.sort else found.cells
        t_search = found.seconds + (time.perf_counter() - t0)
        iso = self.propagator.extract(value, cells, normals=normals)
        self.seed_cells_tested = found.n_tested
        self.stats = {"T_mg": t_search, "T_mt": iso.t1 + iso.t2, "T_mv": iso.t3, "N_cg": found.n_tested,
                      "N_ci": iso.cells_intersected, "seeds": found.found}
        # every candidate is tested again by the propagation; the search's own tests come on top
        return dataclasses.replace(iso, cells_tested=iso.cells_tested + found.n_tested, t1=iso.t1 + t_search)


def _search_method(search_name, doc):
    cls_name = search_name.title().replace("-", "")
    # a module attribute with the class's own name, so that pickle finds the class of a prepared method
    cls = type(cls_name, (SeedsThenPropagate,),
               {"name": search_name, "seeds": search_name, "description": doc, "__module__": __name__,
                "__qualname__": cls_name})
    globals()[cls_name] = cls
    return register(cls)


for _name, _doc in [
    ("sorted-lists", "Giles-Haimes sorted min/max lists"),
    ("span-filter", "Gallagher span filtering"),
    ("span-space", "Livnat span-space k-d tree"),
    ("issue-lattice", "Shen's ISSUE lattice"),
    ("interval-tree", "Cignoni's interval tree"),
]:
    _search_method(_name, _doc)
