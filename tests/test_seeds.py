"""Active-cell search structures (thesis 5.4.1, Table 5.2) against brute force."""

import numpy as np
import pytest

from polygen.volume import seeds
from polygen.volume.seeds import IntervalError, cell_ranges
from polygen.volume.seeds.span_filter import SpanFilter
from polygen.volume.seeds.span_space import SpanSpace

# every method, and the parameter settings that take different code paths
CONFIGS = [
    ("full-scan", {}),
    ("sorted-lists", {}),
    ("span-filter", {}),
    ("span-filter", {"n_buckets": 1}),
    ("span-filter", {"n_buckets": 7}),
    ("span-filter", {"layout": "by-min"}),
    ("span-filter", {"layout": "by-min", "n_buckets": 1}),
    ("span-filter", {"layout": "by-min", "n_buckets": 7}),
    ("span-space", {}),
    ("issue-lattice", {}),
    ("issue-lattice", {"L": 1}),
    ("issue-lattice", {"L": 5}),
    ("issue-lattice", {"L": 5, "inner": "sorted"}),
    ("issue-lattice", {"L": 40}),
    ("interval-tree", {}),
]
CONFIG_IDS = [name + "".join(f"-{k}={v}" for k, v in p.items()) for name, p in CONFIGS]


def _fem_like(m, rng):
    """S_min uniform, spans small and skewed, as for a smooth field on a fine mesh."""
    lo = rng.random(m)
    return lo, lo + rng.exponential(0.5 * m ** (-1 / 3), m)


def _datasets():
    rng = np.random.default_rng(1234)
    out = {}
    lo = rng.random(300)
    out["uniform"] = (lo, lo + rng.random(300) * (1 - lo))
    centres = rng.choice([0.1, 0.5, 0.52, 0.9], 300)
    lo = centres + rng.normal(0, 0.01, 300)
    out["clustered"] = (lo, lo + np.abs(rng.normal(0, 0.02, 300)))
    lo = rng.integers(0, 5, 300).astype(float)
    out["many-equal"] = (lo, lo + rng.integers(0, 3, 300))
    lo = rng.integers(-3, 3, 200).astype(float)
    out["degenerate"] = (lo, lo.copy())  # zero-width intervals
    out["all-same"] = (np.full(50, 2.5), np.full(50, 2.5))
    out["fem-like"] = _fem_like(250, rng)
    # intervals from real cells: node values shared between cells, many endpoints equal
    cells = rng.integers(0, 60, (250, 4))
    out["from-cells"] = cell_ranges(cells, np.round(rng.normal(size=60), 1))
    out["empty"] = (np.empty(0), np.empty(0))
    out["one"] = (np.array([0.25]), np.array([0.75]))
    out["one-point"] = (np.array([-1.0]), np.array([-1.0]))
    return out


DATASETS = _datasets()


def _values(lo, hi):
    """Every endpoint, the midpoints between endpoints, and values outside the range."""
    ends = np.unique(np.r_[lo, hi, 0.0])
    mids = 0.5 * (ends[1:] + ends[:-1])
    outside = [-np.inf, np.inf, -1e300, 1e300, -0.0]
    if ends.size:
        outside += [ends[0] - 1.0, ends[-1] + 1.0, np.nextafter(ends[0], -np.inf), np.nextafter(ends[-1], np.inf)]
    return np.r_[ends, mids, outside]


@pytest.mark.parametrize("data", list(DATASETS))
@pytest.mark.parametrize(("name", "params"), CONFIGS, ids=CONFIG_IDS)
def test_active_equals_brute_force(name, params, data):
    lo, hi = DATASETS[data]
    m = lo.size
    search = seeds.get(name).build(lo, hi, **params)
    assert search.n_cells == m and search.preprocess_s >= 0.0
    for v in _values(lo, hi):
        truth = np.flatnonzero((lo <= v) & (hi >= v))
        np.testing.assert_array_equal(search.active(v), truth, err_msg=f"{name} {params} {data} C={v!r}")
        r = search.query(v)
        assert r.cells.dtype == np.int64
        assert np.all((r.cells >= 0) & (r.cells < m))
        assert np.bincount(r.cells, minlength=m).max(initial=0) <= 1, "a cell was handed over twice"
        handed = np.zeros(m, dtype=bool)
        handed[r.cells] = True
        assert handed[truth].all(), "an active cell is missing from the candidates"
        assert r.n_hits == truth.size
        assert r.n_tested >= r.cells.size >= r.n_hits
        if name == "full-scan":
            assert r.n_tested == m
        if search.cells_in_order:  # what the propagation relies on to skip its sort
            assert np.all(np.diff(r.cells) > 0)


