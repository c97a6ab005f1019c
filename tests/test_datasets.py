"""Tests of polygen.volume.datasets: topology implied by construction, exact fields, determinism, cache."""

import numpy as np
import pytest

from polygen.volume import datasets as ds
from polygen.volume.datasets import fem, parts, tiny

from _surfaces import TINY_VOLUMES  # noqa: E402

TINY = list(TINY_VOLUMES)
PARTS_FAST = ["data1", "data2", "hexa1"]
PARTS_SLOW = ["data3", "data4", "data5", "hexa2", "hexa3"]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A private cache directory for the whole module (the user's cache is never touched)."""
    path = tmp_path_factory.mktemp("polygen-cache")
    with pytest.MonkeyPatch.context() as mp:  # module scope: the function-scoped fixture cannot serve
        mp.setenv(ds.CACHE_ENV, str(path))
        yield path


@pytest.fixture(scope="module")
def data1(cache):
    return ds.load("data1")


# ------------------------------------------------------------ registry
def test_names_and_info():
    names = ds.names()
    for required in ["data1", "data2", "data3", "data4", "data5", "2M", "10M", "hexa1", "hexa2", "hexa3", *TINY]:
        assert required in names
    assert len(set(names)) == len(names)
    for name in names:
        inf = ds.info(name)
        assert inf.name == name
        assert inf.cell_type in ("tetra", "hexa")
        assert len(inf.genus) == 1 + inf.n_voids
        assert inf.n_through_holes == sum(inf.genus)
    thesis = [ds.info(f"data{i}").thesis["cells"] for i in range(1, 6)]
    assert thesis == [20736, 61680, 346644, 557868, 458664]
    assert [ds.info(f"data{i}").target_cells for i in range(1, 6)] == thesis


def test_bad_requests_raise():
    with pytest.raises(ds.DatasetError, match="unknown data set 'nope'"):
        ds.load("nope")
    with pytest.raises(ds.DatasetError, match="no field 'pressure'"):
        ds.load("torus", field="pressure")
    with pytest.raises(ds.DatasetError, match="seed"):
        ds.load("torus", seed=-1)
    with pytest.raises(ds.DatasetError, match="seed"):
        ds.load("torus", seed=1.5)
    with pytest.raises(ds.DatasetError, match="points"):
        ds.gaussian_field(np.zeros((3, 2)), n_bumps=3)
    with pytest.raises(ds.DatasetError, match="n_bumps"):
        ds.gaussian_field(np.zeros((3, 3)), n_bumps=0)
    with pytest.raises(ds.DatasetError, match="origin"):
        ds.distance_field(np.zeros((3, 3)), origin=[0.0, np.nan, 1.0])
    with pytest.raises(ValueError):  # DatasetError is a ValueError
        ds.info(3)


# ------------------------------------------------------------ tiny volumes
@pytest.mark.parametrize("name", TINY)
def test_tiny_topology_is_what_the_construction_implies(name):
    inf = ds.info(name)
    vol = ds.load(name)
    assert vol.cell_type == inf.cell_type
    assert vol.n_cells == inf.target_cells
    assert tuple(vol.group_genus.tolist()) == inf.genus
    assert vol.n_voids == inf.n_voids
    assert vol.n_through_holes == inf.n_through_holes
    assert not ds.is_cached(name)  # built on the fly


def test_tiny_hand_counts():
    # by hand: V + F - E of the boundary, and the sizes of the grids
    two = ds.load("two_tets")
    assert (two.n_points, two.boundary_faces.shape[0]) == (5, 6)
    assert (two.face_neighbors >= 0).sum() == 2  # one shared face, seen from both sides
    hexes = ds.load("two_hexes")
    assert (hexes.n_points, hexes.boundary_faces.shape[0]) == (12, 10)
    ring = ds.load("torus_hex")
    assert ring.n_points == 32 and ring.boundary_faces.shape[0] == 32  # 8 top, 8 bottom, 12 outer, 4 inner
    assert ring.group_euler.tolist() == [0]
    hollow = ds.load("hollow_cube_hex")
    assert hollow.boundary_faces.shape[0] == 54 + 6  # outer 6 * 9, void 6
    assert hollow.group_is_void.tolist() == [False, True]
    g3 = ds.load("genus3_hex")
    assert g3.group_euler.tolist() == [2 - 2 * 3]


@pytest.mark.parametrize("name", ["one_tet", "two_tets", "torus", "hollow_cube", "genus3"])
def test_tiny_tetra_volume_equals_hexa_volume(name):
    # the 6-tetrahedron split must fill each cube exactly: total volume = number of unit cubes
    vol = ds.load(name)
    p = vol.points[vol.cells]
    v6 = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    assert np.all(v6 > 0)
    expected = {"one_tet": 1 / 6, "two_tets": 1 / 6 + 1 / 3, "torus": 8, "hollow_cube": 26, "genus3": 18}[name]
    assert v6.sum() / 6 == pytest.approx(expected)


@pytest.mark.parametrize("name", TINY)
def test_tiny_fields_exact(name):
    vol = ds.load(name)
    x, y, z = vol.points.T
    np.testing.assert_array_equal(vol.scalars(), x + 0.31 * y + 0.097 * z)
    lo, hi = vol.points.min(0), vol.points.max(0)
    eye = lo - 0.25 * (hi - lo)
    np.testing.assert_allclose(vol.fields["distance"], np.sqrt(((vol.points - eye) ** 2).sum(1)), rtol=1e-15)
    # the linear field's only extrema are the nodes of smallest and largest x + 0.31 y + 0.097 z
    mx, mn = ds.node_extrema(vol)
    f = vol.scalars()
    assert mx.tolist() == [int(np.argmax(f))] and mn.tolist() == [int(np.argmin(f))]


def test_field_order():
    vol = ds.load("torus", field="distance")
    assert list(vol.fields)[0] == "distance"
    np.testing.assert_array_equal(vol.scalars(), vol.fields["distance"])
    assert set(vol.fields) == {"linear", "distance", "gaussians"}


# ------------------------------------------------------------ helpers against naive references
def _naive_extrema(vol, values):
    nbrs = [set() for _ in range(vol.n_points)]
    for cell in vol.cells:
        for a, b in vol.local_edges:
            nbrs[cell[a]].add(cell[b])
            nbrs[cell[b]].add(cell[a])
    mx = [i for i in range(vol.n_points) if all(values[i] > values[j] for j in nbrs[i])]
    mn = [i for i in range(vol.n_points) if all(values[i] < values[j] for j in nbrs[i])]
    return mx, mn


@pytest.mark.parametrize("name", ["genus3", "genus3_hex", "hollow_cube", "hollow_cube_hex"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_node_extrema_matches_naive(name, seed):
    vol = ds.load(name)
    rng = np.random.default_rng(seed)
    # rounded random values: ties happen, and tied nodes are no extrema
    vol.add_field("r", np.round(rng.random(vol.n_points) * 6))
    mx, mn = ds.node_extrema(vol, "r")
    nmx, nmn = _naive_extrema(vol, vol.fields["r"])
    assert mx.tolist() == nmx and mn.tolist() == nmn
    assert ds.count_extrema(vol, "r") == (len(nmx), len(nmn))


def test_gaussian_field_matches_naive_and_is_seeded():
    rng = np.random.default_rng(5)
    pts = rng.random((300, 3)) * [3.0, 2.0, 1.0]
    f = ds.gaussian_field(pts, n_bumps=7, seed=3, width=0.4, cutoff=4.0)
    np.testing.assert_array_equal(f, ds.gaussian_field(pts, n_bumps=7, seed=3, width=0.4, cutoff=4.0))
    assert not np.array_equal(f, ds.gaussian_field(pts, n_bumps=7, seed=4, width=0.4, cutoff=4.0))
    # the same draws as the implementation documents, summed naively
    r = np.random.default_rng(3)
    lo, hi = pts.min(0), pts.max(0)
    centres = lo + r.random((7, 3)) * (hi - lo)
    amps = r.choice([-1.0, 1.0], 7) * r.uniform(0.5, 1.0, 7)
    sig = 0.4 * (np.prod(hi - lo) / 7) ** (1 / 3) * r.uniform(0.7, 1.3, 7)
    d2 = ((pts[:, None, :] - centres[None]) ** 2).sum(-1)
    bump = np.exp(-0.5 * d2 / sig**2) - np.exp(-0.5 * 16.0)
    naive = (amps * np.where(d2 < (4.0 * sig) ** 2, bump, 0.0)).sum(1)
    np.testing.assert_allclose(f, naive, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_heat_solve_reproduces_linear_solution(cell_type):
    # a 4x2x2 bar, no sources, u = 0 on x = 0 and u = 1 on x = 4, insulated elsewhere: u = x / 4,
    # which linear tetrahedra and trilinear hexahedra represent exactly
    rng = np.random.default_rng(0)
    points, cells = tiny._grid_volume(np.ones((4, 2, 2), bool), cell_type)
    inner = (points[:, 0] > 0) & (points[:, 0] < 4)
    points[inner] += rng.uniform(-0.15, 0.15, (inner.sum(), 3)) * [1, 0, 0]  # not a regular grid
    part = parts._Part("bar", "", 0, 0, None, ((parts._on_plane(0, 0.0), 0.0), (parts._on_plane(0, 4.0), 1.0)))
    u = fem._heat_field(points, cells, part, spacing=1.0, n_sources=0, seed=0)
    np.testing.assert_allclose(u, points[:, 0] / 4.0, atol=1e-8)


# ------------------------------------------------------------ generated parts
def test_data1_cells_genus_fields(data1):
    inf = ds.info("data1")
    assert abs(data1.n_cells / 20736 - 1) <= 0.05
    assert tuple(data1.group_genus.tolist()) == inf.genus == (2, 0)
    assert data1.n_voids == 1
    assert list(data1.fields) == ["fem", "gaussians", "distance"]
    np.testing.assert_allclose(
        data1.fields["distance"], np.linalg.norm(data1.points - ds.distance_origin(data1.points), axis=1), rtol=1e-14
    )


def test_data1_fem_field_has_interior_extrema_of_both_kinds(data1):
    mx, mn = ds.node_extrema(data1, "fem")
    surface = np.unique(data1.boundary_face_nodes)
    inner_max = np.setdiff1d(mx, surface)
    inner_min = np.setdiff1d(mn, surface)
    assert inner_max.size >= 3 and inner_min.size >= 3
    # a modest number, like the thesis's 21 for data 1
    assert 5 <= mx.size + mn.size <= 100
    # the Dirichlet patches hold their values: the cooled hole at 0, the end face x = 4 at 1
    fem = data1.fields["fem"]
    on_hole = np.abs(np.hypot(data1.points[:, 0] - 1, data1.points[:, 1] - 1) - 0.4) < 1e-6
    on_end = np.abs(data1.points[:, 0] - 4) < 1e-6
    assert on_hole.sum() > 50 and on_end.sum() > 50
    np.testing.assert_allclose(fem[on_hole], 0.0, atol=1e-12)
    np.testing.assert_allclose(fem[on_end], 1.0, atol=1e-12)
    # sources and sinks: the field goes above and below the patch values
    assert fem.max() > 1.0 and fem.min() < 0.0


def test_determinism_and_seed(data1):
    again = ds.load("data1", cache=False)
    np.testing.assert_array_equal(again.points, data1.points)
    np.testing.assert_array_equal(again.cells, data1.cells)
    for name in data1.fields:
        np.testing.assert_array_equal(again.fields[name], data1.fields[name])
    other = ds.load("data1", seed=1, cache=False)
    np.testing.assert_array_equal(other.cells, data1.cells)  # the mesh depends on the name only
    assert not np.allclose(other.fields["fem"], data1.fields["fem"])
    assert not np.allclose(other.fields["gaussians"], data1.fields["gaussians"])


def test_cache_round_trip(cache, data1):
    path = ds.cache_path("data1")
    assert path.parent == cache and path.is_file() and ds.is_cached("data1")
    assert not ds.is_cached("data1", seed=7)
    assert not list(cache.glob("*.tmp"))  # atomic write leaves no temporaries
    with np.load(path, allow_pickle=False) as z:
        assert not z.zip.infolist()[0].compress_type  # stored, not deflated
    back = ds.load("data1")
    np.testing.assert_array_equal(back.cells, data1.cells)
    np.testing.assert_array_equal(back.fields["fem"], data1.fields["fem"])
    assert ds.build("data1") == path
    # a foreign file under the key's name is not trusted: it is rebuilt and overwritten
    np.savez(path, points=np.zeros((4, 3)))
    rebuilt = ds.load("data1")
    np.testing.assert_array_equal(rebuilt.points, data1.points)
    with np.load(path, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["cells"], data1.cells)


def test_cache_dir_from_environment(cache, monkeypatch, tmp_path):
    monkeypatch.setenv(ds.CACHE_ENV, str(tmp_path / "elsewhere"))
    assert ds.cache_dir() == tmp_path / "elsewhere"
    assert ds.cache_path("data2", seed=3).parent == tmp_path / "elsewhere"
    assert "seed3" in ds.cache_path("data2", seed=3).name
    monkeypatch.delenv(ds.CACHE_ENV)
    assert ds.cache_dir().name == "volumes"


def _check_part(name):
    inf = ds.info(name)
    vol = ds.load(name)
    assert vol.cell_type == inf.cell_type
    assert abs(vol.n_cells / inf.target_cells - 1) <= 0.05, (name, vol.n_cells)
    assert tuple(vol.group_genus.tolist()) == inf.genus
    assert vol.n_voids == inf.n_voids
    assert vol.n_through_holes == inf.n_through_holes
    mx, mn = ds.node_extrema(vol, "fem")
    surface = np.unique(vol.boundary_face_nodes)
    assert np.setdiff1d(mx, surface).size >= 3 and np.setdiff1d(mn, surface).size >= 3
    return vol, mx.size + mn.size


@pytest.mark.parametrize("name", ["data2", "hexa1"])
def test_part_fast(cache, name):
    _, n_ext = _check_part(name)
    assert 10 <= n_ext <= 200


@pytest.mark.slow
@pytest.mark.parametrize("name", PARTS_SLOW)
def test_part_slow(cache, name):
    vol, n_ext = _check_part(name)
    if name == "data5":
        assert n_ext >= 2000  # thousands, as Table 7.1's 5986
    else:
        assert n_ext <= 1000  # tens to hundreds


# ------------------------------------------------------------ command line
def test_cli_list_build_info(cache, capsys):
    from polygen.cli import main

    assert main(["datasets"]) == 0
    out = capsys.readouterr().out
    for name in ["data1", "data5", "10M", "hexa1", "torus"]:
        assert name in out
    assert str(cache) in out
    assert main(["datasets", "build", "torus", "--no-progress"]) == 0
    assert "genus by group [1]" in capsys.readouterr().out
    assert main(["datasets", "info", "genus3"]) == 0
    assert "genus by boundary group (3,)" in capsys.readouterr().out
    assert main(["datasets", "build", "nope"]) == 2
    assert main(["datasets", "build"]) == 2


def test_listing_shows_cached_state(cache, data1, capsys):
    from polygen.cli import main

    assert main(["datasets"]) == 0
    lines = {ln.split()[0]: ln.split() for ln in capsys.readouterr().out.splitlines() if ln.strip()}
    assert "cached" in lines["data1"]
    for name in ds.names():
        assert ("cached" in lines[name]) == ds.is_cached(name)


def test_cache_with_int64_cells_is_read_as_int32(tmp_path):
    """A cache file written with int64 cells (before the volume kept int32 ones) is narrowed while read,
    block by block; an id outside the nodes makes the file unreadable (rebuilt), not a wrapped id."""
    from polygen.volume.datasets import registry

    points, cells = tiny._tiny("torus", "tetra")
    cells, fields = np.asarray(cells, np.int64), {}
    path = tmp_path / "c.npz"
    registry._write_cache(path, points, cells, fields, "k")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(registry, "_BLOCK_ROWS", 7)  # several blocks and a short last one
        back = registry._read_cache(path, "k")
        assert back[1].dtype == np.int32
        np.testing.assert_array_equal(back[1], cells)
        cells[-1, 0] = points.shape[0] + 2**32
        registry._write_cache(path, points, cells, fields, "k")
        assert registry._read_cache(path, "k") is None
