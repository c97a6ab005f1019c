"""Merging constrained segments that lie closer than a gap (mesh2d.merge_close_segments).

Oracles: brute-force distances between the kept pieces (shapely), and the hand-built
cases' expected survivors."""

import itertools

import numpy as np
import pytest
import shapely

from polygen.mesh2d import InvalidDomainError, merge_close_segments, planar_graph

SQUARE = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
TAN10 = np.tan(np.radians(10.0))


def _check_invariants(outer, holes, ends, gap):
    """What merging promises: no two distinct end points closer than ``gap``, no two pieces
    that do not touch closer than ``gap``, no piece closer than ``gap`` to a ring it does not
    touch; and the pieces still form a planar graph."""
    tiny = 1e-9 * np.ptp(outer, axis=0).max()
    pts = ends.reshape(-1, 2)
    d = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    assert np.all((d <= tiny) | (d >= gap * (1 - 1e-9)))
    lines = [shapely.LineString(e) for e in ends]
    for a, b in itertools.combinations(lines, 2):
        dist = a.distance(b)
        assert dist <= tiny or dist >= gap * (1 - 1e-9)
    rings = shapely.MultiLineString([np.concatenate([r, r[:1]]) for r in [outer, *holes]])
    for a in lines:
        dist = a.distance(rings)
        assert dist <= tiny or dist >= gap * (1 - 1e-9)
    planar_graph(outer, holes, ends)


def test_bands_near_misses_short_and_shallow_lines_merged():
    gap = 0.3
    segs = np.array([
        [[0.0, 5.0], [10.0, 5.0]],                   # 0: wall to wall, kept (longest)
        [[0.0, 5.04], [10.0, 5.04]],                 # 1: a band 0.04 wide with 0: dropped
        [[0.1, 0.0], [0.1, 5.0]],                    # 2: 0.1 from the left wall: dropped
        [[3.0, 5.0], [3.0, 0.0]],                    # 3: a T at 90 degrees: kept whole
        [[6.0, 2.0], [6.2, 2.0]],                    # 4: shorter than the gap: dropped
        [[7.0, 5.0], [10.0, 5.0 + 3.0 * TAN10]],     # 5: 10 degrees off 0: cut near the junction
        [[5.0, 8.0], [9.92, 8.0]],                   # 6: ends 0.08 from the right wall: snapped onto it
    ])
    ends, kinds, src = merge_close_segments(SQUARE, [], segs, gap=gap)
    assert kinds == ["D1"] * len(ends)
    assert sorted(set(src.tolist())) == [0, 3, 5, 6]
    np.testing.assert_allclose(ends[src == 0][0], segs[0])
    np.testing.assert_allclose(ends[src == 3][0], segs[3])
    # 5 now starts gap away from line 0 (about gap / sin 10 deg from the junction); the cut
    # is conservative by the buffer polygon's 1 / cos(pi / 32) = 1.0048 at most
    (a, b), = ends[src == 5]
    assert gap <= a[1] - 5.0 <= gap / np.cos(np.pi / 32) + 1e-12
    assert np.allclose(b, segs[5, 1])
    np.testing.assert_allclose(ends[src == 6][0], [[5.0, 8.0], [10.0, 8.0]])
    _check_invariants(SQUARE, [], ends, gap)


def test_d0_lines_are_kept_before_longer_d1_lines():
    segs = np.array([[[0.0, 5.0], [10.0, 5.0]], [[0.0, 5.1], [4.0, 5.1]]])
    _, kinds, src = merge_close_segments(SQUARE, [], segs, ["D1", "D0"], gap=0.3)
    assert src.tolist() == [1, 0] or (sorted(src.tolist()) == [0, 1] and "D0" in kinds)
    # the D0 line survives whole; the D1 line keeps only its part beyond the D0 line's reach
    ends, kinds, src = merge_close_segments(SQUARE, [], segs, ["D1", "D0"], gap=0.3)
    np.testing.assert_allclose(ends[src == 1][0], segs[1])
    assert kinds[list(src).index(1)] == "D0"
    assert np.all(ends[src == 0][:, :, 0].min() >= 4.0)


def test_gap_zero_changes_nothing_and_bad_input_is_named():
    segs = np.array([[[0.0, 5.0], [10.0, 5.0]], [[0.0, 5.04], [10.0, 5.04]]])
    ends, kinds, src = merge_close_segments(SQUARE, [], segs, gap=0.0)
    np.testing.assert_array_equal(ends, segs)
    assert src.tolist() == [0, 1]
    with pytest.raises(InvalidDomainError, match="gap"):
        merge_close_segments(SQUARE, [], segs, gap=-1.0)
    with pytest.raises(InvalidDomainError, match="segments"):
        merge_close_segments(SQUARE, [], segs[:, 0], gap=0.3)
    with pytest.raises(InvalidDomainError, match="kind"):
        merge_close_segments(SQUARE, [], segs, ["D1", "D2"], gap=0.3)


@pytest.mark.parametrize("gap", [0.2125, 0.3])
def test_the_fig_4_8_scenes_lines(gap):
    """The simplified discontinuity lines of the Fig. 4.8 scene (39 on the floor, with
    penumbra bands 0.04 wide): merged, they keep the invariants on every polygon."""
    from polygen.discontinuity import simplified_discontinuity
    from polygen.radiosity import scenes

    sc = scenes.three_rectangles_box()
    sd = simplified_discontinuity(sc)
    for k, sg in sd.segments.items():
        poly = sc.polygons[k]
        e, kinds = sg.in_plane(poly)
        ends, _, _ = merge_close_segments(poly.exterior_2d, poly.holes_2d, e, kinds, gap=gap)
        _check_invariants(poly.exterior_2d, poly.holes_2d, ends, gap)
