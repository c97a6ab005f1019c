"""Volume rendering (thesis 7.8): the cell walk, ray casting, equi-distance surfaces, bad input.

Oracles: the analytic chord length of a hollow sphere and a torus (within
the band the meshed surface keeps from the true one, measured on the mesh);
the length inside the meshed polyhedron by brute force over every boundary
triangle (the walk must match it to round-off); a literal back-to-front (7.1)
over samples located by brute force; and the ray caster itself for the
equi-distance rendering (PSNR >= 35 dB, the issue's requirement); VTK's
unstructured-grid ray caster, an external oracle, with its own optical model
(PSNR >= 35 dB over the foreground pixels, tetrahedra and hexahedra).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polygen.volume import UnstructuredVolume, datasets
from polygen.volume.render import (
    View,
    Lighting,
    RayCaster,
    RenderError,
    ShellRenderer,
    TransferFunction,
    boundary_triangles,
    foreground,
    psnr,
    raycast,
)

PSNR_MIN = 35.0  # dB, issue 16: equi-distance surfaces against ray casting at the same spacing
# dB over the foreground (the pixels either image covers), ours against VTK's ray caster with VTK's
# optical model; issue 42 fixed it before measuring
PSNR_VTK_MIN = 35.0


# ------------------------------------------------------------------ meshed solids with a known chord
def _gmsh_solid(build, h):
    """Tetrahedra of the OCC solid ``build(occ)`` at mesh size ``h``, meshed as the data sets mesh their parts."""
    from polygen.volume.datasets.meshing import _compact, _gmsh_model, _single_thread
    from polygen.volume.datasets.tiny import _orient_tets

    with _gmsh_model("polygen-render-test") as gmsh:
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        _single_thread(gmsh)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.mesh.generate(3)
        _, conn = gmsh.model.mesh.getElementsByType(4)
        tags, coords, _ = gmsh.model.mesh.getNodes()
    points, cells = _compact(tags, coords, conn, 4)
    return UnstructuredVolume(points, _orient_tets(points, cells), {"x": points[:, 0].copy()})


R_OUT, R_IN = 1.0, 0.5  # hollow sphere
R_MAJ, R_MIN = 1.0, 0.35  # torus about z


@pytest.fixture(scope="module")
def hollow_sphere():
    def build(occ):
        occ.cut([(3, occ.addSphere(0, 0, 0, R_OUT))], [(3, occ.addSphere(0, 0, 0, R_IN))])

    return _gmsh_solid(build, 0.16)


@pytest.fixture(scope="module")
def torus():
    return _gmsh_solid(lambda occ: occ.addTorus(0, 0, 0, R_MAJ, R_MIN), 0.12)


def _surface_band(vol, distance):
    """Largest distance of the boundary triangles from the analytic surface (``distance(x) -> (K,)``).

    Measured on a barycentric grid of each triangle (its vertices, edges and
    interior), so the meshed surface lies within this band of the true one.
    """
    tris, _ = boundary_triangles(vol)
    p = vol.points[tris]
    g = np.array([(i, j) for i in range(9) for j in range(9 - i)], float) / 8
    bary = np.column_stack([1 - g.sum(1), g])
    x = np.einsum("kb,tbd->tkd", bary, p).reshape(-1, 3)
    return float(np.abs(distance(x)).max())


def _polyhedron_lengths(vol, origins, dirs):
    """Brute force: the ray's length inside the meshed solid from every boundary triangle it crosses.

    Along a ray, entries (d.n < 0) at t_i and exits at t_j give length
    ``sum t_exit - sum t_entry`` (for rays starting outside).
    """
    tris, _ = boundary_triangles(vol)
    a, b, c = (vol.points[tris[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    out = np.zeros(len(origins))
    for i, (o, d) in enumerate(zip(origins, dirs)):
        dn = n @ d
        ok = dn != 0
        t = np.einsum("ij,ij->i", a - o, n)[ok] / dn[ok]
        x = o + t[:, None] * d
        aa, bb, cc, nn = a[ok], b[ok], c[ok], n[ok]
        inside = np.ones(t.shape, bool)
        for p, q in ((aa, bb), (bb, cc), (cc, aa)):
            inside &= np.einsum("ij,ij->i", np.cross(q - p, x - p), nn) >= 0
        hit = inside & (t > 0)
        # a ray through a shared edge hits two triangles: keep distinct crossings
        te, tx = np.unique(np.round(t[hit & (dn[ok] < 0)], 12)), np.unique(np.round(t[hit & (dn[ok] > 0)], 12))
        out[i] = tx.sum() - te.sum()
    return out


def _ortho_x(size, extent, x0=-3.0):
    """Rays along +x over the square ``[-extent, extent]^2`` of (y, z)."""
    return View(eye=(x0, 0, 0), target=(0, 0, 0), up=(0, 0, 1), fov=None, height=2 * extent, size=(size, size))


TF_FLAT = TransferFunction([0.0, 1.0], [[1, 1, 1], [1, 1, 1]], [0.0, 0.0])


def _sphere_chord(p, ro, ri):
    """Length of a line at distance ``p`` from the centre inside ``ri <= |x| <= ro``."""
    h = lambda r: np.sqrt(np.maximum(r * r - p * p, 0.0))  # noqa: E731
    return 2 * (h(ro) - h(ri))


def _torus_chord_x(y, z, r):
    """Length of the line ``(t, y, z)`` inside the torus of major radius R_MAJ and minor radius ``r``."""
    w = np.sqrt(np.maximum(r * r - z * z, 0.0))
    outer = np.sqrt(np.maximum((R_MAJ + w) ** 2 - y * y, 0.0))
    inner = np.sqrt(np.maximum((R_MAJ - w) ** 2 - y * y, 0.0))
    return np.where(w > 0, 2 * (outer - inner), 0.0)


# ------------------------------------------------------------------ the walk
def test_walk_through_a_void_gives_the_chord(hollow_sphere):
    vol = hollow_sphere
    delta = _surface_band(vol, lambda x: np.minimum(np.abs(np.linalg.norm(x, axis=1) - R_OUT),
                                                    np.abs(np.linalg.norm(x, axis=1) - R_IN)))
    assert delta < 0.02  # the mesh follows the sphere: a sanity check of the fixture, not of the walk
    cam = _ortho_x(24, 1.1)
    res = RayCaster(vol).render(cam, TF_FLAT, step=0.05)
    origins, dirs = cam.rays()
    p = np.hypot(origins[:, 1], origins[:, 2])
    length = res.length.ravel()
    # the walk against the meshed polyhedron (exact up to round-off)
    brute = _polyhedron_lengths(vol, origins, dirs)
    np.testing.assert_allclose(length, brute, atol=1e-9)
    # against the analytic chord: the meshed surfaces lie within delta of the spheres
    lo = _sphere_chord(p, R_OUT - delta, R_IN + delta)
    hi = _sphere_chord(p, R_OUT + delta, R_IN - delta)
    assert np.all(length >= lo - 1e-12) and np.all(length <= hi + 1e-12)
    # rays through the void enter twice
    through_void = p < R_IN - delta
    assert through_void.sum() > 20
    assert np.all(res.entries.ravel()[through_void] == 2)
    assert np.all(res.entries.ravel()[p > R_OUT + delta] == 0)


def test_walk_through_a_hole_gives_the_chord(torus):
    vol = torus

    def dist(x):
        return np.hypot(np.hypot(x[:, 0], x[:, 1]) - R_MAJ, x[:, 2]) - R_MIN

    delta = _surface_band(vol, dist)
    assert delta < 0.02
    cam = _ortho_x(32, R_MAJ + R_MIN + 0.05)
    res = RayCaster(vol).render(cam, TF_FLAT, step=0.05)
    origins, dirs = cam.rays()
    y, z = origins[:, 1], origins[:, 2]
    length = res.length.ravel()
    np.testing.assert_allclose(length, _polyhedron_lengths(vol, origins, dirs), atol=1e-9)
    lo, hi = _torus_chord_x(y, z, R_MIN - delta), _torus_chord_x(y, z, R_MIN + delta)
    assert np.all(length >= lo - 1e-12) and np.all(length <= hi + 1e-12)
    # rays through both tubes and the hole re-enter
    twice = (np.abs(y) < R_MAJ - R_MIN - delta) & (np.abs(z) < R_MIN - delta)
    assert twice.sum() > 10
    assert np.all(res.entries.ravel()[twice] == 2)


def test_eye_inside_a_void(hollow_sphere):
    """Perspective eye at the centre of the void: every ray crosses the shell once, radially."""
    vol = hollow_sphere
    delta = _surface_band(vol, lambda x: np.minimum(np.abs(np.linalg.norm(x, axis=1) - R_OUT),
                                                    np.abs(np.linalg.norm(x, axis=1) - R_IN)))
    assert vol.locate([[0.0, 0.0, 0.0]])[0] == -1
    cam = View(eye=(0, 0, 0), target=(1, 0.2, 0.1), fov=90, size=(16, 12))
    res = RayCaster(vol).render(cam, TF_FLAT, step=0.05)
    assert np.all(res.entries == 1)
    assert np.all(np.abs(res.length - (R_OUT - R_IN)) <= 2 * delta)


def test_surfaces_around_an_eye_in_a_void(hollow_sphere):
    """Eye in the void: the distance's minima lie on the void's surface, and the surfaces still match the rays."""
    vol = hollow_sphere
    cam = View(eye=(0.05, -0.02, 0.03), target=(1, 0.2, 0.1), fov=90, size=(24, 24))
    step = 0.02
    tf = TransferFunction([-1.0, 1.0], [[0.1, 0.2, 0.9], [0.9, 0.6, 0.1]], [0.2, 0.8], unit=0.1)
    sr = ShellRenderer(vol, cam)
    assert np.isin(sr.extrema.nodes, vol.boundary_face_nodes).all()
    ray = RayCaster(vol).render(cam, tf, step=step)
    assert psnr(ray.image, sr.render(tf, step=step).image) >= PSNR_MIN


def test_eye_in_material_and_on_a_boundary_face():
    vol = datasets.load("hollow_cube")  # [0, 3]^3 minus the centre cube [1, 2]^3
    rc = RayCaster(vol, "linear")
    # in material, looking through the void along -x: 0.5 + 1
    cam = View(eye=(2.5, 1.5, 1.5), target=(0, 1.5, 1.5), fov=1.0, size=(1, 1))
    res = rc.render(cam, TF_FLAT, step=0.1)
    assert res.length[0, 0] == pytest.approx(1.5, abs=1e-12) and res.entries[0, 0] == 2
    # on the outer face x = 0 (and on a cell face there), looking in: through everything
    for eye in [(0.0, 0.5, 0.5), (0.0, 1.0, 0.5), (0.0, 1.5, 1.5)]:
        cam = View(eye=eye, target=(3, eye[1], eye[2]), fov=1.0, size=(1, 1))
        res = rc.render(cam, TF_FLAT, step=0.1)
        expect = 2.0 if eye[1:] == (1.5, 1.5) else 3.0
        assert res.length[0, 0] == pytest.approx(expect, abs=1e-12)
    # on the face, looking out: nothing
    cam = View(eye=(0.0, 0.5, 0.5), target=(-3, 0.5, 0.5), fov=1.0, size=(1, 1))
    assert rc.render(cam, TF_FLAT, step=0.1).length[0, 0] == 0


@pytest.mark.parametrize("name", ["hollow_cube_hex", "torus_hex", "genus3", "genus3_hex"])
def test_walk_on_tiny_volumes_matches_brute_force(name):
    vol = datasets.load(name)
    lo, hi = vol.points.min(0), vol.points.max(0)
    c = (lo + hi) / 2
    cam = View(eye=c + [-2.0, -9.0, 3.0], target=c, fov=40, size=(20, 16))
    res = RayCaster(vol, "linear").render(cam, TF_FLAT, step=0.1)
    origins, dirs = cam.rays()
    np.testing.assert_allclose(res.length.ravel(), _polyhedron_lengths(vol, origins, dirs), atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.floats(0, 2 * np.pi), st.floats(-1.2, 1.2), st.floats(3.0, 12.0), st.sampled_from(["genus3", "genus3_hex"]))
def test_walk_from_any_side_matches_brute_force(azimuth, elevation, distance, name):
    vol = datasets.load(name)
    c = vol.points.mean(axis=0)
    eye = c + distance * np.array([np.cos(azimuth) * np.cos(elevation), np.sin(azimuth) * np.cos(elevation),
                                   np.sin(elevation)])
    up = (0, 0, 1) if abs(np.sin(elevation)) < 0.99 else (1, 0, 0)
    cam = View(eye=eye, target=c, up=up, fov=50, size=(6, 5))
    res = RayCaster(vol, "linear").render(cam, TF_FLAT, step=0.2)
    origins, dirs = cam.rays()
    np.testing.assert_allclose(res.length.ravel(), _polyhedron_lengths(vol, origins, dirs), atol=1e-9)


def test_walk_on_curved_hexahedra_matches_brute_force():
    vol = datasets.load("hexa1")
    lo, hi = vol.points.min(0), vol.points.max(0)
    c = (lo + hi) / 2
    cam = View(eye=c + [1.0, -6.0, 4.0], target=c, fov=40, size=(12, 12))
    res = RayCaster(vol).render(cam, TF_FLAT, step=0.1)
    origins, dirs = cam.rays()
    np.testing.assert_allclose(res.length.ravel(), _polyhedron_lengths(vol, origins, dirs), atol=1e-9)
    assert res.entries.max() >= 2  # some ray crosses a bolt hole or the void


# ------------------------------------------------------------------ compositing
def _naive_pixel(vol, values, grads, o, d, step, t_max, tf, lighting, bg, model="opacity"):
    """Samples by point location, then (7.1) literally, far to near (opacity by ``model``, OPTICAL_MODELS)."""
    k = np.arange(int(np.ceil(t_max / step)) + 1)
    x = o + (k * step)[:, None] * d
    work = UnstructuredVolume(vol.points, vol.cells, {"s": values, "gx": grads[:, 0], "gy": grads[:, 1],
                                                      "gz": grads[:, 2]}, validate=False)
    s = work.interpolate(x, "s")
    g = np.stack([work.interpolate(x, f) for f in ("gx", "gy", "gz")], axis=1)
    keep = ~np.isnan(s)
    s, g = s[keep], g[keep]
    rgb, _ = tf(s)
    if model == "opacity":
        a = np.interp(s, tf.knots, tf.corrected(step))
    else:  # the table's opacity per unit is the attenuation coefficient
        a = 1 - np.exp(-np.interp(s, tf.knots, tf.opacity) * step / tf.unit)
    gl = np.abs(g @ (-d)) / np.linalg.norm(g, axis=1)
    c = lighting.emission + gl[:, None] * lighting.energy * rgb  # (7.2)
    out = np.full(3, float(bg))
    for ci, ai in zip(c[::-1], a[::-1]):  # (7.1), C_0 the background
        out = out * (1 - ai) + ci * ai
    return out


@pytest.mark.parametrize("model", ["opacity", "attenuation"])
@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_raycast_equals_literal_back_to_front(name, model):
    vol = datasets.load(name)
    lo, hi = vol.points.min(0), vol.points.max(0)
    c = (lo + hi) / 2
    s = vol.scalars()
    step = float(np.linalg.norm(hi - lo)) / 60
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.05, 0.4), unit=step)
    cam = View(eye=c + [2.5, -5.0, 3.0], target=c, fov=30, size=(7, 5))
    light = Lighting()
    rc = RayCaster(vol)
    res = rc.render(cam, tf, step=step, lighting=light, background=0.25, optical_model=model)
    origins, dirs = cam.rays()
    t_max = float(np.linalg.norm(hi - lo) + np.linalg.norm(origins[0] - c))
    got = res.image.reshape(-1, 3)
    hit = np.flatnonzero(res.samples.ravel() > 0)
    assert hit.size >= 10
    for p in hit:
        ref = _naive_pixel(vol, rc.values, rc.grads, origins[p], dirs[p], step, t_max, tf, light, 0.25, model)
        np.testing.assert_allclose(got[p], ref, atol=1e-6)
    assert np.allclose(got[res.samples.ravel() == 0], 0.25)


def test_opacity_correction_keeps_a_uniform_slab():
    """A constant opacity over a slab of thickness L: 1 - (1 - a)^(L / unit) whatever the step."""
    vol = datasets.load("hollow_cube")  # rays at y = z = 0.5 cross 3 units of material
    tf = TransferFunction([0.0, 10.0], [[1, 1, 1]] * 2, [0.3, 0.3], unit=1.0)
    cam = View(eye=(-1, 0.5, 0.5), target=(3, 0.5, 0.5), fov=1.0, size=(1, 1))
    flat = Lighting(emission=1.0, energy=0.0)
    for step in (0.5, 0.25, 0.1):
        img = raycast(vol, cam, tf, field="linear", step=step, lighting=flat).image[0, 0]
        n = round(3.0 / step)  # samples at k * step inside [1, 4)
        assert img[0] == pytest.approx(1 - 0.7 ** (n * step), abs=1e-12)


def test_attenuation_model_on_a_uniform_slab():
    """VTK's model: ``a / unit`` is the attenuation coefficient; a slab L long lets ``exp(-a L / unit)`` through.

    Ours (``"opacity"``) lets ``(1 - a) ** (L / unit)`` through: the same table is denser.
    """
    vol = datasets.load("hollow_cube")  # rays at y = z = 0.5 cross 3 units of material
    tf = TransferFunction([0.0, 10.0], [[1, 1, 1]] * 2, [0.3, 0.3], unit=1.0)
    cam = View(eye=(-1, 0.5, 0.5), target=(3, 0.5, 0.5), fov=1.0, size=(1, 1))
    flat = Lighting(emission=1.0, energy=0.0)
    rc = RayCaster(vol, "linear")
    for step in (0.5, 0.25, 0.1):
        n = round(3.0 / step)
        att = rc.render(cam, tf, step=step, lighting=flat, optical_model="attenuation").image[0, 0, 0]
        assert att == pytest.approx(1 - np.exp(-0.3 * n * step), abs=1e-12)
        ours = rc.render(cam, tf, step=step, lighting=flat).image[0, 0, 0]
        assert ours == pytest.approx(1 - 0.7 ** (n * step), abs=1e-12) and ours > att


# ------------------------------------------------------------------ kept samples
def test_kept_samples_recomposite_without_walking():
    """A transfer-function, lighting or model change on kept samples walks nothing and gives the walk's image."""
    vol = datasets.load("data1")
    cam, step = _view(vol, 24)
    s = vol.scalars()
    tf1 = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.5), unit=step * 4)
    tf2 = TransferFunction.ramp(s.min(), s.max(), cmap="magma", opacity=(0.6, 0.1), unit=step * 2)
    rc = RayCaster(vol, keep_samples=True)
    first = rc.render(cam, tf1, step=step)
    assert (rc.walks, rc.sample_builds) == (1, 1) and rc.kept_bytes >= 32 * int(first.samples.sum())
    plain = RayCaster(vol)
    for tf, kw in [(tf2, {}), (tf1, {"lighting": Lighting(shade=False), "optical_model": "attenuation"}),
                   (tf2, {"lighting": Lighting(direction=(1, 0, 0)), "background": 0.3})]:
        kept = rc.render(cam, tf, step=step, **kw)
        assert kept.seconds["cast"] == 0.0
        walked = plain.render(cam, tf, step=step, **kw)
        np.testing.assert_array_equal(kept.image, walked.image)  # same arithmetic, same order
        np.testing.assert_array_equal(kept.samples, walked.samples)
        np.testing.assert_array_equal(kept.entries, walked.entries)
    assert (rc.walks, rc.sample_builds) == (1, 1)
    assert not np.allclose(first.image, kept.image)
    rc.render(cam, tf1, step=step / 2)  # a new spacing walks again
    assert (rc.walks, rc.sample_builds) == (2, 2)
    rc.render(cam.replace(target=tuple(np.array(cam.target) + 0.1)), tf1, step=step / 2)  # a new view too
    assert (rc.walks, rc.sample_builds) == (3, 3)
    assert plain.walks == 3 and plain.sample_builds == 0 and plain.kept_bytes == 0


