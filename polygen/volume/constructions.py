"""The polygon constructions of Itoh, Yamaguchi and Koyamada (2001) side by side, and a timed sweep.

Four ways to build the polygons from the same thinning-skeleton seeds
separate the two things that could make a construction fast -- removing
the vertex search and storing the cell edges -- (notebook 08,
``benchmarks/fast_construction.py``):

* ``hash``: propagation + a hash on node pairs (the paper's old method);
* ``array``: propagation + the vertex id in an array indexed by edge id;
* ``walk-fifo``, ``walk-lifo``: edge-centred, the cells round an edge found
  by walking (the paper's new method);
* ``table-fifo``, ``table-lifo``: edge-centred with an edge table and an
  edge -> cells index.

The two constructions of the paper's setting (``hash``, ``walk-*``) store
no edges: their surfaces are keyed by node pairs (``vertex_keys="node-pairs"``,
:func:`edge_keyed` relabels them by edge id for a comparison), and their
thinning seeds do not build the volume's edge table on the side.
:func:`construction_memory` measures what each construction holds.
"""

from __future__ import annotations

import ctypes
import dataclasses
import gc
import os
import time

import numpy as np

from polygen import _jit
from polygen.volume import methods
from polygen.volume.edge_centred import EdgeCentredTable, EdgeCentredWalk
from polygen.volume.propagate import EdgeLabels, Propagator

__all__ = ["CONSTRUCTIONS", "NO_STORED_EDGES", "prepare_construction", "make_builder", "builder_of", "timed_sweep",
           "edge_keyed", "construction_memory", "rss_bytes"]

#: label -> (registered method, its parameters, the propagator's vertex search or None)
CONSTRUCTIONS = {
    "hash": ("thinning", {}, "hash"),                                   # (a) reference [12]
    "array": ("thinning", {}, "array"),                                 # (b) if edges were stored
    "walk-fifo": ("edge-centred", {"order": "fifo"}, None),             # (c) the paper, no stored edges
    "walk-lifo": ("edge-centred", {"order": "lifo"}, None),
    "table-fifo": ("edge-centred-table", {"order": "fifo"}, None),      # (d) with the edge table
    "table-lifo": ("edge-centred-table", {"order": "lifo"}, None),
}
#: the constructions of the paper's setting: no edge numbered or stored, surfaces keyed by node pairs
NO_STORED_EDGES = ("hash", "walk-fifo", "walk-lifo")


def prepare_construction(label, vol, field="fem"):
    """The construction ``label`` (a key of :data:`CONSTRUCTIONS`, or ``"scan"``) prepared on ``vol``.

    For ``hash`` and ``array`` the thinning method's propagator is replaced
    by one with that vertex search (same seeds); ``preprocess_s`` is then
    the seeds' preparation and that propagator's. The constructions of
    :data:`NO_STORED_EDGES` key their vertices by node pairs and thin
    without building the edge table on the side.

    Raises
    ------
    KeyError
        An unknown label (the message lists the labels).
    """
    if label == "scan":
        return methods.get("scan")(vol, field=field)
    if label not in CONSTRUCTIONS:
        raise KeyError(f"unknown construction {label!r}; the constructions are scan, {', '.join(CONSTRUCTIONS)}")
    name, params, search = CONSTRUCTIONS[label]
    params = dict(params)
    if label in NO_STORED_EDGES:
        params["edge_table_aside"] = False
        if search is None:
            params["vertex_keys"] = "node-pairs"
    m = methods.get(name)(vol, field=field, **params)
    if search is not None:
        t0 = time.perf_counter()
        m.propagator = make_builder(label, vol, field)
        m.preprocess_s = m.source.preprocess_s + time.perf_counter() - t0
    return m


def make_builder(label, vol, field="fem", *, labels=False):
    """The construction ``label``'s builder alone (what :func:`builder_of` gives), on ``vol``.

    A :class:`~polygen.volume.propagate.Propagator` or an edge-centred
    builder with the parameters of :func:`prepare_construction`'s; the
    table's runs one thread (``threads=1``), as in the notebook. With
    ``labels`` a construction of :data:`NO_STORED_EDGES` labels its vertices
    by the volume's edge ids (the registered methods' default), which makes
    the volume build its edge table.
    """
    name, params, search = CONSTRUCTIONS[label]
    keys = {"vertex_keys": "node-pairs"} if label in NO_STORED_EDGES and not labels else {}
    if search is not None:
        return Propagator(vol, field, vertex_search=search, **keys)
    if name == "edge-centred":
        return EdgeCentredWalk(vol, field, order=params["order"], **keys)
    return EdgeCentredTable(vol, field, order=params["order"], threads=1)


