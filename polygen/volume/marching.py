"""Marching tetrahedra and marching hexahedra (thesis 5.3.1, Fig. 5.4).

The case tables are generated here, from the local edges and faces of
:mod:`polygen.volume.mesh`, never typed in; the numba kernels below turn a
cell's node values into triangles whose corners are *vertex codes*.

Conventions (the same everywhere in polygen):

* **Above / below.** A node is *above* the isovalue ``C`` when ``S >= C``
  and *below* when ``S < C`` (the choice VTK makes too). A cell is
  *intersected* when it has nodes of both kinds; an edge is *crossed* when
  its ends differ. On a crossed edge the lower end is strictly below ``C``,
  so the crossing (5.2) never divides by zero.
* **Vertex identity.** One vertex per crossed cell edge, shared by every
  cell around the edge. The one exception: when the upper end of a crossed
  edge equals ``C`` exactly the crossing *is* that node, and every crossing
  that lands on the node is the same vertex (keyed by the node, not the
  edge). Triangles that then repeat a vertex have zero area and are dropped,
  and a face lying exactly at ``C`` between two cells whose other nodes are
  below is kept once (see ``isosurface._drop_double_faces``). VTK's
  ``contour`` (9.x) merges per edge only: there it keeps the zero-area
  triangles, several points at one node and both copies of such a face;
  its non-degenerate triangles are ours.
* **Orientation.** Every triangle's normal (right-hand rule) points from the
  below side to the above side, i.e. towards increasing scalar, in
  positively oriented cells (the volume model rejects inverted cells).
* **Tetrahedra.** The crossing is a triangle or a quadrilateral. The field
  is linear in a tetrahedron, so the quadrilateral is planar and either
  diagonal gives the same area; we split it along the same diagonal as
  VTK's ``vtkTetra`` case table anyway (a fixed choice per case, i.e. per
  local node order, not a geometric rule: ``_VTK_QUAD_DIAGONAL``), so our
  surface is VTK's triangle for triangle.
* **Hexahedra.** A face whose above corners are diagonal to each other is
  *ambiguous*. We resolve it by the value at the face centre, the mean of its
  four node values (Wyvill et al. [71] in the thesis): if the centre is above,
  the two above corners are joined across the face and the below corners are
  cut off, otherwise the above corners are cut off. The rule depends only on
  the face's four values (summed in sorted order, so both cells that share
  the face compute the same bits), hence the two cells agree on the face's
  segments and the surface is watertight. The polygons are the closed
  polylines that these face segments form; each is split into a fan of
  triangles.

Table layout: ``tri_table[case, 3*t + j]`` is the local edge of corner
``j`` of triangle ``t`` and ``tri_count[case]`` the number of triangles. A
tetrahedral case is 4 bits (bit ``i`` = node ``i`` above); a hexahedral
case is 8 node bits plus 6 face bits (bit ``8 + f`` = the centre of
ambiguous face ``f`` is above).
"""

from __future__ import annotations

import functools

import numpy as np

from polygen._jit import njit, prange
from polygen.volume._cells import HEX_EDGES, HEX_FACES, HEX_UNIT_CORNERS, KUHN_TETS, TET_EDGES, TET_UNIT_CORNERS

__all__ = [
    "TET_EDGES",
    "HEX_EDGES",
    "HEX_FACES",
    "tet_case_table",
    "hex_case_table",
    "hex_cell_cases",
    "case_table",
    "hex_to_tets",
    "HEX_TO_6_TETS",
]

#: Most triangles a hexahedral case emits (12 crossed edges in one polygon give 10).
MAX_TRIANGLES = 12

# VTK's vtkTetra triCases split each quadrilateral crossing along a fixed
# diagonal chosen per case (it depends on the case index, i.e. on the local
# node order, not on geometry). For a case with two above nodes, the quad's
# vertices lie on the four edges joining above to below nodes; the diagonal
# joins the crossings on the two edges listed here. Read off vtkTetra.cxx
# (VTK 9): case 3 -> (0,2)-(1,3), 5 -> (0,3)-(1,2), 6 -> (0,1)-(2,3),
# 9 -> (0,1)-(2,3), 10 -> (0,1)-(2,3), 12 -> (0,3)-(1,2).
_VTK_QUAD_DIAGONAL = {
    3: ((0, 2), (1, 3)),
    5: ((0, 3), (1, 2)),
    6: ((0, 1), (2, 3)),
    9: ((0, 1), (2, 3)),
    10: ((0, 1), (2, 3)),
    12: ((0, 3), (1, 2)),
}

