"""Loops on the volume's boundary that generate its first homology (tree-cotree).

An isosurface component that reaches the boundary either separates the
volume or it does not. One that separates it has an extremum on each side
(the proof of Thm 6.1 works for any surface that cuts the volume in two),
so the extrema graph crosses it; one that does not -- a disk across a ring,
say -- can only exist when the volume has through-holes (Fig. 7.1), and it
is what the thesis's boundary cell lists (6.3.3) are there to find. A much
smaller set finds it too: edge loops on the boundary surface whose classes
generate H1 of every boundary component. For a non-separating component I
there is a closed curve in the volume that crosses I once; by Mayer-Vietoris
(the volume sits in 3-space) H1 of the boundary maps onto H1 of the volume,
so some generator loop b meets I an odd number of times: the boundary
curves of I cross b on the boundary surface, at an edge of b whose two nodes
lie on either side of the isovalue, and every cell holding that edge is
intersected by I.

The generators come from the tree-cotree decomposition (Eppstein, SODA
2003): a breadth-first spanning tree T of the boundary's nodes and edges, a
spanning forest C of its faces joined across the edges not in T; each edge
in neither closes one loop with its two tree paths, 2g of them on a closed
surface of genus g (fewer edges are left over on a sphere: none). The tree
is rooted at an approximate centre of each boundary component (the middle
of a double-sweep diameter), which keeps the loops short.

All this needs a boundary that is a closed 2-manifold. Where cells touch
only along an edge or at a node (:attr:`BoundaryLoops.manifold` is False)
the extrema graph keeps the thesis's boundary lists.

>>> from polygen.volume import datasets
>>> loops = boundary_loops(datasets.load("torus"))
>>> loops.n_loops                       # a solid torus: genus 1, two loops
2
"""

from __future__ import annotations

import dataclasses

import numpy as np

from polygen import _jit
from polygen._jit import njit
from polygen.volume import _thinning_kernels as _tk
from polygen.volume import _topology as _k

__all__ = ["BoundaryLoops", "boundary_loops", "boundary_defects"]


@dataclasses.dataclass(frozen=True, eq=False)
class BoundaryLoops:
    """Closed edge paths on the boundary surface generating its first homology.

    Attributes
    ----------
    offsets : (L+1,) int64
        CSR offsets of the loops into ``nodes`` and ``cells``.
    nodes : (P,) int64
        The nodes of each loop in order; the loop closes from its last node
        back to its first through a boundary edge.
    cells : (P,) int64
        For the edge leaving each node along the loop, a cell that holds it
        (the owner of a boundary face through that edge).
    component : (L,) int64
        The connected boundary component (of the node graph) of each loop.
    leftover_edges : (L, 2) int64
        The edge in neither tree that closes each loop.
    nonmanifold_edges : int
        Boundary edges with other than two boundary faces (cells that touch
        only along an edge).
    nonmanifold_nodes : int
        Boundary nodes whose boundary faces form more than one fan (cells
        that touch only at a node, or along an edge). With either count
        non-zero the loops generate H1 of the pinched surface, not of the
        boundary of the face-connected volume that propagation walks, and
        an extremum of one side of the pinch can hide behind a larger
        neighbour on the other: the extrema graph does not use the loops
        then (:attr:`manifold` is False).
    """

    offsets: np.ndarray
    nodes: np.ndarray
    cells: np.ndarray
    component: np.ndarray
    leftover_edges: np.ndarray
    nonmanifold_edges: int = 0
    nonmanifold_nodes: int = 0

    @property
    def manifold(self) -> bool:
        """The boundary is a closed 2-manifold: every edge has two faces, every node one fan of them."""
        return self.nonmanifold_edges == 0 and self.nonmanifold_nodes == 0

    @property
    def n_loops(self) -> int:
        return int(self.offsets.shape[0] - 1)

    def loop(self, i):
        """(k,) int64 nodes of loop ``i``."""
        return self.nodes[self.offsets[i]:self.offsets[i + 1]]

    def loop_cells(self, i):
        """(k,) int64 cells along loop ``i`` (one per loop edge)."""
        return self.cells[self.offsets[i]:self.offsets[i + 1]]

    def unique_cells(self):
        """(K,) int64 distinct cells over all loops."""
        return np.unique(self.cells)


