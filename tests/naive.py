"""Slow, obviously correct reference implementations the tests compare polygen against (as stumpy's).

Brute force over all nodes, cells or pairs with numpy and scipy; for small inputs only.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def brute_extrema(cells, s):
    """Defs 6.3/6.4 (ties allowed), one representative (lowest id candidate) per flat group."""
    n = s.shape[0]
    k = cells.shape[1]
    rows = np.repeat(cells, k, axis=1).ravel()
    cols = np.tile(cells, (1, k)).ravel()
    star_max = np.full(n, -np.inf)
    star_min = np.full(n, np.inf)
    np.maximum.at(star_max, rows, s[cols])
    np.minimum.at(star_min, rows, s[cols])
    eq = s[rows] == s[cols]
    g = coo_matrix((np.ones(eq.sum()), (rows[eq], cols[eq])), shape=(n, n))
    _, group = connected_components(g, directed=False)
    out = {}
    for kind, cand in (("max", s >= star_max), ("min", s <= star_min)):
        reps = {}
        for v in np.flatnonzero(cand):
            reps.setdefault(group[v], v)
        out[kind] = np.array(sorted(reps.values()), np.int64)
    return out


def cell_graph_components(vol, alive):
    """Face-connected components of the cells where ``alive``; -1 elsewhere."""
    nb = vol.face_neighbors
    c, f = np.nonzero(nb >= 0)
    keep = alive[c] & alive[nb[c, f]]
    m = vol.n_cells
    _, lab = connected_components(coo_matrix((np.ones(keep.sum()), (c[keep], nb[c, f][keep])), shape=(m, m)),
                                  directed=False)
    return np.where(alive, lab, -1)


def intersected_components(vol, s, value):
    """Cells the surface ``S = value`` crosses (``S_min < C <= S_max``) and their face-connected parts (-1 elsewhere)."""
    cmin = s[vol.cells].min(axis=1)
    cmax = s[vol.cells].max(axis=1)
    hit = (cmin < value) & (value <= cmax)
    return hit, cell_graph_components(vol, hit)


def one_seed_per_component(vol, iso):
    """One intersected cell in each face-connected group of intersected cells (brute force)."""
    cells = np.unique(iso.triangle_cells)
    inside = np.zeros(vol.n_cells, bool)
    inside[cells] = True
    nb = vol.face_neighbors
    c, f = np.nonzero((nb >= 0) & inside[:, None])
    keep = inside[nb[c, f]]
    g = coo_matrix((np.ones(keep.sum()), (c[keep], nb[c, f][keep])), shape=(vol.n_cells,) * 2)
    _, labels = connected_components(g, directed=False)
    _, first = np.unique(labels[cells], return_index=True)
    return cells[first]
