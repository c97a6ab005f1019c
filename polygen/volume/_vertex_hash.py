"""Numba kernels of a vertex hash table cleared by generation stamps (the paper's reference [12]).

Open addressing with linear probing over int64 keys, Fibonacci hashing.
A slot is occupied in the current query only when ``stamp[slot] == gen``,
so a new query empties the table by taking the next generation (O(1)),
and the table, once grown to the largest surface seen, is never
allocated or cleared again. The functions count the slots they inspect
(*probes*) so that the callers can report the work of every search.

Vertex keys without stored cell edges are the edge's two end nodes, as
the paper's reference [12] keys them: ``a * n_points + b`` (``a < b``),
and ``n_points**2 + node`` for a crossing exactly on a node
(:func:`pair_key`).
"""

import numpy as np

from polygen._jit import njit

_GOLDEN = np.uint64(11400714819323198485)  # 2**64 / golden ratio: Fibonacci hashing


@njit(inline="always")
def pair_key(a, b, n_points):
    """The key of the vertex on the edge ``(a, b)``, or on node ``a`` when ``a == b``."""
    if a == b:
        return np.int64(n_points) * n_points + a
    if a < b:
        return np.int64(a) * n_points + b
    return np.int64(b) * n_points + a


@njit(inline="always")
def _slot(key, shift):
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(shift))


@njit(inline="always")
def _shift(cap):
    bits = 0
    while (1 << bits) < cap:
        bits += 1
    return 64 - bits


@njit(inline="always")
def get_or_add(hkeys, hvals, hstamp, gen, key, new_val):
    """``(value, probes)``: the value under ``key``, or ``-1 - new_val`` after storing ``new_val`` there.

    The table (a power of two long) must have a free slot.
    """
    mask = hkeys.shape[0] - 1
    i = _slot(key, _shift(hkeys.shape[0]))
    probes = 1
    while hstamp[i] == gen:
        if hkeys[i] == key:
            return np.int64(hvals[i]), probes
        i = (i + 1) & mask
        probes += 1
    hstamp[i] = gen
    hkeys[i] = key
    hvals[i] = new_val
    return -1 - np.int64(new_val), probes


@njit(inline="always")
def get(hkeys, hvals, hstamp, gen, key):
    """``(value, probes)``: the value under ``key``, or ``(-1, probes)`` if it is not there."""
    mask = hkeys.shape[0] - 1
    i = _slot(key, _shift(hkeys.shape[0]))
    probes = 1
    while hstamp[i] == gen:
        if hkeys[i] == key:
            return np.int64(hvals[i]), probes
        i = (i + 1) & mask
        probes += 1
    return np.int64(-1), probes


@njit
def rehash(keys, n, cap, gen):
    """A table of ``cap`` slots (a power of two) holding ``keys[v] -> v`` for ``v < n``, stamped ``gen``."""
    hkeys = np.empty(cap, np.int64)
    hvals = np.empty(cap, np.int32)
    hstamp = np.zeros(cap, np.int32)
    for v in range(n):
        get_or_add(hkeys, hvals, hstamp, gen, keys[v], v)
    return hkeys, hvals, hstamp
