"""Counts that check chapter 7's theorems on a volume: regions, unseeded parts, skeleton ends.

These are the quantities notebook 07 counts against the thesis's claims, computed from scratch
(not by the thinning or extrema-graph kernels they check):

* :func:`side_regions` -- the regions on the two sides of ``S = C`` (Thm 7.2: in a volume
  without through-holes, one more than the isosurface's parts);
* :func:`unseeded_parts` -- the parts of an isosurface that contain none of some seed cells
  (Thm 7.3, Fig. 7.11: an extrema graph's arcs miss a part only around a through-hole);
* :func:`end_cells` -- the cells of a set with exactly one face neighbour in it (Table 7.2: the
  skeleton's C1 cells are its ends, the marked cells at the extrema);
* :func:`first_removal_test` -- the first recorded thinning decision of a given kind, rebuilt by
  :func:`polygen.volume.thinning.removal_test` (Figs 7.6, 7.13);
* :func:`replay_tetra_decisions` -- every recorded decision of a tetrahedral thinning, checked
  against the thesis's rules of 7.5.2 applied from scratch to the state it saw.
"""

from __future__ import annotations

import numpy as np

from polygen.volume.errors import VolumeError
from polygen.volume.thinning import ThinningError, removal_test

__all__ = ["side_regions", "unseeded_parts", "end_cells", "first_removal_test", "replay_tetra_decisions"]


def _cell_ids(vol, cells, name):
    c = np.asarray(cells)
    if c.dtype == bool:
        if c.shape != (vol.n_cells,):
            raise VolumeError(f"{name} as a mask must have shape ({vol.n_cells},); got {c.shape}")
        return np.flatnonzero(c)
    c = c.astype(np.int64, casting="same_kind").ravel() if c.size else np.zeros(0, np.int64)
    if c.size and (c.min() < 0 or c.max() >= vol.n_cells):
        raise VolumeError(f"{name} must be cell ids in 0..{vol.n_cells - 1}; got {c.min()}..{c.max()}")
    return c