def test_kept_samples_bound_holds_through_voids_and_from_inside(hollow_sphere):
    """The room kept per ray (from its boundary crossings) holds every sample: through the void, and from inside."""
    vol = hollow_sphere
    tf = TransferFunction([-1.0, 1.0], [[0.1, 0.2, 0.9], [0.9, 0.6, 0.1]], [0.2, 0.8], unit=0.1)
    for cam in (_ortho_x(20, 1.1), View(eye=(0.75, 0.0, 0.0), target=(0, 0.3, 0.1), fov=90, size=(16, 16))):
        rc = RayCaster(vol, keep_samples=True)
        a = rc.render(cam, tf, step=0.013)  # would raise if a ray had more samples than its room
        b = rc.render(cam, tf, step=0.013, optical_model="attenuation")
        assert rc.walks == 1 and a.samples.sum() > 500
        np.testing.assert_array_equal(
            b.image, RayCaster(vol).render(cam, tf, step=0.013, optical_model="attenuation").image)


# ------------------------------------------------------------------ against VTK's ray caster
def _vtk_case(name, size):
    from polygen.plotting.render import VtkUgridRayCaster

    vol = datasets.load(name)
    lo, hi = vol.points.min(0), vol.points.max(0)
    diag = float(np.linalg.norm(hi - lo))
    cam = View(eye=(lo + hi) / 2 + diag * np.array([1.2, -1.6, 0.9]), target=(lo + hi) / 2, fov=35,
               size=(size, size))
    s = vol.scalars()
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.6), unit=diag / 20)
    vtk_rc = VtkUgridRayCaster(vol, cam, tf)
    theirs, _ = vtk_rc.render()
    vtk_rc.close()
    rc = RayCaster(vol, keep_samples=True)
    flat = Lighting(shade=False)
    ours = {m: rc.render(cam, tf, step=diag / 200, lighting=flat, optical_model=m).image
            for m in ("attenuation", "opacity")}
    return ours, theirs, vtk_rc


