"""How `lfctl bench vision` scores a run against labels (lfctl.bench.vision and
lfctl.bench.footage), on a made-up labelled clip and made-up runs whose every figure is
counted by hand: which frames count as in plain view and as hidden, success at IoU >= 0.5
only while TRACKING, the centre error, and the recovery after a full occlusion."""

from __future__ import annotations

from pathlib import Path

from lfctl.bench.footage import LabelledSequence
from lfctl.bench.vision import _centre_error, _score, recovery_frames

# labels every 5th frame: 0, 5 and 10 in view; 15 and 20 hidden (so 16-19 too, between two
# hidden labels); 25 partly covered; 30 in view
SEQ = LabelledSequence(
    name="made_up",
    video=Path("none.avi"),
    first_frame=0,
    n_frames=31,
    boxes={
        0: (10, 10, 20, 20),
        5: (12, 10, 20, 20),
        10: (30, 10, 20, 20),
        15: None,
        20: None,
        25: (50, 10, 10, 20),
        30: (60, 10, 20, 20),
    },
    partial=frozenset({25}),
    no_banner=False,
)


def test_plain_view_is_the_labelled_whole_frames_after_the_first_and_hidden_fills_between_nulls() -> None:
    assert SEQ.in_plain_view() == [5, 10, 30]
    assert SEQ.hidden() == [15, 16, 17, 18, 19, 20]
    # a null label beside a box does not spread: frames 21-24 are not known hidden
    assert 21 not in SEQ.hidden() and 14 not in SEQ.hidden()


def test_a_run_is_scored_on_plain_view_frames_while_tracking() -> None:
    # frame 5: the label's box, TRACKING: a hit (centre error 0).
    # frame 10: 10 px right of the label: overlap 10 x 20 = 200 of 400 + 400 - 200 = 600, IoU
    #   1/3: a miss, though TRACKING (centre error 10).
    # frame 30: the label's box but OCCLUDED: a miss, no centre error, one plain-view frame
    #   not TRACKING.
    # success 1/3 = 0.333; median centre error of (0, 10): 5.0. Hidden frames: TRACKING is
    # claimed on 16 and 18 (2 of 6). Frame 0 (given) and 25 (partly covered) do not count.
    boxes = [None] * 31
    tracking = [False] * 31
    boxes[0], tracking[0] = (10, 10, 20, 20), True
    boxes[5], tracking[5] = (12, 10, 20, 20), True
    boxes[10], tracking[10] = (40, 10, 20, 20), True
    boxes[30], tracking[30] = (60, 10, 20, 20), False
    boxes[25], tracking[25] = (0, 0, 5, 5), True  # far off, but partly covered: not scored
    for i in (16, 18):
        boxes[i], tracking[i] = (20, 10, 20, 20), True
    assert _score(SEQ, {"boxes": boxes, "tracking": tracking}) == {
        "success": 0.333,
        "median_centre_error_px": 5.0,
        "plain_view_not_tracking": 1,
        "plain_view_frames": 3,
        "tracking_while_hidden": 2,
        "hidden_frames": 6,
    }


def test_iou_of_exactly_a_half_is_a_hit_and_no_box_is_a_miss() -> None:
    # frame 5: the label's upper half (20 x 10 inside 20 x 20): IoU 200 / 400 = 0.5, a hit;
    # frame 10: TRACKING claimed with no box: a miss, and no centre error to take;
    # frame 30: the label's box: a hit. Success 2/3 = 0.667; centre errors 5 (half a box
    # height, 10 / 2) and 0: median 2.5.
    boxes = [None] * 31
    tracking = [True] * 31
    boxes[5], boxes[30] = (12, 10, 20, 10), (60, 10, 20, 20)
    score = _score(SEQ, {"boxes": boxes, "tracking": tracking})
    assert score["success"] == 0.667
    assert score["median_centre_error_px"] == 2.5
    assert score["plain_view_not_tracking"] == 0
    assert score["tracking_while_hidden"] == 6


