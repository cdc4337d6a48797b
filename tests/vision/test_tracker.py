"""The tracker on rendered sequences (statistical pass rules) and on bad input."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from lfctl.config import load_config
from lfctl.render.renderer import VehiclePose
from lfctl.render.sequences import make_sequence
from lfctl.sim.camera_sensor import CameraSensor
from lfctl.vision import markers
from lfctl.vision import tracker as tracker_module
from lfctl.vision.appearance import AppearanceGate
from lfctl.vision.boxes import iou
from lfctl.vision.exposure import Exposure
from lfctl.vision.frames import FrameError
from lfctl.vision.gates import DistanceGate
from lfctl.vision.markers import BannerLook, check_constellation, find_constellations
from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import (
    BACK_ON_PATTERN,
    FOUND_SMALLER,
    NOTHING_OF_IT,
    OUTSIDE_USUAL,
    Tracker,
    TrackerSettings,
    strip_densities,
)

EXAMPLES = Path(__file__).parents[2] / "examples"


def run(tier: str, seed: int, kind: str, n: int = 150, realism: str = "off"):
    seq = make_sequence(tier, seed, n, realism=realism)
    tr = Tracker(TrackerSettings(kind=kind))
    out = []
    for i, (_t, frame, truth) in enumerate(seq.frames()):
        st = tr.init(frame, truth.bbox) if i == 0 else tr.update(frame)
        out.append((st, truth))
    return out


def success(records) -> float:
    valid = [(st, tr) for st, tr in records[1:] if tr.bbox is not None and tr.visible_fraction >= 0.5]
    return float(np.mean([st.bbox is not None and iou(st.bbox, tr.bbox) >= 0.5 for st, tr in valid]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_full_tracker_succeeds_on_the_clear_scene(seed: int) -> None:
    assert success(run("clear", seed, "full")) >= 0.9


def test_paper_claim_hue_only_loses_to_a_same_hue_distractor_that_hs_lbp_rejects() -> None:
    # gap 0 (seed 0): a flat red box slides along the banner's top edge
    assert success(run("distractor", 0, "hue", 300)) <= 0.5
    assert success(run("distractor", 0, "hs-lbp", 300)) >= 0.9
    assert success(run("distractor", 0, "full", 300)) >= 0.95


def test_baselines_report_the_markers_their_window_holds_and_none_off_the_banner() -> None:
    # the paper's pipeline: the tracker's window, then the markers inside it give the pose;
    # hue-only drifts onto the red box (gap 0) and must then report no markers there
    for kind in ("hue", "hs-lbp"):
        records = run("distractor", 0, kind, 300)
        scored = [(st, tr) for st, tr in records[1:] if tr.bbox is not None and tr.visible_fraction >= 0.5]
        on = [st.markers is not None for st, tr in scored if iou(st.bbox, tr.bbox) >= 0.5]
        off = [st.markers is not None for st, tr in scored if iou(st.bbox, tr.bbox) < 0.1]
        assert on and np.mean(on) >= 0.95, kind
        assert not any(off), kind
        if kind == "hue":
            assert len(off) >= 50  # it did drift: the assertion above was put to the test


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])  # the benchmark's seeds: 2 once let a sliver pass for the banner
def test_occlusion_is_flagged_within_3_frames_and_recovered_within_10(seed: int) -> None:
    records = run("occlusion", seed, "full", 300)
    vis = np.array([tr.visible_fraction for _, tr in records])
    hidden = np.flatnonzero(vis < 0.05)
    assert hidden.size >= 20
    first, last = hidden[0], hidden[-1]
    states = [st.status for st, _ in records]
    assert all(s is not TrackStatus.TRACKING for s in states[first + 3 : last + 1])
    assert TrackStatus.TRACKING in states[last + 1 : last + 11]
    back = next(
        i
        for i in range(last + 1, len(records))
        if records[i][0].bbox is not None and iou(records[i][0].bbox, records[i][1].bbox) >= 0.5
    )
    assert back - last <= 10


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 2])
def test_a_hidden_banner_is_not_taken_up_on_its_colours_alone_in_the_realistic_look(seed: int) -> None:
    # the realistic camera's exposure follows the dark occluder: the ground turns the light
    # grey of the banner's panel. Seed 0: a patch of it in the frame's corner passed the gate
    # after 50 hidden frames (6 hidden frames claimed); seed 2: the window slid onto it as the
    # markers went behind the occluder (22). The markers bring the banner back.
    records = run("occlusion", seed, "full", 300, realism="on")
    hidden = [i for i, (_, tr) in enumerate(records) if tr.visible_fraction < 0.05]
    assert len(hidden) >= 20
    assert [i for i in hidden if records[i][0].status is TrackStatus.TRACKING] == []
    tracked = [
        st.status is TrackStatus.TRACKING and iou(st.bbox, tr.bbox) >= 0.5 for st, tr in records[hidden[-1] + 12 :]
    ]
    assert np.mean(tracked) >= 0.95


def test_a_window_found_outside_the_usual_region_needs_the_pattern_too() -> None:
    # followed by colour alone (no markers), a hidden banner is looked for as widely as a lost
    # one at once, since it can come back on its grey-level pattern. Seed 1: on frame 152,
    # with the banner 8 % visible behind the occluder, a patch of grey pavement 0.27 from its
    # mostly grey model (the re-entry gate's 0.29) lies outside the region a target without a
    # pattern would have had; taken on colour alone, the track stayed on it through the 18
    # hidden frames that follow (measured). Its pattern fails, so it is refused. (Measured with
    # the frame-0 calibration's size factors taken whole: with them taken in part, the default,
    # the colour gate refuses the window on frame 152, the wide search never meets the patch,
    # and no hidden frame is claimed either.) The patch is refused where the best window is
    # looked for: the frame's reason is then the window found in the usual region's.
    seq = make_sequence("occlusion", 1, 200, realism="on")
    tr = Tracker(TrackerSettings(use_markers=False, calibration_shrink=1.0))
    refused = []
    outside_usual = tr._outside_usual

    def judged(*args: object) -> tuple:
        taken, why, grey = outside_usual(*args)  # type: ignore[arg-type]
        if not taken:
            refused.append((tr.frame_index, why))
        return taken, why, grey

    tr._outside_usual = judged  # type: ignore[method-assign]
    records = []
    for i, (_t, frame, truth) in enumerate(seq.frames()):
        st = tr.init(frame, truth.bbox) if i == 0 else tr.update(frame)
        records.append((st, truth))
    assert any(why.startswith(OUTSIDE_USUAL) and "fails" in why for _, why in refused)
    hidden = [i for i, (_, truth) in enumerate(records) if truth.visible_fraction < 0.05]
    assert len(hidden) >= 10
    assert [i for i in hidden if records[i][0].status is TrackStatus.TRACKING] == []


def _reappearing(look: np.ndarray) -> list:
    """A 30 px red target with a light bar down its left side moves right 4 px a frame on grey
    noise; on frames 10-13 it is gone, and from frame 14 ``look`` appears 48 px below where it
    would be: outside the region a hidden target without a pattern has (2 window sizes and
    the coasting filter's widening), inside the lost target's 4."""
    rng = np.random.default_rng(0)
    ground = rng.integers(100, 140, (240, 320, 1)).astype(np.uint8).repeat(3, axis=2)
    tracker = Tracker(TrackerSettings(use_markers=False))
    states = []
    for i in range(16):
        frame, x = ground.copy(), 40 + 4 * i
        if i < 10:
            frame[100:130, x : x + 30] = _bar_target()
        elif i >= 14:
            frame[148:178, x : x + 30] = look
        states.append(tracker.init(frame, (x, 100, 30, 30)) if i == 0 else tracker.update(frame))
    return states


def _bar_target() -> np.ndarray:
    t = np.zeros((30, 30, 3), np.uint8)
    t[:] = (40, 40, 200)
    t[:, 4:11] = (215, 215, 240)  # the light bar
    t[20:26, 14:28] = (20, 20, 90)  # a dark red patch, low right
    return t


def test_a_hidden_target_outside_the_usual_region_comes_back_on_its_pattern() -> None:
    states = _reappearing(_bar_target())
    assert [st.status for st in states[10:14]] == [TrackStatus.OCCLUDED] * 4
    back = states[14]
    assert back.status is TrackStatus.TRACKING
    assert back.reason.startswith(f"{BACK_ON_PATTERN} {OUTSIDE_USUAL}")
    assert back.bbox is not None and abs(back.bbox[1] - 148) <= 3


def test_a_look_alike_outside_the_usual_region_is_refused_for_its_pattern() -> None:
    # the same pixels turned on their side: the same colours (the gate's distance 0), the bar
    # across the top instead of down the side
    states = _reappearing(np.ascontiguousarray(_bar_target().transpose(1, 0, 2)))
    refused = states[14]
    assert refused.status is TrackStatus.OCCLUDED
    assert refused.reason.startswith(OUTSIDE_USUAL) and "fails" in refused.reason


def _darkened(n: int, to: float, start: int = 30, frames: int = 40):
    """The clear scene whose light falls from 1 to ``to`` over ``frames`` frames from ``start``
    (a camera without auto-exposure)."""
    for i, (_t, frame, truth) in enumerate(make_sequence("clear", 0, n).frames()):
        gain = 1.0 + (to - 1.0) * float(np.clip((i - start) / frames, 0.0, 1.0))
        yield cv2.convertScaleAbs(frame, alpha=gain), truth


@pytest.mark.parametrize(("compensated", "held"), [(True, True), (False, False)])
def test_the_full_tracker_holds_a_banner_darkened_to_an_eighth(compensated: bool, held: bool) -> None:
    # at an eighth of the light the panel and the markers fall under the value a marker pixel
    # needs and into the darkest brightness bin: without its exposure compensation the full
    # tracker called the banner hidden for good (the tracker-lighting sweep, gain 0.12)
    tr = Tracker()
    if not compensated:
        tr._exposure = Exposure(engage=10.0, release=10.0, limit=10.0)  # never engages at 8x
    records = []
    for i, (frame, truth) in enumerate(_darkened(130, 0.12)):
        records.append((tr.init(frame, truth.bbox) if i == 0 else tr.update(frame), truth))
    after = records[75:]
    tracked = [st.status is TrackStatus.TRACKING and iou(st.bbox, t.bbox) >= 0.5 for st, t in after]
    assert bool(np.mean(tracked) >= 0.95) == held
    if compensated:
        assert tr._exposure.gain > 1.6  # engaged (relative to the light its model was last learnt in)
        assert all(st.markers is not None for st, _ in after[-10:])  # the markers are seen in the dark


@pytest.mark.parametrize("kind", ["hue", "hs-lbp"])
def test_the_paper_trackers_see_the_camera_pixels_in_any_light(kind: str) -> None:
    tr = Tracker(TrackerSettings(kind=kind))
    for i, (frame, truth) in enumerate(_darkened(100, 0.12)):
        tr.init(frame, truth.bbox) if i == 0 else tr.update(frame)
        assert tr._exposure.gain == 1.0


def test_after_learning_afresh_the_gain_is_taken_from_that_frame() -> None:
    # a fall of 1.5x (under the 1.6x that engages) has the model learnt afresh on the dim
    # frame; a further 1.5x is then 1.5x from the model's light, not 2.25x from the first
    # frame's, and is left alone
    tr = Tracker()
    frames = [(f, t) for f, t in _darkened(2, 1.0)]
    frame, truth = frames[0]
    tr.init(frame, truth.bbox)
    dim = cv2.convertScaleAbs(frame, alpha=1 / 1.5)
    tr._exposure.rebase(dim)
    assert tr._exposure.update(cv2.convertScaleAbs(dim, alpha=1 / 1.5)) == 1.0
    assert tr._exposure.update(cv2.convertScaleAbs(dim, alpha=1 / 1.7)) == pytest.approx(1.7, rel=0.03)


def test_a_window_is_blended_into_the_model_at_its_weight() -> None:
    tr = Tracker(TrackerSettings(alpha=0.15))
    tr._ref_hist = np.array([2.0, 2.0], np.float32)
    # rate 0.15 x 0.5: (0.925 * [0.5, 0.5] + 0.075 * [1, 0]) * 4, the model's count kept
    tr._blend(np.array([1.0, 0.0], np.float32), 0.5)
    assert tr._ref_hist == pytest.approx([2.15, 1.85])
    tr._blend(np.array([1.0, 0.0], np.float32), 0.0)  # weight 0: unchanged
    assert tr._ref_hist == pytest.approx([2.15, 1.85])


def test_init_from_markers_finds_the_banner() -> None:
    _t, frame, truth = next(make_sequence("clear", 0, 1).frames())
    st = Tracker().init_from_markers(frame)
    assert st is not None and st.markers is not None and iou(st.bbox, truth.bbox) >= 0.7


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (None, "frame is None"),
        (np.zeros((0, 0, 3), np.uint8), "frame is empty"),
        (np.zeros((10, 10, 3), np.float32), "frame must be uint8, got float32"),
        (np.zeros((10, 10), np.uint8), r"frame must be H x W x 3 \(BGR\), got shape \(10, 10\)"),
        ("not an image", "frame must be a numpy array, got str"),
    ],
)
def test_bad_frames_are_named(frame: object, message: str) -> None:
    with pytest.raises(FrameError, match=message):
        Tracker().init(frame, (0, 0, 5, 5))  # type: ignore[arg-type]


def test_bad_roi_and_use_before_init() -> None:
    frame = np.zeros((48, 64, 3), np.uint8)
    with pytest.raises(FrameError, match=r"ROI 100,100,10,10 lies outside the 64x48 frame"):
        Tracker().init(frame, (100, 100, 10, 10))
    with pytest.raises(FrameError, match="positive width and height"):
        Tracker().init(frame, (1, 1, 0, 5))
    with pytest.raises(FrameError, match="not initialised"):
        Tracker().update(frame)


def test_in_a_vee_the_follower_starts_on_its_target_not_on_a_mix_with_the_banner_behind() -> None:
    # l2's view at the start of examples/vee.toml: its target l1 ahead-right, the leader
    # beyond it with two markers peeking out at l1's left edge. l1's left markers plus those
    # two sit like one banner turned 70 deg and score higher than l1 head-on; but their
    # markers are square (head-on) where a turned banner's are narrowed: the shape check
    # rejects the mix, and the slot still says which banner is the target.
    cfg = load_config(EXAMPLES / "vee.toml")
    sensor = CameraSensor(cfg, "l2", 3)
    others = [VehiclePose(0, 0, 0), VehiclePose(-1.299, 0.75, 0), VehiclePose(-1.299, -0.75, 0)]
    frame, truth = sensor.renderer.render(0.0, VehiclePose(-2.598, -1.5, 0.0, False), others, 2, "l2")
    settings = sensor.perception.tracker.s
    look = BannerLook(settings.marker_saturation, settings.marker_over_side, settings.panel_over_side)
    hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(markers, "check_constellation", lambda *a, **k: "")  # geometry only
        unchecked = find_constellations(hsv, settings.marker_hue_deg, look=look)
    assert len(unchecked) >= 2
    assert iou(unchecked[0].banner_bbox(settings.panel_over_side), truth.bbox) < 0.5  # the squarest is the mix
    assert check_constellation(unchecked[0], hsv, settings.marker_hue_deg, look) == "marker shape"
    cands = find_constellations(hsv, settings.marker_hue_deg, look=look)
    assert all(iou(c.banner_bbox(settings.panel_over_side), truth.bbox) >= 0.8 for c in cands)
    # the slot (1.5 m at 30 deg) says where the target should be; the tracker takes the nearest
    assert sensor.perception.expected_box is not None and iou(sensor.perception.expected_box, truth.bbox) >= 0.8
    st = Tracker(settings).init_from_markers(frame, sensor.perception.expected_box)
    assert st is not None and iou(st.bbox, truth.bbox) >= 0.8


def test_strip_densities_worked_by_hand() -> None:
    """A 20 x 20 region at (100, 50): the core (110..113, 60..63) at 90, the strip the grown
    window (108..115, 58..65) adds around it at 30, its ring (2x: 104..119, 54..69) at 6."""
    prob = np.zeros((20, 20), np.uint8)
    prob[4:20, 4:20] = 6  # the ring's outer box, rows 54..69 and columns 104..119
    prob[8:16, 8:16] = 30  # the grown window
    prob[10:14, 10:14] = 90  # the window it grew from
    grown, core = (108, 58, 8, 8), (110, 60, 4, 4)
    inside, strip, ring = strip_densities(prob, (100, 50), grown, core, 2.0)
    assert (inside, strip, ring) == (90.0, 30.0, 6.0)
    # a grown window that holds only part of the core: the inside is their overlap (2 x 4 px
    # at 90); the strip, the other 56 px: 24 at 30 and 32 at 6
    inside, strip, _ = strip_densities(prob, (100, 50), (112, 58, 8, 8), core, 2.0)
    assert inside == 90.0
    assert strip == pytest.approx((24 * 30 + 32 * 6) / 56)
    # windows past the region's edge count only the pixels inside it; an empty strip is None
    assert strip_densities(prob, (100, 50), core, core, 2.0) is None
    assert strip_densities(prob, (100, 50), (90, 40, 4, 4), core, 2.0) is None


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("sprawl_growth", -1.0),
        ("sprawl_growth", float("nan")),
        ("sprawl_scales", (0.8, 1.2)),
        ("sprawl_scales", (0.0,)),
        ("sprawl_margin", -0.1),
        ("sprawl_margin", 1.5),
    ],
)
def test_sprawl_settings_that_mean_nothing_are_refused(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=field):
        TrackerSettings(**{field: value})  # type: ignore[arg-type]


def _square_prob(side: int, halo: int, size: int = 200) -> np.ndarray:
    """A back-projection: a ``side`` px square at 200 in the middle, ``halo`` elsewhere."""
    prob = np.full((size, size), halo, np.uint8)
    a = size // 2 - side // 2
    prob[a : a + side, a : a + side] = 200
    return prob


def _located_size(prob: np.ndarray, sprawling: bool, start_side: int = 30) -> float | None:
    """The size _locate measures from a centred ``start_side`` px window (calibration 1)."""
    tr = Tracker(TrackerSettings(use_markers=False))
    tr._calibration = (1.0, 1.0, 0.0, 0.0)
    tr._area = tr._size_filter(float(start_side), 0.02**2)
    tr._sprawling = sprawling
    a = prob.shape[0] // 2 - start_side // 2
    return tr._locate(prob, (0, 0), (a, a, start_side, start_side)).size_px


def test_a_target_marked_as_sprawling_grows_only_onto_back_projection_dense_like_its_own() -> None:
    # a 30 px target in a faint halo (20 of 255): CAMShift's window, taking in 10 px more on
    # every side, measures 43 px; believed unless the target is marked, then as predicted
    faint = _square_prob(30, 20)
    assert _located_size(faint, sprawling=False) == 43.0
    assert _located_size(faint, sprawling=True) == 30.0
    # a 60 px target, the window grown inside it: the strip is as dense as the core, believed
    assert _located_size(_square_prob(60, 0), sprawling=True) == 60.0
    # shrinking is never checked: an 18 px target measures 23 px, marked or not
    assert _located_size(_square_prob(18, 0), sprawling=True) == 23.0
    # the cost: a 40 px target in an empty field, CAMShift's window overshooting it (48 px),
    # adds a strip half empty; a marked target's real growth is refused (it lags, documented)
    assert _located_size(_square_prob(40, 0), sprawling=False) == 48.0
    assert _located_size(_square_prob(40, 0), sprawling=True) == 30.0


def _recoloured_box_frames() -> tuple[np.ndarray, np.ndarray]:
    """A blue 40 px box on a textured grey; then the same box red but for a blue 16 px core."""
    rng = np.random.default_rng(3)
    base = cv2.GaussianBlur(rng.normal(110, 12, (240, 320, 3)).clip(0, 255).astype(np.uint8), (3, 3), 0)
    before = base.copy()
    cv2.rectangle(before, (140, 100), (179, 139), (200, 120, 40), -1)
    after = base.copy()
    cv2.rectangle(after, (140, 100), (179, 139), (40, 60, 200), -1)
    cv2.rectangle(after, (152, 112), (167, 127), (200, 120, 40), -1)
    return before, after


@pytest.mark.parametrize(("growth", "status"), [(1.5, TrackStatus.OCCLUDED), (0.0, TrackStatus.TRACKING)])
def test_only_a_grown_window_is_looked_for_smaller(growth: float, status: TrackStatus) -> None:
    """A target whose window has not grown and fails the gate has changed, not sprawled: it is
    not taken up again on a part of itself that still matches (with no growth limit it is)."""
    before, after = _recoloured_box_frames()
    tr = Tracker(TrackerSettings(use_markers=False, sprawl_growth=growth))
    tr.init(before, (140, 100, 40, 40))
    for _ in range(6):
        tr.update(before)
    st = tr.update(after)
    assert st.status is status
    assert st.reason.startswith(FOUND_SMALLER) == (status is TrackStatus.TRACKING)
    assert tr._sprawling == (status is TrackStatus.TRACKING)
    tr.init(before, (140, 100, 40, 40))  # a new start forgets the mark
    assert not tr._sprawling


def test_a_window_found_smaller_outside_the_usual_region_is_taken_on_its_pattern_and_said_to_be(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Outside the region a hidden target would have had, a window found at a smaller size is
    taken only if its pattern passes, and then its reason says both how and where."""
    before, after = _recoloured_box_frames()
    tr = Tracker(TrackerSettings(use_markers=False, sprawl_growth=0.0))
    tr.init(before, (140, 100, 40, 40))
    for _ in range(6):
        tr.update(before)
    assert tr.window is not None
    search = (0, 0, after.shape[1], after.shape[0])
    planes, _ = tr._features(after)
    prob = tr._probability(planes)
    usual = (0, 0, 60, 60)  # the region it would have had: far from the box
    smaller = (after, tr.window, search, planes, prob, False, usual)
    monkeypatch.setattr(AppearanceGate, "best_score", lambda self, grey, box: 0.5)  # (a plain box has no pattern)
    monkeypatch.setattr(AppearanceGate, "passes", lambda self, s: False)
    assert tr._look_smaller(*smaller) is None
    monkeypatch.setattr(AppearanceGate, "passes", lambda self, s: True)
    st = tr._look_smaller(*smaller)
    assert st is not None and st.status is TrackStatus.TRACKING
    assert st.reason.startswith(FOUND_SMALLER)
    assert f"{BACK_ON_PATTERN} {OUTSIDE_USUAL}" in st.reason
    # inside the region it would have had, no pattern is asked for and none is named
    monkeypatch.setattr(AppearanceGate, "passes", lambda self, s: False)
    st = tr._look_smaller(after, tr.window, search, planes, prob, False, search)
    assert st is not None and OUTSIDE_USUAL not in st.reason


def _moving_box_frames(n: int, speed_px: int) -> list[np.ndarray]:
    """A blue 40 px box on a textured grey moving right ``speed_px`` a frame, then the grey
    alone (the box hidden) for as many frames again."""
    rng = np.random.default_rng(5)
    base = cv2.GaussianBlur(rng.normal(110, 12, (240, 400, 3)).clip(0, 255).astype(np.uint8), (3, 3), 0)
    frames = []
    for k in range(n):
        f = base.copy()
        x = 60 + speed_px * k
        cv2.rectangle(f, (x, 100), (x + 39, 139), (200, 120, 40), -1)
        frames.append(f)
    return frames + [base.copy() for _ in range(n)]


@pytest.mark.parametrize(("fit_frames", "direction"), [(15, 1), (0, -1)])
def test_a_hidden_target_coasts_on_the_motion_of_its_confident_frames(fit_frames: int, direction: int) -> None:
    """A box walks right 4 px a frame. Just before it is hidden, the centre filter is given a
    velocity of 6 px a frame to the left, as a neighbour dragging the last windows would: the
    search then coasts right, at the box's pace, on the motion fitted to its confident frames;
    with the fit off (0), left on the filter's."""
    frames = _moving_box_frames(14, 4)
    tr = Tracker(TrackerSettings(use_markers=False, motion_fit_frames=fit_frames))
    tr.init(frames[0], (60, 100, 40, 40))
    for f in frames[1:14]:
        assert tr.update(f).status is TrackStatus.TRACKING
    x, _ = tr._centre.state
    tr._centre.set_motion(np.array([x[0], x[1], -6.0, 0.0]))  # dragged off, as by a neighbour
    hidden = [tr.update(f) for f in frames[14:20]]
    assert all(st.status is TrackStatus.OCCLUDED for st in hidden)
    # the first hidden frame shows where the dragged filter predicted it; the coasting starts after
    centres = [st.bbox[0] + st.bbox[2] / 2 for st in hidden[1:]]
    pace = (centres[-1] - centres[0]) / (len(centres) - 1)
    if direction > 0:
        assert pace == pytest.approx(4.0, abs=0.5)  # the box's own pace
        assert abs(centres[0] - (60 + 4 * 15 + 20)) <= 4  # where the box would be on frame 15
    else:
        assert pace < -3.0


def test_a_target_that_left_past_the_edge_is_looked_for_at_that_edge_and_found_again() -> None:
    """A blue box runs right 8 px a frame out past the picture's right edge, stays out for
    20 frames (a camera that turned away), and comes back in at the same edge 60 px lower,
    where it stands. The hidden target is looked for at the edge where it left: it is found
    there, not coasted on out of the picture (where no search region reaches: it was OCCLUDED,
    then LOST, for good)."""
    rng = np.random.default_rng(5)
    base = cv2.GaussianBlur(rng.normal(110, 12, (240, 400, 3)).clip(0, 255).astype(np.uint8), (3, 3), 0)

    def at(x: int, y: int) -> np.ndarray:
        f = base.copy()
        cv2.rectangle(f, (x, y), (x + 39, y + 39), (200, 120, 40), -1)
        return f

    frames = [at(260 + 8 * k, 80) for k in range(18)]  # off the picture from frame 18
    frames += [base.copy() for _ in range(20)]
    frames += [at(360, 140) for _ in range(20)]  # back, wholly in view at the right edge
    tr = Tracker(TrackerSettings(use_markers=False))
    states = [tr.init(frames[0], (260, 80, 40, 40))] + [tr.update(f) for f in frames[1:]]
    assert all(st.status is not TrackStatus.TRACKING for st in states[20:38])  # gone
    assert not any("left the frame" in st.reason for st in states)
    assert all(st.bbox is not None for st in states[18:38])  # the coasted window, on the picture
    # a banner whose markers were seen coasts on out of the picture, as it did: it is looked
    # for in the whole picture on its markers then (this box has none, so it stays hidden)
    banner = Tracker(TrackerSettings())
    banner.init(frames[0], (260, 80, 40, 40))
    banner._markers_seen = True  # as if its markers had been seen at the start
    coasted = [banner.update(f) for f in frames[1:38]]
    assert coasted[-1].status is TrackStatus.OCCLUDED and coasted[-1].bbox is None  # off the picture
    back = states[38:]
    found = next(i for i, st in enumerate(back) if st.status is TrackStatus.TRACKING)
    assert found <= 3
    assert all(st.status is TrackStatus.TRACKING for st in back[found:])
    assert iou(back[-1].bbox, (360, 140, 40, 40)) >= 0.7


def _past_the_edge_and_back(
    look: np.ndarray, reentry: bool = True, start: int = 220, back: int = 23, frames: int = 30
) -> list:
    """The bar target runs right 8 px a frame from x = ``start`` out past the right edge of a
    320 px picture (wholly out from frame 13 by default: a camera that turned away), and from
    frame ``back`` ``look`` stands at the far left (the camera turned back along another
    path): 180 px from the edge it left by, outside the region it would have had there (4
    window sizes). The tracker's states."""
    rng = np.random.default_rng(0)
    ground = rng.integers(100, 140, (240, 320, 1)).astype(np.uint8).repeat(3, axis=2)
    tracker = Tracker(TrackerSettings(use_markers=False, appearance_reentry=reentry))
    states = []
    for i in range(frames):
        frame, x = ground.copy(), start + 8 * i
        if x < 320:
            frame[100:130, x : min(320, x + 30)] = _bar_target()[:, : min(30, 320 - x)]
        elif i >= back:
            frame[100:130, 20:50] = look
        states.append(tracker.init(frame, (x, 100, 30, 30)) if i == 0 else tracker.update(frame))
    return states


def test_a_target_that_left_past_the_edge_is_looked_for_in_the_whole_picture() -> None:
    """Back at the far left, the target is found on its first frame there, on its pattern
    (outside the region it would have had); while it was out, once its coasted window had
    stopped at the edge, the whole picture was searched."""
    states = _past_the_edge_and_back(_bar_target())
    assert all(st.status is TrackStatus.OCCLUDED for st in states[13:23])  # wholly out
    whole = (0, 0, 320, 240)
    assert states[22].search == whole
    back = states[23]
    assert back.status is TrackStatus.TRACKING
    assert back.reason.startswith(f"{BACK_ON_PATTERN} {OUTSIDE_USUAL}")
    assert back.bbox is not None and iou(back.bbox, (20, 100, 30, 30)) >= 0.6
    assert all(st.status is TrackStatus.TRACKING for st in states[23:])
    assert states[-1].search != whole  # tracking again: the usual region


def test_a_look_alike_across_the_picture_is_not_taken_for_a_target_that_left_past_the_edge() -> None:
    """The same colours (the bar across the top, not down the side) at the far left: searched
    for in the whole picture, it is found, and refused for its pattern; a target without a
    pattern (``appearance_reentry=False``) is not looked for there at all."""
    turned = np.ascontiguousarray(_bar_target().transpose(1, 0, 2))
    states = _past_the_edge_and_back(turned)
    assert all(st.status is TrackStatus.OCCLUDED for st in states[23:])
    assert all(st.reason.startswith(OUTSIDE_USUAL) and "fails" in st.reason for st in states[23:])
    states = _past_the_edge_and_back(_bar_target(), reentry=False)
    assert all(st.status is not TrackStatus.TRACKING for st in states[23:])
    assert all(st.search is None or st.search[0] > 50 for st in states[13:])  # never over the far left


def test_a_target_back_on_its_pattern_outside_the_usual_region_is_said_to_be(monkeypatch: pytest.MonkeyPatch) -> None:
    """The bar target back at the far left, its colours made to pass only the tracking gate,
    not the re-entry one (as a target lit differently comes back): it is taken on its pattern,
    and the reason says the window lies outside the region it would have had, as a window
    taken there past the re-entry gate says."""
    accepts = DistanceGate.accepts
    monkeypatch.setattr(DistanceGate, "accepts", lambda self, d, reentry=False: not reentry and accepts(self, d))
    back = _past_the_edge_and_back(_bar_target())[23]
    assert back.status is TrackStatus.TRACKING
    assert back.reason.startswith(f"{BACK_ON_PATTERN} {OUTSIDE_USUAL} (colour distance")


def test_a_look_alike_is_refused_for_its_pattern_however_long_the_target_was_out() -> None:
    """The look-alike of the test above, first seen 33 frames after the target went out: the
    coaster's uncertainty has grown on at the edge meanwhile (the region it gives would take in
    the whole picture), but the region outside which the pattern must pass is held at the lost
    target's, 4 window sizes: the look-alike is still refused."""
    turned = np.ascontiguousarray(_bar_target().transpose(1, 0, 2))
    states = _past_the_edge_and_back(turned, back=46, frames=50)
    assert all(st.status is TrackStatus.OCCLUDED for st in states[13:])
    assert all(st.reason.startswith(OUTSIDE_USUAL) and "fails" in st.reason for st in states[46:])


def test_a_target_out_before_its_pattern_is_learnt_is_not_searched_for_in_the_whole_picture() -> None:
    """The bar target goes out past the edge on frame 4, before its pattern's typical score is
    learnt (five accepted frames): no window outside the region it would have had could pass,
    so the whole picture is not searched (it costs 2-3 times a frame, for nothing)."""
    states = _past_the_edge_and_back(_bar_target(), start=290, back=12, frames=20)
    assert all(st.status is not TrackStatus.TRACKING for st in states[4:12])
    assert all(st.search != (0, 0, 320, 240) for st in states)


def test_a_look_alike_across_the_picture_does_not_hide_a_target_back_at_the_edge_it_left_by() -> None:
    """The bar target of :func:`_past_the_edge_and_back` comes back from frame 23 at the edge it
    left by, its lower 14 rows hidden (its window not clearly where predicted: the best window
    is looked for), while a look-alike (the bar across the top) stands at the far left. The
    best window in the whole picture is the look-alike, refused for its pattern; the target,
    in the region it would have had, is found there on its first frame back, as it is without
    the look-alike."""
    rng = np.random.default_rng(0)
    ground = rng.integers(100, 140, (240, 320, 1)).astype(np.uint8).repeat(3, axis=2)
    turned = np.ascontiguousarray(_bar_target().transpose(1, 0, 2))
    for look_alike in (False, True):
        tracker = Tracker(TrackerSettings(use_markers=False))
        states = []
        for i in range(26):
            frame, x = ground.copy(), 220 + 8 * i
            if x < 320:
                frame[100:130, x : min(320, x + 30)] = _bar_target()[:, : min(30, 320 - x)]
            elif i >= 23:
                frame[100:116, 285:315] = _bar_target()[:16]
                if look_alike:
                    frame[100:130, 20:50] = turned
            states.append(tracker.init(frame, (x, 100, 30, 30)) if i == 0 else tracker.update(frame))
        assert states[22].search == (0, 0, 320, 240)
        assert all(st.status is TrackStatus.TRACKING for st in states[23:]), look_alike
        assert states[23].bbox is not None and iou(states[23].bbox, (285, 100, 30, 16)) >= 0.4


def test_a_banner_across_the_picture_is_not_taken_on_its_markers_for_a_target_that_left_past_the_edge() -> None:
    """With the markers on (the default), the bar target (no markers) runs out past the edge; a
    rendered banner, of about its size, stands at the far left from frame 23. Its markers are
    found in the whole picture searched, outside the region the target would have had: they
    do not bring it back (another vehicle's banner), nor do its colours."""
    _t, rendered, truth = next(make_sequence("clear", 0, 1).frames())
    x, y, w, h = truth.bbox
    crop = rendered[y - 6 : y + h + 6, x - 6 : x + w + 6]
    crop = cv2.resize(crop, None, fx=42.0 / crop.shape[0], fy=42.0 / crop.shape[0], interpolation=cv2.INTER_AREA)
    rng = np.random.default_rng(0)
    ground = rng.integers(100, 140, (240, 320, 1)).astype(np.uint8).repeat(3, axis=2)
    shown = ground.copy()
    shown[90 : 90 + crop.shape[0], 10 : 10 + crop.shape[1]] = crop
    assert Tracker().init_from_markers(shown) is not None  # the banner's markers are found there
    tracker = Tracker(TrackerSettings())
    states = []
    for i in range(30):
        frame, x = (shown if i >= 23 else ground).copy(), 220 + 8 * i
        if x < 320:
            frame[100:130, x : min(320, x + 30)] = _bar_target()[:, : min(30, 320 - x)]
        states.append(tracker.init(frame, (x, 100, 30, 30)) if i == 0 else tracker.update(frame))
    assert states[22].search == (0, 0, 320, 240)
    assert all(st.status is TrackStatus.OCCLUDED and st.markers is None for st in states[23:])


@pytest.mark.parametrize("distance", [0.0, 0.3])
def test_a_window_with_no_pixel_of_the_target_is_not_taken_on_its_colour_distance(
    monkeypatch: pytest.MonkeyPatch, distance: float
) -> None:
    """The box moves on and then is gone. Its window's colour distance is forced to pass the
    gate (as a model blended from windows that took in surroundings can match them): with the
    box in view the window is still TRACKING, once it is gone and no pixel of the window
    back-projects it is OCCLUDED, and the reason says why."""
    frames = _moving_box_frames(10, 2)
    tr = Tracker(TrackerSettings(use_markers=False))
    tr.init(frames[0], (60, 100, 40, 40))
    for f in frames[1:10]:
        assert tr.update(f).status is TrackStatus.TRACKING
    monkeypatch.setattr(tracker_module, "colour_distance", lambda *_a: distance)
    assert tr.update(frames[9]).status is TrackStatus.TRACKING  # the box, on any distance
    gone = tr.update(frames[10])
    assert gone.status is TrackStatus.OCCLUDED
    assert gone.reason.startswith(NOTHING_OF_IT)
    assert f"colour distance {distance:.2f}" in gone.reason


def test_motion_fit_frames_must_be_a_whole_number() -> None:
    for bad in (-1, 2.5):
        with pytest.raises(ValueError, match="motion_fit_frames"):
            TrackerSettings(motion_fit_frames=bad)  # type: ignore[arg-type]


def _turned_on_ground(face: np.ndarray, mask: np.ndarray, angle_deg: float, seed: int) -> np.ndarray:
    """``face`` where ``mask`` is set, turned by ``angle_deg`` (OpenCV's sense) about (120, 100),
    on grey noise (240 x 200)."""
    rng = np.random.default_rng(seed)
    frame = rng.integers(110, 150, (200, 240, 1)).astype(np.uint8).repeat(3, axis=2)
    m = cv2.getRotationMatrix2D((120.0, 100.0), angle_deg, 1.0)
    face, mask = cv2.warpAffine(face, m, (240, 200)), cv2.warpAffine(mask, m, (240, 200))
    frame[mask > 127] = face[mask > 127]
    return frame


def _rolled_rod(still: int = 10, frames: int = 80) -> list[tuple[np.ndarray, tuple[int, int, int, int]]]:
    """A 64 x 18 px red rod with a blue tip and a dark stripe, lying still for ``still`` frames,
    then turned clockwise 1.5 degrees a frame to upright (as a rolling camera turns a pen's
    cap); each frame with the upright box around the rod."""
    face, mask = np.zeros((200, 240, 3), np.uint8), np.zeros((200, 240), np.uint8)
    face[91:109, 88:152] = (40, 40, 200)
    face[91:109, 136:152] = (200, 120, 30)  # the tip
    face[96:104, 96:118] = (25, 25, 120)  # the stripe
    mask[91:109, 88:152] = 255
    out = []
    for i in range(frames):
        angle = -min(90.0, 1.5 * max(0, i - still))
        frame = _turned_on_ground(face, mask, angle, i)
        turned = cv2.warpAffine(mask, cv2.getRotationMatrix2D((120.0, 100.0), angle, 1.0), (240, 200))
        x, y, w, h = cv2.boundingRect((turned > 127).astype(np.uint8))
        out.append((frame, (x, y, w, h)))
    return out


@pytest.mark.parametrize("step", [5.0, 0.0])
def test_a_rigid_target_turned_upright_is_followed_by_its_pattern(step: float) -> None:
    clip = _rolled_rod()
    tracker = Tracker(TrackerSettings(use_markers=False, turn_step_deg=step))
    for i, (frame, box) in enumerate(clip):
        st = tracker.init(frame, box) if i == 0 else tracker.update(frame)
        assert st.status is TrackStatus.TRACKING
    assert st.bbox is not None
    _, _, w, h = st.bbox
    if step:  # measured: followed to 60 degrees, the window 21 x 47 px on the 18 x 64 rod, IoU 0.59
        assert tracker.turn_deg >= 45.0
        assert h / w >= 2.0 and iou(st.bbox, box) >= 0.5
    else:  # the window's aspect a slow average of CAMShift's: measured 24 x 19 px, IoU 0.27
        assert tracker.turn_deg == 0.0
        assert h / w < 2.0


@pytest.mark.parametrize(("rigid", "turned"), [(0.9, False), (0.8, True)])
def test_a_target_whose_pattern_changes_from_the_start_is_not_turned(rigid: float, turned: bool) -> None:
    # the rod turning from the first frame: its pattern's typical score over the first accepted
    # windows (measured 0.84) is under turn_rigid's 0.9, so it is not taken as rigid; held to
    # 0.8 it is (measured: followed to 55 degrees)
    tracker = Tracker(TrackerSettings(use_markers=False, turn_rigid=rigid))
    for i, (frame, box) in enumerate(_rolled_rod(still=0)):
        tracker.init(frame, box) if i == 0 else tracker.update(frame)
    assert (tracker.turn_deg >= 30.0) is turned and (tracker.turn_deg == 0.0) is not turned


def test_a_banner_whose_markers_were_seen_is_not_turned(monkeypatch: pytest.MonkeyPatch) -> None:
    # started from a box, its markers first seen on frame 6 (a constellation given there), then
    # missing: a banner whose markers were seen is held to them, not to a pattern
    tracker = Tracker(TrackerSettings())

    class Seen:
        centres = np.zeros((4, 2))

        def __init__(self, box: tuple[int, int, int, int]) -> None:
            self.box = box

        def banner_bbox(self, _panel_over_side: float) -> tuple[int, int, int, int]:
            return self.box

    for i, (frame, box) in enumerate(_rolled_rod()):
        if i == 6:
            monkeypatch.setattr(tracker, "_markers_near", lambda *_a, b=box, **_k: Seen(b))
        elif i == 7:
            monkeypatch.setattr(tracker, "_markers_near", lambda *_a, **_k: None)
        tracker.init(frame, box) if i == 0 else tracker.update(frame)
    assert tracker.turn_deg == 0.0


@pytest.mark.parametrize(("shrink", "most_deg"), [(1.0, 0.0), (0.25, 5.0)])
def test_a_spinning_coin_whose_outline_stays_is_not_turned(shrink: float, most_deg: float) -> None:
    # a 60 x 40 px red ellipse whose embossed bar spins 2 degrees a frame inside it: the pattern
    # turns, the outline (CAMShift's aspect) does not, so the window is not turned (measured:
    # without that agreement it is followed to 135 degrees and its window narrows to w/h 1.11).
    # With the calibration's height factor (0.854) taken in part, the default, the measured
    # aspect runs 11 % above the box's on the still frames, and one 5 degree step is taken on
    # frame 14 and held: at most one step
    face = np.zeros((200, 240, 3), np.uint8)
    face[:] = (40, 40, 200)
    cv2.rectangle(face, (100, 94), (150, 106), (20, 20, 110), -1)
    cv2.circle(face, (104, 100), 6, (90, 90, 240), -1)
    mask = np.full((200, 240), 255, np.uint8)
    outline = np.zeros((200, 240), np.uint8)
    cv2.ellipse(outline, (120, 100), (30, 20), 0, 0, 360, 255, -1)
    tracker = Tracker(TrackerSettings(use_markers=False, calibration_shrink=shrink))
    for i in range(80):
        frame = _turned_on_ground(face, mask, -2.0 * max(0, i - 10), i)
        ground = _turned_on_ground(face, np.zeros_like(mask), 0.0, i)
        frame[outline == 0] = ground[outline == 0]
        st = tracker.init(frame, (90, 80, 61, 41)) if i == 0 else tracker.update(frame)
        assert st.status is TrackStatus.TRACKING and st.bbox is not None
        assert st.bbox[2] / st.bbox[3] >= 1.3  # 61 x 41: 1.49
    assert abs(tracker.turn_deg) <= most_deg


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("turn_step_deg", -1.0),
        ("turn_step_deg", 90.0),
        ("turn_step_deg", float("nan")),
        ("turn_rigid", 1.5),
        ("turn_margin", -0.1),
    ],
)
def test_turn_settings_that_mean_nothing_are_refused(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        TrackerSettings(**{field: value})  # type: ignore[arg-type]


def _calibrated(roi: tuple[int, int, int, int], shrink: float) -> tuple[float, float, float, float]:
    """The frame-0 calibration of a full tracker started on ``roi`` over a red 40 x 40 square
    at (80, 60) on grey."""
    frame = np.full((200, 240, 3), 128, np.uint8)
    frame[60:100, 80:120] = (30, 30, 200)
    tracker = Tracker(TrackerSettings(use_markers=False, calibration_shrink=shrink))
    tracker.init(frame, roi)
    return tracker._calibration


def test_a_size_factor_below_one_is_taken_in_part_and_one_above_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    # drawn inside the square: CAMShift's window takes the whole square, twice the box
    whole = _calibrated((88, 68, 24, 24), 1.0)
    assert whole[:2] == (0.5, 0.5)
    assert _calibrated((88, 68, 24, 24), 0.25)[:2] == pytest.approx((0.5**0.25, 0.5**0.25))  # 0.841
    assert _calibrated((88, 68, 24, 24), 0.0)[:2] == (1.0, 1.0)
    # drawn over the square's top-left corner: mean shift moves into the square, and the
    # offsets back to the box are taken whole whatever the setting
    corner = _calibrated((72, 52, 24, 24), 1.0)
    assert corner[2] < -0.1 and corner[3] < -0.1
    assert _calibrated((72, 52, 24, 24), 0.25)[2:] == corner[2:]

    def camshift_gives(w: int, h: int) -> None:
        monkeypatch.setattr(tracker_module, "camshift_in_roi", lambda prob, origin, s: ((s[0], s[1], w, h), 1.0))

    # 60 x 60 for 24 x 24: 0.4, kept to 0.5 before the power (0.841; the power first: 0.795)
    camshift_gives(60, 60)
    assert _calibrated((88, 68, 24, 24), 0.25)[:2] == pytest.approx((0.5**0.25, 0.5**0.25))
    # narrower on one axis, wider on the other: 1.2 whole, 0.6 in part
    camshift_gives(20, 40)
    assert _calibrated((88, 68, 24, 24), 0.25)[:2] == pytest.approx((1.2, 0.6**0.25))
    assert _calibrated((88, 68, 24, 24), 1.0)[:2] == pytest.approx((1.2, 0.6))


@pytest.mark.parametrize("value", [-0.1, 1.5, float("nan")])
def test_a_calibration_shrink_outside_0_1_is_refused(value: float) -> None:
    with pytest.raises(ValueError, match="calibration_shrink"):
        TrackerSettings(calibration_shrink=value)