# Reference cells (positive orientation) used to orient the generated polygons.
_TET_REF = TET_UNIT_CORNERS.astype(float)
_HEX_REF = HEX_UNIT_CORNERS.astype(float)


def _edge_index(local_edges):
    return {frozenset(map(int, e)): i for i, e in enumerate(local_edges)}


def _orient(poly, above, local_edges, ref):
    """Reverse ``poly`` (local edges, cyclic) unless its normal points below -> above."""
    mid = np.array([ref[local_edges[e]].mean(axis=0) for e in poly])
    normal = np.zeros(3)
    for i in range(len(poly)):  # Newell's normal, fine for non-planar polygons
        normal += np.cross(mid[i], mid[(i + 1) % len(poly)])
    up = np.zeros(3)
    for e in poly:
        a, b = local_edges[e]
        up += (ref[a] - ref[b]) if above[a] else (ref[b] - ref[a])
    d = float(normal @ up)
    if abs(d) < 1e-12:
        raise AssertionError(f"cannot orient polygon {poly}")  # never happens; the tests check
    return list(poly) if d > 0 else list(poly[::-1])


def _fan(poly):
    return [(poly[0], poly[i], poly[i + 1]) for i in range(1, len(poly) - 1)]


def _pack(cases_tris, n_cases, width):
    table = np.full((n_cases, 3 * width), -1, np.int8)
    count = np.zeros(n_cases, np.int8)
    for case, tris in cases_tris.items():
        count[case] = len(tris)
        for t, tri in enumerate(tris):
            table[case, 3 * t:3 * t + 3] = tri
    return table, count


@functools.cache
def tet_case_table():
    """Marching-tetrahedra table ``(tri_table (16, 6) int8, tri_count (16,) int8)``.

    Local edges are :data:`TET_EDGES`; bit ``i`` of the case is node ``i``
    above (``S >= C``). Triangles point towards increasing scalar;
    quadrilaterals are split as in VTK's ``vtkTetra``.
    """
    eidx = _edge_index(TET_EDGES)
    out = {}
    for case in range(16):
        above = [(case >> i) & 1 for i in range(4)]
        up = [i for i in range(4) if above[i]]
        down = [i for i in range(4) if not above[i]]
        if not up or not down:
            out[case] = []
            continue
        if len(up) != 2:
            lone, others = (up[0], down) if len(up) == 1 else (down[0], up)
            poly = [eidx[frozenset((lone, o))] for o in others]
            out[case] = [tuple(_orient(poly, above, TET_EDGES, _TET_REF))]
            continue
        (a, b), (c, d) = up, down
        cyc = [eidx[frozenset(p)] for p in ((a, c), (a, d), (b, d), (b, c))]  # quad, cyclic
        diag = {eidx[frozenset(p)] for p in _VTK_QUAD_DIAGONAL[case]}
        poly = _orient(cyc, above, TET_EDGES, _TET_REF)
        k = next(i for i in range(4) if poly[i] in diag)  # start the fan at a diagonal end
        out[case] = _fan(poly[k:] + poly[:k])
    return _pack(out, 16, 2)


@functools.cache
def _hex_geometry():
    eidx = _edge_index(HEX_EDGES)
    mid = _HEX_REF[HEX_EDGES].mean(axis=1)
    x = _HEX_REF[HEX_FACES]
    face_n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])  # outward for the positive reference cell
    return eidx, mid, face_n


def _triple(a, b, c):
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