@njit
def _bfs(indptr, nbr, nbr_edge, root, dist, pred, pred_edge, queue):
    """Breadth-first search from ``root``; fills dist/pred/pred_edge of the nodes reached.

    Returns (the last node reached, one of the farthest; how many nodes were reached, listed in ``queue``).
    """
    dist[root] = 0
    pred[root] = -1
    pred_edge[root] = -1
    queue[0] = root
    head = 0
    tail = 1
    while head < tail:
        u = queue[head]
        head += 1
        for k in range(indptr[u], indptr[u + 1]):
            v = nbr[k]
            if dist[v] >= 0:
                continue
            dist[v] = dist[u] + 1
            pred[v] = u
            pred_edge[v] = nbr_edge[k]
            queue[tail] = v
            tail += 1
    return queue[tail - 1], tail


@njit
def _climb(pred, x, steps):
    """The node ``steps`` tree edges above ``x``."""
    for _ in range(steps):
        x = pred[x]
    return x


@njit
def _spanning_trees(indptr, nbr, nbr_edge, dist, pred, pred_edge):
    """A breadth-first tree in every component, rooted at the middle of a double-sweep diameter.

    Fills dist/pred/pred_edge; returns the component number of each node.
    """
    nv = dist.shape[0]
    scratch_d = np.full(nv, -1, np.int64)
    scratch_p = np.empty(nv, np.int64)
    scratch_e = np.empty(nv, np.int64)
    queue = np.empty(nv, np.int64)
    comp_of = np.full(nv, -1, np.int64)
    n_comp = 0
    for start in range(nv):
        if dist[start] >= 0:
            continue
        far, n_reach = _bfs(indptr, nbr, nbr_edge, start, scratch_d, scratch_p, scratch_e, queue)
        for i in range(n_reach):
            comp_of[queue[i]] = n_comp
            scratch_d[queue[i]] = -1
        far2, _ = _bfs(indptr, nbr, nbr_edge, far, scratch_d, scratch_p, scratch_e, queue)
        centre = _climb(scratch_p, far2, scratch_d[far2] // 2)
        _bfs(indptr, nbr, nbr_edge, centre, dist, pred, pred_edge, queue)
        n_comp += 1
    return comp_of


@njit
def _cotree_leftover(edge_faces_off, edge_faces, in_tree, n_faces):
    """Edges outside the tree that the face forest (union-find across them) does not use."""
    parent = np.arange(n_faces)
    n_e = edge_faces_off.shape[0] - 1
    left = np.zeros(n_e, np.bool_)
    for e in range(n_e):
        if in_tree[e]:
            continue
        if edge_faces_off[e + 1] - edge_faces_off[e] != 2:  # a non-manifold edge: keep its loop
            left[e] = True
            continue
        if not _k.union(parent, edge_faces[edge_faces_off[e]], edge_faces[edge_faces_off[e] + 1]):
            left[e] = True  # the two faces are joined already: this edge closes a loop
    return left


def boundary_defects(vol):
    """Where the boundary of ``vol`` is not a 2-manifold.

    Thms 7.4-7.6 count the genus of the boundary surface (Def. 5.8), and
    the boundary loops stand for its homology; both need a surface: every
    boundary edge on exactly two boundary faces, and the boundary faces
    around every boundary node joined through edges in one fan. Cells that
    touch only at an edge or a node break this; the skeleton, or the loops,
    may then miss parts of an isosurface.

    Returns
    -------
    edges : (E, 2) int64
        Boundary edges on other than two boundary faces.
    nodes : (V,) int64
        Boundary nodes whose boundary faces form more than one fan.
    """
    # the boundary edge table (numbered by lower node, then higher; the boundary groups are built from
    # it, so the thinning has it already) in place of a lexsort of every face edge: best of 5, alone,
    # 2M 0.077 -> 0.011 s, 10M 0.40 -> 0.035 s (benchmarks/experiments/boundary_defects_ab.py)
    fn = np.ascontiguousarray(vol.boundary_face_nodes, np.int64)
    ids, edges = vol.boundary_edge_table
    bad, nodes = _tk.boundary_defects(fn, np.ascontiguousarray(ids, np.int64), edges.shape[0], vol.n_points)
    return np.ascontiguousarray(edges[bad], np.int64).reshape(-1, 2), nodes


@njit
def _close_loops(edges, left_ids, dist, pred, pred_edge, edge_cell, offsets, nodes, cells):
    """Loop of each leftover edge (u, v): u up to the common ancestor, down to v, back to u.

    ``offsets`` must be sized L+1; ``nodes`` / ``cells`` large enough (sum of
    the loop lengths). Node and edge ids are the compact boundary ones.
    """
    n = 0
    up = np.empty(dist.shape[0], np.int64)
    up_e = np.empty(dist.shape[0], np.int64)
    for i in range(left_ids.shape[0]):
        e = left_ids[i]
        u = edges[e, 0]
        v = edges[e, 1]
        offsets[i] = n
        # climb to the common ancestor, u's side written forward, v's side kept to reverse
        a = u
        b = v
        n_up = 0
        while dist[a] > dist[b]:
            nodes[n] = a
            cells[n] = edge_cell[pred_edge[a]]
            n += 1
            a = pred[a]
        while dist[b] > dist[a]:
            up[n_up] = b
            up_e[n_up] = pred_edge[b]
            n_up += 1
            b = pred[b]
        while a != b:
            nodes[n] = a
            cells[n] = edge_cell[pred_edge[a]]
            n += 1
            a = pred[a]
            up[n_up] = b
            up_e[n_up] = pred_edge[b]
            n_up += 1
            b = pred[b]
        # the common ancestor, then v's side from the top down; the last node closes through e
        nodes[n] = a
        if n_up > 0:
            cells[n] = edge_cell[up_e[n_up - 1]]
        else:
            cells[n] = edge_cell[e]
        n += 1
        for j in range(n_up - 1, -1, -1):
            nodes[n] = up[j]
            cells[n] = edge_cell[up_e[j - 1]] if j > 0 else edge_cell[e]
            n += 1
    offsets[left_ids.shape[0]] = n
    return n


def boundary_loops(vol) -> BoundaryLoops:
    """Edge loops on ``vol``'s boundary generating H1 of each boundary component (tree-cotree).

    Parameters
    ----------
    vol : UnstructuredVolume

    Returns
    -------
    BoundaryLoops
        2g loops on a closed boundary component of genus g (none on a
        sphere); a non-manifold boundary edge adds a loop of its own.
    """
    bfn = np.ascontiguousarray(vol.boundary_face_nodes, np.int64)
    owner = np.ascontiguousarray(vol.boundary_faces[:, 0], np.int64)
    nb, k = bfn.shape
    z = np.zeros(0, np.int64)
    if nb == 0:
        return BoundaryLoops(np.zeros(1, np.int64), z, z, z, np.zeros((0, 2), np.int64))
    # boundary edges, numbered, and the face-edge rows (face * k + corner) of each
    ids, edges_g = vol.boundary_edge_table
    n_e = edges_g.shape[0]
    ef_off, ef_rows = _k.csr_from_keys(ids, n_e)
    edge_faces = ef_rows // k
    edge_cell = owner[edge_faces[ef_off[:-1]]]  # a cell holding each edge
    # compact node ids and the node graph (CSR, each neighbour with its edge)
    verts, edges = np.unique(edges_g, return_inverse=True)
    edges = edges.reshape(-1, 2).astype(np.int64)
    nv = verts.shape[0]
    ends = np.concatenate([edges[:, 0], edges[:, 1]])
    indptr, order = _k.csr_from_keys(ends, nv)
    other = np.concatenate([edges[:, 1], edges[:, 0]])[order]
    nbr_edge = np.concatenate([np.arange(n_e), np.arange(n_e)])[order]

    # a spanning tree per component, rooted at the middle of a double-sweep diameter
    dist = np.full(nv, -1, np.int64)
    pred = np.full(nv, -1, np.int64)
    pred_edge = np.full(nv, -1, np.int64)
    comp_of = _spanning_trees(indptr, other, nbr_edge, dist, pred, pred_edge)
    in_tree = np.zeros(n_e, np.bool_)
    in_tree[pred_edge[pred_edge >= 0]] = True
    left = np.flatnonzero(_cotree_leftover(ef_off, edge_faces, in_tree, nb))

    bad_edges, bad_nodes = boundary_defects(vol)
    lengths = dist[edges[left, 0]] + dist[edges[left, 1]] + 1
    offsets = np.zeros(left.shape[0] + 1, np.int64)
    nodes = _jit.scratch(int(lengths.sum()), np.int64)
    cells = _jit.scratch_like(nodes)
    n = _close_loops(edges, left.astype(np.int64), dist, pred, pred_edge, edge_cell, offsets, nodes, cells)
    return BoundaryLoops(offsets=offsets, nodes=verts[nodes[:n]], cells=cells[:n].copy(),
                         component=comp_of[edges[left, 0]], leftover_edges=edges_g[left],
                         nonmanifold_edges=int(bad_edges.shape[0]), nonmanifold_nodes=int(bad_nodes.size))
