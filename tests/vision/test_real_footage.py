"""The tracker on lfctl's labelled real footage (footage/labels), whole sequences: the full
tracker, with its default settings and markers on, through the pose pipeline, from the
label's frame-0 box (as `lfctl track VIDEO --roi` starts it).

The footage and the trackers are deterministic (no seeds): each rule is checked on every
labelled frame. A rule lfctl does not meet yet is an xfail with the measured figure, strict,
so that it fails the day it passes."""

from __future__ import annotations

import dataclasses
import math
from functools import cache

import cv2
import numpy as np
import pytest

from lfctl.bench.footage import LabelledSequence, load_sequences, start_boxes
from lfctl.config import BannerConfig, CameraConfig
from lfctl.data import footage_dir
from lfctl.vision.boxes import Box, iou
from lfctl.vision.perception import BannerPerception
from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import (
    BACK_ON_PATTERN,
    FOUND_SMALLER,
    LOST_SEARCH_SCALE,
    NOTHING_OF_IT,
    Tracker,
    TrackerSettings,
)

pytestmark = pytest.mark.slow

SEQUENCES = {s.name: s for s in load_sequences()}
LABELLED = sorted(n for n, s in SEQUENCES.items() if not s.no_banner)
#: where OpenCV's CSRT reaches 0.9 success (lfctl bench vision, with opencv-contrib): the
#: full tracker must too
CSRT_AT_0_9 = (
    "bikes_cyclist",
    "box_yellow",
    "carphone_bowtie",
    "clm_face_hand",
    "clm_face_scale",
    "coin_pen",
    "obama_bidentie",
    "realshort_greencup",
    "tennisball_board",
    "vtest_bluejacket",
    "vtest_navyred",
    "vtest_redshoulders_walkin",
)
#: the last clips labelled, held out: their measured failures (strict xfails, by rule)
HELD_OUT_FAILS = {
    "csrt": {},
    "hs-lbp": {
        "vtest_navystripe": "labelled held out: success 0.556 against hs-lbp's 0.833 (CSRT 0.278; medians "
        "over the start boxes 0.556 and 0.833), TRACKING on every plain-view frame; the window "
        "spreads onto the man in a black jacket he passes (frame 20) and then stays larger "
        "than the striped jacket, taking in his head (frames 20-65 at IoU 0.29-0.49)",
    },
    "plain": {},
    "hidden": {},
}


def _with_fails(names, rule: str) -> list:
    """``names`` as test parameters, those that fail ``rule`` as strict xfails with their cause."""
    fails = HELD_OUT_FAILS[rule]
    return [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=fails[n])) if n in fails else n for n in names]


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


@pytest.mark.parametrize("name", _with_fails(CSRT_AT_0_9, "csrt"))
def test_holds_the_target_where_csrt_does(name: str) -> None:
    assert success(SEQUENCES[name], full_run(name)) >= 0.9


@pytest.mark.parametrize("name", _with_fails(LABELLED, "hs-lbp"))
def test_never_below_the_papers_features_alone(name: str) -> None:
    seq = SEQUENCES[name]
    ours = success(seq, full_run(name))
    if ours < 1.0:  # at 1.0 nothing is above it (and hs-lbp on a whole 768 x 576 frame is slow)
        assert ours >= success(seq, hs_lbp_run(name))


@pytest.mark.parametrize("name", _with_fails(LABELLED, "hidden"))
def test_never_tracking_while_the_target_is_hidden(name: str) -> None:
    seq = SEQUENCES[name]
    run = full_run(name)
    assert [i for i in seq.hidden() if run.statuses[i] is TrackStatus.TRACKING] == []