def hex_polygons(case):
    """The closed polylines (lists of local edges) of hexahedral ``case`` (14 bits).

    Built face by face: each face with a sign change contributes one segment
    (two crossed edges) or, when ambiguous, two segments chosen by the face
    bit; every crossed edge lies on two faces, so the segments chain into
    closed loops. Each loop is oriented so that its normal points towards
    the above side: along a segment on face ``f`` (outward normal ``n``)
    running in direction ``t``, with ``u`` pointing across the face towards
    the above side of the segment, the loop turns so that ``(u x t) . n < 0``
    (the cell interior lies on the left of the loop). This is decided on one
    face at a time, so symmetric saddles need no special case.
    """
    above = [(case >> i) & 1 for i in range(8)]
    eidx, mid, face_n = _hex_geometry()
    link = {}
    rule = {}  # (e1, e2) -> sign that travelling e1 -> e2 is correct
    for f, q in enumerate(HEX_FACES):
        q = [int(v) for v in q]
        x = _HEX_REF[q]
        n = face_n[f]
        fe = [eidx[frozenset((q[i], q[(i + 1) % 4]))] for i in range(4)]  # edge i joins q[i], q[i+1]
        crossed = [i for i in range(4) if above[q[i]] != above[q[(i + 1) % 4]]]
        segs = []
        if len(crossed) == 2:
            up = [i for i in range(4) if above[q[i]]]
            down = [i for i in range(4) if not above[q[i]]]
            u = x[up].mean(axis=0) - x[down].mean(axis=0)
            segs = [(fe[crossed[0]], fe[crossed[1]], u)]
        elif len(crossed) == 4:
            centre_above = (case >> (8 + f)) & 1
            # cut off the corners of the side that is NOT joined through the centre
            for i in range(4):
                if above[q[i]] != centre_above:
                    e1, e2 = fe[(i - 1) % 4], fe[i]  # the two face edges at corner q[i]
                    u = x[i] - (mid[e1] + mid[e2]) / 2
                    segs.append((e1, e2, u if above[q[i]] else -u))
        for e1, e2, u in segs:
            link.setdefault(e1, []).append(e2)
            link.setdefault(e2, []).append(e1)
            ok = _triple(u, mid[e2] - mid[e1], n) < 0
            rule[(e1, e2)] = ok
            rule[(e2, e1)] = not ok
    polys, seen = [], set()
    for start in sorted(link):
        if start in seen:
            continue
        poly, prev, cur = [start], None, start
        seen.add(start)
        while True:
            nxt = link[cur][0] if link[cur][0] != prev else link[cur][1]
            if nxt == start:
                break
            poly.append(nxt)
            seen.add(nxt)
            prev, cur = cur, nxt
        votes = [rule[(poly[i], poly[(i + 1) % len(poly)])] for i in range(len(poly))]
        if all(votes):
            polys.append(poly)
        elif not any(votes):
            polys.append(poly[::-1])
        else:  # pragma: no cover - the tests check every case
            raise AssertionError(f"inconsistent orientation for hexahedral case {case}: {poly}")
    return polys


def hex_ambiguous_faces(node_case):
    """Local faces of the hexahedron that are ambiguous for the 8-bit ``node_case``."""
    out = []
    for f, q in enumerate(HEX_FACES):
        b = [(node_case >> int(v)) & 1 for v in q]
        if b[0] == b[2] and b[1] == b[3] and b[0] != b[1]:
            out.append(f)
    return out


@functools.cache
def hex_case_table():
    """Marching-hexahedra table ``(tri_table (16384, 36) int8, tri_count (16384,) int8)``.

    Index = 8 node bits | 6 face-centre bits << 8 (only the bits of ambiguous
    faces matter; the others are ignored, so their entries repeat). Local
    edges are :data:`HEX_EDGES`, faces :data:`HEX_FACES`.
    """
    out = {}
    for node_case in range(256):
        amb = hex_ambiguous_faces(node_case)
        for fbits in range(64):
            masked = sum(1 << f for f in amb if (fbits >> f) & 1)
            case = node_case | (fbits << 8)
            key = node_case | (masked << 8)
            if key in out:
                out[case] = out[key]
                continue
            tris = []
            for poly in hex_polygons(key):
                tris += _fan(poly)
            out[key] = out[case] = tris
    return _pack(out, 1 << 14, MAX_TRIANGLES)


