"""`lfctl track` on real video (the labelled footage lfctl ships), on a rendered banner video
with automatic marker detection, and on bad input."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from lfctl.bench.footage import load_sequence
from lfctl.cli import main
from lfctl.data import footage_dir
from lfctl.render.sequences import make_sequence
from lfctl.vision.boxes import iou


def records(capsys: pytest.CaptureFixture[str]) -> list[dict]:
    return [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]


def test_tracks_a_real_target_through_a_whole_video(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """carphone_pristine.mp4 whole (120 frames) from the label's first box, as a user runs it
    (default tracker, markers on): tracking and on the labelled box in every labelled frame,
    and no banner pose (there is no banner)."""
    seq = load_sequence(footage_dir() / "labels" / "carphone_bowtie.json")
    assert seq.first_frame == 0
    out = tmp_path / "annotated.mp4"
    roi = ",".join(str(v) for v in seq.init_box or ())
    assert main(["track", str(seq.video), "--roi", roi, "--out", str(out)]) == 0
    recs = records(capsys)
    assert [r["frame"] for r in recs] == list(range(seq.n_frames))
    for i in seq.in_plain_view():
        assert recs[i]["state"] == "tracking", recs[i]
        assert iou(recs[i]["bbox"], seq.boxes[i]) >= 0.5, (recs[i], seq.boxes[i])
    assert not any("pose" in r or "markers" in r for r in recs)
    assert out.is_file() and out.stat().st_size > 10_000


def banner_video(path: Path, frames: int) -> list:
    """A rendered banner (the clear tier, seed 3) written as an MJPG video: its frames' truths."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (640, 480))
    truths = []
    for _t, frame, truth in make_sequence("clear", 3, frames).frames():
        writer.write(frame)
        truths.append(truth)
    writer.release()
    return truths