@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_against_vtk_ray_caster(name):
    """Ours with VTK's optical model against vtkUnstructuredGridVolumeRayCastMapper, over the foreground.

    hexa1: VTK's ray caster takes tetrahedra, so VTK cuts the hexahedra first (and interpolates
    linearly in each tetrahedron where ours is trilinear). Ours with its own model is denser
    (-ln(1 - a) > a), so brighter on a black background, and further from VTK.
    """
    ours, theirs, vtk_rc = _vtk_case(name, 64)
    assert vtk_rc.tetrahedralised == (name == "hexa1")
    fg = foreground(ours["attenuation"], theirs)
    assert 0.1 < fg.mean() < 0.6  # the volume fills part of the frame, not none or all of it
    value = psnr(ours["attenuation"], theirs, mask=fg)
    assert value >= PSNR_VTK_MIN
    assert psnr(ours["attenuation"], theirs) > value  # the background both leave black only inflates it
    mine = psnr(ours["opacity"], theirs, mask=foreground(ours["opacity"], theirs))
    assert mine < value - 3.0
    assert ours["opacity"][fg].sum() > 1.03 * theirs[fg].sum()


@pytest.mark.slow
def test_against_vtk_ray_caster_data4():
    ours, theirs, _ = _vtk_case("data4", 64)
    assert psnr(ours["attenuation"], theirs, mask=foreground(ours["attenuation"], theirs)) >= PSNR_VTK_MIN