@pytest.mark.parametrize("data", ["uniform", "many-equal", "from-cells", "fem-like"])
def test_counters_closed_forms(data):
    """n_tested equals what the method's description says it scans."""
    lo, hi = DATASETS[data]
    m = lo.size
    sl = seeds.get("sorted-lists").build(lo, hi)
    sf = SpanFilter.build(lo, hi, n_buckets=9)
    it = seeds.get("interval-tree").build(lo, hi)
    depth = int(np.ceil(np.log2(2 * m + 1)))
    g0, g1 = lo.min(), hi.max()
    width = (g1 - g0) / 9

    def bucket(x):
        return np.clip(np.floor((x - g0) / width), 0, 8).astype(int)

    for v in _values(lo, hi):
        assert sl.query(v).n_tested == min(np.sum(lo <= v), np.sum(hi >= v))
        r = sf.query(v)
        if g0 <= v <= g1:
            # the class of C holds every cell whose class range covers it
            b = bucket(v)
            assert r.n_tested == np.sum((bucket(lo) <= b) & (b <= bucket(hi)))
        else:
            assert r.n_tested == 0
        r = it.query(v)
        assert r.n_tested <= r.n_hits + depth  # at most one failed comparison per level


@pytest.mark.parametrize("data", ["many-equal", "degenerate", "uniform", "from-cells"])
def test_kd_tree_is_a_kd_tree(data):
    """In every subtree range the middle element splits by S_min (even depth) or S_max (odd)."""
    lo, hi = DATASETS[data]
    search = SpanSpace.build(lo, hi)
    perm = search.perm
    np.testing.assert_array_equal(np.sort(perm), np.arange(lo.size))
    np.testing.assert_array_equal(search.pts, np.c_[lo[perm], hi[perm]].reshape(-1, 2))
    stack = [(0, lo.size, 0)]
    while stack:
        a, b, d = stack.pop()
        if b - a <= 1:
            continue
        mid = (a + b) // 2
        key = lo if d % 2 == 0 else hi
        assert np.all(key[perm[a:mid]] <= key[perm[mid]])
        assert np.all(key[perm[mid + 1 : b]] >= key[perm[mid]])
        stack += [(a, mid, d + 1), (mid + 1, b, d + 1)]


def test_structures_copy_their_input():
    lo, hi = (a.copy() for a in DATASETS["uniform"])
    built = {name: cls.build(lo, hi) for name, cls in seeds.METHODS.items()}
    truth = np.flatnonzero((lo <= 0.5) & (hi >= 0.5))
    lo[:] = 10.0
    hi[:] = 11.0
    for name, search in built.items():
        np.testing.assert_array_equal(search.active(0.5), truth, err_msg=name)


def test_far_fewer_cells_tested_on_fem_like_intervals():
    """200k short intervals: output-sensitive structures test a small fraction of what a scan does."""
    rng = np.random.default_rng(7)
    m = 200_000
    lo, hi = _fem_like(m, rng)
    values = np.linspace(lo.min(), hi.max(), 22)[1:-1]
    tested = {}
    for name, cls in seeds.METHODS.items():
        search = cls.build(lo, hi)
        rs = [search.query(v) for v in values]
        hits = [r.n_hits for r in rs]
        tested[name] = sum(r.n_tested for r in rs)
        if name == "full-scan":
            n_hits = sum(hits)
        else:
            assert sum(hits) == n_hits
    assert tested["full-scan"] == 20 * m
    assert n_hits < tested["full-scan"] / 50  # k ~ n^(2/3): the premise of Table 5.1
    for name in ("span-space", "interval-tree", "issue-lattice"):
        assert tested[name] < tested["full-scan"] / 20, (name, tested)
        assert tested[name] < 2 * n_hits, (name, tested, n_hits)
    assert tested["interval-tree"] <= n_hits + 20 * 20  # log2(4e5) < 20 levels per query
    assert tested["sorted-lists"] < tested["full-scan"] / 1.5  # never more than half the cells
    assert tested["span-filter"] < tested["full-scan"] / 10  # 64 classes


@pytest.mark.parametrize(
    ("cmin", "cmax", "match"),
    [
        ([0.0, np.nan, 1.0], [1.0, 2.0, 3.0], "cmin must be finite.*NaN.*cell.*1"),
        ([0.0, 1.0, 1.0], [1.0, 2.0, np.nan], "cmax must be finite.*NaN.*2"),
        ([0.0, -np.inf], [1.0, 2.0], "cmin must be finite.*infinite.*1"),
        ([0.0, 3.0, 1.0], [1.0, 2.0, 3.0], r"cmin > cmax.*cell 1 has cmin=3\.0 > cmax=2\.0"),
        ([0.0, 1.0], [1.0, 2.0, 3.0], "same length.*2 and 3"),
        ([[0.0, 1.0]], [[1.0, 2.0]], "1-D"),
        (["a"], [1.0], "real numbers"),
    ],
)
@pytest.mark.parametrize("name", list(seeds.METHODS))
def test_bad_intervals_raise(name, cmin, cmax, match):
    with pytest.raises(ValueError, match=match):
        seeds.get(name).build(cmin, cmax)


