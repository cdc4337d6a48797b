"""The real-footage section of `lfctl bench vision`: scored as documented, peers this OpenCV
cannot create reported as such; its timing pass."""

from __future__ import annotations

import json

import pytest

from lfctl.bench import vision
from lfctl.bench.footage import load_sequence, start_boxes
from lfctl.data import footage_dir


def test_a_labelled_sequence_is_scored_and_a_missing_peer_is_named(capsys: pytest.CaptureFixture[str]) -> None:
    seq = load_sequence(footage_dir() / "labels" / "carphone_bowtie.json")
    result = vision.run_real((seq, ()))  # no OpenCV peer: as if none could be created
    full = result["trackers"]["full"]
    assert full["plain_view_frames"] == len(seq.in_plain_view()) == 23
    assert full["hidden_frames"] == 0 and full["banner_pose_frames"] == 0
    assert 0.0 <= full["success"] <= 1.0 and full["median_ms"] > 0
    assert set(result["trackers"]) == {"hue", "hs-lbp", "full"}
    out = vision.real_section([result], ())
    text = capsys.readouterr().out
    cells = [[c.strip() for c in line.split("|")[1:-1]] for line in text.splitlines() if line.startswith("|")]
    assert cells[-2][:3] == ["carphone_bowtie", "KCF", "n/a (needs opencv-contrib)"]
    assert cells[-1][:3] == ["carphone_bowtie", "CSRT", "n/a (needs opencv-contrib)"]
    assert cells[-3][:3] == ["carphone_bowtie", "MIL", "not run"]
    assert "full tracker on real footage, what breaks each rule:" in text
    assert out["criteria"]["banner_pose_frames"] == 0
    assert "csrt_at_least_0.9_on" not in out["criteria"]  # no CSRT, no claim about where it holds
    json.dumps(out)


def test_a_sequence_without_a_target_counts_banner_poses_both_ways() -> None:
    seq = load_sequence(footage_dir() / "labels" / "neg_iscc_redroom.json")
    result = vision.run_real((seq, ("MIL",)))
    assert result["no_banner"] and result["frames"] == 2 * seq.n_frames  # auto-start and from a box
    assert result["pose_frames"] == 0


def test_the_timing_pass_gives_wall_clock_and_cpu_time_per_tracker() -> None:
    t = vision.timing_pass("clear", 8, ())
    assert t["renderer"] > 0
    for k in vision.OURS:  # the process's CPU time runs on while a frame is worked on: never zero
        assert t[k] > 0 and t[f"{k} cpu"] > 0, t


def test_start_boxes_are_the_label_box_then_seeded_moves_within_the_bound() -> None:
    box = (100, 50, 30, 40)
    boxes = start_boxes(box, 11)
    assert boxes[0] == box and len(boxes) == 11
    assert boxes == start_boxes(box, 11)  # seeded: the same boxes every run, for every tracker
    assert len(set(boxes)) > 5
    for b in boxes:
        assert all(abs(v - w) <= 2 for v, w in zip(b, box, strict=True)), b
    assert all(b[2] >= 2 and b[3] >= 2 for b in start_boxes((0, 0, 2, 2), 30))
    for n, moved in ((0, 2), (3, -1)):
        with pytest.raises(ValueError, match="start_boxes"):
            start_boxes(box, n, moved)


def test_the_start_boxes_section_takes_the_label_box_run_and_the_moved_ones(capsys: pytest.CaptureFixture[str]) -> None:
    seq = load_sequence(footage_dir() / "labels" / "carphone_bowtie.json")
    first = vision.run_real((seq, ()))
    starts = vision.run_starts((seq, ("hs-lbp", "full"), 3))
    assert [s["box"] for s in starts["starts"]["full"]] == [list(b) for b in start_boxes(seq.init_box, 3)[1:]]
    out = vision.starts_section([first], [starts], 3)
    full = out["sequences"]["carphone_bowtie"]["full"]
    got = [first["trackers"]["full"]["success"], *(s["success"] for s in starts["starts"]["full"])]
    assert full["starts"] == 3 and full["success_at_label_box"] == got[0]
    assert full["success_median"] == sorted(got)[1] and full["success_min"] == min(got)
    assert full["starts_at_0.9"] == sum(v >= 0.9 for v in got)
    text = capsys.readouterr().out
    assert "from 3 start boxes each" in text and "what breaks each rule (on the medians)" in text
    assert "csrt_median_at_least_0.9_on" not in out["criteria"]
    json.dumps(out)


def test_an_opencv_refusal_is_reported_in_one_line_naming_what_failed() -> None:
    import cv2
    import numpy as np

    tracker = cv2.TrackerMIL.create()
    with pytest.raises(cv2.error) as info:  # no positive sample fits a box hanging off the frame
        tracker.init(np.zeros((480, 640, 3), np.uint8), (630, 470, 20, 20))
    text = vision.cv_refusal(info.value)
    assert text == "init: !posSamples.empty() (-215)"
    assert "\n" not in text and "/" not in text
