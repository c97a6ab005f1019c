"""Adaptive subdivision (thesis Def. 2.6) by longest-edge bisection: quality, conformity, patches.

Oracles: the smallest angle of every longest-edge bisection (LEB) descendant
of a triangle, found by enumerating its similarity classes (brute force);
Rosenberg & Stenger's bound (no LEB descendant has an angle below half the
smallest angle of the triangle it came from); the 20 degree floor of issue
13; areas of children adding up to their parent's; the T-vertex detector;
V - E + F of a conforming mesh.
"""

import math

import numpy as np
import pytest
from scipy.spatial import Delaunay

from polygen.mesh2d import (
    adaptive_subdivision,
    bubble_mesh,
    find_t_vertices,
    mesh_edges,
    refine_marked,
    triangle_areas,
    triangle_quality,
    validate_domain,
)
from polygen.mesh2d.subdivision import _longest_edge_refine
from polygen.radiosity import mesh_scene, progressive_refinement
from polygen.radiosity.adaptive import adaptive_refine, element_jumps, mark_jumps
from polygen.radiosity.mesh import MeshError
from polygen.radiosity.scene import AreaLight, Polygon, Scene

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def circle(cx, cy, r, k):
    th = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    return np.c_[cx + r * np.cos(th), cy + r * np.sin(th)][::-1]


def jump(xy):
    """A value field with a sharp jump along a circle: refinement concentrates and repeats there."""
    return (np.hypot(xy[:, 0] - 0.3, xy[:, 1] - 0.35) < 0.45).astype(float)


def angles_of(p):
    a = np.linalg.norm(p[1] - p[2])
    b = np.linalg.norm(p[2] - p[0])
    c = np.linalg.norm(p[0] - p[1])
    alpha = math.degrees(math.acos(np.clip((b * b + c * c - a * a) / (2 * b * c), -1, 1)))
    beta = math.degrees(math.acos(np.clip((a * a + c * c - b * b) / (2 * a * c), -1, 1)))
    return alpha, beta, 180.0 - alpha - beta


def leb_min_angle(p):
    """Smallest angle of all longest-edge bisection descendants of triangle p (brute force).

    LEB makes finitely many similarity classes (Rosenberg & Stenger 1975), so a
    search over shapes (sorted angles, rounded) visits them all.  Which of two
    equally long longest edges is bisected does not matter: the two choices are
    mirror images.
    """
    todo = [np.asarray(p, float)]
    seen = set()
    best = 180.0
    while todo:
        q = todo.pop()
        ang = angles_of(q)
        key = tuple(np.round(sorted(ang), 6))
        if key in seen:
            continue
        seen.add(key)
        best = min(best, min(ang))
        lengths = [np.linalg.norm(q[(k + 1) % 3] - q[k]) for k in range(3)]
        k = int(np.argmax(lengths))
        a, b, c = q[k], q[(k + 1) % 3], q[(k + 2) % 3]
        m = 0.5 * (a + b)
        todo += [np.array([a, m, c]), np.array([m, b, c])]
        assert len(seen) < 2000, "LEB similarity classes did not close"
    return best