@pytest.mark.parametrize("name", list(seeds.METHODS))
def test_bad_query_raises(name):
    search = seeds.get(name).build([0.0, 1.0], [1.0, 2.0])
    with pytest.raises(IntervalError, match="NaN"):
        search.query(np.nan)
    with pytest.raises(IntervalError, match="scalar"):
        search.query([0.5])
    with pytest.raises(IntervalError, match="real number"):
        search.active("half")


@pytest.mark.parametrize(
    ("name", "params", "match"),
    [
        ("span-filter", {"n_buckets": 0}, "n_buckets"),
        ("span-filter", {"n_buckets": 2.5}, "n_buckets"),
        ("span-filter", {"layout": "by-max"}, "layout"),
        ("issue-lattice", {"L": 0}, "L must be"),
        ("issue-lattice", {"inner": "octree"}, "inner"),
    ],
)
def test_bad_parameters_raise(name, params, match):
    with pytest.raises(IntervalError, match=match):
        seeds.get(name).build([0.0], [1.0], **params)


def test_registry():
    assert list(seeds.METHODS) == [
        "full-scan", "sorted-lists", "span-filter", "span-space", "issue-lattice", "interval-tree",
    ]
    for name, cls in seeds.METHODS.items():
        assert cls.name == name and seeds.get(name) is cls
    with pytest.raises(IntervalError, match="unknown active-cell search 'octree'.*span-space"):
        seeds.get("octree")
    with pytest.raises(ValueError, match="already registered"):

        class Other(seeds.FullScan):
            name = "span-space"

        seeds.register(Other)


@pytest.mark.parametrize("k", [4, 8])
def test_cell_ranges_against_numpy(k):
    rng = np.random.default_rng(k)
    cells = rng.integers(0, 500, (3000, k))
    scalars = rng.normal(size=500)
    cmin, cmax = cell_ranges(cells, scalars)
    np.testing.assert_array_equal(cmin, scalars[cells].min(axis=1))
    np.testing.assert_array_equal(cmax, scalars[cells].max(axis=1))
    e0, e1 = cell_ranges(np.empty((0, 4), dtype=np.int64), scalars)
    assert e0.shape == e1.shape == (0,)


@pytest.mark.parametrize(
    ("cells", "scalars", "match"),
    [
        ([[0, 1, 2, 5]], np.zeros(5), r"outside \[0, 5\).*cells 0"),
        ([[0, 1, 2, 3], [0, -1, 2, 3]], np.zeros(5), "outside.*cells 1"),
        ([[0, 1, 2, 3]], [0.0, 1.0, np.nan, 0.0], "finite.*nodes 2"),
        ([0, 1, 2, 3], np.zeros(5), r"\(M, k\)"),
        ([[0.0, 1.0, 2.0, 3.0]], np.zeros(5), "integer"),
        ([[0, 1, 2, 3]], np.zeros((5, 1)), "1-D"),
    ],
)
def test_cell_ranges_bad_input(cells, scalars, match):
    with pytest.raises(IntervalError, match=match):
        cell_ranges(cells, scalars)


# ------------------------------------------------------------------ the one seed interface on volumes
def test_every_seed_source_serves_the_same_interface(tiny_volume):
    """Each registered source (searches, extrema graph, thinning) builds on a volume and answers ``Seeds``
    from which the propagation reaches the whole surface of the full scan."""
    from polygen.volume import registry
    from polygen.volume.isosurface import extract
    from polygen.volume.propagate import Propagator
    from polygen.volume.seeds import Seeds, SeedSource, seed_source
    from polygen.volume.surface import IsoSurfaceError, same_surface

    from _surfaces import iso_values

    names = registry.seed_source_names()
    assert set(names) >= {"full-scan", "sorted-lists", "span-filter", "span-space", "issue-lattice",
                          "interval-tree", "extrema-graph", "extrema-graph-loops", "thinning"}
    field = next(iter(tiny_volume.fields))
    s = tiny_volume.scalars(field)
    prop = Propagator(tiny_volume, field)
    for name in names:
        src = seed_source(tiny_volume, field, name)
        assert isinstance(src, SeedSource) and src.name == name and src.preprocess_s >= 0
        for v in iso_values(s, 12, seed=1):
            found = src.query(v)
            assert isinstance(found, Seeds) and found.value == v and found.seconds >= 0
            assert found.cells.dtype == np.int64 and found.cells.ndim == 1
            assert np.all((found.cells >= 0) & (found.cells < tiny_volume.n_cells))
            assert found.n_tested >= 0 and found.found is not None
            ref = extract(tiny_volume, v, field=field)
            assert same_surface(prop.extract(v, found.cells), ref, geometry=False), (name, v)
    with pytest.raises(IsoSurfaceError, match="unknown seed source"):
        seed_source(tiny_volume, field, "octree")


def test_seeds_unpack_as_the_old_triple():
    from polygen.volume import datasets
    from polygen.volume.seeds import seed_source

    vol = datasets.load("torus")
    found = seed_source(vol, None, "span-space").query(0.4)
    cells, n_tested, seconds = found
    assert cells is found.cells and n_tested == found.n_tested and seconds == found.seconds
    assert found[0] is found.cells and len(found) == 3