@pytest.mark.parametrize("name", _with_fails(LABELLED, "plain"))
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
    the gate as a walker passes in front of her (frame 24); without the check it stays
    OCCLUDED through her plain-view frames 35-80. Looked for smaller, she is found again: every
    plain-view frame is TRACKING with the window's centre inside her labelled box (median
    centre error 4 px, measured). The window stays 1.6-2x her size (success 0.067, measured:
    with the coasting on fitted motion it regrows from frame 29 on; before it, from the label
    box, 0.6, but a median of 0.133 over the start boxes of `lfctl bench vision`, as now)."""
    name = "vtest_whitehood"
    seq, run = SEQUENCES[name], full_run(name)
    plain = seq.in_plain_view()
    assert [i for i in plain if run.statuses[i] is not TrackStatus.TRACKING] == []
    for i in plain:
        x, y, w, h = seq.boxes[i]
        bx, by, bw, bh = run.boxes[i]
        assert x <= bx + bw / 2 <= x + w and y <= by + bh / 2 <= y + h, (i, run.boxes[i], seq.boxes[i])
    assert any(r.startswith(FOUND_SMALLER) for r in run.reasons)
    off = tracker_run(name, TrackerSettings(sprawl_growth=float("inf")))
    assert [i for i in plain if off.statuses[i] is not TrackStatus.TRACKING] != []


def test_the_charcoal_jacket_is_held_from_most_start_boxes_once_coasting_on_its_steady_motion() -> None:
    """The charcoal jacket among dark jackets (vtest_darkjacket) goes behind the sign on frame
    26. From most start boxes a labeller could have drawn (the label's moved by up to 2 px:
    `lfctl bench vision`'s start boxes), the window first slides onto another dark jacket
    walking the other way; coasting on the centre filter's velocity, dragged by those frames,
    takes the search away from him for good (measured: a median success of 0.35 over the 11
    starts, 15 frames breaking a rule; 27 before a hidden target was looked for as widely as a
    lost one, 51 before it could come back on its grey-level pattern). On the motion of his
    last confident frames it follows him behind the sign (a median of 0.8, 5 such frames,
    measured)."""
    seq = SEQUENCES["vtest_darkjacket"]
    frames = list(seq.frames())
    assert seq.init_box is not None

    def over_starts(settings: TrackerSettings) -> tuple[float, int]:
        scores, breaks = [], 0
        for box in start_boxes(seq.init_box, 11):
            tracker = Tracker(settings)
            statuses, boxes = [], []
            for i, frame in enumerate(frames):
                st = tracker.init(frame, box) if i == 0 else tracker.update(frame)
                statuses.append(st.status)
                boxes.append(st.bbox)
            run = Run(boxes, statuses, 0)
            scores.append(success(seq, run))
            breaks += sum(statuses[i] is not TrackStatus.TRACKING for i in seq.in_plain_view())
            breaks += sum(statuses[i] is TrackStatus.TRACKING for i in seq.hidden())
        return float(sorted(scores)[len(scores) // 2]), breaks

    fitted, fitted_breaks = over_starts(TrackerSettings())
    filtered, filtered_breaks = over_starts(TrackerSettings(motion_fit_frames=0))
    assert fitted >= 0.8 and fitted_breaks <= 5
    assert filtered < 0.5 and filtered_breaks > 10


def test_a_coin_that_lands_lit_from_another_side_comes_back_on_its_pattern() -> None:
    """A pen flicks the coin (coin_pen) about 100 px in four frames; where it lands it is lit from
    another side: 0.37-0.52 from its colour model, past the re-entry gate's 0.29 though inside
    the tracking gate's 0.53. On its colours alone it stays OCCLUDED, then LOST, in plain view
    for 25 of the 28 labelled frames (success 0.107, measured). With its grey-level pattern, and
    looked for as widely as a lost target from its first hidden frame, it is back on frame 15
    (lost on frame 13, as the flick ends), and on frame 55 after the pen's second pass: every
    plain-view frame TRACKING (success 1.0, measured; 0.857 with the pattern in the narrower
    region)."""
    name = "coin_pen"
    seq, run = SEQUENCES[name], full_run(name)
    plain = seq.in_plain_view()
    assert any(r.startswith(BACK_ON_PATTERN) for r in run.reasons)
    assert all(run.statuses[i] is TrackStatus.TRACKING for i in plain)
    off = tracker_run(name, TrackerSettings(appearance_reentry=False))
    assert not any(r.startswith(BACK_ON_PATTERN) for r in off.reasons)
    assert len([i for i in plain if off.statuses[i] is not TrackStatus.TRACKING]) >= 20


def test_a_ball_gone_below_the_picture_is_not_claimed_where_its_window_holds_none_of_it() -> None:
    """The red ball (redball_lab) drops below the picture's bottom edge on frame 126. Its colour
    model, blended for 125 frames from windows a few pixels larger than the ball over the white
    bench, then matches the bench (distance 0.41-0.73 against the tracking gate's 0.80), and the
    window, holding not one pixel of the ball's colours, slid left along the bottom edge on the
    centre filter's prediction as TRACKING until frame 138 (the hidden frame 130 among them), and
    was elsewhere when the ball came back (OCCLUDED on plain-view frame 145; measured). Refused
    for holding nothing of the ball, the track coasts from frame 126 and takes the ball back as
    it rises through the edge."""
    run = full_run("redball_lab")
    assert run.reasons[126].startswith(NOTHING_OF_IT)
    assert all(run.statuses[i] is not TrackStatus.TRACKING for i in range(126, 131))
    assert all(run.statuses[i] is TrackStatus.TRACKING for i in range(140, 150))


def test_a_hidden_target_with_a_pattern_is_looked_for_as_widely_as_a_lost_one() -> None:
    """The flicked coin (coin_pen) lands about 100 px away four frames after it is last seen
    (frame 15's label: 233, 118, 61 x 40). From its first hidden frame, the region searched for
    a target that can come back on its pattern is LOST_SEARCH_SCALE times its window, and holds
    where it lands; with the pattern off, the region widens only with the coasting filter's
    uncertainty, and it does not."""
    seq = SEQUENCES["coin_pen"]
    assert seq.init_box is not None
    landed = seq.boxes[15]

    def regions(settings: TrackerSettings) -> list[tuple[TrackStatus, Box | None, Box | None]]:
        tracker, got = Tracker(settings), []
        for i, frame in enumerate(seq.frames()):
            if i > 15:
                break
            st = tracker.init(frame, seq.init_box) if i == 0 else tracker.update(frame)
            got.append((st.status, st.search, st.bbox))
        return got

    def holds(outer: Box | None, inner: Box) -> bool:
        return outer is not None and (
            outer[0] <= inner[0]
            and outer[1] <= inner[1]
            and inner[0] + inner[2] <= outer[0] + outer[2]
            and inner[1] + inner[3] <= outer[1] + outer[3]
        )

    on, off = regions(TrackerSettings()), regions(TrackerSettings(appearance_reentry=False))
    hidden = next(i for i, (status, _, _) in enumerate(on) if status is not TrackStatus.TRACKING)
    assert hidden == next(i for i, (status, _, _) in enumerate(off) if status is not TrackStatus.TRACKING)
    last_box, searched = on[hidden - 1][2], on[hidden + 1][1]
    assert last_box is not None and searched is not None
    # the frame (568 x 320) does not clip it here: 4 x (70 x 51) px
    assert searched[2] >= 0.9 * LOST_SEARCH_SCALE * last_box[2]
    assert searched[3] >= 0.9 * LOST_SEARCH_SCALE * last_box[3]
    assert holds(on[15][1], landed) and on[15][0] is TrackStatus.TRACKING
    assert not holds(off[15][1], landed) and off[15][0] is not TrackStatus.TRACKING


def test_a_cap_the_camera_rolls_upright_is_followed_by_its_pattern() -> None:
    """The camera turns the red cap (pens_redcap, batch F) from lying flat (68 x 19 px) to
    upright (18 x 68) in two seconds. Its pattern stays its own over its first frames (typical
    0.96), so the window turns as the pattern, turned back, says the cap has (75 degrees by frame
    40; the perspective changes too): success 1.0 (measured), every labelled frame's IoU
    0.61-0.88. With the window's aspect a slow average of CAMShift's alone it stays wide: 0.25
    (measured; IoU 0.37-0.49 from frame 20)."""
    name = "pens_redcap"
    seq = SEQUENCES[name]
    assert success(seq, full_run(name)) == 1.0
    _, _, w, h = full_run(name).boxes[60] or (0, 0, 1, 1)
    assert h / w >= 3.0  # the label 18 x 67
    off = tracker_run(name, TrackerSettings(turn_step_deg=0.0))
    assert success(seq, off) <= 0.5


def _pan_over(still: np.ndarray, frames: int = 60) -> list[tuple[np.ndarray, float, float, float]]:
    """A camera's pan over a photograph (see footage/README.md): each frame, 480 x 360, a crop
    window of 85 % zooming in to 55 % of the picture's smaller side and back, its centre on a
    Lissajous path over the picture (horizontal period ``frames``, vertical half that). Each
    frame with its crop: the still's point (x0, y0) at the frame's top-left, s frame pixels
    per still pixel."""
    h, w = still.shape[:2]
    out = []
    for i in range(frames):
        t = i / (frames - 1)
        side = min(h, w * 360 / 480) * (0.85 - 0.30 * (0.5 - 0.5 * math.cos(2 * math.pi * t)))
        cw = side * 480 / 360
        cx = w / 2 + (w - cw) / 2 * math.sin(2 * math.pi * t)
        cy = h / 2 + (h - side) / 2 * math.sin(4 * math.pi * t + 0.7)
        x0, y0, s = cx - cw / 2, cy - side / 2, 480 / cw
        m = np.float32([[s, 0, -x0 * s], [0, s, -y0 * s]])
        frame = cv2.warpAffine(still, m, (480, 360), flags=cv2.INTER_AREA, borderMode=cv2.BORDER_REFLECT)
        out.append((frame, x0, y0, s))
    return out


def test_a_target_that_left_past_the_edge_is_found_again_where_the_camera_brings_it_back() -> None:
    """Chelsea the cat's nose in a pan over her photograph (footage/chelsea.png): it leaves past
    the bottom edge of the picture on frames 14-16, is wholly out on frames 16-24, and comes
    back up through that edge 70-170 px further right, rising fast. Looked for only where its
    coasted window stopped at the edge (the tracker before), it stayed OCCLUDED from frame 14 to
    52, in plain view on frames 31-33 among them; looked for in the whole picture, it is back
    from frame 29, TRACKING on every frame it is wholly in view, within half its box, and
    claimed on none where it is out."""
    pan = _pan_over(cv2.imread(str(footage_dir() / "chelsea.png")))
    roi = (240, 250, 90, 75)  # the nose on frame 0
    _, x0, y0, s = pan[0]
    nose = (roi[0] / s + x0, roi[1] / s + y0, roi[2] / s, roi[3] / s)  # in the still
    tracker = Tracker(TrackerSettings())
    plain, hidden = [], []
    for i, (frame, x0, y0, s) in enumerate(pan):
        st = tracker.init(frame, roi) if i == 0 else tracker.update(frame)
        bx, by, bw, bh = ((nose[0] - x0) * s, (nose[1] - y0) * s, nose[2] * s, nose[3] * s)
        inside = max(0.0, min(bx + bw, 480) - max(bx, 0)) * max(0.0, min(by + bh, 360) - max(by, 0)) / (bw * bh)
        truth = (round(bx), round(by), round(bw), round(bh))
        if i and inside >= 1.0:
            plain.append((i, st.status, st.bbox is not None and iou(st.bbox, truth) >= 0.5))
        elif i and inside <= 0.0:
            hidden.append((i, st.status))
    assert len(plain) >= 12 and len(hidden) >= 8  # the clip is what the docstring says
    assert [i for i, status, _ in plain if status is not TrackStatus.TRACKING] == []
    assert [i for i, _, close in plain if not close] == []
    assert [i for i, status in hidden if status is TrackStatus.TRACKING] == []
    assert any(i > 24 for i, _, _ in plain)  # it came back
