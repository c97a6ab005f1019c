"""Numba kernels of the cell-edge-centred construction without stored cell edges (2001 paper, Fig. 5).

The paper's premise (2.1): a volume stores its nodes and cells, not its
cell edges, so there is no edge table to register a vertex in. Its method
needs none: when a vertex is created on an edge of the cell being built,
for-loop (3) visits the cells around that edge by walking from face
neighbour to face neighbour around it, and registers the vertex into
each of them. Nothing is looked up later. Here the only per-cell data are
the cell's nodes, its face neighbours and its polygon's vertex slots.

A cell's *record* is a row of ``rec`` (M, R) int32:

``rec[c, R_GEN]``, ``rec[c, R_STATE]``
    generation stamp and state, as in :mod:`._edge_centred_kernels`;
``rec[c, R_NODES:R_NODES+nn]``
    the node ids;
``rec[c, on:on+nf]`` with ``on = R_NODES + nn``
    the face neighbours (-1 on the boundary), in the order of the local faces;
``rec[c, os:os+ne+nn]`` with ``os = on + nf``
    the polygon's vertex slots: one per local edge, one per node (a
    crossing exactly on a node).

The walk around an edge ``(a, b)`` of cell ``c``: leave ``c`` through one of
the two local faces that contain the edge; in the neighbour, find the local
edge ``(a, b)`` (compare its nodes with ``a`` and ``b``) and leave through
its other face containing that edge; stop on coming back to ``c`` (an edge
inside the volume) or at the boundary, and then walk the other way from
``c``. A vertex exactly on a node is shared by every cell around the node:
those are found by a flood fill over the faces that contain the node.

Both walks find every cell around the edge (node) when the cells around it
are connected through faces, which holds in any conforming mesh of a
3-manifold with boundary (the walk is how the cells around an edge are
defined there). At a non-manifold edge (two parts touching along an edge
only: a partition's Morton range of cells often does) the walk finds the
cells of one side only, and the other side makes the vertex again; at a
non-manifold node the flood fill does the same. Such an edge lies on the
boundary, so its walk ends at the boundary both ways: the kernel lists
every vertex whose walk did (and every vertex on a node), and the caller
merges the vertices of that short list that share a key
(:func:`merge_open_duplicates`). A manifold volume has none to merge.

The vertex keys are the edge's end nodes (:func:`._vertex_hash.pair_key`),
not edge ids: no edge is numbered.

``search=True`` builds the same surface but, instead of reading a polygon's
vertices from its registered slots, looks each one up in a hash table keyed
by its edge's nodes (as the reference [12] method does): a deliberately
searching variant that shows the look-up counter is live.
"""

import numpy as np

from polygen import _jit
from polygen._jit import njit
from polygen.volume import marching as _m
from polygen.volume._edge_centred_kernels import (
    NOT_CROSSED,
    QUEUED,
    R_GEN,
    R_NODES,
    R_STATE,
    _ctz,
    _make_polygon,
    _node_values,
    _polygon_codes,
)
from polygen.volume._vertex_hash import get, get_or_add, pair_key, shift_of

#: kernel status codes: 0 done, 1-3 a buffer overflowed, 4 the hash table is full, 5 the mesh is not conforming
OK, FULL_QUEUE, FULL_TRIANGLES, FULL_VERTICES, FULL_HASH, FULL_AROUND, BAD_MESH = 0, 1, 2, 3, 4, 5, 6
#: counters written by :func:`construct` (indices into ``counters``)
(C_POPS, C_VISITS, C_TOUCHED, C_CONSTRUCTED, C_NODE_TESTS, C_NODE_VERTICES, C_LOOKUPS, C_PROBES,
 C_WALK_STEPS, C_BAD_CELL, C_OPEN) = range(11)
N_COUNTERS = 11
#: a walk around one edge longer than this means a broken mesh
MAX_RING = 1 << 16


def record_width(n_nodes, n_faces, n_local_edges):
    """Record length in int32: stamp, state, nodes, face neighbours, vertex slots."""
    return 2 + n_nodes + n_faces + n_local_edges + n_nodes


def walk_tables(local_edges, local_faces):
    """``(edge_faces (ne, 2), edge_of (nn, nn), node_faces (nn, 3))`` int64 for the walks.

    ``edge_faces[e]``: the two local faces that contain local edge ``e``;
    ``edge_of[i, j]``: the local edge joining local nodes ``i`` and ``j``
    (-1 if none); ``node_faces[i]``: the three local faces that contain node ``i``.
    """
    ne = local_edges.shape[0]
    nn = int(local_edges.max()) + 1
    edge_faces = _jit.scratch((ne, 2), np.int64)
    for e, (a, b) in enumerate(local_edges):
        f = [k for k, face in enumerate(local_faces) if a in face and b in face]
        assert len(f) == 2
        edge_faces[e] = f
    edge_of = np.full((nn, nn), -1, np.int64)
    for e, (a, b) in enumerate(local_edges):
        edge_of[a, b] = edge_of[b, a] = e
    node_faces = _jit.scratch((nn, 3), np.int64)
    for i in range(nn):
        f = [k for k, face in enumerate(local_faces) if i in face]
        assert len(f) == 3
        node_faces[i] = f
    return edge_faces, edge_of, node_faces


