"""The videos users have, given to `lfctl track` (and `lfctl follow`): a variable frame rate,
a recorder that dropped frames, a raw stream with no times, a cut file, a text file, a grey
camera, square and non-square pixels, odd sizes; each tracked or refused as it should be,
and a refusal says what the file is. The files are made here with PyAV."""

from __future__ import annotations

import json
import os
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest

from lfctl.cli import main
from lfctl.config import parse_config
from lfctl.errors import ConfigError
from lfctl.video import VideoSource
from lfctl.vision.camera_model import at_frame_size
from lfctl.vision.frames import colourless

SIZE = (160, 120)


def picture(i: int, grey: bool = False, size: tuple[int, int] = SIZE) -> np.ndarray:
    """A grey textured ground and a blue box moving 1 px a frame from (20, 20)."""
    w, h = size
    rng = np.random.default_rng(i)
    img = (120 + rng.integers(-12, 12, (h, w, 1))).repeat(3, axis=2).astype(np.uint8)
    img[20:50, 20 + i : 60 + i] = 200 if grey else (200, 60, 20)
    return img


def write(
    path: Path,
    n: int = 30,
    pts_ms: list[int] | None = None,
    fmt: str | None = None,
    size: tuple[int, int] = SIZE,
    grey: bool = False,
    sar: Fraction | None = None,
) -> Path:
    """An H.264 clip of ``n`` frames at 30 fps (or at the times ``pts_ms``)."""
    with av.open(str(path), "w", format=fmt) as out:
        stream = out.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = size[0], size[1], "yuv420p"
        if sar is not None:
            stream.codec_context.sample_aspect_ratio = sar
        if pts_ms is not None:
            stream.time_base = Fraction(1, 1000)
        for i in range(n):
            frame = av.VideoFrame.from_ndarray(picture(i, grey, size), format="bgr24")
            if pts_ms is not None:
                frame.pts, frame.time_base = pts_ms[i], Fraction(1, 1000)
            out.mux(stream.encode(frame))
        out.mux(stream.encode())
    return path


def track(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, list[dict], str]:
    code = main(["track", *args])
    out, err = capsys.readouterr()
    return code, [json.loads(line) for line in out.splitlines() if line.startswith("{")], err