def hex_cell_cases(cells, s, value):
    """Per hexahedron: its node case, its ambiguous faces and how each is decided at ``S = value``.

    The same classification as the marching kernel (a node is above when
    ``S >= C``; an ambiguous face's centre is the mean of its four corners,
    summed in sorted order), in numpy, for comparisons and figures.

    Parameters
    ----------
    cells : (M, 8) int64
    s : (N,) float64
    value : float

    Returns
    -------
    node_case : (M,) int64
        8 node bits; 0 and 255 are cells the surface does not cross.
    n_ambiguous : (M,) int64
        Faces whose above corners are diagonal to each other.
    n_centre_above : (M,) int64
        Of those, faces whose centre is above: there the above corners are joined.
    code : (M,) int64
        The index into :func:`hex_case_table` (node bits | centre bits << 8).
    """
    cells = np.asarray(cells)
    if cells.ndim != 2 or cells.shape[1] != 8:
        raise ValueError(f"cells must have shape (M, 8); got {cells.shape}")
    sv = np.asarray(s, np.float64)[cells]
    above = sv >= value
    node_case = (above.astype(np.int64) << np.arange(8)).sum(axis=1)
    q = np.asarray(HEX_FACES)
    a = above[:, q]  # (M, 6, 4) corners of each face, in cyclic order
    amb = (a[..., 0] == a[..., 2]) & (a[..., 1] == a[..., 3]) & (a[..., 0] != a[..., 1])
    v = np.sort(sv[:, q], axis=2)
    centre = (((v[..., 0] + v[..., 1]) + v[..., 2]) + v[..., 3]) * 0.25 >= value
    up = amb & centre
    code = node_case | ((up.astype(np.int64) << np.arange(6)).sum(axis=1) << 8)
    return node_case, amb.sum(axis=1), up.sum(axis=1), code


def case_table(cell_type):
    """``tet_case_table()`` or ``hex_case_table()`` for ``'tetra'`` / ``'hexa'``."""
    if cell_type == "tetra":
        return tet_case_table()
    if cell_type == "hexa":
        return hex_case_table()
    raise ValueError(f"cell_type must be 'tetra' or 'hexa'; got {cell_type!r}")


@functools.cache
def crossed_counts(cell_type):
    """(n_cases,) int64: how many local edges each case crosses."""
    table, _ = case_table(cell_type)
    local_edges = TET_EDGES if cell_type == "tetra" else HEX_EDGES
    case = np.arange(table.shape[0])
    above = (case[:, None] >> np.arange(local_edges.max() + 1)) & 1
    return np.count_nonzero(above[:, local_edges[:, 0]] != above[:, local_edges[:, 1]], axis=1).astype(np.int64)


def local_tables(cell_type):
    """``(tri_table, tri_count, local_edges, local_faces)`` ready for the kernels."""
    table, count = case_table(cell_type)
    if cell_type == "tetra":
        return table, count, TET_EDGES, np.zeros((0, 4), np.int64)
    return table, count, HEX_EDGES, np.ascontiguousarray(HEX_FACES, np.int64)


# ---------------------------------------------------------------- hex -> tets
#: (6, 4) local hexahedron nodes of the Kuhn split along the diagonal 0-6, positive tets
#: (:data:`polygen.volume._cells.KUHN_TETS`).
HEX_TO_6_TETS = KUHN_TETS


def hex_to_tets(cells):
    """Split hexahedra into 6 tetrahedra each along their diagonal 0-6.

    Parameters
    ----------
    cells : (M, 8) int64
        Hexahedra in VTK node order.

    Returns
    -------
    tets : (6M, 4) int64
        Positively oriented tetrahedra (rows ``6c .. 6c+5`` come from cell ``c``).
        The split is conforming between neighbours whose local axes agree, as on
        any structured grid; it is not guaranteed on arbitrary hexahedral meshes.
    """
    cells = np.asarray(cells)
    if cells.ndim != 2 or cells.shape[1] != 8:
        raise ValueError(f"cells must have shape (M, 8); got {cells.shape}")
    return cells[:, HEX_TO_6_TETS].reshape(-1, 4).astype(np.int64)


# =================================================================== kernels
@njit
def _sorted_sum4(a, b, c, d):
    # a sorting network, so the sum is the same for any order of the 4 values
    if a > b:
        a, b = b, a
    if c > d:
        c, d = d, c
    if a > c:
        a, c = c, a
    if b > d:
        b, d = d, b
    if b > c:
        b, c = c, b
    return ((a + b) + c) + d