@njit
def fill_records(rec, cells, neighbors):
    """Node ids and face neighbours into the records (stamps, states and slots cleared)."""
    nn = cells.shape[1]
    nf = neighbors.shape[1]
    width = rec.shape[1]
    for c in range(rec.shape[0]):
        rec[c, R_GEN] = 0
        rec[c, R_STATE] = 0
        for i in range(nn):
            rec[c, R_NODES + i] = cells[c, i]
        for f in range(nf):
            rec[c, R_NODES + nn + f] = neighbors[c, f]
        for w in range(R_NODES + nn + nf, width):
            rec[c, w] = -1


@njit(inline="always")
def _visit(rec, dyn, ds, j, slot, v, nn, n_slots, s, value, faces, vals, gen, queue, tail):
    """For-loop (3) on cell ``j`` around a crossed edge: construct and queue ``P_j`` if missing, register ``v``.

    Returns ``(ok, tail, touched, made)``; ``ok`` is False when the queue is full.
    """
    touched = 0
    made = 0
    if dyn[j, R_GEN] != gen:
        dyn[j, R_GEN] = gen
        touched = 1
        cj, xj = _node_values(rec, j, nn, s, value, faces, vals)
        if tail == queue.shape[0]:
            return False, tail, touched, made
        _make_polygon(dyn, j, cj, xj, n_slots, ds)  # construct P_j
        made = 1
        queue[tail] = j  # insert C_j into the FIFO
        tail += 1
    elif dyn[j, R_STATE] == QUEUED:  # a seed still in the FIFO: construct P_j, it is queued already
        cj, xj = _node_values(rec, j, nn, s, value, faces, vals)
        _make_polygon(dyn, j, cj, xj, n_slots, ds)
        made = 1
    dyn[j, ds + slot] = v  # register V_n into P_j
    return True, tail, touched, made


@njit
def _node_vertex(rec, dyn, ds, nn, on, n_slots, ne, s, value, faces, node_faces, c, node, v, gen, queue, tail,
                 around, around_local):
    """For-loop (3) for a vertex that is ``node`` itself: every cell around the node, by a flood fill over faces.

    A cell around the node may lie wholly above the isovalue, so each cell
    seen for the first time in this query is tested. Returns ``(status,
    tail, n_around, tested, made)``.
    """
    vals = np.empty(8, np.float64)
    cap = around.shape[0]
    n = 0
    for i in range(nn):
        if rec[c, R_NODES + i] == node:
            around[0] = c
            around_local[0] = i
            n = 1
    k = 0
    while k < n:  # the cells around the node, through the faces that contain it
        j = around[k]
        li = around_local[k]
        k += 1
        for t in range(node_faces.shape[1]):
            nb = rec[j, on + node_faces[li, t]]
            if nb < 0:
                continue
            seen = False
            for q in range(n):
                if around[q] == nb:
                    seen = True
                    break
            if seen:
                continue
            if n == cap:
                return FULL_AROUND, tail, n, 0, 0
            lj = -1
            for i in range(nn):
                if rec[nb, R_NODES + i] == node:
                    lj = i
            if lj < 0:
                return BAD_MESH, tail, n, 0, 0
            around[n] = nb
            around_local[n] = lj
            n += 1
    tested = 0
    made = 0
    for q in range(n):
        j = around[q]
        if dyn[j, R_GEN] != gen:
            dyn[j, R_GEN] = gen
            tested += 1
            cj, xj = _node_values(rec, j, nn, s, value, faces, vals)
            if cj < 0:
                dyn[j, R_STATE] = NOT_CROSSED
                continue
            if tail == queue.shape[0]:
                return FULL_QUEUE, tail, n, tested, made
            _make_polygon(dyn, j, cj, xj, n_slots, ds)
            made += 1
            queue[tail] = j
            tail += 1
        else:
            sj = dyn[j, R_STATE]
            if sj == NOT_CROSSED:
                continue
            if sj == QUEUED:
                cj, xj = _node_values(rec, j, nn, s, value, faces, vals)
                _make_polygon(dyn, j, cj, xj, n_slots, ds)
                made += 1
        dyn[j, ds + ne + around_local[q]] = v
    return OK, tail, n, tested, made