# ------------------------------------------------------------------ equi-distance surfaces
def _view(vol, size, *, ortho=False):
    lo, hi = vol.points.min(0), vol.points.max(0)
    c = (lo + hi) / 2
    diag = float(np.linalg.norm(hi - lo))
    eye = c + diag * np.array([1.2, -1.6, 0.9])
    if ortho:
        return View(eye=eye, target=c, fov=None, height=diag, size=(size, size)), diag / 80
    return View(eye=eye, target=c, fov=35, size=(size, size)), diag / 80


def _agreement(name, size, *, ortho=False):
    vol = datasets.load(name)
    cam, step = _view(vol, size, ortho=ortho)
    s = vol.scalars()
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.5), unit=step * 4)
    ray = RayCaster(vol).render(cam, tf, step=step)
    shell = ShellRenderer(vol, cam).render(tf, step=step)
    return psnr(ray.image, shell.image), ray, shell


@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_equi_distance_surfaces_agree_with_ray_casting(name):
    value, ray, shell = _agreement(name, 40)
    assert ray.samples.sum() > 1000
    assert value >= PSNR_MIN


def test_equi_distance_surfaces_take_the_optical_model():
    vol = datasets.load("data1")
    cam, step = _view(vol, 32)
    s = vol.scalars()
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.9), unit=step * 4)
    sr, rc = ShellRenderer(vol, cam), RayCaster(vol)
    att = sr.render(tf, step=step, optical_model="attenuation").image
    assert psnr(att, rc.render(cam, tf, step=step, optical_model="attenuation").image) >= PSNR_MIN
    dense = sr.render(tf, step=step).image  # ours: the same table is denser, so brighter on black
    fg = foreground(att, dense)
    assert dense[fg].sum() > 1.03 * att[fg].sum()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["data3", "data4", "hexa2"])
