"""The occluders' BVH that the visibility rays walk (issue 14): the linear scan's answers, faster.

The oracle is the linear scan the BVH replaces (``index=False``): for every
(element, patch) pair it lists the occluders that may block a ray, and each
ray tests them all.  The walk must give the same boolean for every ray --
same rays, same jitter -- so the same form-factor columns and the same
solve, bit for bit.
"""

import numpy as np
import pytest

from polygen.radiosity import AreaLight, Polygon, Scene, mesh_scene, progressive_refinement, scenes
from polygen.radiosity import solve as solve_module
from polygen.radiosity.formfactor import (
    FormFactorError,
    _segment_meets_box,
    analytic_column,
    box_tree,
    element_geometry,
    pack_polygons,
    visibility_rays,
)


def _random_occluder_scene(n=24, seed=7):
    """A 10^3 room lit by a ceiling light, with n two-sided triangles and quads floating at random
    positions and orientations (some axis-aligned, so rays run parallel to box faces)."""
    rng = np.random.default_rng(seed)
    room = np.array([10.0, 10.0, 10.0])
    light = scenes._ceiling_light(room, (2.0, 2.0), emission=10.0)
    polys = scenes.box_room(room, reflectance=0.6, light=light, name="room")
    polys.append(AreaLight(light, emission=10.0, name="light"))
    for i in range(n):
        c = rng.uniform(2.0, 8.0, 3)
        if i % 4 == 0:  # axis-aligned
            u, v = np.eye(3)[rng.permutation(3)[:2]]
        else:
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            u, v = q[:, 0], q[:, 1]
        s = rng.uniform(0.5, 1.5, 2)
        corners = [-s[0] * u - s[1] * v, s[0] * u - s[1] * v, s[0] * u + s[1] * v,
                   -s[0] * u + s[1] * v]
        ring = c + np.asarray(corners[:3 + i % 2])
        polys.append(Polygon(np.asarray(ring), reflectance=0.6, name=f"occ{i}", two_sided=True))
    return Scene(polys, name="random_occluders")


SCENES = {
    "two_rectangles_room": lambda: scenes.two_rectangles_room(),
    "chair_scene": lambda: scenes.chair_scene(),
    "sphere_scene": lambda: scenes.sphere_scene(),  # Fig. 3.19's 12 x 15 sphere, 180 occluders
    "random_occluders": _random_occluder_scene,
}


@pytest.fixture(scope="module", params=list(SCENES))
def scene_mesh(request):
    sc = SCENES[request.param]()
    return mesh_scene(sc, 2.5, element_levels=1)


def _some_patches(mesh, n, seed=0):
    """The light's first patch and n others at random."""
    light = int(np.flatnonzero([mesh.scene.polygons[k].name == "light"
                                for k in mesh.patch_polygon])[0])
    others = np.random.default_rng(seed).choice(mesh.n_patches, n, replace=False)
    return [light] + [int(p) for p in others]


def test_box_tree_invariants():
    rng = np.random.default_rng(3)
    lo = rng.uniform(0, 10, (137, 3))
    boxes = np.stack([lo, lo + rng.uniform(0, 2, (137, 3))], axis=1)
    t = box_tree(boxes, leaf_size=4)
    assert np.array_equal(np.sort(t.order), np.arange(137))  # every item in exactly one slot
    leaves = np.flatnonzero(t.child[:, 0] < 0)
    assert t.count[leaves].sum() == 137 and t.count[leaves].max() <= 4
    depth = np.zeros(len(t.child), int)
    for nd in range(len(t.child)):
        items = t.order[t.start[nd]:t.start[nd] + t.count[nd]]
        assert np.all(t.node_lo[nd] <= boxes[items, 0]) and np.all(t.node_hi[nd] >= boxes[items, 1])
        if t.child[nd, 0] >= 0:
            a, b = t.child[nd]
            depth[[a, b]] = depth[nd] + 1
            # the children split the parent's slots, the left one first
            assert t.start[a] == t.start[nd] and t.start[b] == t.start[a] + t.count[a]
            assert t.count[a] + t.count[b] == t.count[nd]
    assert depth.max() <= int(np.ceil(np.log2(137))) + 1
    empty = box_tree(np.zeros((0, 2, 3)))
    assert empty.node_lo.shape == (0, 3) and empty.order.shape == (0,)
    with pytest.raises(FormFactorError, match="boxes"):
        box_tree(np.zeros((3, 3)))
    with pytest.raises(FormFactorError, match="leaf_size"):
        box_tree(boxes, leaf_size=0)


