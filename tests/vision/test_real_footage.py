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
from lfctl.vision.tracker import FOUND_SMALLER, Tracker, TrackerSettings

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
    reasons: tuple[str, ...] = ()


@cache
def full_run(name: str) -> Run:
    seq = SEQUENCES[name]
    boxes, statuses, reasons, poses = [], [], [], 0
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
        reasons.append(seen.track.reason)
        poses += seen.pose is not None
    return Run(boxes, statuses, poses, tuple(reasons))


def tracker_run(name: str, settings: TrackerSettings) -> Run:
    """The tracker alone from the label's frame-0 box (no pose pipeline)."""
    seq = SEQUENCES[name]
    assert seq.init_box is not None
    tracker = Tracker(settings)
    boxes, statuses, reasons = [], [], []
    for i, frame in enumerate(seq.frames()):
        st = tracker.init(frame, seq.init_box) if i == 0 else tracker.update(frame)
        boxes.append(st.bbox)
        statuses.append(st.status)
        reasons.append(st.reason)
    return Run(boxes, statuses, 0, tuple(reasons))


@cache
def hs_lbp_run(name: str) -> Run:
    return tracker_run(name, TrackerSettings(kind="hs-lbp"))


def success(seq: LabelledSequence, run: Run) -> float:
    """IoU >= 0.5 over the labelled plain-view frames, counted only while TRACKING."""
    plain = seq.in_plain_view()
    return sum(run.statuses[i] is TrackStatus.TRACKING and iou(run.boxes[i], seq.boxes[i]) >= 0.5 for i in plain) / len(
        plain
    )


@pytest.mark.parametrize("name", CSRT_AT_0_9)
def test_holds_the_target_where_csrt_does(name: str) -> None:
    assert success(SEQUENCES[name], full_run(name)) >= 0.9


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(
            n,
            marks=pytest.mark.xfail(
                strict=True,
                reason="held out, labelled after the tracker's last change: success 0.556 against "
                "hs-lbp's 0.833 (CSRT 0.278), TRACKING on every plain-view frame; the window spreads "
                "onto the man in a black jacket he passes (frame 20) and then stays larger than the "
                "striped jacket, taking in his head (frames 20-65 at IoU 0.29-0.49)",
            ),
        )
        if n == "vtest_navystripe"
        else n
        for n in LABELLED
    ],
)
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


@pytest.mark.parametrize("name", LABELLED)
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


def test_a_window_that_sprawled_over_the_pavement_is_found_again_at_her_size() -> None:
    """The pale-blue jacket (vtest_whitehood): CAMShift's window swells over the pavement and
    her jeans, which faintly share her colours, to 2.2x its start while she shrinks, and fails
    the gate on frame 24 as a walker passes in front of her; without the check it stays
    OCCLUDED through her plain-view frames 35-80. Looked for smaller, she is found again and
    her window then grows only onto back-projection dense like hers (0.6 of her plain-view
    frames at IoU >= 0.5, measured; the misses are frames 15 and 20, before the gate fails,
    and 75-90, where she shrinks to about 24 px and the window, at about 35 px, lags). Without
    the check the track coasts from frame 24 and is lost (0.067)."""
    name = "vtest_whitehood"
    seq, run = SEQUENCES[name], full_run(name)
    assert success(seq, run) >= 0.5
    assert any(r.startswith(FOUND_SMALLER) for r in run.reasons)
    off = tracker_run(name, TrackerSettings(sprawl_growth=float("inf")))
    assert [i for i in seq.in_plain_view() if off.statuses[i] is not TrackStatus.TRACKING] != []
    assert success(seq, off) < 0.2