def test_equi_distance_surfaces_agree_with_ray_casting_large(name):
    value, ray, shell = _agreement(name, 48)
    assert value >= PSNR_MIN


def test_orthographic_planes_are_exact_in_tetrahedra():
    """The depth is linear, so its isosurfaces in a tetrahedron are exact planes: the samples coincide.

    Where a pixel has as many fragments as ray samples, its colour is the ray caster's up to
    round-off; the counts may differ only where a sample sits on the boundary (round-off
    decides whether it is in), which is a few pixels.
    """
    value, ray, shell = _agreement("data1", 32, ortho=True)
    same = ray.samples == shell.samples
    assert ray.samples.sum() > 1000 and (~same).sum() <= 0.01 * same.size
    np.testing.assert_allclose(ray.image[same], shell.image[same], atol=1e-9)


def test_surfaces_through_vtk_agree():
    """The same surfaces drawn by VTK (far to near, depth peeling) against our compositing."""
    from polygen.volume.render.shells import render_shells_pyvista

    vol = datasets.load("data1")
    cam, step = _view(vol, 48)
    s = vol.scalars()
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.5), unit=step * 4)
    sr = ShellRenderer(vol, cam)
    ours = sr.render(tf, step=step).image
    theirs = render_shells_pyvista(sr.shells(step), cam, tf)
    assert theirs.shape == ours.shape
    assert psnr(ours, theirs) >= PSNR_MIN