@njit
def _cell_case(cells, c, s, value, faces):
    """Case index of cell ``c``, or -1 when it is not intersected.

    ``cells`` (M, 4|8) node ids, ``s`` (N,) node values, ``faces`` the
    local faces (empty for tetrahedra).
    """
    return _cell_case_n(cells, c, cells.shape[1], s, value, faces)


@njit
def _cell_case_n(cells, c, nn, s, value, faces):
    """:func:`_cell_case` for rows whose first ``nn`` entries are the nodes (cell records)."""
    case = 0
    for i in range(nn):
        if s[cells[c, i]] >= value:
            case |= 1 << i
    if case == 0 or case == (1 << nn) - 1:
        return -1
    for f in range(faces.shape[0]):
        a = s[cells[c, faces[f, 0]]]
        b = s[cells[c, faces[f, 1]]]
        d = s[cells[c, faces[f, 2]]]
        e = s[cells[c, faces[f, 3]]]
        ua, ub, ud, ue = a >= value, b >= value, d >= value, e >= value
        if ua == ud and ub == ue and ua != ub:
            # face-centre value [71]: the mean of the four corners
            if _sorted_sum4(a, b, d, e) * 0.25 >= value:
                case |= 1 << (8 + f)
    return case


@njit
def _cell_codes(cells, c, s, value, case, tri_table, tri_count, local_edges, out):
    """Triangles of cell ``c`` as local vertex codes; returns how many were kept.

    ``out`` (MAX_TRIANGLES, 3) int64 receives the codes: ``e`` for the
    crossing on local edge ``e``; ``16 + i`` when the crossing is node ``i``
    itself (its value equals ``value``). Triangles repeating a code are
    dropped (zero area).
    """
    k = 0
    for t in range(tri_count[case]):
        for j in range(3):
            e = tri_table[case, 3 * t + j]
            a = local_edges[e, 0]
            b = local_edges[e, 1]
            sa = s[cells[c, a]]
            hi = a if sa >= value else b
            if s[cells[c, hi]] == value:
                out[k, j] = 16 + hi
            else:
                out[k, j] = e
        if out[k, 0] != out[k, 1] and out[k, 0] != out[k, 2] and out[k, 1] != out[k, 2]:
            k += 1
    return k


@njit
def _code_key(code, cell, cells, cell_edges, n_edges):
    """Global vertex key of a local code: an edge id, or ``n_edges + node``."""
    if code < 16:
        return cell_edges[cell, code]
    return n_edges + cells[cell, code - 16]


@njit
def _pair_code(code, c, cells, local_edges, n_points):
    """Node-pair key of a local vertex code: ``a * N + b`` (``a < b``) for the crossing on edge
    ``(a, b)``, ``p * N + p`` for node ``p`` itself. Needs no edge table."""
    if code >= 16:
        p = cells[c, code - 16]
        return p * n_points + p
    a = cells[c, local_edges[code, 0]]
    b = cells[c, local_edges[code, 1]]
    if a < b:
        return a * n_points + b
    return b * n_points + a


@njit
def _n_distinct_codes(tris, k):
    """How many distinct codes the first ``k`` triangles use (codes are < 24)."""
    mask = 0
    for t in range(k):
        for j in range(3):
            mask |= 1 << tris[t, j]
    n = 0
    while mask:
        mask &= mask - 1
        n += 1
    return n