@njit
def construct(rec, dyn, ds, nn, nf, n_points, s, value, faces, tri_table, tri_count, case_mask, local_edges, edge_faces,
              edge_of, node_faces, gen, queue, n_queued, lifo, tris, tri_cell, vkey, vend, open_v, around,
              around_local, search, htable, counters):
    """t2: the cell-edge-centred construction, the cells around an edge found by walking (Fig. 5).

    As :func:`._edge_centred_kernels.construct`, with the records of this
    module and no edge table: ``vkey[v]`` is the vertex's
    :func:`._vertex_hash.pair_key`. With ``search`` every vertex of a
    polygon is looked up in the hash table ``htable`` (stamp ``gen``, see
    :func:`._vertex_hash.get_or_add`) when its triangles are written, instead of being read from
    its slot; the look-ups and the slots probed are counted
    (``counters[C_LOOKUPS]``, ``counters[C_PROBES]``). Without it the
    kernel makes no look-up and counts none. ``open_v`` (as long as
    ``vkey``) receives the vertices whose edge walk ended at the boundary
    both ways, and those on a node, in creation order
    (``counters[C_OPEN]`` of them): the only ones a non-manifold edge or
    node can make twice.

    Returns ``(status, n_polygons, n_triangles, n_vertices,
    any_node_vertex)``; ``status`` other than ``OK`` names the buffer that
    was too small (the caller grows it and starts the query again under a
    new generation), or ``BAD_MESH``: a walk met a neighbour without the
    edge's (node's) nodes or went round more than ``MAX_RING`` cells
    (``counters[C_BAD_CELL]`` is the cell).
    """
    ne = local_edges.shape[0]
    n_slots = ne + nn
    on = R_NODES + nn
    cap_t = tris.shape[0] - _m.MAX_TRIANGLES
    cap_v = vkey.shape[0]
    cap_h = htable.shape[0]
    shift = shift_of(cap_h)
    vals = np.empty(8, np.float64)
    codes = np.empty((_m.MAX_TRIANGLES, 3), np.int64)
    n_p = 0
    n_t = 0
    n_v = 0
    head = 0
    tail = n_queued
    pops = 0
    visits = 0
    touched = 0
    node_tests = 0
    node_vertices = 0
    lookups = 0
    probes = 0
    steps = 0
    n_open = 0
    while head < tail:  # for-loop (1): cells taken from the FIFO
        if lifo:
            tail -= 1
            c = queue[tail]
        else:
            c = queue[head]
            head += 1
        pops += 1
        st = dyn[c, R_STATE]
        if st == QUEUED:  # a seed nobody reached before: construct P_i
            case, exact = _node_values(rec, c, nn, s, value, faces, vals)
            _make_polygon(dyn, c, case, exact, n_slots, ds)
            n_p += 1
            st = dyn[c, R_STATE]
        case = st & 0xFFFF
        exact = st >> 16
        if exact == 0:
            k = tri_count[case]
            todo = case_mask[case]
        else:  # a node at the isovalue: node codes, zero-area triangles dropped
            for i in range(nn):
                vals[i] = s[rec[c, R_NODES + i]]
            k, todo = _polygon_codes(case, exact, vals, value, tri_table, tri_count, local_edges, codes)
        # for-loop (2): the vertices of P_i not registered yet
        while todo:
            w = _ctz(todo)
            todo &= todo - 1
            if dyn[c, ds + w] >= 0:
                continue
            if n_v == cap_v:
                return FULL_VERTICES, n_p, n_t, n_v, node_vertices > 0
            if search and 2 * (n_v + 1) > cap_h:
                return FULL_HASH, n_p, n_t, n_v, node_vertices > 0
            v = n_v
            n_v += 1
            if w < ne:  # a vertex on cell edge E_n = (a, b)
                x = rec[c, R_NODES + local_edges[w, 0]]
                y = rec[c, R_NODES + local_edges[w, 1]]
                a = min(x, y)
                b = max(x, y)
                vend[v, 0] = a
                vend[v, 1] = b
                vkey[v] = pair_key(a, b, n_points)
                # for-loop (3): every cell C_j sharing E_n, C_i first, then walking round E_n both ways
                ok, tail, t_, m_ = _visit(rec, dyn, ds, c, w, v, nn, n_slots, s, value, faces, vals, gen, queue, tail)
                around_n = 1
                for d in range(2):
                    prev = c
                    nxt = rec[c, on + edge_faces[w, d]]
                    while nxt >= 0 and nxt != c:
                        j = nxt
                        ia = -1
                        ib = -1
                        for i in range(nn):
                            z = rec[j, R_NODES + i]
                            if z == a:
                                ia = i
                            elif z == b:
                                ib = i
                        le = edge_of[ia, ib] if ia >= 0 and ib >= 0 else -1
                        if le < 0 or around_n > MAX_RING:
                            counters[C_BAD_CELL] = j
                            return BAD_MESH, n_p, n_t, n_v, node_vertices > 0
                        ok, tail, t_, m_ = _visit(rec, dyn, ds, j, le, v, nn, n_slots, s, value, faces, vals, gen,
                                                  queue, tail)
                        if not ok:
                            return FULL_QUEUE, n_p, n_t, n_v, node_vertices > 0
                        touched += t_
                        n_p += m_
                        around_n += 1
                        # leave C_j through its other face around E_n
                        n0 = rec[j, on + edge_faces[le, 0]]
                        n1 = rec[j, on + edge_faces[le, 1]]
                        nxt = n1 if n0 == prev else n0
                        prev = j
                    if nxt == c:  # round the edge and back: an inner edge, every cell seen
                        break
                if nxt != c:  # a boundary edge: another side may touch it (a non-manifold edge)
                    open_v[n_open] = v
                    n_open += 1
                visits += around_n
                steps += around_n - 1
            else:  # a crossing exactly on a node: shared by every cell around the node
                node = rec[c, R_NODES + w - ne]
                vkey[v] = pair_key(node, node, n_points)
                vend[v, 0] = node
                vend[v, 1] = node
                node_vertices += 1
                open_v[n_open] = v  # the flood fill stops at a non-manifold node as the walk does at an edge
                n_open += 1
                status, tail, n_around, tested, made = _node_vertex(
                    rec, dyn, ds, nn, on, n_slots, ne, s, value, faces, node_faces, c, node, v, gen, queue, tail,
                    around, around_local)
                if status == BAD_MESH:
                    counters[C_BAD_CELL] = c
                if status != OK:
                    return status, n_p, n_t, n_v, True
                visits += n_around
                node_tests += tested
                touched += tested
                n_p += made
            if search:  # the searching variant: remember the vertex by its key
                r, p = get_or_add(htable, gen, vkey[v], v, shift)
        # every vertex of P_i is registered: its triangles, as vertex ids
        if n_t > cap_t:
            return FULL_TRIANGLES, n_p, n_t, n_v, node_vertices > 0
        for t in range(k):
            for jj in range(3):
                w = tri_table[case, 3 * t + jj] if exact == 0 else codes[t, jj]
                if search:  # find the vertex again by its edge's nodes, as reference [12] does
                    if w < ne:
                        key = pair_key(rec[c, R_NODES + local_edges[w, 0]], rec[c, R_NODES + local_edges[w, 1]],
                                       n_points)
                    else:
                        key = pair_key(rec[c, R_NODES + w - ne], rec[c, R_NODES + w - ne], n_points)
                    vid, p = get(htable, gen, key, shift)
                    lookups += 1
                    probes += p
                    tris[n_t, jj] = vid
                else:
                    tris[n_t, jj] = dyn[c, ds + w]
            tri_cell[n_t] = c
            n_t += 1
    counters[C_POPS] = pops
    counters[C_VISITS] = visits
    counters[C_TOUCHED] = touched
    counters[C_CONSTRUCTED] = n_p
    counters[C_NODE_TESTS] = node_tests
    counters[C_NODE_VERTICES] = node_vertices
    counters[C_LOOKUPS] = lookups
    counters[C_PROBES] = probes
    counters[C_WALK_STEPS] = steps
    counters[C_OPEN] = n_open
    return OK, n_p, n_t, n_v, node_vertices > 0