def test_shell_renderer_contract():
    vol = datasets.load("data1")
    cam, step = _view(vol, 24)
    s = vol.scalars()
    sr = ShellRenderer(vol, cam)
    tf1 = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.5), unit=step)
    tf2 = TransferFunction.ramp(s.min(), s.max(), cmap="magma", opacity=(0.4, 0.0), unit=step)
    a = sr.render(tf1, step=step)
    assert (sr.shell_builds, sr.fragment_builds) == (1, 1)
    b = sr.render(tf2, step=step)
    assert sr.rebuilds == 1 and b.seconds["shells"] == 0.0 and b.seconds["skeleton"] == 0.0
    assert (sr.shell_builds, sr.fragment_builds) == (1, 1)  # a new transfer function only composites
    assert not np.allclose(a.image, b.image)
    np.testing.assert_allclose(sr.render(tf1, step=step).image, a.image)
    # turning the camera about its eye keeps skeleton and surfaces
    turned = cam.replace(target=tuple(np.array(cam.target) + [0.3, 0.0, 0.1]))
    c = sr.render(tf1, step=step, camera=turned)
    assert sr.rebuilds == 1 and c.seconds["shells"] == 0.0
    assert (sr.shell_builds, sr.fragment_builds) == (1, 2)  # new crossings for the new view
    assert psnr(c.image, RayCaster(vol).render(turned, tf1, step=step).image) >= PSNR_MIN
    # another spacing: new surfaces from the same skeleton
    sr.render(tf1, step=step * 2)
    assert sr.rebuilds == 1
    # a moved eye rebuilds
    moved = cam.replace(eye=tuple(np.array(cam.eye) + [0.5, 0.0, 0.0]))
    sr.render(tf1, step=step, camera=moved)
    assert sr.rebuilds == 2
    # the skeleton joins the distance extrema: all on the boundary when the eye is outside (Fig. 7.9(b))
    ext = sr.extrema.nodes
    on_boundary = np.isin(ext, vol.boundary_face_nodes)
    assert on_boundary.all()