def test_a_variable_frame_rate_is_tracked_at_each_frames_own_time(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 15 frames, 3 s with none (a recorder paused), 15 more: Matroska stores no frame count,
    # and OpenCV's estimate (duration x rate, 120) called the whole file cut
    pts = [33 * i if i < 15 else 3000 + 33 * i for i in range(30)]
    code, lines, err = track(capsys, str(write(tmp_path / "vfr.mkv", pts_ms=pts)), "--roi", "20,20,40,30")
    assert code == 0, err
    # (the encoder keeps the times at its 1/30 s steps, Matroska in whole milliseconds)
    assert [line["t_s"] for line in lines[13:17]] == [0.433, 0.467, 3.5, 3.533]
    assert len(lines) == 30 and lines[-1]["state"] == "tracking"


def test_a_cut_matroska_file_is_said_from_the_duration_its_head_declares(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    whole = write(tmp_path / "whole.mkv", n=90)
    cut = tmp_path / "cut.mkv"
    data = whole.read_bytes()
    cut.write_bytes(data[: len(data) * 6 // 10])
    code, lines, err = track(capsys, str(cut), "--roi", "20,20,40,30")
    assert code == 2 and 0 < len(lines) < 80
    assert "the 3.00 s it declares: the file is cut or damaged" in err
    code, lines, err = track(capsys, str(whole), "--roi", "20,20,40,30")
    assert code == 0 and len(lines) == 90, err


def test_a_raw_stream_has_no_times_and_is_counted_at_the_rate_given(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    raw = write(tmp_path / "cam.h264", fmt="h264")
    code, lines, err = track(capsys, str(raw), "--roi", "20,20,40,30")
    assert code == 0 and lines[-1]["t_s"] == pytest.approx(29 / 25)  # FFmpeg's 25 fps, said
    assert "frames carry no times (a raw stream): t_s counts them at 25 fps" in err
    code, lines, err = track(capsys, str(raw), "--roi", "20,20,40,30", "--fps", "30")
    assert code == 0 and lines[-1]["t_s"] == pytest.approx(29 / 30, abs=1e-4) and "no times" not in err


@pytest.mark.parametrize(
    ("name", "content", "said"),
    [
        ("notes.txt", b"flight notes\n" * 200, "is not a video: FFmpeg draws it as text"),
        ("00000042.BIN", bytes(range(256)) * 300, "is not a video: FFmpeg draws it as text"),
        ("empty.mp4", b"", "is empty (0 bytes)"),
        ("random.mp4", bytes(np.random.default_rng(1).integers(0, 256, 5000, dtype=np.uint8)), "cannot read"),
    ],
)
def test_what_is_not_a_video_is_refused_saying_what_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, content: bytes, said: str
) -> None:
    (tmp_path / name).write_bytes(content)
    code, lines, err = track(capsys, str(tmp_path / name), "--roi", "20,20,40,30")
    assert code == 2 and not lines and said in err


def test_a_runs_mcap_log_is_refused_as_a_log_and_replay_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a log whose camera frames are H.264 (as lfctl records them): FFmpeg's probe takes the
    # file for a raw H.264 stream and decodes smears from it; it is named for what it is
    from mcap.writer import Writer

    raw = write(tmp_path / "cam.h264", fmt="h264").read_bytes()
    log = tmp_path / "run.mcap"
    with log.open("wb") as f:
        w = Writer(f)
        w.start()
        channel = w.register_channel("/camera", "", w.register_schema("foxglove.CompressedVideo", "jsonschema", b"{}"))
        for k in range(3):
            w.add_message(channel, log_time=k, publish_time=k, data=raw)
        w.finish()
    code, lines, err = track(capsys, str(log), "--roi", "20,20,40,30")
    assert code == 2 and not lines
    assert f"{log} is an MCAP log, not a video: `lfctl replay {log}` shows its camera frames" in err


def test_a_directory_audio_alone_and_a_cameras_number_are_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "clip.mp4").mkdir()
    with pytest.raises(ConfigError, match="is a directory, not a video file"):
        VideoSource(str(tmp_path / "clip.mp4"))
    with av.open(str(tmp_path / "voice.wav"), "w", format="wav") as out:
        stream = out.add_stream("pcm_s16le", rate=8000)
        frame = av.AudioFrame.from_ndarray(np.zeros((1, 800), np.int16), format="s16", layout="mono")
        frame.sample_rate = 8000
        out.mux(stream.encode(frame))
        out.mux(stream.encode())
    with pytest.raises(ConfigError, match=r"voice\.wav has no video stream \(audio only"):
        VideoSource(str(tmp_path / "voice.wav"))
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "97", fmt="mp4")  # a file named as a camera: the number is a camera; the file is ./97
    with pytest.raises(ConfigError, match=r"cannot open camera 97 .*a file named '97' is here: give \./97"):
        VideoSource("97")
    with VideoSource("./97") as video:
        assert video.read() is not None


def test_numbered_image_files_are_told_to_be_made_a_video(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = track(capsys, str(tmp_path / "frame_%04d.png"), "--roi", "1,1,5,5")
    assert code == 2 and "reads videos, not numbered image files" in err


def test_a_grey_camera_is_refused_and_a_grey_or_dim_first_frame_said(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mono = tmp_path / "ir.mkv"  # a monochrome camera's format: grey levels alone
    with av.open(str(mono), "w") as out:
        stream = out.add_stream("ffv1", rate=30)
        stream.width, stream.height, stream.pix_fmt = SIZE[0], SIZE[1], "gray"
        for i in range(3):
            out.mux(stream.encode(av.VideoFrame.from_ndarray(picture(i, grey=True)[:, :, 0], format="gray")))
        out.mux(stream.encode())
    code, lines, err = track(capsys, str(mono), "--roi", "20,20,40,30")
    assert code == 2 and not lines and "has no colour (its pixels are grey levels" in err
    # grey pictures in a colour format (or a colour camera's dim first frame): said, not refused
    code, lines, err = track(capsys, str(write(tmp_path / "grey.mp4", n=3, grey=True)), "--roi", "20,20,40,30")
    assert code == 0 and len(lines) == 3 and "first frame has no colour" in err
    code, lines, err = track(capsys, str(write(tmp_path / "colour.mp4", n=3)), "--roi", "20,20,40,30")
    assert code == 0 and "colour" not in err
    assert not colourless(np.zeros((120, 160, 3), np.uint8))  # a camera starting black says nothing
    assert colourless(picture(0, grey=True)) and not colourless(picture(0))


def test_a_video_ffmpeg_cannot_decode_is_named(tmp_path: Path) -> None:
    clip = write(tmp_path / "c.mkv", n=2).read_bytes()
    assert b"V_MPEG4/ISO/AVC" in clip
    odd = tmp_path / "odd.mkv"
    odd.write_bytes(clip.replace(b"V_MPEG4/ISO/AVC", b"V_NOTHING/KNOWN"))  # a codec id no decoder has
    with pytest.raises(ConfigError, match="its video is in a format FFmpeg has no decoder for"):
        VideoSource(str(odd))


def test_a_whole_matroska_file_with_longer_audio_is_not_called_cut(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # its duration is the longest stream's (the audio's): not the video's
    path = tmp_path / "talk.mkv"
    with av.open(str(path), "w") as out:
        video = out.add_stream("libx264", rate=30)
        video.width, video.height, video.pix_fmt = SIZE[0], SIZE[1], "yuv420p"
        audio = out.add_stream("pcm_s16le", rate=8000)
        for i in range(30):  # 1 s of video
            out.mux(video.encode(av.VideoFrame.from_ndarray(picture(i), format="bgr24")))
        out.mux(video.encode())
        for k in range(30):  # 3 s of audio
            frame = av.AudioFrame.from_ndarray(np.zeros((1, 800), np.int16), format="s16", layout="mono")
            frame.sample_rate, frame.pts = 8000, k * 800
            out.mux(audio.encode(frame))
        out.mux(audio.encode())
    with VideoSource(str(path)) as video_source:
        assert video_source.declared_duration_s is None
    code, lines, err = track(capsys, str(path), "--roi", "20,20,40,30")
    assert code == 0 and len(lines) == 30, err


def test_a_box_partly_off_the_left_edge_is_a_box(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    clip = str(write(tmp_path / "c.mp4", n=3))
    code, lines, err = track(capsys, clip, "--roi", "-10,-10,70,60", "--max-frames", "1")
    assert code == 0 and lines[0]["bbox"] == [0, 0, 60, 50] and "mostly outside" not in err
    code, lines, err = track(capsys, clip, "--roi", "100,100,200,200", "--max-frames", "1")
    assert code == 0 and "lies mostly outside the 160x120 frame" in err
    code, lines, err = track(capsys, clip, "--roi", "", "--max-frames", "1")
    assert code == 2 and "--roi must be x,y,w,h in whole pixels, got ''" in err


def test_an_odd_sized_video_is_written_with_an_edge_not_resized(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    odd = tmp_path / "odd.mkv"  # lossless FFV1 in 4:4:4 takes an odd size (x264's 4:2:0 does not)
    with av.open(str(odd), "w") as out:
        stream = out.add_stream("ffv1", rate=30)
        stream.width, stream.height, stream.pix_fmt = 161, 121, "yuv444p"
        for i in range(4):
            out.mux(stream.encode(av.VideoFrame.from_ndarray(picture(i, size=(161, 121)), format="bgr24")))
        out.mux(stream.encode())
    code, lines, err = track(capsys, str(odd), "--roi", "20,20,40,30", "--out", str(tmp_path / "a.mp4"))
    assert code == 0 and len(lines) == 4 and "is 162x122, the 161x121 frames with a black edge" in err
    out = cv2.VideoCapture(str(tmp_path / "a.mp4"))
    ok, first = out.read()
    out.release()
    assert ok and first.shape[:2] == (122, 162)
    assert first[:, 161].max() < 40 and first[:121, :160].mean() > 60  # the edge black, the picture itself


def test_pixels_that_are_not_square_are_said(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    clip = write(tmp_path / "dv.mp4", n=2, sar=Fraction(64, 45))
    code, _, err = track(capsys, str(clip), "--roi", "20,20,40,30")
    assert code == 0 and "pixels are not square (aspect 64:45)" in err and "not the 228x120 picture" in err
    code, _, err = track(capsys, str(write(tmp_path / "sq.mp4", n=2)), "--roi", "20,20,40,30")
    assert code == 0 and "square" not in err


def test_a_calibration_of_the_picture_turned_a_quarter_is_said_so() -> None:
    cam = parse_config(
        '[[vehicles]]\nname = "l"\nrole = "leader"\n[camera]\nwidth_px = 1280\nheight_px = 720\nfx_px = 900.0\n', "c"
    ).camera
    with pytest.raises(ConfigError, match="the picture turned a quarter"):
        at_frame_size(cam, 720, 1280)
    with pytest.raises(ConfigError, match="another aspect"):
        at_frame_size(cam, 640, 640)


@pytest.mark.parametrize(
    ("keys", "said"),
    [
        (
            "cx_px = 5000.0",
            "camera.cx_px must lie on the picture (below camera.width_px = 640; 0: its centre), got 5000",
        ),
        (
            "cy_px = 481.0",
            "camera.cy_px must lie on the picture (below camera.height_px = 480; 0: its centre), got 481",
        ),
        ("fx_px = 0.0001", "camera.fx_px = 0.0001 px would be a field of view over 170 deg"),
    ],
)
def test_a_calibration_that_is_no_pinholes_is_refused_naming_the_key(keys: str, said: str) -> None:
    with pytest.raises(ConfigError, match=said.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        parse_config(f'[[vehicles]]\nname = "l"\nrole = "leader"\n[camera]\n{keys}\n', "c")


def test_follow_with_a_scenario_without_a_follower_says_what_to_add(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scen = tmp_path / "cam.toml"
    scen.write_text('[[vehicles]]\nname = "leader"\nrole = "leader"\n[camera]\nfx_px = 500.0\n')
    code = main(["follow", "--mavlink", "udpout:127.0.0.1:9", "--camera", os.devnull, "--scenario", str(scen)])
    err = capsys.readouterr().err
    assert code == 2 and "the scenario has no follower" in err and 'role = "follower"' in err


def test_an_mp4_trimmed_without_reencoding_is_not_called_cut(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # ffmpeg -ss .. -c copy keeps the samples before the cut behind an edit list: the file
    # stores 60 samples and shows 42 (it was refused as cut, 42 of the 60 frames it declares)
    whole = write(tmp_path / "whole.mp4", n=60)
    trimmed = tmp_path / "trimmed.mp4"
    with av.open(str(whole)) as inp, av.open(str(trimmed), "w") as out:
        ist = inp.streams.video[0]
        ost = out.add_stream_from_template(ist)
        skip = round(18 / (ist.time_base * 30))  # the first 18 frames' time, in the stream's units
        for packet in inp.demux(ist):
            if packet.dts is None:
                continue
            packet.pts -= skip
            packet.dts -= skip
            packet.stream = ost
            out.mux(packet)
    with av.open(str(trimmed)) as check:
        assert check.streams.video[0].frames == 60  # the samples, kept
    code, lines, err = track(capsys, str(trimmed), "--roi", "38,20,40,30")
    assert code == 0 and len(lines) == 42 and "declares" not in err, err


def test_a_missing_source_is_said_alike_by_track_and_follow(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # lfctl follow --camera and lfctl track take shipped clips by name: both say so
    said = "does not exist (give a file, a camera index or a stream URL; or a shipped clip by name, from "
    nope = str(tmp_path / "nope.mp4")
    code, _lines, err = track(capsys, nope, "--roi", "20,20,40,30")
    assert code == 2 and said in err
    assert main(["follow", "--camera", nope, "--mavlink", "udpout:127.0.0.1:9"]) == 2
    assert said in capsys.readouterr().err
    # the video reader itself names no shipped clips (it reads any source)
    with pytest.raises(ConfigError, match=r"does not exist \(give a file, a camera index or a stream URL\)$"):
        VideoSource(nope)
