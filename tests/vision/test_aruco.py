"""The ArUco banner: the rendered tag, its pose, coasting when it is not seen, the scenario keys."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from lfctl.config import TAG_DICTIONARIES, BannerConfig, CameraConfig, SceneConfig, parse_config
from lfctl.errors import ConfigError
from lfctl.guidance.formation import FormationController, FormationSettings, Odometry
from lfctl.render.renderer import Renderer, VehiclePose
from lfctl.vision.aruco import ArucoSettings, tag_bitmap, tag_dictionary
from lfctl.vision.banner import BannerGeometry
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.perception import BannerPerception
from lfctl.vision.track_state import TrackStatus

ARUCO = BannerConfig(kind="aruco")
CAMERA = CameraConfig()
ME = VehiclePose(0.0, 0.0, 0.0, banner=False)


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(CAMERA, ARUCO, SceneConfig(), 7)


def test_rendered_tag_is_found_at_its_true_corners(renderer: Renderer) -> None:
    frame, truth = renderer.render(0.0, ME, [VehiclePose(2.0, 0.3, 0.2)], 0)
    st = BannerPerception.from_config(CAMERA, ARUCO).tracker.init_from_markers(frame)
    assert st is not None and st.status is TrackStatus.TRACKING
    # the truth's four points are the tag's corners for an ArUco banner (TL, TR, BR, BL)
    assert np.max(np.abs(st.markers - truth.markers_px)) < 0.5


def test_pose_of_a_tag_at_a_hand_worked_range_and_bearing(renderer: Renderer) -> None:
    # leader 2.0 m ahead, 0.3 m right, turned 0.2 rad: range sqrt(2.0^2 + 0.3^2) = 2.0224 m,
    # bearing atan(0.3 / 2.0) = 8.531 deg, relative heading 11.459 deg
    frame, truth = renderer.render(0.0, ME, [VehiclePose(2.0, 0.3, 0.2)], 0)
    assert truth.range_m == pytest.approx(2.0224, abs=1e-4)
    seen = BannerPerception.from_config(CAMERA, ARUCO).step(0.0, frame)
    m = seen.measurement
    assert m.status is TrackStatus.TRACKING and seen.pose is not None and seen.pose.method == "pnp"
    assert m.range_m == pytest.approx(2.0224, abs=0.02)
    assert math.degrees(m.bearing_rad) == pytest.approx(8.531, abs=0.3)
    assert math.degrees(seen.pose.rel_heading_rad) == pytest.approx(11.459, abs=3.0)


def test_the_realistic_camera_prints_the_tag_on_its_board() -> None:
    # scene.realism "on": the board, lighting and sensor change, the tag and its pose do not
    real = Renderer(CAMERA, ARUCO, SceneConfig(realism="on"), 7)
    frame, truth = real.render(0.0, ME, [VehiclePose(2.0, 0.3, 0.2)], 0)
    seen = BannerPerception.from_config(CAMERA, ARUCO).step(0.0, frame)
    assert seen.measurement.status is TrackStatus.TRACKING and seen.pose is not None
    assert np.max(np.abs(seen.track.markers - truth.markers_px)) < 1.5
    assert seen.measurement.range_m == pytest.approx(truth.range_m, rel=0.02)


def test_pose_uses_the_tag_side_not_the_marker_square() -> None:
    # the same four corners give twice the depth for a twice larger square
    cam = CameraModel.from_config(CAMERA)
    per = BannerPerception.from_config(CAMERA, ARUCO)
    corners = np.array([[300.0, 220.0], [340.0, 220.0], [340.0, 260.0], [300.0, 260.0]])
    pose = per.marker_pose(corners)
    assert pose is not None
    assert pose.centre_cam_m[2] == pytest.approx(cam.K[0, 0] * ARUCO.tag_size_m / 40.0, rel=0.01)
    assert BannerGeometry.from_config(ARUCO).square_m == ARUCO.tag_size_m
    assert BannerGeometry.from_config(BannerConfig()).square_m == BannerConfig().side_m


def test_hidden_tag_coasts_then_is_lost_and_the_formation_filter_coasts(renderer: Renderer) -> None:
    cam = CameraModel.from_config(CAMERA)
    geometry = BannerGeometry.from_config(ARUCO)
    per = BannerPerception(cam, geometry, ArucoSettings(panel_over_tag=geometry.panel_over_side, lost_after_frames=5))
    ctrl = FormationController(FormationSettings(range_cmd_m=1.8))
    seen_boxes, statuses, outs = [], [], []
    for k in range(12):
        t = k / 30.0
        # the leader drives away to the right at 0.3 m/s; its banner is gone from frame 4 on
        leader = VehiclePose(1.8 + 0.01 * k, 0.01 * k, 0.0, banner=k < 4)
        frame, _truth = renderer.render(t, ME, [leader], 0)
        p = per.step(t, frame)
        statuses.append(p.measurement.status)
        seen_boxes.append(p.track.bbox if p.track is not None else None)
        outs.append(ctrl.step(p.measurement, Odometry(t, 0.0, 0.0, 0.0, 0.0)))
        if k >= 4:
            assert p.measurement.range_m is None and p.measurement.bearing_rad is None
    assert statuses[:4] == [TrackStatus.TRACKING] * 4
    assert statuses[4:9] == [TrackStatus.OCCLUDED] * 5
    assert statuses[9:] == [TrackStatus.LOST] * 3
    # while OCCLUDED the window is the centre filter's prediction: it keeps moving right
    xs = [b[0] + b[2] / 2 for b in seen_boxes[3:9]]
    assert all(b > a for a, b in itertools.pairwise(xs))
    # the follower's target filter coasts through the first misses (an estimate, OCCLUDED)...
    assert outs[5].status is TrackStatus.OCCLUDED and outs[5].range_est_m == pytest.approx(1.83, abs=0.05)
    # ... and stops once the sensor says LOST
    assert outs[-1].status is TrackStatus.LOST and outs[-1].speed_mps == 0.0


def test_tag_found_again_after_it_was_hidden(renderer: Renderer) -> None:
    per = BannerPerception.from_config(CAMERA, ARUCO)
    statuses = []
    for k in range(10):
        frame, _ = renderer.render(k / 30.0, ME, [VehiclePose(2.0, 0.0, 0.0, banner=not 3 <= k < 6)], 0)
        statuses.append(per.step(k / 30.0, frame).measurement.status)
    assert statuses == [TrackStatus.TRACKING] * 3 + [TrackStatus.OCCLUDED] * 3 + [TrackStatus.TRACKING] * 4


def test_of_two_banners_with_the_same_id_the_slot_picks_the_target(renderer: Renderer) -> None:
    # two vehicles side by side 2.5 m ahead, 0.6 m apart; the slot says the right one
    left, right = VehiclePose(2.5, -0.3, 0.0), VehiclePose(2.5, 0.3, 0.0)
    frame, _ = renderer.render(0.0, ME, [left, right], 1)
    for slot_bearing, want_east in ((math.atan2(0.3, 2.5), 0.3), (math.atan2(-0.3, 2.5), -0.3)):
        per = BannerPerception.from_config(CAMERA, ARUCO, (math.hypot(2.5, 0.3), slot_bearing))
        m = per.step(0.0, frame).measurement
        assert m.status is TrackStatus.TRACKING
        assert m.range_m * math.sin(m.bearing_rad) == pytest.approx(want_east, abs=0.03)


def test_a_markers_banner_renders_no_tag_and_an_aruco_banner_no_markers() -> None:
    markers = Renderer(CAMERA, BannerConfig(), SceneConfig(), 7)
    frame, _ = markers.render(0.0, ME, [VehiclePose(1.5, 0.0, 0.0)], 0)
    assert BannerPerception.from_config(CAMERA, ARUCO).step(0.0, frame).track is None
    assert BannerPerception.from_config(CAMERA, BannerConfig()).step(0.0, frame).track is not None
    tagged = Renderer(CAMERA, ARUCO, SceneConfig(), 7)
    frame, _ = tagged.render(0.0, ME, [VehiclePose(1.5, 0.0, 0.0)], 0)
    assert BannerPerception.from_config(CAMERA, BannerConfig()).step(0.0, frame).track is None


@pytest.mark.parametrize("name", sorted(TAG_DICTIONARIES))
def test_the_config_knows_each_dictionary_as_opencv_does(name: str) -> None:
    bits, ids = TAG_DICTIONARIES[name]
    d = tag_dictionary(name)
    assert (d.markerSize, len(d.bytesList)) == (bits, ids)
    assert tag_bitmap(name, ids - 1).shape == (bits + 2, bits + 2)


LEADER = '[[vehicles]]\nname = "leader"\nrole = "leader"\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("kind = 'apriltag'", r"banner\.kind must be one of 'markers', 'aruco', got 'apriltag'"),
        ("aruco_dictionary = '7X7_50'", r"banner\.aruco_dictionary must be one of '4X4_50'"),
        ("aruco_id = 50", r"banner\.aruco_id must be below 50 for 4X4_50, got 50"),
        ("aruco_id = -1", r"banner\.aruco_id must be within 0\.\.586, got -1"),
        ("kind = 'aruco'\ntag_size_m = 0.2", r"banner\.tag_size_m with a one-cell margin .* at most 0\.165 for 4X4_50"),
        (
            "kind = 'aruco'\naruco_dictionary = '6X6_50'\ntag_size_m = 0.18",
            r"tag_size_m at most 0\.176 for 6X6_50",
        ),
        ("tag_size_m = 0", r"banner\.tag_size_m must be within \(0, 10\], got 0"),
    ],
)
def test_bad_aruco_keys_name_the_key(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(LEADER + "[banner]\n" + text + "\n")


def test_aruco_keys_load() -> None:
    cfg = parse_config(
        LEADER + "[banner]\nkind = 'aruco'\naruco_dictionary = '5X5_50'\naruco_id = 7\ntag_size_m = 0.1\n"
    )
    assert (cfg.banner.kind, cfg.banner.aruco_dictionary, cfg.banner.aruco_id) == ("aruco", "5X5_50", 7)
    # a markers banner ignores the tag's size (it need not fit the panel)
    assert parse_config(LEADER + "[banner]\ntag_size_m = 0.3\n").banner.kind == "markers"


TWO = LEADER + '[[vehicles]]\nname = "f1"\nrole = "follower"\n'
THREE = TWO + '[[vehicles]]\nname = "f2"\nrole = "follower"\n'


def test_each_vehicle_prints_its_own_tag_and_a_follower_looks_for_its_targets() -> None:
    # banner.aruco_id 5: the leader 5, then 6 and 7 in [[vehicles]] order; f2 follows f1 (a chain)
    cfg = parse_config(THREE + "target = 'f1'\n[banner]\nkind = 'aruco'\naruco_id = 5\n")
    assert cfg.tag_ids() == {"leader": 5, "f1": 6, "f2": 7}
    assert (cfg.banner_of("leader").aruco_id, cfg.banner_of("f1").aruco_id) == (5, 6)
    # a vehicle's own key wins; the others keep their place's id
    own = parse_config(TWO + "aruco_id = 42\n[banner]\nkind = 'aruco'\n")
    assert own.tag_ids() == {"leader": 0, "f1": 42}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        # f1's own id is the leader's (banner.aruco_id, its place 0)
        (
            TWO + "aruco_id = 0\n[banner]\nkind = 'aruco'\n",
            r"vehicles\[f1\]\.aruco_id 0 is vehicles\[leader\]'s tag 0 \(banner\.aruco_id 0 \+ its place in "
            r"\[\[vehicles\]\]\) too",
        ),
        # f1 takes 2, which f2 prints from its place
        (
            TWO + 'aruco_id = 2\n[[vehicles]]\nname = "f2"\nrole = "follower"\n[banner]\nkind = \'aruco\'\n',
            r"vehicles\[f2\]'s tag 2 \(banner\.aruco_id 0 \+ its place in \[\[vehicles\]\]\) is "
            r"vehicles\[f1\]\.aruco_id 2 too",
        ),
        # the leader at 49 leaves f1 the 50th id of a 50-id dictionary
        (
            TWO + "[banner]\nkind = 'aruco'\naruco_id = 49\n",
            r"vehicles\[f1\]'s tag 50 \(banner\.aruco_id 49 \+ its place in \[\[vehicles\]\]\) must be below 50 for 4X4_50",
        ),
        (
            TWO + "aruco_id = 30\n[banner]\nkind = 'aruco'\naruco_dictionary = 'APRILTAG_16h5'\n",
            r"aruco_id 30 must be below 30",
        ),
        (TWO + "aruco_id = 587\n", r"vehicles\[f1\]\.aruco_id must be within 0\.\.586, got 587"),
    ],
)
def test_bad_tag_ids_name_the_vehicle_and_the_value(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(text)


def test_a_markers_banner_does_not_use_tag_ids() -> None:
    # 49 + 1 would be past 4X4_50, but the markers banner prints no tag
    assert parse_config(TWO + "[banner]\naruco_id = 49\n").banner.kind == "markers"


@pytest.mark.parametrize("realism", ["off", "on"])
def test_each_banner_shows_its_own_tag_and_perception_finds_only_its_targets(realism: str) -> None:
    # two rovers side by side, 2 m ahead: the left prints tag 3, the right tag 4
    r = Renderer(CAMERA, ARUCO, SceneConfig(realism=realism), 7)
    left, right = VehiclePose(2.0, -0.4, 0.0, tag_id=3), VehiclePose(2.0, 0.4, 0.0, tag_id=4)
    frame, truth = r.render(0.0, ME, [left, right], 1)
    found = {}
    for tag in (3, 4, 0):
        st = BannerPerception.from_config(CAMERA, BannerConfig(kind="aruco", aruco_id=tag)).tracker.init_from_markers(
            frame
        )
        found[tag] = None if st is None else st.markers
    assert found[0] is None  # the scenario's id is printed by neither
    assert found[4] is not None and np.max(np.abs(found[4] - truth.markers_px)) < 1.5  # the target (index 1)
    assert found[3] is not None and float(found[3][:, 0].mean()) < float(truth.markers_px[:, 0].mean()) - 50


def test_track_and_follow_look_for_the_first_followers_target() -> None:
    from lfctl.cli.track import _watched_banner

    # the leader prints its own 9 (banner.aruco_id 5 is the default for the places after it)
    leader9 = LEADER + "aruco_id = 9\n" + THREE[len(LEADER) :]
    cfg = parse_config(leader9 + "[banner]\nkind = 'aruco'\naruco_id = 5\n")
    assert cfg.tag_ids() == {"leader": 9, "f1": 6, "f2": 7}
    assert _watched_banner(cfg).aruco_id == 9  # f1 follows the leader: its tag, not banner.aruco_id
    chain = parse_config(leader9 + "[formation]\nshape = 'column'\ntargets = 'chain'\n[banner]\nkind = 'aruco'\n")
    assert chain.slots()["f2"].target == "f1" and chain.banner_of(chain.slots()["f2"].target).aruco_id == 1
    # a leader alone: its own
    assert _watched_banner(parse_config(LEADER + "[banner]\nkind = 'aruco'\naruco_id = 9\n")).aruco_id == 9