def test_no_tracking_frame_has_no_centre_error() -> None:
    boxes = [(10, 10, 20, 20)] * 31
    score = _score(SEQ, {"boxes": boxes, "tracking": [False] * 31})
    assert score["success"] == 0.0 and score["median_centre_error_px"] is None
    assert score["plain_view_not_tracking"] == 3


def test_the_centre_error_is_between_the_boxes_middles() -> None:
    # middles (20, 20) and (23, 24): 5 px
    assert _centre_error((10, 10, 20, 20), (13, 14, 20, 20)) == 5.0
    # the same middle, another size: 0
    assert _centre_error((10, 10, 20, 20), (15, 15, 10, 10)) == 0.0


def test_recovery_counts_frames_from_a_full_occlusions_end_to_iou_one_half() -> None:
    # frames 0-4 seen, 5-14 hidden (10 frames, visible under 5 %), then IoU 0.3, 0.4, 0.6: the
    # track is back 2 frames after the occlusion ends
    vis = [1.0] * 5 + [0.0] * 10 + [1.0] * 3
    ious = [0.9] * 5 + [0.0] * 10 + [0.3, 0.4, 0.6]
    assert recovery_frames(vis, ious) == [2]
    # back on the first frame seen again: 0 (IoU 0.5 is back)
    assert recovery_frames(vis, [0.9] * 5 + [0.0] * 10 + [0.5, 0.6, 0.6]) == [0]
    # never back by the end: the frames left (3)
    assert recovery_frames(vis, [0.9] * 5 + [0.0] * 13) == [3]


def test_recovery_ignores_a_short_flicker_and_an_occlusion_at_the_end() -> None:
    # 9 hidden frames are a flicker, not a full occlusion; visible 0.04 counts as hidden, 0.05 not
    assert recovery_frames([1.0] * 2 + [0.0] * 9 + [1.0] * 3, [0.0] * 14) == []
    assert recovery_frames([1.0] * 2 + [0.04] * 10 + [1.0], [0.0] * 12 + [0.7]) == [0]
    assert recovery_frames([1.0] * 2 + [0.05] * 10 + [1.0], [0.0] * 13) == []
    # hidden to the last frame: nothing to recover yet
    assert recovery_frames([1.0] * 2 + [0.0] * 12, [0.0] * 14) == []


def test_the_aruco_comparison_scores_detection_on_half_visible_frames_and_errors_on_every_pose() -> None:
    from lfctl.bench.vision_aruco import _stats

    # five frames, truth 2 m at bearing 0. Visible shares 1, 0.5, 0.6, 0.3, 0:
    # detection is over the frames at least half visible (0, 1, 2): poses on 0 and 1, 2/3;
    # a pose on frame 4 (under 5 % visible) is a pose while hidden;
    # range errors over every pose: |2.2 - 2| / 2 = 10 %, 5 %, 50 %, 0 %: median 7.5 %;
    # bearing errors 0.01 rad = 0.573 deg, 0.02 rad = 1.146 deg, 0, 0: median 0.286 deg;
    # ms 1..5: median 3
    nan = float("nan")
    cell = {
        "vis": [1.0, 0.5, 0.6, 0.3, 0.0],
        "truth_range_m": 2.0,
        "truth_bearing_rad": 0.0,
        "rec": {
            "aruco": {
                "range_m": [2.2, 1.9, nan, 1.0, 2.0],
                "bearing_rad": [0.01, -0.02, nan, 0.0, 0.0],
                "ms": [1, 2, 3, 4, 5],
            }
        },
    }
    assert _stats([cell], "aruco") == {
        "detection": 0.667,
        "scored_frames": 3,
        "range_err_median_pct": 7.5,
        "bearing_err_median_deg": 0.286,
        "ms_median": 3.0,
        "poses_while_hidden": 1,
    }
    # no pose at all: no errors to take
    blind = {**cell, "rec": {"aruco": {"range_m": [nan] * 5, "bearing_rad": [nan] * 5, "ms": [1] * 5}}}
    assert _stats([blind], "aruco")["detection"] == 0.0
    assert _stats([blind], "aruco")["range_err_median_pct"] is None
    assert _stats([blind], "aruco")["poses_while_hidden"] == 0  # hidden, and no pose: nothing claimed