def check_refinement(n0, t0, n1, t1, parent):
    """Conforming, oriented, children tiling their parents."""
    tv, over = find_t_vertices(n1, t1)
    assert len(tv) == 0 and len(over) == 0
    a0 = triangle_areas(n0, t0)
    a1 = triangle_areas(n1, t1)
    assert a1.min() > 0  # orientation kept, nothing degenerate
    np.testing.assert_allclose(np.bincount(parent, weights=a1, minlength=len(t0)), a0, rtol=1e-10)
    # each child inside its parent (barycentric coordinates of its centroid)
    cen = n1[t1].mean(axis=1)
    p = n0[t0[parent]]
    d = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
         - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    for k in range(3):
        u, v = p[:, (k + 1) % 3], p[:, (k + 2) % 3]
        s = (v[:, 0] - u[:, 0]) * (cen[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (cen[:, 0] - u[:, 0])
        assert np.all(s / d > 0)
    # a conforming mesh of a connected domain keeps V - E + F (only used nodes count)
    used = np.unique(t1)
    used0 = np.unique(t0)
    assert (len(used) - len(mesh_edges(t1)) + len(t1)
            == len(used0) - len(mesh_edges(t0)) + len(t0))


@pytest.fixture(scope="module", params=["square", "hole"])
def bubble(request):
    if request.param == "square":
        dom, h = validate_domain(SQUARE), 0.1
    else:
        dom, h = validate_domain(SQUARE, [circle(0.5, 0.5, 0.2, 12)]), 0.12
    return dom, bubble_mesh(dom, (), h, seed=1)


def test_five_levels_keep_angles_on_a_bubble_mesh(bubble):
    dom, bm = bubble
    bound = np.array([leb_min_angle(bm.nodes[t]) for t in bm.triangles])
    ang0, _ = triangle_quality(bm.nodes, bm.triangles)
    res = adaptive_subdivision(bm.nodes, bm.triangles, jump(bm.nodes), 0.5, levels=5, value_fn=jump)
    # refinement concentrates at the jump and repeats at every level
    assert len(res.n_marked) == 5 and min(res.n_marked) > 0
    assert res.n_marked == sorted(res.n_marked)
    check_refinement(bm.nodes, bm.triangles, res.nodes, res.triangles, res.parent)
    np.testing.assert_allclose(triangle_areas(res.nodes, res.triangles).sum(), dom.area, rtol=1e-12)
    ang, _ = triangle_quality(res.nodes, res.triangles)
    # issue 13: >= 20 degrees after five levels
    assert ang.min() >= 20.0
    # every element is an LEB descendant of its input element: never below that
    # element's brute-force bound, nor below half its smallest angle (Rosenberg-Stenger)
    assert np.all(ang >= bound[res.parent] - 1e-6)
    assert np.all(ang >= 0.5 * ang0[res.parent] - 1e-9)
    # the values carried are the field at the nodes
    np.testing.assert_array_equal(res.values, jump(res.nodes))
    # the red-green closure, same mesh and marks, degrades (the reason for LEB)
    rg = adaptive_subdivision(bm.nodes, bm.triangles, jump(bm.nodes), 0.5, levels=5, value_fn=jump,
                              method="red-green")
    assert triangle_quality(rg.nodes, rg.triangles)[0].min() < 20.0
    assert len(find_t_vertices(rg.nodes, rg.triangles)[0]) == 0


def test_marked_elements_become_four_times_smaller(bubble):
    dom, bm = bubble
    rng = np.random.default_rng(7)
    marked = rng.random(len(bm.triangles)) < 0.2
    n1, t1, parent, halves = refine_marked(bm.nodes, bm.triangles, marked)
    check_refinement(bm.nodes, bm.triangles, n1, t1, parent)
    a0 = triangle_areas(bm.nodes, bm.triangles)
    a1 = triangle_areas(n1, t1)
    ratio = a1 / a0[parent]
    # two bisections of every marked element: children at most a quarter of it
    assert ratio[marked[parent]].max() <= 0.25 * (1 + 1e-12)
    assert np.all(np.bincount(parent, minlength=len(bm.triangles))[marked] >= 4)
    # unmarked elements are bisected only where the closure needs it: mostly untouched
    assert np.mean(np.bincount(parent, minlength=len(bm.triangles))[~marked] == 1) > 0.3
    # new nodes are midpoints of earlier nodes, the old ones unchanged
    np.testing.assert_array_equal(n1[: len(bm.nodes)], bm.nodes)
    new = np.arange(len(bm.nodes), len(n1))
    assert np.all(halves < new[:, None])
    np.testing.assert_array_equal(n1[new], 0.5 * (n1[halves[:, 0]] + n1[halves[:, 1]]))
    # buffers grown from almost nothing: the same mesh
    grown = _longest_edge_refine(bm.nodes, bm.triangles, marked, 2, spare=1)
    for x, y in zip(grown, (n1, t1, parent, halves)):
        np.testing.assert_array_equal(x, y)
    # nothing marked: nothing changes
    n2, t2, p2, h2 = refine_marked(bm.nodes, bm.triangles, np.zeros(len(bm.triangles), bool))
    np.testing.assert_array_equal(t2, bm.triangles)
    assert len(h2) == 0 and np.array_equal(p2, np.arange(len(bm.triangles)))


def test_random_marks_on_random_delaunay_meshes():
    # A fixed-seed loop in place of a property test (hypothesis is not installed).  Points:
    # a jittered grid, so that the brute-force similarity classes stay few (slivers of a few
    # tenths of a degree have thousands).
    rng = np.random.default_rng(2026)
    for trial in range(12):
        k = int(rng.integers(3, 9))
        g = (np.stack(np.meshgrid(np.arange(k + 1), np.arange(k + 1)), -1).reshape(-1, 2)
             + rng.uniform(-0.3, 0.3, ((k + 1) ** 2, 2)) * rng.random()) / k
        pts = np.vstack([SQUARE, g[(g > 0.02).all(1) & (g < 0.98).all(1)]])
        tri = Delaunay(pts).simplices.astype(np.int64)
        a = triangle_areas(pts, tri)
        tri = np.where((a < 0)[:, None], tri[:, [0, 2, 1]], tri)
        tri = tri[np.abs(a) > 1e-12]
        ang0, _ = triangle_quality(pts, tri)
        bound = np.array([leb_min_angle(pts[t]) for t in tri])
        n, t, root = pts, tri, np.arange(len(tri))
        for level in range(3):
            marked = rng.random(len(t)) < rng.choice([0.05, 0.3, 1.0])
            n2, t2, par, _ = refine_marked(n, t, marked, bisections=int(rng.integers(1, 3)))
            check_refinement(n, t, n2, t2, par)
            n, t, root = n2, t2, root[par]
        ang, _ = triangle_quality(n, t)
        np.testing.assert_allclose(np.bincount(root, weights=triangle_areas(n, t), minlength=len(tri)),
                                   triangle_areas(pts, tri), rtol=1e-10)
        # Rosenberg & Stenger (Math. Comp. 29, 1975): an LEB descendant's smallest
        # angle is at least half the smallest angle of the triangle it came from
        assert np.all(ang >= 0.5 * ang0[root] - 1e-9), trial
        assert np.all(ang >= bound[root] - 1e-6), trial


def test_refine_marked_bad_input():
    nodes = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    with pytest.raises(ValueError, match="method"):
        refine_marked(nodes, tri, [True, False], method="newest")
    with pytest.raises(ValueError, match="bisections"):
        refine_marked(nodes, tri, [True, False], bisections=0)
    with pytest.raises(ValueError, match="marked"):
        refine_marked(nodes, tri, [True])
    with pytest.raises(ValueError, match="oriented"):
        refine_marked(nodes, np.array([[0, 1, 2], [0, 3, 2]]), [True, False])
    with pytest.raises(ValueError, match="more than two"):
        refine_marked(np.vstack([nodes, [[2, 0.5]]]), np.array([[0, 1, 2], [0, 2, 3], [2, 0, 4]]),
                      [True, False, False])
    # a single triangle (all edges on the boundary): bisected twice
    n1, t1, par, _ = refine_marked(nodes, tri[:1], [True])
    assert len(t1) == 4 and len(n1) == len(nodes) + 3


# ---------------------------------------------------------------------------
# radiosity: adaptive_refine on a scene (patches kept)
# ---------------------------------------------------------------------------

def _shadow_scene():
    # a 0.6 x 0.6 light at height 3 over a 1 x 1 blocker at 1.5: on the floor the umbra is
    # |x|, |z| < 0.7 and the penumbra 0.7 < max(|x|, |z|) < 1.3, wider than the elements (0.25)
    # so that refining it resolves a gradient (area-sampled visibility averages the light over
    # an element: across a penumbra narrower than the elements, smaller elements see a sharper
    # step, and the jumps between neighbours would grow, not shrink)
    floor = Polygon([[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]], reflectance=0.5, name="floor")
    light = AreaLight(np.array([[-0.3, 3, -0.3], [-0.3, 3, 0.3], [0.3, 3, 0.3],
                                [0.3, 3, -0.3]])[::-1], emission=100.0)
    blocker = Polygon([[-0.5, 1.5, -0.5], [0.5, 1.5, -0.5], [0.5, 1.5, 0.5], [-0.5, 1.5, 0.5]],
                      reflectance=0.0, name="blocker")
    return Scene([floor, light, blocker])


def _check_patches_kept(m, new, parent):
    """Same patches; every element inside its parent's patch, tiling it."""
    assert new.n_patches == m.n_patches
    np.testing.assert_allclose(new.patch_area, m.patch_area, rtol=1e-12)
    np.testing.assert_array_equal(new.element_patch, m.element_patch[parent])
    np.testing.assert_allclose(np.bincount(parent, weights=new.element_area, minlength=m.n_elements),
                               m.element_area, rtol=1e-10)
    np.testing.assert_allclose(np.bincount(new.element_patch, weights=new.element_area,
                                           minlength=new.n_patches), new.patch_area, rtol=1e-10)
    # each element's centroid inside its patch triangle (in 3D: on the patch's side of every edge)
    p = new.nodes[new.patches[new.element_patch]]
    c = new.element_centroid
    nrm = new.patch_normal[new.element_patch]
    for k in range(3):
        e = p[:, (k + 1) % 3] - p[:, k]
        assert np.all(np.einsum("ij,ij->i", np.cross(e, c - p[:, k]), nrm) > 0)
    # no T-vertices within any polygon: a bisected patch edge is split on both sides
    assert len(new.t_vertices()) == 0


def test_adaptive_refine_conforming_and_local():
    s = _shadow_scene()
    m = mesh_scene(s, 0.5, element_levels=1)
    # 8 x 8 visibility rays per pair: a soft penumbra rather than a binary shadow
    r = progressive_refinement(m, form_factors="analytic", visibility_samples=8, tol=1e-6)
    b = r.radiosity
    thr = 0.1 * b[m.element_polygon == 0].max()
    marked = mark_jumps(m, b, thr)
    # brute force: pairs of elements sharing two nodes whose values differ by more than thr
    ref = np.zeros(m.n_elements, dtype=bool)
    for i in range(m.n_elements):
        share = (np.isin(m.elements, m.elements[i]).sum(axis=1) == 2)
        nb = np.flatnonzero(share)
        if np.any(np.abs(b[nb] - b[i]).max(axis=1) > thr):
            ref[i] = True
    np.testing.assert_array_equal(marked, ref)
    assert marked.any() and not marked.all()
    ad = adaptive_refine(m, b, thr)
    new = ad.mesh
    assert ad.n_marked == marked.sum()
    _check_patches_kept(m, new, ad.parent)
    # marked elements bisected twice (a quarter of the area or less), others mostly untouched
    children = np.bincount(ad.parent, minlength=m.n_elements)
    assert np.all(children[marked] >= 4)
    assert (new.element_area / m.element_area[ad.parent])[marked[ad.parent]].max() <= 0.25 * (1 + 1e-9)
    assert np.mean(children[~marked] == 1) > 0.5
    # the red-green closure: marked elements 1 -> 4, neighbours 1 -> 4 or 1 -> 2
    rg = adaptive_refine(m, b, thr, method="red-green")
    _check_patches_kept(m, rg.mesh, rg.parent)
    children = np.bincount(rg.parent, minlength=m.n_elements)
    assert np.all(children[marked] == 4) and set(np.unique(children)) <= {1, 2, 4}
    everything = adaptive_refine(m, b, 0.0, marked=np.ones(m.n_elements, dtype=bool),
                                 method="red-green").mesh
    assert everything.n_elements == 4 * m.n_elements
    # the penumbra is continuous: solved again on the refined mesh, the largest jump between
    # neighbouring floor elements shrinks.  (Not by half, as elements of half the size would
    # give in a resolved gradient: the penumbra is about one element wide.  Measured: 0.73 of
    # the first jump with red-green, 0.85 with longest-edge bisection, whose transition
    # elements are rotated by 45 degrees against the axis-aligned penumbra.)
    j1 = element_jumps(m, b)[m.element_polygon == 0].max()
    for refined in (new, rg.mesh):
        r2 = progressive_refinement(refined, form_factors="analytic", visibility_samples=8, tol=1e-6)
        assert element_jumps(refined, r2.radiosity)[refined.element_polygon == 0].max() < j1
    with pytest.raises(MeshError, match="element_values"):
        mark_jumps(m, b[:-1], thr)
    with pytest.raises(MeshError, match="threshold"):
        mark_jumps(m, b, -1.0)
    with pytest.raises(MeshError, match="method"):
        adaptive_refine(m, b, thr, method="newest-vertex")
    # min_area stops the refinement
    assert not mark_jumps(m, b, thr, min_area=m.element_area.max()).any()


def test_adaptive_refine_five_levels_keep_angles_and_patches():
    # marks from a sharp field on the floor (a disc), five rounds: the angles stay above
    # half the first mesh's (and 20 degrees), patches are kept, no T-vertices
    s = _shadow_scene()
    m0 = mesh_scene(s, 0.5, element_levels=1)
    ang0, _ = m0.element_quality()
    m, root = m0, np.arange(m0.n_elements)
    for level in range(5):
        c = m.element_centroid
        v = (np.hypot(c[:, 0] - 0.3, c[:, 2] + 0.2) < 1.1) * (m.element_polygon == 0)
        ad = adaptive_refine(m, v.astype(float), 0.5)
        assert ad.n_marked > 0
        _check_patches_kept(m, ad.mesh, ad.parent)
        m, root = ad.mesh, root[ad.parent]
    ang, _ = m.element_quality()
    assert np.all(ang >= 0.5 * ang0[root] - 1e-9)
    assert ang.min() >= 20.0
    assert m.n_elements > 4 * m0.n_elements


# ----------------------------------------------------------------------------
# the mesh model of chapters 3 and 4: two faces, D0 copies, regions
# ----------------------------------------------------------------------------
def test_adaptive_refine_keeps_faces_d0_copies_and_regions():
    from polygen.radiosity import Polygon, Scene, Segments, mesh_scene

    floor = Polygon([[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]], name="floor")
    plate = Polygon([[1, 1, 2], [3, 1, 2], [3, 3, 2], [1, 3, 2]], name="plate", two_sided=True)
    seg = Segments([[[2.0, 0.0, 0.0], [2.0, 4.0, 0.0]]], "D0")
    mesh = mesh_scene(Scene([floor, plate]), 0.8, segments={"floor": seg})
    x = mesh.element_centroid
    # a jump along x = 2 on the floor (across the D0 line) and on the plate's back face only
    values = np.where(x[:, 0] > 2.0, 1.0, 0.0) * ((mesh.element_polygon == 0)
                                                  | (mesh.element_side == -1))
    out = adaptive_refine(mesh, values, 0.5)
    new = out.mesh
    assert out.n_marked > 0 and new.n_elements > mesh.n_elements
    # every face keeps its area: the plate's two faces are refined apart, not mirrored again
    for k, side in ((0, 1), (1, 1), (1, -1)):
        sel_old = (mesh.element_polygon == k) & (mesh.element_side == side)
        sel_new = (new.element_polygon == k) & (new.element_side == side)
        assert new.element_area[sel_new].sum() == pytest.approx(mesh.element_area[sel_old].sum())
    back = (new.element_polygon == 1) & (new.element_side == -1)
    front = (new.element_polygon == 1) & (new.element_side == 1)
    assert back.sum() > front.sum() == ((mesh.element_polygon == 1)
                                        & (mesh.element_side == 1)).sum()
    # D0 copies survive: nodes on x = 2 of the floor still come in pairs on one site
    on = np.flatnonzero(np.isclose(new.nodes[:, 0], 2.0) & (new.nodes[:, 2] == 0.0))
    copies = np.bincount(new.node_site[on])
    assert copies.max() == 2 and (new.node_site[on] != on).any()
    # no element of the floor crosses the D0 line, regions are carried over
    ex = new.nodes[new.elements][:, :, 0]
    fl = new.element_polygon == 0
    assert np.all((ex[fl].max(axis=1) <= 2.0 + 1e-12) | (ex[fl].min(axis=1) >= 2.0 - 1e-12))
    reg = new.element_region[fl]
    right = new.element_centroid[fl, 0] > 2.0
    assert len(set(reg[right])) == 1 and len(set(reg[~right])) == 1 and reg[right][0] != reg[~right][0]
    assert len(new.t_vertices()) == 0


@pytest.mark.parametrize("patch,mesher", [(160.0, "lattice"), (100.0, "lattice"), (80.0, "bubble")],
                         ids=["lattice-160", "lattice-100", "bubble-80"])
def test_adaptive_refine_cornell_keeps_half_the_start_angle(patch, mesher):
    """Issue 13's 20 degrees after five levels holds only from a start mesh of 40 degrees or more.

    The default Cornell meshes (the radiosity-error benchmark's coarse 160, the tests' 100, notebook
    02's bubble 80) start below that: the floor is cut where the blocks stand, and the short block's
    footprint comes within 65 mm of the floor's front edge, less than a patch. So the bound asserted
    on them is Rosenberg & Stenger's, from the start mesh's own angles: five levels of longest-edge
    bisection, concentrated where the worst start element is, keep every element at or above half
    the smallest angle of the element it came from."""
    from polygen.radiosity import bubble_mesher, scenes

    kw = {"mesher": bubble_mesher} if mesher == "bubble" else {}
    m0 = mesh_scene(scenes.cornell_box(), patch, element_levels=1, **kw)
    ang0, _ = m0.element_quality()
    worst = int(np.argmin(ang0))
    centre = m0.element_centroid[worst]
    m, root = m0, np.arange(m0.n_elements)
    for level in range(5):
        # a shadow edge's marks: every element of the worst element's polygon within half a patch of it
        near = np.linalg.norm(m.element_centroid - centre, axis=1) < 0.5 * patch
        marked = near & (m.element_polygon == m0.element_polygon[worst])
        ad = adaptive_refine(m, np.zeros(m.n_elements), 0.0, marked=marked)
        assert ad.n_marked == marked.sum() > 0
        _check_patches_kept(m, ad.mesh, ad.parent)
        assert len(ad.mesh.t_vertices()) == 0
        m, root = ad.mesh, root[ad.parent]
    ang, _ = m.element_quality()
    # the worst start element was refined, five times over
    assert np.sum(root == worst) >= 2 ** 5
    assert np.all(ang >= 0.5 * ang0[root] - 1e-9)
    assert ang.min() >= min(20.0, 0.5 * ang0.min())