@njit(parallel=True)
def _scan_count(cells, s, value, faces, tri_table, tri_count, n_crossed, local_edges, chunk,
                cases, chunk_cells, chunk_tris, chunk_lookups):
    # pass 1 (t1): classify every cell, remember its case, count per chunk
    m = cells.shape[0]
    nn = cells.shape[1]
    full = (1 << nn) - 1
    nch = chunk_cells.shape[0]
    for ch in prange(nch):
        lo = ch * chunk
        hi = min(m, lo + chunk)
        nc = 0
        nt = 0
        nl = 0
        careful = faces.shape[0] > 0  # hexahedra: face bits change the case
        # branch-free first sweep (it vectorises): node bits, counts, exact hits
        for c in range(lo, hi):
            case = 0
            eq = 0
            for i in range(nn):
                sv = s[cells[c, i]]
                case |= np.int32(sv >= value) << i
                eq |= np.int32(sv == value)
            inside = np.int32(case != 0) & np.int32(case != full)
            cases[c] = case if inside else -1
            nc += inside
            nt += tri_count[case]
            nl += n_crossed[case]
            careful |= (eq & inside) != 0
        if careful:
            # again, cell by cell: face-centre bits, vanishing triangles on exact hits
            tris = np.empty((MAX_TRIANGLES, 3), np.int64)
            nt = 0
            nl = 0
            for c in range(lo, hi):
                if cases[c] < 0:
                    continue
                case = _cell_case(cells, c, s, value, faces)
                cases[c] = case
                k = _cell_codes(cells, c, s, value, case, tri_table, tri_count, local_edges, tris)
                nt += k
                nl += _n_distinct_codes(tris, k)
        chunk_cells[ch] = nc
        chunk_tris[ch] = nt
        chunk_lookups[ch] = nl


@njit(parallel=True)
def _scan_fill(cells, s, value, cell_edges, n_edges, n_points, pairs, tri_table, tri_count, local_edges, chunk,
               cases, tri_off, tri_keys, tri_cell):
    # pass 2 (t2): emit the triangles of the intersected cells, each corner as a global vertex key --
    # an edge id or n_edges + node (_code_key), or with ``pairs`` the node pair of its edge, which
    # needs no edge table (_pair_code; ``cell_edges`` is then unread and may be empty)
    m = cells.shape[0]
    nch = tri_off.shape[0] - 1
    for ch in prange(nch):
        lo = ch * chunk
        hi = min(m, lo + chunk)
        tris = np.empty((MAX_TRIANGLES, 3), np.int64)
        it = tri_off[ch]
        for c in range(lo, hi):
            case = cases[c]
            if case < 0:
                continue
            k = _cell_codes(cells, c, s, value, case, tri_table, tri_count, local_edges, tris)
            for t in range(k):
                for j in range(3):
                    if pairs:
                        tri_keys[it, j] = _pair_code(tris[t, j], c, cells, local_edges, n_points)
                    else:
                        tri_keys[it, j] = _code_key(tris[t, j], c, cells, cell_edges, n_edges)
                tri_cell[it] = c
                it += 1


@njit
def _number_vertices(tri_keys, seen, vid, keys, tris):
    """One vertex per distinct key, numbered in order of first use; returns the count.

    ``seen`` (K,) uint8 zeros; ``vid`` (K,) int32 scratch, only read where
    ``seen``; ``keys`` (>= V,) receives the key of each vertex; ``tris``
    the triangles as vertex ids. O(T): nothing of the volume's size is swept.
    """
    n = 0
    for t in range(tri_keys.shape[0]):
        for j in range(3):
            k = tri_keys[t, j]
            if not seen[k]:
                seen[k] = 1
                vid[k] = n
                keys[n] = k
                n += 1
            tris[t, j] = vid[k]
    return n


@njit
def _vertex_positions(keys, edges, points, s, value, out):
    """(5.2) crossing points of the vertices with global ``keys`` (t3)."""
    n_edges = edges.shape[0]
    for v in range(keys.shape[0]):
        k = keys[v]
        if k >= n_edges:
            p = k - n_edges
            for d in range(3):
                out[v, d] = points[p, d]
        else:
            a = edges[k, 0]
            b = edges[k, 1]
            c1 = s[a]
            c2 = s[b]
            # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
            for d in range(3):
                out[v, d] = ((value - c1) * points[b, d] - (value - c2) * points[a, d]) / (c2 - c1)


@njit(inline="always")
def triangle_normal(vertices, i0, i1, i2):
    """``(nx, ny, nz)``: (v1 - v0) x (v2 - v0) of the triangle ``i0, i1, i2`` of ``vertices (V, 3)``,
    twice its area along its normal; the one expression every normal sum here is made of (bit for bit)."""
    ux = vertices[i1, 0] - vertices[i0, 0]
    uy = vertices[i1, 1] - vertices[i0, 1]
    uz = vertices[i1, 2] - vertices[i0, 2]
    wx = vertices[i2, 0] - vertices[i0, 0]
    wy = vertices[i2, 1] - vertices[i0, 1]
    wz = vertices[i2, 2] - vertices[i0, 2]
    return uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx


@njit
def _mean_normals(vertices, triangles, out):
    """Vertex normals = mean of the adjacent triangle normals (thesis 5.3.1), area-weighted.

    Weighting by area makes the sum over the fan of one polygon equal to the
    polygon's own (Newell) normal times its area, so the way a polygon was
    split into triangles does not matter and slivers cannot tilt a normal.
    """
    out[:] = 0.0
    for t in range(triangles.shape[0]):
        i0 = triangles[t, 0]
        i1 = triangles[t, 1]
        i2 = triangles[t, 2]
        nx, ny, nz = triangle_normal(vertices, i0, i1, i2)
        for i in (i0, i1, i2):
            out[i, 0] += nx
            out[i, 1] += ny
            out[i, 2] += nz
    _normalize(out)


@njit
def zero_rows(nrm):
    """(K,) int64, ascending: the rows of ``nrm (V, 3)`` whose ``|x| + |y| + |z|`` is not > 0 (zero or NaN).

    One pass, no temporaries: numpy's ``flatnonzero(~(abs(nrm).sum(axis=1) > 0))`` took as long as the
    mean normals themselves (2M, 20 values: 25 ms against 27).
    """
    n = 0
    for v in range(nrm.shape[0]):
        if not (abs(nrm[v, 0]) + abs(nrm[v, 1]) + abs(nrm[v, 2]) > 0.0):
            n += 1
    out = np.empty(n, np.int64)
    k = 0
    for v in range(nrm.shape[0]):
        if not (abs(nrm[v, 0]) + abs(nrm[v, 1]) + abs(nrm[v, 2]) > 0.0):
            out[k] = v
            k += 1
    return out


@njit
def _normalize(out):
    """Each row of ``out`` (V, 3) to unit length in place (:func:`unit_into`; a zero row stays zero)."""
    for v in range(out.shape[0]):
        unit_into(out[v, 0], out[v, 1], out[v, 2], out, v)


@njit(inline="always")
def unit_into(x, y, z, out, v):
    """``out[v] = (x, y, z) / |(x, y, z)|`` (a zero vector as it is): the one normalisation of the summed
    vertex normals (:func:`_normalize` and :func:`normalised` too); returns 1 where the row is zero (or
    not finite: :func:`zero_rows` lists it), else 0."""
    ln = np.sqrt(x ** 2 + y ** 2 + z ** 2)
    if ln > 0.0:
        x /= ln
        y /= ln
        z /= ln
    out[v, 0] = x
    out[v, 1] = y
    out[v, 2] = z
    return 0 if abs(x) + abs(y) + abs(z) > 0.0 else 1


@njit
def normalised(sums, out):
    """``out[v] = sums[v] / |sums[v]|`` for the rows of ``out`` (V, 3) (:func:`unit_into`); returns how
    many rows :func:`zero_rows` would list. ``sums`` (>= V, 3) float64."""
    n_zero = 0
    for v in range(out.shape[0]):
        n_zero += unit_into(sums[v, 0], sums[v, 1], sums[v, 2], out, v)
    return n_zero


@njit
def _gradient_normals(keys, edges, s, value, node_grad, out):
    """Vertex normals from the node gradients interpolated along the edge (unit length)."""
    n_edges = edges.shape[0]
    for v in range(keys.shape[0]):
        k = keys[v]
        if k >= n_edges:
            for d in range(3):
                out[v, d] = node_grad[k - n_edges, d]
        else:
            a = edges[k, 0]
            b = edges[k, 1]
            t = (value - s[a]) / (s[b] - s[a])
            for d in range(3):
                out[v, d] = (1.0 - t) * node_grad[a, d] + t * node_grad[b, d]
        ln = np.sqrt(out[v, 0] ** 2 + out[v, 1] ** 2 + out[v, 2] ** 2)
        if ln > 0.0:
            for d in range(3):
                out[v, d] /= ln


# reference-cell derivatives of the trilinear shape functions at the centre
_HEX_DN = np.array([[(2 * p[0] - 1) * 0.25, (2 * p[1] - 1) * 0.25, (2 * p[2] - 1) * 0.25] for p in _HEX_REF])