def test_segment_meets_box_against_sampling():
    """True wherever a point sampled on the segment lies in the box; False wherever the segment
    stays clear of it (distance by dense sampling)."""
    rng = np.random.default_rng(11)
    lo, hi = np.array([-1.0, -0.5, 0.0]), np.array([1.0, 0.5, 2.0])
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    n_in = n_out = 0
    for i in range(600):
        a, b = rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3)
        if i % 3 == 0:  # parallel to a box face
            b[i % 9 // 3] = a[i % 9 // 3]
        pts = a + t * (b - a)
        dist = np.linalg.norm(np.maximum(np.maximum(lo - pts, pts - hi), 0.0), axis=1).min()
        hit = _segment_meets_box(a, b, lo, hi)
        if dist == 0.0:
            assert hit
            n_in += 1
        elif dist > 2e-3 * np.linalg.norm(b - a):  # beyond the sampling's resolution
            assert not hit
            n_out += 1
    assert n_in > 100 and n_out > 100


def test_walk_gives_the_linear_scans_answer_for_every_ray(scene_mesh):
    mesh = scene_mesh
    packed = pack_polygons(mesh.scene.polygons)
    geometry = element_geometry(mesh)
    n_blocked = n_free = 0
    for p in _some_patches(mesh, 6):
        fast = visibility_rays(mesh, p, packed=packed, geometry=geometry, visibility_samples=3)
        slow = visibility_rays(mesh, p, packed=packed, geometry=geometry, visibility_samples=3,
                               index=False)
        for x, y in zip(fast, slow):
            np.testing.assert_array_equal(x, y)
        n_blocked += int(fast[4].sum())
        n_free += int((~fast[4]).sum())
    # the comparison means something only if both answers occur often
    assert n_blocked > 100 and n_free > 100


def test_walk_gives_the_same_columns(scene_mesh):
    mesh = scene_mesh
    packed = pack_polygons(mesh.scene.polygons)
    geometry = element_geometry(mesh)
    for p in _some_patches(mesh, 4, seed=1):
        a = analytic_column(mesh, p, packed=packed, geometry=geometry, visibility_samples=2)
        b = analytic_column(mesh, p, packed=packed, geometry=geometry, visibility_samples=2,
                            index=False, parallel=False)
        np.testing.assert_array_equal(a, b)


def test_walk_gives_the_same_solve(monkeypatch):
    mesh = mesh_scene(_random_occluder_scene(), 2.5, element_levels=1)
    fast = progressive_refinement(mesh, tol=0.05, visibility_samples=2)
    monkeypatch.setattr(solve_module, "analytic_column",
                        lambda *a, **kw: analytic_column(*a, index=False, **kw))
    slow = progressive_refinement(mesh, tol=0.05, visibility_samples=2)
    assert len(fast.shots) > 20
    np.testing.assert_array_equal(fast.shots, slow.shots)
    np.testing.assert_array_equal(fast.radiosity, slow.radiosity)


@pytest.mark.parametrize("columns", [0, 20])
def test_column_cache_gives_the_same_solve(columns):
    """Kept columns are the columns bit for bit: the same shots and radiosities with no cache,
    a small one (room for 20 dense columns, then no more kept) and the default."""
    mesh = mesh_scene(_random_occluder_scene(), 2.5, element_levels=1)
    full = progressive_refinement(mesh, tol=0.02, visibility_samples=2)
    other = progressive_refinement(mesh, tol=0.02, visibility_samples=2,
                                   cache_bytes=columns * 8 * mesh.n_elements)
    np.testing.assert_array_equal(full.shots, other.shots)
    np.testing.assert_array_equal(full.radiosity, other.radiosity)
    n = len(full.shots)
    # patches shoot again: the default cache computes each column once
    assert full.stats["columns_computed"] == len(np.unique(full.shots)) < n
    assert full.stats["columns_computed"] + full.stats["columns_reused"] == n
    assert other.stats["columns_computed"] + other.stats["columns_reused"] == n
    if columns == 0:
        assert other.stats["columns_reused"] == 0
    else:  # some kept, the others computed at each shot
        assert full.stats["columns_computed"] < other.stats["columns_computed"] < n


def test_cache_bytes_is_checked():
    mesh = mesh_scene(scenes.two_rectangles_room(), 5.0, element_levels=0)
    with pytest.raises(solve_module.SolverError, match="cache_bytes"):
        progressive_refinement(mesh, cache_bytes=-1)


def test_polygon_index_on_the_shared_tree_against_brute_force():
    """Chapter 3's PolygonIndex now builds on box_tree: its queries (default points: the boxes'
    corners) against the brute-force box and separating-plane tests."""
    from polygen.discontinuity.scene_index import PolygonIndex

    rng = np.random.default_rng(5)
    lo = rng.uniform(0, 10, (60, 3))
    boxes = np.stack([lo, lo + rng.uniform(0.1, 2, (60, 3))], axis=1)
    index = PolygonIndex(boxes, leaf_size=3)
    assert np.array_equal(index.order, box_tree(boxes, leaf_size=3).order)
    corners = np.array([[[b[i, 0], b[j, 1], b[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
                        for b in boxes])  # (60, 8, 3)
    planes, qboxes = [], []
    for q in range(8):  # random half-space pairs, capped by a box
        n = rng.normal(size=(2, 3))
        n /= np.linalg.norm(n, axis=1)[:, None]
        c = rng.uniform(2, 8, 3)
        planes.append(np.column_stack([n, n @ c]))
        qboxes.append([c - 4, c + 4])
    got = {(int(q), int(i)) for q, i in index.query(planes, np.asarray(qboxes))}
    apart = {(q, i) for q in range(8) for i in range(60)
             if any(np.all(corners[i] @ p[:3] > p[3]) for p in planes[q])}
    want = {(q, i) for q in range(8) for i in range(60)
            if np.all(boxes[i, 0] <= qboxes[q][1]) and np.all(boxes[i, 1] >= qboxes[q][0])} - apart
    # every pair that may meet is returned, none that a face separates (the box test is the
    # leaves' boxes: a polygon in a leaf that meets the query's box may come back)
    assert want <= got and not got & apart and len(want) > 20


def test_a_tree_out_of_step_with_the_occluders_is_refused():
    mesh = mesh_scene(scenes.two_rectangles_room(), 5.0, element_levels=0)
    packed = pack_polygons(mesh.scene.polygons)
    packed.occluders = packed.occluders[:1]
    for call in (analytic_column, visibility_rays):
        with pytest.raises(FormFactorError, match="occluder_tree"):
            call(mesh, 0, packed=packed)
