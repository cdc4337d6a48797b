"""SmartRTL's way back thinned as ArduPilot's AP_SmartRTL thins it, worked by hand:
detect_simplifications (a point is dropped unless it is more than SRTL_ACCURACY / 2 from the
segment between the points kept either side), segment_segment_dist (the two lines' closest
points, each clamped to its own leg) and detect_loops (legs less than 0.99 SRTL_ACCURACY
apart), with the loop buffer of a quarter of SRTL_POINTS."""

from __future__ import annotations

import pytest

from lfctl.link.smartrtl import clean, leg_distances, prune_loops, simplify

# --- simplify ------------------------------------------------------------------------------------


def test_three_points_on_a_line_simplify_to_the_two_ends() -> None:
    # (1, 0.1) is 0.1 m off the segment (0, 0)-(2, 0), within 0.5: dropped
    assert simplify([(0.0, 0.0), (1.0, 0.1), (2.0, 0.0)], 0.5) == [(0.0, 0.0), (2.0, 0.0)]


def test_a_point_exactly_epsilon_off_the_line_is_dropped() -> None:
    # (1, 0.5) is 0.5 m off (0, 0)-(2, 0): kept only if max_dist > epsilon, and 0.5 > 0.5 is not
    assert simplify([(0.0, 0.0), (1.0, 0.5), (2.0, 0.0)], 0.5) == [(0.0, 0.0), (2.0, 0.0)]


def test_both_halves_either_side_of_the_farthest_point_are_simplified() -> None:
    # (0,0) (1,1) (2,0) (3,3) (4,0), epsilon 0.1: from (0,0)-(4,0) the farthest is (3,3), 3 m:
    # kept. (3,3)-(4,0) has no point between. (0,0)-(3,3): (1,1) is on it, (2,0) is
    # |2 - 0| / sqrt 2 = 1.41 off: kept. (0,0)-(2,0): (1,1) is 1 off: kept. Everything stays.
    way = [(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (3.0, 3.0), (4.0, 0.0)]
    assert simplify(way, 0.1) == way


def test_the_distance_is_to_the_segment_not_the_line() -> None:
    # distance_to_segment clamps to the segment's ends: (-1, 0) behind (0,0)-(2,0) is 1 m from
    # it (kept at epsilon 0.5); (3, 0) beyond a (0,0)-(2,0) segment likewise
    assert simplify([(0.0, 0.0), (-1.0, 0.0), (2.0, 0.0)], 0.5) == [(0.0, 0.0), (-1.0, 0.0), (2.0, 0.0)]
    assert simplify([(0.0, 0.0), (3.0, 0.0), (2.0, 0.0)], 0.5) == [(0.0, 0.0), (3.0, 0.0), (2.0, 0.0)]


def test_a_point_near_a_one_metre_segment_is_measured_to_the_segment() -> None:
    # segment (0,0)-(1,0), 1 m long: (0.9, 0.1) is 0.1 m from it (dropped at 0.2), though
    # 0.906 m from its start
    assert simplify([(0.0, 0.0), (0.9, 0.1), (1.0, 0.0)], 0.2) == [(0.0, 0.0), (1.0, 0.0)]


def test_a_way_back_to_where_it_began_keeps_its_far_point() -> None:
    # first and last points the same: the "segment" is a point; (1, 0) is 1 m from it: kept
    way = [(0.0, 0.0), (1.0, 0.0), (0.0, 0.0)]
    assert simplify(way, 0.5) == way


# --- leg_distances: segment_segment_dist ------------------------------------------------------------


def test_legs_whose_lines_cross_beyond_both_are_measured_between_their_clamped_ends() -> None:
    # a (0,0)-(1,0), b (3,1)-(3,2): the lines cross at (3, 0), t1 = 3 and t2 = -1, clamped to
    # 1 and 0: (1, 0) and (3, 1), sqrt(4 + 1) = 2.236 apart, midway (2, 0.5)
    dist, mid = leg_distances((0.0, 0.0), (1.0, 0.0), (3.0, 1.0), (3.0, 2.0))
    assert dist[0] == pytest.approx(5**0.5)
    assert tuple(mid[0]) == pytest.approx((2.0, 0.5))
    # b (3,-2)-(3,-1): t2 = 2, clamped to 1: (3, -1), again sqrt 5 from (1, 0), midway (2, -0.5)
    dist, mid = leg_distances((0.0, 0.0), (1.0, 0.0), (3.0, -2.0), (3.0, -1.0))
    assert dist[0] == pytest.approx(5**0.5)
    assert tuple(mid[0]) == pytest.approx((2.0, -0.5))


def test_slanted_legs_are_measured_with_the_cross_terms() -> None:
    # a (0,0)-(2,0), b (1,1)-(2,3): u (2,0), v (1,2), w = a0 - b0 = (-1,-1); a 4, b 2, c 5,
    # d -2, e -3, a c - b^2 = 16; t1 = (b e - c d) / 16 = (-6 + 10) / 16 = 0.25: (0.5, 0);
    # t2 = (a e - b d) / 16 = (-12 + 4) / 16 = -0.5, clamped 0: (1, 1); 1.118 apart
    dist, mid = leg_distances((0.0, 0.0), (2.0, 0.0), (1.0, 1.0), (2.0, 3.0))
    assert dist[0] == pytest.approx(1.25**0.5)
    assert tuple(mid[0]) == pytest.approx((0.75, 0.5))


def test_crossing_legs_meet_where_they_cross() -> None:
    # a (0,0)-(2,0), b (1,-1)-(2,1): w (-1, 1); a 4, b 2, c 5, d -2, e 1; t1 = (2 + 10) / 16
    # = 0.75, t2 = (4 + 4) / 16 = 0.5: both at (1.5, 0)
    dist, mid = leg_distances((0.0, 0.0), (2.0, 0.0), (1.0, -1.0), (2.0, 1.0))
    assert dist[0] == pytest.approx(0.0, abs=1e-6)
    assert tuple(mid[0]) == pytest.approx((1.5, 0.0))


# --- prune_loops, clean -----------------------------------------------------------------------------


def test_legs_exactly_delta_apart_do_not_meet() -> None:
    # the last leg (2,3)-(2,1.5) ends 1.5 m from (2, 0) on the first leg: a loop only if
    # 1.5 < delta; at delta 1.5 nothing is cut
    way = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (2.0, 3.0), (2.0, 1.5)]
    assert prune_loops(way, 1.5) == way