def merge_open_duplicates(open_v, tris, vkey, vend):
    """Vertices made twice at a non-manifold edge or node, merged: ``(tris, vkey, vend, n_merged)``.

    ``open_v`` (ascending vertex ids): the vertices :func:`construct` listed
    (a walk that ended at the boundary both ways, or a node). Among them,
    those that share a key are one vertex made once per side; each later
    copy is dropped and its triangles point at the first. O(k log k) in the
    short list's length ``k``; the arrays are returned as they are when
    nothing repeats.
    """
    if open_v.shape[0] < 2:
        return tris, vkey, vend, 0
    k = vkey[open_v]
    order = np.argsort(k, kind="stable")
    ks = k[order]
    again = np.flatnonzero(ks[1:] == ks[:-1]) + 1
    if not again.size:
        return tris, vkey, vend, 0
    first = np.arange(ks.shape[0])
    starts = np.r_[True, ks[1:] != ks[:-1]]
    first = np.maximum.accumulate(np.where(starts, first, 0))  # each sorted row's group start
    n_v = vkey.shape[0]
    remap = np.arange(n_v)
    remap[open_v[order[again]]] = open_v[order[first[again]]]
    keep = remap == np.arange(n_v)
    new = np.cumsum(keep) - 1
    tris = new[remap[tris]].astype(tris.dtype, copy=False)
    return tris, vkey[keep], np.ascontiguousarray(vend[keep]), int(again.size)
