"""The tracker on lfctl's labelled real footage (footage/labels), whole sequences: the full
tracker, with its default settings and markers on, through the pose pipeline, from the
label's frame-0 box (as `lfctl track VIDEO --roi` starts it).

The footage and the trackers are deterministic (no seeds): each rule is checked on every
labelled frame. A rule lfctl does not meet yet is an xfail with the measured figure, strict,
so that it fails the day it passes."""

from __future__ import annotations

import dataclasses
from functools import cache

import pytest

from lfctl.bench.footage import LabelledSequence, load_sequences
from lfctl.config import BannerConfig, CameraConfig
from lfctl.vision.boxes import Box, iou
from lfctl.vision.perception import BannerPerception
from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import Tracker, TrackerSettings

pytestmark = pytest.mark.slow

SEQUENCES = {s.name: s for s in load_sequences()}
LABELLED = sorted(n for n, s in SEQUENCES.items() if not s.no_banner)
#: where OpenCV's CSRT reaches 0.9 success (lfctl bench vision, with opencv-contrib): the
#: full tracker must too
CSRT_AT_0_9 = ("bikes_cyclist", "carphone_bowtie", "vtest_bluejacket", "vtest_navyred")


@dataclasses.dataclass(frozen=True)
class Run:
    boxes: list[Box | None]
    statuses: list[TrackStatus]
    pose_frames: int


@cache
def full_run(name: str) -> Run:
    seq = SEQUENCES[name]
    boxes, statuses, poses = [], [], 0
    perception = None
    for i, frame in enumerate(seq.frames()):
        if perception is None:
            h, w = frame.shape[:2]
            camera = dataclasses.replace(CameraConfig(), width_px=w, height_px=h)
            perception = BannerPerception.from_config(camera, BannerConfig())
        seen = perception.step(i / 30.0, frame, seq.init_box)
        assert seen.track is not None
        boxes.append(seen.track.bbox)
        statuses.append(seen.track.status)
        poses += seen.pose is not None
    return Run(boxes, statuses, poses)


@cache
def hs_lbp_run(name: str) -> Run:
    seq = SEQUENCES[name]
    assert seq.init_box is not None
    tracker = Tracker(TrackerSettings(kind="hs-lbp"))
    boxes, statuses = [], []
    for i, frame in enumerate(seq.frames()):
        st = tracker.init(frame, seq.init_box) if i == 0 else tracker.update(frame)
        boxes.append(st.bbox)
        statuses.append(st.status)
    return Run(boxes, statuses, 0)


def success(seq: LabelledSequence, run: Run) -> float:
    """IoU >= 0.5 over the labelled plain-view frames, counted only while TRACKING."""
    plain = seq.in_plain_view()
    return sum(run.statuses[i] is TrackStatus.TRACKING and iou(run.boxes[i], seq.boxes[i]) >= 0.5 for i in plain) / len(
        plain
    )


@pytest.mark.parametrize("name", CSRT_AT_0_9)
def test_holds_the_target_where_csrt_does(name: str) -> None:
    assert success(SEQUENCES[name], full_run(name)) >= 0.9


@pytest.mark.parametrize("name", LABELLED)
def test_never_below_the_papers_features_alone(name: str) -> None:
    seq = SEQUENCES[name]
    ours = success(seq, full_run(name))
    if ours < 1.0:  # at 1.0 nothing is above it (and hs-lbp on a whole 768 x 576 frame is slow)
        assert ours >= success(seq, hs_lbp_run(name))


@pytest.mark.parametrize("name", LABELLED)
def test_never_tracking_while_the_target_is_hidden(name: str) -> None:
    seq = SEQUENCES[name]
    run = full_run(name)
    assert [i for i in seq.hidden() if run.statuses[i] is TrackStatus.TRACKING] == []


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(
            n,
            marks=pytest.mark.xfail(
                strict=True,
                reason="12 of 15 plain-view frames not TRACKING (OCCLUDED 35-80, LOST 85-90), success 0.067 "
                "(CSRT 0.733): the "
                "pale-blue jacket is half grey pixels (saturation <= 40) and shares its blue with her "
                "jeans; CAMShift's window spreads over the jeans and the bright pavement, 23 x 51 px on "
                "frame 5 to 65 x 105 on frame 20 while she shrinks to 20 x 47, and the windows after "
                "it are mostly pavement, past the gate",
            ),
        )
        if n == "vtest_whitehood"
        else n
        for n in LABELLED
    ],
)
def test_never_occluded_while_the_target_is_in_plain_view(name: str) -> None:
    seq = SEQUENCES[name]
    run = full_run(name)
    assert [i for i in seq.in_plain_view() if run.statuses[i] is not TrackStatus.TRACKING] == []


@pytest.mark.parametrize("name", LABELLED)
def test_no_banner_pose_where_there_is_no_banner(name: str) -> None:
    assert full_run(name).pose_frames == 0


@pytest.mark.parametrize("name", sorted(n for n, s in SEQUENCES.items() if s.no_banner))
def test_no_banner_pose_in_the_sequences_without_a_target(name: str) -> None:
    """As `lfctl track VIDEO` (searching for the markers until found) and from a box."""
    seq = SEQUENCES[name]
    frames = list(seq.frames())
    h, w = frames[0].shape[:2]
    camera = dataclasses.replace(CameraConfig(), width_px=w, height_px=h)
    for roi in (None, (w // 4, h // 4, w // 2, h // 2)):
        perception = BannerPerception.from_config(camera, BannerConfig())
        assert all(perception.step(i / 30.0, f, roi).pose is None for i, f in enumerate(frames))
