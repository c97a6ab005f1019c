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
def shift_of(cap):
    """``64 - log2(cap)``: the shift of Fibonacci hashing for a table of ``cap`` slots (a power of two)."""
    bits = 0
    while (1 << bits) < cap:
        bits += 1
    return 64 - bits


@njit(inline="always")
def get_or_add(table, gen, key, new_val, shift):
    """``(value, probes)``: the value under ``key``, or ``-1 - new_val`` after storing ``new_val`` there.

    ``table`` (cap, 2) int64, cap a power of two with a free slot: per slot
    the key and ``stamp << 32 | value``, side by side so that a probe reads
    one cache line; the slot is occupied in this query when its stamp is
    ``gen``. ``shift`` is :func:`shift_of` ``(cap)``.
    """
    mask = table.shape[0] - 1
    i = np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(shift))
    probes = 1
    while (table[i, 1] >> 32) == gen:
        if table[i, 0] == key:
            return table[i, 1] & 0xFFFFFFFF, probes
        i = (i + 1) & mask
        probes += 1
    table[i, 0] = key
    table[i, 1] = (np.int64(gen) << 32) | new_val
    return -1 - np.int64(new_val), probes


@njit(inline="always")
def get(table, gen, key, shift):
    """``(value, probes)``: the value under ``key``, or ``(-1, probes)`` if it is not there."""
    mask = table.shape[0] - 1
    i = np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(shift))
    probes = 1
    while (table[i, 1] >> 32) == gen:
        if table[i, 0] == key:
            return table[i, 1] & 0xFFFFFFFF, probes
        i = (i + 1) & mask
        probes += 1
    return np.int64(-1), probes


@njit
def rehash(keys, n, cap, gen):
    """A table of ``cap`` slots (a power of two) holding ``keys[v] -> v`` for ``v < n``, stamped ``gen``."""
    table = np.zeros((cap, 2), np.int64)
    shift = shift_of(cap)
    for v in range(n):
        get_or_add(table, gen, keys[v], v, shift)
    return table