@njit
def _node_gradients(points, cells, s, hex_dn, out):
    """Volume-weighted mean over the cells around each node of the cell gradient.

    Tetrahedra: the exact (constant) gradient of the linear interpolant;
    hexahedra: the trilinear gradient at the cell centre (``hex_dn`` (8, 3)).
    """
    out[:] = 0.0
    wsum = np.zeros(points.shape[0])
    nn = cells.shape[1]
    jac = np.empty((3, 3))
    rhs = np.empty(3)
    for c in range(cells.shape[0]):
        jac[:] = 0.0
        rhs[:] = 0.0
        if nn == 4:
            p0 = cells[c, 0]
            for r in range(3):
                q = cells[c, r + 1]
                for d in range(3):
                    jac[r, d] = points[q, d] - points[p0, d]
                rhs[r] = s[q] - s[p0]
        else:
            for i in range(8):
                q = cells[c, i]
                for r in range(3):
                    for d in range(3):
                        jac[r, d] += hex_dn[i, r] * points[q, d]
                    rhs[r] += hex_dn[i, r] * s[q]
        det = np.linalg.det(jac)
        if det == 0.0:
            continue
        g = np.linalg.solve(jac, rhs)
        w = abs(det)
        for i in range(nn):
            q = cells[c, i]
            wsum[q] += w
            for d in range(3):
                out[q, d] += w * g[d]
    for q in range(points.shape[0]):
        if wsum[q] > 0.0:
            for d in range(3):
                out[q, d] /= wsum[q]


# ------------------------------------------- the scan without prepared topology
@njit
def _number_pair_codes(tri_codes, n_points, shift, table_keys, table_vals, codes, tris, edges, keys):
    """One vertex per distinct node-pair code, numbered in order of first use (as
    :func:`_number_vertices`, so the numbering is the full scan's); returns the count.

    An open-addressing hash table (``table_keys`` (H,) int64 all -1, ``H`` a
    power of two ``2**(64 - shift)``; ``table_vals`` (H,) int32 or int64
    scratch) replaces the volume-sized ``seen`` array: only the crossed
    edges are touched. Fills ``codes`` (V,), ``tris`` (T, 3) vertex ids,
    ``edges`` (V, 2) the node pair of each vertex and ``keys`` (V,) its key
    in the numbering of ``edges``: ``v`` on an edge, ``V_max + node`` on a
    node, with ``V_max = edges.shape[0]`` (what :func:`_vertex_positions` reads).
    Returns -1 instead, at once, when the codes are more than ``H / 2`` (the
    table was sized from an estimate: the caller sizes it again and starts
    over; nothing written so far is kept).
    """
    n_slots = table_keys.shape[0]
    n_edges = edges.shape[0]
    n_max = n_slots // 2
    n = 0
    for t in range(tri_codes.shape[0]):
        for j in range(3):
            k = tri_codes[t, j]
            h = np.int64((np.uint64(k) * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(shift))
            while True:
                cur = table_keys[h]
                if cur == k:
                    tris[t, j] = table_vals[h]
                    break
                if cur == -1:
                    if n == n_max:
                        return -1
                    table_keys[h] = k
                    table_vals[h] = n
                    codes[n] = k
                    a = k // n_points
                    b = k - a * n_points
                    edges[n, 0] = a
                    edges[n, 1] = b
                    keys[n] = n if a != b else n_edges + a
                    tris[t, j] = n
                    n += 1
                    break
                h += 1
                if h == n_slots:
                    h = 0
    return n


@njit
def crossing_points(vend, n_v, points, s, value, out):
    """(5.2) crossing points from the edge ends (the smaller node id first, as in ``mesh.edges``).

    ``out[v]`` for the first ``n_v`` rows of ``vend`` (V, 2) int; ``a == b`` (a node at the value): the node.
    """
    for v in range(n_v):
        a = vend[v, 0]
        b = vend[v, 1]
        if a == b:
            for d in range(3):
                out[v, d] = points[a, d]
        else:
            c1 = s[a]
            c2 = s[b]
            # (5.2) P_c = ((C - C1) P2 - (C - C2) P1) / (C2 - C1)
            for d in range(3):
                out[v, d] = ((value - c1) * points[b, d] - (value - c2) * points[a, d]) / (c2 - c1)