def test_a_full_loop_buffer_stops_the_search_before_an_older_loop() -> None:
    # a loop early on (legs 1 and 4 cross at (1, 0)), then a tail of three legs that meet
    # nothing older: with room for 1 loop it is the only one found, and cut
    way = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, -1.0), (1.0, -5.0), (5.0, -9.0), (5.0, -20.0)]
    assert prune_loops(way, 0.5, max_loops=1) == [(0.0, 0.0), (1.0, 0.0), *way[4:]]


def test_clean_simplifies_at_half_the_accuracy_and_prunes_at_0_99_of_it() -> None:
    # SRTL_ACCURACY 2: (1, 0.6) is 0.6 m off the line, within 1 m: dropped
    assert clean([(0.0, 0.0), (1.0, 0.6), (2.0, 0.0)], 2.0) == [(0.0, 0.0), (2.0, 0.0)]
    # legs 1.5 m apart are within 1.98 m: cut and joined midway, at (2, 0.75)
    way = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (2.0, 3.0), (2.0, 1.5)]
    assert clean(way, 2.0) == [(0.0, 0.0), (2.0, 0.75), (2.0, 1.5)]


def test_clean_cuts_at_most_a_quarter_of_srtl_points_loops() -> None:
    # two separate loops: legs 1 and 4 cross at (1, 0), legs 5 and 8 at (6, -1) (accuracy
    # 0.2: no point is within 0.1 of a line, none is simplified). SRTL_POINTS 4 leaves room
    # for int(0.25 x 4) = 1 loop: the newest, found first from the newest leg, is cut (points
    # 5..7 become (6, -1)); the older stays. SRTL_POINTS 8: both are cut.
    way = [
        (0.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, -1.0),
        (7.0, -1.0),
        (7.0, 1.0),
        (6.0, 1.0),
        (6.0, -3.0),
    ]
    assert clean(way, 0.2, points_max=4) == [*way[:5], (6.0, -1.0), (6.0, -3.0)]
    assert clean(way, 0.2, points_max=8) == [(0.0, 0.0), (1.0, 0.0), (1.0, -1.0), (6.0, -1.0), (6.0, -3.0)]
