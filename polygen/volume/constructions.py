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
"""

from __future__ import annotations

import time

import numpy as np

from polygen.volume import methods
from polygen.volume.propagate import Propagator

__all__ = ["CONSTRUCTIONS", "prepare_construction", "builder_of", "timed_sweep"]

#: label -> (registered method, its parameters, the propagator's vertex search or None)
CONSTRUCTIONS = {
    "hash": ("thinning", {}, "hash"),                                   # (a) reference [12]
    "array": ("thinning", {}, "array"),                                 # (b) if edges were stored
    "walk-fifo": ("edge-centred", {"order": "fifo"}, None),             # (c) the paper, no stored edges
    "walk-lifo": ("edge-centred", {"order": "lifo"}, None),
    "table-fifo": ("edge-centred-table", {"order": "fifo"}, None),      # (d) with the edge table
    "table-lifo": ("edge-centred-table", {"order": "lifo"}, None),
}


def prepare_construction(label, vol, field="fem"):
    """The construction ``label`` (a key of :data:`CONSTRUCTIONS`, or ``"scan"``) prepared on ``vol``.

    For ``array`` the thinning method's propagator finds each vertex by an
    array read at its edge id instead of the hash (same seeds); its
    preparation time is added to ``preprocess_s``.

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
    m = methods.get(name)(vol, field=field, **params)
    if search == "array":
        t0 = time.perf_counter()
        m.propagator = Propagator(vol, field, vertex_search="array")
        m.preprocess_s += time.perf_counter() - t0
    return m


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