def side_regions(vol, scalars, value):
    """How many regions the isosurface ``S = value`` cuts the volume's nodes into.

    A region is a connected group of nodes on one side of ``value`` (``S < value`` or
    ``S >= value``) joined by the volume's edges -- in a tetrahedron the nodes on one side are
    joined by its edges, so these are the connected regions of the two sides (Thm 7.2, Fig. 7.10).

    Parameters
    ----------
    vol : UnstructuredVolume
    scalars : (N,) float64
        The field at the nodes.
    value : float

    Returns
    -------
    int
        Regions below plus regions at or above ``value`` (0 for an empty side).

    Raises
    ------
    VolumeError
        ``scalars`` not one finite value per node.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    s = np.asarray(scalars, np.float64)
    if s.shape != (vol.n_points,) or not np.all(np.isfinite(s)):
        raise VolumeError(f"scalars must be {vol.n_points} finite node values; got shape {s.shape}")
    edges = vol.edges
    n = 0
    for side in (s < value, s >= value):
        e = edges[side[edges[:, 0]] & side[edges[:, 1]]]
        graph = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(s.size, s.size))
        _, labels = connected_components(graph, directed=False)
        n += np.unique(labels[side]).size
    return int(n)


def unseeded_parts(iso, seed_cells):
    """The parts of an isosurface in which none of ``seed_cells`` lies.

    A part (:meth:`IsoSurface.triangle_components`) is reached from the seeds when one of its
    triangles lies in a seed cell; propagation from the seeds builds exactly the reached parts.

    Parameters
    ----------
    iso : IsoSurface
    seed_cells : (K,) int
        Cell ids, e.g. the seeds an extrema graph's arcs give (``seeds.cells[:seeds.n_from_arcs]``).

    Returns
    -------
    (P,) int64
        The component labels of the parts not reached, ascending.
    """
    comp = np.asarray(iso.triangle_components(), np.int64)
    reached = comp[np.isin(iso.triangle_cells, np.asarray(seed_cells, np.int64))]
    return np.setdiff1d(comp, reached).astype(np.int64)


def end_cells(vol, cells):
    """The cells of a set that have exactly one face neighbour in the set (its ends).

    Parameters
    ----------
    vol : UnstructuredVolume
    cells : (K,) int or (M,) bool
        The set, as cell ids or a mask (e.g. ``skeleton.cells`` or ``skeleton.mask()``).

    Returns
    -------
    (E,) int64
        Ascending cell ids.

    Raises
    ------
    VolumeError
        Ids out of range or a mask of the wrong length.
    """
    keep = np.zeros(vol.n_cells, bool)
    keep[_cell_ids(vol, cells, "cells")] = True
    nbr = vol.face_neighbors
    inside = (nbr >= 0) & keep[np.maximum(nbr, 0)]
    return np.flatnonzero(keep & (inside.sum(axis=1) == 1)).astype(np.int64)


def first_removal_test(vol, record, cls, removed, *, n_quad=None):
    """The first recorded thinning decision of class ``cls`` with outcome ``removed``, rebuilt.

    Parameters
    ----------
    vol : UnstructuredVolume
        The volume that was thinned.
    record : ThinningRecord
        From ``thin_volume(..., record=True)``.
    cls : int
        The class the cell was taken at (C1 .. C5).
    removed : bool
        The decision.
    n_quad : int, optional, keyword-only
        Also require this many quadruple-shared nodes (Def. 7.4).

    Returns
    -------
    RemovalTest
        As :func:`polygen.volume.thinning.removal_test` of the first matching decision.

    Raises
    ------
    ThinningError
        A record without decisions, or no decision that matches.
    """
    if record.decided_cell is None:
        raise ThinningError("this record has no decisions; thin with record=True")
    for k in np.flatnonzero((record.decided_class == cls) & (record.decided_removed == bool(removed))):
        test = removal_test(vol, record, k)
        if n_quad is None or test.quad_nodes.size == n_quad:
            return test
    raise ThinningError(f"no recorded C{cls} decision with removed={bool(removed)}"
                        + ("" if n_quad is None else f" and {n_quad} quadruple-shared nodes"))


def replay_tetra_decisions(vol, record):
    """Whether each recorded decision of a tetrahedral thinning is the thesis's rule (7.5.2).

    Replayed in plain Python on the state each test saw -- the cells removed before it
    (``record.decided_after``); ``n_B != 0`` for a node on the volume's boundary or on a removed
    cell -- a decision agrees when the cell had as many non-removed neighbours as its class and:
    C1 goes; C2 goes exactly when its triple-shared edge is inside the volume (not an edge of a
    boundary face) and every cell around that edge is still there (the walk from E_a reaches
    E_b); C3 goes exactly when its quadruple-shared node has ``n_B = 0``.

    Parameters
    ----------
    vol : UnstructuredVolume
        The tetrahedral volume that was thinned.
    record : ThinningRecord
        From ``thin_volume(vol, ..., record=True)``.

    Returns
    -------
    (D,) bool
        Per decision in ``record.decided_cell``: the replay agrees.

    Raises
    ------
    VolumeError
        A volume of hexahedra (their rules are others, Fig. 7.13).
    ThinningError
        A record without decisions.
    """
    if vol.cell_type != "tetra":
        raise VolumeError(f"the replay knows the tetrahedral rules; got a volume of {vol.cell_type}")
    if record.decided_cell is None:
        raise ThinningError("this record has no decisions; thin with record=True")
    off, node_cells = vol.node_cells
    bf = vol.boundary_face_nodes
    boundary_edges = {tuple(sorted(e)) for f in bf.tolist() for e in zip(f, f[1:] + f[:1])}
    gone, on_b = np.zeros(vol.n_cells, bool), np.zeros(vol.n_points, bool)
    on_b[bf.ravel()] = True
    agree = np.zeros(record.decided_cell.shape[0], bool)
    done = 0
    for k, (c, q, removed) in enumerate(zip(record.decided_cell.tolist(), record.decided_class.tolist(),
                                            record.decided_removed.tolist())):
        for x in record.removal_order[done:record.decided_after[k]]:
            gone[x], on_b[vol.cells[x]] = True, True
        done = record.decided_after[k]
        nb = [f for f in range(4) if vol.face_neighbors[c, f] >= 0 and not gone[vol.face_neighbors[c, f]]]
        if len(nb) != q:
            continue
        faces = [set(vol.cells[c, vol.local_faces[f]].tolist()) for f in nb]
        if q == 2:
            a, b = sorted(faces[0] & faces[1])
            around = np.intersect1d(node_cells[off[a]:off[a + 1]], node_cells[off[b]:off[b + 1]])
            rule = (a, b) not in boundary_edges and not gone[around].any()
        elif q == 3:
            rule = not on_b[next(iter(faces[0] & faces[1] & faces[2]))]
        else:
            rule = q == 1
        agree[k] = rule == removed
    return agree