def test_eye_inside_the_volume_is_the_distance_minimum():
    """Fig. 7.9(a): the eye inside is the one interior extremum (distance 0 there, or at the nearest node)."""
    vol = datasets.load("data1")
    interior_cells = np.flatnonzero(~np.isin(vol.cells, vol.boundary_face_nodes).any(axis=1))
    cell = interior_cells[len(interior_cells) // 2]
    inside = vol.points[vol.cells[cell]].mean(axis=0)
    cam = View(eye=inside, target=inside + [1.0, 0.2, 0.0], fov=60, size=(16, 16))
    sr = ShellRenderer(vol, cam)
    ext = sr.extrema
    interior = ext.nodes[~np.isin(ext.nodes, vol.boundary_face_nodes)]
    assert interior.size == 1 and ext.is_min[ext.nodes == interior[0]].all()
    assert interior[0] in vol.cells[cell]
    s = vol.scalars()
    step = 0.05
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.0, 0.3), unit=step * 4)
    assert psnr(sr.render(tf, step=step).image, RayCaster(vol).render(cam, tf, step=step).image) >= PSNR_MIN


# ------------------------------------------------------------------ bad input
def test_bad_input():
    with pytest.raises(RenderError, match="opacity must be >= 0"):
        TransferFunction([0, 1], [[0, 0, 0], [1, 1, 1]], [0.2, -0.1])
    with pytest.raises(RenderError, match="strictly ascending"):
        TransferFunction([1, 0], [[0, 0, 0], [1, 1, 1]], [0.2, 0.1])
    with pytest.raises(RenderError, match="at least one pixel"):
        View(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), size=(0, 10))
    with pytest.raises(RenderError, match="whole numbers"):
        View(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), size=(10.5, 10))
    with pytest.raises(RenderError, match="coincide"):
        View(eye=(1, 1, 1), target=(1, 1, 1))
    with pytest.raises(RenderError, match="parallel"):
        View(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 0, 1))
    with pytest.raises(RenderError, match="height > 0"):
        View(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov=None)
    with pytest.raises(RenderError, match="fov"):
        View(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov=180)
    vol = datasets.load("hollow_cube")
    cam = View(eye=(-5, 1.5, 1.5), target=(0, 1.5, 1.5), size=(4, 4))
    rc = RayCaster(vol, "linear")
    for step in (0, -1, np.nan, "a"):
        with pytest.raises(RenderError, match="step"):
            rc.render(cam, TF_FLAT, step=step)
    with pytest.raises(RenderError, match="TransferFunction"):
        rc.render(cam, {"knots": [0, 1]}, step=0.1)
    with pytest.raises(RenderError, match="light direction"):
        rc.render(cam, TF_FLAT, step=0.1, lighting=Lighting(direction=(0, 0, 0)))
    with pytest.raises(RenderError, match="finite"):
        RayCaster(vol, np.full(vol.n_points, np.nan))
    with pytest.raises(RenderError, match="optical_model"):
        rc.render(cam, TF_FLAT, step=0.1, optical_model="vtk")
    img = np.zeros((4, 4, 3))
    with pytest.raises(RenderError, match="mask"):
        psnr(img, img, mask=np.ones((3, 4), bool))
    with pytest.raises(RenderError, match="no pixel"):
        psnr(img, img, mask=np.zeros((4, 4), bool))