def edge_keyed(label, iso, vol):
    """The surface ``iso`` of construction ``label`` with its vertices keyed by ``vol``'s edge ids.

    The constructions of :data:`NO_STORED_EDGES` key them by node pairs;
    this relabels them (reading, and so making the volume build, its edge
    list) for a comparison with another method's surface
    (:func:`~polygen.volume.surface.same_surface`). Any other label's
    surface comes back as it is.
    """
    if label not in NO_STORED_EDGES:
        return iso
    return dataclasses.replace(iso, vertex_keys=EdgeLabels(vol)(iso.vertex_keys))


def builder_of(m):
    """What builds a prepared method's polygons: its edge-centred builder or its propagator (None for the scan)."""
    return getattr(m, "builder", None) or getattr(m, "propagator", None)


def timed_sweep(m, values, *, repeat=3):
    """Every value extracted ``repeat`` times by the prepared method ``m``; each stage time at its minimum.

    Parameters
    ----------
    m : a prepared method (``extract(value)``)
    values : sequence of float
    repeat : int, keyword-only
        Runs of the whole sweep (at least 1).

    Returns
    -------
    isos : list of IsoSurface
        The surfaces of the last run.
    times : (V, 3) float64
        t1, t2, t3 of each value, each at its minimum over the runs.
    probes : int
        Hash slots the builder inspected in the last run (0 without a hash).
    """
    if repeat < 1:
        raise ValueError(f"repeat must be at least 1; got {repeat}")
    times = np.full((len(values), 3), np.inf)
    isos, probes = [], 0
    for _ in range(repeat):
        isos, probes = [], 0
        for i, v in enumerate(values):
            iso = m.extract(v)
            times[i] = np.minimum(times[i], [iso.t1, iso.t2, iso.t3])
            isos.append(iso)
            b = builder_of(m)  # after the call: a method may make its builder on first use
            probes += b.stats.get("probes", 0) if b is not None else 0
    return isos, times, probes


def timed_sweeps(ms, values, *, repeat=3):
    """:func:`timed_sweep` of several prepared methods, interleaved: each of ``repeat`` rounds runs every
    method's whole sweep in turn, so that a load on the machine falls on all of them alike (one method's
    runs after another's measured the second under another load: on a 2-core CI machine running other
    tests beside, notebook 08 once measured the new construction's t_p at 0.96 of the old one's, against
    0.63-0.71 quiet).

    ``ms``: name -> prepared method. Returns name -> ``(isos, times, probes)`` as :func:`timed_sweep`
    (each stage time at its minimum over the rounds; the surfaces and probes of the last round).
    """
    if repeat < 1:
        raise ValueError(f"repeat must be at least 1; got {repeat}")
    out = {}
    for _ in range(repeat):
        for name, m in ms.items():
            isos, times, probes = timed_sweep(m, values, repeat=1)
            if name in out:
                times = np.minimum(out[name][1], times)
            out[name] = (isos, times, probes)
    return out


def rss_bytes():
    """This process's resident memory in bytes (Linux ``/proc/self/statm``), or None where it cannot be read.

    Freed heap memory is handed back to the system first (``malloc_trim``),
    and released output buffers (:func:`polygen._jit.release_output_pool`),
    so that two readings differ by what is held between them.
    """
    gc.collect()
    _jit.release_output_pool()
    libc = _libc()
    if libc is not None:
        libc.malloc_trim(0)
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):  # pragma: no cover - not Linux
        return None


_LIBC = []