def test_finds_the_banner_and_reports_its_pose(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    video = tmp_path / "banner.avi"
    truths = banner_video(video, 30)
    assert main(["track", str(video)]) == 0
    recs = records(capsys)
    assert len(recs) == 30
    with_pose = [(r, tr) for r, tr in zip(recs, truths, strict=True) if "pose" in r]
    assert len(with_pose) >= 27
    err = np.array([(r["pose"]["range_m"] - tr.range_m) / tr.range_m for r, tr in with_pose])
    assert np.sqrt(np.mean(err**2)) < 0.02
    assert "ended after" not in capsys.readouterr().err  # the whole file: nothing to say
    # the same file cut short (a copy that stopped, a damaged card): said, with what it declares
    # well short of it is an error (exit 2), after every frame read was tracked and printed
    cut = tmp_path / "cut.avi"
    cut.write_bytes(video.read_bytes()[: video.stat().st_size // 2])
    assert main(["track", str(cut)]) == 2
    captured = capsys.readouterr()
    n = len([line for line in captured.out.splitlines() if line.startswith("{")])
    assert 0 < n < 27 and f"{cut} ended after {n} of the 30 frames it declares: the file is cut" in captured.err


def test_frames_that_do_not_decode_in_the_middle_of_a_file_are_passed_over_and_said(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    # 5 kB zeroed a third into the bow-tie clip: OpenCV fails one read and decodes the 84 frames
    # after it; the tracker stopped at the failed read and called the file cut
    data = bytearray((footage_dir() / "carphone_pristine.mp4").read_bytes())
    at = len(data) // 3
    data[at : at + 5000] = bytes(5000)
    damaged = tmp_path / "damaged.mp4"
    damaged.write_bytes(data)
    assert main(["track", str(damaged), "--roi", "80,101,45,18"]) == 0
    captured = capsys.readouterr()
    recs = [json.loads(line) for line in captured.out.splitlines() if line.startswith("{")]
    assert len(recs) == 119 and recs[-1]["state"] == "tracking"
    assert recs[-1]["t_s"] == pytest.approx(119 / 29.97, abs=0.05)  # its own time: the frame passed over counts
    assert "1 frame that did not decode passed over (damaged in the middle" in captured.err
    assert "ended after" not in captured.err


class _LiveCamera:
    """A live camera (as VideoSource gives one) whose first ``dark`` frames are a plain grey
    card (the banner not in view yet, or a stream's first frame half decoded), then the
    rendered banner."""

    live = untimed = True
    info = declared_frames = declared_duration_s = pixel_aspect = None
    fps, skipped, passed_over = 30.0, 0, 0

    def __init__(self, source: object, latest: bool = False, dark: int = 5) -> None:
        grey = np.full((480, 640, 3), 128, np.uint8)
        self._frames = [grey] * dark + [f for _t, f, _truth in make_sequence("clear", 3, 20).frames()]
        self.frames_read = 0

    @property
    def time_s(self) -> float:
        return max(0, self.frames_read - 1) / self.fps

    def read(self, timeout_s: float | None = None) -> np.ndarray | None:
        if self.frames_read >= len(self._frames):
            return None
        self.frames_read += 1
        return self._frames[self.frames_read - 1]

    def close(self) -> None:
        pass

    def __enter__(self) -> _LiveCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        pass


def test_a_live_camera_is_searched_for_the_banner_until_it_shows(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # a file whose first frame shows no banner is an error (give --roi); a camera's first frame
    # may not show it yet: each frame is searched, the frames before it said as lost
    import lfctl.video

    monkeypatch.setattr(lfctl.video, "VideoSource", _LiveCamera)
    assert main(["track", "0"]) == 0
    captured = capsys.readouterr()
    recs = [json.loads(line) for line in captured.out.splitlines() if line.startswith("{")]
    assert [r["state"] for r in recs[:5]] == ["lost"] * 5 and len(recs) == 25
    assert sum("pose" in r for r in recs[5:]) >= 18  # found on its first frame in view
    assert "no banner (its four markers, or its ArUco tag) in 0's first frame: looking for it in each frame" in (
        captured.err
    )


def test_a_calibration_made_at_another_size_of_the_same_aspect_is_scaled_to_the_frames(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """A camera calibrated at 1280 x 960 that gives 640 x 480 frames: its intrinsics are halved
    (and said), so the pose is as true as with the frames' own; another aspect is refused."""
    import math

    from lfctl.data import examples_dir

    video = tmp_path / "banner.avi"
    truths = banner_video(video, 20)
    fx = 320 / math.tan(math.radians(31))  # the rendered camera's: 62 deg across 640 px
    text = (examples_dir() / "convoy.toml").read_text()
    calibrated = f"[camera]\nwidth_px = 1280\nheight_px = 960\nfx_px = {2 * fx!r}\ncx_px = 639.5\ncy_px = 479.5\n"
    scenario = tmp_path / "calibrated.toml"
    scenario.write_text(text.replace("[camera]\n", calibrated, 1))
    assert main(["track", str(video), "--scenario", str(scenario)]) == 0
    captured = capsys.readouterr()
    assert (
        "camera intrinsics given for camera.width_px x height_px = 1280x960 scaled by 0.5 to the frames' 640x480"
        in captured.err
    )
    recs = [json.loads(line) for line in captured.out.splitlines() if line.startswith("{")]
    err = np.array(
        [(r["pose"]["range_m"] - tr.range_m) / tr.range_m for r, tr in zip(recs, truths, strict=True) if "pose" in r]
    )
    assert len(err) >= 18 and np.sqrt(np.mean(err**2)) < 0.02
    scenario.write_text(text.replace("[camera]\n", calibrated.replace("960", "720"), 1))
    assert main(["track", str(video), "--scenario", str(scenario)]) == 2
    assert (
        "camera.fx_px and the other intrinsics hold at camera.width_px x height_px = 1280x720"
        in capsys.readouterr().err
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["track", "/nonexistent/video.mp4"], "does not exist"),
        (["track", "__TEXT__"], "cannot read"),
        (["track", "__VIDEO__", "--roi", "1,2,3"], "--roi must be x,y,w,h"),
        (["track", "__VIDEO__", "--roi", "9000,9000,10,10"], "lies outside the"),
        (["track", "__VIDEO__", "--roi", "1,2,30,30", "--out", "out.txt"], "must end in .mp4, .avi"),
        (["track", "__VIDEO__", "--roi", "1,2,30,30", "--out", "__TMP__"], "is a folder"),
        (["track", "__VIDEO__", "--roi", "1,2,30,30", "--out", "/nonexistent/a.mp4"], "does not exist"),
        (["track", "__VIDEO__", "--roi", "1,2,30,30", "--scenario", "nosuch"], "neither a file nor a shipped"),
    ],
)
def test_bad_input_is_named(argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = tmp_path / "notes.mp4"
    text.write_text("not a video")
    video = str(footage_dir() / "bikes.mp4")
    named = {"__TEXT__": str(text), "__VIDEO__": video, "__TMP__": str(tmp_path)}
    with pytest.raises(SystemExit) if "--out" in argv else contextlib.nullcontext() as stop:
        assert main([named.get(a, a) for a in argv]) == 2
    if stop is not None:  # argparse refuses a bad --out before the video is opened
        assert stop.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and "Assertion failed" not in err


def test_a_pipe_or_the_video_itself_as_out_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import os

    fifo = tmp_path / "camera.mp4"
    os.mkfifo(fifo)  # opened, it would block for ever, deaf to Ctrl-C
    assert main(["track", str(fifo), "--roi", "1,1,5,5"]) == 2
    assert "is a named pipe or socket" in capsys.readouterr().err
    video = tmp_path / "v.mp4"
    video.write_bytes((footage_dir() / "bikes.mp4").read_bytes())
    link = tmp_path / "link.mp4"
    link.symlink_to(video)
    for out in (video, link):
        assert main(["track", str(video), "--roi", "1,2,30,30", "--out", str(out)]) == 2
        assert "is the video being tracked" in capsys.readouterr().err
    assert video.read_bytes() == (footage_dir() / "bikes.mp4").read_bytes()  # untouched


def test_a_run_that_fails_on_its_first_frame_writes_no_out_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the writer is opened once frame 0 is tracked: a run refused on it leaves no 257-byte
    # file no player opens
    video = str(footage_dir() / "bikes.mp4")
    out = tmp_path / "annotated.mp4"
    for argv, says in (
        ([], "no banner"),
        (["--roi", "9999,9999,10,10"], "outside"),
    ):
        assert main(["track", video, *argv, "--out", str(out)]) == 2
        assert says in capsys.readouterr().err
        assert not out.exists()
    assert main(["track", video, "--roi", "1,2,30,30", "--max-frames", "2", "--out", str(out)]) == 0
    assert cv2.VideoCapture(str(out)).get(cv2.CAP_PROP_FRAME_COUNT) == 2


def test_an_existing_out_file_is_refused_and_left_alone(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """An earlier recording named as --out is not written over (it was, silently: a 4 MB video
    became the 3 frames tracked); worded as `audit --recover` words it, a dangling link too."""
    video = str(footage_dir() / "bikes.mp4")
    out = tmp_path / "precious.mp4"
    out.write_bytes(b"an earlier recording")
    dangling = tmp_path / "link.mp4"
    dangling.symlink_to(tmp_path / "nowhere.mp4")
    for path in (out, dangling):
        assert main(["track", video, "--roi", "1,2,30,30", "--max-frames", "2", "--out", str(path)]) == 2
        err = capsys.readouterr().err
        assert f"--out {path}: it exists (track writes over nothing: name a new file)" in err, err
        assert "Traceback" not in err
    assert out.read_bytes() == b"an earlier recording"
    assert not (tmp_path / "nowhere.mp4").exists()


def test_a_shipped_scenario_is_taken_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    video = str(footage_dir() / "bikes.mp4")
    assert main(["track", video, "--roi", "1,2,30,30", "--scenario", "vee", "--max-frames", "2"]) == 0
    assert len(records(capsys)) == 2


@pytest.mark.parametrize(("name", "kind"), [("hue-only", "hue"), ("hue", "hue"), ("hs-lbp", "hs-lbp")])
def test_the_tracker_names_are_replays(
    name: str, kind: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """`--tracker` takes the names `lfctl replay` takes (`hue-only` was refused here)."""
    import lfctl.vision.perception as perception

    made: list[str] = []
    real = perception.BannerPerception.from_config

    def spy(*args: object, **kwargs: object) -> perception.BannerPerception:
        made.append(str(kwargs["kind"]))
        return real(*args, **kwargs)

    monkeypatch.setattr(perception.BannerPerception, "from_config", spy)
    seq = load_sequence(footage_dir() / "labels" / "carphone_bowtie.json")
    roi = ",".join(str(v) for v in seq.init_box or ())
    assert main(["track", str(seq.video), "--roi", roi, "--tracker", name, "--max-frames", "3"]) == 0
    assert made == [kind] and len(records(capsys)) == 3


def test_a_camera_that_is_not_there_is_one_line_without_opencvs_own_warnings(tmp_path: Path) -> None:
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENCV_")}
    done = subprocess.run(
        [sys.executable, "-m", "lfctl", "track", "7"], capture_output=True, text=True, env=env, timeout=120
    )
    assert done.returncode == 2
    assert done.stderr == "lfctl: error: cannot open camera 7 with OpenCV (no such camera, or it is busy)\n"


def test_a_frame_rate_below_one_frame_in_100_s_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # --fps 1e-300 was taken, and t_s became 1e+300
    with pytest.raises(SystemExit) as stop:
        main(["track", str(footage_dir() / "bikes.mp4"), "--roi", "1,2,30,30", "--fps", "1e-300"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--fps" in err and "within [0.01, 10000] fps, got 1e-300" in err, err