@pytest.mark.parametrize("keep", [False, True])
def test_renderers_pickle_and_copy(keep):
    """A renderer a user holds pickles and deep-copies (Dask, multiprocessing): the copy draws the same image."""
    import copy
    import pickle

    vol = datasets.load("hollow_cube")
    cam, step = _view(vol, 16)
    s = vol.scalars()
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.05, 0.4), unit=step * 4)
    from polygen.volume.render import _kernels

    rc = RayCaster(vol, keep_samples=keep)
    image = rc.render(cam, tf, step=step).image
    image = rc.render(cam, tf, step=step).image  # with kept samples: composited again, without a walk
    builds = {k: len(getattr(_kernels, k).signatures) for k in ("cast", "composite_samples")}
    for other in (pickle.loads(pickle.dumps(rc)), copy.deepcopy(rc)):
        np.testing.assert_array_equal(other.render(cam, tf, step=step).image, image)
    # the copies' arrays are read-only again, as the original's: their kernels are not compiled a second time
    assert {k: len(getattr(_kernels, k).signatures) for k in builds} == builds
    sr = ShellRenderer(vol, cam)
    shells = sr.render(tf, step=step).image
    for other in (pickle.loads(pickle.dumps(sr)), copy.deepcopy(sr)):
        np.testing.assert_array_equal(other.render(tf, step=step).image, shells)