def _libc():
    """glibc, with its heap's mmap threshold fixed at 128 KiB (None elsewhere).

    glibc raises the threshold after a large block is freed, so that the
    next blocks of that size come from the heap and stay resident when
    freed; a fixed threshold keeps large arrays in their own mappings, which
    go back to the system when freed (what :func:`rss_bytes` relies on).
    """
    if not _LIBC:
        try:
            libc = ctypes.CDLL("libc.so.6")
            libc.mallopt(-3, 128 * 1024)  # M_MMAP_THRESHOLD
            _LIBC.append(libc)
        except (OSError, AttributeError):  # pragma: no cover - not glibc
            _LIBC.append(None)
    return _LIBC[0]


def _root(a):
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def _volume_tables(vol):
    """``{name: {id(root): root}}``: the arrays of the tables ``vol`` has built (its ``__dict__``, not its
    points, cells and fields), each buffer once."""
    own = {id(_root(a)) for a in (vol.points, vol.cells) if isinstance(a, np.ndarray)}
    own |= {id(_root(vol.scalars(name))) for name in vol.fields}
    out = {}

    def arrays(x, d, into):
        if isinstance(x, np.ndarray):
            r = _root(x)
            if id(r) not in own:
                into[id(r)] = r
        elif isinstance(x, (tuple, list)) and d:
            for y in x:
                arrays(y, d - 1, into)

    for name, x in vars(vol).items():
        got = {}
        arrays(x, 2, got)
        if got:
            out[name] = got
    return out


def construction_memory(label, vol, value, seeds, *, field="fem", rss=False, labels=False):
    """What construction ``label`` holds after its preparation and one extract on ``vol``, in bytes.

    The experiment (the same for every construction): ``vol`` is a freshly
    loaded volume; its face neighbours are built first (every construction
    and every seed source reads them; they are not counted), and its tables
    are noted. Then the builder alone (:func:`make_builder`) is prepared and
    extracts ``value`` from ``seeds`` (cell ids, e.g. the thinning skeleton's
    for that value, found on another copy of the volume), and its surface
    is dropped. Counted, each buffer once: every numpy array reachable from
    the builder that is not the volume's (``builder``), and every table the
    volume built meanwhile (``volume``, by name: what the construction made
    the volume build, e.g. the edge table a labelling by edge id reads).
    The points, cells and field are not counted.

    Parameters
    ----------
    label : str
        A key of :data:`CONSTRUCTIONS`.
    vol : UnstructuredVolume
        Fresh: no table built but (at most) its face neighbours.
    value : float
    seeds : (K,) int
    field : str, keyword-only
    rss : bool, keyword-only
        Also read the process's resident memory (:func:`rss_bytes`) before
        the preparation and after the extract (``rss``: the difference; the
        kernels should have run once in the process before, so that their
        compilation or loading is not in it).
    labels : bool, keyword-only
        :func:`make_builder`'s: ``hash`` and ``walk-*`` labelling their
        vertices by edge id.

    Returns
    -------
    dict
        ``total``, ``builder``, ``volume`` (name -> bytes), ``by_array``
        (the builder's own ``memory_bytes()``: its names for the same
        arrays), ``rss`` (or None), ``cells``.
    """
    vol.face_neighbors
    before = _volume_tables(vol)
    old = {k for got in before.values() for k in got}
    r0 = rss_bytes() if rss else None
    builder = make_builder(label, vol, field, labels=labels)
    iso = builder.extract(value, seeds)
    if hasattr(builder, "settle"):
        builder.settle()
    del iso
    r1 = rss_bytes() if rss else None
    after = _volume_tables(vol)
    vol_new, volume = {}, {}
    for name, got in after.items():
        new = {k: a for k, a in got.items() if k not in old}
        if new:
            volume[name] = int(sum(a.nbytes for a in new.values()))
            vol_new.update(new)
    held = methods.reachable_buffers(builder, vol)
    base = {id(_root(a)) for a in (vol.points, vol.cells, *(vol.scalars(n) for n in vol.fields))}
    own = {k: a for k, a in held.items() if k not in old and k not in vol_new and k not in base}
    builder_bytes = int(sum(a.nbytes for a in own.values()))
    return {"total": builder_bytes + sum(volume.values()), "builder": builder_bytes, "volume": volume,
            "by_array": builder.memory_bytes(), "rss": None if r0 is None or r1 is None else r1 - r0,
            "cells": int(vol.n_cells)}
