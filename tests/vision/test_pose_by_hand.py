"""The leader's pose from its four markers (lfctl.vision.pose), on marker centres placed by
hand: a camera with f = 500 px and its principal point at (320, 240), a marker square of
E = 0.2 m. Each expected pose is worked out in the test from the pinhole model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfctl.vision.pose import paper_pose, pnp_pose, to_vehicle_frame

K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])
E = 0.2


def square(u0: float, v0: float, half_w: float, half_h: float) -> np.ndarray:
    """Centres TL, TR, BR, BL of markers half_w / half_h px either side of (u0, v0), as floats
    (an integer array would round a sub-pixel change made to it)."""
    return np.array(
        [
            [u0 - half_w, v0 - half_h],
            [u0 + half_w, v0 - half_h],
            [u0 + half_w, v0 + half_h],
            [u0 - half_w, v0 + half_h],
        ],
        float,
    )


def test_a_banner_above_the_axis_is_at_its_level_range_by_either_estimator() -> None:
    # The square's centre at (0, -0.5, 2) m in the camera frame (half a metre up, 2 m ahead),
    # facing the camera: corners at x = +-0.1, y = -0.6 / -0.4, so u = 320 +- 500 * 0.1 / 2
    # = 295 / 345 and v = 240 + 500 * (-0.6 / 2) = 90 and 240 + 500 * (-0.4 / 2) = 140.
    # Range is the level distance, 2 m (not the slant sqrt(4 + 0.25) = 2.06), bearing 0.
    centres = square(320, 115, 25, 25)
    for pose in (pnp_pose(centres, K, None, E), paper_pose(centres, K, E)):
        assert pose is not None
        assert pose.centre_cam_m == pytest.approx([0.0, -0.5, 2.0], abs=1e-9)
        assert pose.range_m == pytest.approx(2.0, abs=1e-9)
        assert pose.bearing_rad == pytest.approx(0.0, abs=1e-9)
        assert pose.rel_heading_rad == pytest.approx(0.0, abs=1e-9)
        assert pose.right_cam == pytest.approx([1.0, 0.0, 0.0], abs=1e-9)
        assert pose.quality == pytest.approx(1.0, abs=1e-9)


def test_the_papers_quality_is_how_far_the_pairs_gap_is_from_the_squares_side() -> None:
    # Pairs 50 px tall at 2 m (E f / d = 0.2 * 500 / 2), but only 37.5 px apart: the gap
    # measures 37.5 * 2 / 500 = 0.15 m against E = 0.2, quality 1 - 0.05 / 0.2 = 0.75
    pose = paper_pose(square(320, 240, 18.75, 25), K, E)
    assert pose is not None
    assert pose.quality == pytest.approx(0.75, abs=1e-9)
    assert pose.range_m == pytest.approx(2.0, abs=1e-9)


def test_the_papers_pair_stands_at_the_mean_of_its_two_markers_directions() -> None:
    # The left pair detected leaning: its top at (295, 215), its bottom 10 px further right at
    # (305, 265); the right pair upright at u = 345. Rays (level camera, body frame):
    #   left top    (1, -0.05, -0.05): horizontal run 1.0012492, climb -0.0499376
    #   left bottom (1, -0.03, +0.05): horizontal run 1.0004499, climb +0.0499775
    # drop 0.0999151, so d = 0.2 / 0.0999151 = 2.001699 m; its place is d times the mean of the
    # two horizontal directions, (0.9991512, -0.0399621): (2.0000, -0.0800) m. The right pair at
    # (2.0, +0.1), so the centre is 0.01 m right of the axis (bearing 0.01 / 2 = 0.005 rad), the
    # gap 0.18 m (quality 0.9). Either marker's direction alone would put it 0.0 or 0.02 right.
    pose = paper_pose(np.array([[295, 215], [345, 215], [345, 265], [305, 265]], float), K, E)
    assert pose is not None
    assert pose.centre_cam_m[0] == pytest.approx(0.0100, abs=2e-4)
    assert pose.bearing_rad == pytest.approx(0.0050, abs=1e-4)
    assert pose.quality == pytest.approx(0.9, abs=1e-3)


def test_the_papers_estimate_refuses_a_pair_under_a_pixel_tall() -> None:
    # a left pair 0.5 px tall would put the banner at 0.2 * 500 / 0.5 = 200 m: no pose
    centres = square(320, 240, 25, 25)
    centres[3] = centres[0] + [0.0, 0.5]
    assert paper_pose(centres, K, E) is None
    centres = square(320, 240, 25, 25)
    centres[2] = centres[1] + [0.0, 0.5]  # the right pair likewise
    assert paper_pose(centres, K, E) is None


def test_the_papers_estimate_refuses_a_bottom_marker_level_with_its_top() -> None:
    # the left pair 10 px apart sideways and not at all in height: no drop, no distance
    # (on the principal point's row both rays climb 0: the drop is exactly 0)
    centres = square(320, 240, 25, 25)
    centres[0], centres[3] = [300.0, 240.0], [310.0, 240.0]
    assert paper_pose(centres, K, E) is None
    centres[3] = centres[0] + [0.0, -20.0]  # upside down: the "bottom" above the top
    assert paper_pose(centres, K, E) is None


def test_the_papers_estimate_refuses_a_marker_straight_below_a_downward_camera() -> None:
    # A camera pitched 90 degrees down: its x is the body's right, its y the body's back, its z
    # the body's down. The marker at the principal point lies on a vertical ray, with no
    # horizontal direction to place it along.
    down = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    centres = square(345, 265, 25, 25)  # TL at (320, 240)
    assert paper_pose(centres, K, E, down) is None
    centres = square(345, 215, 25, 25)  # BL there
    assert paper_pose(centres, K, E, down) is None


def test_the_vehicle_frame_adds_the_mount_and_the_banners_offset_along_the_leaders_heading() -> None:
    # Banner 2 m ahead (camera frame (0, 0, 2)), camera 0.3 m ahead of the follower's reference
    # point and 0.1 m right (FRD), level: the banner at (2.3, 0.1) in the body frame. The leader
    # turned 60 degrees right: its right axis points at 150 degrees, (cos 150, sin 150) =
    # (-0.866025, 0.5) in the body frame, (0.5, 0, -0.866025) in the camera's (x right, z ahead).
    # The heading comes from that axis (the pose's own rel_heading_rad, left at 0 here, is for a
    # pose without one): atan2(0.866025, 0.5) = 60 degrees. The reference point is 0.5 m ahead of
    # the banner along the heading: (2.3 + 0.5 cos 60, 0.1 + 0.5 sin 60) = (2.55, 0.533013).
    # Range sqrt(6.5025 + 0.284103) = 2.605111; bearing atan(0.533013 / 2.55) = atan(0.209025)
    # = 0.209025 - 0.209025^3 / 3 + 0.209025^5 / 5 - 0.209025^7 / 7 = 0.206058 rad.
    level = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    pose = pnp_pose(square(320, 240, 25, 25), K, None, E)
    assert pose is not None
    turned = type(pose)(pose.centre_cam_m, 2.0, 0.0, 0.0, 1.0, "pnp", np.array([0.5, 0.0, -math.sqrt(3) / 2]))
    rng, brg, rel = to_vehicle_frame(turned, np.array([0.3, 0.1, 0.0]), level, 0.5)
    assert rel == pytest.approx(math.radians(60), abs=1e-9)
    assert rng == pytest.approx(2.605111, abs=1e-6)
    assert brg == pytest.approx(0.206058, abs=1e-6)
    # without the axis, the pose's own relative heading is taken: 0, the offset straight ahead
    plain = type(pose)(pose.centre_cam_m, 2.0, 0.0, 0.0, 1.0, "paper", None)
    rng, brg, rel = to_vehicle_frame(plain, np.array([0.3, 0.1, 0.0]), level, 0.5)
    assert (rng, brg, rel) == pytest.approx((math.hypot(2.8, 0.1), math.atan2(0.1, 2.8), 0.0), abs=1e-12)


def test_a_banner_turned_30_degrees_left_reads_so_by_either_estimator() -> None:
    # The leader turned 30 degrees left: its banner's right axis points 60 degrees right of the
    # camera's axis, so its right pair is further away. Level coordinates (ahead, right), m:
    # left pair (2 - 0.1 sin 30, -0.1 cos 30) = (1.95, -0.0866025), right pair (2.05, 0.0866025).
    # Pinhole pixels: u = 320 + 500 right / ahead, v = 240 +- 500 * 0.1 / ahead.
    # Expected: centre (2, 0), range 2, bearing 0, relative heading -30 degrees, quality 1.
    left, right = (1.95, -0.1 * math.cos(math.radians(30))), (2.05, 0.1 * math.cos(math.radians(30)))
    u = [320 + 500 * p[1] / p[0] for p in (left, right)]
    dv = [500 * 0.1 / p[0] for p in (left, right)]
    centres = np.array([[u[0], 240 - dv[0]], [u[1], 240 - dv[1]], [u[1], 240 + dv[1]], [u[0], 240 + dv[0]]])
    for pose in (paper_pose(centres, K, E), pnp_pose(centres, K, None, E)):
        assert pose is not None
        assert pose.rel_heading_rad == pytest.approx(math.radians(-30), abs=1e-6)
        assert pose.range_m == pytest.approx(2.0, abs=1e-6)
        assert pose.bearing_rad == pytest.approx(0.0, abs=1e-6)
        assert pose.quality == pytest.approx(1.0, abs=1e-6)


def test_the_papers_estimate_of_a_banner_off_the_axis_by_hand() -> None:
    # Wrong, an off-axis banner would read its range as the depth (2 m) or its lateral offset
    # from a thin-lens depth (the printed eq. 10, z = f (E/h + 1)).
    # By hand: banner centre 0.5 m right, 2 m ahead, facing the camera: left pair at x = 0.4,
    # right pair at x = 0.6. Pixels: u = 320 + 500 x / 2 = 420 and 470, v = 240 -+ 500 * 0.1 / 2
    # = 215 / 265. Left pair rays (1, 0.2, -+0.05): horizontal run sqrt(1.04) = 1.019804, climb
    # -+0.049029, drop 0.098058, d = 0.2 / 0.098058 = 2.039608 (= sqrt(2^2 + 0.4^2)); placed
    # along (1, 0.2) / 1.019804: (2.0, 0.4). Right pair likewise (2.0, 0.6). Eq. 9: centre
    # (2.0, 0.5); eq. 11: range sqrt(4.25) = 2.061553, bearing atan(0.25) = 0.244979 rad;
    # heading atan2(-(2 - 2), 0.6 - 0.4) = 0; quality 1 (gap 0.2 = E).
    pose = paper_pose(np.array([[420, 215], [470, 215], [470, 265], [420, 265]], float), K, E)
    assert pose is not None
    assert pose.centre_cam_m == pytest.approx([0.5, 0.0, 2.0], abs=1e-9)
    assert pose.range_m == pytest.approx(2.061553, abs=1e-6)
    assert pose.bearing_rad == pytest.approx(0.244979, abs=1e-6)
    assert pose.rel_heading_rad == pytest.approx(0.0, abs=1e-9)
    assert pose.quality == pytest.approx(1.0, abs=1e-9)
